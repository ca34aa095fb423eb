//! The prompts, as versioned template files (`ava/prompts/v1/*.j2`, Jinja syntax through
//! minijinja). A run records the version with every call, so results can be told apart when
//! the wording changes; `--prompts DIR` swaps in another set without rebuilding.

use minijinja::{Environment, UndefinedBehavior};
use std::path::Path;

/// The templates every set must have.
pub const TEMPLATES: [&str; 6] = ["system", "planner", "priority", "roles", "decision", "repair"];

const V1: [(&str, &str); 6] = [
    ("system", include_str!("../prompts/v1/system.j2")),
    ("planner", include_str!("../prompts/v1/planner.j2")),
    ("priority", include_str!("../prompts/v1/priority.j2")),
    ("roles", include_str!("../prompts/v1/roles.j2")),
    ("decision", include_str!("../prompts/v1/decision.j2")),
    ("repair", include_str!("../prompts/v1/repair.j2")),
];

const V2: [(&str, &str); 6] = [
    ("system", include_str!("../prompts/v2/system.j2")),
    ("planner", include_str!("../prompts/v2/planner.j2")),
    ("priority", include_str!("../prompts/v2/priority.j2")),
    ("roles", include_str!("../prompts/v2/roles.j2")),
    ("decision", include_str!("../prompts/v2/decision.j2")),
    ("repair", include_str!("../prompts/v2/repair.j2")),
];

#[derive(Debug, thiserror::Error)]
pub enum PromptError {
    #[error("{}: cannot read the template: {source}", path.display())]
    Read {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("template `{name}` ({origin}): {source}")]
    Template {
        name: String,
        origin: String,
        #[source]
        source: minijinja::Error,
    },
}

/// A set of prompt templates.
#[derive(Debug)]
pub struct Prompts {
    version: String,
    origin: String,
    env: Environment<'static>,
}

impl Prompts {
    /// The paper's set shipped with the crate (`v1`).
    pub fn builtin() -> Result<Prompts, PromptError> {
        Prompts::builtin_for(crate::PromptStyle::Paper)
    }

    /// The set shipped for a prompt style: `v1` (the paper's) or `v2` (the rich prompt).
    pub fn builtin_for(style: crate::PromptStyle) -> Result<Prompts, PromptError> {
        let (version, set) = match style {
            crate::PromptStyle::Paper => ("v1", &V1),
            crate::PromptStyle::Rich => ("v2", &V2),
        };
        Prompts::from_sources(version, &format!("builtin {version}"), set.iter().map(|(n, s)| (n.to_string(), s.to_string())).collect())
    }

    /// A set from `dir`, holding `<name>.j2` for each of [`TEMPLATES`]. Its version is the
    /// folder's name and a hash of the texts, so edits show in the recordings.
    pub fn from_dir(dir: &Path) -> Result<Prompts, PromptError> {
        let mut sources = Vec::new();
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        for name in TEMPLATES {
            let path = dir.join(format!("{name}.j2"));
            let text = std::fs::read_to_string(&path).map_err(|source| PromptError::Read { path: path.clone(), source })?;
            h.update(text.as_bytes());
            sources.push((name.to_owned(), text));
        }
        let base = dir.file_name().map_or_else(|| "custom".into(), |n| n.to_string_lossy().into_owned());
        Prompts::from_sources(&format!("{base}-{:08x}", h.digest() as u32), &dir.display().to_string(), sources)
    }

    fn from_sources(version: &str, origin: &str, sources: Vec<(String, String)>) -> Result<Prompts, PromptError> {
        let mut env = Environment::new();
        // A misspelt variable is an error, not an empty string in a prompt.
        env.set_undefined_behavior(UndefinedBehavior::Strict);
        env.set_trim_blocks(false);
        for (name, text) in sources {
            env.add_template_owned(name.clone(), text).map_err(|source| PromptError::Template {
                name,
                origin: origin.to_owned(),
                source,
            })?;
        }
        Ok(Prompts { version: version.to_owned(), origin: origin.to_owned(), env })
    }

    pub fn version(&self) -> &str {
        &self.version
    }

    /// Renders template `name` with `ctx`.
    pub fn render(&self, name: &str, ctx: &impl serde::Serialize) -> Result<String, PromptError> {
        let err = |source| PromptError::Template { name: name.to_owned(), origin: self.origin.clone(), source };
        self.env.get_template(name).map_err(err)?.render(ctx).map_err(err)
    }
}
