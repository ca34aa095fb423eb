//! Rendering: team colours, fog of war, grid labels, determinism, golden images, modes.

use crate::helpers::*;
use avacraft_engine::{Env, EnvConfig, Rules, Team, Vec2, builtin, grid_cell_center};
use avacraft_render::{CpuBackend, ENEMY, FrameBuilder, MapView, OWN, ObsMode, Observation, Observer, RenderConfig, RgbImage, VlmOptions};
use std::path::PathBuf;
use std::sync::Arc;

fn rgb(c: avacraft_render::Rgba) -> [u8; 3] {
    [c.0[0], c.0[1], c.0[2]]
}

#[test]
fn units_carry_their_sides_colour_and_unseen_enemies_are_not_drawn() {
    // Own Marine near the centre, one enemy within sight, one far outside it.
    let s = load(&arena("pvp", &[("Marine", 1, 16.0, 16.0), ("Marine", 2, 20.0, 16.0), ("Zergling", 2, 30.0, 30.0)]));
    let env = Env::new(Arc::clone(&s), passive(), 0);
    let mut fog_env = Env::new(
        s,
        EnvConfig {
            rules: Rules { full_vision: false, cooldown_jitter: false, auto_acquire: [false; 2], ..Rules::default() },
            ..EnvConfig::default()
        },
        0,
    );
    fog_env.step();
    let (w, h) = (320, 240);
    let mut fb = FrameBuilder::new();
    let img = CpuBackend::new().render(&fb.screen(fog_env.world(), Team::One, w, h));
    let view = MapView::fit(fog_env.world(), [0.0, 0.0, w as f32, h as f32]);
    let px = |p: Vec2| {
        let q = view.px(p);
        img.get_pixel(q[0] as u32, q[1] as u32).0
    };
    assert_eq!(px(Vec2::new(16.0, 16.0)), rgb(OWN), "own unit is blue");
    assert_eq!(px(Vec2::new(20.0, 16.0)), rgb(ENEMY), "seen enemy is red");
    assert_ne!(px(Vec2::new(30.0, 30.0)), rgb(ENEMY), "the Zergling outside sight is not drawn");
    // From team 2's side the colours swap.
    let img2 = CpuBackend::new().render(&fb.screen(fog_env.world(), Team::Two, w, h));
    let q = view.px(Vec2::new(20.0, 16.0));
    assert_eq!(img2.get_pixel(q[0] as u32, q[1] as u32).0, rgb(OWN));
    // With full vision the far Zergling is drawn.
    let full = CpuBackend::new().render(&fb.screen(env.world(), Team::One, w, h));
    let q = view.px(Vec2::new(30.0, 30.0));
    assert_eq!(full.get_pixel(q[0] as u32, q[1] as u32).0, rgb(ENEMY));
}

#[test]
fn fog_darkens_unseen_ground() {
    let s = load(&arena("pvp", &[("Marine", 1, 6.0, 16.0), ("Marine", 2, 28.0, 28.0)]));
    let env = Env::new(s, EnvConfig::default(), 0);
    let img = CpuBackend::new().render(&FrameBuilder::new().screen(env.world(), Team::One, 320, 320));
    let view = MapView::fit(env.world(), [0.0, 0.0, 320.0, 320.0]);
    let lum = |p: Vec2| {
        let q = view.px(p);
        img.get_pixel(q[0] as u32, q[1] as u32).0.iter().map(|&c| c as u32).sum::<u32>()
    };
    // Same flat ground, one cell in sight, one far away.
    assert!(
        lum(Vec2::new(10.5, 16.5)) > lum(Vec2::new(25.5, 16.5)) + 60,
        "{} vs {}",
        lum(Vec2::new(10.5, 16.5)),
        lum(Vec2::new(25.5, 16.5))
    );
}

