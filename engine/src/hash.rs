//! A stable 64-bit hash of the simulation state (FNV-1a over the exact bits of each value), so two runs
//! can be compared for byte-identical trajectories without storing them, and a replay can name
//! the first step where it leaves a recording.
//!
//! The hash covers everything that evolves and can change what happens next: the RNG's
//! position, every field of every unit (buffs, timers, cooldowns, channels, morphs, targets,
//! waypoints), area effects, pending casts, vision, counters. Structs are destructured field
//! by field, so adding a field to `World`, `Unit`, `Status`, `AreaEffect` or `PendingCast`
//! does not compile until it is hashed here or listed as derived (with the reason).
//! Iteration is over vectors and `BTreeMap`s only, never hash maps.

use crate::ability::{AbilityTarget, AreaEffect, Channel, PendingCast, Status};
use crate::geom::Vec2;
use crate::ids::UnitId;
use crate::world::{Order, Shot, TeamStats, Unit, World};
use rand_chacha::ChaCha8Rng;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    /// One 32-bit word at a time (FNV-1a over words, not bytes: four times fewer rounds).
    pub fn u32(&mut self, v: u32) {
        self.0 ^= v as u64;
        self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
    }
    pub fn u64(&mut self, v: u64) {
        self.u32(v as u32);
        self.u32((v >> 32) as u32);
    }
    pub fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    pub fn finish(&self) -> u64 {
        self.0
    }
    pub(crate) fn vec2(&mut self, v: Vec2) {
        self.f32(v.x);
        self.f32(v.y);
    }
    /// A unit reference; 0 stands for none (tags start at 1).
    pub(crate) fn unit(&mut self, id: Option<UnitId>) {
        self.u32(id.map_or(0, UnitId::tag));
    }
    /// Booleans packed 32 to a word, with the count first so lengths cannot alias.
    pub(crate) fn bools(&mut self, v: impl ExactSizeIterator<Item = bool>) {
        self.u32(v.len() as u32);
        let mut word = 0u32;
        for (i, b) in v.enumerate() {
            word |= (b as u32) << (i % 32);
            if i % 32 == 31 {
                self.u32(word);
                word = 0;
            }
        }
        self.u32(word);
    }
    /// Where a ChaCha8 stream stands: its key, stream and word position (the next draw
    /// follows from these alone).
    pub(crate) fn rng(&mut self, r: &ChaCha8Rng) {
        for w in r.get_seed().chunks_exact(4) {
            self.u32(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
        }
        self.u64(r.get_stream());
        let pos = r.get_word_pos();
        self.u64(pos as u64);
        self.u64((pos >> 64) as u64);
    }
}

impl World {
    /// Hash of the full state: the loop, the RNG's position, the rules and upgrades, every
    /// unit (all fields, abilities' status included), area effects, pending casts, vision,
    /// counters and the last loop's shots. Caches and buffers that are recomputed from these
    /// before use are left out (see the destructuring below).
    pub fn state_hash(&self) -> u64 {
        let mut h = Fnv::default();
        let World {
            tick,
            rng,
            rules,
            upgrades,
            vis,
            dirty,
            dirty_next,
            stats,
            shots,
            units,
            effects,
            pending_casts,
            any_guarded,
            deaths_pending,
            missiles,
            data,
            // Fixed by the scenario, which a recording carries as text.
            terrain: _,
            max_sight: _,
            reach_radius: _,
            max_step: _,
            cloak_possible: _,
            // Derived from unit positions by `refresh` before anything reads them.
            heights: _,
            grid: _,
            team_grid: _,
            // Flow fields are a pure function of terrain and goal; eviction only costs time.
            paths: _,
            // Per-loop scratch buffers, cleared before use.
            orca: _,
            scratch: _,
            scratch_damage: _,
        } = self;
        h.u32(*tick);
        h.rng(rng);
        let crate::world::Rules { full_vision, cooldown_jitter, auto_acquire, abilities, weapon_period, melee_surround } = *rules;
        h.bools([full_vision, cooldown_jitter, auto_acquire[0], auto_acquire[1], abilities].into_iter());
        // Hashed only when not the default, so every world made before the switch keeps its hash.
        if weapon_period != crate::world::WeaponPeriod::Attack {
            h.u32(weapon_period as u32);
        }
        if melee_surround {
            h.u32(0x5a);
        }
        for team in upgrades {
            h.u32(team.len() as u32);
            team.iter().for_each(|&u| h.u32(u as u32));
        }
        for v in vis {
            h.bools(v.iter().copied());
        }
        h.bools(dirty.iter().copied());
        h.bools(dirty_next.iter().copied());
        h.bools([*any_guarded, *deaths_pending].into_iter());
        stats.iter().for_each(|s| hash_stats(&mut h, s));
        h.u32(shots.len() as u32);
        for &Shot { from, to, impact } in shots {
            h.unit(Some(from));
            h.unit(Some(to));
            h.vec2(impact);
        }
        h.u32(units.len() as u32);
        units.iter().for_each(|u| hash_unit(&mut h, u));
        h.u32(effects.len() as u32);
        effects.iter().for_each(|e| hash_effect(&mut h, e));
        h.u32(pending_casts.len() as u32);
        pending_casts.iter().for_each(|c| hash_cast(&mut h, c));
        // Hashed only where they can differ from the legacy game, so that its hashes (golden
        // trajectories, earlier recordings) are what they were before data sets existed.
        if *data != crate::units::DataSet::Legacy {
            h.u32(0xDA7A_0000 | data.code() as u32);
        }
        if !missiles.is_empty() {
            h.u32(missiles.len() as u32);
            for m in missiles {
                h.unit(Some(m.attacker));
                h.unit(Some(m.target));
                h.vec2(m.pos);
                h.f32(m.weapon.damage);
            }
        }
        h.finish()
    }
}

