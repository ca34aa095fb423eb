//! What abilities do to the world: checking a cast (every refusal reason) and carrying it out
//! at the start of a loop, and (`tick`) their per-loop side. The ability data these read and
//! leave behind (`ability`) sits below the world; this sits above it and the combat rules.

mod tick;

use crate::ability::*;
use crate::combat::PendingHit;
use crate::geom::Vec2;
use crate::ids::Team;
use crate::ids::UnitId;
use crate::time::LOOPS_PER_SECOND;
use crate::units::UnitKind;
use crate::world::{Order, Unit, World};

impl World {
    /// Checks everything about a cast except its target: whether `u` could cast `ability`
    /// now on some target. Used for availability masks and observations too.
    pub fn can_cast(&self, u: &Unit, ability: Ability) -> Result<(), Refusal> {
        let spec = ability.spec();
        let tick = self.tick;
        if !self.rules.abilities {
            return Err(Refusal::Disabled);
        }
        if !ability.casters().contains(&u.kind) {
            return Err(Refusal::NotItsAbility { kind: u.kind });
        }
        if let Some(upgrade) = ability.upgrade_for(u.kind)
            && !self.has_upgrade(u.team, upgrade)
        {
            return Err(Refusal::NeedsUpgrade { upgrade });
        }
        if let Some((into, _)) = u.status.morph {
            return Err(Refusal::Busy { what: format!("morphing into {}", into.display_name()) });
        }
        if u.status.lifted(tick) {
            return Err(Refusal::Busy { what: "held by a Graviton Beam".into() });
        }
        let ready = u.status.ready_at(ability);
        if ready > tick {
            return Err(Refusal::OnCooldown { seconds: (ready - tick) as f32 / LOOPS_PER_SECOND });
        }
        let need = match ability {
            Ability::Heal => u.spec().heal.map_or(0.0, |h| h.min_energy_to_start),
            _ => spec.energy,
        };
        if u.energy < need {
            return Err(Refusal::NotEnoughEnergy { have: u.energy, need });
        }
        let st = &u.status;
        match ability {
            Ability::Stimpack if u.hp <= stim_cost(u.kind) => Err(Refusal::NotEnoughLife { have: u.hp, cost: stim_cost(u.kind) }),
            Ability::Cloak if st.cloaked => Err(Refusal::AlreadyActive),
            Ability::Decloak if !st.cloaked => Err(Refusal::NotActive),
            Ability::GuardianShield if st.guardian_up(tick) => Err(Refusal::AlreadyActive),
            Ability::Barrier if st.barrier_up(tick) => Err(Refusal::AlreadyActive),
            Ability::Afterburners if st.boosted(tick) => Err(Refusal::AlreadyActive),
            Ability::AssaultMode if !self.terrain.walkable(u.pos) => {
                Err(Refusal::InvalidTarget { why: "no ground to land on here".into() })
            }
            _ => Ok(()),
        }
    }

    /// Checks a cast fully (by the rules an observation's check shares, `crate::rules`) and
    /// returns the target as it will be used.
    pub(crate) fn check_cast(&self, team: Team, u: &Unit, ability: Ability, target: AbilityTarget) -> Result<AbilityTarget, Refusal> {
        crate::rules::cast(self, team, u, ability, target).map(|()| target)
    }

    /// Whether any unit of `team` sees point `p` (the cliff rule included).
    pub fn team_sees_point(&self, team: Team, p: Vec2) -> bool {
        if self.rules.full_vision {
            return true;
        }
        let ph = self.terrain.height_at(p);
        self.alive(team).any(|v| {
            let sight = v.spec().sight;
            v.pos.dist_sq(p) <= sight * sight && (v.flying() || ph < self.heights[v.id.index()] + 0.5)
        })
    }

    /// Carries out every cast accepted since the last loop, both teams together in unit
    /// order. A cast no longer valid (its target died, a second Feedback found no energy
    /// left) fizzles without cost.
    pub(crate) fn run_casts(&mut self) {
        if self.pending_casts.is_empty() {
            return;
        }
        let mut casts = std::mem::take(&mut self.pending_casts);
        casts.sort_by_key(|c| c.unit);
        let mut hits = Vec::new();
        let mut moved = false;
        for c in &casts {
            let u = &self.units[c.unit.index()];
            if !u.alive || u.team != c.team {
                continue;
            }
            if let Ok(target) = self.check_cast(c.team, u, c.ability, c.target) {
                moved |= self.perform(c.unit.index(), c.ability, target, &mut hits);
            }
        }
        casts.clear();
        self.pending_casts = casts;
        self.resolve_hits(hits);
        if moved {
            self.refresh();
        }
    }

