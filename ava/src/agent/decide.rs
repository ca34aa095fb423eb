//! One decision through the pipeline's stages.

use super::run::CallMeta;
use super::situation::{self, Tally};
use super::stages::{self, Plan, Priority};
use super::state::{AvaSetup, Episode, HistoryItem};
use crate::config::{AvaConfig, Fallback};
use crate::decision::{self, Item, Order, Refused, Situation};
use crate::llm::{ChatReply, ChatRequest, Message, Part, Png, Role, Stage};
use avacraft_engine::UnitId;
use avacraft_engine::agent::{GroupObs, view};
use avacraft_render::{Camera, CpuBackend, FrameBuilder, VlmOptions};
use serde::Serialize;
use serde_json::Value;
use std::time::Instant;

#[derive(Serialize)]
struct SystemCtx<'a> {
    team_name: String,
    scenario: &'a str,
    objective: &'a str,
    image: bool,
    text: bool,
    camera_width: f32,
    /// A grid cell's size in world units (`2.4 x 1.7`).
    cell: String,
}

#[derive(Serialize)]
struct Knowledge {
    title: String,
    text: String,
}

#[derive(Serialize)]
struct DecisionCtx<'a> {
    situation: &'a str,
    plan: Option<String>,
    priorities: &'a [Priority],
    roles: &'a [super::RoleOf],
    knowledge: Vec<Knowledge>,
    history: Vec<&'a HistoryItem>,
    units: String,
    image: bool,
    schema: Option<String>,
    /// The micro action set's verbs are offered.
    micro: bool,
    /// When the next decision comes, in steps and game seconds.
    next_in: String,
}

#[derive(Serialize)]
struct RepairCtx<'a> {
    refused: &'a [Refused],
    accepted: String,
    pending: String,
}

/// The pipeline's state for one decision.
struct Turn<'a> {
    setup: &'a AvaSetup,
    camera: Camera,
    cfg: &'a AvaConfig,
    ep: &'a mut Episode,
    obs: &'a GroupObs,
    /// Model time of this decision as the replies report it, milliseconds.
    model_ms: f64,
    /// Wall time spent inside calls (retry pauses included), milliseconds.
    call_ms: f64,
    /// A grid cell's size in world units, for the system prompt.
    cell: String,
}

