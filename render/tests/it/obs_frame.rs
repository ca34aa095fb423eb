//! The VLM screenshot drawn from an observation through a camera: side colours, unit size,
//! fog, the grid over the view, clipping, annotations, and determinism.

use avacraft_engine::agent::{EffectInfo, GroupObs, view};
use avacraft_engine::{EffectKind, Env, EnvConfig, OrderInfo, Reads, Rules, Scenario, Team, UnitId, Vec2};
use avacraft_render::{Camera, CpuBackend, ENEMY, FrameBuilder, OWN, Prim, RgbImage, Rgba, Scene, VlmOptions, vlm_layout, vlm_obs_layout};
use std::sync::Arc;

fn rgb(c: Rgba) -> [u8; 3] {
    [c.0[0], c.0[1], c.0[2]]
}

fn env(name: &str) -> Env {
    let s = Arc::new(Scenario::load(name).unwrap_or_else(|e| panic!("{name}: {e}")));
    Env::new(s, EnvConfig { rules: Rules { cooldown_jitter: false, ..Rules::default() }, ..EnvConfig::default() }, 1)
}

/// 3m_vlm stepped until team 1 sees all three enemy Marines.
fn env_3m_in_sight() -> Env {
    let mut e = env("3m_vlm");
    for _ in 0..60 {
        if GroupObs::team(&e, Team::One, 0, Reads::UNITS).enemies().count() == 3 {
            return e;
        }
        e.step();
    }
    panic!("3m_vlm: the enemy never came in sight");
}

fn obs(e: &Env) -> GroupObs {
    GroupObs::team(e, Team::One, 0, Reads::UNITS)
}

/// The default camera for a `w` x `h` screenshot: 24 units across the map area, on the team.
fn camera(e: &Env, o: &GroupObs, w: u32, h: u32) -> Camera {
    vlm_obs_layout(w, h).camera(o.own().map(view::pos), Camera::DEFAULT_WIDTH, e.scenario().terrain.playable())
}

fn render(e: &Env, o: &GroupObs, cam: &Camera, w: u32, h: u32, opts: &VlmOptions) -> (Scene, RgbImage) {
    let scene = FrameBuilder::new().vlm_obs(&e.scenario().terrain, o, cam, w, h, opts);
    let img = CpuBackend::new().render(&scene);
    (scene, img)
}

fn pixel(img: &RgbImage, p: [f32; 2]) -> [u8; 3] {
    img.get_pixel(p[0] as u32, p[1] as u32).0
}

#[test]
fn own_units_are_blue_and_seen_enemies_red_at_both_sizes() {
    let e = env_3m_in_sight();
    let o = obs(&e);
    for (w, h) in [(1920, 1080), (960, 540)] {
        let cam = camera(&e, &o, w, h);
        let (_, img) = render(&e, &o, &cam, w, h, &VlmOptions::default());
        let v = vlm_obs_layout(w, h).view(&cam);
        let mut seen = [0, 0];
        for u in &o.units {
            assert!(cam.contains(view::pos(u)), "{w}x{h}: {} out of view {:?}", u.tag.tag(), cam.rect());
            let want = if u.own { OWN } else { ENEMY };
            assert_eq!(pixel(&img, v.px(view::pos(u))), rgb(want), "{w}x{h}: unit {} (own: {})", u.tag.tag(), u.own);
            seen[u.own as usize] += 1;
        }
        assert_eq!(seen, [3, 3]);
    }
}

#[test]
fn units_are_drawn_at_camera_scale_several_times_the_whole_map_size() {
    let e = env("3m_vlm");
    let o = obs(&e);
    let (w, h) = (1920, 1080);
    let layout = vlm_obs_layout(w, h);
    let cam = camera(&e, &o, w, h);
    let v = layout.view(&cam);
    // The camera fills the map area, 24 units across it.
    assert_eq!(cam.width(), Camera::DEFAULT_WIDTH);
    let (tl, br) = (v.px(Vec2::new(cam.rect().left, cam.rect().top)), v.px(Vec2::new(cam.rect().right, cam.rect().bottom)));
    for (a, b) in [(tl[0], layout.map[0]), (tl[1], layout.map[1]), (br[0], layout.map[2]), (br[1], layout.map[3])] {
        assert!((a - b).abs() <= 1.0, "view {tl:?}..{br:?} vs map area {:?}", layout.map);
    }
    // Measure a Marine's disc: the run of own-coloured pixels right of its centre.
    let (_, img) = render(&e, &o, &cam, w, h, &VlmOptions::default());
    let u = o.own().next().expect("an own Marine");
    let want = view::radius(u) * v.scale();
    let c = v.px(view::pos(u));
    let run = (0..200).take_while(|&dx| img.get_pixel(c[0] as u32 + dx, c[1] as u32).0 == rgb(OWN)).count() as f32;
    assert!((run - want).abs() <= 1.5, "drawn radius {run} px, camera math says {want}");
    // The whole-map screenshot of a 96x96 map (pvz_ht) draws the same Marine at the map's
    // scale: the camera shows 24 of the 96 playable units across, so ~4x the radius (16x
    // the area).
    let big = env("pvz_ht");
    let playable = big.scenario().terrain.playable();
    let whole = vlm_layout(big.world(), w, h).0.scale() * view::radius(u);
    let ratio = want / whole;
    assert!(ratio >= 0.95 * playable.width() / Camera::DEFAULT_WIDTH, "{want} px vs {whole} px whole-map: only {ratio}x");
    assert!(ratio > 3.5, "{ratio}");
}

