//! What calls cost: tokens, latency and dollars, per call, per decision and per episode. The
//! paper's cost table (GPT-4o ~2.3 s and ~1,800 tokens per decision) is reproduced from
//! these counts; dollars come from a price table the user can replace.

use crate::llm::{Stage, Usage};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

const BUILTIN: &str = include_str!("../prices.toml");

/// Dollars per million tokens.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Price {
    pub prompt: f64,
    pub completion: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriceTable {
    pub models: BTreeMap<String, Price>,
}

#[derive(Debug, thiserror::Error)]
pub enum PriceError {
    #[error("{file}: {source}")]
    Syntax {
        file: String,
        #[source]
        source: toml::de::Error,
    },
    #[error("{file}: model `{model}`: prices must be finite and not negative")]
    Value { file: String, model: String },
}

impl PriceTable {
    pub fn builtin() -> PriceTable {
        // The shipped file is checked by a test; an empty table is the safe answer anyway.
        PriceTable::from_toml("ava/prices.toml", BUILTIN).unwrap_or(PriceTable { models: BTreeMap::new() })
    }

    pub fn from_toml(file: &str, text: &str) -> Result<PriceTable, PriceError> {
        let t: PriceTable = toml::from_str(text).map_err(|source| PriceError::Syntax { file: file.to_owned(), source })?;
        for (model, p) in &t.models {
            if !(p.prompt.is_finite() && p.completion.is_finite() && p.prompt >= 0.0 && p.completion >= 0.0) {
                return Err(PriceError::Value { file: file.to_owned(), model: model.clone() });
            }
        }
        Ok(t)
    }

    /// Dollars for a call's tokens, or `None` when the model has no price.
    pub fn cost(&self, model: &str, usage: Usage) -> Option<f64> {
        let p = self.models.get(model)?;
        Some((usage.prompt_tokens as f64 * p.prompt + usage.completion_tokens as f64 * p.completion) / 1e6)
    }
}

/// Sums over calls.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Totals {
    pub calls: u64,
    /// Calls that failed (transport, HTTP status, envelope) and were retried or given up.
    pub failed_calls: u64,
    pub prompt_tokens: u64,
    pub completion_tokens: u64,
    /// Calls whose server gave no token counts.
    pub calls_without_usage: u64,
    pub latency_ms: f64,
    pub cost_usd: f64,
    /// Calls of a model missing from the price table.
    pub unpriced_calls: u64,
}

impl Totals {
    pub fn add_call(&mut self, usage: Option<Usage>, latency_ms: f64, cost: Option<f64>, failed: bool) {
        self.calls += 1;
        self.failed_calls += u64::from(failed);
        match usage {
            Some(u) => {
                self.prompt_tokens += u.prompt_tokens;
                self.completion_tokens += u.completion_tokens;
            }
            None if !failed => self.calls_without_usage += 1,
            None => {}
        }
        self.latency_ms += latency_ms;
        match cost {
            Some(c) => self.cost_usd += c,
            None if !failed => self.unpriced_calls += 1,
            None => {}
        }
    }
    pub fn merge(&mut self, o: &Totals) {
        self.calls += o.calls;
        self.failed_calls += o.failed_calls;
        self.prompt_tokens += o.prompt_tokens;
        self.completion_tokens += o.completion_tokens;
        self.calls_without_usage += o.calls_without_usage;
        self.latency_ms += o.latency_ms;
        self.cost_usd += o.cost_usd;
        self.unpriced_calls += o.unpriced_calls;
    }
}

/// An episode's accounting.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EpisodeCost {
    pub episode: u64,
    pub seed: u64,
    pub team: u8,
    pub decisions: u64,
    pub total: Totals,
    pub by_stage: BTreeMap<Stage, Totals>,
    /// Repair rounds after refused items.
    pub repairs: u64,
    /// Items refused by the checks (each repair round's included).
    pub refused_items: u64,
    /// Decisions where no valid action came and the fallback acted.
    pub fallbacks: u64,
    /// Decisions given up after transport errors (the fallback acted).
    pub transport_failures: u64,
    /// Pipeline time per decision besides waiting for the model, milliseconds (sum).
    pub overhead_ms: f64,
}

impl EpisodeCost {
    pub fn per_decision(&self) -> (f64, f64, f64) {
        let n = self.decisions.max(1) as f64;
        (self.total.calls as f64 / n, (self.total.prompt_tokens + self.total.completion_tokens) as f64 / n, self.total.latency_ms / n)
    }
}