impl Turn<'_> {
    fn meta(&self, attempt: u32) -> CallMeta {
        CallMeta {
            episode: self.obs.episode,
            // The episode's seed, so records match `episode --seed` (the agent's own seed is
            // derived from it).
            seed: self.obs.seed,
            team: self.ep.team.player(),
            step: self.obs.step,
            decision: self.ep.decisions,
            attempt,
        }
    }

    /// The camera whose grid cells history names moves by, or none when positions are exact.
    fn grid_words(&self) -> Option<&Camera> {
        (self.cfg.prompt == crate::PromptStyle::Paper).then_some(&self.camera)
    }

    fn ask(&mut self, stage: Stage, messages: Vec<Message>, schema: Value, attempt: u32) -> Option<ChatReply> {
        let req = ChatRequest { stage, messages, schema: Some((format!("ava_{}", stage.name()), schema)), sampling: self.cfg.sampling };
        let meta = self.meta(attempt);
        let t0 = Instant::now();
        let r = self.setup.run.call(meta, self.setup.prompts.version(), &req, self.cfg.max_retries, self.cfg.backoff_ms, &mut self.ep.cost);
        self.call_ms += t0.elapsed().as_secs_f64() * 1000.0;
        match r {
            Ok(reply) => {
                self.model_ms += reply.latency_ms;
                Some(reply)
            }
            Err(e) => {
                tracing::warn!(stage = stage.name(), step = self.obs.step, "model call failed: {e}");
                None
            }
        }
    }

    fn render(&self, key: &str, ctx: &impl Serialize) -> String {
        match self.setup.prompts.render(key, ctx) {
            Ok(s) => s,
            Err(e) => {
                // Templates are checked when loaded; a failure here is a template that uses a
                // variable this code does not give, which must stop the run.
                self.setup.run.set_fatal(format!("prompt: {e}"));
                String::new()
            }
        }
    }

    fn user(&self, text: String, image: Option<&Png>) -> Vec<Message> {
        let system = self.render(
            "system",
            &SystemCtx {
                team_name: format!("team {}", self.ep.team.player()),
                scenario: &self.ep.scenario.name,
                objective: &self.ep.scenario.objective,
                image: self.cfg.image,
                text: self.cfg.text,
                camera_width: self.cfg.camera_width,
                cell: self.cell.clone(),
            },
        );
        let mut parts = vec![Part::Text(text)];
        if let Some(png) = image {
            parts.push(Part::Image(png.clone()));
        }
        vec![Message::text(Role::System, system), Message { role: Role::User, parts }]
    }

    /// The planner stage: a new plan when the model gives one. Returns whether it did.
    fn planner(&mut self, situation: &str, image: Option<&Png>) -> bool {
        let text = self.render("planner", &serde_json::json!({"situation": situation}));
        let msgs = self.user(text, image);
        let mut replanned = false;
        if let Some(r) = self.ask(Stage::Planner, msgs, Plan::schema(), 0) {
            match decision::extract_json(&r.text).ok().and_then(|v| serde_json::from_value::<Plan>(v).ok()) {
                Some(p) => {
                    self.ep.plan = Some(p);
                    replanned = true;
                }
                None => self.ep.cost.refused_items += 1,
            }
        }
        self.ep.plan_at = self.ep.decisions;
        replanned
    }

    /// The roles stage: the living units' roles, kept when the model names none.
    fn roles(&mut self, situation: &str, plan: Option<&str>, image: Option<&Png>, alive: &[UnitId]) {
        let text = self.render("roles", &serde_json::json!({"situation": situation, "plan": plan}));
        let msgs = self.user(text, image);
        if let Some(r) = self.ask(Stage::Roles, msgs, stages::roles_schema(), 0) {
            let v = decision::extract_json(&r.text).unwrap_or(Value::Null);
            let (roles, dropped) = stages::read_roles(&v, alive);
            self.ep.cost.refused_items += dropped as u64;
            if !roles.is_empty() {
                self.ep.roles = roles;
            }
        }
    }

    /// The priority stage: the enemies to kill first, as the model names them.
    fn priorities(&mut self, situation: &str, image: Option<&Png>) -> Vec<Priority> {
        let text = self.render("priority", &serde_json::json!({"situation": situation}));
        let msgs = self.user(text, image);
        let Some(r) = self.ask(Stage::Priority, msgs, stages::priority_schema(), 0) else { return Vec::new() };
        let v = decision::extract_json(&r.text).unwrap_or(Value::Null);
        let (p, dropped) = stages::read_priorities(&v, self.obs);
        self.ep.cost.refused_items += dropped as u64;
        p
    }

    /// Retrieval: passages on the unit types on the field and the plan's skill. The rich
    /// prompt keeps only passages about the types on the field, and no profiles (its unit
    /// block gives each type's data already): keyword ranking alone put Marine and Spine
    /// Crawler passages into a Stalker-and-Zealot fight.
    fn knowledge(&self, skill: Option<&str>) -> Vec<Knowledge> {
        let mut kinds: Vec<avacraft_engine::UnitKind> = self.obs.units.iter().map(|u| u.kind.base()).collect();
        kinds.sort_unstable_by_key(|k| k.name());
        kinds.dedup();
        let mut query = kinds.iter().map(|k| k.name()).collect::<Vec<_>>().join(" ");
        if let Some(skill) = skill {
            query.push(' ');
            query.push_str(skill);
        }
        let rich = self.cfg.prompt == crate::PromptStyle::Rich;
        let wide = if rich { self.cfg.top_k * 8 } else { self.cfg.top_k };
        self.setup
            .retriever
            .search(&query, wide)
            .into_iter()
            .filter(|h| {
                !rich
                    || (kinds.contains(&h.passage.kind.base())
                        && match h.passage.topic {
                            crate::Topic::Profile => false,
                            // An own unit's ability only when one lists it (Blink needs an
                            // upgrade); an enemy type's, whatever it has researched.
                            crate::Topic::Ability(a) => {
                                let kind = h.passage.kind.base();
                                let own_kind = self.obs.own().any(|u| u.kind.base() == kind);
                                !own_kind || self.obs.own().any(|u| u.abilities.iter().any(|i| i.ability == a))
                            }
                            _ => true,
                        })
            })
            .take(self.cfg.top_k)
            .map(|h| Knowledge { title: h.passage.title.clone(), text: h.passage.text.clone() })
            .collect()
    }

    /// The decision stage with its repair rounds: each round's checked commands are kept,
    /// and a repair asks only for the units still without one.
    fn decision(&mut self, mut msgs: Vec<Message>, schema: &Value, sit: &Situation<'_>, alive: &[UnitId]) -> Vec<(UnitId, Order)> {
        let mut commands: Vec<(UnitId, Order)> = Vec::new();
        for attempt in 0..=self.cfg.max_repairs {
            let Some(reply) = self.ask(Stage::Decision, msgs.clone(), schema.clone(), attempt) else {
                self.ep.cost.transport_failures += 1;
                break;
            };
            let pending: Vec<UnitId> = alive.iter().copied().filter(|t| !commands.iter().any(|(c, _)| c == t)).collect();
            let refused = match decision::extract_json(&reply.text).and_then(|v| decision::parse_items(&v, "actions")) {
                Ok((items, refused)) => {
                    // A repair may only give actions to the units still waiting.
                    let mut refused = refused;
                    let items: Vec<(usize, Item)> = items
                        .into_iter()
                        .filter(|(i, it)| {
                            // `it.unit` is the number the model wrote.
                            let id = UnitId::try_from(it.unit).ok();
                            let done = attempt > 0 && id.is_some_and(|id| !pending.contains(&id) && alive.contains(&id));
                            if done {
                                refused.push(Refused {
                                    item: *i,
                                    unit: Some(it.unit),
                                    reason: format!("unit {} already has an accepted action", it.unit),
                                });
                            }
                            !done
                        })
                        .collect();
                    let checked = decision::check(sit, &items, refused);
                    for (t, c) in checked.commands {
                        if !commands.iter().any(|(u, _)| *u == t) {
                            commands.push((t, c));
                        }
                    }
                    checked.refused
                }
                Err(e) => vec![Refused { item: 0, unit: None, reason: e.to_string() }],
            };
            self.ep.cost.refused_items += refused.len() as u64;
            let pending: Vec<UnitId> = alive.iter().copied().filter(|t| !commands.iter().any(|(c, _)| c == t)).collect();
            if refused.is_empty() || pending.is_empty() || attempt == self.cfg.max_repairs {
                break;
            }
            self.ep.cost.repairs += 1;
            let accepted: Vec<String> = commands.iter().map(|(t, c)| situation::order_text(*t, c, self.grid_words())).collect();
            let repair = self.render("repair", &RepairCtx { refused: &refused, accepted: accepted.join(", "), pending: list(&pending) });
            msgs.push(Message::text(Role::Assistant, reply.text));
            msgs.push(Message::text(Role::User, repair));
        }
        commands
    }
}

