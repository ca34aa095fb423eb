//! Building display lists from the world as one team sees it: the MARL screen and minimap,
//! and the annotated VLM screenshot. Fog of war: enemies a team does not see are not drawn,
//! and cells it does not see are darkened.

use crate::draw::{self, Labels};
use crate::font::text_width;
use crate::map_view::MapView;
use crate::scene::{Prim, Rgba, Scene};
use crate::style;
use avacraft_engine::{Team, Unit, UnitId, Vec2, World};
use std::collections::BTreeSet;
use std::sync::Arc;

/// What to annotate on a VLM screenshot beyond the defaults.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VlmOptions {
    /// Units an agent marked as priority: drawn with a highlight ring.
    pub highlights: Vec<UnitId>,
}

/// Where the VLM screenshot puts the map: its transform, the legend panel's width (0: no
/// legend), the grid label scale and the legend's text scale. Tests use it to find cells.
pub fn vlm_layout(world: &World, width: u32, height: u32) -> (MapView, f32, u32, u32) {
    let (margin, panel, label, legend_scale) = vlm_frame(width, height);
    let view = MapView::fit(world, [margin, margin, width as f32 - panel - 4.0, height as f32 - 4.0]);
    (view, panel, label, legend_scale)
}

/// The VLM screenshot's proportions at `width` x `height`: the margin left of and above the
/// map (room for the grid labels), the legend panel's width (0: none), the grid label scale
/// and the legend's text scale.
pub(crate) fn vlm_frame(width: u32, height: u32) -> (f32, f32, u32, u32) {
    let label = ((height as f32 / 1080.0) * 3.0).round().max(1.0) as u32;
    // Room for the widest grid label, "10", left of the map and for a line above it.
    let margin = text_width("10", label) + 8.0;
    // A legend panel on the right when a 22-character line fits there.
    let legend_scale = (label.max(2) - 1).max(1);
    let panel = (width as f32 * 0.22).min(width as f32 - height as f32).max(0.0);
    let panel = if panel >= 22.0 * 8.0 * legend_scale as f32 + 20.0 { panel } else { 0.0 };
    (margin, panel, label, legend_scale)
}

/// Terrain colours, keyed by the terrain itself (held, so its address cannot be reused), and
/// the cell range they cover.
type TerrainColors = (Arc<avacraft_engine::Terrain>, Arc<Vec<Rgba>>, [u32; 4]);

/// Caches what does not change within an episode (terrain colours).
#[derive(Debug, Default)]
pub struct FrameBuilder {
    terrain: Option<TerrainColors>,
    fog: Vec<bool>,
}

