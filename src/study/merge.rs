//! `mc-study merge` (all parts → `OUT/results.parquet` sorted by sample id, then the
//! summary) and `mc-study status` (done / missing / failed per shard).

use super::manifest::{held_elsewhere, DirLock, Manifest, Ranges};
use super::runner::{part_files, read_part, shard_lock_path, Shard};
use super::store::{self, Row, Table};
use super::summary::Summary;
use super::Study;
use anyhow::{bail, Context, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Every row of every part, one per sample id. A sample stored twice (by a shard rerun
/// from a copy, say) is kept once if its rows agree but for the wall time, and refused if
/// they disagree.
pub fn collect(out: &Path) -> Result<(Manifest, Table)> {
    let manifest = Manifest::load(out)?;
    let mut rows: Vec<(Row, usize)> = Vec::new();
    let mut metadata = HashMap::new();
    let files = part_files(out)?;
    for (k, p) in files.iter().enumerate() {
        let t = read_part(p, &manifest)?;
        if t.columns != manifest.columns {
            bail!("{} has other columns than manifest.json", p.display());
        }
        metadata = t.metadata;
        rows.extend(t.rows.into_iter().map(|r| (r, k)));
    }
    rows.sort_by_key(|(r, _)| r.id);
    for w in rows.windows(2) {
        let ((a, i), (b, j)) = (&w[0], &w[1]);
        if a.id == b.id && !same_sample(a, b) {
            bail!(
                "sample {} is stored twice with different values, in {} and {}: delete the part that should not be there and rerun the same `mc-study run` command",
                a.id,
                files[*i].display(),
                files[*j].display()
            );
        }
    }
    let mut rows: Vec<Row> = rows.into_iter().map(|(r, _)| r).collect();
    rows.dedup_by_key(|r| r.id);
    let columns = manifest.columns.clone();
    Ok((
        manifest,
        Table {
            columns,
            rows,
            metadata,
            digest: String::new(),
        },
    ))
}

/// Refuses the directory of a worst-case search, which `merge`, `status` and `report` do
/// not read: `mc-study worst-case` resumes and prints it.
pub fn refuse_search(out: &Path) -> Result<()> {
    if Manifest::load(out).is_ok_and(|m| m.design == "worst-case") {
        bail!(
            "{} holds the runs of a worst-case search: rerun `mc-study worst-case STUDY` to resume it and print the result (also in worst-case.json)",
            out.display()
        );
    }
    Ok(())
}

/// Two rows of one sample agree: every value bit for bit but the wall time.
fn same_sample(a: &Row, b: &Row) -> bool {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let (da, db) = (&a.diagnostics, &b.diagnostics);
    bits(&a.inputs) == bits(&b.inputs)
        && bits(&a.outputs) == bits(&b.outputs)
        && da.steps == db.steps
        && da.max_penetration.to_bits() == db.max_penetration.to_bits()
        && da.max_solver_residual.to_bits() == db.max_solver_residual.to_bits()
        && da.nonconverged_steps == db.nonconverged_steps
        && a.error == b.error
        && a.suspect == b.suspect
}

/// The study of a result directory, from the study and scene texts stored in its parts,
/// checked against the manifest's hash: the limits, display units and cautions of the
/// summary come from the texts the hash covers, never from an editable manifest.
pub fn stored_study(manifest: &Manifest, table: &Table) -> Result<Study> {
    let text = |key: &str| {
        table.metadata.get(key).with_context(|| {
            format!(
                "the part files lack the stored study (metadata `{key}`): written by another tool?"
            )
        })
    };
    let (study_text, scene_text) = (text(store::META_STUDY)?, text(store::META_SCENE)?);
    let samples = (manifest.samples > 0).then_some(manifest.samples);
    let study = Study::from_texts(study_text, scene_text, "the stored study.yaml", samples)
        .context("the study stored with the results no longer loads")?;
    if study.hash() != manifest.study_hash {
        bail!(
            "manifest.json does not match the study stored in the part files (hash {}… against {}…): it was edited or belongs to another run; delete it and rerun the study to rebuild it from the parts",
            &manifest.study_hash[..12.min(manifest.study_hash.len())],
            &study.hash()[..12]
        );
    }
    Ok(study)
}

/// The row count of an existing results file, from its footer.
fn rows_in(path: &Path) -> Option<u64> {
    let file = std::fs::File::open(path).ok()?;
    let reader = parquet::file::reader::SerializedFileReader::new(file).ok()?;
    use parquet::file::reader::FileReader;
    u64::try_from(reader.metadata().file_metadata().num_rows()).ok()
}

pub struct Merged {
    pub path: PathBuf,
    pub rows: u64,
    pub missing: Ranges,
    pub summary: Summary,
}

/// Writes `OUT/results.parquet`, `OUT/summary.json`; refuses (unless `allow_partial`) when
/// samples are missing and names them.
pub fn merge(out: &Path, allow_partial: bool) -> Result<Merged> {
    refuse_search(out)?;
    let (manifest, mut table) = collect(out)?;
    let missing =
        Ranges::from_ids(table.rows.iter().map(|r| r.id).collect()).missing_in(0, manifest.runs);
    if !missing.is_empty() && !allow_partial {
        bail!(
            "{} of {} samples are missing: {}. Run the study again on this directory to complete it (it resumes), see `mc-study status {}`, or merge what is there with --allow-partial.",
            missing.count(),
            manifest.runs,
            missing.describe(8),
            out.display()
        );
    }
    if table.rows.is_empty() {
        bail!("{} holds no samples yet", out.display());
    }
    table
        .metadata
        .insert("mc_study.complete".into(), missing.is_empty().to_string());
    let study = stored_study(&manifest, &table)?;
    let summary = Summary::of(&manifest.study_name, &table, &study.outputs)
        .with_inputs(&study.parameters)
        .with_curves(&table, study.subject.curves());
    let path = out.join("results.parquet");
    let _dir = DirLock::acquire(out)?;
    // a slow merge of fewer parts must not replace the result of a later, fuller one
    if let Some(rows) = rows_in(&path) {
        if rows > table.rows.len() as u64 {
            bail!(
                "{} already holds {rows} samples, more than the {} this merge found; it was left as it is",
                path.display(),
                table.rows.len()
            );
        }
    }
    store::write(&path, &table.columns, &table.rows, &table.metadata)?;
    let json = out.join("summary.json");
    let tmp = out.join(format!(".summary.json.{}.tmp", std::process::id()));
    std::fs::write(&tmp, summary.to_json())
        .and_then(|()| std::fs::rename(&tmp, &json))
        .with_context(|| format!("writing {}", json.display()))?;
    Ok(Merged {
        path,
        rows: table.rows.len() as u64,
        missing,
        summary,
    })
}

/// Per shard of an `n`-way split: (shard, samples, done, failed, missing ranges).
pub struct ShardStatus {
    pub shard: Shard,
    /// A process holds the shard's lock: it is being run now.
    pub running: bool,
    pub samples: u64,
    pub done: u64,
    pub failed: u64,
    pub missing: Ranges,
}

/// `mc-study status`: the study and each shard's state.
pub struct StatusReport {
    pub manifest: Manifest,
    pub shards: Vec<ShardStatus>,
    pub out: PathBuf,
}

impl std::fmt::Display for StatusReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let m = &self.manifest;
        writeln!(
            f,
            "study {} ({} runs, hash {}…)",
            m.study_name,
            m.runs,
            &m.study_hash[..12.min(m.study_hash.len())]
        )?;
        writeln!(
            f,
            "{:<8} {:>9} {:>9} {:>9} {:>9}  state",
            "shard", "samples", "done", "failed", "missing"
        )?;
        let mut resubmit = Vec::new();
        let mut running = Vec::new();
        for s in &self.shards {
            let state = if s.done == s.samples {
                "complete"
            } else if s.running {
                "running"
            } else if s.done == 0 {
                "missing"
            } else {
                "partial"
            };
            if s.done < s.samples && !s.running {
                resubmit.push(s.shard.index.to_string());
            }
            if s.done < s.samples && s.running {
                running.push(s.shard.index.to_string());
            }
            writeln!(
                f,
                "{:<8} {:>9} {:>9} {:>9} {:>9}  {state}",
                format!("{}/{}", s.shard.index, s.shard.count),
                s.samples,
                s.done,
                s.failed,
                s.samples - s.done
            )?;
        }
        if !running.is_empty() {
            writeln!(f, "shards still running: {}", running.join(","))?;
        }
        if !resubmit.is_empty() {
            writeln!(f, "incomplete shards: --array={}", resubmit.join(","))
        } else if running.is_empty() {
            writeln!(
                f,
                "all shards complete: `mc-study merge {}`",
                self.out.display()
            )
        } else {
            Ok(())
        }
    }
}

/// The state of each shard of an `n`-way split (default: the latest run's).
pub fn status(out: &Path, shards: Option<u64>) -> Result<StatusReport> {
    refuse_search(out)?;
    let (manifest, table) = collect(out)?;
    let n = shards.unwrap_or(manifest.shards).max(1);
    let done = Ranges::from_ids(table.rows.iter().map(|r| r.id).collect());
    let v = (0..n)
        .map(|index| {
            let shard = Shard { index, count: n };
            let (a, b) = shard.range(manifest.runs);
            let in_shard = |id: u64| (a..b).contains(&id);
            let missing = done.missing_in(a, b);
            ShardStatus {
                shard,
                running: held_elsewhere(&shard_lock_path(out, &shard.label())),
                samples: b - a,
                done: (b - a) - missing.count(),
                failed: table
                    .rows
                    .iter()
                    .filter(|r| in_shard(r.id) && r.failed())
                    .count() as u64,
                missing,
            }
        })
        .collect();
    Ok(StatusReport {
        manifest,
        shards: v,
        out: out.to_path_buf(),
    })
}
