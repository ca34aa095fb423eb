//! The battle as Foxglove messages: what [`LiveView`] publishes after every step, and what
//! recordings hold on the same channels ([`Frame`], so an MCAP writer needs no server).
//!
//! Time on every channel is game time, not the wall clock: episode k starts where episode
//! k-1 ended (plus one second), so a session's timeline only moves forward and a replay
//! stamps what the live run stamped.

use crate::channels::LiveChannel;
use crate::ros2;
use crate::server::LiveServer;
use avacraft_engine::{Env, Order, Outcome, Team, UnitId, World, loops_to_seconds};
use avacraft_msgs::encode;
use avacraft_render::{CpuBackend, FrameBuilder, MapView};
use foxglove::Encode;
use foxglove::schemas::{
    CircleAnnotation, Color, CylinderPrimitive, ImageAnnotations, Log, Point2, Pose, Quaternion, RawImage, SceneEntity,
    SceneEntityDeletion, SceneUpdate, TextAnnotation, TextPrimitive, Timestamp, Vector3, log::Level, scene_entity_deletion,
};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Nanoseconds per game loop (22.4 loops a second at the "faster" game speed).
const NS_PER_LOOP: u64 = 44_642_857;

/// Image sizes of the live view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewSize {
    pub screen: (u32, u32),
    pub minimap: u32,
}

impl Default for ViewSize {
    fn default() -> Self {
        ViewSize { screen: (640, 480), minimap: 256 }
    }
}

/// One step's messages, encoded, with their channel and log time.
pub type Frame = Vec<(LiveChannel, u64, Vec<u8>)>;

fn color(r: u8, g: u8, b: u8, a: f64) -> Color {
    Color { r: f64::from(r) / 255.0, g: f64::from(g) / 255.0, b: f64::from(b) / 255.0, a }
}

fn team_color(team: Team, a: f64) -> Color {
    let c = if team == Team::One { avacraft_render::OWN } else { avacraft_render::ENEMY };
    color(c.0[0], c.0[1], c.0[2], a)
}

fn stamp(ns: u64) -> Timestamp {
    let sec = u32::try_from(ns / 1_000_000_000).unwrap_or(u32::MAX);
    Timestamp::new(sec, (ns % 1_000_000_000) as u32)
}

fn encoded<T: Encode>(m: &T) -> Vec<u8> {
    let mut buf = Vec::with_capacity(m.encoded_len().unwrap_or(256));
    // Encoding into a growable buffer cannot run out of room.
    let _ = m.encode(&mut buf);
    buf
}

/// What an order says, for the log.
fn order_text(world: &World, order: &Order) -> String {
    let name = |id: UnitId| world.unit(id).map_or_else(|| format!("#{}", id.tag()), |u| format!("{} #{}", u.name(), id.tag()));
    match order {
        Order::Idle => "idle".into(),
        Order::Hold => "hold".into(),
        Order::Move { to } => format!("move to ({:.1}, {:.1})", to.x, to.y),
        Order::AttackMove { to } => format!("attack-move to ({:.1}, {:.1})", to.x, to.y),
        Order::Attack { target } => format!("attack {}", name(*target)),
    }
}

/// Builds the live view's messages from the environment, step after step.
#[derive(Debug)]
pub struct Framer {
    size: ViewSize,
    wire: Wire,
    frames: FrameBuilder,
    cpu: CpuBackend,
    /// Session time at the current episode's loop 0.
    base: u64,
    episode: u64,
    orders: BTreeMap<UnitId, String>,
    /// The seed and loop of the last frame.
    last: Option<(u64, u32)>,
}

impl Framer {
    /// A framer of Foxglove's protobuf messages, as the live server sends them.
    pub fn new(size: ViewSize) -> Framer {
        Framer::with_wire(size, Wire::Foxglove)
    }

    /// A framer whose messages go out on `wire`.
    pub fn with_wire(size: ViewSize, wire: Wire) -> Framer {
        Framer {
            size,
            wire,
            frames: FrameBuilder::new(),
            cpu: CpuBackend::new(),
            base: NS_PER_LOOP * 22,
            episode: 0,
            orders: BTreeMap::new(),
            last: None,
        }
    }

    /// Session time of the environment's current loop (as of the last frame's episode).
    pub fn now(&self, env: &Env) -> u64 {
        self.base + u64::from(env.world().tick()) * NS_PER_LOOP
    }

