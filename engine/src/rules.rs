//! Who may do what to whom, written once. The simulator checks an action against the world
//! ([`World::validate`]); an agent checks it against its group's observation
//! ([`crate::policy::check_action`]) before the action leaves it (AVA turns the answer into
//! words for its model, an agent node counts what it sends in vain). Both run [`check`] over
//! a [`Sight`]: the world's units and visibility, or the units an observation carries. So
//! the two can only disagree where the observation lacks a fact (fog, the exact cooldown),
//! and then the observation's check is the stricter one (tested in `tests/it/rules.rs`).

use crate::ability::{Ability, AbilityTarget, PendingCast, Refusal, TargetRule};
use crate::action::{Action, ActionError, Command, GRID, Inability, MOVE_AMOUNT, TargetProblem, grid_cell_center};
use crate::geom::Vec2;
use crate::ids::{Team, UnitId};
use crate::terrain::Terrain;
use crate::units::{Attrs, UnitKind, UnitSpec, Weapon};
use crate::world::{Order, Unit, World};

/// What the rules read of a unit: the same facts whether it is the world's [`Unit`] or an
/// observation's `UnitInfo` (plus its type's data, which a player knows; `obs` implements it).
pub(crate) trait Facts {
    fn id(&self) -> UnitId;
    fn kind(&self) -> UnitKind;
    /// The kind's row in the game's data set.
    fn spec(&self) -> &'static UnitSpec;
    fn pos(&self) -> Vec2;
    fn radius(&self) -> f32;
    /// 0 while immobile, morphing, lifted or channelling.
    fn speed(&self) -> f32;
    /// On the air layer (a flying type, or a ground unit held up by a Graviton Beam).
    fn on_air(&self) -> bool;
    fn heals(&self) -> bool;
    fn morphing(&self) -> bool;
    fn energy(&self) -> f32;
    fn hp(&self) -> f32;
    fn max_hp(&self) -> f32;
}

impl Facts for Unit {
    fn id(&self) -> UnitId {
        self.id
    }
    fn kind(&self) -> UnitKind {
        self.kind
    }
    fn spec(&self) -> &'static UnitSpec {
        self.spec
    }
    fn pos(&self) -> Vec2 {
        self.pos
    }
    fn radius(&self) -> f32 {
        self.radius
    }
    fn speed(&self) -> f32 {
        self.speed
    }
    fn on_air(&self) -> bool {
        self.flying()
    }
    fn heals(&self) -> bool {
        self.spec().heal.is_some()
    }
    fn morphing(&self) -> bool {
        self.status.morph.is_some()
    }
    fn energy(&self) -> f32 {
        self.energy
    }
    fn hp(&self) -> f32 {
        self.hp
    }
    fn max_hp(&self) -> f32 {
        self.max_hp
    }
}

/// Edge-to-edge distance.
pub(crate) fn edge(a: &impl Facts, b: &impl Facts) -> f32 {
    a.pos().dist(b.pos()) - a.radius() - b.radius()
}

/// The weapon of `u` that reaches `t`'s layer, with its index.
pub(crate) fn weapon_for(u: &impl Facts, t: &impl Facts) -> Option<(usize, &'static Weapon)> {
    let air = t.on_air();
    u.spec().weapons.iter().enumerate().find(|(_, w)| w.reach.hits(air))
}

/// Whether `t` is within the range band of `u`'s weapon against it.
pub(crate) fn in_weapon_range(u: &impl Facts, t: &impl Facts) -> bool {
    weapon_for(u, t).is_some_and(|(_, w)| {
        let d = edge(u, t);
        d <= w.range && d >= w.min_range
    })
}

/// Whether `u` may attack `t` (heal it, for a healer); `friendly`: same team.
pub(crate) fn attack(u: &impl Facts, t: &impl Facts, friendly: bool) -> Result<(), TargetProblem> {
    if u.heals() {
        if !friendly || t.id() == u.id() {
            return Err(TargetProblem::HealerNeedsFriend);
        }
        if !t.spec().attrs.has(Attrs::BIOLOGICAL) {
            return Err(TargetProblem::NotBiological);
        }
        return Ok(());
    }
    if friendly {
        return Err(TargetProblem::Friendly);
    }
    if weapon_for(u, t).is_none() {
        return Err(if t.on_air() { TargetProblem::NoAirWeapon } else { TargetProblem::NoGroundWeapon });
    }
    if u.speed() <= 0.0 && !in_weapon_range(u, t) {
        return Err(TargetProblem::OutOfReach);
    }
    Ok(())
}

fn invalid(why: impl Into<String>) -> Refusal {
    Refusal::InvalidTarget { why: why.into() }
}

