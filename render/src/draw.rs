//! Drawing helpers shared by the world-based frames (`frame.rs`) and the observation-based
//! VLM screenshot (`obs_frame.rs`). They take plain data (a unit type, a centre and radius in
//! pixels, fractions), not a `World` or a `UnitInfo`, so both sources draw units, bars,
//! labels, effects, the grid and the legend exactly alike.

use crate::font::text_width;
use crate::map_view::MapView;
use crate::scene::{Prim, Rgba, Scene};
use crate::style::{self, Shape};
use avacraft_engine::{EffectKind, GRID, Rect, Team, UnitKind, Vec2, grid_cell_center, loops_to_seconds};
use std::collections::BTreeSet;

pub(crate) fn shape_prims(s: Shape, c: [f32; 2], r: f32, color: Rgba, scene: &mut Scene) {
    match s {
        Shape::Disc => scene.push(Prim::Disc { c, r, color }),
        Shape::Star => {
            scene.push(Prim::Polygon { points: style::polygon(Shape::Triangle, c, r), color });
            scene.push(Prim::Polygon { points: style::polygon(Shape::InvTriangle, c, r), color });
        }
        Shape::Cross => {
            let (a, b) = (r, r * 0.38);
            scene.push(Prim::Rect { rect: [c[0] - a, c[1] - b, c[0] + a, c[1] + b], color });
            scene.push(Prim::Rect { rect: [c[0] - b, c[1] - a, c[0] + b, c[1] + a], color });
        }
        _ => scene.push(Prim::Polygon { points: style::polygon(s, c, r), color }),
    }
}

/// A unit's body: its type's shape in its side's colour, with a white outline for air units
/// and Colossi (`outline`), which sets them apart from the ground layer.
pub(crate) fn unit_body(kind: UnitKind, c: [f32; 2], r: f32, outline: bool, color: Rgba, scene: &mut Scene) {
    let s = style::shape(kind);
    if outline {
        shape_prims(s, c, r + (r * 0.15).max(1.0), style::AIR_OUTLINE, scene);
    }
    shape_prims(s, c, r, color, scene);
}

/// HP, shield and energy bars above a unit drawn at `c` with radius `r`; `shield` and
/// `energy` are `None` for units without them. Fractions are clamped to 0..=1.
pub(crate) fn bars(c: [f32; 2], r: f32, hp: f32, shield: Option<f32>, energy: Option<f32>, scene: &mut Scene) {
    let w = ((1.2 * r).max(6.0).round()) * 2.0;
    let h = (r * 0.3).clamp(2.0, 7.0).round();
    let c = [c[0].round(), c[1].round()];
    let mut y = c[1] - r.round() - 3.0 - h;
    let mut bar = |frac: f32, color: Rgba, y: f32| {
        scene.push(Prim::Rect { rect: [c[0] - w * 0.5, y, c[0] + w * 0.5, y + h], color: style::BAR_BACK });
        scene.push(Prim::Rect { rect: [c[0] - w * 0.5, y, (c[0] - w * 0.5 + w * frac.clamp(0.0, 1.0)).round(), y + h], color });
    };
    bar(hp, if hp > 0.35 { style::HP_OK } else { style::HP_LOW }, y);
    if let Some(s) = shield {
        y -= h + 1.0;
        bar(s, style::SHIELD, y);
    }
    if let Some(e) = energy {
        y -= h + 1.0;
        bar(e, style::ENERGY, y);
    }
}

pub(crate) fn outlined_text(scene: &mut Scene, pos: [f32; 2], scale: u32, text: &str, color: Rgba) {
    let s = scale as f32;
    let pos = [pos[0].round(), pos[1].round()];
    for (dx, dy) in [(-s, 0.0), (s, 0.0), (0.0, -s), (0.0, s)] {
        scene.push(Prim::Text { pos: [pos[0] + dx, pos[1] + dy], scale, text: text.to_owned(), color: style::SHADOW });
    }
    scene.push(Prim::Text { pos, scale, text: text.to_owned(), color });
}