    /// The episodes framed before the current one.
    pub fn episode(&self) -> u64 {
        self.episode
    }

    /// Notes where the environment is: a new episode (its loop counter went back, or its
    /// seed changed) starts one second of session time after the previous one's last loop.
    fn follow(&mut self, env: &Env) {
        let (seed, tick) = (env.seed(), env.world().tick());
        if let Some((s, t)) = self.last
            && (s != seed || tick < t)
        {
            self.base += (u64::from(t) + 22) * NS_PER_LOOP;
            self.episode += 1;
            self.orders.clear();
        }
        self.last = Some((seed, tick));
    }

    /// One step's messages on the channels `want` accepts (the images are drawn only when
    /// wanted).
    pub fn frame(&mut self, env: &Env, want: &dyn Fn(LiveChannel) -> bool) -> Frame {
        self.follow(env);
        let t = self.now(env);
        let world = env.world();
        let mut out = Vec::new();
        let acting = self.order_changes(env);
        let (w, h) = self.size.screen;
        if want(LiveChannel::Screen) {
            let img = self.cpu.render(&self.frames.screen(world, Team::One, w, h));
            out.push((LiveChannel::Screen, t, self.wire.image(&raw_image(t, "screen", img))));
        }
        if want(LiveChannel::Minimap) {
            let m = self.size.minimap;
            let img = self.cpu.render(&self.frames.minimap(world, Team::One, m, m));
            out.push((LiveChannel::Minimap, t, self.wire.image(&raw_image(t, "minimap", img))));
        }
        if want(LiveChannel::Annotations) {
            let a = annotations(world, t, (w, h), &acting);
            out.push((LiveChannel::Annotations, t, if self.wire == Wire::Ros2 { encode(&ros2::annotations(&a)) } else { encoded(&a) }));
        }
        if want(LiveChannel::Scene) {
            let s = scene(world, t, &acting);
            out.push((LiveChannel::Scene, t, if self.wire == Wire::Ros2 { encode(&ros2::scene(&s)) } else { encoded(&s) }));
        }
        if want(LiveChannel::Log) {
            for (id, text) in &acting {
                let team = world.unit(*id).map_or(Team::One, |u| u.team);
                let name = format!("team{}/{}", team.index() + 1, world.unit(*id).map_or_else(String::new, |u| u.name()));
                out.push((LiveChannel::Log, t, self.wire.log(&log(t, Level::Info, &name, text))));
            }
        }
        if want(LiveChannel::Status) {
            let json = status(env, self.episode);
            out.push((LiveChannel::Status, t, if self.wire == Wire::Ros2 { ros2::status(json) } else { json.into_bytes() }));
        }
        out
    }

    /// Units of the agent teams whose order changed since the last frame, and the new order.
    fn order_changes(&mut self, env: &Env) -> Vec<(UnitId, String)> {
        let world = env.world();
        let mut out = Vec::new();
        for u in world.units() {
            if !u.alive || !env.is_agent_team(u.team) {
                continue;
            }
            let text = order_text(world, &u.order);
            if self.orders.get(&u.id) != Some(&text) {
                self.orders.insert(u.id, text.clone());
                out.push((u.id, text));
            }
        }
        out
    }
}

fn raw_image(t: u64, frame_id: &str, img: avacraft_render::RgbImage) -> RawImage {
    let (width, height) = img.dimensions();
    RawImage {
        timestamp: Some(stamp(t)),
        frame_id: frame_id.into(),
        width,
        height,
        encoding: "rgb8".into(),
        step: width * 3,
        data: img.into_raw().into(),
    }
}

/// A Log message at `t`.
pub fn log(t: u64, level: Level, name: &str, text: &str) -> Log {
    Log { timestamp: Some(stamp(t)), level: level as i32, message: text.into(), name: name.into(), file: String::new(), line: 0 }
}

/// A log line as the log channel's bytes on `wire`, for writers other than the server
/// (recordings).
pub fn log_bytes(wire: Wire, t: u64, level: Level, name: &str, text: &str) -> Vec<u8> {
    wire.log(&log(t, level, name, text))
}

/// How the live view's messages are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wire {
    /// Foxglove's protobuf messages (and the status as JSON): the live server's.
    Foxglove,
    /// ROS 2 messages in CDR (see [`crate::ros2_type`]): recordings'.
    Ros2,
}

