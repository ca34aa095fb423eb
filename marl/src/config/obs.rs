//! The observation-mode keys of a run's config (`configs/obs.toml`, documented there).
//!
//! They are merged into every algorithm's config text before overrides apply, so
//! `--set obs=rgb` works whatever file a run starts from, and they have serde defaults so
//! checkpoints written before these keys existed still load (as `features` runs).
//!
//! Their checks and the Swin sizes a config selects ([`SwinSizes::of`]) are in the config
//! (`super`); the encoders (`crate::encoders`) build on these types.

use crate::Error;
use serde::{Deserialize, Serialize};

/// The keys' documented defaults, merged into configs that lack them.
pub const OBS_DEFAULTS: &str = include_str!("../../configs/obs.toml");

/// Which observation the agent network reads (the paper's four MARL modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ObsKind {
    /// SMAC's feature vectors.
    #[default]
    Features,
    /// Screen and minimap images.
    Rgb,
    /// Images and SMAC features.
    Hybrid,
    /// Images and the text description's embedding.
    VisionText,
}

impl ObsKind {
    /// The names `--obs` takes.
    pub const NAMES: [&'static str; 4] = ["features", "rgb", "hybrid", "vision-text"];
    pub const ALL: [ObsKind; 4] = [ObsKind::Features, ObsKind::Rgb, ObsKind::Hybrid, ObsKind::VisionText];

    /// The mode a name of [`ObsKind::NAMES`] names.
    pub fn from_name(name: &str) -> Option<ObsKind> {
        ObsKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Whether the agent network reads images (every mode but `features`).
    pub fn images(self) -> bool {
        self != ObsKind::Features
    }
    /// Whether the SMAC feature vector stays in the agent network's input.
    pub fn features(self) -> bool {
        matches!(self, ObsKind::Features | ObsKind::Hybrid)
    }
    /// Whether the text description is embedded.
    pub fn text(self) -> bool {
        self == ObsKind::VisionText
    }
    pub fn name(self) -> &'static str {
        match self {
            ObsKind::Features => "features",
            ObsKind::Rgb => "rgb",
            ObsKind::Hybrid => "hybrid",
            ObsKind::VisionText => "vision-text",
        }
    }
}

/// The image backbone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Backbone {
    #[default]
    Cnn,
    /// A Swin Transformer of the config's `swin_*` sizes.
    Swin,
    /// Swin-Tiny's sizes, whatever the `swin_*` keys say.
    SwinTiny,
}

/// Sizes of a Swin Transformer stream.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SwinSizes {
    pub patch: usize,
    pub embed_dim: usize,
    pub depths: Vec<usize>,
    pub heads: Vec<usize>,
    pub window: usize,
}

impl SwinSizes {
    /// Swin-Tiny (Liu et al. 2021, `swin_tiny_patch4_window7_224`).
    pub fn tiny() -> SwinSizes {
        SwinSizes { patch: 4, embed_dim: 96, depths: vec![2, 2, 6, 2], heads: vec![3, 6, 12, 24], window: 7 }
    }
}

// Serde defaults for checkpoints older than these keys; a unit test keeps them equal to
// `configs/obs.toml`.
pub(crate) fn screen_size() -> [u32; 2] {
    [80, 60]
}
pub(crate) fn minimap_size() -> [u32; 2] {
    [32, 32]
}
pub(crate) fn encoder_dim() -> usize {
    64
}
pub(crate) fn cnn_channels() -> Vec<usize> {
    vec![16, 32]
}
pub(crate) fn cnn_pool() -> usize {
    4
}
pub(crate) fn swin_patch() -> usize {
    4
}
pub(crate) fn swin_embed_dim() -> usize {
    24
}
pub(crate) fn swin_depths() -> Vec<usize> {
    vec![2, 2]
}
pub(crate) fn swin_heads() -> Vec<usize> {
    vec![2, 4]
}
pub(crate) fn swin_window() -> usize {
    7
}
pub(crate) fn text_dim() -> usize {
    32
}
pub(crate) fn text_cache() -> usize {
    20000
}
pub(crate) fn text_max_tokens() -> usize {
    256
}

/// Adds the keys of `configs/obs.toml` that `table` lacks.
pub fn add_defaults(table: &mut toml::Table) -> Result<(), Error> {
    let defaults: toml::Table =
        toml::from_str(OBS_DEFAULTS).map_err(|e| Error::ConfigParse { what: "configs/obs.toml".into(), message: e.to_string() })?;
    for (k, v) in defaults {
        table.entry(k).or_insert(v);
    }
    Ok(())
}