/// Unit labels ("tag type"), placed greedily so they do not cover each other, and drawn
/// last, above every unit.
#[derive(Debug, Default)]
pub(crate) struct Labels {
    taken: Vec<[f32; 4]>,
    labels: Vec<([f32; 2], u32, String)>,
    /// Pixel rectangle a label must lie in (`None`: anywhere); a label outside it would be
    /// cut off by the view's edge.
    bounds: Option<[f32; 4]>,
    /// Boxes (unit bodies) a label should rather not cover.
    avoid: Vec<[f32; 4]>,
}

impl Labels {
    pub(crate) fn new(bounds: Option<[f32; 4]>) -> Self {
        Self { bounds, ..Self::default() }
    }

    /// Asks labels to keep off the box [x0, y0, x1, y1] (a unit's body) where they can: a
    /// spot clear of such boxes is preferred over the next spot in the usual order.
    pub(crate) fn avoid(&mut self, b: [f32; 4]) {
        self.avoid.push(b);
    }

    /// Places the label of the unit `tag` of type `kind`, drawn at `c` with radius `r`.
    pub(crate) fn place(&mut self, c: [f32; 2], r: f32, tag: u32, kind: UnitKind, scale: u32) {
        let text = format!("{tag} {}", style::code(kind));
        let (tw, th) = (text_width(&text, scale), 8.0 * scale as f32);
        // Greedy placement: below, right, left, above, then further out; the first spot not
        // covering an earlier label wins, so crowds stay readable.
        let gap = 3.0;
        let spots = [
            [c[0] - tw * 0.5, c[1] + r + gap],
            [c[0] + r + gap, c[1] - th * 0.5],
            [c[0] - r - gap - tw, c[1] - th * 0.5],
            [c[0] - tw * 0.5, c[1] - r - gap - th - 3.0 * th * 0.5],
            [c[0] - tw * 0.5, c[1] + r + gap + th + 2.0],
            [c[0] + r + gap, c[1] + th],
            [c[0] - r - gap - tw, c[1] + th],
        ];
        let free = |p: [f32; 2]| {
            let b = [p[0] - 1.0, p[1] - 1.0, p[0] + tw + 1.0, p[1] + th + 1.0];
            !self.avoid.iter().any(|t| overlap(&b, t))
        };
        let spot = spots.iter().copied().find(|&p| self.clear(p, tw, th) && free(p));
        let (pos, text, tw) = match spot.or_else(|| spots.iter().copied().find(|&p| self.clear(p, tw, th))) {
            Some(p) => (p, text, tw),
            None => {
                // Crowded: the bare tag on the unit or just below it if that is clear; else no
                // label at all, rather than one far from its unit or merged with another into a
                // number that is not there (the unit list still names every unit).
                let bare = tag.to_string();
                let w = text_width(&bare, scale);
                let near = [[c[0] - w * 0.5, c[1] - th * 0.5], [c[0] - w * 0.5, c[1] + r]];
                match near.into_iter().find(|&p| self.clear(p, w, th)) {
                    Some(p) => (p, bare, w),
                    None => return,
                }
            }
        };
        self.taken.push([pos[0], pos[1], pos[0] + tw, pos[1] + th]);
        self.labels.push((pos, scale, text));
    }

    /// Whether a `w` x `h` label at `p` covers no earlier label and lies within the bounds.
    fn clear(&self, p: [f32; 2], w: f32, h: f32) -> bool {
        let b = [p[0] - 1.0, p[1] - 1.0, p[0] + w + 1.0, p[1] + h + 1.0];
        let inside = self.bounds.is_none_or(|a| p[0] >= a[0] && p[1] >= a[1] && p[0] + w <= a[2] && p[1] + h <= a[3]);
        inside && !self.taken.iter().any(|t| overlap(&b, t))
    }

    pub(crate) fn draw(self, scene: &mut Scene) {
        for (pos, scale, text) in self.labels {
            outlined_text(scene, pos, scale, &text, style::LABEL);
        }
    }
}

fn overlap(a: &[f32; 4], b: &[f32; 4]) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// An area effect of `kind` drawn at `c` with radius `r` pixels; `line` scales ring widths.
pub(crate) fn effect(kind: EffectKind, c: [f32; 2], r: f32, line: f32, scene: &mut Scene) {
    match kind {
        EffectKind::PsionicStorm => {
            scene.push(Prim::Disc { c, r, color: style::STORM });
            scene.push(Prim::Ring { c, r, width: 2.0 * line, color: style::STORM_EDGE });
        }
        EffectKind::ForceField => scene.push(Prim::Disc { c, r, color: style::FORCE_FIELD }),
        EffectKind::GuardianShield => scene.push(Prim::Ring { c, r, width: 1.5 * line, color: style::GUARDIAN }),
        EffectKind::Kd8Charge => scene.push(Prim::Ring { c, r, width: line, color: style::CHARGE }),
    }
}

