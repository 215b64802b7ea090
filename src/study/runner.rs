//! The batch: rayon workers run the pending samples of a shard; one writer thread owns all
//! I/O, receives rows through a bounded channel and writes them as part files. A killed
//! run loses at most the rows not yet in a part; a resumed run skips every sample found in
//! a part, whichever run or shard wrote it.

use super::manifest::{lock_file, DirLock, Manifest, Ranges};
use super::store::{self, Columns, Row};
use super::{Study, StudyError};
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use std::collections::HashMap;
use std::fs::File;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Shard `index` of `count`: the contiguous block of sample ids
/// [runs·index/count, runs·(index+1)/count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Shard {
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N`; `/N` takes I from `SLURM_ARRAY_TASK_ID`.
    pub fn parse(text: &str) -> Result<Shard, StudyError> {
        Shard::parse_text(text).map_err(StudyError::Shard)
    }

    fn parse_text(text: &str) -> Result<Shard, String> {
        let (i, n) = text
            .split_once('/')
            .ok_or_else(|| format!("--shard `{text}`: expected I/N (e.g. 3/8) or /N"))?;
        let count: u64 = n
            .trim()
            .parse()
            .map_err(|_| format!("--shard `{text}`: N must be a whole number ≥ 1"))?;
        let index: u64 = if i.trim().is_empty() {
            let v = std::env::var("SLURM_ARRAY_TASK_ID").map_err(|_| {
                format!("--shard `{text}` names no index and SLURM_ARRAY_TASK_ID is not set")
            })?;
            v.trim()
                .parse()
                .map_err(|_| format!("SLURM_ARRAY_TASK_ID = `{v}` is not a whole number"))?
        } else {
            i.trim()
                .parse()
                .map_err(|_| format!("--shard `{text}`: I must be a whole number"))?
        };
        if count == 0 || index >= count {
            return Err(format!("--shard {index}/{count}: needs 0 ≤ I < N"));
        }
        Ok(Shard { index, count })
    }

    pub fn range(&self, runs: u64) -> (u64, u64) {
        let at = |k: u64| (u128::from(runs) * u128::from(k) / u128::from(self.count)) as u64;
        (at(self.index), at(self.index + 1))
    }

    /// The part-file label, `3of8`.
    pub fn label(&self) -> String {
        format!("{}of{}", self.index, self.count)
    }
}

#[derive(Clone)]
pub struct RunOptions {
    pub out: PathBuf,
    pub threads: Option<usize>,
    pub shard: Shard,
    /// Show the progress bar (it is hidden anyway when stderr is not a terminal).
    pub progress: bool,
    /// A part is written when it holds this many rows…
    pub rows_per_part: usize,
    /// …or when its oldest row is this old.
    pub seconds_per_part: f64,
    /// Set (by a stop signal) to stop starting samples; the rows done are written before
    /// return.
    pub stop: Arc<AtomicBool>,
    /// In an adaptive (rare-event) study run in shards, wait for the other shards to
    /// finish each batch and go on with the next, rather than return after this shard's
    /// part of one batch.
    pub wait_for_shards: bool,
}

impl RunOptions {
    pub fn new(out: PathBuf) -> Self {
        RunOptions {
            out,
            threads: None,
            shard: Shard::WHOLE,
            progress: true,
            rows_per_part: 1024,
            seconds_per_part: 30.0,
            stop: Arc::new(AtomicBool::new(false)),
            wait_for_shards: false,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunReport {
    /// Samples of the shard already done before this run.
    pub skipped: u64,
    pub done: u64,
    pub failed: u64,
    pub parts: u64,
    pub interrupted: bool,
    pub wall_seconds: f64,
    /// Sample ids still missing in the whole study after this run.
    pub missing: Ranges,
}

pub fn parts_dir(out: &Path) -> PathBuf {
    out.join("parts")
}

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default()
}

/// Every part file in `OUT/parts`, sorted by name.
pub fn part_files(out: &Path) -> Result<Vec<PathBuf>> {
    let dir = parts_dir(out);
    let mut v = Vec::new();
    if dir.exists() {
        for e in std::fs::read_dir(&dir)? {
            let p = e?.path();
            let name = file_name(&p);
            if name.starts_with("part-") && name.ends_with(".parquet") {
                v.push(p);
            }
        }
    }
    v.sort();
    Ok(v)
}

/// The advice for a part that fails its checks.
fn damaged(p: &Path, why: &str) -> String {
    format!(
        "{} {why}. Delete it and rerun the same `mc-study run` command: the samples it held are computed again",
        p.display()
    )
}

/// Reads a part file, refusing one written for another study, one whose bytes differ from
/// the digest recorded when it was written, and one with sample ids outside the study.
pub fn read_part(p: &Path, manifest: &Manifest) -> Result<store::Table> {
    let t = store::read(p)
        .map_err(|e| anyhow::anyhow!(damaged(p, &format!("cannot be read ({e:#})"))))?;
    if let Some(recorded) = manifest.parts.get(&file_name(p)) {
        if *recorded != t.digest {
            bail!(damaged(
                p,
                "is corrupted: its SHA-256 differs from the one recorded in manifest.json when it was written"
            ));
        }
    }
    if t.metadata.get(store::META_HASH) != Some(&manifest.study_hash) {
        bail!(
            "{} belongs to another study (its hash differs); nothing was overwritten",
            p.display()
        );
    }
    if let Some(r) = t.rows.iter().find(|r| r.id >= manifest.runs) {
        bail!(damaged(
            p,
            &format!(
                "holds sample {}, but the study has samples 0–{} only",
                r.id,
                manifest.runs.saturating_sub(1)
            )
        ));
    }
    Ok(t)
}

/// The sample ids found in the part files, recording the digest of any part written by a
/// run that died before it could record it, and forgetting parts that were deleted.
fn completed(out: &Path, manifest: &mut Manifest) -> Result<Ranges> {
    let mut all = Ranges::default();
    let files = part_files(out)?;
    let names: Vec<String> = files.iter().map(|p| file_name(p)).collect();
    manifest.parts.retain(|name, _| names.contains(name));
    for (p, name) in files.iter().zip(names) {
        let t = read_part(p, manifest)?;
        manifest.parts.entry(name).or_insert(t.digest);
        all = all.union(&Ranges::from_ids(t.rows.iter().map(|r| r.id).collect()));
    }
    Ok(all)
}

impl Study {
    pub fn columns(&self) -> Columns {
        Columns {
            inputs: self
                .parameters
                .iter()
                .map(|p| (p.path.clone(), p.unit.clone()))
                .collect(),
            outputs: self
                .outputs
                .iter()
                .map(|o| (o.name.clone(), o.unit.clone()))
                .collect(),
            tagged: self.reliability.is_some() || self.search.is_some(),
            optional: self.outputs.iter().any(|o| o.optional),
            curves: self
                .subject
                .curves()
                .iter()
                .map(|c| store::CurveColumn {
                    name: c.name.clone(),
                    unit: c.unit.clone(),
                    x: c.x_name.clone(),
                    x_unit: c.x_unit.clone(),
                    grid: c.grid,
                })
                .collect(),
        }
    }

    pub fn file_metadata(&self) -> HashMap<String, String> {
        HashMap::from([
            (store::META_HASH.to_string(), self.hash()),
            (store::META_STUDY.to_string(), self.text.clone()),
            (store::META_SCENE.to_string(), self.scene_text.clone()),
            (
                store::META_VERSION.to_string(),
                format!("mc-study {}", env!("CARGO_PKG_VERSION")),
            ),
            (store::META_NAME.to_string(), self.name.clone()),
        ])
    }

    fn manifest(&self, shards: u64, completed: Ranges) -> Manifest {
        Manifest {
            tool: format!("mc-study {}", env!("CARGO_PKG_VERSION")),
            study_name: self.name.clone(),
            study_hash: self.hash(),
            design: self
                .search
                .as_ref()
                .map_or(self.design.kind.name(), |s| s.kind)
                .to_string(),
            seed: self.seed,
            samples: self.design.base,
            runs: self.runs(),
            columns: self.columns(),
            shards,
            completed,
            parts: Default::default(),
        }
    }

    /// The row of sample i; with `suspect: fail`, a suspect sample is a failed one.
    pub fn row(&self, i: u64) -> Row {
        self.row_at(i, self.inputs(i))
    }

    /// The row of a run numbered i at `inputs`.
    pub fn row_at(&self, i: u64, inputs: Vec<f64>) -> Row {
        let mut o = self.run_inputs(&inputs);
        if self.suspect_fails {
            if let Some(why) = o.suspect.take() {
                o.error = Some(format!("suspect: {why}"));
                o.outputs.iter_mut().for_each(|v| *v = f64::NAN);
                o.curves.iter_mut().for_each(Vec::clear);
            }
        }
        Row {
            id: i,
            inputs,
            outputs: o.outputs,
            diagnostics: o.diagnostics,
            missing: (o.error.is_none() && !o.missing.is_empty()).then(|| {
                let why: Vec<&str> = o.missing.iter().map(|(_, w)| w.as_str()).collect();
                why.join("; ")
            }),
            error: o.error,
            suspect: o.suspect,
            curves: o.curves,
            tag: None,
        }
    }
}

/// The lock file of the shard labelled `label` (`3of8`): held by the process running it.
pub fn shard_lock_path(out: &Path, label: &str) -> PathBuf {
    parts_dir(out).join(format!(".shard-{label}.lock"))
}

/// Claims the shard for this process (two processes never write the same part names).
fn lock_shard(out: &Path, shard: Shard) -> Result<File> {
    let p = shard_lock_path(out, &shard.label());
    let f = lock_file(&p)?;
    match f.try_lock() {
        Ok(()) => Ok(f),
        Err(std::fs::TryLockError::WouldBlock) => {
            bail!(
                "shard {}/{} of {} is being run by another process",
                shard.index,
                shard.count,
                out.display()
            )
        }
        Err(std::fs::TryLockError::Error(e)) => Err(e).context("locking the shard"),
    }
}

/// What a directory that is not (yet) a result directory may hold: what a run that died
/// before writing its first manifest leaves behind, and the scripts of `mc-study slurm`.
fn is_skeleton(out: &Path) -> Result<bool> {
    for e in std::fs::read_dir(out).with_context(|| format!("reading {}", out.display()))? {
        let p = e?.path();
        let name = file_name(&p);
        let ours = name == ".lock"
            // `mc-study slurm` writes its scripts before the tasks run
            || name == "slurm"
            || (name.starts_with(".manifest.json.") && name.ends_with(".tmp"))
            || (name == "parts"
                && std::fs::read_dir(&p)?
                    .all(|e| e.is_ok_and(|e| e.file_name().to_string_lossy().starts_with('.'))));
        if !ours {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Refuses an OUT that exists and is neither empty nor a result directory: a run writes
/// only into a new or empty directory, or into one of its own study's result directories.
pub fn check_out(out: &Path) -> Result<()> {
    if out.as_os_str().is_empty() {
        bail!("the output directory is empty text: give --out DIR or the study's `output`");
    }
    if !out.exists() {
        return Ok(());
    }
    if !out.is_dir() {
        bail!("{} exists and is not a directory", out.display());
    }
    // Another task of the same array may write its first manifest, then study.yaml, while
    // this one looks. The manifest comes first, so it is asked for after the scan: a scan
    // that met anything else was made when the manifest already existed.
    if !is_skeleton(out)? && !super::manifest::path(out).exists() {
        bail!(
            "{} is not empty and holds no results of mc-study (no manifest.json); nothing was written. Choose a new or empty directory, or the directory of an earlier run of this study.",
            out.display()
        );
    }
    Ok(())
}

/// Removes the temporary files of writers that died: those of OUT itself (written only
/// under the directory lock, which the caller holds) and those of shards no process runs.
fn remove_orphans(out: &Path) -> Result<()> {
    let tmp = |name: &str| name.starts_with('.') && name.ends_with(".tmp");
    for e in std::fs::read_dir(out)? {
        let p = e?.path();
        if tmp(&file_name(&p)) && p.is_file() {
            std::fs::remove_file(&p).with_context(|| format!("removing {}", p.display()))?;
        }
    }
    for e in std::fs::read_dir(parts_dir(out))? {
        let p = e?.path();
        let name = file_name(&p);
        // `.part-3of8-000012.parquet.<pid>.tmp` belongs to shard 3of8
        let Some(label) = name
            .strip_prefix(".part-")
            .and_then(|r| r.split('-').next())
        else {
            continue;
        };
        if tmp(&name) && !super::manifest::held_elsewhere(&shard_lock_path(out, label)) {
            std::fs::remove_file(&p).with_context(|| format!("removing {}", p.display()))?;
        }
    }
    Ok(())
}

/// Refuses to run while another split of the same study runs in OUT: shards of different
/// splits overlap, and both would compute the same samples.
fn check_split(out: &Path, shard: Shard) -> Result<()> {
    for e in std::fs::read_dir(parts_dir(out))? {
        let p = e?.path();
        let name = file_name(&p);
        let Some(label) = name
            .strip_prefix(".shard-")
            .and_then(|r| r.strip_suffix(".lock"))
        else {
            continue;
        };
        let Some((i, n)) = label.split_once("of") else {
            continue;
        };
        if n != shard.count.to_string() && super::manifest::held_elsewhere(&p) {
            bail!(
                "shard {i}/{n} of {} is being run by another process; a run split {}-ways would compute some of its samples again. Wait for it to end, or stop it, then rerun.",
                out.display(),
                shard.count
            );
        }
    }
    Ok(())
}

/// Creates or reopens OUT for `study`: refuses another study's directory, an unrelated
/// one, and a run of another split under way; cleans orphan temporary files; returns the
/// completed ranges found in the parts.
fn prepare(study: &Study, out: &Path, shard: Shard) -> Result<(Ranges, File)> {
    check_out(out)?;
    std::fs::create_dir_all(parts_dir(out))
        .with_context(|| format!("creating {}", out.display()))?;
    let _dir = DirLock::acquire(out)?;
    let hash = study.hash();
    let mut manifest = if super::manifest::path(out).exists() {
        let m = Manifest::load(out)?;
        m.check_same_study(&hash, out)?;
        m
    } else if !part_files(out)?.is_empty() {
        bail!(
            "{} holds part files but no manifest.json; refusing to mix results",
            out.display()
        );
    } else {
        study.manifest(shard.count, Ranges::default())
    };
    check_split(out, shard)?;
    let shard_lock = lock_shard(out, shard)?;
    remove_orphans(out)?;
    let done = completed(out, &mut manifest)?;
    manifest.shards = shard.count;
    manifest.completed = done.clone();
    manifest.save(out)?;
    let text = out.join("study.yaml");
    std::fs::write(&text, &study.text).with_context(|| format!("writing {}", text.display()))?;
    Ok((done, shard_lock))
}

/// The writer: owns every file operation after `prepare`.
struct Writer<'a> {
    study: &'a Study,
    out: &'a Path,
    shard: Shard,
    columns: Columns,
    metadata: HashMap<String, String>,
    next_seq: u64,
    rows: Vec<Row>,
    report: RunReport,
}

impl Writer<'_> {
    /// Writes the buffered rows as a part; whether there were any.
    fn flush(&mut self) -> Result<bool> {
        if self.rows.is_empty() {
            return Ok(false);
        }
        let name = format!("part-{}-{:06}.parquet", self.shard.label(), self.next_seq);
        let path = parts_dir(self.out).join(&name);
        let digest = store::write(&path, &self.columns, &self.rows, &self.metadata)?;
        self.next_seq += 1;
        self.report.parts += 1;
        let ids = Ranges::from_ids(self.rows.iter().map(|r| r.id).collect());
        self.rows.clear();
        let _dir = DirLock::acquire(self.out)?;
        let mut m = Manifest::load(self.out)
            .unwrap_or_else(|_| self.study.manifest(self.shard.count, Ranges::default()));
        m.completed = m.completed.union(&ids);
        m.parts.insert(name, digest);
        m.save(self.out)?;
        Ok(true)
    }
}

fn next_seq(out: &Path, shard: Shard) -> Result<u64> {
    let prefix = format!("part-{}-", shard.label());
    let mut next = 0;
    for p in part_files(out)? {
        let name = file_name(&p);
        if let Some(seq) = name
            .strip_prefix(&prefix)
            .and_then(|s| s.strip_suffix(".parquet"))
        {
            if let Ok(s) = seq.parse::<u64>() {
                next = next.max(s + 1);
            }
        }
    }
    Ok(next)
}

/// Runs the pending samples of `opts.shard` into `opts.out`.
pub fn run(study: &Study, opts: &RunOptions) -> Result<RunReport> {
    run_rows(study, opts, (0, study.runs()), &|i| study.row(i))
}

/// Runs the samples of `opts.shard`'s part of the ids [first, end) that are not stored
/// yet, `row(i)` computing sample i's row: a plain study's ids, or one batch of an
/// adaptive study.
pub fn run_rows(
    study: &Study,
    opts: &RunOptions,
    (first, end): (u64, u64),
    row: &(dyn Fn(u64) -> Row + Sync),
) -> Result<RunReport> {
    let start = Instant::now();
    let out = opts.out.as_path();
    let (done_before, _shard_lock) = prepare(study, out, opts.shard)?;
    super::curves::write_references(out, &study.references)?;
    let (a, b) = opts.shard.range(end - first);
    let (a, b) = (first + a, first + b);
    let pending = done_before.missing_in(a, b);
    let mut writer = Writer {
        study,
        out,
        shard: opts.shard,
        columns: study.columns(),
        metadata: study.file_metadata(),
        next_seq: next_seq(out, opts.shard)?,
        rows: Vec::new(),
        report: RunReport {
            skipped: (b - a) - pending.count(),
            ..Default::default()
        },
    };

    let bar = if opts.progress && std::io::stderr().is_terminal() {
        let pb = ProgressBar::with_draw_target(Some(pending.count()), ProgressDrawTarget::stderr());
        pb.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{wide_bar}] {pos}/{len} samples, {per_sec}, ETA {eta} {msg}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        pb
    } else {
        ProgressBar::hidden()
    };
    let logging = opts.progress && !std::io::stderr().is_terminal();

    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(t) = opts.threads {
            b = b.num_threads(t);
        }
        b.build().context("starting the worker threads")?
    };
    let (tx, rx) = mpsc::sync_channel::<Row>(4096);
    let stop = opts.stop.clone();
    let total = pending.count();

    let written = std::thread::scope(|scope| -> Result<RunReport> {
        let stop_w = stop.clone();
        let bar_w = bar.clone();
        let handle = scope.spawn(move || -> Result<RunReport> {
            let mut oldest: Option<Instant> = None;
            // `inf` means never: a part is written when full or at the end
            let budget = Duration::try_from_secs_f64(opts.seconds_per_part).unwrap_or(Duration::MAX);
            let mut step = || -> Result<bool> {
                let wait = oldest.map_or(budget, |t| budget.saturating_sub(t.elapsed()));
                let open = match rx.recv_timeout(wait.max(Duration::from_millis(1))) {
                    Ok(row) => {
                        writer.report.done += 1;
                        if row.failed() {
                            writer.report.failed += 1;
                            bar_w.set_message(format!("{} failed", writer.report.failed));
                        }
                        bar_w.inc(1);
                        writer.rows.push(row);
                        oldest.get_or_insert_with(Instant::now);
                        true
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) => true,
                    Err(mpsc::RecvTimeoutError::Disconnected) => false,
                };
                let due = oldest.is_some_and(|t| t.elapsed() >= budget);
                if writer.rows.len() >= opts.rows_per_part || due || !open {
                    let wrote = writer.flush()?;
                    oldest = None;
                    if logging && wrote {
                        eprintln!(
                            "{}: {}/{total} samples of shard {}/{} done ({} failed), {:.1} samples/s",
                            study.name,
                            writer.report.done,
                            opts.shard.index,
                            opts.shard.count,
                            writer.report.failed,
                            writer.report.done as f64 / start.elapsed().as_secs_f64()
                        );
                    }
                }
                Ok(open)
            };
            loop {
                match step() {
                    Ok(true) => {}
                    Ok(false) => break,
                    Err(e) => {
                        // stop the workers; rows not yet written are lost, never half-written
                        stop_w.store(true, Ordering::SeqCst);
                        return Err(e);
                    }
                }
            }
            Ok(writer.report)
        });
        pool.install(|| {
            pending
                .0
                .par_iter()
                .flat_map(|&(a, b)| (a..b).into_par_iter())
                // an Err ends the iteration at once, however many samples remain
                .try_for_each_with(tx, |tx, i| {
                    if stop.load(Ordering::Relaxed) {
                        return Err(());
                    }
                    tx.send(row(i)).map_err(|_| ())
                })
                .ok();
        });
        handle.join().expect("the writer thread does not panic")
    });
    bar.finish_and_clear();
    let mut report = written?;
    let m = Manifest::load(out)?;
    report.missing = m.completed.missing_in(0, study.runs());
    report.interrupted = !m.completed.missing_in(a, b).is_empty();
    report.wall_seconds = start.elapsed().as_secs_f64();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Barrier};

    /// A task of an array checks OUT while a sibling writes its first manifest and then its
    /// study.yaml: the directory is a skeleton before and a result directory after, so
    /// `check_out` must accept it whatever it sees in between.
    #[test]
    fn check_out_accepts_a_directory_whose_manifest_appears_while_it_looks() {
        let root = std::env::temp_dir().join(format!("mc-study-check-out-{}", std::process::id()));
        let start = Arc::new(Barrier::new(2));
        for i in 0..500 {
            let out = root.join(i.to_string());
            std::fs::create_dir_all(parts_dir(&out)).unwrap();
            std::fs::write(out.join(".lock"), "").unwrap();
            std::fs::write(out.join(".manifest.json.x.tmp"), "{}").unwrap();
            let writer = {
                let (out, start) = (out.clone(), start.clone());
                std::thread::spawn(move || {
                    start.wait();
                    let manifest = super::super::manifest::path(&out);
                    std::fs::rename(out.join(".manifest.json.x.tmp"), manifest).unwrap();
                    std::fs::write(out.join("study.yaml"), "name: x\n").unwrap();
                })
            };
            start.wait();
            let checked = check_out(&out);
            writer.join().unwrap();
            assert!(checked.is_ok(), "attempt {i}: {:#}", checked.unwrap_err());
        }
        std::fs::remove_dir_all(&root).unwrap();
        // an unrelated directory is still refused
        let stranger = root.join("stranger");
        std::fs::create_dir_all(&stranger).unwrap();
        std::fs::write(stranger.join("study.yaml"), "name: x\n").unwrap();
        let refused = check_out(&stranger).unwrap_err().to_string();
        assert!(
            refused.contains("holds no results of mc-study"),
            "{refused}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
