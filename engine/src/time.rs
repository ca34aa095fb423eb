//! The game loop is the only clock. StarCraft II advances 16 loops per game second at
//! "Normal" speed; the ladder's "Faster" speed shows 22.4 loops per real second. Every
//! duration and rate in the engine is stored per loop; these helpers convert at the edges.

/// Game loops per second of LotV ("Faster") game time, the time base of the paper.
pub const LOOPS_PER_SECOND: f32 = 22.4;
/// Game loops per Normal-speed game second (python-sc2's data file uses this base).
pub const LOOPS_PER_NORMAL_SECOND: f32 = 16.0;
/// SMAC's `step_mul`: one environment step is this many game loops.
pub const DEFAULT_STEP_MUL: std::num::NonZeroU32 = std::num::NonZeroU32::new(8).expect("8 is not zero");
/// The paper's episode limit: 300 s of game time.
pub const DEFAULT_TIME_LIMIT_S: f32 = 300.0;

/// Game seconds ("Faster") to loops, rounded to the nearest loop.
pub fn seconds_to_loops(s: f32) -> u32 {
    (s * LOOPS_PER_SECOND).round().max(0.0) as u32
}

/// Loops to game seconds ("Faster").
pub fn loops_to_seconds(loops: u32) -> f32 {
    loops as f32 / LOOPS_PER_SECOND
}

/// A Normal-speed duration (python-sc2 data) to loops, unrounded.
pub const fn normal_s(s: f32) -> f32 {
    s * LOOPS_PER_NORMAL_SECOND
}

/// A Normal-speed rate (per Normal second) to a per-loop rate.
pub const fn per_normal_s(rate: f32) -> f32 {
    rate / LOOPS_PER_NORMAL_SECOND
}
