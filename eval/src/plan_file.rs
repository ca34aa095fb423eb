//! Reading a plan file: the TOML checked section by section into a [`Plan`], every refusal
//! naming the file, the field and the value. Relative paths (`marl:DIR`, scenario files,
//! curve folders, the document) are resolved against the plan's folder.

use crate::plan::{
    AgentDef, AgentKind, Cell, CellKey, CurveDef, Plan, PlanError, RawAgent, RawCurve, RawHeadToHead, RawPlan, eval_env, unshipped,
};
use avacraft_engine::{DataSet, EnvOptions, Mode, OpponentKind, Scenario, Team, builtin_names, smac_names};
use avacraft_policy::{PolicyError, PolicySpec, Resolve};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Reads and validates a plan.
pub fn load(path: &Path) -> Result<Plan, PlanError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| PlanError::Io { file: file.clone(), source })?;
    parse(&file, &text, path.parent())
}

/// Parses plan text (`file` names it in errors).
pub fn parse(file: &str, text: &str, base: Option<&Path>) -> Result<Plan, PlanError> {
    let raw: RawPlan = toml::from_str(text).map_err(|source| PlanError::Syntax { file: file.to_owned(), source: Box::new(source) })?;
    let data = match &raw.data {
        None => None,
        Some(d) => Some(d.parse::<DataSet>().map_err(|e| PlanError::Invalid {
            file: file.to_owned(),
            field: "data".into(),
            value: format!("{d:?}"),
            reason: e.to_string(),
        })?),
    };
    let cx = Cx { file, base, data };
    let env = match &raw.env {
        None => eval_env(),
        Some(over) => eval_env().overlay(over, &["opponent", "data"]).map_err(|why| cx.err("env", over.to_string(), why))?,
    };
    env.config().map_err(|b| cx.err(format!("env.{}", b.option), b.value, b.supported))?;
    let seeds = cx.seeds(&raw.seeds)?;
    let scenarios = cx.scenarios(&raw.scenarios)?;
    let opponents = cx.opponents(&raw.opponents)?;
    let mut agents = Vec::new();
    for (i, a) in raw.agents.iter().enumerate() {
        let def = cx.agent(i, a, &agents, &scenarios, seeds.len())?;
        agents.push(def);
    }
    let mut cells = Vec::new();
    let mut skipped: Vec<(String, String)> = Vec::new();
    cx.pve_cells(&scenarios, &agents, &opponents, &mut cells, &mut skipped)?;
    for (h, t) in raw.headtohead.iter().enumerate() {
        cx.headtohead_cells(h, t, &agents, &mut cells, &mut skipped)?;
    }
    if cells.is_empty() {
        return Err(cx.err(
            "agents",
            format!("{} agents", agents.len()),
            "the plan has nothing to play (agents and scenarios, or [[headtohead]])",
        ));
    }
    let off_rules = cx.off_rules(&cells, &agents, &env)?;
    let curves = raw.curves.iter().enumerate().map(|(i, c)| cx.curve(i, c)).collect::<Result<Vec<_>, _>>()?;
    let name =
        raw.name.unwrap_or_else(|| Path::new(file).file_stem().map_or_else(|| "plan".to_owned(), |s| s.to_string_lossy().into_owned()));
    let document = match raw.document {
        Some(d) if d.trim().is_empty() || !d.ends_with(".md") => {
            return Err(cx.err("document", format!("{d:?}"), "a Markdown file (`.md`), e.g. \"../../docs/results.md\""));
        }
        Some(d) => Some(base.map_or_else(|| PathBuf::from(&d), |b| b.join(&d))),
        None => None,
    };
    Ok(Plan {
        file: file.to_owned(),
        name,
        agents,
        cells,
        seeds,
        curves,
        unshipped: skipped,
        off_rules,
        document,
        protocol: raw.protocol.unwrap_or_default(),
        env,
    })
}

/// The plan file being read.
struct Cx<'a> {
    file: &'a str,
    base: Option<&'a Path>,
    /// The plan's data set for every scenario, if it names one.
    data: Option<DataSet>,
}

