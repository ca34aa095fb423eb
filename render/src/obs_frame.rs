//! The VLM screenshot drawn from what an agent observes ([`GroupObs`]) and the map (a player
//! knows the map: the scenario's [`Terrain`]), never from the `World`, so one agent sees the
//! same picture in-process and deployed behind the wire. It frames a [`Camera`] view, as
//! StarCraft II's camera does, with the 10x10 movement grid laid over that view.
//!
//! Geometry: the camera's rectangle is fitted into the layout's map area
//! ([`ObsLayout::map`]) with one scale on both axes, centred ([`ObsLayout::view`]); the grid
//! is drawn over the camera's rectangle with the engine's cell formula, so cell (c, r) is
//! drawn exactly around [`Camera::cell_center`]`(c, r)`. A camera built for the map area's
//! pixel size ([`ObsLayout::map_px`], [`ObsLayout::camera`]) fills it; one of another
//! aspect (the whole image's, say) is letterboxed inside it. Anything outside the view is
//! cut off at its edge.

use crate::camera::Camera;
use crate::draw::{self, Labels};
use crate::frame::{FrameBuilder, VlmOptions, vlm_frame};
use crate::map_view::MapView;
use crate::scene::{Prim, Rgba, Scene};
use crate::style;
use avacraft_engine::agent::{GroupObs, view};
use avacraft_engine::{OrderInfo, Rect, Terrain, UnitFlags, UnitInfo, Vec2};
use std::collections::BTreeSet;
use std::sync::Arc;

/// Where the observation screenshot puts the map, the grid labels and the legend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObsLayout {
    /// The pixel rectangle [x0, y0, x1, y1] (whole pixels) the camera's view is fitted into:
    /// the image minus a margin for the grid labels (top, left), the legend panel (right)
    /// and 4 pixels (right, bottom).
    pub map: [f32; 4],
    /// The legend panel's width at the right edge (0: no legend, when it would not fit).
    pub panel: f32,
    /// Text scale of the grid labels (8 * scale pixels tall).
    pub label: u32,
    /// Text scale of the legend.
    pub legend_scale: u32,
}

/// The layout of a `width` x `height` observation screenshot: the same margins, label sizes
/// and legend panel as the whole-map [`FrameBuilder::vlm`].
pub fn vlm_obs_layout(width: u32, height: u32) -> ObsLayout {
    let (margin, panel, label, legend_scale) = vlm_frame(width, height);
    // Whole pixels, so a camera of `map_px()` fills the area exactly.
    let x1 = (width as f32 - panel - 4.0).floor().max(margin + 1.0);
    let y1 = (height as f32 - 4.0).floor().max(margin + 1.0);
    ObsLayout { map: [margin, margin, x1, y1], panel, label, legend_scale }
}

impl ObsLayout {
    /// The map area's size in pixels: what to give [`Camera::new`] or [`Camera::framing`]
    /// for a view that fills it.
    pub fn map_px(&self) -> (u32, u32) {
        ((self.map[2] - self.map[0]) as u32, (self.map[3] - self.map[1]) as u32)
    }

    /// [`Camera::framing`] for this layout's map area: `width` world units across (e.g.
    /// [`Camera::DEFAULT_WIDTH`]) around `points` (the team's units), inside `playable`.
    pub fn camera(&self, points: impl IntoIterator<Item = Vec2>, width: f32, playable: Rect) -> Camera {
        let (w, h) = self.map_px();
        Camera::framing(points, width, w, h, playable)
    }

    /// World-to-pixel transform of `camera`'s view in the map area.
    pub fn view(&self, camera: &Camera) -> MapView {
        MapView::fit_rect(camera.rect(), self.map)
    }
}

