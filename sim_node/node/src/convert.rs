//! The engine's structures to messages and back. Every action off the wire passes
//! `action_from_msg`, which names what is wrong instead of guessing.

use avacraft_engine::{Ability, AbilityTarget, Action, Command, Direction, Env, Team, UnitId, UnitInfo, Vec2, World, describe, unit_list};
use avacraft_msgs::{AbilityState, AreaEffect, Header, Time, UnitAction, UnitObservation, UnitState};

/// Header stamped with game time (the simulation's clock, as `/clock` would give it).
pub fn header(world: &World, frame: &str) -> Header {
    let loops = world.tick() as u64;
    let nanos = loops * 1_000_000_000 * 10 / 224;
    Header { stamp: Time { sec: (nanos / 1_000_000_000) as i32, nanosec: (nanos % 1_000_000_000) as u32 }, frame_id: frame.to_owned() }
}

pub fn unit_state(u: &UnitInfo) -> UnitState {
    UnitState {
        tag: u.tag,
        name: u.name.clone(),
        unit_type: u.kind.name().to_owned(),
        team: u.team,
        x: u.x,
        y: u.y,
        hp: u.hp,
        max_hp: u.max_hp,
        shield: u.shield,
        max_shield: u.max_shield,
        energy: u.energy,
        max_energy: u.max_energy,
        weapon_cooldown_s: u.weapon_cooldown_s,
        grid_x: u.grid[0],
        grid_y: u.grid[1],
        order: serde_name(&u.order),
        target_tag: u.target.unwrap_or(0),
        flags: u.flags.iter().map(|s| (*s).to_owned()).collect(),
        buffs: u.buffs.iter().map(|s| (*s).to_owned()).collect(),
    }
}

fn serde_name(o: &avacraft_engine::OrderInfo) -> String {
    match o {
        avacraft_engine::OrderInfo::Idle => "idle".into(),
        avacraft_engine::OrderInfo::Hold => "hold".into(),
        avacraft_engine::OrderInfo::Move { x, y } => format!("move {x:.1} {y:.1}"),
        avacraft_engine::OrderInfo::AttackMove { x, y } => format!("attack_move {x:.1} {y:.1}"),
        avacraft_engine::OrderInfo::Attack { target } => format!("attack {target}"),
    }
}

pub fn effects(world: &World, team: Team) -> Vec<AreaEffect> {
    let tick = world.tick();
    world
        .area_effects()
        .iter()
        .filter(|e| e.active(tick) && (e.team == team || world.team_sees_point(team, e.pos)))
        .map(|e| AreaEffect {
            kind: e.kind.name().to_owned(),
            team: e.team.player(),
            x: e.pos.x,
            y: e.pos.y,
            radius: e.radius,
            remaining_s: e.until.saturating_sub(tick) as f32 / avacraft_engine::LOOPS_PER_SECOND,
        })
        .collect()
}

/// The observation of one unit: itself, what its team sees, its abilities, SMAC's mask and
/// features, and the team's text.
pub fn unit_observation(env: &Env, team: Team, agent: usize, episode: u64, text: &str) -> UnitObservation {
    let w = env.world();
    let id = env.agents(team)[agent];
    let list = unit_list(w, team);
    let me = list.iter().find(|u| u.tag == id.tag());
    let l = env.smac_layout(team);
    let mut avail = vec![0u8; l.n_actions];
    env.avail_agent(team, agent, &mut avail);
    let mut features = vec![0f32; l.obs_size];
    env.obs_agent(team, agent, &mut features);
    UnitObservation {
        header: header(w, "map"),
        episode,
        step: env.steps(),
        game_loop: w.tick(),
        unit_tag: id.tag(),
        alive: me.is_some(),
        own: me.map(unit_state).unwrap_or_default(),
        allies: list.iter().filter(|u| u.own && u.tag != id.tag()).map(unit_state).collect(),
        enemies: list.iter().filter(|u| !u.own).map(unit_state).collect(),
        abilities: me
            .map(|u| {
                u.abilities
                    .iter()
                    .map(|a| AbilityState {
                        ability: a.ability.name().to_owned(),
                        available: a.available,
                        cooldown_s: a.cooldown_s,
                        energy_cost: a.energy_cost,
                        target_kind: format!("{:?}", a.target).to_lowercase(),
                    })
                    .collect()
            })
            .unwrap_or_default(),
        effects: effects(w, team),
        avail_actions: avail,
        features,
        text: text.to_owned(),
    }
}

/// The team's text description (computed once per step and shared by its units).
pub fn team_text(env: &Env, team: Team) -> String {
    describe(env, team)
}

/// Why an action message was refused before reaching the engine.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BadAction {
    #[error("unit tag {0} does not exist")]
    UnknownUnit(u32),
    #[error("unknown action kind {0}")]
    Kind(u8),
    #[error("unknown direction {0}")]
    Direction(u8),
    #[error("unknown ability target kind {0}")]
    TargetKind(u8),
    #[error("target tag {0} does not exist")]
    UnknownTarget(u32),
    #[error("{0}")]
    Ability(String),
    #[error("point ({0}, {1}) is not finite")]
    Point(f32, f32),
}

fn unit_id(w: &World, tag: u32) -> Option<UnitId> {
    let i = tag.checked_sub(1)?;
    let id = UnitId::new(u16::try_from(i).ok()?);
    w.unit(id).map(|_| id)
}

/// A message to an engine action (the engine then checks it against the game's rules).
pub fn action_from_msg(w: &World, a: &UnitAction) -> Result<Action, BadAction> {
    let unit = unit_id(w, a.unit_tag).ok_or(BadAction::UnknownUnit(a.unit_tag))?;
    let point = || if a.x.is_finite() && a.y.is_finite() { Ok(Vec2::new(a.x, a.y)) } else { Err(BadAction::Point(a.x, a.y)) };
    let target = || unit_id(w, a.target_tag).ok_or(BadAction::UnknownTarget(a.target_tag));
    let command = match a.kind {
        UnitAction::NOOP => Command::NoOp,
        UnitAction::STOP => Command::Stop,
        UnitAction::HOLD => Command::Hold,
        UnitAction::ATTACK => Command::Attack { target: target()? },
        UnitAction::MOVE_GRID => Command::MoveGrid { x: a.grid_x, y: a.grid_y },
        UnitAction::MOVE_DIR => Command::MoveDir {
            dir: match a.direction {
                UnitAction::UP => Direction::Up,
                UnitAction::DOWN => Direction::Down,
                UnitAction::LEFT => Direction::Left,
                UnitAction::RIGHT => Direction::Right,
                d => return Err(BadAction::Direction(d)),
            },
        },
        UnitAction::MOVE_TO => Command::MoveTo { to: point()? },
        UnitAction::ATTACK_MOVE_TO => Command::AttackMoveTo { to: point()? },
        UnitAction::ABILITY => {
            let ability: Ability = a.ability.parse().map_err(|e: avacraft_engine::UnknownAbility| BadAction::Ability(e.to_string()))?;
            let target = match a.ability_target {
                UnitAction::TARGET_NONE => AbilityTarget::None,
                UnitAction::TARGET_POINT => AbilityTarget::Point { to: point()? },
                UnitAction::TARGET_UNIT => AbilityTarget::Unit { unit: target()? },
                k => return Err(BadAction::TargetKind(k)),
            };
            Command::Ability { ability, target }
        }
        k => return Err(BadAction::Kind(k)),
    };
    Ok(Action::new(unit, command))
}
