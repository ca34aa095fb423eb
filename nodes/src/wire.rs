//! The engine's observation types to messages and back, losslessly. Enumerations travel as
//! the numbers `.msg` constants name (engine order, 1-based where 0 means "none"), sets as
//! bits; a value off the wire that names nothing is an error, never a guess. The tests
//! check every constant in the `.msg` files against the engine's tables.

use avacraft_engine::agent::{AgentObs, EffectInfo};
use avacraft_engine::{
    Ability, AbilityInfo, AbilityTarget, Action, Activity, Buffs, Command, DataSet, Direction, EffectKind, OrderInfo, RefusalCode,
    TargetKind, Team, UnitFlags, UnitId, UnitInfo, UnitKind, UnknownBits, Vec2,
};
use avacraft_msgs::{AbilityState, AreaEffect, Header, UnitAction, UnitObservation, UnitState};
use std::sync::Arc;

/// A field off the wire that does not name anything the engine knows.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum WireError {
    #[error("{field} = {value}: no such value (see the constants in {msg}.msg)")]
    Unknown { msg: &'static str, field: &'static str, value: u32 },
    #[error(transparent)]
    Bits(#[from] UnknownBits),
    #[error("UnitObservation: unit_tag {tag} is not the tag of its `own` state ({own})")]
    OwnTag { tag: u32, own: u32 },
    #[error("UnitAction: unit_tag is 0 or past 65536 (tags start at 1)")]
    ZeroTag,
    #[error("{msg}.{field} = {value}: not a unit tag (tags run from 1 to 65536)")]
    Tag { msg: &'static str, field: &'static str, value: u32 },
    #[error("{msg}.{field} = {value}: not a team (1 or 2)")]
    Team { msg: &'static str, field: &'static str, value: u8 },
    #[error("UnitAction: point ({0}, {1}) is not finite")]
    Point(f32, f32),
}

fn code_of<T: PartialEq>(all: &[T], v: &T) -> u8 {
    // Every table here is far shorter than 255 entries.
    all.iter().position(|x| x == v).map_or(0, |i| i as u8 + 1)
}

fn from_code<T: Copy>(all: &[T], code: u8, msg: &'static str, field: &'static str) -> Result<T, WireError> {
    (code as usize).checked_sub(1).and_then(|i| all.get(i)).copied().ok_or(WireError::Unknown { msg, field, value: code as u32 })
}

pub fn unit_type_code(k: UnitKind) -> u8 {
    code_of(&UnitKind::ALL, &k)
}
pub fn unit_type_from(code: u8) -> Result<UnitKind, WireError> {
    from_code(&UnitKind::ALL, code, "UnitState", "unit_type")
}
pub fn ability_code(a: Ability) -> u8 {
    code_of(&Ability::ALL, &a)
}
pub fn ability_from(code: u8) -> Result<Ability, WireError> {
    from_code(&Ability::ALL, code, "AbilityState", "ability")
}
pub fn effect_code(k: EffectKind) -> u8 {
    code_of(&EffectKind::ALL, &k)
}
pub fn effect_from(code: u8) -> Result<EffectKind, WireError> {
    from_code(&EffectKind::ALL, code, "AreaEffect", "kind")
}

const TARGETS: [TargetKind; 4] = [TargetKind::None, TargetKind::Point, TargetKind::Unit, TargetKind::PointOrUnit];
const ACTIVITIES: [Activity; 5] = [Activity::Idle, Activity::Moving, Activity::Attacking, Activity::Healing, Activity::Dead];

/// A unit named on the wire: its tag, checked.
pub fn tag_in(msg: &'static str, field: &'static str, value: u32) -> Result<UnitId, WireError> {
    UnitId::try_from(value).map_err(|_| WireError::Tag { msg, field, value })
}

/// A team named on the wire: its player number, checked.
fn team_in(msg: &'static str, field: &'static str, value: u8) -> Result<Team, WireError> {
    Team::from_player(value.into()).ok_or(WireError::Team { msg, field, value })
}

fn order_parts(o: &OrderInfo) -> (u8, f32, f32, u32) {
    match *o {
        OrderInfo::Idle => (UnitState::ORDER_IDLE, 0.0, 0.0, 0),
        OrderInfo::Hold => (UnitState::ORDER_HOLD, 0.0, 0.0, 0),
        OrderInfo::Move { x, y } => (UnitState::ORDER_MOVE, x, y, 0),
        OrderInfo::AttackMove { x, y } => (UnitState::ORDER_ATTACK_MOVE, x, y, 0),
        OrderInfo::Attack { target } => (UnitState::ORDER_ATTACK, 0.0, 0.0, target.tag()),
    }
}

