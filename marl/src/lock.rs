//! One process at a time in a run's folder. A second `avacraft train` on the same run (the
//! same plan started twice, a resume while the run still trains) would rewrite the replay
//! journal, the log and the checkpoint under the first one, which goes on writing to files
//! no longer there: what it trained would not resume. An advisory lock on `train.lock` in
//! the folder, held while the process trains there, refuses the second one by name.

use crate::Error;
use std::fs::{File, TryLockError};
use std::path::Path;

/// The lock file's name in a run's folder.
pub const LOCK_FILE: &str = "train.lock";

/// Held while a process trains into a run's folder; released when dropped (or when the
/// process ends, however it ends: the operating system drops the lock with the file).
#[derive(Debug)]
pub struct RunLock {
    _file: File,
}

impl RunLock {
    /// Takes the lock of `dir` (creating the folder), or says that another process holds it.
    pub fn acquire(dir: &Path) -> Result<RunLock, Error> {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
        let path = dir.join(LOCK_FILE);
        let file = File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|source| Error::Io { path: path.clone(), source })?;
        match file.try_lock() {
            Ok(()) => Ok(RunLock { _file: file }),
            Err(TryLockError::WouldBlock) => Err(Error::RunInUse { dir: dir.to_path_buf() }),
            Err(TryLockError::Error(source)) => Err(Error::Io { path, source }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_holder_is_refused_until_the_first_lets_go() -> Result<(), Error> {
        let dir = std::env::temp_dir().join(format!("avacraft-lock-{}", std::process::id()));
        let first = RunLock::acquire(&dir)?;
        let second = RunLock::acquire(&dir);
        assert!(matches!(&second, Err(Error::RunInUse { dir: d }) if *d == dir), "{second:?}");
        let shown = second.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(shown.contains(&dir.display().to_string()) && shown.contains("another process"), "{shown}");
        drop(first);
        let again = RunLock::acquire(&dir)?;
        drop(again);
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }
}
