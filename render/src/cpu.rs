//! The CPU back end: a small scanline rasteriser over an RGB buffer. Used on every machine,
//! and as the reference the GPU back end is compared against.

use crate::scene::{Prim, Rgba, Scene};
use image::RgbImage;

/// Draws scenes on the CPU.
#[derive(Debug, Default, Clone)]
pub struct CpuBackend {
    /// A `Cells` primitive's columns as runs of pixels over the same cell: (first, end, cell).
    runs: Vec<(u32, u32, u32)>,
}

fn blend(dst: &mut [u8], c: Rgba) {
    let a = c.0[3] as u32;
    if a == 255 {
        dst.copy_from_slice(&c.0[..3]);
        return;
    }
    for (d, &s) in dst.iter_mut().zip(&c.0[..3]) {
        *d = div255(s as u32 * a + *d as u32 * (255 - a));
    }
}

/// `x / 255` rounded to nearest (`(x + 127) / 255`) for `x <= 255 * 255`, without a division:
/// blending is most of the time of a screenshot's fog.
#[inline]
fn div255(x: u32) -> u8 {
    let t = x + 128;
    ((t + (t >> 8)) >> 8) as u8
}

/// Fills RGB pixels with one colour: the first pixel, then doubling copies (memcpy speed;
/// VLM screenshots are mostly large flat areas).
fn fill_rgb(px: &mut [u8], rgb: [u8; 3]) {
    if px.len() < 3 {
        return;
    }
    px[..3].copy_from_slice(&rgb);
    let mut filled = 3;
    while filled < px.len() {
        let n = filled.min(px.len() - filled);
        px.copy_within(..n, filled);
        filled += n;
    }
}

/// Pixels `xs` of one RGB row in colour `c`: copied when opaque, blended otherwise, left
/// alone when fully transparent (which blending would leave as they are too).
fn fill_span(row: &mut [u8], xs: std::ops::Range<u32>, c: Rgba) {
    let px = &mut row[xs.start as usize * 3..xs.end as usize * 3];
    match c.0[3] {
        0 => {}
        255 => fill_rgb(px, [c.0[0], c.0[1], c.0[2]]),
        _ => px.chunks_exact_mut(3).for_each(|p| blend(p, c)),
    }
}

/// Pixel index range whose centres lie in [lo, hi).
fn span(lo: f32, hi: f32, max: u32) -> std::ops::Range<u32> {
    let a = (lo - 0.5).ceil().max(0.0) as u32;
    let b = ((hi - 0.5).ceil().max(0.0) as u32).min(max);
    a.min(b)..b
}

impl CpuBackend {
    pub fn new() -> Self {
        Self::default()
    }

    /// Renders a scene into a new image.
    pub fn render(&mut self, scene: &Scene) -> RgbImage {
        let mut img = RgbImage::new(scene.width, scene.height);
        self.render_into(scene, &mut img);
        img
    }

    /// Renders into an existing image of the scene's size (reused across frames).
    pub fn render_into(&mut self, scene: &Scene, img: &mut RgbImage) {
        if img.dimensions() != (scene.width, scene.height) {
            *img = RgbImage::new(scene.width, scene.height);
        }
        let bg = scene.background.0;
        fill_rgb(img.as_mut(), [bg[0], bg[1], bg[2]]);
        for p in &scene.prims {
            self.draw(p, img);
        }
    }