impl FrameBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Terrain colours of the cells covering the playable area, top row first, and that
    /// cell range [x0, y0, x1, y1) in map cells.
    fn terrain(&mut self, world: &World) -> (Arc<Vec<Rgba>>, [u32; 4]) {
        let t = world.terrain();
        if let Some((k, colors, range)) = &self.terrain
            && Arc::ptr_eq(k, world.terrain_arc())
        {
            return (Arc::clone(colors), *range);
        }
        let p = t.playable();
        let range =
            [p.left.floor() as u32, p.bottom.floor() as u32, (p.right.ceil() as u32).min(t.width()), (p.top.ceil() as u32).min(t.height())];
        let mut colors = Vec::new();
        for cy in (range[1]..range[3]).rev() {
            for cx in range[0]..range[2] {
                colors.push(style::terrain(t.cell_height((cy * t.width() + cx) as usize)));
            }
        }
        let colors = Arc::new(colors);
        self.terrain = Some((Arc::clone(world.terrain_arc()), Arc::clone(&colors), range));
        (colors, range)
    }

    fn ground(&mut self, world: &World, team: Team, view: &MapView, scene: &mut Scene) {
        let (colors, r) = self.terrain(world);
        let t = world.terrain();
        let rect = {
            let a = view.px(Vec2::new(r[0] as f32, r[3] as f32));
            let b = view.px(Vec2::new(r[2] as f32, r[1] as f32));
            [a[0], a[1], b[0], b[1]]
        };
        let (cols, rows) = (r[2] - r[0], r[3] - r[1]);
        scene.push(Prim::Cells { rect, cols, rows, colors });
        world.cell_visibility(team, &mut self.fog);
        if self.fog.iter().all(|&v| v) {
            return;
        }
        let mut shade = Vec::with_capacity((cols * rows) as usize);
        for cy in (r[1]..r[3]).rev() {
            for cx in r[0]..r[2] {
                let seen = self.fog[(cy * t.width() + cx) as usize];
                shade.push(if seen { Rgba([0, 0, 0, 0]) } else { style::FOG });
            }
        }
        scene.push(Prim::Cells { rect, cols, rows, colors: Arc::new(shade) });
    }

    /// The MARL screen: terrain, fog, units as coloured shapes (no text).
    pub fn screen(&mut self, world: &World, team: Team, width: u32, height: u32) -> Scene {
        let mut scene = Scene::new(width, height, style::BACKGROUND);
        let view = MapView::fit(world, [0.0, 0.0, width as f32, height as f32]);
        self.ground(world, team, &view, &mut scene);
        effects(world, team, &view, &mut scene, 1.0);
        units(world, team, &view, &mut scene, 1.0, None);
        scene
    }

    /// The minimap: the whole playable area, units as dots of at least one pixel.
    pub fn minimap(&mut self, world: &World, team: Team, width: u32, height: u32) -> Scene {
        let mut scene = Scene::new(width, height, style::BACKGROUND);
        let view = MapView::fit(world, [0.0, 0.0, width as f32, height as f32]);
        self.ground(world, team, &view, &mut scene);
        for u in seen_units(world, team) {
            let c = view.px(u.pos);
            let r = (u.radius() * view.scale()).max(0.75);
            scene.push(Prim::Disc { c, r, color: side(u, team) });
        }
        scene
    }

    /// The VLM screenshot: terrain levels, fog, the labelled 10x10 movement grid, units by
    /// shape and side with tag numbers and HP/shield/energy bars, attack and heal lines,
    /// splash, highlight rings, and a legend panel.
    pub fn vlm(&mut self, world: &World, team: Team, width: u32, height: u32, opts: &VlmOptions) -> Scene {
        let mut scene = Scene::new(width, height, style::BACKGROUND);
        let (view, panel, label, legend_scale) = vlm_layout(world, width, height);
        self.ground(world, team, &view, &mut scene);
        draw::grid(world.terrain().playable(), &view, &mut scene, label);
        effects(world, team, &view, &mut scene, label as f32);
        shots(world, team, &view, &mut scene);
        units(world, team, &view, &mut scene, 1.0, Some((label.max(2) - 1).max(1)));
        for id in &opts.highlights {
            if let Some(u) = world.unit(*id).filter(|u| u.alive && world.visible_to(team, u.id)) {
                let r = u.radius() * view.scale() + 6.0 * label as f32;
                scene.push(Prim::Ring { c: view.px(u.pos), r, width: 2.0 * label as f32, color: style::HIGHLIGHT });
            }
        }
        if panel > 0.0 {
            legend(world, team, &mut scene, width as f32 - panel, legend_scale);
        }
        scene
    }
}

fn side(u: &Unit, team: Team) -> Rgba {
    if u.team == team { style::OWN } else { style::ENEMY }
}

/// Living units the team may see, in drawing order: small ground units, then units that
/// stride over them (Colossus), then air units.
fn seen_units(world: &World, team: Team) -> impl Iterator<Item = &Unit> {
    let layer = |l: u8| {
        world.units().iter().filter(move |u| {
            let ul = if u.flying() {
                2
            } else if u.spec().cliff_walk {
                1
            } else {
                0
            };
            u.alive && ul == l && world.visible_to(team, u.id)
        })
    };
    layer(0).chain(layer(1)).chain(layer(2))
}

