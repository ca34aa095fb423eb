//! Links from a report's Markdown to what lies outside it: the shipped runs' learning curves
//! and the report's own images, relative to where the Markdown is written.

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
    pub(crate) fn curves(&self, spec: &str, scenario: &str, text: &str) -> String {
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
