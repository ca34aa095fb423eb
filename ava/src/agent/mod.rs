//! The AVA agent: the paper's pipeline behind the engine's one agent contract, so it plays
//! in-process, from Python and as an agent node alike.
//!
//! Per decision: the screenshot (drawn from the observation through a StarCraft-like camera)
//! and the unit block in the same grid's terms; the planner's micro plan (refreshed every N
//! decisions and when a unit is lost or new enemies appear); role assignment; priority
//! inference with a second screenshot ringing the named enemies; retrieval from the unit
//! knowledge base; then the decision, checked item by item, with repair rounds that tell the
//! model why items were refused. The executed actions are the model's, or the fallback's when
//! nothing valid came; both are counted.

mod command;
mod decide;
mod rich;
mod run;
mod situation;
mod stages;
mod state;

pub use command::AvaCommander;
pub use rich::describe_rich;
pub use run::{AvaRun, CallObserver};
pub use situation::{Tally, describe, place};
pub use stages::{Plan, Priority, ROLES, RoleOf, Skill};
pub use state::AvaSetup;

use crate::config::Timing;
use crate::cost::EpisodeCost;
use crate::decision::Order;
use avacraft_engine::agent::{Agent, AgentCtx, Briefing, GroupObs};
use avacraft_engine::{Action, Command, LOOPS_PER_SECOND, UnitId};
use avacraft_render::{CpuBackend, FrameBuilder};
use state::Episode;
use std::sync::Arc;

/// The agent.
#[derive(Debug)]
pub struct AvaAgent {
    name: String,
    setup: AvaSetup,
    frames: FrameBuilder,
    cpu: CpuBackend,
    ep: Option<Episode>,
}

impl AvaAgent {
    pub fn new(setup: AvaSetup) -> AvaAgent {
        let name = format!("ava:{}", setup.run.model());
        AvaAgent { name, setup, frames: FrameBuilder::new(), cpu: CpuBackend::new(), ep: None }
    }
}

impl Agent for AvaAgent {
    fn name(&self) -> &str {
        &self.name
    }

    fn reset(&mut self, ctx: &AgentCtx) {
        let cost = EpisodeCost { seed: ctx.seed, team: ctx.team.player(), ..EpisodeCost::default() };
        let cost_idx = self.setup.run.open_episode(cost.clone());
        self.ep = Some(Episode::new(ctx, cost_idx, cost));
    }

    fn brief(&mut self, briefing: &Briefing) {
        if let Some(ep) = self.ep.as_mut() {
            ep.briefing = Some(briefing.clone());
        }
    }

    fn act(&mut self, obs: &GroupObs) -> Vec<Action> {
        let Some(ep) = self.ep.as_mut() else { return Vec::new() };
        if let Some((step, lp)) = ep.last_seen
            && obs.step > step
            && obs.game_loop > lp
        {
            ep.loops_per_step = (obs.game_loop - lp) / (obs.step - step);
        }
        ep.last_seen = Some((obs.step, obs.game_loop));
        let mut alive: Vec<UnitId> = obs.controlled.iter().filter(|c| c.alive).map(|c| c.unit).collect();
        alive.sort_unstable();
        let orders = if let Some((ready, _)) = &ep.pending {
            if obs.step < *ready {
                Vec::new()
            } else {
                let (_, orders) = ep.pending.take().unwrap_or_default();
                // The game went on while the model thought: an order checked then may not hold
                // now (its target died or left sight). Those are dropped and counted as
                // refused, as the engine would refuse them.
                let terrain = &ep.scenario.terrain;
                let (fresh, stale): (Vec<_>, Vec<_>) = orders.into_iter().filter(|(t, _)| alive.contains(t)).partition(|(t, o)| match o {
                    Order::Do(c) => avacraft_engine::agent::check_action(obs, terrain, &Action::new(*t, *c)).is_ok(),
                    Order::Keep(_) => true,
                });
                ep.cost.refused_items += stale.len() as u64;
                fresh
            }
        } else {
            let first = *ep.first_step.get_or_insert(obs.step);
            let cfg = Arc::clone(&self.setup.config);
            if alive.is_empty() || !(obs.step - first).is_multiple_of(cfg.decide_every) {
                Vec::new()
            } else {
                let (orders, model_ms) = decide::decide(&self.setup, &mut self.frames, &mut self.cpu, ep, obs, &alive, decide::Mode::Full);
                let step_ms = ep.loops_per_step.max(1) as f64 * 1000.0 / LOOPS_PER_SECOND as f64;
                let delay = (model_ms / step_ms).ceil() as u32;
                if cfg.timing == Timing::Realtime && delay > 0 {
                    ep.pending = Some((obs.step + delay, orders));
                    Vec::new()
                } else {
                    orders
                }
            }
        };
        let mut out = Vec::new();
        for (t, o) in orders {
            match o {
                Order::Do(c) => {
                    // A new order ends the unit's stance; an ability (Stimpack, Siege Mode, a
                    // KD8 Charge thrown, a Blink) does not change what the unit keeps doing,
                    // as the scripts go on with their rules after casting.
                    if !matches!(c, Command::Ability { .. }) {
                        ep.stances.remove(&t);
                    }
                    out.push(Action::new(t, c));
                }
                Order::Keep(st) => {
                    ep.stances.insert(t, st);
                }
            }
        }
        // Stances act every step, this one included, from the group's observation alone.
        ep.stances.retain(|t, _| alive.contains(t));
        for (&t, st) in &ep.stances {
            if let Some(u) = obs.units.iter().find(|u| u.tag == t && u.own) {
                out.extend(st.act(obs, &ep.scenario.terrain, u));
            }
        }
        out
    }
}