    fn target_pos(&self, target: AbilityTarget, fallback: Vec2) -> Vec2 {
        match target {
            AbilityTarget::Point { to } => to,
            AbilityTarget::Unit { unit } => self.unit(unit).map_or(fallback, |t| t.pos),
            AbilityTarget::None => fallback,
        }
    }

    /// Applies a checked cast. Returns whether a unit was moved (the grids need a refresh).
    fn perform(&mut self, i: usize, ability: Ability, target: AbilityTarget, hits: &mut Vec<PendingHit>) -> bool {
        let tick = self.tick;
        let spec = ability.spec();
        self.cancel_channel(i);
        let (id, team, pos) = {
            let u = &mut self.units[i];
            u.energy -= spec.energy;
            if spec.cooldown > 0 {
                u.status.cooldown_until = tick + spec.cooldown;
            }
            (u.id, u.team, u.pos)
        };
        self.count_ability(team, ability);
        let tpos = self.target_pos(target, pos);
        let target_unit = match target {
            AbilityTarget::Unit { unit } => Some(unit.index()),
            _ => None,
        };
        let effect = |kind, radius, until| AreaEffect { kind, team, owner: id, pos: tpos, radius, start: tick, until };
        match ability {
            Ability::Stimpack => {
                let u = &mut self.units[i];
                u.hp -= stim_cost(u.kind);
                u.status.stim_until = tick + STIM_LOOPS;
                u.status.hold(tick + STIM_LOOPS);
            }
            Ability::Heal => {
                if let AbilityTarget::Unit { unit } = target {
                    self.set_order(id, Order::Attack { target: unit });
                }
            }
            Ability::Afterburners => {
                let st = &mut self.units[i].status;
                st.boost_until = tick + AFTERBURNER_LOOPS;
                st.hold(st.boost_until);
            }
            Ability::SiegeMode => self.start_morph(i, UnitKind::SiegeTankSieged, SIEGE_LOOPS),
            Ability::Unsiege => self.start_morph(i, UnitKind::SiegeTank, UNSIEGE_LOOPS),
            Ability::FighterMode => self.start_morph(i, UnitKind::VikingFighter, VIKING_MORPH_LOOPS),
            Ability::AssaultMode => self.start_morph(i, UnitKind::VikingAssault, VIKING_MORPH_LOOPS),
            Ability::PhasingMode => self.start_morph(i, UnitKind::WarpPrismPhasing, PRISM_MORPH_LOOPS),
            Ability::TransportMode => self.start_morph(i, UnitKind::WarpPrism, PRISM_MORPH_LOOPS),
            Ability::Kd8Charge => self.effects.push(effect(EffectKind::Kd8Charge, KD8_RADIUS, tick + KD8_DELAY_LOOPS)),
            Ability::SteadyTargeting => {
                if let AbilityTarget::Unit { unit } = target {
                    let u = &mut self.units[i];
                    u.status.channel = Some(Channel::Snipe { target: unit, done: tick + SNIPE_LOOPS });
                    u.target = Some(unit);
                }
            }
            Ability::Emp => {
                for v in self.units.iter_mut().filter(|v| v.alive && v.pos.dist(tpos) - v.radius <= EMP_RADIUS) {
                    v.shield = (v.shield - EMP_DRAIN).max(0.0);
                    v.energy = (v.energy - EMP_DRAIN).max(0.0);
                    v.status.revealed_until = tick + EMP_REVEAL_LOOPS;
                }
            }
            Ability::Cloak => self.units[i].status.cloaked = true,
            Ability::Decloak => self.units[i].status.cloaked = false,
            Ability::Blink => {
                let u = &mut self.units[i];
                u.heading = (tpos - u.pos).normalized();
                u.pos = tpos;
                u.vel = Vec2::ZERO;
                self.dirty[i] = true;
                self.set_order(id, Order::Idle);
                return true;
            }
            Ability::GuardianShield => {
                self.units[i].status.guardian_until = tick + GUARDIAN_LOOPS;
                let mut e = effect(EffectKind::GuardianShield, GUARDIAN_RADIUS, tick + GUARDIAN_LOOPS);
                e.pos = pos;
                self.effects.push(e);
            }
            Ability::ForceField => self.effects.push(effect(EffectKind::ForceField, FORCE_FIELD_RADIUS, tick + FORCE_FIELD_LOOPS)),
            Ability::PsionicStorm => {
                self.effects.push(effect(EffectKind::PsionicStorm, STORM_RADIUS, tick + STORM_LOOPS));
                self.set_order(id, Order::Idle);
            }
            Ability::Feedback => {
                if let Some(j) = target_unit {
                    // An interrupted snipe's refund comes back first, so Feedback drains it too.
                    self.cancel_channel(j);
                    let drained = std::mem::take(&mut self.units[j].energy);
                    self.spell_damage(j, drained * FEEDBACK_PER_ENERGY, id);
                }
            }
            Ability::Barrier => self.raise_barrier(i),
            Ability::GravitonBeam => {
                if let Some(j) = target_unit {
                    let t = &mut self.units[j];
                    t.status.lifted_until = tick + GRAVITON_LOOPS;
                    t.status.hold(tick + GRAVITON_LOOPS);
                    t.body = crate::world::Body::Air;
                    t.vel = Vec2::ZERO;
                    self.units[i].status.channel = Some(Channel::Graviton { target: UnitId::new(j as u16) });
                }
            }
            Ability::Explode => {
                let u = &mut self.units[i];
                u.alive = false;
                u.hp = 0.0;
                u.activity = crate::world::Activity::Dead;
                if let Some(w) = u.spec().weapons.first() {
                    hits.push(PendingHit { attacker: id, target: None, weapon: w, impact: pos, dir: Vec2::ZERO });
                }
            }
            Ability::Transfusion => {
                if let Some(j) = target_unit {
                    let t = &mut self.units[j];
                    t.hp = (t.hp + TRANSFUSE_NOW).min(t.max_hp);
                    t.status.hot_until = tick + TRANSFUSE_LOOPS;
                    t.status.hold(tick + TRANSFUSE_LOOPS);
                    t.status.hot_per_loop = TRANSFUSE_LATER / TRANSFUSE_LOOPS as f32;
                }
            }
        }
        false
    }

