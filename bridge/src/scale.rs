//! Frame scaling for DDS: a box filter (each output pixel is the mean of the input pixels
//! it covers), so small text and unit markers fade rather than vanish as with nearest
//! neighbour.

use avacraft_msgs::Image;

/// `img` scaled to `(width, height)` if it is an `rgb8` frame of another size (rows `step`
/// bytes apart); anything else, or a frame whose sizes do not add up, unchanged.
pub fn scale_rgb8(img: Image, (width, height): (u32, u32)) -> Image {
    let (w, h, stride) = (img.width as usize, img.height as usize, img.step as usize);
    let fits = w.checked_mul(3).is_some_and(|row| row <= stride) && stride.checked_mul(h).is_some_and(|n| n <= img.data.len());
    if img.encoding != "rgb8" || (img.width, img.height) == (width, height) || w == 0 || h == 0 || !fits {
        return img;
    }
    let (ow, oh) = (width as usize, height as usize);
    let mut data = vec![0u8; ow * oh * 3];
    for oy in 0..oh {
        let (y0, y1) = (oy * h / oh, ((oy + 1) * h).div_ceil(oh).max(oy * h / oh + 1));
        for ox in 0..ow {
            let (x0, x1) = (ox * w / ow, ((ox + 1) * w).div_ceil(ow).max(ox * w / ow + 1));
            let mut sum = [0u32; 3];
            for y in y0..y1.min(h) {
                let row = &img.data[y * stride + x0 * 3..y * stride + x1.min(w) * 3];
                for px in row.chunks_exact(3) {
                    for c in 0..3 {
                        sum[c] += px[c] as u32;
                    }
                }
            }
            let n = ((y1.min(h) - y0) * (x1.min(w) - x0)) as u32;
            let o = (oy * ow + ox) * 3;
            for c in 0..3 {
                data[o + c] = ((sum[c] + n / 2) / n) as u8;
            }
        }
    }
    Image { width, height, step: width * 3, data, ..img }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> Image {
        let mut data = Vec::new();
        for y in 0..h {
            for x in 0..w {
                data.extend(f(x, y));
            }
        }
        Image { width: w, height: h, step: w * 3, encoding: "rgb8".into(), data, ..Image::default() }
    }

    #[test]
    fn halving_averages_each_two_by_two_block() {
        let out = scale_rgb8(img(4, 2, |x, _| if x % 2 == 0 { [0, 100, 200] } else { [100, 200, 0] }), (2, 1));
        assert_eq!((out.width, out.height, out.step, out.data.len()), (2, 1, 6, 6));
        assert_eq!(out.data, vec![50, 150, 100, 50, 150, 100]);
    }

    #[test]
    fn padded_rows_are_read_by_step_and_bad_sizes_pass_unchanged() {
        let mut a = img(2, 2, |_, _| [10, 20, 30]);
        // Two bytes of padding per row, set to 255: they must not leak into the mean.
        a.data = [[10, 20, 30, 10, 20, 30, 255, 255], [10, 20, 30, 10, 20, 30, 255, 255]].concat();
        a.step = 8;
        assert_eq!(scale_rgb8(a, (1, 1)).data, vec![10, 20, 30]);
        let huge = Image { width: u32::MAX, height: u32::MAX, step: 3, ..img(1, 1, |_, _| [1, 2, 3]) };
        assert_eq!(scale_rgb8(huge.clone(), (1, 1)), huge);
    }

    #[test]
    fn same_size_and_other_encodings_pass_unchanged() {
        let a = img(3, 3, |x, y| [x as u8, y as u8, 7]);
        assert_eq!(scale_rgb8(a.clone(), (3, 3)), a);
        let mono = Image { encoding: "mono8".into(), ..a.clone() };
        assert_eq!(scale_rgb8(mono.clone(), (1, 1)), mono);
    }

    proptest::proptest! {
        #[test]
        fn any_size_to_any_size_keeps_a_uniform_colour(w in 1u32..40, h in 1u32..40, ow in 1u32..50, oh in 1u32..50, c in proptest::array::uniform3(0u8..)) {
            let out = scale_rgb8(img(w, h, |_, _| c), (ow, oh));
            proptest::prop_assert_eq!(out.data.len(), (ow * oh * 3) as usize);
            proptest::prop_assert!(out.data.chunks_exact(3).all(|p| p == c));
        }
    }
}
