//! Files a run keeps (checkpoints, resume state) are written aside and renamed into place, so
//! a process killed mid-write (a user's Ctrl-C, a second `--resume` killing the first, a
//! machine going down) leaves each file whole: the old one or the new one, never an empty
//! `config.json` that makes the run unreadable.

use crate::Error;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Where `path` is written before it is renamed over: beside it, so the rename stays on one
/// file system.
pub(crate) fn aside(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(std::ffi::OsStr::to_os_string).unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

fn renamed(tmp: &Path, path: &Path) -> Result<(), Error> {
    std::fs::rename(tmp, path).map_err(|source| Error::Io { path: path.to_path_buf(), source })
}

/// Writes `bytes` to `path` whole or not at all.
pub(crate) fn write(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), Error> {
    let tmp = aside(path);
    std::fs::write(&tmp, bytes).map_err(|source| Error::Io { path: tmp.clone(), source })?;
    renamed(&tmp, path)
}

/// [`write`] for the other crates' files a user would lose to a torn write (an evaluation's
/// plan, a run's summary): the error names the file.
pub fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> std::io::Result<()> {
    write(path, bytes).map_err(|e| match e {
        Error::Io { source, .. } => source,
        other => std::io::Error::other(other),
    })
}

/// Whether `path` is a file left aside by a write that was killed before its rename.
pub fn is_aside(path: &Path) -> bool {
    path.extension().is_some_and(|x| x == "tmp")
}

/// Saves named tensors to the safetensors file `path` whole or not at all.
pub(crate) fn tensors(map: &HashMap<String, candle_core::Tensor>, path: &Path) -> Result<(), Error> {
    let tmp = aside(path);
    candle_core::safetensors::save(map, &tmp)?;
    renamed(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_that_fails_leaves_the_old_file_whole() {
        let d = std::env::temp_dir().join(format!("avacraft-aside-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("temp dir");
        let path = d.join("config.json");
        write(&path, "{\"old\": 1}").expect("first write");
        assert_eq!(std::fs::read_to_string(&path).expect("read"), "{\"old\": 1}");
        assert!(!aside(&path).exists(), "nothing left aside after a write");
        // Block the aside file with a directory: the write fails, naming where, and the
        // file it would have replaced is untouched (a plain fs::write would have emptied it
        // first, as a kill does).
        std::fs::create_dir_all(aside(&path)).expect("block");
        let e = write(&path, "{\"new\": 2}").expect_err("the aside file cannot be written");
        assert!(e.to_string().contains("config.json.tmp"), "{e}");
        assert_eq!(std::fs::read_to_string(&path).expect("read"), "{\"old\": 1}");

        let t = d.join("agent.safetensors");
        let mut map = HashMap::new();
        map.insert("w".to_owned(), candle_core::Tensor::new(&[1f32, 2.0], &candle_core::Device::Cpu).expect("tensor"));
        tensors(&map, &t).expect("save");
        let back = candle_core::safetensors::load(&t, &candle_core::Device::Cpu).expect("load");
        assert_eq!(back["w"].to_vec1::<f32>().expect("vec"), vec![1.0, 2.0]);
        std::fs::create_dir_all(aside(&t)).expect("block");
        map.insert("w".to_owned(), candle_core::Tensor::new(&[3f32], &candle_core::Device::Cpu).expect("tensor"));
        assert!(tensors(&map, &t).is_err());
        let back = candle_core::safetensors::load(&t, &candle_core::Device::Cpu).expect("load");
        assert_eq!(back["w"].to_vec1::<f32>().expect("vec"), vec![1.0, 2.0], "the old weights stay");
        let _ = std::fs::remove_dir_all(&d);
    }
}