/// What happened since the last decision (written into the last history item), the
/// enemies in sight, and whether the plan is stale: a unit lost, or an enemy never seen.
fn since_last(ep: &mut Episode, obs: &GroupObs) -> (Vec<UnitId>, bool, bool) {
    let tally = Tally::of(obs);
    if let (Some(prev), Some(last)) = (ep.tally, ep.history.back_mut())
        && last.outcome.is_empty()
    {
        last.outcome = prev.outcome(&tally);
    }
    let lost = ep.tally.is_some_and(|p| tally.own_units < p.own_units);
    let enemies: Vec<UnitId> = obs.units.iter().filter(|u| !u.own).map(|u| u.tag).collect();
    let new_enemies = enemies.iter().any(|t| !ep.seen_enemies.contains(t));
    ep.seen_enemies.extend(enemies.iter().copied());
    ep.tally = Some(tally);
    (enemies, lost, new_enemies)
}

fn screenshot(
    setup: &AvaSetup,
    frames: &mut FrameBuilder,
    cpu: &mut CpuBackend,
    ep: &Episode,
    obs: &GroupObs,
    camera: &Camera,
    hl: &[UnitId],
) -> Option<Png> {
    let (w, h) = setup.config.draw_size();
    let opts = VlmOptions { highlights: hl.to_vec() };
    let scene = frames.vlm_obs(&ep.scenario.terrain, obs, camera, w, h, &opts);
    match Png::encode(&cpu.render(&scene)) {
        Ok(p) => Some(p),
        Err(e) => {
            setup.run.set_fatal(format!("screenshot: {e}"));
            None
        }
    }
}

