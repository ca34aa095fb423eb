//! The display list: what to draw, in pixel coordinates, independent of the back end. Every
//! back end draws the same list, which is what makes their outputs agree.

use std::sync::Arc;

/// A colour with straight (non-premultiplied) alpha; true RGB order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgba(pub [u8; 4]);

impl Rgba {
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Rgba([r, g, b, 255])
    }
    pub const fn with_alpha(self, a: u8) -> Self {
        Rgba([self.0[0], self.0[1], self.0[2], a])
    }
}

/// One drawing primitive. Coverage is decided at pixel centres (x + 0.5, y + 0.5), with no
/// anti-aliasing, so results are exact and identical across back ends.
#[derive(Clone, Debug, PartialEq)]
pub enum Prim {
    /// A grid of coloured cells over a pixel rectangle; `colors` row 0 is the top row.
    Cells {
        rect: [f32; 4],
        cols: u32,
        rows: u32,
        colors: Arc<Vec<Rgba>>,
    },
    /// A filled axis-aligned rectangle [x0, x1) x [y0, y1).
    Rect {
        rect: [f32; 4],
        color: Rgba,
    },
    Disc {
        c: [f32; 2],
        r: f32,
        color: Rgba,
    },
    Ring {
        c: [f32; 2],
        r: f32,
        width: f32,
        color: Rgba,
    },
    /// A filled convex polygon, vertices in either winding.
    Polygon {
        points: Vec<[f32; 2]>,
        color: Rgba,
    },
    Line {
        a: [f32; 2],
        b: [f32; 2],
        width: f32,
        color: Rgba,
    },
    /// Text in the built-in 8x8 font, `scale` pixels per font pixel; `pos` is the top left.
    Text {
        pos: [f32; 2],
        scale: u32,
        text: String,
        color: Rgba,
    },
}

/// A frame to draw: size, background, primitives in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub width: u32,
    pub height: u32,
    pub background: Rgba,
    pub prims: Vec<Prim>,
}

impl Scene {
    pub fn new(width: u32, height: u32, background: Rgba) -> Self {
        Self { width, height, background, prims: Vec::new() }
    }
    pub fn push(&mut self, p: Prim) {
        self.prims.push(p);
    }
}

/// The four corners of a line of `width` from `a` to `b` (None for a zero-length line), so
/// both back ends draw exactly the same quad.
pub(crate) fn line_quad(a: [f32; 2], b: [f32; 2], width: f32) -> Option<[[f32; 2]; 4]> {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = (dx * dx + dy * dy).sqrt();
    if len < 1e-6 {
        return None;
    }
    let (nx, ny) = (-dy / len * width * 0.5, dx / len * width * 0.5);
    Some([[a[0] + nx, a[1] + ny], [b[0] + nx, b[1] + ny], [b[0] - nx, b[1] - ny], [a[0] - nx, a[1] - ny]])
}
