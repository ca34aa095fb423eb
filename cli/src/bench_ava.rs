//! `bench --ava`: AVA's pipeline time per decision beyond the model's (screenshots, prompts,
//! retrieval, parsing and checking), with a stand-in model that answers at once, against
//! the goals (5 ms on 3m_vlm, 20 ms on pvz_ht) and against an environment step measured in the
//! same run.

use anyhow::Result;
use avacraft_ava::cost::PriceTable;
use avacraft_ava::llm::Synthetic;
use avacraft_ava::{AvaAgent, AvaConfig, AvaRun, AvaSetup, Prompts};
use avacraft_engine::agent::{AgentTeam, Grouping};
use avacraft_engine::{Controllers, Env, EnvConfig, Scenario, Team};
use serde::Serialize;
use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

#[derive(Serialize, Debug, Clone)]
pub struct AvaRow {
    pub scenario: String,
    pub variant: String,
    pub decisions: u64,
    pub calls_per_decision: f64,
    pub overhead_ms_per_decision: f64,
    /// One environment step (the simulation's own work), measured in the same run.
    pub env_step_ms: f64,
    pub ratio_to_env_step: f64,
    pub goal_ms: f64,
    /// goal / measured (above 1 meets the goal).
    pub ratio_to_goal: f64,
}

fn goal(scenario: &str) -> f64 {
    if scenario == "pvz_ht" { 20.0 } else { 5.0 }
}

/// Plays episodes of `scenario` with AVA over the stand-in model until `decisions` decisions;
/// returns (decisions, calls, overhead ms).
fn play(scenario: &Arc<Scenario>, cfg: AvaConfig, decisions: u64) -> Result<(u64, u64, f64)> {
    let retriever = avacraft_ava::kb::retriever(cfg.retriever)?;
    let setup = AvaSetup {
        config: Arc::new(cfg),
        run: AvaRun::new(Box::new(Synthetic), None, PriceTable::builtin()),
        prompts: Arc::new(Prompts::builtin()?),
        retriever,
    };
    let s = setup.clone();
    let team = AgentTeam::new(Team::One, Grouping::Team, move || Box::new(AvaAgent::new(s.clone())));
    let mut controllers = Controllers::new(scenario, vec![team]);
    let mut env = Env::new(Arc::clone(scenario), EnvConfig::default(), 1);
    let mut seed = 1;
    let done = |s: &AvaSetup| s.run.episodes().iter().map(|e| e.decisions).sum::<u64>();
    while done(&setup) < decisions {
        env.reset(seed);
        controllers.reset(&env);
        while !env.done() && done(&setup) < decisions {
            controllers.act(&mut env);
            env.step();
        }
        seed += 1;
    }
    let eps = setup.run.episodes();
    Ok((eps.iter().map(|e| e.decisions).sum(), eps.iter().map(|e| e.total.calls).sum(), eps.iter().map(|e| e.overhead_ms).sum()))
}

/// Milliseconds per step of `scenario` with the scripted focus-fire agent.
fn env_step_ms(scenario: &Arc<Scenario>, steps: u64) -> Result<f64> {
    let mut controllers = Controllers::named(scenario, "focus-fire", None)?;
    let mut env = Env::new(Arc::clone(scenario), EnvConfig::default(), 1);
    let (mut n, mut seed) = (0u64, 1);
    let t0 = Instant::now();
    while n < steps {
        env.reset(seed);
        controllers.reset(&env);
        while !env.done() && n < steps {
            controllers.act(&mut env);
            env.step();
            n += 1;
        }
        seed += 1;
    }
    Ok(t0.elapsed().as_secs_f64() * 1000.0 / n.max(1) as f64)
}

pub fn run(names: &[String], decisions: u64, json: bool, out: &mut dyn Write) -> Result<()> {
    let mut rows = Vec::new();
    for name in names {
        let scenario = Arc::new(Scenario::load(name)?);
        let step_ms = env_step_ms(&scenario, 400)?;
        let variants = [
            ("full pipeline", AvaConfig::default()),
            ("text only", AvaConfig { image: false, ..AvaConfig::default() }),
            ("no planner/roles/priority", AvaConfig { planner: false, roles: false, priority: false, ..AvaConfig::default() }),
        ];
        for (variant, cfg) in variants {
            let (d, calls, ms) = play(&scenario, cfg, decisions)?;
            let per = ms / d.max(1) as f64;
            rows.push(AvaRow {
                scenario: scenario.name.clone(),
                variant: variant.to_owned(),
                decisions: d,
                calls_per_decision: calls as f64 / d.max(1) as f64,
                overhead_ms_per_decision: per,
                env_step_ms: step_ms,
                ratio_to_env_step: per / step_ms,
                goal_ms: goal(&scenario.name),
                ratio_to_goal: goal(&scenario.name) / per,
            });
        }
    }
    if json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
        return Ok(());
    }
    writeln!(out, "AVA pipeline time per decision beyond the model (stand-in model answering at once)")?;
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_FULL_CONDENSED).set_header([
        "scenario",
        "variant",
        "decisions",
        "calls/decision",
        "ms/decision",
        "env step ms",
        "x env step",
        "goal ms",
        "goal / measured",
    ]);
    for r in &rows {
        t.add_row([
            r.scenario.clone(),
            r.variant.clone(),
            r.decisions.to_string(),
            format!("{:.2}", r.calls_per_decision),
            format!("{:.2}", r.overhead_ms_per_decision),
            format!("{:.3}", r.env_step_ms),
            format!("{:.1}", r.ratio_to_env_step),
            format!("{:.0}", r.goal_ms),
            format!("{:.2}", r.ratio_to_goal),
        ]);
    }
    writeln!(out, "{t}")?;
    Ok(())
}