fn order_from(s: &UnitState) -> Result<OrderInfo, WireError> {
    Ok(match s.order {
        UnitState::ORDER_IDLE => OrderInfo::Idle,
        UnitState::ORDER_HOLD => OrderInfo::Hold,
        UnitState::ORDER_MOVE => OrderInfo::Move { x: s.order_x, y: s.order_y },
        UnitState::ORDER_ATTACK_MOVE => OrderInfo::AttackMove { x: s.order_x, y: s.order_y },
        UnitState::ORDER_ATTACK => OrderInfo::Attack { target: tag_in("UnitState", "order_target", s.order_target)? },
        v => return Err(WireError::Unknown { msg: "UnitState", field: "order", value: v as u32 }),
    })
}

/// One unit as the wire carries it (its abilities travel next to it, own units only).
pub fn unit_state(u: &UnitInfo) -> UnitState {
    let (order, order_x, order_y, order_target) = order_parts(&u.order);
    UnitState {
        tag: u.tag.tag(),
        name: u.name.clone(),
        unit_type: unit_type_code(u.kind),
        team: u.team.player(),
        own: u.own,
        x: u.x,
        y: u.y,
        hp: u.hp,
        max_hp: u.max_hp,
        shield: u.shield,
        max_shield: u.max_shield,
        energy: u.energy,
        max_energy: u.max_energy,
        speed: u.speed,
        weapon_cooldown_s: u.weapon_cooldown_s,
        grid_x: u.grid[0],
        grid_y: u.grid[1],
        order,
        order_x,
        order_y,
        order_target,
        activity: code_of(&ACTIVITIES, &u.activity) - 1,
        target_tag: u.target.map_or(0, UnitId::tag),
        flags: u.flags.bits(),
        buffs: u.buffs.bits(),
        data_set: u.data.code(),
    }
}

/// The data set a unit's stats come from; a type the set lacks is refused.
fn data_set_from(s: &UnitState) -> Result<DataSet, WireError> {
    let d = DataSet::from_code(s.data_set).ok_or(WireError::Unknown { msg: "UnitState", field: "data_set", value: s.data_set as u32 })?;
    let kind = unit_type_from(s.unit_type)?;
    if !d.has(kind) {
        return Err(WireError::Unknown { msg: "UnitState", field: "data_set", value: s.data_set as u32 });
    }
    Ok(d)
}

/// The inverse of [`unit_state`]: `abilities` are the unit's own (empty for others).
pub fn unit_info(s: &UnitState, abilities: &[AbilityState]) -> Result<UnitInfo, WireError> {
    Ok(UnitInfo {
        tag: tag_in("UnitState", "tag", s.tag)?,
        name: s.name.clone(),
        kind: unit_type_from(s.unit_type)?,
        data: data_set_from(s)?,
        team: team_in("UnitState", "team", s.team)?,
        own: s.own,
        x: s.x,
        y: s.y,
        grid: [s.grid_x, s.grid_y],
        hp: s.hp,
        max_hp: s.max_hp,
        shield: s.shield,
        max_shield: s.max_shield,
        energy: s.energy,
        max_energy: s.max_energy,
        speed: s.speed,
        weapon_cooldown_s: s.weapon_cooldown_s,
        order: order_from(s)?,
        activity: from_code(&ACTIVITIES, s.activity.saturating_add(1), "UnitState", "activity")?,
        target: (s.target_tag != 0).then(|| tag_in("UnitState", "target_tag", s.target_tag)).transpose()?,
        flags: UnitFlags::from_bits(s.flags)?,
        buffs: Buffs::from_bits(s.buffs)?,
        abilities: abilities.iter().map(ability_info).collect::<Result<_, _>>()?,
    })
}

pub fn ability_state(a: &AbilityInfo) -> AbilityState {
    AbilityState {
        ability: ability_code(a.ability),
        available: a.available,
        unavailable: a.why_not.map_or(AbilityState::UNAVAILABLE_NONE, |c| code_of(&RefusalCode::ALL, &c)),
        cooldown_s: a.cooldown_s,
        energy_cost: a.energy_cost,
        range: a.range,
        target_kind: code_of(&TARGETS, &a.target) - 1,
    }
}

