//! The crate's one error type and the refused-config-value detail it boxes.

/// A config value refused: its key, the value, the rule it breaks and the nearest valid value
/// (boxed in [`Error`] to keep the error small).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{key} = {value}`: {rule}; nearest valid value: {nearest}")]
pub struct Refused {
    pub key: String,
    pub value: String,
    pub rule: String,
    pub nearest: String,
}

/// What can go wrong configuring, training, saving or loading.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("unknown algorithm `{algo}` (known: {known})")]
    UnknownAlgo { algo: String, known: String },
    #[error("unknown config key `{key}` (known: {known})")]
    UnknownKey { key: String, known: String },
    #[error("override `{text}`: {message}")]
    Override { text: String, message: String },
    #[error("{what}: {message}")]
    ConfigParse { what: String, message: String },
    #[error("{0}")]
    BadValue(Box<Refused>),
    #[error("tensor operation failed")]
    Tensor(#[from] candle_core::Error),
    #[error("environment")]
    Env(#[from] avacraft_engine::VecEnvError),
    #[error("{}", path.display())]
    Io {
        path: std::path::PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}", path.display())]
    Json {
        path: std::path::PathBuf,
        #[source]
        source: serde_json::Error,
    },
    #[error("learning-curve plot: {message}")]
    Plot { message: String },
    #[error("checkpoint: {message}")]
    Checkpoint { message: String },
    /// Another process trains into the same run folder (its `train.lock` is held).
    #[error("another process is training into {} (it holds {}/train.lock): two runs in one folder overwrite each other's files; wait for it or stop it", dir.display(), dir.display())]
    RunInUse { dir: std::path::PathBuf },
    #[error("training diverged at update {update}: loss {loss}")]
    Diverged { update: u64, loss: f64 },
    #[error("training diverged: the gradients' norm is {norm}")]
    NonFiniteGradient { norm: f64 },
    #[error("observation: {message}")]
    Observation { message: String },
    #[error("text model all-MiniLM-L6-v2: {message}")]
    TextModel { message: String },
    /// all-MiniLM-L6-v2, the vision-text mode's text model.
    #[error(transparent)]
    Text(#[from] avacraft_minilm::Error),
}