    fn draw(&mut self, p: &Prim, img: &mut RgbImage) {
        let (w, h) = img.dimensions();
        let stride = w as usize * 3;
        let buf: &mut [u8] = img.as_mut();
        let mut put = |x: u32, y: u32, c: Rgba| {
            let i = y as usize * stride + x as usize * 3;
            blend(&mut buf[i..i + 3], c);
        };
        match p {
            Prim::Cells { rect, cols, rows, colors } => {
                let (cw, ch) = ((rect[2] - rect[0]) / *cols as f32, (rect[3] - rect[1]) / *rows as f32);
                let cell_x = |x: u32| (((x as f32 + 0.5 - rect[0]) / cw) as u32).min(cols - 1);
                self.runs.clear();
                for x in span(rect[0], rect[2], w) {
                    let cx = cell_x(x);
                    match self.runs.last_mut() {
                        Some(run) if run.2 == cx => run.1 = x + 1,
                        _ => self.runs.push((x, x + 1, cx)),
                    }
                }
                for y in span(rect[1], rect[3], h) {
                    let cy = (((y as f32 + 0.5 - rect[1]) / ch) as u32).min(rows - 1);
                    let cells = &colors[(cy * cols) as usize..((cy + 1) * cols) as usize];
                    let row = &mut buf[y as usize * stride..(y as usize + 1) * stride];
                    for &(x0, x1, cx) in &self.runs {
                        fill_span(row, x0..x1, cells[cx as usize]);
                    }
                }
            }
            Prim::Rect { rect, color } => {
                let xs = span(rect[0], rect[2], w);
                for y in span(rect[1], rect[3], h) {
                    fill_span(&mut buf[y as usize * stride..(y as usize + 1) * stride], xs.clone(), *color);
                }
            }
            Prim::Disc { c, r, color } => {
                let r2 = r * r;
                for y in span(c[1] - r, c[1] + r + 1.0, h) {
                    let dy = y as f32 + 0.5 - c[1];
                    for x in span(c[0] - r, c[0] + r + 1.0, w) {
                        let dx = x as f32 + 0.5 - c[0];
                        if dx * dx + dy * dy <= r2 {
                            put(x, y, *color);
                        }
                    }
                }
            }
            Prim::Ring { c, r, width, color } => {
                let (ri, ro) = ((r - width * 0.5).max(0.0), r + width * 0.5);
                let (ri2, ro2) = (ri * ri, ro * ro);
                for y in span(c[1] - ro, c[1] + ro + 1.0, h) {
                    let dy = y as f32 + 0.5 - c[1];
                    for x in span(c[0] - ro, c[0] + ro + 1.0, w) {
                        let dx = x as f32 + 0.5 - c[0];
                        let d2 = dx * dx + dy * dy;
                        if d2 <= ro2 && d2 >= ri2 {
                            put(x, y, *color);
                        }
                    }
                }
            }
            Prim::Polygon { points, color } => fill_convex(points, *color, w, h, &mut put),
            Prim::Line { a, b, width, color } => {
                if let Some(quad) = crate::scene::line_quad(*a, *b, *width) {
                    fill_convex(&quad, *color, w, h, &mut put);
                }
            }
            Prim::Text { pos, scale, text, color } => crate::font::runs(*pos, *scale, text, |r| {
                let xs = span(r[0], r[2], w);
                for y in span(r[1], r[3], h) {
                    fill_span(&mut buf[y as usize * stride..(y as usize + 1) * stride], xs.clone(), *color);
                }
            }),
        }
    }
}

/// Fills a convex polygon: a pixel is in when its centre is on the inner side of every edge.
/// A centre exactly on an edge follows the top-left rule GPUs use (in when the edge is a top
/// edge, horizontal with the inside below, or a left edge, with the inside to its right), so
/// both back ends cover the same pixels even on ties.
fn fill_convex(points: &[[f32; 2]], color: Rgba, w: u32, h: u32, put: &mut impl FnMut(u32, u32, Rgba)) {
    let n = points.len();
    if n < 3 {
        return;
    }
    let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    for p in points {
        x0 = x0.min(p[0]);
        y0 = y0.min(p[1]);
        x1 = x1.max(p[0]);
        y1 = y1.max(p[1]);
    }
    // Signed area decides which side is inside.
    let area: f32 = (0..n)
        .map(|i| {
            let (a, b) = (points[i], points[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum();
    if area == 0.0 {
        return;
    }
    let sign = if area > 0.0 { 1.0 } else { -1.0 };
    let edges: Vec<([f32; 2], [f32; 2], bool)> = (0..n)
        .map(|i| {
            let (a, b) = (points[i], points[(i + 1) % n]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let top_left = (d[1] == 0.0 && sign * d[0] > 0.0) || sign * d[1] < 0.0;
            (a, d, top_left)
        })
        .collect();
    for y in span(y0, y1 + 1.0, h) {
        let py = y as f32 + 0.5;
        for x in span(x0, x1 + 1.0, w) {
            let px = x as f32 + 0.5;
            let inside = edges.iter().all(|(a, d, top_left)| {
                let e = sign * (d[0] * (py - a[1]) - d[1] * (px - a[0]));
                e > 0.0 || (e == 0.0 && *top_left)
            });
            if inside {
                put(x, y, color);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disc_covers_pixel_centres_within_radius() {
        let mut s = Scene::new(10, 10, Rgba::rgb(0, 0, 0));
        s.push(Prim::Disc { c: [5.0, 5.0], r: 2.0, color: Rgba::rgb(255, 0, 0) });
        let img = CpuBackend::new().render(&s);
        assert_eq!(img.get_pixel(5, 5).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(4, 4).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(7, 5).0, [0, 0, 0], "centre (7.5, 5.5) is 2.55 away");
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
    }

    #[test]
    fn div255_rounds_as_the_division_does() {
        for x in 0..=255 * 255 {
            assert_eq!(div255(x) as u32, (x + 127) / 255, "{x}");
        }
    }

    #[test]
    fn alpha_blends_and_rgb_order_is_kept() {
        let mut s = Scene::new(2, 1, Rgba::rgb(0, 0, 200));
        s.push(Prim::Rect { rect: [0.0, 0.0, 1.0, 1.0], color: Rgba::rgb(255, 0, 0).with_alpha(128) });
        let img = CpuBackend::new().render(&s);
        assert_eq!(img.get_pixel(0, 0).0, [128, 0, 100]);
        assert_eq!(img.get_pixel(1, 0).0, [0, 0, 200]);
    }
}