fn hash_stats(h: &mut Fnv, s: &TeamStats) {
    let TeamStats { damage_dealt, healing_done, kills, attacks, abilities } = s;
    h.f32(*damage_dealt);
    h.f32(*healing_done);
    h.u32(*kills);
    h.u32(*attacks);
    h.u32(abilities.len() as u32);
    for (&a, &n) in abilities {
        h.u32(a as u32);
        h.u32(n);
    }
}

fn hash_order(h: &mut Fnv, o: Order) {
    match o {
        Order::Idle => h.u32(0),
        Order::Hold => h.u32(1),
        Order::Move { to } => {
            h.u32(2);
            h.vec2(to);
        }
        Order::AttackMove { to } => {
            h.u32(3);
            h.vec2(to);
        }
        Order::Attack { target } => {
            h.u32(4);
            h.unit(Some(target));
        }
    }
}

fn hash_unit(h: &mut Fnv, u: &Unit) {
    let Unit {
        // Its index in `units`, hashed by position.
        id: _,
        team,
        kind,
        body,
        radius,
        ordinal,
        pos,
        vel,
        heading,
        look,
        hp,
        max_hp,
        shield,
        max_shield,
        energy,
        cooldown,
        speed,
        order,
        target,
        last_damaged,
        alive,
        activity,
        was_healing,
        last_attacker,
        blocked_loops,
        waypoint,
        base_speed,
        status,
        swing,
        aim,
        // The kind's row in the world's data set, hashed with the world.
        spec: _,
    } = u;
    // A turret exists only in the game's data sets: hashed for the units that have one.
    if u.spec.weapons.iter().any(|w| w.timing.turn > 0.0) {
        h.f32(*aim);
    }
    // An attack in progress exists only under weapon timing: hashed when there is one.
    if let Some(sw) = swing {
        h.unit(Some(sw.target));
        h.u32(sw.weapon as u32 | (sw.fired as u32) << 8);
        h.u32(sw.fire_at);
        h.u32(sw.done_at);
        h.f32(sw.cooldown_before);
    }
    h.u32(team.index() as u32 | (*kind as u32) << 1 | (*body as u32) << 16 | (*activity as u32) << 20);
    h.u32(*ordinal as u32 | (*blocked_loops as u32) << 16);
    h.bools([*alive, *was_healing].into_iter());
    for v in [*radius, *hp, *max_hp, *shield, *max_shield, *energy, *cooldown, *speed, *base_speed] {
        h.f32(v);
    }
    h.vec2(*pos);
    h.vec2(*vel);
    h.vec2(*heading);
    // Only turned under SMACv2's conic fields of view: hashed when turned, so every other
    // run's hashes are what they were before the field existed.
    if *look != crate::world::LOOK_EAST {
        h.vec2(*look);
    }
    hash_order(h, *order);
    h.unit(*target);
    h.unit(*last_attacker);
    h.u32(*last_damaged);
    match waypoint {
        None => h.u32(0),
        Some((a, b, n)) => {
            h.u32(1);
            h.vec2(*a);
            h.vec2(*b);
            h.u32(*n);
        }
    }
    hash_status(h, status);
}

