//! The vision-text mode's text embedding: all-MiniLM-L6-v2, from its own crate (AVA's
//! retrieval uses it too).

pub use avacraft_minilm::*;
