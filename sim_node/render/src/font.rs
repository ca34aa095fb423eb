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
