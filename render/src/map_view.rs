//! The map-to-pixel transform. Kept out of `frame.rs`: the drawing helpers (`draw.rs`) take
//! it, and `frame.rs` imports them.

use avacraft_engine::{Rect, Vec2, World};

/// Map-to-pixel transform for the playable area fitted into a pixel rectangle.
#[derive(Clone, Copy, Debug)]
pub struct MapView {
    left: f32,
    top: f32,
    scale: f32,
    ox: f32,
    oy: f32,
}

impl MapView {
    /// Fits the playable area into `area` = [x0, y0, x1, y1] keeping its aspect ratio, centred.
    pub fn fit(world: &World, area: [f32; 4]) -> Self {
        Self::fit_rect(world.terrain().playable(), area)
    }
    /// Fits the world rectangle `p` (a camera's view, say) into `area` = [x0, y0, x1, y1]
    /// with the same scale on both axes, centred.
    pub fn fit_rect(p: Rect, area: [f32; 4]) -> Self {
        // An area smaller than the margins degenerates to a point instead of mirroring.
        let area = [area[0], area[1], area[2].max(area[0] + 1.0), area[3].max(area[1] + 1.0)];
        let scale = ((area[2] - area[0]) / p.width()).min((area[3] - area[1]) / p.height()).max(1e-3);
        let ox = area[0] + ((area[2] - area[0]) - p.width() * scale) * 0.5;
        let oy = area[1] + ((area[3] - area[1]) - p.height() * scale) * 0.5;
        Self { left: p.left, top: p.top, scale, ox, oy }
    }
    pub fn px(&self, p: Vec2) -> [f32; 2] {
        [self.ox + (p.x - self.left) * self.scale, self.oy + (self.top - p.y) * self.scale]
    }
    pub fn scale(&self) -> f32 {
        self.scale
    }
}
