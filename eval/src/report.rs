//! The report of an evaluation folder: the paper's tables as Markdown, every cell as CSV and
//! JSON, and the plots. It reads only the folder (`plan.json` and `results.jsonl`), so merged
//! shards report like one run.

use crate::links::Links;
use crate::meta::Meta;
use crate::plan::{AgentKind, CellKey};
use crate::results::{EpisodeResult, Loaded};
use crate::stats::CellStats;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The whole report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Report {
    pub meta: Meta,
    pub cells: Vec<CellStats>,
    /// Cells of the plan with no finished episode yet.
    pub missing: Vec<CellKey>,
}

impl Report {
    pub fn build(meta: Meta, loaded: &Loaded) -> Report {
        let mut by_cell: BTreeMap<&CellKey, Vec<&EpisodeResult>> = BTreeMap::new();
        for ((k, _), r) in &loaded.done {
            by_cell.entry(k).or_default().push(r);
        }
        let mut failed: BTreeMap<&CellKey, usize> = BTreeMap::new();
        for r in &loaded.failed {
            // A failure later made good by a retry is not a failure of the cell.
            if !loaded.done.contains_key(&(r.cell.clone(), r.seed)) {
                *failed.entry(&r.cell).or_default() += 1;
            }
        }
        let mut cells = Vec::new();
        let mut missing = Vec::new();
        for key in &meta.cells {
            match by_cell.get(key) {
                Some(rs) => cells.push(CellStats::of(key.clone(), rs, failed.get(key).copied().unwrap_or(0))),
                None => missing.push(key.clone()),
            }
        }
        Report { meta, cells, missing }
    }

    fn pve(&self) -> impl Iterator<Item = &CellStats> {
        self.cells.iter().filter(|c| c.key.against.starts_with("opponent:"))
    }

