//! SMAC-compatible features: per-agent observation, global state, available actions and
//! the discrete action index, with SMAC's layout, order and normalisation
//! (`oxwhirl/smac`, `starcraft2.py`, default options). Observations obey fog of war on top
//! of SMAC's own sight rule; the state is SMAC's privileged global state for centralised
//! training and does not.

use super::group::GroupObs;
use super::slots::AbilitySlots;
use crate::action::{ActionError, Command, Direction};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::rules::Facts;
use crate::scenario::Scenario;
use crate::terrain::Rect;
use crate::units::{Race, UnitKind};
use crate::world::{Unit, World};
use serde::Serialize;

/// SMAC's fixed sight range for features (every unit).
pub const SIGHT_RANGE: f32 = 9.0;
/// SMAC's fixed shoot range for available attack actions (every unit).
pub const SHOOT_RANGE: f32 = 6.0;
/// Actions before the first attack index: no-op, stop, north, south, east, west.
pub const N_ACTIONS_NO_ATTACK: usize = 6;
const MOVE_FEATS: usize = 4;
/// SMACv2's `min_attack_range`: the shortest shoot range under `use_unit_ranges`.
pub const MIN_ATTACK_RANGE: f32 = 2.0;

/// SMAC's `get_env_info()`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct EnvInfo {
    pub n_agents: usize,
    pub n_actions: usize,
    pub obs_shape: usize,
    pub state_shape: usize,
    pub episode_limit: usize,
}

/// The feature layout of one team's agents.
#[derive(Clone, Debug, PartialEq)]
pub struct SmacLayout {
    pub team: Team,
    pub n_agents: usize,
    pub n_enemies: usize,
    pub n_actions: usize,
    pub agents: Vec<UnitId>,
    pub enemies: Vec<UnitId>,
    /// One-hot order of unit types for allies and for enemies (empty: no type bits).
    pub ally_types: Vec<UnitKind>,
    pub enemy_types: Vec<UnitKind>,
    pub shield_ally: usize,
    pub shield_enemy: usize,
    pub obs_size: usize,
    pub state_size: usize,
    /// The opt-in ability extension (empty when off).
    pub abilities: AbilitySlots,
    /// SMACv2's layout (procedural scenarios): type bits always, each unit's own sight and
    /// shoot ranges (`use_unit_ranges`, at least `min_attack_range` 2), and the agent's
    /// position in its own features (`obs_own_pos`).
    pub v2: bool,
    /// SMAC's range mask on attack actions; off (SMACv2's `action_mask: False`), any living
    /// enemy the team sees may be attacked. The observation's "can attack" bit keeps the
    /// range either way, as SMACv2's does.
    pub range_mask: bool,
    /// SMACv2's conic fields of view: the number of look actions (0: off, a full circle).
    /// They sit after the moves, so the attack block starts at [`SmacLayout::attack_base`];
    /// the agent's look direction joins its own features (after its position) and each
    /// ally's state row (after its shield).
    pub fov: usize,
    /// The MAPPO repository's agent-specific state in place of SMAC's (off by default; see
    /// [`SmacLayout::with_state_agent`]).
    pub(super) state_agent: bool,
    map_center: Vec2,
    map_size: Vec2,
    playable_w: f32,
    playable_h: f32,
    playable: Rect,
}

impl SmacLayout {
    /// SMAC's layout, without the ability extension.
    pub fn new(scenario: &Scenario, team: Team) -> Self {
        Self::with_abilities(scenario, team, false)
    }