    pub(crate) fn count_ability(&mut self, team: Team, ability: Ability) {
        *self.stats[team.index()].abilities.entry(ability).or_default() += 1;
    }

    fn start_morph(&mut self, i: usize, into: UnitKind, loops: u32) {
        let id = self.units[i].id;
        self.set_order(id, Order::Idle);
        let u = &mut self.units[i];
        // The new mode has other weapons: an attack under way ends now.
        u.cancel_swing();
        u.status.morph = Some((into, self.tick + loops));
        u.vel = Vec2::ZERO;
        u.speed = 0.0;
    }

    /// Barrier: absorbs the next damage for a while; StarCraft II raises it automatically
    /// on the first hit when it is off cooldown.
    pub(crate) fn raise_barrier(&mut self, i: usize) {
        let tick = self.tick;
        let st = &mut self.units[i].status;
        st.barrier_hp = BARRIER_HP;
        st.barrier_until = tick + BARRIER_LOOPS;
        st.hold(tick + BARRIER_LOOPS);
        st.cooldown_until = tick + Ability::Barrier.spec().cooldown;
    }

    /// Ends a channel of unit `i` (a new order, death, or a new cast), releasing a lifted
    /// target.
    pub(crate) fn cancel_channel(&mut self, i: usize) {
        match self.units[i].status.channel.take() {
            Some(Channel::Graviton { target }) => {
                let t = &mut self.units[target.index()];
                t.status.lifted_until = t.status.lifted_until.min(self.tick);
            }
            // An interrupted Steady Targeting gives its energy back.
            Some(Channel::Snipe { .. }) => {
                let u = &mut self.units[i];
                u.energy = (u.energy + Ability::SteadyTargeting.spec().energy).min(u.spec().energy_max);
            }
            None => {}
        }
    }
}
