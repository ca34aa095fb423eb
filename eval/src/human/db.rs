//! The ratings database (SQLite). One row per rater and replay, enforced by a UNIQUE
//! constraint (not only by the page), ratings held to 1..5 by CHECK constraints. The journal
//! is WAL with `synchronous = FULL`, so a rating is on disk once its submit is answered, and
//! the schema is only ever created, never migrated destructively: a database of a newer
//! schema is refused rather than touched.

use super::{HumanError, MAX_COMMENT_CHARS, METRICS, check_rater};
use rusqlite::{Connection, OpenFlags, params};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

const SCHEMA_VERSION: i64 = 1;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS ratings (
    id           INTEGER PRIMARY KEY,
    rater        TEXT NOT NULL,
    replay       TEXT NOT NULL,
    exploitation INTEGER NOT NULL CHECK (exploitation BETWEEN 1 AND 5),
    coherence    INTEGER NOT NULL CHECK (coherence BETWEEN 1 AND 5),
    similarity   INTEGER NOT NULL CHECK (similarity BETWEEN 1 AND 5),
    comment      TEXT NOT NULL DEFAULT '',
    submitted_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    UNIQUE (rater, replay)
);";

/// One rating: the three scores in [`METRICS`] order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rating {
    pub rater: String,
    pub replay: String,
    pub exploitation: i64,
    pub coherence: i64,
    pub similarity: i64,
    #[serde(default)]
    pub comment: String,
}

impl Rating {
    /// The scores in [`METRICS`] order.
    pub fn scores(&self) -> [i64; 3] {
        [self.exploitation, self.coherence, self.similarity]
    }

    /// Checks the rater's name, the scores and the comment's length (the replay id is the
    /// caller's to check against its study).
    pub fn check(&self) -> Result<(), HumanError> {
        check_rater(&self.rater)?;
        for (m, v) in METRICS.iter().zip(self.scores()) {
            if !(1..=5).contains(&v) {
                return Err(HumanError::BadScore { metric: m.key, value: v });
            }
        }
        let chars = self.comment.chars().count();
        if chars > MAX_COMMENT_CHARS {
            return Err(HumanError::CommentTooLong { chars });
        }
        Ok(())
    }
}

/// An open ratings database.
#[derive(Debug)]
pub struct Db {
    path: PathBuf,
    conn: Connection,
}

impl Db {
    /// Opens the database, creating it (and its table) if needed.
    pub fn open(path: &Path) -> Result<Db, HumanError> {
        let conn = Connection::open(path).map_err(|source| HumanError::Db { path: path.to_path_buf(), source })?;
        let db = Db { path: path.to_path_buf(), conn };
        db.init()?;
        Ok(db)
    }

    /// Opens an existing database for reading (analysis while the server may be running).
    pub fn open_read_only(path: &Path) -> Result<Db, HumanError> {
        if !path.is_file() {
            return Err(HumanError::NoRatings { path: path.to_path_buf() });
        }
        let conn = Connection::open_with_flags(path, OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX)
            .map_err(|source| HumanError::Db { path: path.to_path_buf(), source })?;
        let db = Db { path: path.to_path_buf(), conn };
        db.check_version()?;
        Ok(db)
    }

    fn err(&self) -> impl FnOnce(rusqlite::Error) -> HumanError + '_ {
        |source| HumanError::Db { path: self.path.clone(), source }
    }

    fn check_version(&self) -> Result<i64, HumanError> {
        let v: i64 = self.conn.query_row("PRAGMA user_version", [], |r| r.get(0)).map_err(self.err())?;
        if v > SCHEMA_VERSION {
            return Err(HumanError::Schema { path: self.path.clone(), found: v, known: SCHEMA_VERSION });
        }
        Ok(v)
    }

    fn init(&self) -> Result<(), HumanError> {
        self.conn.busy_timeout(std::time::Duration::from_secs(5)).map_err(self.err())?;
        let _mode: String = self.conn.query_row("PRAGMA journal_mode = WAL", [], |r| r.get(0)).map_err(self.err())?;
        self.conn.execute_batch("PRAGMA synchronous = FULL;").map_err(self.err())?;
        if self.check_version()? < SCHEMA_VERSION {
            self.conn.execute_batch(&format!("BEGIN; {SCHEMA} PRAGMA user_version = {SCHEMA_VERSION}; COMMIT;")).map_err(self.err())?;
        }
        Ok(())
    }

    /// Stores a rating (checked first); a second rating of the same replay by the same rater
    /// is refused with [`HumanError::AlreadyRated`] and changes nothing.
    pub fn insert(&self, r: &Rating) -> Result<(), HumanError> {
        r.check()?;
        let res = self.conn.execute(
            "INSERT INTO ratings (rater, replay, exploitation, coherence, similarity, comment) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
            params![r.rater, r.replay, r.exploitation, r.coherence, r.similarity, r.comment],
        );
        match res {
            Ok(_) => Ok(()),
            Err(e) if e.sqlite_error().is_some_and(|f| f.extended_code == rusqlite::ffi::SQLITE_CONSTRAINT_UNIQUE) => {
                Err(HumanError::AlreadyRated { rater: r.rater.clone(), replay: r.replay.clone() })
            }
            Err(source) => Err(HumanError::Db { path: self.path.clone(), source }),
        }
    }

    /// The replays `rater` has rated.
    pub fn rated_by(&self, rater: &str) -> Result<Vec<String>, HumanError> {
        let mut st = self.conn.prepare("SELECT replay FROM ratings WHERE rater = ?1 ORDER BY id").map_err(self.err())?;
        let rows = st.query_map([rater], |r| r.get::<_, String>(0)).map_err(self.err())?;
        rows.collect::<Result<Vec<_>, _>>().map_err(self.err())
    }

    /// Every rating, in the order they came.
    pub fn all(&self) -> Result<Vec<Rating>, HumanError> {
        let mut st = self
            .conn
            .prepare("SELECT rater, replay, exploitation, coherence, similarity, comment FROM ratings ORDER BY id")
            .map_err(self.err())?;
        let rows = st
            .query_map([], |r| {
                Ok(Rating {
                    rater: r.get(0)?,
                    replay: r.get(1)?,
                    exploitation: r.get(2)?,
                    coherence: r.get(3)?,
                    similarity: r.get(4)?,
                    comment: r.get(5)?,
                })
            })
            .map_err(self.err())?;
        rows.collect::<Result<Vec<_>, _>>().map_err(self.err())
    }
}