#[test]
fn grid_labels_sit_over_their_cells() {
    // The label k above the grid is centred on the column of cell (k, *), exactly where the
    // grid-move action sends a unit.
    let s = Arc::new(builtin("mixed_units").expect("scenario"));
    let env = Env::new(s, EnvConfig::default(), 0);
    let (w, h) = (1920, 1080);
    let img = CpuBackend::new().render(&FrameBuilder::new().vlm(env.world(), Team::One, w, h, &VlmOptions::default()));
    let playable = env.world().terrain().playable();
    let (view, _, label, _) = avacraft_render::vlm_layout(env.world(), w, h);
    let top = view.px(Vec2::new(playable.left, playable.top))[1];
    for k in 1..=10u8 {
        let cx = view.px(grid_cell_center(playable, k, 1))[0];
        // Label pixels (light grey) in a band above the map, within half a cell of the centre.
        let half = view.scale() * playable.width() / 20.0;
        let mut hit = 0;
        for y in (top - 30.0).max(0.0) as u32..top as u32 {
            for x in (cx - half) as u32..(cx + half) as u32 {
                if img.get_pixel(x, y).0 == [235, 235, 235] {
                    hit += 1;
                }
            }
        }
        assert!(hit > 10, "label {k} not found above its column at x = {cx}");
    }
    // Row labels, "10" included, are whole and inside the image, left of the map.
    let left = view.px(Vec2::new(playable.left, playable.top))[0];
    let tw = 16.0 * label as f32;
    assert!(left - tw - 4.0 >= 0.0, "row label 10 would be cut off: map starts at x = {left}");
}

#[test]
fn rendering_is_deterministic_and_png_round_trips() {
    let s = Arc::new(builtin("2s3z_vlm").expect("scenario"));
    let mut env = Env::new(s, EnvConfig::default(), 3);
    for _ in 0..15 {
        env.step();
    }
    let mut a = Observer::new(ObsMode::Vlm, RenderConfig::default().with_vlm(640, 360));
    let mut b = Observer::new(ObsMode::Vlm, RenderConfig::default().with_vlm(640, 360));
    let (x, y) = (a.screenshot(&env, Team::One, &VlmOptions::default()), b.screenshot(&env, Team::One, &VlmOptions::default()));
    assert_eq!(x.as_raw(), y.as_raw());
    let mut png = Vec::new();
    x.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).expect("png");
    let back = image::load_from_memory(&png).expect("decode").to_rgb8();
    assert_eq!(back.as_raw(), x.as_raw());
}

#[test]
fn observation_modes() {
    let s = Arc::new(builtin("3m_vlm").expect("scenario"));
    let env = Env::new(s, EnvConfig::default(), 0);
    let cfg = RenderConfig::default().with_vlm(480, 270);
    match Observer::new(ObsMode::Rgb, cfg).observe(&env, Team::One, &VlmOptions::default()) {
        Observation::Rgb { screen, minimap } => {
            assert_eq!((screen.dimensions(), minimap.dimensions()), ((160, 120), (32, 32)));
        }
        other => panic!("{other:?}"),
    }
    match Observer::new(ObsMode::Hybrid, cfg).observe(&env, Team::One, &VlmOptions::default()) {
        Observation::Hybrid { screen, features, .. } => {
            assert_eq!(screen.dimensions(), (160, 120));
            assert_eq!((features.obs.len(), features.obs[0].len(), features.state.len()), (3, 30, 48));
        }
        other => panic!("{other:?}"),
    }
    match Observer::new(ObsMode::Vlm, cfg).observe(&env, Team::One, &VlmOptions::default()) {
        Observation::Vlm { screenshot, text, units } => {
            assert_eq!(screenshot.dimensions(), (480, 270));
            assert!(text.contains("Objective"));
            assert!(units.iter().any(|u| u.name == "Marine_1"));
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(Observer::new(ObsMode::Features, cfg).observe(&env, Team::One, &VlmOptions::default()), Observation::Features(_)));
}

/// Compares with a stored image: at most 0.5% of pixels may differ by more than 8 per channel.
/// `AVACRAFT_BLESS=1` rewrites the stored images after an intended change.
fn golden(name: &str, img: &RgbImage) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("golden").join(format!("{name}.png"));
    if std::env::var_os("AVACRAFT_BLESS").is_some() {
        img.save(&path).expect("bless");
        return;
    }
    let want = image::open(&path).unwrap_or_else(|e| panic!("{}: {e} (run with AVACRAFT_BLESS=1 to create it)", path.display())).to_rgb8();
    assert_eq!(want.dimensions(), img.dimensions(), "{name}");
    let bad = want.pixels().zip(img.pixels()).filter(|(a, b)| a.0.iter().zip(b.0.iter()).any(|(x, y)| x.abs_diff(*y) > 8)).count();
    let total = (img.width() * img.height()) as usize;
    assert!(bad * 200 <= total, "{name}: {bad} of {total} pixels differ from {}", path.display());
}