/// What a call of [`decide`] does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Mode {
    /// The whole pipeline (an AVA agent on its own).
    Full,
    /// Planner, roles and priorities for the whole team, no decision (a commander); the
    /// results stay in the episode's `plan`, `roles` and `priorities`.
    Command,
}

/// Takes one decision; returns the commands and the model time it took (milliseconds). A role
/// group with a commander's briefing (`ep.briefing`) skips the planner, roles and priority
/// stages and uses the briefing's plan and priorities instead.
pub(super) fn decide(
    setup: &AvaSetup,
    frames: &mut FrameBuilder,
    cpu: &mut CpuBackend,
    ep: &mut Episode,
    obs: &GroupObs,
    alive: &[UnitId],
    mode: Mode,
) -> (Vec<(UnitId, Order)>, f64) {
    let t0 = Instant::now();
    let cfg = Arc::clone(&setup.config);
    let (w, h) = cfg.draw_size();
    let scenario = Arc::clone(&ep.scenario);
    let playable = scenario.terrain.playable();
    let own = obs.units.iter().filter(|u| u.own && alive.contains(&u.tag)).map(view::pos);
    // The camera fills the screenshot's map area, so its grid is the one drawn.
    let camera = avacraft_render::vlm_obs_layout(w, h).camera(own, cfg.camera_width, playable);

    let (enemies, lost, new_enemies) = since_last(ep, obs);

    let rich = cfg.prompt == crate::PromptStyle::Rich;
    let situation = if cfg.text && rich {
        super::rich::describe_rich(obs, &scenario.terrain, alive, Some(scenario.spawn(ep.team.other())))
    } else if cfg.text {
        situation::describe(obs, &camera, alive)
    } else {
        format!("Step {}. Your units have tags {}.", obs.step, list(alive))
    };
    let image = if cfg.image { screenshot(setup, frames, cpu, ep, obs, &camera, &[]) } else { None };
    let briefing = ep.briefing.clone();
    let staged = briefing.is_none();
    let view = camera.rect();
    let cell = format!("{:.1} x {:.1}", (view.right - view.left) / 10.0, (view.top - view.bottom) / 10.0);
    let mut turn = Turn { setup, camera, cfg: &cfg, ep, obs, model_ms: 0.0, call_ms: 0.0, cell };

    let replanned = staged
        && cfg.planner
        && (turn.ep.plan.is_none() || turn.ep.decisions - turn.ep.plan_at >= cfg.plan_every || lost || new_enemies)
        && turn.planner(&situation, image.as_ref());
    let plan = match &briefing {
        Some(b) => Some(b.plan.clone()).filter(|p| !p.is_empty()),
        None => turn.ep.plan.as_ref().filter(|_| cfg.planner).map(Plan::summary),
    };

    if staged && (cfg.roles || mode == Mode::Command) && (turn.ep.roles.is_empty() || replanned || lost) {
        turn.roles(&situation, plan.as_deref(), image.as_ref(), alive);
    }
    turn.ep.roles.retain(|r| alive.contains(&r.unit));
    if let Some(b) = &briefing {
        // The commander gave the group its role.
        turn.ep.roles = alive.iter().map(|&unit| super::RoleOf { unit, role: b.role.name().to_owned(), task: String::new() }).collect();
    }

    // Priority inference, and the second screenshot ringing the named enemies.
    let mut priorities = Vec::new();
    let mut image2 = None;
    if let Some(b) = &briefing {
        priorities = b
            .priorities
            .iter()
            .filter(|t| enemies.contains(t))
            .map(|&unit| Priority { unit, reason: "named by the commander".into() })
            .collect();
    } else if cfg.priority && !enemies.is_empty() {
        priorities = turn.priorities(&situation, image.as_ref());
        if cfg.image && !priorities.is_empty() {
            let hl: Vec<UnitId> = priorities.iter().map(|p| p.unit).collect();
            image2 = screenshot(setup, frames, cpu, turn.ep, obs, &camera, &hl);
        }
    }
    if cfg.image && briefing.is_some() && !priorities.is_empty() {
        let hl: Vec<UnitId> = priorities.iter().map(|p| p.unit).collect();
        image2 = screenshot(setup, frames, cpu, turn.ep, obs, &camera, &hl);
    }
    if mode == Mode::Command {
        turn.ep.priorities = priorities;
        return (Vec::new(), close(turn, t0));
    }

    let skill = turn.ep.plan.as_ref().filter(|_| cfg.planner && staged).map(|p| p.primary_skill.name.clone());
    let knowledge = if cfg.retrieval { turn.knowledge(skill.as_deref()) } else { Vec::new() };

    // The decision, with repair rounds.
    let micro = cfg.actions == crate::ActionSet::Micro;
    let schema = decision::schema_for(alive, &decision::targets(obs), &castable(obs), micro);
    let next_in = next_decision(cfg.decide_every, turn.ep.loops_per_step);
    let ctx = DecisionCtx {
        situation: &situation,
        plan,
        priorities: &priorities,
        roles: &turn.ep.roles.clone(),
        knowledge,
        history: turn.ep.history.iter().collect(),
        units: list(alive),
        image: cfg.image,
        schema: cfg.schema_in_prompt.then(|| schema.to_string()),
        micro,
        next_in,
    };
    let text = turn.render("decision", &ctx);
    let msgs = turn.user(text, image2.as_ref().or(image.as_ref()));
    let sit = Situation { obs, camera: &camera, terrain: &scenario.terrain, micro };
    let mut commands = turn.decision(msgs, &schema, &sit, alive);
    if commands.is_empty() {
        turn.ep.cost.fallbacks += 1;
        if cfg.fallback == Fallback::AttackNearest {
            commands = situation::attack_nearest(obs, alive).into_iter().map(|(t, c)| (t, Order::Do(c))).collect();
        }
    }

    let actions: Vec<String> = commands.iter().map(|(t, c)| situation::order_text(*t, c, turn.grid_words())).collect();
    turn.ep.history.push_back(HistoryItem { step: obs.step, actions: actions.join(", "), outcome: String::new() });
    while turn.ep.history.len() > cfg.history {
        turn.ep.history.pop_front();
    }
    (commands, close(turn, t0))
}