    /// SMAC's layout, with the ability slots appended when `abilities` is on.
    pub fn with_abilities(scenario: &Scenario, team: Team, abilities: bool) -> Self {
        let agents: Vec<UnitId> = scenario.agent_order(team);
        let enemies: Vec<UnitId> = scenario.team_units(team.other()).map(|(i, _)| UnitId::new(i as u16)).collect();
        let base = |t: Team| {
            let mut v: Vec<UnitKind> = scenario.team_units(t).map(|(_, u)| u.kind.base()).collect();
            v.sort_by_key(|k| k.name());
            v.dedup();
            v
        };
        let (own, all) = (base(team), {
            let mut v: Vec<UnitKind> = scenario.units.iter().map(|u| u.kind.base()).collect();
            v.sort_by_key(|k| k.name());
            v.dedup();
            v
        });
        // SMAC sets unit_type_bits only for maps whose agents mix types; the one-hot then
        // covers every type in the map, in alphabetical order (MMM: marauder, marine, medivac).
        let generator = scenario.generator.as_deref();
        let ally_types = match generator {
            // SMACv2: the race's types in its one-hot order, whatever this episode drew.
            Some(g) => g.kinds().collect(),
            None if own.len() > 1 => all.clone(),
            None => Vec::new(),
        };
        let mut enemy_types = ally_types.clone();
        // SMAC quirk kept for drop-in compatibility: for stalkers-and-zealots maps the enemy
        // one-hot is zealot, stalker (`get_unit_type_id` with ally=False), the reverse of the allies'.
        if generator.is_none() && enemy_types == [UnitKind::Stalker, UnitKind::Zealot] {
            enemy_types.reverse();
        }
        // A procedural team's sizes are fixed, its types are not: what it could draw decides.
        let could = |t: Team, f: &dyn Fn(UnitKind) -> bool| match generator {
            Some(g) => g.kinds().any(f),
            None => scenario.team_units(t).any(|(_, u)| f(u.kind)),
        };
        let shields = |t: Team| could(t, &|k| scenario.data.spec(k).race == Race::Protoss) as usize;
        let (shield_ally, shield_enemy) = (shields(team), shields(team.other()));
        let tb = ally_types.len();
        let (n_agents, n_enemies) = (agents.len(), enemies.len());
        // SMAC's healers target allies through the attack slots; where a team has more agents
        // than enemies, the block widens so a healer can reach every ally (SMAC's own maps
        // never need this: MMM has as many agents as enemies).
        let healer = could(team, &|k| scenario.data.spec(k).heal.is_some());
        let n_targets = if healer { n_enemies.max(n_agents) } else { n_enemies };
        let floor = generator.map_or(0, |g| g.kinds().map(|k| super::slot_abilities(k).len()).max().unwrap_or(0));
        let slots = if abilities { AbilitySlots::new(scenario, &agents, n_enemies, floor) } else { AbilitySlots::default() };
        let ext_obs = if abilities { 1 + slots.slots } else { 0 };
        let n_actions = N_ACTIONS_NO_ATTACK + n_targets + slots.n_actions();
        let fe = 4 + 1 + shield_enemy + tb;
        let fa = 4 + 1 + shield_ally + tb;
        let v2 = generator.is_some();
        let own_feats = 1 + shield_ally + tb + if v2 { 2 } else { 0 };
        let obs_size = MOVE_FEATS + n_enemies * fe + (n_agents - 1) * fa + own_feats + ext_obs;
        let state_size = n_agents * (4 + shield_ally + tb) + n_enemies * (3 + shield_enemy + tb) + n_agents * n_actions;
        let p = scenario.terrain.playable();
        Self {
            team,
            n_agents,
            n_enemies,
            n_actions,
            agents,
            enemies,
            ally_types,
            enemy_types,
            shield_ally,
            shield_enemy,
            obs_size,
            state_size,
            abilities: slots,
            v2,
            range_mask: true,
            fov: 0,
            state_agent: false,
            map_center: Vec2::new(scenario.terrain.width() as f32 / 2.0, scenario.terrain.height() as f32 / 2.0),
            map_size: Vec2::new(scenario.terrain.width() as f32, scenario.terrain.height() as f32),
            playable_w: p.width(),
            playable_h: p.height(),
            playable: p,
        }
    }

    /// The layout with the range mask on attack actions on or off (see `range_mask`).
    pub fn with_range_mask(mut self, on: bool) -> Self {
        self.range_mask = on;
        self
    }