impl Cx<'_> {
    fn err(&self, field: impl Into<String>, value: impl Into<String>, reason: impl Into<String>) -> PlanError {
        PlanError::Invalid { file: self.file.to_owned(), field: field.into(), value: value.into(), reason: reason.into() }
    }

    fn policy_err(&self, field: String, value: String, source: PolicyError) -> PlanError {
        PlanError::Policy { file: self.file.to_owned(), field, value, source: Box::new(source) }
    }

    fn seeds(&self, seeds: &[u64]) -> Result<Vec<u64>, PlanError> {
        if seeds.is_empty() {
            return Err(self.err("seeds", "[]", "at least one seed is needed"));
        }
        for (i, s) in seeds.iter().enumerate() {
            if seeds[..i].contains(s) {
                return Err(self.err(format!("seeds[{i}]"), s.to_string(), "named twice"));
            }
        }
        Ok(seeds.to_vec())
    }

    /// The game a cell of `policy` on `sc` plays: the plan's data set where it names one;
    /// otherwise a trained network's own (the one it learned on), else the scenario's.
    fn played_on(&self, field: String, sc: &Arc<Scenario>, policy: &PolicySpec) -> Result<Arc<Scenario>, PlanError> {
        if self.data.is_some() {
            return Ok(Arc::clone(sc));
        }
        let trained = policy.trained_data(sc).map_err(|e| self.policy_err(field.clone(), format!("{policy} on {}", sc.name), e))?;
        match trained {
            Some(d) if d != sc.data => {
                sc.with_data(d).map(Arc::new).map_err(|e| self.err(field, format!("{policy} on {}", sc.name), e.to_string()))
            }
            _ => Ok(Arc::clone(sc)),
        }
    }

    /// The networks that play under other rules than they learned (the plan's `env` sets the
    /// weapon periods and the surround experiment for every cell): `(agent, scenario, what
    /// differs)`, each once. They play, and the report says so.
    fn off_rules(&self, cells: &[Cell], agents: &[AgentDef], env: &EnvOptions) -> Result<Vec<(String, String, String)>, PlanError> {
        let mut off = Vec::new();
        for c in cells {
            for k in std::iter::once(c.agent).chain(c.agent2) {
                let (a, sc) = (&agents[k], &c.scenario);
                let field = || format!("agents: {} on {}", a.name, sc.name);
                let mut what = Vec::new();
                if let Some(p) = a.policy.trained_weapon_period(sc).map_err(|e| self.policy_err(field(), a.policy.to_string(), e))?
                    && p != env.weapon_period
                {
                    what.push(format!("weapon periods from the {p}, played from the {}", env.weapon_period));
                }
                if let Some(m) = a.policy.trained_melee_surround(sc).map_err(|e| self.policy_err(field(), a.policy.to_string(), e))?
                    && m != env.melee_surround
                    && sc.has_melee()
                {
                    let (was, is) = if m { ("under", "without") } else { ("without", "under") };
                    what.push(format!("learned {was} the surround experiment, played {is} it"));
                }
                let entry = (a.name.clone(), sc.name.clone(), what.join("; "));
                if !what.is_empty() && !off.contains(&entry) {
                    off.push(entry);
                }
            }
        }
        Ok(off)
    }

    /// Whether a cell of `policies` on `sc` needs the ability slots: one of its networks
    /// reads them.
    fn ability_actions(&self, field: String, sc: &Scenario, policies: &[&PolicySpec]) -> Result<bool, PlanError> {
        for p in policies {
            if p.ability_actions(sc).map_err(|e| self.policy_err(field.clone(), format!("{p} on {}", sc.name), e))? {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// A built-in scenario by name, or a scenario file relative to the plan.
    fn scenario(&self, field: String, name: &str) -> Result<Arc<Scenario>, PlanError> {
        let arg = match self.base.map(|b| b.join(name)) {
            Some(p) if p.is_file() => p.display().to_string(),
            _ => name.to_owned(),
        };
        let s = Scenario::load(&arg).map_err(|e| self.err(field.clone(), format!("{name:?}"), e.to_string()))?;
        match self.data {
            None => Ok(Arc::new(s)),
            Some(d) => s.with_data(d).map(Arc::new).map_err(|e| self.err(field, format!("{name:?}"), e.to_string())),
        }
    }

    /// The PvE scenarios (`all`: every built-in one).
    fn scenarios(&self, names: &[String]) -> Result<Vec<Arc<Scenario>>, PlanError> {
        let mut scenarios: Vec<Arc<Scenario>> = Vec::new();
        for (i, s) in names.iter().enumerate() {
            if s == "all" || s == "smac" {
                let names: Vec<&str> = if s == "all" { builtin_names().collect() } else { smac_names().collect() };
                for n in names {
                    let sc = self.scenario(format!("scenarios[{i}]"), n)?;
                    if sc.mode == Mode::Pve && !scenarios.iter().any(|x| x.name == sc.name) {
                        scenarios.push(sc);
                    }
                }
                continue;
            }
            let sc = self.scenario(format!("scenarios[{i}]"), s)?;
            if sc.mode == Mode::Pvp {
                return Err(self.err(format!("scenarios[{i}]"), format!("{s:?}"), "a PvP scenario goes in a [[headtohead]] table"));
            }
            if scenarios.iter().any(|x| x.name == sc.name) {
                return Err(self.err(format!("scenarios[{i}]"), format!("{s:?}"), "named twice"));
            }
            scenarios.push(sc);
        }
        Ok(scenarios)
    }

    /// The PvE opponents (`default`: each scenario's own); none named is the default.
    fn opponents(&self, names: &[String]) -> Result<Vec<Option<OpponentKind>>, PlanError> {
        let mut opponents: Vec<Option<OpponentKind>> = Vec::new();
        for (i, o) in names.iter().enumerate() {
            let k = if o == "default" {
                None
            } else {
                Some(o.parse::<OpponentKind>().map_err(|e| self.err(format!("opponents[{i}]"), format!("{o:?}"), e))?)
            };
            if opponents.contains(&k) {
                return Err(self.err(format!("opponents[{i}]"), format!("{o:?}"), "named twice"));
            }
            opponents.push(k);
        }
        if opponents.is_empty() {
            opponents.push(None);
        }
        Ok(opponents)
    }

    /// Agent `i`, its policy resolved by the registry.
    fn agent(
        &self,
        i: usize,
        a: &RawAgent,
        before: &[AgentDef],
        scenarios: &[Arc<Scenario>],
        n_seeds: usize,
    ) -> Result<AgentDef, PlanError> {
        let f = |name: &str| format!("agents[{i}].{name}");
        if a.name.is_empty() || a.name.len() > 64 || !a.name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.:+".contains(c)) {
            return Err(self.err(f("name"), format!("{:?}", a.name), "1 to 64 letters, digits or -_.:+"));
        }
        if before.iter().any(|x| x.name == a.name) {
            return Err(self.err(f("name"), format!("{:?}", a.name), "two agents share this name"));
        }
        let policy = PolicySpec::resolve(&a.policy, a.ava.clone(), Resolve::against(self.base)).map_err(|e| {
            let field = if matches!(e, PolicyError::Ava(_) | PolicyError::SpecWithoutAva { .. }) { f("ava") } else { f("policy") };
            self.policy_err(field, format!("{:?}", a.policy), e)
        })?;
        if policy.is_dds() {
            return Err(self.err(f("policy"), format!("{:?}", a.policy), "an evaluation plays in-process; DDS agents cannot"));
        }
        let kind = a.kind.unwrap_or(match &policy {
            PolicySpec::Marl(_) | PolicySpec::Baseline(_) => AgentKind::Marl,
            PolicySpec::Ava(_) => AgentKind::Vlm,
            _ => AgentKind::Scripted,
        });
        if let Some(only) = &a.scenarios {
            for (j, s) in only.iter().enumerate() {
                if !scenarios.iter().any(|x| &x.name == s) {
                    return Err(self.err(format!("agents[{i}].scenarios[{j}]"), format!("{s:?}"), "not one of the plan's scenarios"));
                }
            }
        }
        if let Some(n) = a.seeds
            && (n == 0 || n > n_seeds)
        {
            return Err(self.err(f("seeds"), n.to_string(), format!("the number of the plan's seeds it plays: 1 to {n_seeds}")));
        }
        if let Some(of) = &a.seed_of {
            let Some(base) = before.iter().find(|x| &x.name == of) else {
                return Err(self.err(f("seed_of"), format!("{of:?}"), "not an agent named before this one"));
            };
            if base.seed_of.is_some() {
                return Err(self.err(f("seed_of"), format!("{of:?}"), "itself another agent's training seed: name that agent"));
            }
            if base.kind != AgentKind::Marl || kind != AgentKind::Marl {
                return Err(self.err(
                    f("seed_of"),
                    format!("{of:?}"),
                    "training seeds are of trained (marl) agents, both this one and that",
                ));
            }
        }
        Ok(AgentDef { name: a.name.clone(), policy, kind, scenarios: a.scenarios.clone(), seeds: a.seeds, seed_of: a.seed_of.clone() })
    }

    /// Every agent on every PvE scenario it plays, against every opponent. A shipped
    /// baseline missing for a scenario leaves its cells out, listed in `skipped`.
    fn pve_cells(
        &self,
        scenarios: &[Arc<Scenario>],
        agents: &[AgentDef],
        opponents: &[Option<OpponentKind>],
        cells: &mut Vec<Cell>,
        skipped: &mut Vec<(String, String)>,
    ) -> Result<(), PlanError> {
        for sc in scenarios {
            for (ai, a) in agents.iter().enumerate() {
                if a.scenarios.as_ref().is_some_and(|only| !only.contains(&sc.name)) {
                    continue;
                }
                // An image-mode checkpoint plays PvE cells from rendered frames (see `run`).
                let fits = a.policy.frames_policy(sc).and_then(|f| if f.is_some() { Ok(()) } else { a.policy.check(sc, Team::One) });
                match fits {
                    Ok(()) => {}
                    Err(e) if unshipped(&e) => {
                        skipped.push((a.name.clone(), sc.name.clone()));
                        continue;
                    }
                    Err(source) => {
                        return Err(self.policy_err(format!("agents[{ai}].policy"), format!("{} on {}", a.policy, sc.name), source));
                    }
                }
                let played = self.played_on(format!("agents[{ai}].policy"), sc, &a.policy)?;
                let ability_actions = self.ability_actions(format!("agents[{ai}].policy"), sc, &[&a.policy])?;
                for o in opponents {
                    let against = format!("opponent:{}", o.map_or("default", |k| k.name()));
                    cells.push(Cell {
                        key: CellKey { scenario: sc.name.clone(), agent: a.name.clone(), against },
                        scenario: Arc::clone(&played),
                        agent: ai,
                        opponent: *o,
                        agent2: None,
                        ability_actions,
                    });
                }
            }
        }
        Ok(())
    }

    /// The agents of `[[headtohead]]` table `h` by name, each once.
    fn indices(&self, h: usize, field: &str, names: &[String], agents: &[AgentDef]) -> Result<Vec<usize>, PlanError> {
        let mut idx = Vec::new();
        for (j, n) in names.iter().enumerate() {
            let Some(k) = agents.iter().position(|a| &a.name == n) else {
                return Err(self.err(format!("headtohead[{h}].{field}[{j}]"), format!("{n:?}"), "not one of the plan's agents"));
            };
            if idx.contains(&k) {
                return Err(self.err(format!("headtohead[{h}].{field}[{j}]"), format!("{n:?}"), "named twice"));
            }
            idx.push(k);
        }
        if idx.is_empty() {
            return Err(self.err(format!("headtohead[{h}].{field}"), "[]", "at least one agent is needed"));
        }
        Ok(idx)
    }

    /// The pairings of `[[headtohead]]` table `h` on its PvP scenarios.
    fn headtohead_cells(
        &self,
        h: usize,
        t: &RawHeadToHead,
        agents: &[AgentDef],
        cells: &mut Vec<Cell>,
        skipped: &mut Vec<(String, String)>,
    ) -> Result<(), PlanError> {
        let idx = self.indices(h, "agents", &t.agents, agents)?;
        let idx2 = match &t.against {
            Some(names) => self.indices(h, "against", names, agents)?,
            None => idx.clone(),
        };
        for (j, s) in t.scenarios.iter().enumerate() {
            let sc = self.scenario(format!("headtohead[{h}].scenarios[{j}]"), s)?;
            if sc.mode != Mode::Pvp {
                return Err(self.err(format!("headtohead[{h}].scenarios[{j}]"), format!("{s:?}"), "a PvE scenario goes in `scenarios`"));
            }
            for &a in &idx {
                for &b in &idx2 {
                    let missing = [a, b].into_iter().find(|&k| agents[k].policy.check(&sc, Team::One).is_err_and(|e| unshipped(&e)));
                    if let Some(k) = missing {
                        let pair = (agents[k].name.clone(), sc.name.clone());
                        if !skipped.contains(&pair) {
                            skipped.push(pair);
                        }
                        continue;
                    }
                    for (k, team) in [(a, Team::One), (b, Team::Two)] {
                        agents[k].policy.check(&sc, team).map_err(|source| {
                            self.policy_err(
                                format!("headtohead[{h}].agents"),
                                format!("{} as {team} on {}", agents[k].name, sc.name),
                                source,
                            )
                        })?;
                    }
                    let key = CellKey { scenario: sc.name.clone(), agent: agents[a].name.clone(), against: agents[b].name.clone() };
                    if cells.iter().any(|c| c.key == key) {
                        return Err(self.err(format!("headtohead[{h}]"), key.to_string(), "this pairing is planned twice"));
                    }
                    // Team 1's agent decides the game (a network plays the one it learned).
                    let played = self.played_on(format!("headtohead[{h}].agents"), &sc, &agents[a].policy)?;
                    let policies = [&agents[a].policy, &agents[b].policy];
                    let ability_actions = self.ability_actions(format!("headtohead[{h}].agents"), &sc, &policies)?;
                    cells.push(Cell { key, scenario: played, agent: a, opponent: None, agent2: Some(b), ability_actions });
                }
            }
        }
        Ok(())
    }

    /// A training run whose curves the report plots.
    fn curve(&self, i: usize, c: &RawCurve) -> Result<CurveDef, PlanError> {
        let dir = match self.base {
            Some(b) if c.dir.is_relative() => b.join(&c.dir),
            _ => c.dir.clone(),
        };
        if !dir.join("log.csv").is_file() {
            return Err(self.err(
                format!("curves[{i}].dir"),
                format!("{:?}", c.dir.display().to_string()),
                "holds no log.csv of `avacraft train`",
            ));
        }
        Ok(CurveDef { name: c.name.clone(), dir })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Meta;

    /// The plan the README shows parses, with its checkpoint found from the plan's folder.
    #[test]
    fn the_shipped_plan_is_valid() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("plans/pve_scripted.toml");
        let plan = load(&p).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(plan.agents.iter().map(|a| a.kind).filter(|k| *k == AgentKind::Marl).count(), 1);
        assert_eq!(plan.jobs().len(), plan.cells.len() * 5);
        assert!(plan.cells.iter().any(|c| c.agent2.is_some()), "the head-to-head matrix");
    }

    /// A training seed names a trained agent defined before it; anything else is refused,
    /// naming the field.
    #[test]
    fn training_seeds_name_a_trained_agent_before_them() {
        let head = "name = \"p\"\nseeds = [1]\nscenarios = [\"3m_vlm\"]\n[[agents]]\nname = \"q\"\npolicy = \"baseline:qmix\"\n[[agents]]\nname = \"h\"\npolicy = \"hold\"\n";
        let seed = |of: &str| format!("{head}[[agents]]\nname = \"q2\"\npolicy = \"baseline:qmix-s2\"\nseed_of = \"{of}\"\n");
        let plan = parse("ok.toml", &seed("q"), None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(plan.agents[2].seed_of.as_deref(), Some("q"));
        assert_eq!(Meta::of(&plan).seed_of, [("q2".to_owned(), "q".to_owned())]);
        for (of, why) in [("nobody", "not an agent named before"), ("h", "trained (marl) agents"), ("q2", "not an agent named before")] {
            let e = parse("bad.toml", &seed(of), None).expect_err(of).to_string();
            assert!(e.contains("agents[2].seed_of") && e.contains(why), "{of}: {e}");
        }
        let chained = format!("{}[[agents]]\nname = \"q3\"\npolicy = \"baseline:qmix-s3\"\nseed_of = \"q2\"\n", seed("q"));
        let e = parse("bad.toml", &chained, None).expect_err("a seed of a seed").to_string();
        assert!(e.contains("agents[3].seed_of") && e.contains("itself another agent's training seed"), "{e}");
    }

    /// A plan's `[env]` table sets options over the evaluation's defaults; a name that is no
    /// option, one set elsewhere in the plan or a bad value is refused, naming the field.
    #[test]
    fn the_env_table_sets_the_other_environment_options() {
        let head = "seeds = [1]\nscenarios = [\"3m_vlm\"]\n[[agents]]\nname = \"h\"\npolicy = \"hold\"\n";
        let plan = parse("ok.toml", &format!("{head}[env]\nstep_mul = 4\nfull_vision = true\n"), None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(plan.env, EnvOptions { step_mul: 4, full_vision: true, ..eval_env() });
        assert_eq!(parse("ok.toml", head, None).unwrap_or_else(|e| panic!("{e}")).env, eval_env());
        for (table, want) in [("step_mull = 4", "step_mull"), ("opponent = \"focus\"", "`opponent`"), ("step_mul = 0", "env.step_mul")] {
            let e = parse("bad.toml", &format!("{head}[env]\n{table}\n"), None).expect_err(table).to_string();
            assert!(e.contains("bad.toml") && e.contains(want), "{table}: {e}");
        }
    }

    /// A cell whose network was trained with the ability slots plays a game that has them
    /// (its network gives orders there); the other agents' cells are left as the plan says.
    #[test]
    fn a_network_with_ability_slots_plays_its_cells_with_them() {
        let dir = std::env::temp_dir().join(format!("avacraft-eval-abilities-{}", std::process::id()));
        let cfg = avacraft_marl::Config::for_algo(
            "mappo",
            &["t_max=100", "envs=2", "rollout_len=50", "test_interval=100", "test_nepisode=1", "episode_limit=10", "ability_actions=true"]
                .map(String::from),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let scenario = Arc::new(Scenario::load("8s_vs_8m3mr1mv1st").unwrap_or_else(|e| panic!("{e}")));
        let opts = avacraft_marl::RunOptions { scenario, seed: 1, threads: 1, out: Some(dir.clone()) };
        avacraft_marl::train(&cfg, &opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e}"));
        let text = format!(
            "seeds = [1]\nscenarios = [\"8s_vs_8m3mr1mv1st\"]\n[[agents]]\nname = \"a\"\npolicy = \"marl:{}\"\n[[agents]]\nname = \"h\"\npolicy = \"hold\"\n",
            dir.join("best").display()
        );
        let plan = parse("a.toml", &text, None).unwrap_or_else(|e| panic!("{e}"));
        let slots: Vec<(&str, bool)> = plan.cells.iter().map(|c| (c.key.agent.as_str(), c.ability_actions)).collect();
        assert_eq!(slots, [("a", true), ("h", false)]);
        assert!(!plan.env.ability_actions);
        let out = dir.join("eval");
        let played = crate::run::play_job(&plan, crate::Job { cell: 0, seed: 1 }, &out);
        assert!(played.error.is_none(), "{:?}", played.error);
        let held = crate::run::play_job(&plan, crate::Job { cell: 1, seed: 1 }, &out);
        // (Their trajectory hashes differ by the games' settings alone.)
        let game = |r: &crate::results::EpisodeResult| format!("{:?} {} {:?} {:?}", r.result, r.steps, r.damage_dealt, r.units_left);
        assert_ne!(game(&played), game(&held), "the network gives orders");
        let _ = std::fs::remove_dir_all(dir);
    }
}