pub fn ability_info(a: &AbilityState) -> Result<AbilityInfo, WireError> {
    Ok(AbilityInfo {
        ability: ability_from(a.ability)?,
        target: from_code(&TARGETS, a.target_kind.saturating_add(1), "AbilityState", "target_kind")?,
        energy_cost: a.energy_cost,
        range: a.range,
        cooldown_s: a.cooldown_s,
        available: a.available,
        why_not: match a.unavailable {
            AbilityState::UNAVAILABLE_NONE => None,
            c => Some(from_code(&RefusalCode::ALL, c, "AbilityState", "unavailable")?),
        },
    })
}

pub fn area_effect(e: &EffectInfo) -> AreaEffect {
    AreaEffect { kind: effect_code(e.kind), team: e.team.player(), x: e.x, y: e.y, radius: e.radius, remaining_s: e.remaining_s }
}

pub fn effect_info(e: &AreaEffect) -> Result<EffectInfo, WireError> {
    Ok(EffectInfo {
        kind: effect_from(e.kind)?,
        team: team_in("AreaEffect", "team", e.team)?,
        x: e.x,
        y: e.y,
        radius: e.radius,
        remaining_s: e.remaining_s,
    })
}

/// One unit's observation as the simulator node publishes it.
pub fn unit_observation(o: &AgentObs, header: Header) -> UnitObservation {
    UnitObservation {
        header,
        episode: o.episode,
        seed: o.seed,
        step: o.step,
        game_loop: o.game_loop,
        unit_tag: o.unit.tag(),
        alive: o.alive,
        own: o.own.as_ref().map(unit_state).unwrap_or_default(),
        allies: o.allies.iter().map(unit_state).collect(),
        enemies: o.enemies.iter().map(unit_state).collect(),
        abilities: o.own.as_ref().map(|u| u.abilities.iter().map(ability_state).collect()).unwrap_or_default(),
        effects: o.effects.iter().map(area_effect).collect(),
        avail_actions: o.avail_actions.clone(),
        features: o.features.clone(),
        text: o.text.to_string(),
    }
}

/// The inverse of [`unit_observation`]: what an agent node hands its policy. `team` is the
/// node's (an observation of a dead unit carries no unit to read it from).
pub fn agent_obs(m: &UnitObservation, team: Team) -> Result<AgentObs, WireError> {
    let own = if m.alive {
        if m.own.tag != m.unit_tag {
            return Err(WireError::OwnTag { tag: m.unit_tag, own: m.own.tag });
        }
        Some(unit_info(&m.own, &m.abilities)?)
    } else {
        None
    };
    Ok(AgentObs {
        episode: m.episode,
        seed: m.seed,
        step: m.step,
        game_loop: m.game_loop,
        unit: tag_in("UnitObservation", "unit_tag", m.unit_tag)?,
        team,
        alive: m.alive,
        own,
        allies: m.allies.iter().map(|u| unit_info(u, &[])).collect::<Result<_, _>>()?,
        enemies: m.enemies.iter().map(|u| unit_info(u, &[])).collect::<Result<_, _>>()?,
        effects: m.effects.iter().map(effect_info).collect::<Result<_, _>>()?,
        avail_actions: m.avail_actions.clone(),
        features: m.features.clone(),
        text: Arc::from(m.text.as_str()),
    })
}

fn tag_of(id: UnitId) -> u32 {
    id.tag()
}

fn unit_of(tag: u32) -> Result<UnitId, WireError> {
    UnitId::try_from(tag).map_err(|_| WireError::ZeroTag)
}

