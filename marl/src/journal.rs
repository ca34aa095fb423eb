//! The Q-learners' replay buffer kept on disk episode by episode (`resume/buffer/`), so that a
//! resumed run samples from the very buffer the uninterrupted run would have. Each finished
//! episode is appended once, as it goes into the buffer, instead of the whole buffer (up to
//! gigabytes) being written at every test round; segments of [`SEGMENT`] episodes that have
//! left the buffer are deleted at test rounds. A resume reads back the episodes the buffer
//! held at the state's test round and drops any written after it.
//!
//! An episode is kept as where it was played (its environment and that environment's episode
//! number) and team 1's actions, a byte or two per agent a step, with a digest of the whole
//! episode: the game is deterministic, so a resume plays it again
//! ([`avacraft_engine::Replayer`]) and checks the digest. The buffer of a long run on a large
//! map (gigabytes in memory) keeps in megabytes, small enough to carry a run between
//! machines. Journals written before kept whole episodes; those are still read.
//!
//! Image observations are not journaled: a run in an image mode resumes with a refilled
//! buffer, as before.

use crate::buffer::ReplayBuffer;
use crate::{Episode, Error};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// Episodes per segment file.
const SEGMENT: u64 = 64;
/// The run's episode count when the buffer started (0, or where a resume started a new one):
/// the ring's slots count from it.
const ORIGIN_FILE: &str = "origin";
/// The first bytes of a whole episode's record (journals written before actions-only ones).
const MAGIC: u32 = 0x4a45_5031;
/// The first bytes of an episode kept as its actions.
const MAGIC_PLAYED: u32 = 0x4a45_5032;

/// An episode kept as where it was played and team 1's actions: what
/// [`avacraft_engine::Replayer::replay`] needs to give it back.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Played {
    /// The environment (lane) of the run's vector environment it was played in.
    pub(crate) lane: usize,
    /// That environment's episode number ([`avacraft_engine::VecEnv::episode_numbers`]).
    pub(crate) episode: u64,
    /// Steps.
    pub(crate) len: usize,
    /// `len x A` SMAC indices.
    pub(crate) actions: Vec<u32>,
    /// [`digest`] of the episode as it was played.
    pub(crate) digest: u64,
}

/// An episode record of a segment: whole, or as it was played.
#[derive(Clone, Debug)]
enum Record {
    Whole(Episode),
    Played(Played),
}

/// What gives a played episode back: the run's environments replaying it.
pub(crate) type Rebuild<'a> = dyn Fn(&Played) -> Result<Episode, Error> + 'a;