/// The unit-target rules of a cast: the ability's side rule, its range and what it needs of
/// its target. `friendly`: same team.
pub(crate) fn cast_on(ability: Ability, u: &impl Facts, t: &impl Facts, friendly: bool) -> Result<(), Refusal> {
    let spec = ability.spec();
    match spec.rule {
        TargetRule::Enemy if friendly => return Err(invalid("needs an enemy unit")),
        TargetRule::Ally if !friendly || t.id() == u.id() => return Err(invalid("needs another friendly unit")),
        _ => {}
    }
    let distance = edge(u, t);
    if distance > spec.range {
        return Err(Refusal::OutOfRange { distance, range: spec.range });
    }
    let attrs = t.spec().attrs;
    let bio = attrs.has(Attrs::BIOLOGICAL);
    match ability {
        Ability::SteadyTargeting if !bio => Err(invalid("Steady Targeting needs a biological target")),
        Ability::Feedback if t.energy() <= 0.0 => Err(invalid("the target has no energy")),
        Ability::GravitonBeam if t.on_air() || attrs.has(Attrs::MASSIVE) || attrs.has(Attrs::STRUCTURE) => {
            Err(invalid("Graviton Beam lifts non-massive ground units only"))
        }
        Ability::GravitonBeam if t.morphing() => Err(invalid("the target is changing mode")),
        Ability::Kd8Charge if t.on_air() => Err(invalid("KD8 Charge hits ground units only")),
        Ability::Transfusion | Ability::Heal if !bio => Err(invalid("needs a biological target")),
        Ability::Transfusion | Ability::Heal if t.hp() >= t.max_hp() => Err(invalid("the target is at full health")),
        _ => Ok(()),
    }
}

/// The point-target rules of a cast, but Blink's vision of high ground (which needs the
/// side's vision: [`Sight::sees`]).
pub(crate) fn cast_at(ability: Ability, u: &impl Facts, to: Vec2, terrain: &Terrain) -> Result<(), Refusal> {
    if !to.is_finite() || !terrain.playable().contains(to) {
        return Err(invalid(format!("point ({}, {}) is outside the playable area", to.x, to.y)));
    }
    let range = ability.spec().range;
    let distance = u.pos().dist(to) - u.radius();
    if distance > range {
        return Err(Refusal::OutOfRange { distance, range });
    }
    if ability == Ability::Blink && !terrain.walkable(to) {
        return Err(invalid("Blink needs ground a unit can stand on"));
    }
    Ok(())
}

/// What a side knows when it checks an action: the world, or an observation.
pub(crate) trait Sight {
    type U: Facts;
    fn terrain(&self) -> &Terrain;
    /// The acting unit, which must be `team`'s: `None` when it is dead.
    fn actor(&self, team: Team, unit: UnitId) -> Result<Option<&Self::U>, ActionError>;
    /// A living unit `team` sees, and whether it is on `team`'s side.
    fn seen(&self, team: Team, target: UnitId) -> Result<(&Self::U, bool), ActionError>;
    /// Whether `team` sees point `p` (an observation may say no where the world says yes).
    fn sees(&self, team: Team, p: Vec2) -> bool;
    /// Everything about a cast but its target (energy, cooldown, upgrade, mode, state).
    fn castable(&self, u: &Self::U, ability: Ability) -> Result<(), Refusal>;
}

/// A whole cast: castable now, and its target by the rules.
pub(crate) fn cast<S: Sight>(s: &S, team: Team, u: &S::U, ability: Ability, target: AbilityTarget) -> Result<(), Refusal> {
    s.castable(u, ability)?;
    use crate::ability::TargetKind as K;
    match (ability.spec().target, target) {
        (K::None, AbilityTarget::None) => Ok(()),
        (K::Point | K::PointOrUnit, AbilityTarget::Point { to }) => {
            cast_at(ability, u, to, s.terrain())?;
            let t = s.terrain();
            if ability == Ability::Blink && t.height_at(to) > t.height_at(u.pos()) + 0.5 && !s.sees(team, to) {
                return Err(invalid("Blink up a cliff needs vision of the higher ground"));
            }
            Ok(())
        }
        (K::Unit | K::PointOrUnit, AbilityTarget::Unit { unit }) => {
            // Unknown, dead and unseen units get the same answer, so a refusal never tells
            // whether a hidden enemy lives.
            let (t, friendly) = s.seen(team, unit).map_err(|_| invalid(format!("unit #{} is not visible", unit.tag())))?;
            cast_on(ability, u, t, friendly)
        }
        (expected, _) => Err(Refusal::WrongTargetKind { expected }),
    }
}