    /// The opponents PvE cells were played against, in first-seen order.
    fn opponents(&self) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for c in self.pve() {
            if !v.contains(&c.key.against.as_str()) {
                v.push(&c.key.against);
            }
        }
        v
    }

    pub(crate) fn scenarios(&self, pvp: bool) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for c in &self.cells {
            if c.key.against.starts_with("opponent:") != pvp && !v.contains(&c.key.scenario.as_str()) {
                v.push(&c.key.scenario);
            }
        }
        v
    }

    fn cell(&self, scenario: &str, agent: &str, against: &str) -> Option<&CellStats> {
        self.cells.iter().find(|c| c.key.scenario == scenario && c.key.agent == agent && c.key.against == against)
    }

    /// [`Meta::versus_scripted`] over this report's cells.
    pub(crate) fn versus_scripted(&self, scenario: &str, agent: &str) -> Option<f64> {
        self.meta.versus_scripted(&self.cells, scenario, agent)
    }

    /// The best agent of `kind` on `scenario` by [`Report::versus_scripted`] (the first named
    /// on a tie).
    pub(crate) fn best_of(&self, scenario: &str, kind: AgentKind) -> Option<(f64, &str)> {
        let mut best: Option<(f64, &str)> = None;
        for (a, k, _) in &self.meta.agents {
            if *k != kind || self.meta.is_variant(a) {
                continue;
            }
            if let Some(w) = self.versus_scripted(scenario, a)
                && best.is_none_or(|(b, _)| w > b)
            {
                best = Some((w, a));
            }
        }
        best
    }

    /// Per scenario, the best MARL agent against the best scripted one, and the means over
    /// the scenarios both played.
    fn marl_against_scripted(&self, s: &mut String) {
        let mut all: Vec<&str> = self.scenarios(false);
        all.extend(self.scenarios(true));
        type Best<'a> = Option<(f64, &'a str)>;
        let rows: Vec<(&str, Best<'_>, Best<'_>)> =
            all.iter().map(|sc| (*sc, self.best_of(sc, AgentKind::Marl), self.best_of(sc, AgentKind::Scripted))).collect();
        if !rows.iter().any(|(_, m, k)| m.is_some() && k.is_some()) {
            return;
        }
        let _ = writeln!(
            s,
            "## MARL against scripted agents\n\nPer scenario, the best MARL agent's and the best scripted agent's win rate (PvE: against the scenario's own opponent; PvP: the mean over the scripted agents on team 2).\n"
        );
        table_header(s, "scenario", &["best MARL", "best scripted", "MARL - scripted"]);
        let (mut sum_m, mut sum_k, mut n) = (0.0, 0.0, 0usize);
        let show = |b: Option<(f64, &str)>| b.map_or("–".to_owned(), |(w, a)| format!("{w:.2} ({a})"));
        for (sc, mb, kb) in &rows {
            let diff = match (mb, kb) {
                (Some((a, _)), Some((b, _))) => {
                    sum_m += a;
                    sum_k += b;
                    n += 1;
                    format!("{:+.2}{}", a - b, if a < b { " (MARL behind)" } else { "" })
                }
                _ => "–".to_owned(),
            };
            table_row(s, sc, &[show(*mb), show(*kb), diff]);
        }
        if n > 0 {
            let (am, ak) = (sum_m / n as f64, sum_k / n as f64);
            table_row(s, &format!("**mean over {n} scenarios**"), &[format!("{am:.3}"), format!("{ak:.3}"), format!("{:+.3}", am - ak)]);
        }
        s.push('\n');
    }

    /// Per agent with other training seeds ([`Meta::seed_of`]) and scenario, each seed's win
    /// rate (as [`Report::versus_scripted`] compares them) and their mean ± standard deviation
    /// over the seeds: how far one training run's result carries.
    fn training_seeds(&self, s: &mut String) {
        let m = &self.meta;
        let mut all: Vec<&str> = self.scenarios(false);
        all.extend(self.scenarios(true));
        for (base, _, _) in m.agents.iter().filter(|(a, _, _)| m.seed_of.iter().any(|(_, b)| b == a)) {
            let group: Vec<&str> =
                std::iter::once(base.as_str()).chain(m.seed_of.iter().filter(|(_, b)| b == base).map(|(a, _)| a.as_str())).collect();
            let rows: Vec<(&str, Vec<Option<f64>>)> = all
                .iter()
                .map(|sc| (*sc, group.iter().map(|a| self.versus_scripted(sc, a)).collect::<Vec<_>>()))
                .filter(|(_, w)| w.iter().flatten().count() > 1)
                .collect();
            if rows.is_empty() {
                continue;
            }
            let _ = writeln!(
                s,
                "## Training seeds of `{base}`

The win rate of each training run (PvE: against the scenario's own opponent; PvP: the mean over the scripted agents on team 2), and the mean ± standard deviation over the runs. The other tables show `{base}` alone; its other seeds are left out of their best-of columns.
"
            );
            let mut cols = group.clone();
            cols.push("mean ± std over runs");
            table_header(s, "scenario", &cols);
            for (sc, w) in rows {
                let mut row: Vec<String> = w.iter().map(|x| x.map_or("–".to_owned(), |v| format!("{v:.2}"))).collect();
                let ms = crate::stats::MeanStd::of(w.iter().flatten().copied());
                row.push(format!("{:.2} ± {:.2} ({} runs)", ms.mean, ms.std, w.iter().flatten().count()));
                table_row(s, sc, &row);
            }
            s.push('\n');
        }
    }

    /// Which unit data the rows played (a trained network plays the set it learned on).
    fn games_line(&self) -> String {
        let m = &self.meta;
        let mut by: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
        for c in &self.cells {
            let agents = by.entry(m.game(&c.key)).or_default();
            if !agents.contains(&c.key.agent.as_str()) {
                agents.push(c.key.agent.as_str());
            }
        }
        match by.len() {
            0 => "No cell played yet.".to_owned(),
            1 => format!("Unit data: every cell played on the `{}` set.", by.keys().next().copied().unwrap_or_default()),
            _ => {
                let parts: Vec<String> = by.iter().map(|(d, a)| format!("`{d}`: {}", a.join(", "))).collect();
                format!("Unit data per row (a trained network plays the set it learned on): {}.", parts.join("; "))
            }
        }
    }

    /// The paper's tables as Markdown.
    pub fn markdown(&self) -> String {
        self.markdown_with(&Links::none())
    }

    /// [`Report::markdown`] with links to the learning curves and images from where it is
    /// written.
    pub(crate) fn markdown_with(&self, links: &Links) -> String {
        let mut s = String::new();
        let m = &self.meta;
        let _ = writeln!(s, "# Evaluation `{}`\n", m.name);
        self.summary(&mut s, links);
        let _ = writeln!(s, "## Protocol\n");
        if !m.protocol.trim().is_empty() {
            let _ = writeln!(s, "{}\n", m.protocol.trim());
        }
        let episodes: usize = self.cells.iter().map(|c| c.episodes).sum();
        let _ = writeln!(
            s,
            "{} cells, {} episodes finished (up to {} seeds per cell); win rates are mean ± standard deviation over seeds, [95% Wilson interval].\n",
            self.cells.len(),
            episodes,
            m.seeds.len()
        );
        let _ = writeln!(s, "{}\n", self.games_line());
        let agents: Vec<&str> = m.agents.iter().map(|(n, _, _)| n.as_str()).collect();
        self.per_scenario(&mut s, &agents);
        self.marl_against_scripted(&mut s);
        self.training_seeds(&mut s);
        self.ablations(&mut s, &agents);
        self.costs(&mut s, &agents);
        self.head_to_head(&mut s, &agents);
        self.every_cell(&mut s);
        if !m.unshipped.is_empty() {
            let pairs: Vec<String> = m.unshipped.iter().map(|(a, sc)| format!("{a} on {sc}")).collect();
            let _ = writeln!(s, "\nNo shipped baseline, so not played: {}.", pairs.join("; "));
        }
        if !m.off_rules.is_empty() {
            let cells: Vec<String> = m.off_rules.iter().map(|(a, sc, what)| format!("{a} on {sc} ({what})")).collect();
            let _ = writeln!(
                s,
                "\nPlayed under other rules than they learned (the plan's `env` sets them for every cell): {}.",
                cells.join("; ")
            );
        }
        if !self.missing.is_empty() {
            let _ = writeln!(s, "\nNot played yet: {}.", self.missing.iter().map(|k| k.to_string()).collect::<Vec<_>>().join("; "));
        }
        s
    }

    /// One win-rate table per opponent, each with the best agent of each kind.
    fn per_scenario(&self, s: &mut String, agents: &[&str]) {
        let m = &self.meta;
        for against in self.opponents() {
            let _ = writeln!(s, "## Win rate per scenario ({})\n", against.trim_start_matches("opponent:"));
            let shown: Vec<&str> =
                agents.iter().copied().filter(|a| self.pve().any(|c| c.key.agent == *a && c.key.against == against)).collect();
            table_header(s, "scenario", &shown);
            for sc in self.scenarios(false) {
                let row: Vec<String> = shown.iter().map(|a| self.cell(sc, a, against).map_or("–".to_owned(), win_text)).collect();
                table_row(s, sc, &row);
            }
            s.push('\n');
            // MARL against VLM: the best agent of each kind per scenario.
            let kinds: Vec<AgentKind> = {
                let mut k: Vec<AgentKind> = shown.iter().filter_map(|a| m.kind(a)).collect();
                k.sort();
                k.dedup();
                k
            };
            if kinds.len() > 1 {
                let _ = writeln!(s, "### Best of each kind ({})\n", against.trim_start_matches("opponent:"));
                let names: Vec<&str> = kinds.iter().map(|k| k.name()).collect();
                table_header(s, "scenario", &names);
                for sc in self.scenarios(false) {
                    let row: Vec<String> = kinds
                        .iter()
                        .map(|k| {
                            // On a tie, the agent named first in the plan.
                            let of_kind: Vec<&CellStats> = self
                                .pve()
                                .filter(|c| c.key.scenario == sc && c.key.against == against && m.kind(&c.key.agent) == Some(*k))
                                .filter(|c| !m.is_variant(&c.key.agent))
                                .collect();
                            of_kind
                                .into_iter()
                                .rev()
                                .max_by(|a, b| a.win_rate.mean.total_cmp(&b.win_rate.mean))
                                .map_or("–".to_owned(), |c| format!("{:.2} ({})", c.win_rate.mean, c.key.agent))
                        })
                        .collect();
                    table_row(s, sc, &row);
                }
                s.push('\n');
            }
        }
    }

    /// The VLM agents side by side.
    fn ablations(&self, s: &mut String, agents: &[&str]) {
        let m = &self.meta;
        let vlm: Vec<&str> = agents.iter().copied().filter(|a| m.kind(a) == Some(AgentKind::Vlm)).collect();
        if vlm.len() > 1 {
            let _ = writeln!(s, "## Ablations (VLM agents, win rate per scenario)\n");
            table_header(s, "scenario", &vlm);
            for sc in self.scenarios(false) {
                let row: Vec<String> = vlm
                    .iter()
                    .map(|a| {
                        self.pve()
                            .find(|c| c.key.scenario == sc && c.key.agent == *a)
                            .map_or("–".to_owned(), |c| format!("{:.2}", c.win_rate.mean))
                    })
                    .collect();
                table_row(s, sc, &row);
            }
            s.push('\n');
        }
    }

    /// What each VLM agent's model calls cost.
    fn costs(&self, s: &mut String, agents: &[&str]) {
        let costed: Vec<&CellStats> = self.cells.iter().filter(|c| c.cost.is_some()).collect();
        if !costed.is_empty() {
            let _ = writeln!(s, "## Cost per agent\n");
            table_header(
                s,
                "agent",
                &["decisions/episode", "calls/decision", "tokens/decision", "$/episode", "model s/decision", "failed calls", "fallbacks"],
            );
            for a in agents {
                let cs: Vec<&crate::stats::CostStats> =
                    costed.iter().filter(|c| c.key.agent == *a).filter_map(|c| c.cost.as_ref()).collect();
                if cs.is_empty() {
                    continue;
                }
                let n = cs.len() as f64;
                let avg = |f: &dyn Fn(&crate::stats::CostStats) -> f64| cs.iter().map(|c| f(c)).sum::<f64>() / n;
                let unpriced = cs.iter().any(|c| c.unpriced_episodes > 0);
                let row = vec![
                    format!("{:.1}", avg(&|c| c.decisions_per_episode)),
                    format!("{:.2}", avg(&|c| c.calls_per_decision)),
                    format!("{:.0}", avg(&|c| c.tokens_per_decision)),
                    if unpriced { "unpriced".to_owned() } else { format!("{:.4}", avg(&|c| c.dollars_per_episode)) },
                    format!("{:.2}", avg(&|c| c.model_seconds_per_decision)),
                    cs.iter().map(|c| c.failed_calls).sum::<u64>().to_string(),
                    cs.iter().map(|c| c.fallbacks).sum::<u64>().to_string(),
                ];
                table_row(s, a, &row);
            }
            s.push('\n');
        }
    }

    /// One matrix per PvP scenario, with only the agents that played on it.
    fn head_to_head(&self, s: &mut String, agents: &[&str]) {
        for sc in self.scenarios(true) {
            let _ = writeln!(s, "## Head to head on {sc} (row's win rate as team 1)\n");
            let names: Vec<&str> = agents
                .iter()
                .copied()
                .filter(|a| self.cells.iter().any(|c| c.key.scenario == sc && (c.key.agent == *a || c.key.against == *a)))
                .collect();
            table_header(s, "team 1 \\ team 2", &names);
            for a in &names {
                let row: Vec<String> =
                    names.iter().map(|b| self.cell(sc, a, b).map_or("–".to_owned(), |c| format!("{:.2}", c.win_rate.mean))).collect();
                table_row(s, a, &row);
            }
            s.push('\n');
        }
    }

    /// Every cell's numbers.
    fn every_cell(&self, s: &mut String) {
        let _ = writeln!(s, "## Every cell\n");
        table_header(
            s,
            "scenario",
            &["agent", "against", "episodes", "W/D/L", "win rate", "game s", "damage dealt", "kills", "deaths", "refused"],
        );
        for c in &self.cells {
            let row = vec![
                c.key.agent.clone(),
                c.key.against.clone(),
                if c.failed > 0 { format!("{} ({} failed)", c.episodes, c.failed) } else { c.episodes.to_string() },
                format!("{}/{}/{}", c.wins, c.draws, c.losses),
                win_text(c),
                format!("{:.1}", c.game_seconds.mean),
                format!("{:.0}", c.damage_dealt.mean),
                format!("{:.1}", c.kills.mean),
                format!("{:.1}", c.deaths.mean),
                format!("{:.1}", c.refused_actions.mean),
            ];
            table_row(s, &c.key.scenario, &row);
        }
    }

    /// Every cell as CSV.
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "scenario,agent,kind,against,episodes,failed,wins,draws,losses,win_rate,win_std,win_ci_low,win_ci_high,game_seconds,damage_dealt,damage_taken,kills,deaths,refused_actions,calls_per_decision,tokens_per_decision,dollars_per_episode,model_seconds_per_decision\n",
        );
        for c in &self.cells {
            let kind = self.meta.kind(&c.key.agent).map_or("", AgentKind::name);
            let cost = c.cost.as_ref();
            let opt = |f: &dyn Fn(&crate::stats::CostStats) -> f64| cost.map_or(String::new(), |k| format!("{:.6}", f(k)));
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{},{},{},{}",
                csv_field(&c.key.scenario),
                csv_field(&c.key.agent),
                kind,
                csv_field(&c.key.against),
                c.episodes,
                c.failed,
                c.wins,
                c.draws,
                c.losses,
                c.win_rate.mean,
                c.win_rate.std,
                c.win_ci95.0,
                c.win_ci95.1,
                c.game_seconds.mean,
                c.damage_dealt.mean,
                c.damage_taken.mean,
                c.kills.mean,
                c.deaths.mean,
                c.refused_actions.mean,
                opt(&|k| k.calls_per_decision),
                opt(&|k| k.tokens_per_decision),
                opt(&|k| k.dollars_per_episode),
                opt(&|k| k.model_seconds_per_decision),
            );
        }
        s
    }

    /// Writes `report.md`, `report.csv`, `report.json` and the plots into `dir`; returns the
    /// files written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, crate::EvalError> {
        let mut files = Vec::new();
        let mut put = |name: &str, text: &str| -> Result<(), crate::EvalError> {
            let p = dir.join(name);
            std::fs::write(&p, text).map_err(|source| crate::EvalError::Io { path: p.clone(), source })?;
            files.push(p);
            Ok(())
        };
        put("report.md", &self.markdown_with(&Links::from(dir, &avacraft_marl::baselines::root(), "")))?;
        put("report.csv", &self.csv())?;
        let json = serde_json::to_string_pretty(self)
            .map_err(|e| crate::EvalError::Io { path: dir.join("report.json"), source: std::io::Error::other(e) })?;
        put("report.json", &json)?;
        let plots = crate::plot::all(&self.meta, &self.cells, dir)?;
        files.extend(plots.iter().cloned());
        if let Some(doc) = &self.meta.document {
            files.extend(self.write_document(doc, &plots)?);
        }
        Ok(files)
    }

    /// The report as a document (e.g. `docs/results.md`): its plots copied into a folder
    /// named after it, beside it, and shown under the tables.
    fn write_document(&self, doc: &Path, plots: &[PathBuf]) -> Result<Vec<PathBuf>, crate::EvalError> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| crate::EvalError::Io { path, source }
        };
        let stem = doc.file_stem().map_or_else(|| "results".to_owned(), |s| s.to_string_lossy().into_owned());
        let img_dir = doc.with_file_name(&stem);
        std::fs::create_dir_all(&img_dir).map_err(io(&img_dir))?;
        let here = doc.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let mut text = self.markdown_with(&Links::from(here, &avacraft_marl::baselines::root(), &format!("{stem}/")));
        let mut files = Vec::new();
        // The win-rate heat map opens the page; the others go under the tables.
        let rest: Vec<&PathBuf> = plots.iter().filter(|p| p.file_name().is_some_and(|n| n != crate::plot::WIN_RATES)).collect();
        if !rest.is_empty() {
            text.push_str("\n## Plots\n\n");
        }
        for p in plots {
            let Some(name) = p.file_name() else { continue };
            let to = img_dir.join(name);
            std::fs::copy(p, &to).map_err(io(&to))?;
            if rest.contains(&p) {
                let _ = writeln!(text, "![{}]({stem}/{})\n", name.to_string_lossy(), name.to_string_lossy());
            }
            files.push(to);
        }
        // The numbers behind the tables, for scripts and the tests that check them.
        for (name, body) in [("report.csv", self.csv()), ("report.json", serde_json::to_string_pretty(self).unwrap_or_default())] {
            let to = img_dir.join(name);
            std::fs::write(&to, body).map_err(io(&to))?;
            files.push(to);
        }
        let _ = writeln!(text, "The numbers: [{stem}/report.csv]({stem}/report.csv), [{stem}/report.json]({stem}/report.json).");
        std::fs::write(doc, text).map_err(io(doc))?;
        files.push(doc.to_path_buf());
        Ok(files)
    }
}

fn win_text(c: &CellStats) -> String {
    format!("{:.2} ± {:.2} [{:.2}, {:.2}]", c.win_rate.mean, c.win_rate.std, c.win_ci95.0, c.win_ci95.1)
}

fn table_header(s: &mut String, first: &str, cols: &[&str]) {
    let _ = writeln!(s, "| {first} | {} |", cols.join(" | "));
    let _ = writeln!(s, "|---|{}", "---|".repeat(cols.len()));
}

fn table_row(s: &mut String, first: &str, cols: &[String]) {
    let _ = writeln!(s, "| {first} | {} |", cols.join(" | "));
}

fn csv_field(v: &str) -> String {
    if v.contains([',', '"', '\n']) { format!("\"{}\"", v.replace('"', "\"\"")) } else { v.to_owned() }
}