    /// The layout with `n` look actions (SMACv2's `conic_fov` with `num_fov_actions = n`; 0:
    /// off). The actions, the observation and the state grow (see `fov`).
    pub fn with_fov(mut self, n: u8) -> Self {
        let (old, n) = (self.fov, usize::from(n));
        self.fov = n;
        let on = |k: usize| if k > 0 { 2 } else { 0 };
        self.n_actions = self.n_actions - old + n;
        self.obs_size = self.obs_size - on(old) + on(n);
        self.state_size = self.state_width();
        self
    }

    /// The state's width: SMAC's global state, or every agent's agent-specific row.
    pub(super) fn state_width(&self) -> usize {
        if self.state_agent {
            return self.n_agents * self.agent_state_size();
        }
        let look = if self.fov > 0 { 2 } else { 0 };
        let na = 4 + self.shield_ally + self.ally_types.len() + look;
        let ne = 3 + self.shield_enemy + self.enemy_types.len();
        self.n_agents * na + self.n_enemies * ne + self.n_agents * self.n_actions
    }

    /// The first attack index: after no-op, stop, the four moves and the look actions.
    pub fn attack_base(&self) -> usize {
        N_ACTIONS_NO_ATTACK + self.fov
    }

    /// Whether a point is in `u`'s view within `range`: a full circle (strictly within, as
    /// SMAC's sight), or under conic fields of view within `range` and a cone of 2π/fov
    /// around where it looks. SMACv2 compares arctangents of slopes, which also admits
    /// points behind a unit looking east or west; here the cone is the geometric one.
    fn in_view(&self, u: &Unit, p: Vec2, range: f32, strict: bool) -> bool {
        let d = p - u.pos;
        let dist = d.len();
        let within = if strict { dist < range } else { dist <= range };
        if self.fov == 0 || !within {
            return within;
        }
        dist == 0.0 || d.dot(u.look) > dist * (std::f32::consts::PI / self.fov as f32).cos()
    }

    /// Where enemy `j`'s features sit in an agent's observation.
    pub fn enemy_row(&self, j: usize) -> std::ops::Range<usize> {
        let fe = 5 + self.shield_enemy + self.ally_types.len();
        MOVE_FEATS + j * fe..MOVE_FEATS + (j + 1) * fe
    }

    /// Whether living `agent` has living enemy `j` in its features: the team sees it and it
    /// is within the agent's sight (strictly, as SMAC).
    pub fn sees_enemy(&self, world: &World, agent: usize, j: usize) -> bool {
        let Some(u) = self.agents.get(agent).and_then(|&id| world.unit(id)).filter(|u| u.alive) else { return false };
        let Some(e) = self.enemies.get(j).and_then(|&id| world.unit(id)).filter(|e| e.alive) else { return false };
        world.visible_to(self.team, e.id) && self.sees(u, e.pos)
    }

    /// Whether `u`'s features show a unit at `p`: within sight (strictly, as SMAC; SMACv2's
    /// cone includes its edge of range) and, under conic fields of view, in the cone.
    fn sees(&self, u: &Unit, p: Vec2) -> bool {
        self.in_view(u, p, self.sight(u), self.fov == 0)
    }

    /// A position from the map's centre over the playable size, as SMAC's state has it.
    pub(super) fn centred(&self, p: Vec2) -> [f32; 2] {
        [(p.x - self.map_center.x) / self.playable_w, (p.y - self.map_center.y) / self.playable_h]
    }

    /// How far an agent sees for its features: SMAC's 9, or SMACv2's the unit's own sight.
    pub(super) fn sight(&self, u: &Unit) -> f32 {
        if self.v2 { u.spec().sight } else { SIGHT_RANGE }
    }

    /// How far an agent may attack (or heal) through its attack slots: SMAC's 6, or SMACv2's
    /// the unit's own range, at least 2.
    fn shoot(&self, u: &Unit) -> f32 {
        if !self.v2 {
            return SHOOT_RANGE;
        }
        let s = u.spec();
        let reach = s.weapons.iter().map(|w| w.range).chain(s.heal.map(|h| h.range)).fold(0.0, f32::max);
        reach.max(MIN_ATTACK_RANGE)
    }

    pub(super) fn one_hot(types: &[UnitKind], kind: UnitKind, out: &mut [f32]) {
        if let Some(i) = types.iter().position(|&k| k == kind.base()) {
            out[i] = 1.0;
        }
    }

