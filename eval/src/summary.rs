//! The report's opening: one table that answers "who wins where" (per scenario, the best
//! learner with its last checkpoint beside it, the best scripted agent and AVA), each learner
//! linked to its learning curves, then the heat map of every agent on every scenario.

use crate::plan::AgentKind;
use crate::report::Report;
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// Where the Markdown is written, for the links it carries: the shipped runs' learning
/// curves (`curves.png` under the baselines folder) and the report's own images.
pub(crate) struct Links {
    /// The baselines folder as seen from the Markdown file's folder (`None`: no links).
    pub baselines: Option<(PathBuf, String)>,
    /// The prefix of the report's images from the Markdown file (`""` or `results/`).
    pub images: String,
}

impl Links {
    /// Links from a Markdown file in `dir` to `baselines` (the shipped runs) and to images in
    /// `images` (relative to `dir`).
    pub(crate) fn from(dir: &Path, baselines: &Path, images: &str) -> Links {
        let rel = relative(dir, baselines).map(|r| (baselines.to_path_buf(), r));
        Links { baselines: rel, images: images.to_owned() }
    }

    pub(crate) fn none() -> Links {
        Links { baselines: None, images: String::new() }
    }

    /// `[text](curves)` where the shipped run behind `spec` on `scenario` has its curves.
    fn curves(&self, spec: &str, scenario: &str, text: &str) -> String {
        let run = spec.strip_prefix(avacraft_marl::baselines::BASELINE_PREFIX);
        let Some(((root, rel), run)) = self.baselines.as_ref().zip(run) else { return text.to_owned() };
        let (run, _) = avacraft_marl::baselines::split_last(run);
        if !root.join(scenario).join(run).join("curves.png").is_file() {
            return text.to_owned();
        }
        format!("[{text}]({rel}/{scenario}/{run}/curves.png)")
    }
}

/// `to` as a relative path from the folder `from` (both made absolute first); `None` when
/// either cannot be resolved.
pub(crate) fn relative(from: &Path, to: &Path) -> Option<String> {
    let (from, to) = (std::path::absolute(from).ok()?, std::path::absolute(to).ok()?);
    let norm = |p: &Path| -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        for c in p.components() {
            match c {
                Component::ParentDir => {
                    v.pop();
                }
                Component::Normal(s) => v.push(s.to_string_lossy().into_owned()),
                _ => {}
            }
        }
        v
    };
    let (f, t) = (norm(&from), norm(&to));
    let common = f.iter().zip(&t).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<String> = vec!["..".to_owned(); f.len() - common];
    parts.extend(t[common..].iter().cloned());
    Some(if parts.is_empty() { ".".to_owned() } else { parts.join("/") })
}

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

#[cfg(test)]
mod tests {
    use super::relative;
    use std::path::Path;

    #[test]
    fn relative_paths_climb_out_and_down() {
        assert_eq!(relative(Path::new("/a/docs"), Path::new("/a/baselines")).as_deref(), Some("../baselines"));
        assert_eq!(relative(Path::new("/a/eval/plans/../../docs"), Path::new("/a/x/../baselines")).as_deref(), Some("../baselines"));
        assert_eq!(relative(Path::new("/a"), Path::new("/a")).as_deref(), Some("."));
        assert_eq!(relative(Path::new("/a/b/c"), Path::new("/d")).as_deref(), Some("../../../d"));
    }
}