#[test]
fn golden_frames() {
    for (name, scenario, steps) in [("3m_start", "3m_vlm", 0), ("2s3z_fight", "2s3z_vlm", 20), ("2c_vs_64zg_fight", "2c_vs_64zg_vlm", 25)] {
        // The frames were pinned on the legacy game: these test drawing, not the battle.
        let s = Arc::new(builtin(scenario).expect("scenario").with_data(avacraft_engine::DataSet::Legacy).expect("legacy has every unit"));
        let mut env = Env::new(s, exact(), 1);
        for _ in 0..steps {
            env.step();
        }
        let mut fb = FrameBuilder::new();
        let mut cpu = CpuBackend::new();
        golden(&format!("{name}_screen"), &cpu.render(&fb.screen(env.world(), Team::One, 160, 120)));
        golden(&format!("{name}_minimap"), &cpu.render(&fb.minimap(env.world(), Team::One, 32, 32)));
        golden(&format!("{name}_vlm"), &cpu.render(&fb.vlm(env.world(), Team::One, 640, 360, &VlmOptions::default())));
    }
}

/// The wgpu back end. Without a Vulkan device the wgpu tests fail and say how to get one:
/// Mesa's CPU driver (lavapipe), which the README's set-up command installs.
fn gpu() -> avacraft_render::WgpuBackend {
    avacraft_render::WgpuBackend::new().unwrap_or_else(|e| {
        panic!(
            "the wgpu back end cannot be tested: {e}. It needs a Vulkan device; Mesa's CPU one \
             (lavapipe) is enough: `sudo apt-get install mesa-vulkan-drivers libvulkan1` (Debian), \
             part of the README's set-up"
        )
    })
}

#[test]
fn cpu_and_wgpu_back_ends_agree() {
    let mut gpu = gpu();
    for (scenario, steps) in [("3m_vlm", 12), ("2c_vs_64zg_vlm", 25), ("mixed_units", 30)] {
        let s = Arc::new(builtin(scenario).expect("scenario"));
        let mut env = Env::new(s, exact(), 1);
        for _ in 0..steps {
            env.step();
        }
        let mut fb = FrameBuilder::new();
        let highlight = VlmOptions { highlights: vec![avacraft_engine::UnitId::new(0)] };
        for scene in [
            fb.screen(env.world(), Team::One, 160, 120),
            fb.minimap(env.world(), Team::One, 32, 32),
            fb.vlm(env.world(), Team::One, 1280, 720, &highlight),
        ] {
            let a = CpuBackend::new().render(&scene);
            let b = gpu.render(&scene).expect("gpu frame");
            assert_eq!(a.dimensions(), b.dimensions());
            let differ = a.pixels().zip(b.pixels()).filter(|(x, y)| x.0.iter().zip(y.0.iter()).any(|(p, q)| p.abs_diff(*q) > 2)).count();
            let total = (a.width() * a.height()) as usize;
            assert!(differ * 500 <= total, "{scenario} {}x{}: {differ} of {total} pixels differ", a.width(), a.height());
        }
    }
    // A batch (one atlas, one submission) gives the same frames as one by one.
    let s = Arc::new(builtin("MMM_vs_MMM").expect("scenario"));
    let mut env = Env::new(s, exact(), 1);
    let mut fb = FrameBuilder::new();
    let mut scenes = Vec::new();
    for _ in 0..5 {
        env.step();
        scenes.push(fb.screen(env.world(), Team::One, 160, 120));
        scenes.push(fb.screen(env.world(), Team::Two, 160, 120));
    }
    let batch = gpu.render_batch(&scenes).expect("batch");
    assert_eq!(batch.len(), scenes.len());
    for (scene, img) in scenes.iter().zip(&batch) {
        assert_eq!(gpu.render(scene).expect("frame").as_raw(), img.as_raw());
    }
    // Nothing bleeds between frames of a batch: a disc at a frame's edge stays in its frame.
    let plain = avacraft_render::Scene::new(40, 30, avacraft_render::Rgba::rgb(10, 20, 30));
    let mut edge = plain.clone();
    edge.push(avacraft_render::Prim::Disc { c: [1.0, 15.0], r: 6.0, color: avacraft_render::Rgba::rgb(0, 255, 0) });
    edge.push(avacraft_render::Prim::Disc { c: [39.0, 15.0], r: 6.0, color: avacraft_render::Rgba::rgb(0, 255, 0) });
    let batch = gpu.render_batch(&[plain.clone(), edge.clone(), plain.clone()]).expect("batch");
    let flat = CpuBackend::new().render(&plain);
    assert_eq!(batch[0].as_raw(), flat.as_raw(), "frame 0 got paint from frame 1");
    assert_eq!(batch[2].as_raw(), flat.as_raw(), "frame 2 got paint from frame 1");
    assert_eq!(batch[1].as_raw(), CpuBackend::new().render(&edge).as_raw());
    // Ties: edges exactly on pixel centres follow the top-left rule on both back ends.
    let mut ties = avacraft_render::Scene::new(32, 32, avacraft_render::Rgba::rgb(0, 0, 0));
    let white = avacraft_render::Rgba::rgb(255, 255, 255);
    ties.push(avacraft_render::Prim::Line { a: [10.0, 2.0], b: [10.0, 30.0], width: 1.0, color: white });
    ties.push(avacraft_render::Prim::Line { a: [2.0, 20.0], b: [30.0, 20.0], width: 1.0, color: white });
    ties.push(avacraft_render::Prim::Polygon { points: vec![[20.5, 2.5], [28.5, 2.5], [28.5, 10.5], [20.5, 10.5]], color: white });
    ties.push(avacraft_render::Prim::Polygon { points: vec![[4.5, 24.5], [8.5, 28.5], [4.5, 28.5]], color: white });
    assert_eq!(gpu.render(&ties).expect("frame").as_raw(), CpuBackend::new().render(&ties).as_raw(), "tie-breaking differs");
    // Degenerate sizes render on both back ends without panicking, and agree.
    let s = Arc::new(builtin("pvz_ht").expect("scenario"));
    let env = Env::new(s, exact(), 1);
    for (w, h) in [(8, 8), (60, 20), (33, 200)] {
        let scene = FrameBuilder::new().vlm(env.world(), Team::One, w, h, &VlmOptions::default());
        assert_eq!(gpu.render(&scene).expect("frame").as_raw(), CpuBackend::new().render(&scene).as_raw(), "{w}x{h}");
    }
    assert!(gpu.render(&avacraft_render::Scene::new(0, 0, avacraft_render::Rgba::rgb(0, 0, 0))).is_err(), "0x0 is an error, not a panic");
    // Deterministic on the GPU too.
    let s = Arc::new(builtin("2s3z_vlm").expect("scenario"));
    let env = Env::new(s, exact(), 1);
    let scene = FrameBuilder::new().vlm(env.world(), Team::One, 640, 360, &VlmOptions::default());
    assert_eq!(gpu.render(&scene).expect("frame").as_raw(), gpu.render(&scene).expect("frame").as_raw());
}