impl FrameBuilder {
    /// The VLM screenshot of `camera`'s view, from an observation only: terrain levels; fog
    /// (cells the team's units in `obs` do not see, by the engine's rule
    /// [`view::sees_point`], darkened); the 10x10 grid over the view with labels 1..10;
    /// area effects; attack (yellow) and heal (green) lines of units whose target is in the
    /// observation; units by shape and side (own blue, enemy red), white-outlined when in
    /// the air, with tag and type labels and HP/shield/energy bars; highlight rings for
    /// `opts.highlights`; arrows at the view's edge pointing at units outside it; and the
    /// legend panel when it fits. See the module docs for the geometry.
    pub fn vlm_obs(&mut self, terrain: &Terrain, obs: &GroupObs, camera: &Camera, width: u32, height: u32, opts: &VlmOptions) -> Scene {
        let layout = vlm_obs_layout(width, height);
        let v = layout.view(camera);
        let rect = camera.rect();
        let mut scene = Scene::new(width, height, style::BACKGROUND);
        ground(terrain, obs, rect, &v, &mut scene);
        draw::grid_lines(rect, &v, &mut scene);
        for e in &obs.effects {
            let c = Vec2::new(e.x, e.y);
            if touches(rect, c, e.radius) {
                draw::effect(e.kind, v.px(c), e.radius * v.scale(), layout.label as f32, &mut scene);
            }
        }
        intents(obs, rect, &v, &mut scene);
        let tl = v.px(Vec2::new(rect.left, rect.top));
        let br = v.px(Vec2::new(rect.right, rect.bottom));
        units(obs, camera, &v, [tl[0], tl[1], br[0], br[1]], (layout.label.max(2) - 1).max(1), &mut scene);
        for id in &opts.highlights {
            if let Some(u) = obs.unit(*id).filter(|u| touches(rect, view::pos(u), view::radius(u))) {
                let r = view::radius(u) * v.scale() + 6.0 * layout.label as f32;
                scene.push(Prim::Ring { c: v.px(view::pos(u)), r, width: 2.0 * layout.label as f32, color: style::HIGHLIGHT });
            }
        }
        let arrows = edge_arrows(obs, camera, &v, 5.0 * layout.label as f32, &mut scene);
        // Cut off what spills out of the view: background over everything around it (whole
        // pixels, keeping the grid's outer lines, which run through the edge pixels).
        let (w, h) = (width as f32, height as f32);
        let (x0, y0, x1, y1) = (tl[0].floor(), tl[1].floor(), br[0].floor() + 1.0, br[1].floor() + 1.0);
        for r in [[0.0, 0.0, w, y0], [0.0, y1, w, h], [0.0, y0, x0, y1], [x1, y0, w, y1]] {
            scene.push(Prim::Rect { rect: r, color: style::BACKGROUND });
        }
        draw::grid_labels(rect, &v, &mut scene, layout.label);
        if layout.panel > 0.0 {
            let kinds: BTreeSet<&str> = obs.units.iter().map(|u| u.kind.base().name()).collect();
            let mut extra = vec![format!("view {:.0} x {:.0} units", camera.width(), camera.height())];
            if arrows > 0 {
                extra.push("arrows: units off view".into());
            }
            draw::legend(&mut scene, width as f32 - layout.panel, layout.legend_scale, obs.team, obs.game_loop, &extra, kinds);
        }
        scene
    }
}

/// Whether a disc of radius `r` around `c` reaches into `rect` (false for a centre that is
/// not finite, so malformed positions are never drawn).
fn touches(rect: Rect, c: Vec2, r: f32) -> bool {
    let r = if r.is_finite() { r.max(0.0) } else { 0.0 };
    c.is_finite() && c.x + r >= rect.left && c.x - r <= rect.right && c.y + r >= rect.bottom && c.y - r <= rect.top
}

/// `v` if finite, else 0: observations may come over the wire, and a NaN must not reach
/// the rasteriser.
fn finite(v: f32) -> f32 {
    if v.is_finite() { v } else { 0.0 }
}

fn side(u: &UnitInfo) -> Rgba {
    if u.own { style::OWN } else { style::ENEMY }
}

/// Terrain of the playable cells in view, then fog over those the team does not see.
fn ground(terrain: &Terrain, obs: &GroupObs, rect: Rect, v: &MapView, scene: &mut Scene) {
    let p = terrain.playable();
    // Float-to-int `as` saturates (negative to 0), so a view off the map gives an empty range.
    let span = |lo: f32, hi: f32, n: u32| (lo.floor().max(0.0) as u32, (hi.ceil().max(0.0) as u32).min(n));
    let (x0, x1) = span(p.left.max(rect.left), p.right.min(rect.right), terrain.width());
    let (y0, y1) = span(p.bottom.max(rect.bottom), p.top.min(rect.top), terrain.height());
    if x1 <= x0 || y1 <= y0 {
        return;
    }
    let a = v.px(Vec2::new(x0 as f32, y1 as f32));
    let b = v.px(Vec2::new(x1 as f32, y0 as f32));
    let (cols, rows) = (x1 - x0, y1 - y0);
    let idx = |cx: u32, cy: u32| (cy * terrain.width() + cx) as usize;
    let mut colors = Vec::with_capacity((cols * rows) as usize);
    let mut shade = Vec::with_capacity((cols * rows) as usize);
    let own: Vec<&UnitInfo> = obs.own().collect();
    for cy in (y0..y1).rev() {
        for cx in x0..x1 {
            colors.push(style::terrain(terrain.cell_height(idx(cx, cy))));
            let centre = Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5);
            let seen = view::sees_point(terrain, own.iter().copied(), centre);
            shade.push(if seen { Rgba([0, 0, 0, 0]) } else { style::FOG });
        }
    }
    let rect = [a[0], a[1], b[0], b[1]];
    scene.push(Prim::Cells { rect, cols, rows, colors: Arc::new(colors) });
    if shade.contains(&style::FOG) {
        scene.push(Prim::Cells { rect, cols, rows, colors: Arc::new(shade) });
    }
}

