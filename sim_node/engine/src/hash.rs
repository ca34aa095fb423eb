//! A stable 64-bit hash of the simulation state (FNV-1a over the exact bits of each value), so two runs
//! can be compared for byte-identical trajectories without storing them.

use crate::world::{Order, World};

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
}

impl World {
    /// Hash of everything that evolves: loop, and every unit's state and order.
    pub fn state_hash(&self) -> u64 {
        let mut h = Fnv::default();
        h.u32(self.tick);
        for u in &self.units {
            h.u32(u.alive as u32 | (u.kind as u32) << 8);
            for v in [u.pos.x, u.pos.y, u.hp, u.shield, u.energy, u.cooldown, u.heading.x, u.heading.y] {
                h.f32(v);
            }
            match u.order {
                Order::Idle => h.u32(0),
                Order::Hold => h.u32(1),
                Order::Move { to } => {
                    h.u32(2);
                    h.f32(to.x);
                    h.f32(to.y);
                }
                Order::AttackMove { to } => {
                    h.u32(3);
                    h.f32(to.x);
                    h.f32(to.y);
                }
                Order::Attack { target } => {
                    h.u32(4);
                    h.u32(target.tag());
                }
            }
            h.u32(u.target.map_or(0, |t| t.tag()));
            let st = &u.status;
            for v in [
                st.stim_until,
                st.slow_until,
                st.boost_until,
                st.guardian_until,
                st.barrier_until,
                st.lifted_until,
                st.cooldown_until,
                st.hot_until,
                st.storm_next,
                st.revealed_until,
            ] {
                h.u32(v);
            }
            h.u32(st.cloaked as u32 | st.morph.map_or(0, |(k, t)| (k as u32) << 24 ^ t) << 1);
            match st.channel {
                None => h.u32(0),
                Some(crate::ability::Channel::Snipe { target, done }) => {
                    h.u32(1 | target.tag() << 2);
                    h.u32(done);
                }
                Some(crate::ability::Channel::Graviton { target }) => h.u32(2 | target.tag() << 2),
            }
            h.f32(st.barrier_hp);
            h.f32(st.hot_per_loop);
        }
        for e in &self.effects {
            h.u32(e.kind as u32 | e.until << 4);
            h.u32(e.team.index() as u32 | e.owner.tag() << 1);
            h.f32(e.radius);
            h.f32(e.pos.x);
            h.f32(e.pos.y);
        }
        h.finish()
    }
}