fn units(world: &World, team: Team, view: &MapView, scene: &mut Scene, min_r: f32, label: Option<u32>) {
    let mut labels = Labels::new(None);
    for u in seen_units(world, team) {
        let c = view.px(u.pos);
        let r = (u.radius() * view.scale()).max(min_r);
        draw::unit_body(u.kind, c, r, u.flying() || u.spec().cliff_walk, side(u, team), scene);
        if let Some(scale) = label {
            let shield = (u.max_shield > 0.0).then(|| u.shield / u.max_shield);
            let energy = (u.spec().energy_max > 0.0).then(|| u.energy / u.spec().energy_max);
            draw::bars(c, r, u.hp_fraction(), shield, energy, scene);
            labels.place(c, r, u.id.tag(), u.kind, scale);
        }
    }
    // Labels last, above every unit.
    labels.draw(scene);
}

/// Area effects the team can see: storms, force fields, Guardian Shields, KD8 charges.
fn effects(world: &World, team: Team, view: &MapView, scene: &mut Scene, line: f32) {
    let tick = world.tick();
    for e in world.area_effects().iter().filter(|e| e.active(tick)) {
        if e.team != team && !world.team_sees_point(team, e.pos) {
            continue;
        }
        draw::effect(e.kind, view.px(e.pos), e.radius * view.scale(), line, scene);
    }
}

/// Attack and heal lines of the last loop, and splash rings, where the team sees both ends.
fn shots(world: &World, team: Team, view: &MapView, scene: &mut Scene) {
    for s in world.shots() {
        let (Some(a), Some(t)) = (world.unit(s.from), world.unit(s.to)) else { continue };
        // Both ends must be seen: a line into fog would give away what stands there.
        let seen = |u: &Unit| u.team == team || world.visible_to(team, u.id);
        if !seen(a) || !seen(t) {
            continue;
        }
        let heal = a.team == t.team;
        let color = if heal { style::HEAL_LINE } else { style::ATTACK_LINE };
        scene.push(Prim::Line { a: view.px(a.pos), b: view.px(s.impact), width: 2.0, color });
        let splash = a.spec().weapons.iter().find_map(|w| match w.splash {
            avacraft_engine::Splash::Radial { zones, .. } => zones.last().map(|z| z.0),
            avacraft_engine::Splash::Line { half_length, .. } => Some(half_length),
            _ => None,
        });
        if let Some(r) = splash.filter(|_| !heal) {
            scene.push(Prim::Ring { c: view.px(s.impact), r: r * view.scale(), width: 2.0, color: style::SPLASH });
        }
    }
}

fn legend(world: &World, team: Team, scene: &mut Scene, x: f32, s: u32) {
    let kinds: BTreeSet<&str> =
        world.units().iter().filter(|u| u.alive && world.visible_to(team, u.id)).map(|u| u.kind.base().name()).collect();
    draw::legend(scene, x, s, team, world.tick(), &[], kinds);
}

/// Draws a team's screen and minimap for in-process agents that read frames (an image-mode
/// network): the scene builder and CPU back end the training's observation source, the
/// simulator node's frame topics and the evaluations use, so every path hands a network
/// the same pixels.
#[derive(Debug, Default)]
pub struct FramePainter {
    frames: FrameBuilder,
    cpu: crate::CpuBackend,
}

impl FramePainter {
    pub fn new() -> Self {
        Self::default()
    }
}

impl avacraft_engine::agent::FrameSource for FramePainter {
    fn draw(&mut self, world: &World, team: Team, need: avacraft_engine::agent::FrameNeed) -> avacraft_engine::agent::TeamFrames {
        let ((sw, sh), (mw, mh)) = (need.screen, need.minimap);
        let screen = self.cpu.render(&self.frames.screen(world, team, sw, sh)).into_raw();
        let minimap = self.cpu.render(&self.frames.minimap(world, team, mw, mh)).into_raw();
        avacraft_engine::agent::TeamFrames { screen, minimap }
    }
}
