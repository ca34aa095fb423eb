//! What the pipeline's parts share: what an agent is made from, and what it keeps within an
//! episode. A leaf, so the agent, the commander and the decision all read it without
//! depending on one another.

use super::run::AvaRun;
use super::situation::Tally;
use super::stages::{Plan, Priority, RoleOf};
use crate::config::AvaConfig;
use crate::cost::EpisodeCost;
use crate::decision::Order;
use crate::kb::SharedRetriever;
use crate::prompt::Prompts;
use avacraft_engine::agent::Stance;
use avacraft_engine::agent::{AgentCtx, Briefing};
use avacraft_engine::{DEFAULT_STEP_MUL, Scenario, Team, UnitId};
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

/// A past decision, for the prompt.
#[derive(Clone, Debug, serde::Serialize)]
pub(super) struct HistoryItem {
    pub(super) step: u32,
    pub(super) actions: String,
    pub(super) outcome: String,
}

/// What an agent keeps within an episode.
#[derive(Debug)]
pub(super) struct Episode {
    pub(super) scenario: Arc<Scenario>,
    pub(super) team: Team,
    pub(super) first_step: Option<u32>,
    pub(super) decisions: u32,
    pub(super) plan: Option<Plan>,
    pub(super) plan_at: u32,
    pub(super) roles: Vec<RoleOf>,
    /// The last priority stage's answer (a commander passes it on).
    pub(super) priorities: Vec<Priority>,
    /// A commander's briefing for this step (role groups under dynamic roles).
    pub(super) briefing: Option<Briefing>,
    pub(super) history: VecDeque<HistoryItem>,
    pub(super) tally: Option<Tally>,
    pub(super) seen_enemies: BTreeSet<UnitId>,
    /// Realtime: orders waiting for their step.
    pub(super) pending: Option<(u32, Vec<(UnitId, Order)>)>,
    /// Units' standing orders (the micro action set) until their next order.
    pub(super) stances: BTreeMap<UnitId, Stance>,
    /// Game loops per environment step, as observed (for realtime delays).
    pub(super) loops_per_step: u32,
    pub(super) last_seen: Option<(u32, u32)>,
    pub(super) cost_idx: usize,
    pub(super) cost: EpisodeCost,
}

impl Episode {
    pub(super) fn new(ctx: &AgentCtx, cost_idx: usize, cost: EpisodeCost) -> Episode {
        Episode {
            scenario: Arc::clone(&ctx.scenario),
            team: ctx.team,
            first_step: None,
            decisions: 0,
            plan: None,
            plan_at: 0,
            roles: Vec::new(),
            priorities: Vec::new(),
            briefing: None,
            history: VecDeque::new(),
            tally: None,
            seen_enemies: BTreeSet::new(),
            pending: None,
            stances: BTreeMap::new(),
            loops_per_step: DEFAULT_STEP_MUL.get(),
            last_seen: None,
            cost_idx,
            cost,
        }
    }
}

/// Everything an AVA agent is made from; cheap to clone (one per group).
#[derive(Clone, Debug)]
pub struct AvaSetup {
    pub config: Arc<AvaConfig>,
    pub run: Arc<AvaRun>,
    pub prompts: Arc<Prompts>,
    pub retriever: SharedRetriever,
}