#[test]
fn ground_the_team_does_not_see_is_darker() {
    let e = env("3m_vlm");
    let o = obs(&e);
    let (w, h) = (960, 540);
    let cam = camera(&e, &o, w, h);
    let (scene, img) = render(&e, &o, &cam, w, h, &VlmOptions::default());
    let v = vlm_obs_layout(w, h).view(&cam);
    let terrain = &e.scenario().terrain;
    let lum = |p: Vec2| pixel(&img, v.px(p)).iter().map(|&c| c as u32).sum::<u32>();
    // Cell centres in view, away from units and grid lines, by whether the team sees them.
    let r = cam.rect();
    let on_line = |x: f32, lo: f32, ext: f32| {
        let f = (x - lo) / ext * 10.0;
        (f - f.round()).abs() < 0.15
    };
    let (mut seen, mut fogged) = (None, None);
    for cy in r.bottom.ceil() as u32..r.top.floor() as u32 {
        for cx in r.left.ceil() as u32..r.right.floor() as u32 {
            let p = Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5);
            let clear = o.units.iter().all(|u| view::pos(u).dist(p) > 2.5);
            if !clear || on_line(p.x, r.left, r.width()) || on_line(p.y, r.bottom, r.height()) {
                continue;
            }
            let slot = if view::sees_point(terrain, o.own(), p) { &mut seen } else { &mut fogged };
            slot.get_or_insert((p, terrain.height_at(p)));
        }
    }
    let ((a, ha), (b, hb)) = (seen.expect("a seen cell"), fogged.expect("a fogged cell"));
    assert_eq!(ha, hb, "same terrain level");
    assert!(lum(a) > lum(b) + 60, "seen {a:?}: {}, fogged {b:?}: {}", lum(a), lum(b));
    assert!(scene.prims.iter().any(|p| matches!(p, Prim::Cells { colors, .. } if colors.contains(&Rgba([0, 0, 0, 150])))));
}

#[test]
fn the_grid_covers_the_view_and_its_cells_sit_where_cell_center_says() {
    let e = env("3m_vlm");
    let o = obs(&e);
    let (w, h) = (1920, 1080);
    let layout = vlm_obs_layout(w, h);
    // A camera of the image's aspect: letterboxed in the map area, the grid still exact.
    for cam in [camera(&e, &o, w, h), Camera::framing(o.own().map(view::pos), 24.0, w, h, e.scenario().terrain.playable())] {
        let (scene, _) = render(&e, &o, &cam, w, h, &VlmOptions::default());
        let v = layout.view(&cam);
        let grid = Rgba([255, 255, 255, 70]);
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for p in &scene.prims {
            if let Prim::Line { a, b, color, .. } = p
                && *color == grid
            {
                if a[0] == b[0] {
                    xs.push(a[0]);
                } else {
                    ys.push(a[1]);
                }
            }
        }
        assert_eq!((xs.len(), ys.len()), (11, 11));
        for col in 1..=10u8 {
            for row in 1..=10u8 {
                let c = v.px(cam.cell_center(col, row).expect("cell"));
                let (i, j) = (col as usize, row as usize);
                assert!(xs[i - 1] < c[0] && c[0] < xs[i] && ys[j - 1] < c[1] && c[1] < ys[j], "cell ({col}, {row}) at {c:?}");
            }
        }
        // Label k above the view, centred on column k's cell centres.
        for k in 1..=10u8 {
            let cx = v.px(cam.cell_center(k, 1).expect("cell"))[0];
            let found = scene.prims.iter().any(|p| match p {
                Prim::Text { pos, scale, text, .. } => {
                    let tw = text.len() as f32 * 8.0 * *scale as f32;
                    *text == k.to_string() && pos[1] < ys[0] && (pos[0] + tw * 0.5 - cx).abs() <= 1.0
                }
                _ => false,
            });
            assert!(found, "label {k}");
        }
    }
}