    /// SMAC's `can_move`: the pathing grid half a move away.
    fn can_move(world: &World, id: UnitId, d: Direction) -> bool {
        let Some(u) = world.unit(id) else { return false };
        if u.speed <= 0.0 {
            return false;
        }
        let p = u.pos + d.vector() * (crate::action::MOVE_AMOUNT / 2.0);
        if u.flying() { world.terrain().playable().contains(p) } else { world.terrain().walkable(p) }
    }

    /// SMAC's attack-action targets for an agent: enemies, or for a healer its allies.
    fn targets(&self, known: &impl Known, agent: usize) -> &[UnitId] {
        let healer = self.agents.get(agent).and_then(|&id| known.body(id)).is_some_and(|u| u.heals());
        if healer { &self.agents } else { &self.enemies }
    }

    pub fn avail_actions(&self, world: &World, agent: usize, out: &mut [u8]) {
        out.fill(0);
        let id = self.agents[agent];
        let Some(u) = world.unit(id).filter(|u| u.alive) else {
            out[0] = 1;
            return;
        };
        // A channelling or morphing unit may also wait (any other order would cancel a
        // channel): SMAC's no-op, otherwise only for dead agents.
        out[0] = (u.status.channel.is_some() || u.status.morph.is_some()) as u8;
        out[1] = 1;
        for (k, d) in [Direction::Up, Direction::Down, Direction::Right, Direction::Left].into_iter().enumerate() {
            out[2 + k] = Self::can_move(world, id, d) as u8;
        }
        // Looking around is always possible (SMACv2).
        out[N_ACTIONS_NO_ATTACK..self.attack_base()].fill(1);
        let busy = u.status.morph.is_some();
        let base = self.attack_base();
        for j in 0..self.ability_base() - base {
            out[base + j] = (!busy && self.attack_slot(world, agent, u, j, self.range_mask)) as u8;
        }
        if self.abilities.slots > 0 {
            self.ability_mask(world, agent, u, out);
        }
    }

    /// Whether attack index `attack_base() + j` is available to living agent `u`: target `j`
    /// (an enemy, or for a healer an ally) is alive, seen, within SMAC's shoot range and,
    /// under conic fields of view, in the cone (if `by_range`), and hittable.
    fn attack_slot(&self, world: &World, agent: usize, u: &Unit, j: usize, by_range: bool) -> bool {
        let Some(&t) = self.targets(world, agent).get(j) else { return false };
        let Some(tu) = world.unit(t) else { return false };
        tu.alive
            && world.visible_to(self.team, t)
            && (!by_range || self.in_view(u, tu.pos, self.shoot(u), false))
            && if u.spec().heal.is_some() {
                // SMAC's rule (any ally but Medivacs), narrowed to what heal can target:
                // biological units (the same on SMAC's own maps, whose allies are all biological).
                t != u.id && tu.kind.base() != UnitKind::Medivac && tu.spec().attrs.has(crate::units::Attrs::BIOLOGICAL)
            } else {
                crate::combat::weapon_for(u, tu).is_some()
            }
    }

    /// Whether one action index is available, without building the whole mask.
    pub fn is_available(&self, world: &World, agent: usize, idx: usize) -> bool {
        let Some(u) = self.agents.get(agent).and_then(|&id| world.unit(id)).filter(|u| u.alive) else {
            return idx == 0;
        };
        match idx {
            0 => u.status.channel.is_some() || u.status.morph.is_some(),
            1 => true,
            2..=5 => Self::can_move(world, u.id, [Direction::Up, Direction::Down, Direction::Right, Direction::Left][idx - 2]),
            i if i < self.attack_base() => true,
            i if i < self.ability_base() => {
                u.status.morph.is_none() && self.attack_slot(world, agent, u, i - self.attack_base(), self.range_mask)
            }
            i if i < self.n_actions => self.ability_available(world, agent, u, i - self.ability_base()),
            _ => false,
        }
    }