/// An engine action as an agent node sends it.
pub fn unit_action(a: &Action) -> UnitAction {
    let base = UnitAction { unit_tag: tag_of(a.unit), ..UnitAction::default() };
    match a.command {
        Command::NoOp => UnitAction { kind: UnitAction::NOOP, ..base },
        Command::Stop => UnitAction { kind: UnitAction::STOP, ..base },
        Command::Hold => UnitAction { kind: UnitAction::HOLD, ..base },
        Command::Attack { target } => UnitAction { kind: UnitAction::ATTACK, target_tag: tag_of(target), ..base },
        Command::MoveGrid { x, y } => UnitAction { kind: UnitAction::MOVE_GRID, grid_x: x, grid_y: y, ..base },
        Command::MoveDir { dir } => UnitAction {
            kind: UnitAction::MOVE_DIR,
            direction: match dir {
                Direction::Up => UnitAction::UP,
                Direction::Down => UnitAction::DOWN,
                Direction::Left => UnitAction::LEFT,
                Direction::Right => UnitAction::RIGHT,
            },
            ..base
        },
        Command::MoveTo { to } => UnitAction { kind: UnitAction::MOVE_TO, x: to.x, y: to.y, ..base },
        Command::Look { sector, sectors } => UnitAction { kind: UnitAction::LOOK, look_sector: sector, look_sectors: sectors, ..base },
        Command::AttackMoveTo { to } => UnitAction { kind: UnitAction::ATTACK_MOVE_TO, x: to.x, y: to.y, ..base },
        Command::Ability { ability, target } => {
            let b = UnitAction { kind: UnitAction::ABILITY, ability: ability_code(ability), ..base };
            match target {
                AbilityTarget::None => UnitAction { ability_target: UnitAction::TARGET_NONE, ..b },
                AbilityTarget::Point { to } => UnitAction { ability_target: UnitAction::TARGET_POINT, x: to.x, y: to.y, ..b },
                AbilityTarget::Unit { unit } => UnitAction { ability_target: UnitAction::TARGET_UNIT, target_tag: tag_of(unit), ..b },
            }
        }
    }
}

/// The inverse of [`unit_action`]. Whether the units exist is the game's to check.
pub fn action(a: &UnitAction) -> Result<Action, WireError> {
    let unit = unit_of(a.unit_tag)?;
    let point = || if a.x.is_finite() && a.y.is_finite() { Ok(Vec2::new(a.x, a.y)) } else { Err(WireError::Point(a.x, a.y)) };
    let bad = |field: &'static str, value: u8| WireError::Unknown { msg: "UnitAction", field, value: value as u32 };
    let command = match a.kind {
        UnitAction::NOOP => Command::NoOp,
        UnitAction::STOP => Command::Stop,
        UnitAction::HOLD => Command::Hold,
        UnitAction::ATTACK => Command::Attack { target: unit_of(a.target_tag)? },
        UnitAction::MOVE_GRID => Command::MoveGrid { x: a.grid_x, y: a.grid_y },
        UnitAction::MOVE_DIR => Command::MoveDir {
            dir: match a.direction {
                UnitAction::UP => Direction::Up,
                UnitAction::DOWN => Direction::Down,
                UnitAction::LEFT => Direction::Left,
                UnitAction::RIGHT => Direction::Right,
                d => return Err(bad("direction", d)),
            },
        },
        UnitAction::MOVE_TO => Command::MoveTo { to: point()? },
        // The engine refuses a sector outside its count, with the unit named.
        UnitAction::LOOK => Command::Look { sector: a.look_sector, sectors: a.look_sectors },
        UnitAction::ATTACK_MOVE_TO => Command::AttackMoveTo { to: point()? },
        UnitAction::ABILITY => {
            let target = match a.ability_target {
                UnitAction::TARGET_NONE => AbilityTarget::None,
                UnitAction::TARGET_POINT => AbilityTarget::Point { to: point()? },
                UnitAction::TARGET_UNIT => AbilityTarget::Unit { unit: unit_of(a.target_tag)? },
                k => return Err(bad("ability_target", k)),
            };
            Command::Ability { ability: ability_from(a.ability)?, target }
        }
        k => return Err(bad("kind", k)),
    };
    Ok(Action::new(unit, command))
}

#[cfg(test)]
mod tests {
    use super::*;
    use avacraft_msgs::{RosMessage, UnitAction, embedded_registry};

    fn msg_constants<T: RosMessage>(prefix: &str) -> Vec<(String, u64)> {
        let spec = embedded_registry().get(T::TYPE_NAME).expect("embedded");
        spec.constants
            .iter()
            .filter_map(|c| Some((c.name.strip_prefix(prefix)?.to_owned(), c.value.parse::<u64>().expect("unsigned constant"))))
            .collect()
    }