#[test]
fn units_outside_the_view_are_not_drawn() {
    let e = env_3m_in_sight();
    let mut o = obs(&e);
    let (w, h) = (960, 540);
    let cam = camera(&e, &o, w, h);
    // Move one enemy far outside the view.
    let far = o.units.iter_mut().find(|u| !u.own).expect("an enemy");
    let (id, out) = (far.tag, Vec2::new(cam.rect().right + 5.0, cam.rect().bottom - 5.0));
    (far.x, far.y) = (out.x, out.y);
    assert!(!cam.contains(out));
    let (scene, img) = render(&e, &o, &cam, w, h, &VlmOptions { highlights: vec![id] });
    let tag = id.tag();
    let v = vlm_obs_layout(w, h).view(&cam);
    let enemy_discs = scene.prims.iter().filter(|p| matches!(p, Prim::Disc { color, .. } if *color == ENEMY)).count();
    assert_eq!(enemy_discs, o.enemies().count() - 1);
    let label = format!("{tag} ");
    let (x0, y0) = (v.px(Vec2::new(cam.rect().left, cam.rect().top)), v.px(Vec2::new(cam.rect().right, cam.rect().bottom)));
    let in_view = |p: &[f32; 2]| p[0] >= x0[0] && p[0] <= y0[0] && p[1] >= x0[1] && p[1] <= y0[1];
    // Neither its "tag type" label nor a bare tag (grid labels sit outside the view).
    assert!(
        !scene
            .prims
            .iter()
            .any(|p| matches!(p, Prim::Text { text, pos, .. } if text.starts_with(&label) || (*text == tag.to_string() && in_view(pos))))
    );
    assert!(!scene.prims.iter().any(|p| matches!(p, Prim::Ring { .. })), "no highlight ring for a unit out of view");
    // An arrow at the view's edge points towards it instead.
    let arrows: Vec<&Vec<[f32; 2]>> = scene
        .prims
        .iter()
        .filter_map(|p| if let Prim::Polygon { points, color } = p { (*color == ENEMY).then_some(points) } else { None })
        .collect();
    assert_eq!(arrows.len(), 1);
    let (c, t) = (v.px(cam.center()), v.px(out));
    let tip = arrows[0][0];
    assert!((tip[0] - c[0]) * (t[0] - c[0]) > 0.0 && (tip[1] - c[1]) * (t[1] - c[1]) > 0.0, "arrow {tip:?} towards {t:?}");
    // Nothing red where it would be were the image larger; the others still drawn.
    let p = v.px(out);
    assert!(p[0] as u32 >= w || p[1] as u32 >= h || pixel(&img, p) != rgb(ENEMY));
    for u in o.enemies().filter(|u| u.tag != id) {
        assert_eq!(pixel(&img, v.px(view::pos(u))), rgb(ENEMY));
    }
}

#[test]
fn effects_intents_and_highlights_come_from_the_observation() {
    let e = env_3m_in_sight();
    let mut o = obs(&e);
    let (w, h) = (960, 540);
    let cam = camera(&e, &o, w, h);
    let enemy = o.enemies().next().expect("an enemy").tag;
    let (mine, ally) = {
        let mut own = o.own().map(|u| u.tag);
        (own.next().expect("own"), own.next().expect("own"))
    };
    for u in &mut o.units {
        u.order = if u.tag == mine {
            OrderInfo::Attack { target: enemy }
        } else if u.tag == ally {
            OrderInfo::Attack { target: mine }
        } else {
            OrderInfo::Attack { target: UnitId::new(998) }
        };
    }
    let fx = |x: f32, y: f32| EffectInfo { kind: EffectKind::PsionicStorm, team: Team::Two, x, y, radius: 1.5, remaining_s: 2.0 };
    o.effects = vec![fx(cam.center().x, cam.center().y), fx(cam.rect().right + 10.0, cam.center().y)];
    let opts = VlmOptions { highlights: vec![mine] };
    let (scene, _) = render(&e, &o, &cam, w, h, &opts);
    let count = |f: &dyn Fn(&Prim) -> bool| scene.prims.iter().filter(|p| f(p)).count();
    let yellow = Rgba([255, 230, 60, 200]);
    let green = Rgba([120, 255, 140, 200]);
    let storm = Rgba([170, 80, 255, 110]);
    assert_eq!(count(&|p| matches!(p, Prim::Line { color, .. } if *color == yellow)), 1, "one attack line (target 999 unknown)");
    assert_eq!(count(&|p| matches!(p, Prim::Line { color, .. } if *color == green)), 1, "one heal line to an ally");
    assert_eq!(count(&|p| matches!(p, Prim::Disc { color, .. } if *color == storm)), 1, "the storm in view only");
    assert_eq!(count(&|p| matches!(p, Prim::Ring { color, .. } if *color == Rgba::rgb(255, 230, 0))), 1, "highlight");
    assert!(scene.prims.iter().any(|p| matches!(p, Prim::Text { text, .. } if text.starts_with(&format!("{} Mar", mine.tag())))));
    assert!(scene.prims.iter().any(|p| matches!(p, Prim::Text { text, .. } if *text == format!("team 1, loop {}", o.game_loop))));
}

