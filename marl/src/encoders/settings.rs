//! The observation-mode keys of a run's config (`configs/obs.toml`, documented there).
//!
//! They are merged into every algorithm's config text before overrides apply, so
//! `--set obs=rgb` works whatever file a run starts from, and they have serde defaults so
//! checkpoints written before these keys existed still load (as `features` runs).

use crate::{Config, Error};
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
    /// The sizes `cfg` selects.
    pub fn of(cfg: &Config) -> SwinSizes {
        match cfg.encoder {
            Backbone::SwinTiny => SwinSizes::tiny(),
            _ => SwinSizes {
                patch: cfg.swin_patch,
                embed_dim: cfg.swin_embed_dim,
                depths: cfg.swin_depths.clone(),
                heads: cfg.swin_heads.clone(),
                window: cfg.swin_window,
            },
        }
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

/// Checks the observation keys of `cfg`.
pub fn validate(cfg: &Config) -> Result<(), Error> {
    let bad = |key: &str, value: String, why: &str, nearest: String| Err(crate::config::bad(key, value, why, nearest));
    for (key, size) in [("screen_size", cfg.screen_size), ("minimap_size", cfg.minimap_size)] {
        if size.iter().any(|&s| !(8..=4096).contains(&s)) {
            let near = size.map(|s| s.clamp(8, 4096));
            return bad(key, format!("{size:?}"), "frame sides must lie in 8..=4096 pixels", format!("{near:?}"));
        }
    }
    if !(2..=512).contains(&cfg.text_max_tokens) {
        return bad(
            "text_max_tokens",
            cfg.text_max_tokens.to_string(),
            "must lie in 2..=512 (BERT's positions)",
            cfg.text_max_tokens.clamp(2, 512).to_string(),
        );
    }
    for (key, v) in [("encoder_dim", cfg.encoder_dim), ("text_dim", cfg.text_dim), ("cnn_pool", cfg.cnn_pool)] {
        if v == 0 {
            return bad(key, "0".into(), "must be at least 1", "1".into());
        }
    }
    if cfg.cnn_channels.is_empty() || cfg.cnn_channels.contains(&0) {
        let near: Vec<usize> = if cfg.cnn_channels.is_empty() { vec![16] } else { cfg.cnn_channels.iter().map(|&c| c.max(1)).collect() };
        return bad(
            "cnn_channels",
            format!("{:?}", cfg.cnn_channels),
            "needs at least one convolution, every width at least 1",
            format!("{near:?}"),
        );
    }
    let s = SwinSizes::of(cfg);
    if s.depths.is_empty() || s.depths.len() != s.heads.len() {
        let near: Vec<usize> = s.depths.iter().map(|_| 2).collect();
        return bad(
            "swin_heads",
            format!("{:?}", s.heads),
            &format!("one head count per stage ({} stages in swin_depths)", s.depths.len()),
            format!("{near:?}"),
        );
    }
    for (key, v) in [("swin_patch", s.patch), ("swin_window", s.window), ("swin_embed_dim", s.embed_dim)] {
        if v == 0 {
            return bad(key, "0".into(), "Swin sizes must be at least 1", "1".into());
        }
    }
    if s.depths.contains(&0) {
        return bad(
            "swin_depths",
            format!("{:?}", s.depths),
            "every stage needs at least 1 block",
            format!("{:?}", s.depths.iter().map(|&d| d.max(1)).collect::<Vec<_>>()),
        );
    }
    for (i, &h) in s.heads.iter().enumerate() {
        let width = s.embed_dim << i;
        if h == 0 || !width.is_multiple_of(h) {
            let near = (1..=width).filter(|d| width.is_multiple_of(*d)).min_by_key(|d| d.abs_diff(h)).unwrap_or(1);
            return bad(
                "swin_heads",
                format!("{:?}", s.heads),
                &format!("stage {} is {width} wide: its {h} heads must divide it", i + 1),
                format!("{near} heads at stage {}", i + 1),
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obs_toml_matches_the_serde_defaults() -> Result<(), Error> {
        // A config without the keys (as old checkpoints are) and one with obs.toml merged.
        let with = Config::for_algo("qmix", &[])?;
        let mut json = serde_json::to_value(&with).map_err(|source| Error::Json { path: "config".into(), source })?;
        let keys: toml::Table =
            toml::from_str(OBS_DEFAULTS).map_err(|e| Error::ConfigParse { what: "obs.toml".into(), message: e.to_string() })?;
        if let Some(o) = json.as_object_mut() {
            for k in keys.keys() {
                assert!(o.remove(k).is_some(), "{k} is not a Config field");
            }
        }
        let without: Config = serde_json::from_value(json).map_err(|source| Error::Json { path: "config".into(), source })?;
        assert_eq!(with, without);
        Ok(())
    }

    #[test]
    fn bad_swin_heads_are_named() {
        let e = Config::for_algo("qmix", &["swin_heads=[5, 4]".into()]).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("swin_heads"), "{e}");
        assert!(Config::for_algo("qmix", &["obs=\"vision-text\"".into(), "encoder=\"swin-tiny\"".into()]).is_ok());
        assert!(Config::for_algo("qmix", &["obs=pixels".into()]).is_err());
    }
}