#[test]
fn any_back_end_serves_observations() {
    // Auto picks wgpu where an adapter exists and the CPU elsewhere; both give the frame.
    let s = Arc::new(builtin("3m_vlm").expect("scenario"));
    let env = Env::new(s, EnvConfig::default(), 0);
    let backend = avacraft_render::BackendChoice::Auto.open().expect("auto never fails");
    let name = backend.name();
    let mut obs = Observer::new(ObsMode::Rgb, RenderConfig::default()).with_backend(backend);
    let mut cpu = Observer::new(ObsMode::Rgb, RenderConfig::default());
    let (a, b) = (obs.screen(&env, Team::One), cpu.screen(&env, Team::One));
    assert_eq!(a.dimensions(), (160, 120), "{name}");
    let differ = a.pixels().zip(b.pixels()).filter(|(x, y)| x.0.iter().zip(y.0.iter()).any(|(p, q)| p.abs_diff(*q) > 2)).count();
    assert!(differ * 500 <= 160 * 120, "{name}: {differ} pixels differ from the CPU back end");
    assert!(avacraft_render::BackendChoice::Cpu.open().expect("cpu").name() == "cpu");
}

#[test]
fn videos_are_valid_gifs_and_write_errors_surface() {
    let dir = std::env::temp_dir().join(format!("avacraft-video-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let path = dir.join("ep.gif");
    let s = Arc::new(builtin("3m_vlm").expect("scenario"));
    let mut env = Env::new(s, EnvConfig::default(), 0);
    let mut fb = FrameBuilder::new();
    let mut cpu = CpuBackend::new();
    let mut v = avacraft_render::VideoWriter::create(&path, 100).expect("create");
    for _ in 0..4 {
        env.step();
        v.push(&cpu.render(&fb.vlm(env.world(), Team::One, 320, 180, &VlmOptions::default()))).expect("frame");
    }
    assert_eq!(v.finish().expect("finish"), 4);
    use image::AnimationDecoder;
    let frames = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(std::fs::File::open(&path).expect("open")))
        .expect("gif")
        .into_frames()
        .collect_frames()
        .expect("frames");
    assert_eq!(frames.len(), 4);
    let _ = std::fs::remove_dir_all(&dir);
    // A full disk (Linux's /dev/full): the error reaches the caller instead of a silently
    // truncated file.
    let full = std::path::Path::new("/dev/full");
    assert!(full.exists(), "/dev/full, the full disk this test writes to, is missing: every Linux system has it");
    let img = RgbImage::new(64, 64);
    let r = avacraft_render::VideoWriter::create(full, 100).and_then(|mut v| v.push(&img).and_then(|_| v.finish()));
    assert!(r.is_err(), "writing to /dev/full must fail");
}

#[test]
fn attack_lines_do_not_reveal_units_in_fog() {
    // A visible enemy Marine shoots an own unit (always seen); a hidden one is drawn nowhere,
    // and no line leads from the visible shooter into fog.
    let s =
        load(&arena("pvp", &[("Marine", 1, 10.0, 16.0), ("Marine", 2, 14.5, 16.0), ("Medivac", 2, 15.0, 17.0), ("Marine", 2, 25.0, 16.0)]));
    let mut env = Env::new(s, exact(), 0);
    env.step();
    let scene = FrameBuilder::new().vlm(env.world(), Team::One, 1280, 720, &VlmOptions::default());
    let (view, ..) = avacraft_render::vlm_layout(env.world(), 1280, 720);
    let hidden = view.px(Vec2::new(25.0, 16.0));
    for p in &scene.prims {
        if let avacraft_render::Prim::Line { a, b, .. } = p {
            for q in [a, b] {
                assert!((q[0] - hidden[0]).abs() > 3.0 || (q[1] - hidden[1]).abs() > 3.0, "a line ends at a unit in fog");
            }
        }
    }
}

#[test]
fn storms_and_force_fields_are_drawn_where_they_are() {
    let units = [("HighTemplar", 1, 8.0, 16.0, "energy = 200"), ("Sentry", 1, 8.0, 12.0, ""), ("Zealot", 2, 28.0, 28.0, "")];
    let toml = arena_units("pvp", &units, "upgrades = [{ team = 1, name = \"PsiStormTech\" }]");
    let mut env = Env::new(load(&toml), exact_loop(), 1);
    let cast = |ability, x, y| avacraft_engine::Command::Ability {
        ability,
        target: avacraft_engine::AbilityTarget::Point { to: Vec2::new(x, y) },
    };
    env.submit(
        Team::One,
        &[
            avacraft_engine::Action::new(uid(0), cast(avacraft_engine::Ability::PsionicStorm, 14.0, 16.0)),
            avacraft_engine::Action::new(uid(1), cast(avacraft_engine::Ability::ForceField, 14.0, 10.0)),
        ],
    );
    let (w, h) = (320, 320);
    let mut fb = FrameBuilder::new();
    let before = CpuBackend::new().render(&fb.screen(env.world(), Team::One, w, h));
    env.step();
    let after = CpuBackend::new().render(&fb.screen(env.world(), Team::One, w, h));
    let view = MapView::fit(env.world(), [0.0, 0.0, w as f32, h as f32]);
    let px = |img: &RgbImage, p: Vec2| {
        let [x, y] = view.px(p);
        img.get_pixel(x as u32, y as u32).0
    };
    let (s0, s1) = (px(&before, Vec2::new(14.0, 16.0)), px(&after, Vec2::new(14.0, 16.0)));
    assert!(s1[2] > s0[2] + 40 && s1[0] > s0[0] + 25, "storm tints purple: {s0:?} -> {s1:?}");
    let (f0, f1) = (px(&before, Vec2::new(14.0, 10.0)), px(&after, Vec2::new(14.0, 10.0)));
    assert!(f1[1] > f0[1] + 40 && f1[2] > f0[2] + 40, "force field tints light blue: {f0:?} -> {f1:?}");
    let far = Vec2::new(20.0, 22.0);
    assert_eq!(px(&before, far), px(&after, far), "nothing drawn elsewhere");
}
