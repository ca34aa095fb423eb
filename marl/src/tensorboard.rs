//! TensorBoard event files beside `log.csv`, so a run's curves open in TensorBoard (or any
//! reader of its format: tbparse, W&B's sync) next to other RL code's.
//!
//! An event file is a TFRecord stream of `tensorflow.Event` protobufs: the first names the
//! format version, each later one carries a step and scalar summaries. Only the few fields
//! scalars need are declared here (prost encodes them); their field numbers are TensorFlow's
//! (`event.proto`, `summary.proto`), which is all a reader checks. Each record is framed by
//! its length and two masked CRC-32C checksums, which readers verify.
//!
//! A resumed run opens a new file in the same folder: TensorBoard reads every event file of
//! a folder as one run, ordered by step.

use crate::Error;
use prost::Message;
use std::io::Write;
use std::path::{Path, PathBuf};

/// `tensorflow.Event`, the fields a scalar log uses.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Event {
    #[prost(double, tag = "1")]
    pub wall_time: f64,
    #[prost(int64, tag = "2")]
    pub step: i64,
    #[prost(string, optional, tag = "3")]
    pub file_version: Option<String>,
    #[prost(message, optional, tag = "5")]
    pub summary: Option<Summary>,
}

/// `tensorflow.Summary`.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Summary {
    #[prost(message, repeated, tag = "1")]
    pub value: Vec<SummaryValue>,
}

/// `tensorflow.Summary.Value` holding a `simple_value`.
#[derive(Clone, PartialEq, prost::Message)]
pub struct SummaryValue {
    #[prost(string, tag = "1")]
    pub tag: String,
    #[prost(float, optional, tag = "2")]
    pub simple_value: Option<f32>,
}

/// The version string TensorBoard expects in a file's first event.
pub const FILE_VERSION: &str = "brain.Event:2";