/// A hash of everything an episode holds but its frames: a replayed episode is checked
/// against the one that was played.
pub(crate) fn digest(ep: &Episode) -> u64 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    let mut bytes = Vec::new();
    h.update(&(ep.len as u64).to_le_bytes());
    for v in [&ep.obs, &ep.state, &ep.reward, &ep.terminated] {
        bytes.clear();
        bytes.extend(v.iter().flat_map(|x| x.to_le_bytes()));
        h.update(&(v.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    h.update(&(ep.avail.len() as u64).to_le_bytes());
    h.update(&ep.avail);
    bytes.clear();
    bytes.extend(ep.actions.iter().flat_map(|x| x.to_le_bytes()));
    h.update(&bytes);
    h.digest()
}

pub(crate) struct Journal {
    dir: PathBuf,
    capacity: u64,
    /// Episodes appended so far (over the whole run).
    written: u64,
    file: Option<BufWriter<std::fs::File>>,
    /// Episodes written at the previous [`Journal::sync`]: the state saved then may still be
    /// the one a resume starts from (a kill before the next state is saved), so segments it
    /// needs stay.
    synced: u64,
    /// Episodes before this one are not written (a journal started mid-run starts at a
    /// segment's first episode, so each segment holds whole runs of episodes).
    skip_until: u64,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io { path: path.to_path_buf(), source }
}

fn segment_path(dir: &Path, first: u64) -> PathBuf {
    dir.join(format!("seg-{first:012}.bin"))
}

impl Journal {
    /// A new, empty journal in `run/resume/buffer` (a previous one is removed).
    pub(crate) fn create(run: &Path, capacity: usize) -> Result<Journal, Error> {
        let dir = run.join("resume").join("buffer");
        if dir.exists() {
            std::fs::remove_dir_all(&dir).map_err(io(&dir))?;
        }
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let j = Journal { dir, capacity: capacity.max(1) as u64, written: 0, file: None, synced: 0, skip_until: 0 };
        j.write_origin(0)?;
        Ok(j)
    }

    fn write_origin(&self, origin: u64) -> Result<(), Error> {
        crate::aside::write(&self.dir.join(ORIGIN_FILE), origin.to_string())
    }

    /// Where the buffer the journal keeps started (0 for journals written before it was kept,
    /// which started with their runs).
    fn read_origin(dir: &Path) -> Result<u64, Error> {
        let path = dir.join(ORIGIN_FILE);
        match std::fs::read_to_string(&path) {
            Ok(text) => text
                .trim()
                .parse()
                .map_err(|_| Error::Checkpoint { message: format!("{}: `{}` is not an episode count", path.display(), text.trim()) }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(0),
            Err(source) => Err(Error::Io { path, source }),
        }
    }

    /// A new, empty journal whose next episode is the run's `inserted`-th: a run resumed
    /// without a journal (saved before journals) keeps one from there on.
    pub(crate) fn create_at(run: &Path, capacity: usize, inserted: u64) -> Result<Journal, Error> {
        let mut j = Journal::create(run, capacity)?;
        (j.written, j.synced) = (inserted, inserted);
        j.skip_until = inserted.div_ceil(SEGMENT) * SEGMENT;
        j.write_origin(inserted)?;
        Ok(j)
    }

    /// The buffer as it was after `inserted` episodes, and the journal going on from there;
    /// `None` if the journal does not hold those episodes (a run saved before journals).
    /// Episodes kept as played are given back by `rebuild`, and each is checked against its
    /// digest: one that plays otherwise than it did (another build of the game) is an error
    /// naming the folder to delete to go on with a fresh buffer.
    pub(crate) fn resume(
        run: &Path,
        capacity: usize,
        inserted: u64,
        rebuild: &Rebuild<'_>,
    ) -> Result<Option<(Journal, ReplayBuffer)>, Error> {
        let dir = run.join("resume").join("buffer");
        let capacity = capacity.max(1) as u64;
        let from = inserted.saturating_sub(capacity);
        let mut kept: Vec<(u64, Record)> = Vec::new();
        let mut first = from / SEGMENT * SEGMENT;
        while first < inserted {
            let path = segment_path(&dir, first);
            if !path.is_file() {
                return Ok(None);
            }
            let (records, cut) = read_segment(&path)?;
            // The segment holding episode `inserted` may hold later ones, the last perhaps
            // cut short by a kill: kept on disk only up to it.
            let upto = (inserted - first).min(SEGMENT) as usize;
            if records.len() < upto {
                // Written and flushed before the state was saved: cut or damaged since.
                return Err(Error::Checkpoint {
                    message: format!(
                        "{}: {} whole episode records where the run's state needs {upto}: cut short or damaged \
                         (delete {} to go on with a fresh replay buffer)",
                        path.display(),
                        records.len(),
                        dir.display()
                    ),
                });
            }
            if records.len() > upto || cut {
                rewrite_segment(&path, &records[..upto])?;
            }
            for (k, rec) in records.into_iter().take(upto).enumerate() {
                let idx = first + k as u64;
                if idx >= from {
                    kept.push((idx, rec));
                }
            }
            first += SEGMENT;
        }
        // Later segments were written after the state: gone.
        for e in std::fs::read_dir(&dir).map_err(io(&dir))?.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if let Some(n) = name.strip_prefix("seg-").and_then(|n| n.strip_suffix(".bin")).and_then(|n| n.parse::<u64>().ok())
                && n >= first
            {
                std::fs::remove_file(e.path()).map_err(io(&e.path()))?;
            }
        }
        let kept = rebuilt(&dir, kept, rebuild)?;
        let origin = Journal::read_origin(&dir)?;
        if origin > inserted {
            return Err(Error::Checkpoint {
                message: format!("{}: the buffer starts at episode {origin}, after the state's {inserted}", dir.display()),
            });
        }
        let buffer = ReplayBuffer::restored(capacity as usize, kept, (origin, inserted));
        let file =
            if inserted.is_multiple_of(SEGMENT) { None } else { Some(open_append(&segment_path(&dir, inserted / SEGMENT * SEGMENT))?) };
        Ok(Some((Journal { dir, capacity, written: inserted, file, synced: inserted, skip_until: 0 }, buffer)))
    }

    /// Appends a finished episode (the one the buffer just took), played in environment
    /// `lane` as that environment's episode number `episode`: kept as its actions, with its
    /// digest.
    pub(crate) fn append(&mut self, ep: &Episode, lane: usize, episode: u64) -> Result<(), Error> {
        if self.written < self.skip_until {
            self.written += 1;
            return Ok(());
        }
        if self.written.is_multiple_of(SEGMENT) || self.file.is_none() {
            self.flush()?;
            let path = segment_path(&self.dir, self.written / SEGMENT * SEGMENT);
            self.file = Some(open_append(&path)?);
        }
        let path = segment_path(&self.dir, self.written / SEGMENT * SEGMENT);
        let played = Played { lane, episode, len: ep.len, actions: ep.actions.clone(), digest: digest(ep) };
        if let Some(f) = &mut self.file {
            write_played(f, &played).map_err(io(&path))?;
        }
        self.written += 1;
        Ok(())
    }

    /// At a test round, before the state is saved: everything appended is on disk, and the
    /// segments that had left the buffer by the previous test round are deleted.
    pub(crate) fn sync(&mut self) -> Result<(), Error> {
        self.flush()?;
        let oldest = self.synced.min(self.written).saturating_sub(self.capacity);
        self.synced = self.written;
        let mut first = 0;
        while first + SEGMENT <= oldest {
            let p = segment_path(&self.dir, first);
            if p.is_file() {
                std::fs::remove_file(&p).map_err(io(&p))?;
            }
            first += SEGMENT;
        }
        Ok(())
    }

    /// Deletes the journal: a finished run keeps no buffer on disk (a buffer holds up to
    /// gigabytes); a run extended past its end refills its buffer.
    pub(crate) fn remove(self) -> Result<(), Error> {
        drop(self.file);
        std::fs::remove_dir_all(&self.dir).map_err(io(&self.dir))
    }

    fn flush(&mut self) -> Result<(), Error> {
        if let Some(f) = &mut self.file {
            f.flush().map_err(io(&self.dir))?;
            f.get_ref().sync_data().map_err(io(&self.dir))?;
        }
        Ok(())
    }
}

fn open_append(path: &Path) -> Result<BufWriter<std::fs::File>, Error> {
    let f = std::fs::OpenOptions::new().create(true).append(true).open(path).map_err(io(path))?;
    Ok(BufWriter::new(f))
}

/// The kept records as episodes, the played ones replayed and checked against their digests.
fn rebuilt(dir: &Path, kept: Vec<(u64, Record)>, rebuild: &Rebuild<'_>) -> Result<Vec<(u64, Episode)>, Error> {
    kept.into_iter()
        .map(|(idx, rec)| {
            let p = match rec {
                Record::Whole(ep) => return Ok((idx, ep)),
                Record::Played(p) => p,
            };
            let ep = rebuild(&p)?;
            if digest(&ep) != p.digest {
                return Err(Error::Checkpoint {
                    message: format!(
                        "{}: episode {idx} of the run (environment {}, its episode {}) plays otherwise than when it was \
                         kept (another build of the game, or changed files): delete that folder to go on with a fresh \
                         replay buffer",
                        dir.display(),
                        p.lane,
                        p.episode
                    ),
                });
            }
            Ok((idx, ep))
        })
        .collect()
}

fn rewrite_segment(path: &Path, records: &[Record]) -> Result<(), Error> {
    let tmp = path.with_extension("bin.tmp");
    let mut f = BufWriter::new(std::fs::File::create(&tmp).map_err(io(&tmp))?);
    for rec in records {
        match rec {
            Record::Whole(ep) => write_episode(&mut f, ep),
            Record::Played(p) => write_played(&mut f, p),
        }
        .map_err(io(&tmp))?;
    }
    f.flush().map_err(io(&tmp))?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io(path))
}

fn write_episode(w: &mut impl Write, ep: &Episode) -> std::io::Result<()> {
    w.write_all(&MAGIC.to_le_bytes())?;
    w.write_all(&(ep.len as u64).to_le_bytes())?;
    let put_len = |w: &mut dyn Write, n: usize| w.write_all(&(n as u64).to_le_bytes());
    for v in [&ep.obs, &ep.state, &ep.reward, &ep.terminated] {
        put_len(w, v.len())?;
        for x in v.iter() {
            w.write_all(&x.to_le_bytes())?;
        }
    }
    put_len(w, ep.avail.len())?;
    w.write_all(&ep.avail)?;
    put_len(w, ep.actions.len())?;
    for x in &ep.actions {
        w.write_all(&x.to_le_bytes())?;
    }
    Ok(())
}

/// Bytes per action: the fewest that hold every index.
fn width(actions: &[u32]) -> u8 {
    match actions.iter().copied().max().unwrap_or(0) {
        0..=0xff => 1,
        0x100..=0xffff => 2,
        _ => 4,
    }
}

fn write_played(w: &mut impl Write, p: &Played) -> std::io::Result<()> {
    w.write_all(&MAGIC_PLAYED.to_le_bytes())?;
    w.write_all(&(p.lane as u64).to_le_bytes())?;
    w.write_all(&p.episode.to_le_bytes())?;
    w.write_all(&(p.len as u64).to_le_bytes())?;
    let wd = width(&p.actions);
    w.write_all(&[wd])?;
    w.write_all(&(p.actions.len() as u64).to_le_bytes())?;
    for &x in &p.actions {
        w.write_all(&x.to_le_bytes()[..wd as usize])?;
    }
    w.write_all(&p.digest.to_le_bytes())
}

/// Reads every whole record of a segment, and whether a record cut short (a kill mid-write)
/// ends it.
fn read_segment(path: &Path) -> Result<(Vec<Record>, bool), Error> {
    let mut bytes = Vec::new();
    std::fs::File::open(path).and_then(|mut f| f.read_to_end(&mut bytes)).map_err(io(path))?;
    let mut r = Reader { bytes: &bytes, at: 0 };
    let mut records = Vec::new();
    let mut cut = false;
    while r.at < bytes.len() {
        let start = r.at;
        match r.record() {
            Some(rec) => records.push(rec),
            None if start == r.at || r.at >= bytes.len() => {
                cut = true;
                break;
            }
            None => {
                return Err(Error::Checkpoint {
                    message: format!("{}: episode record {} at byte {start} is corrupt", path.display(), records.len()),
                });
            }
        }
    }
    Ok((records, cut))
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        let end = self.at.checked_add(n)?;
        let s = self.bytes.get(self.at..end);
        self.at = if s.is_some() { end } else { self.bytes.len() };
        s
    }
    fn u64(&mut self) -> Option<u64> {
        self.take(8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
    }
    fn count(&mut self, item: usize) -> Option<usize> {
        let n = usize::try_from(self.u64()?).ok()?;
        // A count past the bytes left is a record cut short (a kill mid-write: the reader is
        // at the end, as a short read leaves it), not an allocation.
        match n.checked_mul(item) {
            Some(b) if b <= self.bytes.len() - self.at => Some(n),
            _ => {
                self.at = self.bytes.len();
                None
            }
        }
    }
    fn f32s(&mut self) -> Option<Vec<f32>> {
        let n = self.count(4)?;
        Some(self.take(n * 4)?.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }
    fn record(&mut self) -> Option<Record> {
        let magic = u32::from_le_bytes(self.take(4)?.try_into().ok()?);
        match magic {
            MAGIC => self.episode().map(Record::Whole),
            MAGIC_PLAYED => self.played().map(Record::Played),
            _ => None,
        }
    }
    fn episode(&mut self) -> Option<Episode> {
        let len = usize::try_from(self.u64()?).ok()?;
        let (obs, state, reward, terminated) = (self.f32s()?, self.f32s()?, self.f32s()?, self.f32s()?);
        let n = self.count(1)?;
        let avail = self.take(n)?.to_vec();
        let n = self.count(4)?;
        let actions = self.take(n * 4)?.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        Some(Episode { len, obs, state, avail, actions, reward, terminated, frames: Default::default() })
    }
    fn played(&mut self) -> Option<Played> {
        let lane = usize::try_from(self.u64()?).ok()?;
        let episode = self.u64()?;
        let len = usize::try_from(self.u64()?).ok()?;
        let wd = *self.take(1)?.first()? as usize;
        if ![1, 2, 4].contains(&wd) {
            return None;
        }
        let n = self.count(wd)?;
        let actions = self
            .take(n * wd)?
            .chunks_exact(wd)
            .map(|c| {
                let mut b = [0u8; 4];
                b[..wd].copy_from_slice(c);
                u32::from_le_bytes(b)
            })
            .collect();
        let digest = self.u64()?;
        Some(Played { lane, episode, len, actions, digest })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn episode(k: u64) -> Episode {
        let len = (k % 5) as usize + 1;
        Episode {
            len,
            obs: (0..len * 3).map(|i| i as f32 + k as f32).collect(),
            state: vec![k as f32; len + 1],
            avail: vec![1; len * 2],
            actions: (0..len as u32).collect(),
            reward: vec![0.5; len],
            terminated: vec![0.0; len],
            frames: Default::default(),
        }
    }

    /// Gives back the episodes [`episode`] makes, numbered as they were kept (here: each
    /// one's number as its "episode").
    fn replay(p: &Played) -> Result<Episode, Error> {
        Ok(episode(p.episode))
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("avacraft-journal-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_resumed_journal_gives_back_the_buffer_and_forgets_later_episodes() -> Result<(), Error> {
        let run = scratch("resume");
        let cap = 100;
        let mut j = Journal::create(&run, cap)?;
        let mut buf = ReplayBuffer::new(cap);
        for k in 0..250 {
            j.append(&episode(k), 0, k)?;
            buf.insert(episode(k));
            if k == 180 {
                j.sync()?;
            }
        }
        j.sync()?;
        // Segments that had left the buffer at the previous sync (181 - 100) are gone.
        assert!(!segment_path(&run.join("resume/buffer"), 0).exists());
        assert!(segment_path(&run.join("resume/buffer"), 64).exists());
        let (mut j2, back) = Journal::resume(&run, cap, 250, &replay)?.expect("all kept");
        assert_eq!(back, buf);
        // Resumed at the previous sync's state (a kill after the last sync, before its state
        // was saved): that state's buffer, and the later episodes are dropped from disk.
        let (_, earlier) = Journal::resume(&run, cap, 181, &replay)?.expect("kept");
        let mut want = ReplayBuffer::new(cap);
        (0..181).for_each(|k| want.insert(episode(k)));
        assert_eq!(earlier, want);
        // The journal goes on from there.
        let (mut j3, _) = Journal::resume(&run, cap, 181, &replay)?.expect("kept");
        for k in 181..230 {
            j3.append(&episode(k), 0, k)?;
            want.insert(episode(k));
        }
        j3.sync()?;
        let (_, again) = Journal::resume(&run, cap, 230, &replay)?.expect("kept");
        assert_eq!(again, want);
        // Episodes the journal never held: none to resume from.
        assert!(Journal::resume(&run, cap, 400, &replay)?.is_none());
        j2.sync()?;
        let _ = std::fs::remove_dir_all(&run);
        Ok(())
    }

    #[test]
    fn an_episode_kept_as_played_is_a_few_bytes_a_step() -> Result<(), Error> {
        let ep = Episode { len: 100, actions: vec![35; 100 * 27], ..episode(0) };
        let p = Played { lane: 3, episode: 41, len: 100, actions: ep.actions.clone(), digest: digest(&ep) };
        let mut bytes = Vec::new();
        write_played(&mut bytes, &p).map_err(|source| Error::Io { path: PathBuf::new(), source })?;
        // One byte an action, and 45 for the rest of the record.
        assert_eq!(bytes.len(), 2700 + 45);
        let back = Reader { bytes: &bytes, at: 0 }.record();
        assert!(matches!(back, Some(Record::Played(q)) if q == p));
        // Wider indices take more bytes, and come back whole.
        let wide = Played { actions: vec![0, 300, 70_000], len: 1, ..p };
        let mut bytes = Vec::new();
        write_played(&mut bytes, &wide).map_err(|source| Error::Io { path: PathBuf::new(), source })?;
        assert!(matches!(Reader { bytes: &bytes, at: 0 }.record(), Some(Record::Played(q)) if q == wide));
        Ok(())
    }

    #[test]
    fn an_episode_that_plays_otherwise_is_refused_naming_the_folder() -> Result<(), Error> {
        let run = scratch("otherwise");
        let mut j = Journal::create(&run, 10)?;
        for k in 0..5 {
            j.append(&episode(k), 1, k)?;
        }
        j.sync()?;
        // Another build of the game: the third episode comes back changed.
        let changed = |p: &Played| -> Result<Episode, Error> {
            let mut ep = replay(p)?;
            if p.episode == 2 {
                ep.reward[0] = 1.0;
            }
            Ok(ep)
        };
        let Err(e) = Journal::resume(&run, 10, 5, &changed) else { panic!("a changed episode was taken") };
        let msg = e.to_string();
        assert!(msg.contains("resume/buffer") && msg.contains("episode 2 ") && msg.contains("delete"), "{msg}");
        let _ = std::fs::remove_dir_all(&run);
        Ok(())
    }

    #[test]
    fn a_journal_of_whole_episodes_is_still_read_and_goes_on_as_played() -> Result<(), Error> {
        let run = scratch("whole");
        let dir = run.join("resume/buffer");
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let whole: Vec<Record> = (0..7).map(|k| Record::Whole(episode(k))).collect();
        rewrite_segment(&segment_path(&dir, 0), &whole)?;
        let (mut j, buf) = Journal::resume(&run, 100, 7, &replay)?.expect("kept");
        let mut want = ReplayBuffer::new(100);
        (0..7).for_each(|k| want.insert(episode(k)));
        assert_eq!(buf, want);
        for k in 7..12 {
            j.append(&episode(k), 0, k)?;
            want.insert(episode(k));
        }
        j.sync()?;
        let (_, again) = Journal::resume(&run, 100, 12, &replay)?.expect("kept");
        assert_eq!(again, want);
        let _ = std::fs::remove_dir_all(&run);
        Ok(())
    }

    #[test]
    fn a_segment_cut_anywhere_in_its_last_record_reads_the_records_before_it() -> Result<(), Error> {
        let dir = scratch("cut");
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let path = dir.join("seg.bin");
        let played = |k: u64| {
            let ep = episode(k);
            Played { lane: 0, episode: k, len: ep.len, actions: ep.actions.clone(), digest: digest(&ep) }
        };
        for last in [Record::Whole(episode(9)), Record::Played(played(9))] {
            let records = [Record::Whole(episode(7)), Record::Played(played(8)), last];
            rewrite_segment(&path, &records)?;
            let bytes = std::fs::read(&path).map_err(io(&path))?;
            rewrite_segment(&path, &records[..2])?;
            let whole = std::fs::metadata(&path).map_err(io(&path))?.len() as usize;
            for cut in whole..bytes.len() {
                std::fs::write(&path, &bytes[..cut]).map_err(io(&path))?;
                let (back, was_cut) = read_segment(&path).map_err(|e| Error::Checkpoint { message: format!("cut at {cut}: {e}") })?;
                assert_eq!((back.len(), was_cut), (2, cut > whole), "cut at {cut} of {}", bytes.len());
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
        #[test]
        fn torn_or_garbled_segments_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), cut in 0usize..400) {
            let dir = scratch(&format!("fuzz-{cut}"));
            std::fs::create_dir_all(&dir).expect("dir");
            let path = dir.join("seg.bin");
            let mut good = Vec::new();
            write_episode(&mut good, &episode(3)).expect("write");
            let ep = episode(4);
            write_played(&mut good, &Played { lane: 1, episode: 4, len: ep.len, actions: ep.actions.clone(), digest: digest(&ep) }).expect("write");
            good.truncate(cut.min(good.len()));
            good.extend(&bytes);
            std::fs::write(&path, &good).expect("write");
            let _ = read_segment(&path);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
}