/// The abilities some own unit can cast now: the schema offers only these, since a small model
/// held to the schema otherwise fills in one it cannot use.
fn castable(obs: &GroupObs) -> Vec<&'static str> {
    let mut a: Vec<&str> =
        obs.units.iter().filter(|u| u.own).flat_map(|u| u.abilities.iter().filter(|a| a.available).map(|a| a.ability.name())).collect();
    a.sort_unstable();
    a.dedup();
    a
}

/// When the next decision comes, in steps and game seconds (the rich prompt says it).
fn next_decision(steps: u32, loops_per_step: u32) -> String {
    let s = if steps == 1 { "" } else { "s" };
    format!("{steps} step{s} ({:.2} s of game time)", avacraft_engine::loops_to_seconds(steps * loops_per_step))
}

/// Counts the decision, adds the pipeline time besides the calls' to the episode's overhead
/// and publishes its accounting; returns the decision's model time (milliseconds).
fn close(turn: Turn<'_>, t0: Instant) -> f64 {
    let Turn { setup, ep, obs, model_ms, call_ms, .. } = turn;
    ep.decisions += 1;
    ep.cost.decisions += 1;
    ep.cost.episode = obs.episode;
    ep.cost.seed = obs.seed;
    ep.cost.overhead_ms += (t0.elapsed().as_secs_f64() * 1000.0 - call_ms).max(0.0);
    setup.run.update_episode(ep.cost_idx, &ep.cost);
    model_ms
}

use std::sync::Arc;

fn list(units: &[UnitId]) -> String {
    units.iter().map(|id| id.tag().to_string()).collect::<Vec<_>>().join(", ")
}