fn masked_crc(bytes: &[u8]) -> u32 {
    let c = crc32c::crc32c(bytes);
    c.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// One TFRecord: length, its checksum, the data, the data's checksum.
pub fn frame(data: &[u8]) -> Vec<u8> {
    let len = (data.len() as u64).to_le_bytes();
    let mut out = Vec::with_capacity(data.len() + 16);
    out.extend_from_slice(&len);
    out.extend_from_slice(&masked_crc(&len).to_le_bytes());
    out.extend_from_slice(data);
    out.extend_from_slice(&masked_crc(data).to_le_bytes());
    out
}

/// Why a byte stream is not a sequence of TFRecords.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RecordError {
    #[error("record at byte {at}: truncated ({needed} bytes needed, {left} left)")]
    Truncated { at: usize, needed: usize, left: usize },
    #[error("record at byte {at}: the {what} checksum does not match")]
    Checksum { at: usize, what: &'static str },
    #[error("record at byte {at}: not an Event: {message}")]
    Decode { at: usize, message: String },
}

/// Splits a TFRecord stream into its events, checking every checksum (the tests read the
/// files back with it; TensorBoard's own reader is checked in `marl/tests/it`).
pub fn read_events(bytes: &[u8]) -> Result<Vec<Event>, RecordError> {
    let mut out = Vec::new();
    let mut at = 0;
    while at < bytes.len() {
        let left = bytes.len() - at;
        if left < 12 {
            return Err(RecordError::Truncated { at, needed: 12, left });
        }
        let len_bytes = &bytes[at..at + 8];
        let crc = u32::from_le_bytes([bytes[at + 8], bytes[at + 9], bytes[at + 10], bytes[at + 11]]);
        if masked_crc(len_bytes) != crc {
            return Err(RecordError::Checksum { at, what: "length" });
        }
        let mut l = [0u8; 8];
        l.copy_from_slice(len_bytes);
        let len = u64::from_le_bytes(l);
        let needed = usize::try_from(len).ok().and_then(|n| n.checked_add(16)).unwrap_or(usize::MAX);
        if needed > left {
            return Err(RecordError::Truncated { at, needed, left });
        }
        let data = &bytes[at + 12..at + needed - 4];
        let t = at + needed - 4;
        let crc = u32::from_le_bytes([bytes[t], bytes[t + 1], bytes[t + 2], bytes[t + 3]]);
        if masked_crc(data) != crc {
            return Err(RecordError::Checksum { at, what: "data" });
        }
        out.push(Event::decode(data).map_err(|e| RecordError::Decode { at, message: e.to_string() })?);
        at += needed;
    }
    Ok(out)
}

/// Appends scalar events to one event file of a run's folder.
#[derive(Debug)]
pub struct EventWriter {
    file: std::fs::File,
    path: PathBuf,
}

impl EventWriter {
    /// A new event file in `dir`, named as TensorBoard's writers name theirs (the wall time
    /// and the process make it unique, so a resumed run's file sits beside the first one).
    pub fn create(dir: &Path) -> Result<EventWriter, Error> {
        let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let path = dir.join(format!("events.out.tfevents.{}.avacraft.{}", now.as_secs(), std::process::id()));
        let file = std::fs::File::create(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
        let mut w = EventWriter { file, path };
        let first = Event { wall_time: now.as_secs_f64(), step: 0, file_version: Some(FILE_VERSION.into()), summary: None };
        w.write(&first)?;
        Ok(w)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write(&mut self, e: &Event) -> Result<(), Error> {
        let bytes = frame(&e.encode_to_vec());
        self.file.write_all(&bytes).and_then(|()| self.file.flush()).map_err(|source| Error::Io { path: self.path.clone(), source })
    }

    /// One event at `step` holding every finite scalar of `scalars` (tags as given; `NaN`
    /// marks a value this algorithm does not have, and is left out).
    pub fn scalars(&mut self, step: u64, scalars: &[(String, f64)]) -> Result<(), Error> {
        let value: Vec<SummaryValue> = scalars
            .iter()
            .filter(|(_, v)| v.is_finite())
            .map(|(tag, v)| SummaryValue { tag: tag.clone(), simple_value: Some(*v as f32) })
            .collect();
        let wall_time = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_secs_f64();
        let step = i64::try_from(step).unwrap_or(i64::MAX);
        self.write(&Event { wall_time, step, file_version: None, summary: Some(Summary { value }) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn crc32c_matches_the_known_vector() {
        // RFC 3720's check value for "123456789".
        assert_eq!(crc32c::crc32c(b"123456789"), 0xe306_9283);
    }

    #[test]
    fn a_written_file_reads_back() -> Result<(), Box<dyn std::error::Error>> {
        let dir = std::env::temp_dir().join(format!("avacraft-tb-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let mut w = EventWriter::create(&dir)?;
        w.scalars(10, &[("a/b".into(), 0.5), ("skipped".into(), f64::NAN)])?;
        w.scalars(20, &[("a/b".into(), 0.75)])?;
        let events = read_events(&std::fs::read(w.path())?)?;
        assert_eq!(events.len(), 3);
        assert_eq!(events[0].file_version.as_deref(), Some(FILE_VERSION));
        let s = events[1].summary.as_ref().ok_or("no summary")?;
        assert_eq!((events[1].step, s.value.len(), s.value[0].tag.as_str(), s.value[0].simple_value), (10, 1, "a/b", Some(0.5)));
        assert_eq!(events[2].step, 20);
        std::fs::remove_dir_all(&dir)?;
        Ok(())
    }

    proptest! {
        #[test]
        fn events_round_trip_and_damage_is_caught(steps in proptest::collection::vec(0i64..1 << 40, 1..6), v in -1e6f32..1e6, flip in any::<prop::sample::Index>()) {
            let events: Vec<Event> = steps.iter().map(|&step| Event {
                wall_time: 1.5, step, file_version: None,
                summary: Some(Summary { value: vec![SummaryValue { tag: "x".into(), simple_value: Some(v) }] }),
            }).collect();
            let bytes: Vec<u8> = events.iter().flat_map(|e| frame(&e.encode_to_vec())).collect();
            prop_assert_eq!(read_events(&bytes), Ok(events));
            // Any one flipped byte is refused (a checksum, or the length, no longer fits).
            let mut bad = bytes.clone();
            let i = flip.index(bad.len());
            bad[i] ^= 0x20;
            prop_assert!(read_events(&bad).is_err());
            // A cut stream is refused, never read short.
            prop_assert!(read_events(&bytes[..bytes.len() - 1]).is_err());
        }
    }
}
