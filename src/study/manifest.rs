//! `OUT/manifest.json`: which study the directory belongs to (its hash), the columns, and
//! the completed sample ranges. The part files are the ground truth: a run rebuilds the
//! ranges from them when it starts, so a crash between writing a part and updating the
//! manifest loses nothing. Updates from concurrent shards are serialised by a file lock.

use super::store::Columns;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

/// Sorted, disjoint, non-adjacent half-open ranges of sample ids.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Ranges(pub Vec<(u64, u64)>);

impl Ranges {
    /// The ranges covering `ids` (any order, duplicates allowed).
    pub fn from_ids(mut ids: Vec<u64>) -> Ranges {
        ids.sort_unstable();
        ids.dedup();
        let mut out: Vec<(u64, u64)> = Vec::new();
        for id in ids {
            match out.last_mut() {
                Some(last) if last.1 == id => last.1 += 1,
                _ => out.push((id, id + 1)),
            }
        }
        Ranges(out)
    }

    pub fn union(&self, other: &Ranges) -> Ranges {
        let mut all: Vec<(u64, u64)> = self.0.iter().chain(&other.0).copied().collect();
        all.sort_unstable();
        let mut out: Vec<(u64, u64)> = Vec::new();
        for (a, b) in all {
            match out.last_mut() {
                Some(last) if a <= last.1 => last.1 = last.1.max(b),
                _ => out.push((a, b)),
            }
        }
        Ranges(out)
    }

    /// The part of [a, b) not covered.
    pub fn missing_in(&self, a: u64, b: u64) -> Ranges {
        let mut out = Vec::new();
        let mut at = a;
        for &(x, y) in &self.0 {
            if y <= at {
                continue;
            }
            if x >= b {
                break;
            }
            if x > at {
                out.push((at, x));
            }
            at = at.max(y);
        }
        if at < b {
            out.push((at, b));
        }
        Ranges(out)
    }

    pub fn count(&self) -> u64 {
        self.0.iter().map(|(a, b)| b - a).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// "0–9, 20–29" (inclusive ends), at most `max` ranges then "…".
    pub fn describe(&self, max: usize) -> String {
        let mut parts: Vec<String> = self
            .0
            .iter()
            .take(max)
            .map(|&(a, b)| {
                if b == a + 1 {
                    a.to_string()
                } else {
                    format!("{a}–{}", b - 1)
                }
            })
            .collect();
        if self.0.len() > max {
            parts.push(format!("… ({} ranges)", self.0.len()));
        }
        parts.join(", ")
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub tool: String,
    pub study_name: String,
    pub study_hash: String,
    pub design: String,
    pub seed: u64,
    /// The study's sample count N (`--samples` or `samples`; for Saltelli the base rows).
    #[serde(default)]
    pub samples: u64,
    /// Sample ids are 0..runs.
    pub runs: u64,
    pub columns: Columns,
    /// Shard count of the latest run (for `status`).
    pub shards: u64,
    pub completed: Ranges,
    /// The SHA-256 of each part file (by name), recorded when it was written and checked
    /// on every read.
    #[serde(default)]
    pub parts: BTreeMap<String, String>,
}

pub fn path(out: &Path) -> PathBuf {
    out.join("manifest.json")
}

impl Manifest {
    pub fn load(out: &Path) -> Result<Manifest> {
        let p = path(out);
        let text =
            std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?;
        serde_json::from_str(&text)
            .with_context(|| format!("{} is not a manifest of mc-study", p.display()))
    }

    /// Writes atomically (temporary file, fsync, rename).
    pub fn save(&self, out: &Path) -> Result<()> {
        let p = path(out);
        let tmp = out.join(format!(".manifest.json.{}.tmp", std::process::id()));
        let mut text = serde_json::to_string_pretty(self)?;
        text.push('\n');
        let written = std::fs::write(&tmp, text).and_then(|()| File::open(&tmp)?.sync_all());
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(e).with_context(|| format!("writing {}", p.display()));
        }
        std::fs::rename(&tmp, &p).with_context(|| format!("writing {}", p.display()))?;
        Ok(())
    }

    /// Refuses a directory that belongs to another study.
    pub fn check_same_study(&self, hash: &str, out: &Path) -> Result<()> {
        if self.study_hash != hash {
            bail!(
                "{} holds results of a different study (`{}`, hash {}…; this one is {}…): the study file, its scene or the sample count changed. Nothing was overwritten. Use another --out directory, or delete this one to start over.",
                out.display(),
                self.study_name,
                &self.study_hash[..12.min(self.study_hash.len())],
                &hash[..12.min(hash.len())]
            );
        }
        Ok(())
    }
}

/// Opens (creating it if needed) a file used only for its lock.
pub fn lock_file(p: &Path) -> Result<File> {
    File::options()
        .create(true)
        .truncate(false)
        .write(true)
        .open(p)
        .with_context(|| format!("creating the lock file {}", p.display()))
}

/// Holds `OUT/.lock` exclusively while alive.
pub struct DirLock(File);

impl DirLock {
    /// Waits for the lock, saying so when another process holds it.
    pub fn acquire(out: &Path) -> Result<DirLock> {
        let p = out.join(".lock");
        let f = lock_file(&p)?;
        match f.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                eprintln!(
                    "waiting for {}: another mc-study process (a run, merge or status of this directory) holds it",
                    p.display()
                );
                f.lock().context("locking the output directory")?;
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(e).context("locking the output directory")
            }
        }
        Ok(DirLock(f))
    }
}

/// Whether another process holds the lock of `p` (a shard's lock file) now.
pub fn held_elsewhere(p: &Path) -> bool {
    let Ok(f) = File::open(p) else {
        return false;
    };
    match f.try_lock() {
        Ok(()) => {
            let _ = f.unlock();
            false
        }
        Err(std::fs::TryLockError::WouldBlock) => true,
        Err(std::fs::TryLockError::Error(_)) => false,
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        let _ = self.0.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_merge_and_complement() {
        let r = Ranges::from_ids(vec![5, 1, 2, 3, 9, 2]);
        assert_eq!(r.0, vec![(1, 4), (5, 6), (9, 10)]);
        let u = r.union(&Ranges(vec![(4, 5), (10, 12)]));
        assert_eq!(u.0, vec![(1, 6), (9, 12)]);
        assert_eq!(u.missing_in(0, 15).0, vec![(0, 1), (6, 9), (12, 15)]);
        assert_eq!(u.missing_in(2, 5).0, Vec::<(u64, u64)>::new());
        assert_eq!(u.count(), 8);
        assert_eq!(u.describe(5), "1–5, 9–11");
    }
}