/// The order an action gives, or why it is refused; `None` keeps the current order (and for
/// an ability, the cast is queued by the caller).
pub(crate) fn check<S: Sight>(s: &S, team: Team, a: &Action) -> Result<Option<Order>, ActionError> {
    let unit = a.unit;
    let u = s.actor(team, unit)?;
    if a.command == Command::NoOp {
        // SMAC's required action for dead agents; for living ones, keep the order.
        return Ok(None);
    }
    let u = u.ok_or(ActionError::DeadUnit { unit })?;
    if let Command::Ability { ability, target } = a.command {
        return cast(s, team, u, ability, target).map(|_| None).map_err(|refusal| ActionError::AbilityRefused { unit, ability, refusal });
    }
    if let Command::Look { sector, sectors } = a.command {
        // Turning the field of view keeps the order, whatever the unit is doing.
        return if sector < sectors { Ok(None) } else { Err(ActionError::BadLook { sector, sectors }) };
    }
    let cannot = |why| ActionError::Unavailable { unit, why };
    if u.morphing() && a.command != Command::Stop {
        return Err(cannot(Inability::Morphing));
    }
    let terrain = s.terrain();
    let playable = terrain.playable();
    let mobile = || if u.speed() > 0.0 { Ok(()) } else { Err(cannot(Inability::Immobile { kind: u.kind() })) };
    let in_map = |p: Vec2| if p.is_finite() && playable.contains(p) { Ok(p) } else { Err(ActionError::OffMap { x: p.x, y: p.y }) };
    // Ground units head for the nearest point they can actually reach (a grid cell over a
    // cliff or outside the arena means "as close as you can get").
    let reach = |p: Vec2| -> Result<Vec2, ActionError> {
        if u.on_air() {
            return Ok(p);
        }
        terrain.reachable_point(u.pos(), p, u.spec().cliff_walk).ok_or(cannot(Inability::NoGround))
    };
    Ok(match a.command {
        Command::NoOp | Command::Ability { .. } | Command::Look { .. } => None,
        Command::Stop => Some(Order::Idle),
        Command::Hold => Some(Order::Hold),
        Command::Attack { target } => {
            let (t, friendly) = s.seen(team, target)?;
            attack(u, t, friendly).map_err(|why| ActionError::InvalidTarget { unit, target, why })?;
            Some(Order::Attack { target })
        }
        Command::MoveGrid { x, y } => {
            if !(1..=GRID).contains(&x) || !(1..=GRID).contains(&y) {
                return Err(ActionError::OffGrid { x, y });
            }
            mobile()?;
            Some(Order::Move { to: reach(grid_cell_center(playable, x, y))? })
        }
        Command::MoveDir { dir } => {
            mobile()?;
            Some(Order::Move { to: reach(playable.clamp(u.pos() + dir.vector() * MOVE_AMOUNT, 0.0))? })
        }
        Command::MoveTo { to } => {
            mobile()?;
            Some(Order::Move { to: reach(in_map(to)?)? })
        }
        Command::AttackMoveTo { to } => {
            mobile()?;
            Some(Order::AttackMove { to: reach(in_map(to)?)? })
        }
    })
}

impl Sight for World {
    type U = Unit;
    fn terrain(&self) -> &Terrain {
        World::terrain(self)
    }
    fn actor(&self, team: Team, unit: UnitId) -> Result<Option<&Unit>, ActionError> {
        let u = self.unit(unit).ok_or(ActionError::UnknownUnit { unit })?;
        if u.team != team {
            return Err(ActionError::NotYourUnit { unit, owner: u.team, team });
        }
        Ok(u.alive.then_some(u))
    }
    fn seen(&self, team: Team, target: UnitId) -> Result<(&Unit, bool), ActionError> {
        let t = self.unit(target).ok_or(ActionError::UnknownTarget { target })?;
        if !t.alive {
            return Err(ActionError::TargetDead { target });
        }
        if !self.visible_to(team, target) {
            return Err(ActionError::TargetNotVisible { target, team });
        }
        Ok((t, t.team == team))
    }
    fn sees(&self, team: Team, p: Vec2) -> bool {
        self.team_sees_point(team, p)
    }
    fn castable(&self, u: &Unit, ability: Ability) -> Result<(), Refusal> {
        self.can_cast(u, ability)
    }
}

impl World {
    /// Checks an action for `team` and, if valid, gives the unit its new order.
    pub fn apply(&mut self, team: Team, a: &Action) -> Result<(), ActionError> {
        let order = self.validate(team, a)?;
        if let Command::Ability { ability, target } = a.command {
            self.pending_casts.push(PendingCast { team, unit: a.unit, ability, target });
            return Ok(());
        }
        if let Command::Look { sector, sectors } = a.command {
            if let Some(u) = self.units.get_mut(a.unit.index()) {
                u.look = Command::look_direction(sector, sectors);
            }
            return Ok(());
        }
        if let Some(o) = order {
            // A new order ends a channel (Steady Targeting, Graviton Beam).
            self.cancel_channel(a.unit.index());
            self.set_order(a.unit, o);
        }
        Ok(())
    }

    /// The order an action would give, or why it is refused; `None` keeps the current order.
    /// The rules are [`check`]'s, which observations check actions with too.
    pub fn validate(&self, team: Team, a: &Action) -> Result<Option<Order>, ActionError> {
        check(self, team, a)
    }
}