    pub fn obs(&self, world: &World, agent: usize, out: &mut [f32]) {
        out.fill(0.0);
        let id = self.agents[agent];
        let Some(u) = world.unit(id).filter(|u| u.alive) else { return };
        let moves = [Direction::Up, Direction::Down, Direction::Right, Direction::Left];
        for (k, d) in moves.into_iter().enumerate() {
            out[k] = Self::can_move(world, id, d) as u8 as f32;
        }
        let tb = self.ally_types.len();
        let fe = 5 + self.shield_enemy + tb;
        let sight = self.sight(u);
        let mut off = MOVE_FEATS;
        for (j, &e) in self.enemies.iter().enumerate() {
            let f = &mut out[off + j * fe..off + (j + 1) * fe];
            if let Some(eu) = world.unit(e)
                && eu.alive
                && world.visible_to(self.team, e)
            {
                let d = eu.pos - u.pos;
                let dist = d.len();
                if self.sees(u, eu.pos) {
                    // SMAC reads this from the available actions: for a healer that is the
                    // heal slot of ally j, a quirk kept for compatibility.
                    f[0] = self.attack_slot(world, agent, u, j, true) as u8 as f32;
                    f[1] = dist / sight;
                    f[2] = d.x / sight;
                    f[3] = d.y / sight;
                    f[4] = eu.hp / eu.max_hp;
                    if self.shield_enemy > 0 && eu.max_shield > 0.0 {
                        f[5] = eu.shield / eu.max_shield;
                    }
                    Self::one_hot(&self.enemy_types, eu.kind, &mut f[5 + self.shield_enemy..]);
                }
            }
        }
        off += self.n_enemies * fe;
        let fa = 5 + self.shield_ally + tb;
        for (k, &a) in self.agents.iter().filter(|&&a| a != id).enumerate() {
            let f = &mut out[off + k * fa..off + (k + 1) * fa];
            if let Some(au) = world.unit(a).filter(|au| au.alive) {
                let d = au.pos - u.pos;
                let dist = d.len();
                if self.sees(u, au.pos) {
                    f[0] = 1.0;
                    f[1] = dist / sight;
                    f[2] = d.x / sight;
                    f[3] = d.y / sight;
                    f[4] = au.hp / au.max_hp;
                    if self.shield_ally > 0 && au.max_shield > 0.0 {
                        f[5] = au.shield / au.max_shield;
                    }
                    Self::one_hot(&self.ally_types, au.kind, &mut f[5 + self.shield_ally..]);
                }
            }
        }
        off += (self.n_agents - 1) * fa;
        let f = &mut out[off..];
        f[0] = u.hp / u.max_hp;
        if self.shield_ally > 0 && u.max_shield > 0.0 {
            f[1] = u.shield / u.max_shield;
        }
        let mut t = 1 + self.shield_ally;
        if self.v2 {
            // SMACv2's own features: health, shield, position over the map's size, type.
            f[t] = u.pos.x / self.map_size.x;
            f[t + 1] = u.pos.y / self.map_size.y;
            t += 2;
        }
        if self.fov > 0 {
            // SMACv2's own_fov_x, own_fov_y.
            f[t] = u.look.x;
            f[t + 1] = u.look.y;
            t += 2;
        }
        Self::one_hot(&self.ally_types, u.kind, &mut f[t..]);
        if self.abilities.slots > 0 {
            let ext = self.obs_size - 1 - self.abilities.slots;
            self.ability_obs(world, agent, u, &mut out[ext..]);
        }
    }