fn hash_status(h: &mut Fnv, st: &Status) {
    let Status {
        stim_until,
        slow_until,
        boost_until,
        guardian_until,
        barrier_until,
        barrier_hp,
        cloaked,
        lifted_until,
        hot_until,
        hot_per_loop,
        morph,
        channel,
        storm_next,
        cooldown_until,
        guarded,
        detected,
        revealed_until,
        quiet_after,
    } = st;
    for v in [
        stim_until,
        slow_until,
        boost_until,
        guardian_until,
        barrier_until,
        lifted_until,
        hot_until,
        storm_next,
        cooldown_until,
        revealed_until,
        quiet_after,
    ] {
        h.u32(*v);
    }
    h.f32(*barrier_hp);
    h.f32(*hot_per_loop);
    h.bools([*cloaked, *guarded, *detected].into_iter());
    match morph {
        None => h.u32(0),
        Some((into, done)) => {
            h.u32(1 | (*into as u32) << 1);
            h.u32(*done);
        }
    }
    match channel {
        None => h.u32(0),
        Some(Channel::Snipe { target, done }) => {
            h.u32(1);
            h.unit(Some(*target));
            h.u32(*done);
        }
        Some(Channel::Graviton { target }) => {
            h.u32(2);
            h.unit(Some(*target));
        }
    }
}

fn hash_effect(h: &mut Fnv, e: &AreaEffect) {
    let AreaEffect { kind, team, owner, pos, radius, start, until } = *e;
    h.u32(kind as u32 | (team.index() as u32) << 8);
    h.unit(Some(owner));
    h.vec2(pos);
    h.f32(radius);
    h.u32(start);
    h.u32(until);
}

fn hash_cast(h: &mut Fnv, c: &PendingCast) {
    let PendingCast { team, unit, ability, target } = *c;
    h.u32(team.index() as u32 | (ability as u32) << 1);
    h.unit(Some(unit));
    match target {
        AbilityTarget::None => h.u32(0),
        AbilityTarget::Point { to } => {
            h.u32(1);
            h.vec2(to);
        }
        AbilityTarget::Unit { unit } => {
            h.u32(2);
            h.unit(Some(unit));
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::ability::{Ability, AbilityTarget, PendingCast};
    use crate::ids::{Team, UnitId};
    use crate::world::{Rules, World};
    use rand::RngCore;

    /// State a loop's outcome depends on but that an observer of units' positions, HP and
    /// orders does not see: each must change the hash.
    #[test]
    fn hidden_state_changes_the_hash() {
        let s = crate::builtin("3m_vlm").expect("built in");
        let fresh = || World::new(&s, Rules::default(), 1);
        let base = fresh().state_hash();
        assert_eq!(base, fresh().state_hash(), "deterministic");
        assert_ne!(base, World::new(&s, Rules::default(), 2).state_hash(), "the RNG's key");
        type Edit = (&'static str, fn(&mut World));
        let edits: [Edit; 7] = [
            ("a draw from the RNG", |w| {
                w.rng().next_u32();
            }),
            ("the last attacker", |w| w.units[0].last_attacker = Some(UnitId::new(4))),
            ("a waypoint", |w| w.units[0].waypoint = Some((w.units[0].pos, w.units[0].pos, 3))),
            ("blocked loops", |w| w.units[1].blocked_loops = 2),
            ("a status timer", |w| w.units[2].status.quiet_after = 9),
            ("a pending cast", |w| {
                w.pending_casts.push(PendingCast {
                    team: Team::One,
                    unit: UnitId::new(0),
                    ability: Ability::Stimpack,
                    target: AbilityTarget::None,
                })
            }),
            ("a kill count", |w| w.stats[1].kills = 1),
        ];
        for (what, edit) in edits {
            let mut w = fresh();
            edit(&mut w);
            assert_ne!(w.state_hash(), base, "{what} is not hashed");
        }
    }
}
