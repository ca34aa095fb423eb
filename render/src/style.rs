//! Colours and unit shapes. Shapes differ by unit type so a person or a VLM can tell a
//! Marine from a Marauder without reading labels; colours are from the viewer's side: own
//! units blue, enemies red.

use crate::scene::Rgba;
use avacraft_engine::UnitKind;

pub const OWN: Rgba = Rgba::rgb(40, 120, 255);
pub const ENEMY: Rgba = Rgba::rgb(230, 40, 40);
pub const VOID: Rgba = Rgba::rgb(12, 12, 16);
pub const BACKGROUND: Rgba = Rgba::rgb(20, 20, 26);
pub const FOG: Rgba = Rgba([0, 0, 0, 150]);
pub const GRID: Rgba = Rgba([255, 255, 255, 70]);
pub const LABEL: Rgba = Rgba::rgb(235, 235, 235);
pub const SHADOW: Rgba = Rgba::rgb(0, 0, 0);
pub const HP_OK: Rgba = Rgba::rgb(60, 220, 60);
pub const HP_LOW: Rgba = Rgba::rgb(240, 60, 40);
pub const SHIELD: Rgba = Rgba::rgb(90, 200, 255);
pub const ENERGY: Rgba = Rgba::rgb(200, 90, 255);
pub const BAR_BACK: Rgba = Rgba::rgb(30, 30, 30);
pub const ATTACK_LINE: Rgba = Rgba([255, 230, 60, 200]);
pub const HEAL_LINE: Rgba = Rgba([120, 255, 140, 200]);
pub const SPLASH: Rgba = Rgba([255, 150, 40, 150]);
pub const HIGHLIGHT: Rgba = Rgba::rgb(255, 230, 0);
pub const AIR_OUTLINE: Rgba = Rgba::rgb(250, 250, 250);
pub const STORM: Rgba = Rgba([170, 80, 255, 110]);
pub const STORM_EDGE: Rgba = Rgba([210, 150, 255, 220]);
pub const FORCE_FIELD: Rgba = Rgba([150, 230, 255, 150]);
pub const GUARDIAN: Rgba = Rgba([120, 200, 255, 160]);
pub const CHARGE: Rgba = Rgba([255, 150, 40, 220]);

/// Terrain colour for a height in cliff levels: higher is lighter, ramps in between.
pub fn terrain(height: Option<f32>) -> Rgba {
    match height {
        None => VOID,
        Some(h) => {
            let t = (h.clamp(0.0, 4.0) / 4.0 * 255.0) as u32;
            let lerp = |a: u32, b: u32| (a + (b - a) * t / 255) as u8;
            Rgba::rgb(lerp(40, 200), lerp(52, 190), lerp(38, 150))
        }
    }
}

/// Outline shapes, as unit-circle polygons or a disc.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    Disc,
    Square,
    Diamond,
    Triangle,
    InvTriangle,
    Pentagon,
    Hexagon,
    Octagon,
    Star,
    Cross,
}

pub fn shape(kind: UnitKind) -> Shape {
    use Shape::*;
    use UnitKind as K;
    match kind.base() {
        K::Marine | K::Zergling | K::Sentry => Disc,
        K::Marauder | K::Immortal | K::Ultralisk => Square,
        K::Stalker | K::VikingAssault | K::WarpPrism => Diamond,
        K::Zealot | K::Reaper | K::Phoenix => Triangle,
        K::Banshee | K::Baneling => InvTriangle,
        K::Hellbat | K::Queen | K::Hydralisk => Pentagon,
        K::SiegeTank | K::Colossus => Hexagon,
        K::PhotonCannon | K::SpineCrawler => Octagon,
        K::HighTemplar | K::Archon | K::Ghost => Star,
        K::Medivac => Cross,
        _ => Disc,
    }
}

/// Vertices of a shape of radius `r` around `c` (empty for a disc).
pub fn polygon(s: Shape, c: [f32; 2], r: f32) -> Vec<[f32; 2]> {
    let regular = |n: usize, phase: f32| -> Vec<[f32; 2]> {
        (0..n)
            .map(|k| {
                let a = phase + k as f32 * std::f32::consts::TAU / n as f32;
                [c[0] + r * a.cos(), c[1] - r * a.sin()]
            })
            .collect()
    };
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
    match s {
        Shape::Disc | Shape::Star | Shape::Cross => Vec::new(),
        Shape::Square => regular(4, FRAC_PI_4),
        Shape::Diamond => regular(4, 0.0),
        Shape::Triangle => regular(3, FRAC_PI_2),
        Shape::InvTriangle => regular(3, -FRAC_PI_2),
        Shape::Pentagon => regular(5, FRAC_PI_2),
        Shape::Hexagon => regular(6, 0.0),
        Shape::Octagon => regular(8, std::f32::consts::PI / 8.0),
    }
}

/// A short type code drawn after the tag on screenshots ("12 Mdv"), so shapes shared by two
/// types never leave a reader guessing.
pub fn code(kind: UnitKind) -> &'static str {
    use UnitKind as K;
    match kind {
        K::Marine => "Mar",
        K::Marauder => "Mrd",
        K::Medivac => "Mdv",
        K::SiegeTank => "Tnk",
        K::SiegeTankSieged => "TnkS",
        K::Reaper => "Rpr",
        K::Hellbat => "Hbt",
        K::VikingAssault => "VikA",
        K::VikingFighter => "VikF",
        K::Ghost => "Gst",
        K::Banshee => "Bsh",
        K::Zealot => "Zlt",
        K::Stalker => "Stk",
        K::Sentry => "Snt",
        K::HighTemplar => "HT",
        K::Archon => "Arc",
        K::Immortal => "Imm",
        K::Colossus => "Col",
        K::Phoenix => "Phx",
        K::WarpPrism => "WP",
        K::WarpPrismPhasing => "WPph",
        K::PhotonCannon => "Can",
        K::Zergling => "Zgl",
        K::Baneling => "Bne",
        K::Ultralisk => "Ult",
        K::Queen => "Qn",
        K::SpineCrawler => "Spn",
        K::Hydralisk => "Hyd",
    }
}
