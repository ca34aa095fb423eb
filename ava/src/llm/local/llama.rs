//! What every part of the local back end needs: llama.cpp's process-wide initialisation,
//! the error they all return, and the check of the files handed to llama.cpp. A leaf, so
//! decoding and vision depend on it and not on the model that uses them.

use crate::llm::LlmError;
use llama_cpp_2::llama_backend::LlamaBackend;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub(super) fn local(why: impl Into<String>) -> LlmError {
    LlmError::Local { why: why.into() }
}

/// llama.cpp's process-wide initialisation, done once; its logs go to `tracing`.
pub(super) fn backend() -> Result<&'static LlamaBackend, LlmError> {
    static BACKEND: OnceLock<Result<LlamaBackend, String>> = OnceLock::new();
    BACKEND
        .get_or_init(|| {
            llama_cpp_2::send_logs_to_tracing(llama_cpp_2::LogOptions::default());
            LlamaBackend::init().map_err(|e| e.to_string())
        })
        .as_ref()
        .map_err(|e| local(format!("cannot initialise llama.cpp: {e}")))
}

/// Why a file cannot be given to llama.cpp as a model or a vision projector.
#[derive(Debug, thiserror::Error)]
pub enum GgufError {
    #[error("{what} {}: no such file", path.display())]
    Missing { what: &'static str, path: PathBuf },
    #[error("{what} {}: cannot read it", path.display())]
    Unreadable {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{what} {}: not a GGUF file ({why})", path.display())]
    NotGguf { what: &'static str, path: PathBuf, why: &'static str },
}

/// Checks that `path` is a readable GGUF file (its first bytes), naming `what` it is meant
/// to be and the path when it is not: llama.cpp itself only says that loading failed.
pub fn check_gguf(path: &Path, what: &'static str) -> Result<(), GgufError> {
    use std::io::Read as _;
    let mut magic = [0u8; 4];
    let read = std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut magic));
    let path = path.to_path_buf();
    match read {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(GgufError::Missing { what, path }),
        Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(GgufError::NotGguf { what, path, why: "shorter than its header" }),
        Err(source) => Err(GgufError::Unreadable { what, path, source }),
        Ok(()) if &magic != b"GGUF" => Err(GgufError::NotGguf { what, path, why: "it does not start with `GGUF`" }),
        Ok(()) => Ok(()),
    }
}

/// [`check_gguf`] as an [`LlmError`], which is plain text (calls and their errors are
/// recorded as JSON): the source's words go into it.
pub(super) fn check_gguf_llm(path: &Path, what: &'static str) -> Result<(), LlmError> {
    check_gguf(path, what).map_err(|e| match &e {
        GgufError::Unreadable { source, .. } => local(format!("{e}: {source}")),
        _ => local(e.to_string()),
    })
}