/// The 10x10 grid of the grid-move action over `area` (the playable area, or a camera's
/// view), labelled 1..10 along the top (x) and left (y), exactly where `grid_cell_center`
/// puts each cell of that area.
pub(crate) fn grid(area: Rect, view: &MapView, scene: &mut Scene, label: u32) {
    grid_lines(area, view, scene);
    grid_labels(area, view, scene, label);
}

/// The grid's lines (see [`grid`]).
pub(crate) fn grid_lines(area: Rect, view: &MapView, scene: &mut Scene) {
    let tl = view.px(Vec2::new(area.left, area.top));
    let br = view.px(Vec2::new(area.right, area.bottom));
    for k in 0..=GRID {
        let f = k as f32 / GRID as f32;
        // One-pixel lines run through pixel centres, so no back end has to break a tie.
        let x = (tl[0] + (br[0] - tl[0]) * f).floor() + 0.5;
        let y = (tl[1] + (br[1] - tl[1]) * f).floor() + 0.5;
        scene.push(Prim::Line { a: [x, tl[1]], b: [x, br[1]], width: 1.0, color: style::GRID });
        scene.push(Prim::Line { a: [tl[0], y], b: [br[0], y], width: 1.0, color: style::GRID });
    }
}

/// The grid's labels 1..10 above and left of it (see [`grid`]).
pub(crate) fn grid_labels(area: Rect, view: &MapView, scene: &mut Scene, label: u32) {
    let tl = view.px(Vec2::new(area.left, area.top));
    for k in 1..=GRID {
        let c = view.px(grid_cell_center(area, k, k));
        let t = k.to_string();
        let tw = text_width(&t, label);
        let th = 8.0 * label as f32;
        let (a, b) = ([c[0] - tw * 0.5, tl[1] - th - 4.0], [tl[0] - tw - 4.0, c[1] - th * 0.5]);
        scene.push(Prim::Text { pos: [a[0].round(), a[1].round()], scale: label, text: t.clone(), color: style::LABEL });
        scene.push(Prim::Text { pos: [b[0].round(), b[1].round()], scale: label, text: t, color: style::LABEL });
    }
}

/// The legend panel at `x`, text scale `s`: the team and game loop, `extra` lines (the
/// camera's view), what colours and marks mean, and the shape of each unit type in `kinds`
/// (base type names).
pub(crate) fn legend(scene: &mut Scene, x: f32, s: u32, team: Team, tick: u32, extra: &[String], kinds: BTreeSet<&str>) {
    let line = 8.0 * s as f32 + 8.0;
    let mut y = 12.0;
    let text = |scene: &mut Scene, t: String, color: Rgba, y: &mut f32| {
        scene.push(Prim::Text { pos: [(x + 10.0).round(), y.round()], scale: s, text: t, color });
        *y += line;
    };
    text(scene, format!("{team}, loop {tick}"), style::LABEL, &mut y);
    text(scene, format!("game time {:.1} s", loops_to_seconds(tick)), style::LABEL, &mut y);
    for e in extra {
        text(scene, e.clone(), style::LABEL, &mut y);
    }
    text(scene, "blue: yours".into(), style::OWN, &mut y);
    text(scene, "red: enemy".into(), style::ENEMY, &mut y);
    text(scene, "dark: fog of war".into(), style::LABEL, &mut y);
    text(scene, "outline: air/Colossus".into(), style::LABEL, &mut y);
    text(scene, "label: tag + type".into(), style::LABEL, &mut y);
    text(scene, "bars: HP/shield/energy".into(), style::LABEL, &mut y);
    y += line * 0.5;
    for k in kinds {
        let kind = k.parse().unwrap_or(UnitKind::Marine);
        let r = 4.0 * s as f32;
        shape_prims(style::shape(kind), [x + 10.0 + r, y + r], r, style::LABEL, scene);
        text(scene, format!("   {} {k}", style::code(kind)), style::LABEL, &mut y);
    }
}
