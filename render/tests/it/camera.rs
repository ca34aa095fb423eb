//! The VLM camera: grid cells map to points and back, points outside the view have no cell,
//! framing keeps the view on the map and the team in view, and bad input never panics.

use avacraft_engine::{GRID, Rect, Vec2, grid_cell_center};
use avacraft_render::Camera;
use proptest::prelude::*;

fn camera() -> impl Strategy<Value = Camera> {
    (-1000.0f32..1000.0, -1000.0f32..1000.0, 1.0f32..500.0, 1u32..4000, 1u32..4000)
        .prop_map(|(x, y, w, pw, ph)| Camera::new(Vec2::new(x, y), w, pw, ph))
}

proptest! {
    #[test]
    fn every_cell_centre_lies_in_its_own_cell(cam in camera()) {
        for col in 1..=GRID {
            for row in 1..=GRID {
                let p = cam.cell_center(col, row).expect("cell in range");
                prop_assert!(cam.contains(p));
                prop_assert_eq!(cam.cell_of(p), Some((col, row)), "{:?} cell ({}, {})", cam, col, row);
                // The engine's own formula over the view: grid moves go where the cell is drawn.
                prop_assert_eq!(p, grid_cell_center(cam.rect(), col, row));
            }
        }
    }

    #[test]
    fn points_outside_the_view_have_no_cell(cam in camera(), d in 0.01f32..1000.0, f in 0.0f32..=1.0) {
        let r = cam.rect();
        let (x, y) = (r.left + f * cam.width(), r.bottom + f * cam.height());
        for p in [Vec2::new(r.right + d, y), Vec2::new(r.left - d, y), Vec2::new(x, r.top + d), Vec2::new(x, r.bottom - d)] {
            prop_assert!(!cam.contains(p));
            prop_assert_eq!(cam.cell_of(p), None);
        }
        prop_assert!(cam.cell_of(cam.center()).is_some());
    }

    #[test]
    fn framing_stays_on_the_map_and_keeps_the_team_in_view(
        (left, bottom, pw, ph) in (-100.0f32..100.0, -100.0f32..100.0, 1.0f32..200.0, 1.0f32..200.0),
        fracs in prop::collection::vec((0.0f32..=1.0, 0.0f32..=1.0), 0..20),
        width in 1.0f32..300.0,
        (px_w, px_h) in (1u32..4000, 1u32..4000),
    ) {
        let playable = Rect { left, bottom, right: left + pw, top: bottom + ph };
        let points: Vec<Vec2> = fracs.iter().map(|&(a, b)| Vec2::new(left + a * pw, bottom + b * ph)).collect();
        let cam = Camera::framing(points.iter().copied(), width, px_w, px_h, playable);
        let r = cam.rect();
        let eps = 1e-3;
        prop_assert!((cam.width() - width).abs() <= 1e-4 * width);
        if cam.width() <= playable.width() {
            prop_assert!(r.left >= playable.left - eps && r.right <= playable.right + eps, "{:?} in {:?}", r, playable);
        } else {
            prop_assert!((cam.center().x - playable.center().x).abs() <= eps);
        }
        if cam.height() <= playable.height() {
            prop_assert!(r.bottom >= playable.bottom - eps && r.top <= playable.top + eps, "{:?} in {:?}", r, playable);
        } else {
            prop_assert!((cam.center().y - playable.center().y).abs() <= eps);
        }
        let n = points.len() as f32;
        if n > 0.0 {
            let c = points.iter().fold(Vec2::ZERO, |s, &p| s + p) * (1.0 / n);
            prop_assert!(c.x >= r.left - eps && c.x <= r.right + eps && c.y >= r.bottom - eps && c.y <= r.top + eps, "{:?} in {:?}", c, r);
        } else {
            prop_assert!(cam.center().dist(playable.center()) <= eps);
        }
    }
}

#[test]
fn a_default_camera_is_24_wide_at_the_pixel_aspect() {
    let cam = Camera::new(Vec2::new(10.0, 20.0), Camera::DEFAULT_WIDTH, 1920, 1080);
    assert_eq!((cam.width(), cam.height()), (24.0, 13.5));
    let r = cam.rect();
    assert_eq!((r.left, r.right, r.bottom, r.top), (-2.0, 22.0, 13.25, 26.75));
    // (1, 1) is the top-left cell, as for the engine's grid.
    assert_eq!(cam.cell_center(1, 1), Some(Vec2::new(-2.0 + 1.2, 26.75 - 0.675)));
    assert_eq!(cam.cell_of(Vec2::new(-1.9, 26.7)), Some((1, 1)));
    assert_eq!(cam.cell_of(Vec2::new(21.9, 13.3)), Some((10, 10)));
    // Edges belong to the view; the far edges to the last cells.
    assert_eq!(cam.cell_of(Vec2::new(22.0, 13.25)), Some((10, 10)));
    for (c, r) in [(0, 1), (1, 0), (11, 1), (1, 11)] {
        assert_eq!(cam.cell_center(c, r), None);
    }
}

#[test]
fn bad_input_is_replaced_not_a_panic() {
    for w in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -3.0] {
        assert_eq!(Camera::new(Vec2::ZERO, w, 16, 9).width(), Camera::DEFAULT_WIDTH, "{w}");
    }
    assert_eq!(Camera::new(Vec2::ZERO, 1e-9, 16, 9).width(), Camera::MIN_EXTENT);
    assert_eq!(Camera::new(Vec2::ZERO, 1e30, 16, 9).width(), Camera::MAX_EXTENT);
    // Zero pixels count as one; extreme aspects are clamped.
    assert_eq!(Camera::new(Vec2::ZERO, 24.0, 0, 0).height(), 24.0);
    assert_eq!(Camera::new(Vec2::ZERO, 24.0, 1, u32::MAX).height(), Camera::MAX_EXTENT);
    assert_eq!(Camera::new(Vec2::new(f32::NAN, 3.0), 24.0, 16, 9).center(), Vec2::new(0.0, 3.0));
    // Non-finite points are skipped; a malformed playable area is not used.
    let playable = Rect { left: 0.0, bottom: 0.0, right: 96.0, top: 96.0 };
    let cam = Camera::framing([Vec2::new(f32::NAN, 1.0), Vec2::new(50.0, 50.0)], 24.0, 16, 9, playable);
    assert_eq!(cam.center(), Vec2::new(50.0, 50.0));
    let bad = Rect { left: f32::NAN, bottom: 0.0, right: 1.0, top: -5.0 };
    assert_eq!(Camera::framing([Vec2::new(7.0, 8.0)], 24.0, 16, 9, bad).center(), Vec2::new(7.0, 8.0));
    assert_eq!(Camera::framing(std::iter::empty(), 24.0, 16, 9, bad).center(), Vec2::ZERO);
    assert_eq!(Camera::framing(std::iter::empty(), 24.0, 16, 9, playable).center(), Vec2::new(48.0, 48.0));
}