    fn upper_snake(name: &str) -> String {
        let mut out = String::new();
        for (i, c) in name.chars().enumerate() {
            if c.is_ascii_uppercase() && i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_uppercase());
        }
        out
    }

    #[test]
    fn msg_constants_are_the_engine_tables() {
        let types: Vec<(String, u64)> = UnitKind::ALL.iter().map(|k| (upper_snake(k.name()), unit_type_code(*k) as u64)).collect();
        assert_eq!(msg_constants::<UnitState>("TYPE_"), types);
        let flags: Vec<(String, u64)> = UnitFlags::CONSTANTS.iter().map(|(n, v)| ((*n).to_owned(), *v as u64)).collect();
        assert_eq!(msg_constants::<UnitState>("FLAG_"), flags);
        let buffs: Vec<(String, u64)> = Buffs::CONSTANTS.iter().map(|(n, v)| ((*n).to_owned(), *v as u64)).collect();
        assert_eq!(msg_constants::<UnitState>("BUFF_"), buffs);
        let abilities: Vec<(String, u64)> = Ability::ALL.iter().map(|a| (a.name().to_uppercase(), ability_code(*a) as u64)).collect();
        assert_eq!(msg_constants::<AbilityState>("ABILITY_"), abilities);
        let effects: Vec<(String, u64)> = EffectKind::ALL.iter().map(|k| (k.name().to_uppercase(), effect_code(*k) as u64)).collect();
        assert_eq!(msg_constants::<AreaEffect>("KIND_"), effects);
        let mut reasons = vec![("NONE".to_owned(), 0)];
        reasons.extend(RefusalCode::ALL.iter().map(|c| (upper_snake(&format!("{c:?}")), code_of(&RefusalCode::ALL, c) as u64)));
        assert_eq!(msg_constants::<AbilityState>("UNAVAILABLE_"), reasons);
        let targets: Vec<(String, u64)> =
            TARGETS.iter().map(|t| (upper_snake(&format!("{t:?}")), code_of(&TARGETS, t) as u64 - 1)).collect();
        assert_eq!(msg_constants::<AbilityState>("TARGET_"), targets);
        let acts: Vec<(String, u64)> =
            ACTIVITIES.iter().map(|a| (upper_snake(&format!("{a:?}")), code_of(&ACTIVITIES, a) as u64 - 1)).collect();
        assert_eq!(msg_constants::<UnitState>("ACTIVITY_"), acts);
        // Actions name abilities with the same numbers.
        assert!(embedded_registry().get(UnitAction::TYPE_NAME).is_some());
    }

    /// Every unit both teams see, with abilities, buffs and orders of all kinds, survives the
    /// trip through the messages unchanged.
    #[test]
    fn real_observations_round_trip() {
        use avacraft_engine::{Controllers, Env, EnvConfig, Team, builtin, unit_list};
        let mut seen = (0, UnitFlags::empty(), Buffs::empty());
        for name in ["3m_vlm", "pvz_ht", "8m3mr1mv1st_mirror", "MMM_vs_MMM", "2c_vs_64zg_vlm"] {
            let scenario = Arc::new(builtin(name).expect("scenario"));
            let mut env = Env::new(Arc::clone(&scenario), EnvConfig::default(), 3);
            let mut ctl = Controllers::named(&scenario, "focus-fire", Some("focus-fire")).expect("policy");
            ctl.reset(&env);
            for step in 0..200 {
                ctl.act(&mut env);
                if step % 7 == 0 {
                    for team in [Team::One, Team::Two] {
                        for u in unit_list(env.world(), team) {
                            let abilities: Vec<AbilityState> = u.abilities.iter().map(ability_state).collect();
                            assert_eq!(unit_info(&unit_state(&u), &abilities).as_ref(), Ok(&u), "{name} step {step}");
                            seen.0 += 1;
                            seen.1.insert(u.flags);
                            seen.2.insert(u.buffs);
                        }
                    }
                }
                if env.step().done {
                    break;
                }
            }
        }
        assert!(seen.0 > 1000 && seen.1.contains(UnitFlags::FLYING) && !seen.2.is_empty(), "{seen:?}");
    }

    /// Observations of every unit of a few scenarios, and every kind of action, go through
    /// the messages and come back equal.
    #[test]
    fn agent_observations_and_actions_round_trip() {
        use avacraft_engine::{Env, EnvConfig, Team, builtin};
        for name in ["3m_vlm", "pvz_ht", "8m3mr1mv1st_mirror"] {
            let mut env = Env::new(Arc::new(builtin(name).expect("scenario")), EnvConfig::default(), 5);
            for step in 0..120 {
                if step % 30 == 0 {
                    for team in [Team::One, Team::Two] {
                        for o in env.agent_observations(team, 4) {
                            let m = unit_observation(&o, Header::default());
                            let back = avacraft_msgs::decode::<UnitObservation>(&avacraft_msgs::encode(&m)).expect("decodes");
                            assert_eq!(agent_obs(&back, o.team).as_ref(), Ok(&o), "{name} step {step}");
                        }
                    }
                }
                env.step();
            }
        }
        let u = UnitId::new(2);
        let t = UnitId::new(7);
        let p = Vec2::new(3.5, 9.25);
        let mut commands = vec![
            Command::NoOp,
            Command::Stop,
            Command::Hold,
            Command::Attack { target: t },
            Command::MoveGrid { x: 4, y: 9 },
            Command::MoveTo { to: p },
            Command::AttackMoveTo { to: p },
        ];
        commands.extend(Direction::ALL.map(|dir| Command::MoveDir { dir }));
        commands.extend((0..12).map(|sector| Command::Look { sector, sectors: 12 }));
        for ability in Ability::ALL {
            for target in [AbilityTarget::None, AbilityTarget::Point { to: p }, AbilityTarget::Unit { unit: t }] {
                commands.push(Command::Ability { ability, target });
            }
        }
        for c in commands {
            let a = Action::new(u, c);
            assert_eq!(action(&unit_action(&a)), Ok(a));
        }
        assert_eq!(action(&UnitAction { unit_tag: 0, ..UnitAction::default() }), Err(WireError::ZeroTag));
        let nan = UnitAction { unit_tag: 1, kind: UnitAction::MOVE_TO, x: f32::NAN, ..UnitAction::default() };
        assert!(matches!(action(&nan), Err(WireError::Point(..))));
        assert!(matches!(
            action(&UnitAction { unit_tag: 1, kind: 99, ..UnitAction::default() }),
            Err(WireError::Unknown { field: "kind", .. })
        ));
    }

    #[test]
    fn data_set_codes_are_the_msg_constants() {
        let pairs = [
            (DataSet::Liberty, UnitState::DATA_LIBERTY),
            (DataSet::Void, UnitState::DATA_VOID),
            (DataSet::Ladder, UnitState::DATA_LADDER),
            (DataSet::Legacy, UnitState::DATA_LEGACY),
        ];
        for (d, code) in pairs {
            assert_eq!(d.code(), code, "{d}");
            let s = UnitState { unit_type: 1, data_set: code, ..UnitState::default() };
            assert_eq!(data_set_from(&s).expect("known"), d);
        }
        // An unknown set, and a unit the set lacks (Liberty has no Hellbat), are refused.
        assert!(data_set_from(&UnitState { unit_type: 1, data_set: 9, ..UnitState::default() }).is_err());
        let hellbat = unit_type_code(UnitKind::Hellbat);
        assert!(data_set_from(&UnitState { unit_type: hellbat, data_set: 0, ..UnitState::default() }).is_err());
    }

    #[test]
    fn unknown_values_are_errors() {
        // A unit named by a valid tag of a valid team; each case breaks one field.
        let ok = UnitState { tag: 1, team: 1, unit_type: 1, ..UnitState::default() };
        assert!(unit_info(&ok, &[]).is_ok());
        let s = UnitState { unit_type: 200, ..ok.clone() };
        assert_eq!(unit_info(&s, &[]), Err(WireError::Unknown { msg: "UnitState", field: "unit_type", value: 200 }));
        let s = UnitState { order: 9, ..ok.clone() };
        assert!(matches!(unit_info(&s, &[]), Err(WireError::Unknown { field: "order", .. })));
        let s = UnitState { flags: 1 << 30, ..ok.clone() };
        assert!(matches!(unit_info(&s, &[]), Err(WireError::Bits(_))));
        // Ids are typed past the wire: tag 0 and team 3 name nothing.
        assert_eq!(unit_info(&UnitState { tag: 0, ..ok.clone() }, &[]), Err(WireError::Tag { msg: "UnitState", field: "tag", value: 0 }));
        assert_eq!(
            unit_info(&UnitState { team: 3, ..ok.clone() }, &[]),
            Err(WireError::Team { msg: "UnitState", field: "team", value: 3 })
        );
        let attack = UnitState { order: UnitState::ORDER_ATTACK, order_target: 0, ..ok.clone() };
        assert!(matches!(unit_info(&attack, &[]), Err(WireError::Tag { field: "order_target", .. })));
        let e = AreaEffect { kind: 1, team: 0, ..AreaEffect::default() };
        assert!(matches!(effect_info(&e), Err(WireError::Team { field: "team", .. })));
        let a = AbilityState { ability: 1, target_kind: 7, ..AbilityState::default() };
        assert!(matches!(ability_info(&a), Err(WireError::Unknown { field: "target_kind", .. })));
        assert!(matches!(ability_info(&AbilityState::default()), Err(WireError::Unknown { field: "ability", .. })));
    }
}