/// Lines from units with an attack order to their targets, when both are in the
/// observation: heal lines (green) to a unit of the same side, attack lines (yellow) else.
fn intents(obs: &GroupObs, rect: Rect, v: &MapView, scene: &mut Scene) {
    for u in &obs.units {
        let OrderInfo::Attack { target } = u.order else { continue };
        let Some(t) = obs.unit(target) else { continue };
        let (a, b) = (view::pos(u), view::pos(t));
        // Drawn when its bounding box meets the view; the mask cuts the rest.
        let bbox = Rect { left: a.x.min(b.x), right: a.x.max(b.x), bottom: a.y.min(b.y), top: a.y.max(b.y) };
        let meets = bbox.left <= rect.right && bbox.right >= rect.left && bbox.bottom <= rect.top && bbox.top >= rect.bottom;
        if !(a.is_finite() && b.is_finite() && meets) {
            continue;
        }
        let color = if u.own == t.own { style::HEAL_LINE } else { style::ATTACK_LINE };
        scene.push(Prim::Line { a: v.px(a), b: v.px(b), width: 2.0, color });
    }
}

/// Units reaching into the view, in drawing order (ground, Colossi, air; tag order within
/// a layer, as the world-based frames draw them); bars and labels for those whose centre is
/// in view, labels kept inside `bounds` (the view in pixels).
fn units(obs: &GroupObs, camera: &Camera, v: &MapView, bounds: [f32; 4], label: u32, scene: &mut Scene) {
    let layer = |u: &UnitInfo| {
        if view::flying(u) {
            2
        } else if u.flags.contains(UnitFlags::CLIFF_WALKER) {
            1
        } else {
            0
        }
    };
    let outline = |u: &UnitInfo| view::flying(u) || u.flags.contains(UnitFlags::CLIFF_WALKER);
    let rect = camera.rect();
    let mut shown: Vec<&UnitInfo> = obs.units.iter().filter(|u| touches(rect, view::pos(u), view::radius(u) * 1.2)).collect();
    shown.sort_by_key(|u| (layer(u), u.tag));
    let mut labels = Labels::new(Some(bounds));
    for u in &shown {
        // The body and, above it, the bars (see `draw::bars` for their size).
        let (c, r) = (v.px(view::pos(u)), (view::radius(u) * v.scale()).max(1.0));
        let n = 1.0 + (u.max_shield > 0.0) as u8 as f32 + (u.max_energy > 0.0) as u8 as f32;
        let (half, h) = ((1.2 * r).max(6.0).round(), (r * 0.3).clamp(2.0, 7.0).round());
        labels.avoid([c[0] - r.max(half), c[1] - r - 3.0 - n * (h + 1.0), c[0] + r.max(half), c[1] + r]);
    }
    for u in shown {
        let c = v.px(view::pos(u));
        let r = (view::radius(u) * v.scale()).max(1.0);
        draw::unit_body(u.kind, c, r, outline(u), side(u), scene);
        if camera.contains(view::pos(u)) {
            let frac = |a: f32, max: f32| (max > 0.0).then(|| finite(a / max));
            draw::bars(c, r, finite(view::hp_fraction(u)), frac(u.shield, u.max_shield), frac(u.energy, u.max_energy), scene);
            labels.place(c, r, u.tag.tag(), u.kind, label);
        }
    }
    labels.draw(scene);
}

/// For each unit outside the view, a small arrow of its side's colour just inside the
/// view's edge, pointing at it, so the agent knows where the rest of the battle is. Returns
/// how many were drawn.
fn edge_arrows(obs: &GroupObs, camera: &Camera, v: &MapView, size: f32, scene: &mut Scene) -> usize {
    let rect = camera.rect();
    let c = v.px(camera.center());
    // Half extents of the view in pixels, less room for the arrow.
    let (hx, hy) = (camera.width() * 0.5 * v.scale() - size - 2.0, camera.height() * 0.5 * v.scale() - size - 2.0);
    if hx <= 0.0 || hy <= 0.0 {
        return 0;
    }
    let mut n = 0;
    for u in obs.units.iter().filter(|u| view::pos(u).is_finite() && !touches(rect, view::pos(u), view::radius(u) * 1.2)) {
        let t = v.px(view::pos(u));
        let (dx, dy) = (t[0] - c[0], t[1] - c[1]);
        let len = (dx * dx + dy * dy).sqrt();
        if len < 1e-3 {
            continue;
        }
        // Where the ray towards the unit leaves the inset view.
        let k = (hx / dx.abs().max(1e-6)).min(hy / dy.abs().max(1e-6));
        let (ux, uy) = (dx / len, dy / len);
        let tip = [c[0] + dx * k + ux * size, c[1] + dy * k + uy * size];
        let base = [tip[0] - ux * size * 1.6, tip[1] - uy * size * 1.6];
        let (px, py) = (-uy * size * 0.7, ux * size * 0.7);
        let tri = |g: f32| {
            vec![
                [tip[0] + ux * g, tip[1] + uy * g],
                [base[0] + px * (1.0 + g / size), base[1] + py * (1.0 + g / size)],
                [base[0] - px * (1.0 + g / size), base[1] - py * (1.0 + g / size)],
            ]
        };
        scene.push(Prim::Polygon { points: tri(1.5), color: style::SHADOW });
        scene.push(Prim::Polygon { points: tri(0.0), color: side(u) });
        n += 1;
    }
    n
}
