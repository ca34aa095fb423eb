//! What the agents of one run share: the model back end, the recorder, the price table, and
//! the per-episode accounting that a caller reads after (or during) the run.

use crate::cost::{EpisodeCost, PriceTable};
use crate::llm::{CallRecord, ChatModel, ChatReply, ChatRequest, LlmError, Recorder};
use std::sync::{Arc, Mutex, MutexGuard};

/// Who asks, for the record.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CallMeta {
    pub episode: u64,
    pub seed: u64,
    pub team: u8,
    pub step: u32,
    pub decision: u32,
    pub attempt: u32,
}

/// Sees every call as it is recorded (an agent node publishes them for the session's MCAP).
pub type CallObserver = Box<dyn FnMut(&CallRecord, &ChatRequest) + Send>;

struct Inner {
    model: Box<dyn ChatModel>,
    recorder: Option<Recorder>,
    observer: Option<CallObserver>,
    prices: PriceTable,
    episodes: Vec<EpisodeCost>,
    fatal: Option<String>,
}

/// The accounting's file in a recording's folder.
pub const COSTS_FILE: &str = "costs.json";

impl Drop for AvaRun {
    fn drop(&mut self) {
        if let Err(e) = self.write_costs() {
            tracing::warn!(error = %e, "the AVA accounting could not be written");
        }
    }
}

/// A model shared by a run's AVA agents (both teams of a PvP game may share one; calls are
/// made one at a time, in the order the episode asks them, so a replay meets them in the
/// same order).
pub struct AvaRun {
    inner: Mutex<Inner>,
}

impl std::fmt::Debug for AvaRun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AvaRun").finish_non_exhaustive()
    }
}

impl AvaRun {
    pub fn new(model: Box<dyn ChatModel>, recorder: Option<Recorder>, prices: PriceTable) -> Arc<AvaRun> {
        Arc::new(AvaRun { inner: Mutex::new(Inner { model, recorder, observer: None, prices, episodes: Vec::new(), fatal: None }) })
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic elsewhere while holding the lock leaves plain data behind; keep going.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Hands every later call's record to `observer` too (the run folder keeps them as well).
    pub fn observe(&self, observer: CallObserver) {
        self.lock().observer = Some(observer);
    }

    /// The model's configured name.
    pub fn model(&self) -> String {
        self.lock().model.model().to_owned()
    }

    /// Accounting of every episode so far (the current one as it stands).
    pub fn episodes(&self) -> Vec<EpisodeCost> {
        self.lock().episodes.clone()
    }

    /// The first error that should stop the run: a replay that no longer matches its
    /// recording, or a recording that cannot be written. The agents fall back and go on; the
    /// caller checks this and fails.
    pub fn fatal(&self) -> Option<String> {
        self.lock().fatal.clone()
    }

    pub(crate) fn set_fatal(&self, why: String) {
        let mut g = self.lock();
        if g.fatal.is_none() {
            g.fatal = Some(why);
        }
    }

    /// Starts an episode's accounting and returns its index.
    pub(crate) fn open_episode(&self, cost: EpisodeCost) -> usize {
        let mut g = self.lock();
        g.episodes.push(cost);
        g.episodes.len() - 1
    }

    pub(crate) fn update_episode(&self, idx: usize, cost: &EpisodeCost) {
        if let Some(e) = self.lock().episodes.get_mut(idx) {
            *e = cost.clone();
        }
    }

    /// Writes the accounting so far to `costs.json` in the recording's folder (done when the
    /// run is dropped too, so an agent node stopped at the end of a session leaves it).
    pub fn write_costs(&self) -> Result<(), crate::llm::RecordError> {
        let g = self.lock();
        let Some(rec) = g.recorder.as_ref() else { return Ok(()) };
        let path = rec.dir().join(COSTS_FILE);
        let io = |source| crate::llm::RecordError::Io { path: path.clone(), what: "cannot write the accounting", source };
        let text = serde_json::to_string_pretty(&g.episodes).map_err(|e| io(std::io::Error::other(e)))?;
        // Rewritten after every episode: written aside and renamed, so a node killed
        // mid-write keeps the last whole accounting instead of a torn one.
        let tmp = path.with_extension("json.tmp");
        std::fs::write(&tmp, text).and_then(|()| std::fs::rename(&tmp, &path)).map_err(io)
    }

    /// One call with retries: transport errors, 429s and 5xxs are tried again after pauses
    /// of `backoff_ms`, doubling, up to `max_retries` times. Every attempt is recorded and
    /// accounted in `cost` before its answer is used.
    pub(crate) fn call(
        &self,
        meta: CallMeta,
        prompts: &str,
        req: &ChatRequest,
        max_retries: u32,
        backoff_ms: u64,
        cost: &mut EpisodeCost,
    ) -> Result<ChatReply, LlmError> {
        let mut g = self.lock();
        let hash = req.hash();
        let mut attempt = 0;
        loop {
            let result = g.model.complete(req);
            let model = g.model.model().to_owned();
            let priced = |r: &ChatReply| r.usage.and_then(|u| g.prices.cost(&model, u));
            let cost_usd = result.as_ref().ok().and_then(priced);
            let (usage, latency) = match &result {
                Ok(r) => (r.usage, r.latency_ms),
                Err(_) => (None, 0.0),
            };
            let failed = result.is_err();
            cost.total.add_call(usage, latency, cost_usd, failed);
            cost.by_stage.entry(req.stage).or_default().add_call(usage, latency, cost_usd, failed);
            let inner = &mut *g;
            if inner.recorder.is_some() || inner.observer.is_some() {
                let record = |messages, schema_file| CallRecord {
                    seq: 0,
                    episode: meta.episode,
                    seed: meta.seed,
                    team: meta.team,
                    step: meta.step,
                    decision: meta.decision,
                    stage: req.stage,
                    attempt: meta.attempt,
                    retry: attempt,
                    model: model.clone(),
                    prompts: prompts.to_owned(),
                    request_hash: hash.clone(),
                    messages,
                    schema: req.schema.as_ref().map(|s| s.0.clone()),
                    schema_file,
                    sampling: req.sampling,
                    reply: result.as_ref().ok().cloned(),
                    error: result.as_ref().err().cloned(),
                    cost_usd,
                };
                let record = match inner.recorder.as_mut() {
                    Some(rec) => {
                        match rec.store(req).and_then(|m| Ok((m, rec.store_schema(req)?))).and_then(|(m, s)| rec.write(record(m, s))) {
                            Ok(r) => Some(r),
                            Err(e) => {
                                inner.fatal.get_or_insert_with(|| format!("recording: {e}"));
                                None
                            }
                        }
                    }
                    None => Some(record(crate::llm::unstored(req), None)),
                };
                if let (Some(r), Some(observe)) = (record, inner.observer.as_mut()) {
                    observe(&r, req);
                }
            }
            match result {
                Ok(r) => return Ok(r),
                Err(e) if e.retryable() && attempt < max_retries => {
                    if inner.model.waits() {
                        let pause = backoff_ms.saturating_mul(1 << attempt.min(16));
                        std::thread::sleep(std::time::Duration::from_millis(pause));
                    }
                    attempt += 1;
                }
                Err(e) => {
                    if matches!(e, LlmError::Replay { .. }) {
                        inner.fatal.get_or_insert_with(|| e.to_string());
                    }
                    return Err(e);
                }
            }
        }
    }
}