impl Wire {
    fn image(self, m: &RawImage) -> Vec<u8> {
        match self {
            Wire::Foxglove => encoded(m),
            Wire::Ros2 => encode(&ros2::image(m)),
        }
    }

    fn log(self, m: &Log) -> Vec<u8> {
        match self {
            Wire::Foxglove => encoded(m),
            Wire::Ros2 => encode(&ros2::log(m)),
        }
    }
}

/// The episode's status as JSON (the status channel's schema).
pub fn status(env: &Env, episode: u64) -> String {
    let w = env.world();
    let result = match env.outcome() {
        None => "running",
        Some(Outcome::Win) => "win",
        Some(Outcome::Loss) => "loss",
        Some(Outcome::Draw) => "draw",
    };
    serde_json::json!({
        "scenario": env.scenario().name,
        "seed": env.seed(),
        "episode": episode,
        "step": env.steps(),
        "game_loop": w.tick(),
        "game_seconds": loops_to_seconds(w.tick()),
        "units_left": [w.alive(Team::One).count(), w.alive(Team::Two).count()],
        "result": result,
    })
    .to_string()
}

fn label(u: &avacraft_engine::Unit) -> String {
    if u.max_shield > 0.0 {
        format!("{} #{} {:.0}+{:.0}", u.name(), u.id.tag(), u.hp, u.shield)
    } else {
        format!("{} #{} {:.0}", u.name(), u.id.tag(), u.hp)
    }
}

/// Rings and labels over the screen image (its pixel coordinates), for team 1's view.
fn annotations(world: &World, t: u64, (w, h): (u32, u32), acting: &[(UnitId, String)]) -> ImageAnnotations {
    let view = MapView::fit(world, [0.0, 0.0, w as f32, h as f32]);
    let mut a = ImageAnnotations { timestamp: Some(stamp(t)), ..ImageAnnotations::default() };
    for u in world.units().iter().filter(|u| u.alive && world.visible_to(Team::One, u.id)) {
        let [x, y] = view.px(u.pos);
        let r = f64::from((u.radius() * view.scale()).max(3.0));
        let marked = acting.iter().any(|(id, _)| *id == u.id);
        a.circles.push(CircleAnnotation {
            timestamp: Some(stamp(t)),
            position: Some(Point2 { x: f64::from(x), y: f64::from(y) }),
            diameter: 2.0 * r + 4.0,
            thickness: if marked { 3.0 } else { 1.5 },
            fill_color: Some(color(0, 0, 0, 0.0)),
            outline_color: Some(if marked { color(255, 220, 0, 1.0) } else { team_color(u.team, 1.0) }),
            ..CircleAnnotation::default()
        });
        a.texts.push(TextAnnotation {
            timestamp: Some(stamp(t)),
            position: Some(Point2 { x: f64::from(x) + r + 3.0, y: f64::from(y) - r }),
            text: label(u),
            font_size: 10.0,
            text_color: Some(color(255, 255, 255, 1.0)),
            background_color: Some(color(0, 0, 0, 0.5)),
            ..TextAnnotation::default()
        });
    }
    a
}

/// Every unit as a cylinder (height by health, team colour, yellow when it just got an
/// order) with its label, in map coordinates (frame `map`, one cell a metre).
fn scene(world: &World, t: u64, acting: &[(UnitId, String)]) -> SceneUpdate {
    let pose = |x: f32, y: f32, z: f64| Pose {
        position: Some(Vector3 { x: f64::from(x), y: f64::from(y), z }),
        orientation: Some(Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }),
    };
    let mut entities = Vec::new();
    for u in world.units().iter().filter(|u| u.alive) {
        let r = f64::from(u.radius());
        let z0 = if u.flying() { 3.0 } else { 0.0 };
        let height = 0.3 + 1.2 * f64::from(u.hp_fraction());
        let marked = acting.iter().any(|(id, _)| *id == u.id);
        let mut cylinders = vec![CylinderPrimitive {
            pose: Some(pose(u.pos.x, u.pos.y, z0 + height / 2.0)),
            size: Some(Vector3 { x: 2.0 * r, y: 2.0 * r, z: height }),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: Some(team_color(u.team, if world.visible_to(Team::One, u.id) { 0.9 } else { 0.35 })),
        }];
        if marked {
            cylinders.push(CylinderPrimitive {
                pose: Some(pose(u.pos.x, u.pos.y, z0 + 0.02)),
                size: Some(Vector3 { x: 2.0 * r + 0.6, y: 2.0 * r + 0.6, z: 0.04 }),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: Some(color(255, 220, 0, 0.9)),
            });
        }
        entities.push(SceneEntity {
            timestamp: Some(stamp(t)),
            frame_id: "map".into(),
            id: format!("unit-{}", u.id.tag()),
            frame_locked: true,
            cylinders,
            texts: vec![TextPrimitive {
                pose: Some(pose(u.pos.x, u.pos.y, z0 + height + 0.6)),
                billboard: true,
                font_size: 12.0,
                scale_invariant: true,
                color: Some(color(255, 255, 255, 1.0)),
                text: label(u),
            }],
            ..SceneEntity::default()
        });
    }
    // The dead leave the scene: every entity is replaced each step.
    let all = SceneEntityDeletion { timestamp: Some(stamp(t)), r#type: scene_entity_deletion::Type::All as i32, id: String::new() };
    SceneUpdate { deletions: vec![all], entities }
}

