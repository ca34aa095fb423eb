//! The built-in bitmap font (font8x8's public-domain basic Latin glyphs).

use font8x8::legacy::BASIC_LEGACY;

/// 8 rows of 8 bits (bit 0 is the leftmost pixel) for a character; '?' for anything outside
/// basic Latin.
pub fn glyph(c: char) -> [u8; 8] {
    let i = c as usize;
    if i < BASIC_LEGACY.len() { BASIC_LEGACY[i] } else { BASIC_LEGACY['?' as usize] }
}

/// Width in pixels of `text` at `scale`.
pub fn text_width(text: &str, scale: u32) -> f32 {
    (text.chars().count() * 8) as f32 * scale as f32
}

/// Calls `f` with one rectangle [x0, y0, x1, y1] per run of set pixels in each glyph row of
/// `text` drawn at `pos` and `scale`: the shape both back ends fill.
pub fn runs(pos: [f32; 2], scale: u32, text: &str, mut f: impl FnMut([f32; 4])) {
    let s = scale.max(1) as f32;
    for (k, ch) in text.chars().enumerate() {
        for (row, bits) in glyph(ch).iter().enumerate() {
            let mut col = 0;
            while col < 8 {
                if bits & (1 << col) == 0 {
                    col += 1;
                    continue;
                }
                let start = col;
                while col < 8 && bits & (1 << col) != 0 {
                    col += 1;
                }
                let x0 = pos[0] + (k * 8 + start) as f32 * s;
                let y0 = pos[1] + row as f32 * s;
                f([x0, y0, x0 + (col - start) as f32 * s, y0 + s]);
            }
        }
    }
}
