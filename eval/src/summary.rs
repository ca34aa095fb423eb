//! The report's opening: one table that answers "who wins where" (per scenario, the best
//! learner with its last checkpoint beside it, the best scripted agent and AVA), each learner
//! linked to its learning curves, then the heat map of every agent on every scenario.

use crate::links::Links;
use crate::plan::AgentKind;
use crate::report::Report;
use std::fmt::Write as _;

impl Report {
    /// The opening table and the heat map under it.
    pub(crate) fn summary(&self, s: &mut String, links: &Links) {
        let m = &self.meta;
        let mut all: Vec<(&str, bool)> = self.scenarios(false).into_iter().map(|sc| (sc, false)).collect();
        all.extend(self.scenarios(true).into_iter().map(|sc| (sc, true)));
        if all.is_empty() {
            return;
        }
        let has = |k: AgentKind| m.agents.iter().any(|(_, kind, _)| *kind == k);
        let lasts: Vec<(&str, &str)> = m.agents.iter().filter_map(|(a, _, _)| m.last_of(a).map(|of| (of, a.as_str()))).collect();
        let _ = writeln!(s, "## Who wins where\n");
        let _ = writeln!(
            s,
            "Win rate of the best agent of each kind (PvE: against the scenario's own opponent; PvP: the mean over the scripted agents on team 2). A learner is its best-of-N checkpoint{}; its name links to its learning curves.\n",
            if lasts.is_empty() { "" } else { ", with the last checkpoint of the same run beside it" }
        );
        let mut cols: Vec<&str> = Vec::new();
        if has(AgentKind::Marl) {
            cols.push("best learner");
            if !lasts.is_empty() {
                cols.push("its last checkpoint");
            }
        }
        if has(AgentKind::Scripted) {
            cols.push("best script");
        }
        if has(AgentKind::Vlm) {
            cols.push("AVA (best)");
        }
        let _ = writeln!(s, "| scenario | {} |", cols.join(" | "));
        let _ = writeln!(s, "|---|{}", "---:|".repeat(cols.len()));
        for (sc, pvp) in all {
            let spec = |a: &str| m.agents.iter().find(|(n, _, _)| n == a).map_or("", |(_, _, p)| p.as_str());
            let mut row: Vec<String> = Vec::new();
            let best = |k: AgentKind| self.best_of(sc, k);
            if has(AgentKind::Marl) {
                let b = best(AgentKind::Marl);
                row.push(b.map_or("–".to_owned(), |(w, a)| format!("{} {w:.2}", links.curves(spec(a), sc, a))));
                if !lasts.is_empty() {
                    let last = b.and_then(|(_, a)| lasts.iter().find(|(of, _)| *of == a)).and_then(|(_, l)| self.versus_scripted(sc, l));
                    row.push(last.map_or("–".to_owned(), |w| format!("{w:.2}")));
                }
            }
            if has(AgentKind::Scripted) {
                row.push(best(AgentKind::Scripted).map_or("–".to_owned(), |(w, a)| format!("{a} {w:.2}")));
            }
            if has(AgentKind::Vlm) {
                row.push(best(AgentKind::Vlm).map_or("–".to_owned(), |(w, a)| format!("{a} {w:.2}")));
            }
            let name = if pvp { format!("{sc} (PvP)") } else { sc.to_owned() };
            let _ = writeln!(s, "| {name} | {} |", row.join(" | "));
        }
        s.push('\n');
        if self.cells.iter().any(|c| c.key.against.starts_with("opponent:") || m.kind(&c.key.against) == Some(AgentKind::Scripted)) {
            let _ = writeln!(s, "![Win rate of every agent on every scenario]({}winrate.png)\n", links.images);
        }
    }
}