    pub fn state(&self, world: &World, last_actions: &[Option<usize>], out: &mut [f32]) {
        if self.state_agent {
            return self.agent_states(world, last_actions, out);
        }
        out.fill(0.0);
        let tb = self.ally_types.len();
        let look = if self.fov > 0 { 2 } else { 0 };
        let na = 4 + self.shield_ally + look + tb;
        for (i, &a) in self.agents.iter().enumerate() {
            let f = &mut out[i * na..(i + 1) * na];
            let Some(u) = world.unit(a).filter(|u| u.alive) else { continue };
            f[0] = u.hp / u.max_hp;
            f[1] = cooldown_feature(u);
            f[2..4].copy_from_slice(&self.centred(u.pos));
            if self.shield_ally > 0 && u.max_shield > 0.0 {
                f[4] = u.shield / u.max_shield;
            }
            if look > 0 {
                // SMACv2's ally fov_x, fov_y.
                f[4 + self.shield_ally] = u.look.x;
                f[5 + self.shield_ally] = u.look.y;
            }
            Self::one_hot(&self.ally_types, u.kind, &mut f[4 + self.shield_ally + look..]);
        }
        let base = self.n_agents * na;
        let ne = 3 + self.shield_enemy + tb;
        for (j, &e) in self.enemies.iter().enumerate() {
            let f = &mut out[base + j * ne..base + (j + 1) * ne];
            let Some(u) = world.unit(e).filter(|u| u.alive) else { continue };
            f[0] = u.hp / u.max_hp;
            f[1..3].copy_from_slice(&self.centred(u.pos));
            if self.shield_enemy > 0 && u.max_shield > 0.0 {
                f[3] = u.shield / u.max_shield;
            }
            Self::one_hot(&self.enemy_types, u.kind, &mut f[3 + self.shield_enemy..]);
        }
        let base = base + self.n_enemies * ne;
        for (i, la) in last_actions.iter().enumerate().take(self.n_agents) {
            if let Some(a) = la.filter(|&a| a < self.n_actions) {
                out[base + i * self.n_actions + a] = 1.0;
            }
        }
    }

    /// The typed action for SMAC index `idx` of `agent`; `None` for an index out of range.
    pub fn command_for(&self, world: &World, agent: usize, idx: usize) -> Option<Command> {
        self.command_from(world, agent, idx)
    }

    /// [`SmacLayout::command_for`] from observation data alone (`g` holds `agent`'s unit):
    /// what an agent outside the engine can compute. `None` for an index out of range, or
    /// one naming a position the group does not see (an area spell at an unseen enemy).
    pub fn command_for_obs(&self, g: &GroupObs, agent: usize, idx: usize) -> Option<Command> {
        self.command_from(g, agent, idx)
    }

    fn command_from(&self, known: &impl Known, agent: usize, idx: usize) -> Option<Command> {
        Some(match idx {
            i if i < N_ACTIONS_NO_ATTACK => fixed_command(i),
            i if i < self.attack_base() => Command::Look { sector: (i - N_ACTIONS_NO_ATTACK) as u8, sectors: self.fov as u8 },
            i if i < self.ability_base() => Command::Attack { target: *self.targets(known, agent).get(i - self.attack_base())? },
            i if i < self.n_actions => self.ability_command(known, agent, i - self.ability_base())?,
            _ => return None,
        })
    }

    /// Reflects an agent's observation in the map's vertical centre line, in place: east and
    /// west swap (the move bits), x offsets change sign, an own x position becomes its mirror
    /// and an own look direction's x changes sign.
    /// A policy trained as team 1 plays team 2 of a left-right mirrored scenario in this
    /// image (with [`SmacLayout::mirror_avail`] and [`SmacLayout::mirror_action`]).
    pub fn mirror_obs(&self, obs: &mut [f32]) {
        if obs.len() < MOVE_FEATS {
            return;
        }
        obs.swap(2, 3);
        let tb = self.ally_types.len();
        let (fe, fa) = (5 + self.shield_enemy + tb, 5 + self.shield_ally + tb);
        let enemies = (0..self.n_enemies).map(|j| MOVE_FEATS + j * fe + 2);
        let allies = (0..self.n_agents.saturating_sub(1)).map(|k| MOVE_FEATS + self.n_enemies * fe + k * fa + 2);
        for i in enemies.chain(allies) {
            if let Some(v) = obs.get_mut(i) {
                *v = -*v;
            }
        }
        let own = MOVE_FEATS + self.n_enemies * fe + self.n_agents.saturating_sub(1) * fa + 1 + self.shield_ally;
        // Only a living agent's features are filled: a dead one's stay zero.
        let alive = obs.iter().any(|&v| v != 0.0);
        if self.v2
            && alive
            && let Some(x) = obs.get_mut(own)
        {
            *x = 1.0 - *x;
        }
        let look = own + if self.v2 { 2 } else { 0 };
        if self.fov > 0
            && alive
            && let Some(x) = obs.get_mut(look)
        {
            *x = -*x;
        }
    }

