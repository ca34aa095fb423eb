//! The VLM screenshot's camera: like StarCraft II's, it shows a window of the map a fixed
//! number of world units wide (24 by default) around the team's units, rather than the whole
//! map, so units keep a readable size on big maps. The 10x10 movement grid of the VLM
//! agents' grid moves is laid over this view, and [`Camera::cell_center`] maps a grid cell
//! back to the map with the engine's own formula ([`grid_cell_center`] over the view's
//! rectangle), so what is drawn and where a move goes agree.

use avacraft_engine::{GRID, Rect, Vec2, grid_cell_center, grid_cell_of};

/// A window of the map: its centre and size in world units (y up, as on the map).
///
/// Sizes are kept usable whatever the input, without panicking: a width that is not finite
/// or not positive is replaced by [`Camera::DEFAULT_WIDTH`]; widths and heights are clamped
/// to [`Camera::MIN_EXTENT`]..=[`Camera::MAX_EXTENT`]; a pixel size of 0 counts as 1; a
/// centre coordinate that is not finite becomes 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    center: Vec2,
    width: f32,
    height: f32,
}

impl Camera {
    /// World units across StarCraft II's default camera.
    pub const DEFAULT_WIDTH: f32 = 24.0;
    /// The smallest width or height kept (a tenth of a map cell: grid cells stay far above
    /// float precision at any map coordinate).
    pub const MIN_EXTENT: f32 = 0.1;
    /// The largest width or height kept (far beyond any map).
    pub const MAX_EXTENT: f32 = 100_000.0;

    /// A view `width` world units wide centred on `center`, as tall as the pixel area
    /// `px_w` x `px_h` it is drawn into asks for: `height = width * px_h / px_w`.
    pub fn new(center: Vec2, width: f32, px_w: u32, px_h: u32) -> Camera {
        let width = if width.is_finite() && width > 0.0 { width } else { Self::DEFAULT_WIDTH };
        let width = width.clamp(Self::MIN_EXTENT, Self::MAX_EXTENT);
        // In f64: u32 pixel counts are exact there, and the ratio of extreme sizes cannot
        // overflow before the clamp.
        let height = (width as f64 * px_h.max(1) as f64 / px_w.max(1) as f64) as f32;
        let height = height.clamp(Self::MIN_EXTENT, Self::MAX_EXTENT);
        let finite = |v: f32| if v.is_finite() { v } else { 0.0 };
        Camera { center: Vec2::new(finite(center.x), finite(center.y)), width, height }
    }

    /// The view a player's camera would show: centred on the centroid of `points` (the
    /// team's living units; points that are not finite are skipped), then shifted so the
    /// view stays inside `playable` along each axis where it fits; along an axis where the
    /// playable area is narrower than the view, centred on the playable area. With no
    /// points, centred on the playable area.
    pub fn framing(points: impl IntoIterator<Item = Vec2>, width: f32, px_w: u32, px_h: u32, playable: Rect) -> Camera {
        let (mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0u32);
        for p in points.into_iter().filter(|p| p.is_finite()) {
            sx += p.x as f64;
            sy += p.y as f64;
            n += 1;
        }
        let valid = [playable.left, playable.right, playable.bottom, playable.top].iter().all(|v| v.is_finite())
            && playable.left <= playable.right
            && playable.bottom <= playable.top;
        let centroid = if n > 0 {
            Vec2::new((sx / n as f64) as f32, (sy / n as f64) as f32)
        } else if valid {
            playable.center()
        } else {
            Vec2::ZERO
        };
        let mut cam = Camera::new(centroid, width, px_w, px_h);
        if valid {
            cam.center = Vec2::new(
                fit_axis(cam.center.x, cam.width * 0.5, playable.left, playable.right),
                fit_axis(cam.center.y, cam.height * 0.5, playable.bottom, playable.top),
            );
        }
        cam
    }

    pub fn center(&self) -> Vec2 {
        self.center
    }
    /// World units across.
    pub fn width(&self) -> f32 {
        self.width
    }
    /// World units from bottom to top.
    pub fn height(&self) -> f32 {
        self.height
    }

    /// The map rectangle seen (y up: `top` > `bottom`).
    pub fn rect(&self) -> Rect {
        let (hw, hh) = (self.width * 0.5, self.height * 0.5);
        Rect { left: self.center.x - hw, right: self.center.x + hw, bottom: self.center.y - hh, top: self.center.y + hh }
    }

    /// Whether `p` is in view (edges included).
    pub fn contains(&self, p: Vec2) -> bool {
        self.rect().contains(p)
    }

    /// Centre of grid cell (`col`, `row`), both 1..=10, (1, 1) top left: the engine's
    /// [`grid_cell_center`] over [`Camera::rect`]. `None` outside 1..=10.
    pub fn cell_center(&self, col: u8, row: u8) -> Option<Vec2> {
        let ok = |k: u8| (1..=GRID).contains(&k);
        (ok(col) && ok(row)).then(|| grid_cell_center(self.rect(), col, row))
    }

    /// The grid cell (`col`, `row`) containing `p` (the engine's [`grid_cell_of`] over
    /// [`Camera::rect`]; points on the right or bottom edge belong to the last cell), `None`
    /// when `p` is not in view.
    pub fn cell_of(&self, p: Vec2) -> Option<(u8, u8)> {
        self.contains(p).then(|| grid_cell_of(self.rect(), p))
    }
}

/// The centre `c` of a view `2 * half` wide moved the least to keep the view within
/// [`lo`, `hi`], or the middle of that range when the view is wider than it.
fn fit_axis(c: f32, half: f32, lo: f32, hi: f32) -> f32 {
    let (a, b) = (lo + half, hi - half);
    // Compared rather than trusting `hi - lo >= 2 * half`: rounding may put `a` a hair above
    // `b`, and `clamp` panics when its bounds cross.
    if a <= b { c.clamp(a, b) } else { (lo + hi) * 0.5 }
}