/// A live view: a [`Framer`] whose frames go to a [`LiveServer`]'s clients.
#[derive(Debug)]
pub struct LiveView {
    server: Arc<LiveServer>,
    framer: Framer,
    now: Arc<AtomicU64>,
}

/// Writes lines to a live view's log channel from another thread (AVA's model calls), at
/// the session time of the view's last step.
#[derive(Clone, Debug)]
pub struct LiveLog {
    server: Arc<LiveServer>,
    now: Arc<AtomicU64>,
}

impl LiveLog {
    pub fn line(&self, level: Level, name: &str, text: &str) {
        let t = self.now.load(Ordering::Relaxed);
        self.server.publish(LiveChannel::Log, t, &encoded(&log(t, level, name, text)));
    }
}

impl LiveView {
    pub fn new(server: LiveServer, size: ViewSize) -> LiveView {
        LiveView { server: Arc::new(server), framer: Framer::new(size), now: Arc::new(AtomicU64::new(0)) }
    }

    pub fn server(&self) -> &LiveServer {
        &self.server
    }

    pub fn logger(&self) -> LiveLog {
        LiveLog { server: Arc::clone(&self.server), now: Arc::clone(&self.now) }
    }

    /// Publishes the environment as it is now (what no client watches is not drawn).
    pub fn step(&mut self, env: &Env) {
        let server = &self.server;
        let frame = self.framer.frame(env, &|c| server.wanted(c));
        self.now.store(self.framer.now(env), Ordering::Relaxed);
        for (ch, t, bytes) in frame {
            server.publish(ch, t, &bytes);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use avacraft_engine::{EnvConfig, Scenario};
    use foxglove::Decode;

    type R = Result<(), Box<dyn std::error::Error>>;

    #[test]
    fn a_step_is_framed_on_every_channel_and_decodes() -> R {
        let scenario = Arc::new(Scenario::load("3m_vlm")?);
        let mut env = Env::new(Arc::clone(&scenario), EnvConfig::default(), 3);
        let mut framer = Framer::new(ViewSize { screen: (160, 120), minimap: 64 });
        env.step();
        let frame = framer.frame(&env, &|_| true);
        let on = |c: LiveChannel| frame.iter().filter(move |(ch, ..)| *ch == c);
        let (_, t, screen) = on(LiveChannel::Screen).next().ok_or("no screen")?;
        let img = RawImage::decode(&screen[..])?;
        assert_eq!((img.width, img.height, img.encoding.as_str(), img.step, img.data.len()), (160, 120, "rgb8", 480, 160 * 120 * 3));
        assert_eq!(img.timestamp.map(|s| s.total_nanos()), Some(*t));
        let (_, _, scene) = on(LiveChannel::Scene).next().ok_or("no scene")?;
        let scene = SceneUpdate::decode(&scene[..])?;
        assert_eq!(scene.entities.len(), env.world().units().iter().filter(|u| u.alive).count());
        assert!(scene.entities.iter().all(|e| e.frame_id == "map" && !e.cylinders.is_empty() && e.texts.len() == 1));
        let (_, _, ann) = on(LiveChannel::Annotations).next().ok_or("no annotations")?;
        let ann = ImageAnnotations::decode(&ann[..])?;
        assert_eq!(ann.circles.len(), ann.texts.len());
        assert!(!ann.circles.is_empty());
        // Every agent got its first order: one log line each, and none on the next step
        // unless an order changed.
        let logs = on(LiveChannel::Log).count();
        assert_eq!(logs, env.agents(Team::One).len());
        let (_, _, st) = on(LiveChannel::Status).next().ok_or("no status")?;
        let st: serde_json::Value = serde_json::from_slice(st)?;
        assert_eq!((st["scenario"].as_str(), st["step"].as_u64(), st["result"].as_str()), (Some("3m_vlm"), Some(1), Some("running")));
        // Only wanted channels are framed.
        let only = framer.frame(&env, &|c| c == LiveChannel::Status);
        assert!(only.iter().all(|(c, ..)| *c == LiveChannel::Status) && only.len() == 1);
        Ok(())
    }

    /// Recordings' wire: the same step as ROS 2 messages, each decoding as its channel's ROS 2
    /// type with what the protobuf one carries.
    #[test]
    fn the_ros2_wire_carries_the_same_step() -> R {
        use avacraft_msgs::foxglove_msgs as fm;
        use avacraft_msgs::{Image, StdString, decode};
        let scenario = Arc::new(Scenario::load("3m_vlm")?);
        let mut env = Env::new(Arc::clone(&scenario), EnvConfig::default(), 3);
        env.step();
        let size = ViewSize { screen: (160, 120), minimap: 64 };
        let fox = Framer::new(size).frame(&env, &|_| true);
        let ros = Framer::with_wire(size, Wire::Ros2).frame(&env, &|_| true);
        assert_eq!(fox.iter().map(|(c, t, _)| (*c, *t)).collect::<Vec<_>>(), ros.iter().map(|(c, t, _)| (*c, *t)).collect::<Vec<_>>());
        let on = |f: &Frame, c: LiveChannel| f.iter().find(|(ch, ..)| *ch == c).map(|(_, t, d)| (*t, d.clone())).ok_or("missing");
        let (t, img) = on(&ros, LiveChannel::Screen)?;
        let img: Image = decode(&img)?;
        let want = RawImage::decode(&on(&fox, LiveChannel::Screen)?.1[..])?;
        assert_eq!((img.width, img.height, img.step, img.encoding.as_str()), (want.width, want.height, want.step, "rgb8"));
        assert_eq!(img.data, want.data.to_vec());
        assert_eq!(u64::try_from(img.header.stamp.sec)? * 1_000_000_000 + u64::from(img.header.stamp.nanosec), t);
        let scene: fm::SceneUpdate = decode(&on(&ros, LiveChannel::Scene)?.1)?;
        let want = SceneUpdate::decode(&on(&fox, LiveChannel::Scene)?.1[..])?;
        assert_eq!(scene.entities.len(), want.entities.len());
        for (a, b) in scene.entities.iter().zip(&want.entities) {
            assert_eq!((a.id.as_str(), a.cylinders.len(), a.texts.len()), (b.id.as_str(), b.cylinders.len(), b.texts.len()));
            assert_eq!(a.texts[0].text, b.texts[0].text);
        }
        let ann: fm::ImageAnnotations = decode(&on(&ros, LiveChannel::Annotations)?.1)?;
        let want = ImageAnnotations::decode(&on(&fox, LiveChannel::Annotations)?.1[..])?;
        assert_eq!((ann.circles.len(), ann.texts.len()), (want.circles.len(), want.texts.len()));
        let line: fm::Log = decode(&on(&ros, LiveChannel::Log)?.1)?;
        assert_eq!(line.level, fm::Log::INFO);
        let st: StdString = decode(&on(&ros, LiveChannel::Status)?.1)?;
        assert_eq!(st.data.as_bytes(), &on(&fox, LiveChannel::Status)?.1[..]);
        Ok(())
    }

    #[test]
    fn session_time_only_moves_forward_across_episodes() -> R {
        let scenario = Arc::new(Scenario::load("3m_vlm")?);
        let mut env = Env::new(Arc::clone(&scenario), EnvConfig::default(), 3);
        let mut framer = Framer::new(ViewSize { screen: (32, 24), minimap: 16 });
        let mut last = 0;
        for seed in [3, 4, 4] {
            env.reset(seed);
            for _ in 0..5 {
                env.step();
                let t = framer.frame(&env, &|c| c == LiveChannel::Status)[0].1;
                assert!(t > last, "seed {seed}: {t} after {last}");
                last = t;
            }
        }
        assert_eq!(framer.episode(), 2);
        Ok(())
    }
}