    /// [`SmacLayout::mirror_obs`] for a mask: east and west swap. (Look actions are all
    /// available or none, so their mirror needs no swap.)
    pub fn mirror_avail(avail: &mut [u8]) {
        if avail.len() > 5 {
            avail.swap(4, 5);
        }
    }

    /// The action of the mirror image: move east and move west swap, look sector `i` (angle
    /// 2πi/N) becomes the sector at π minus that angle, the rest are the same.
    pub fn mirror_action(&self, idx: usize) -> usize {
        let n = self.fov;
        match idx {
            4 => 5,
            5 => 4,
            i if n > 0 && (N_ACTIONS_NO_ATTACK..self.attack_base()).contains(&i) => {
                N_ACTIONS_NO_ATTACK + (n + n / 2 - (i - N_ACTIONS_NO_ATTACK)) % n
            }
            i => i,
        }
    }

    /// The playable area of the scenario's map.
    pub(crate) fn playable(&self) -> Rect {
        self.playable
    }

    /// SMAC index of a typed command, where SMAC has one.
    pub fn index_for(&self, world: &World, agent: usize, c: &Command) -> Option<usize> {
        Some(match c {
            Command::NoOp => 0,
            Command::Stop => 1,
            Command::MoveDir { dir: Direction::Up } => 2,
            Command::MoveDir { dir: Direction::Down } => 3,
            Command::MoveDir { dir: Direction::Right } => 4,
            Command::MoveDir { dir: Direction::Left } => 5,
            Command::Look { sector, sectors } if usize::from(*sectors) == self.fov && sector < sectors => {
                N_ACTIONS_NO_ATTACK + usize::from(*sector)
            }
            Command::Attack { target } => {
                self.attack_base()
                    + self.targets(world, agent).iter().take(self.ability_base() - self.attack_base()).position(|t| t == target)?
            }
            Command::Ability { ability, target } => self.ability_index(world, agent, *ability, target)?,
            _ => return None,
        })
    }
}

/// What the layout reads of units when it turns an index into a command: the world's units
/// (training, the simulator) or those an observation lists (an agent behind the wire, which
/// knows living units it sees only).
pub(crate) trait Known {
    type U: Facts;
    fn body(&self, id: UnitId) -> Option<&Self::U>;
}

impl Known for World {
    type U = Unit;
    fn body(&self, id: UnitId) -> Option<&Unit> {
        self.unit(id)
    }
}

impl Known for GroupObs {
    type U = super::UnitInfo;
    fn body(&self, id: UnitId) -> Option<&super::UnitInfo> {
        self.unit(id)
    }
}

/// Why a SMAC action index was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IndexError {
    #[error("agent {agent}: action index {index} is out of range (n_actions = {n_actions})")]
    OutOfRange { agent: usize, index: usize, n_actions: usize },
    #[error("agent {agent}: action {index} is not available now")]
    Unavailable { agent: usize, index: usize },
    #[error("{0} actions given for {1} agents")]
    WrongCount(usize, usize),
    #[error(transparent)]
    Action(#[from] ActionError),
}

/// SMAC's first six actions, the same for every unit: no-op, stop, move north, south, east, west.
fn fixed_command(i: usize) -> Command {
    match i {
        0 => Command::NoOp,
        1 => Command::Stop,
        2 => Command::MoveDir { dir: Direction::Up },
        3 => Command::MoveDir { dir: Direction::Down },
        4 => Command::MoveDir { dir: Direction::Right },
        _ => Command::MoveDir { dir: Direction::Left },
    }
}

/// SMAC's cooldown feature: the weapon's cooldown (a healer's energy) over SMAC's maximum.
pub(super) fn cooldown_feature(u: &Unit) -> f32 {
    let max = u.spec().smac_max_cd;
    if u.spec().heal.is_some() { u.energy / max } else { u.cooldown.max(0.0) / max }
}