#[test]
fn same_observation_same_pixels_in_process_or_folded_from_agent_messages() {
    let mut e = env("3m_vlm");
    for _ in 0..12 {
        e.step();
    }
    let team = obs(&e);
    // What an agent node gets: one observation per unit, folded.
    let per_unit = e.agent_observations(Team::One, 0);
    let folded = GroupObs::fold(&per_unit, |id| id.index()).expect("observations");
    let (w, h) = (960, 540);
    let cam = camera(&e, &team, w, h);
    assert_eq!(cam, camera(&e, &folded, w, h));
    let opts = VlmOptions { highlights: vec![UnitId::new(0)] };
    let (s1, a) = render(&e, &team, &cam, w, h, &opts);
    let (s2, b) = render(&e, &folded, &cam, w, h, &opts);
    let (s3, c) = render(&e, &team, &cam, w, h, &opts);
    assert_eq!(s1, s2);
    assert_eq!(s1, s3);
    assert!(a == b && a == c, "identical pixels");
}

#[test]
fn tiny_and_odd_sizes_do_not_panic() {
    let e = env_3m_in_sight();
    let o = obs(&e);
    for (w, h) in [(1, 1), (10, 300), (300, 10), (64, 64), (3000, 200)] {
        for cam in [camera(&e, &o, w, h), Camera::new(Vec2::new(-1e4, 1e4), 1e5, w, h), Camera::new(Vec2::ZERO, 0.1, w, h)] {
            let (scene, img) = render(&e, &o, &cam, w, h, &VlmOptions::default());
            assert_eq!(img.dimensions(), (scene.width, scene.height));
        }
    }
    let mut bad = o.clone();
    for u in &mut bad.units {
        (u.x, u.hp, u.max_shield, u.shield) = (f32::NAN, f32::NAN, 1.0, f32::INFINITY);
    }
    render(&e, &bad, &camera(&e, &o, 640, 360), 640, 360, &VlmOptions::default());
}

/// On a procedural scenario the legend lists the unit types this episode drew (those the team
/// knows of), so a VLM reading the picture is told what each shape is, draw after draw.
#[test]
fn the_legend_lists_the_drawn_unit_types() {
    let mut kinds_seen = std::collections::BTreeSet::new();
    for seed in 1..9 {
        let s = Arc::new(Scenario::load("zerg_10_vs_10").unwrap_or_else(|e| panic!("{e}")));
        let e = Env::new(s, EnvConfig::default(), seed);
        let o = obs(&e);
        let cam = camera(&e, &o, 1920, 1080);
        let (scene, _) = render(&e, &o, &cam, 1920, 1080, &VlmOptions::default());
        let texts: Vec<String> =
            scene.prims.iter().filter_map(|p| if let Prim::Text { text, .. } = p { Some(text.clone()) } else { None }).collect();
        let mut drawn: Vec<&str> = o.units.iter().map(|u| u.kind.base().name()).collect();
        drawn.sort_unstable();
        drawn.dedup();
        for k in &drawn {
            assert!(texts.iter().any(|t| t.trim_start().ends_with(&format!(" {k}"))), "seed {seed}: {k} not in the legend {texts:?}");
            kinds_seen.insert(k.to_string());
        }
        for k in ["Marine", "Stalker", "Zealot"] {
            assert!(!texts.iter().any(|t| t.trim_start().ends_with(&format!(" {k}"))), "seed {seed}: {k} was not drawn");
        }
    }
    assert!(kinds_seen.contains("Zergling") && kinds_seen.contains("Hydralisk"), "{kinds_seen:?}");
}
