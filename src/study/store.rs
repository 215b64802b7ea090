//! The Parquet files of a study: one row per sample (`sample_id`, inputs, outputs,
//! diagnostics, `status`, `error`), units in field metadata, the study in file metadata.
//! Every file is written to a temporary name, fsynced and renamed, so that a reader (or a
//! resumed run) sees a whole file or none.

use super::sample_run::Diagnostics;
use crate::probe::curve::Grid;
use anyhow::{bail, Context, Result};
use arrow_array::builder::{Float64Builder, ListBuilder};
use arrow_array::{
    Array, ArrayRef, Float64Array, ListArray, RecordBatch, StringArray, UInt64Array,
};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::fs::File;
use std::path::Path;
use std::sync::Arc;

/// One sample's row.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub id: u64,
    pub inputs: Vec<f64>,
    /// NaN (stored as null) for a failed sample.
    pub outputs: Vec<f64>,
    pub diagnostics: Diagnostics,
    pub error: Option<String>,
    /// Why the values of a run that went through are suspect (see `Outcome`).
    pub suspect: Option<String>,
    /// Why optional outputs of a run that went through have no value (the `missing`
    /// column).
    pub missing: Option<String>,
    /// Each curve's values on its grid (NaN, stored as null, where its x never was);
    /// empty for a failed sample.
    pub curves: Vec<Vec<f64>>,
    /// Where the run sits in an adaptive (rare-event) study; `None` in a plain one.
    pub tag: Option<Tag>,
}

/// Where a run of an adaptive study sits: its batch, stage, level, chain, and (in the
/// merged results, once the margin's scales are known) its margin.
#[derive(Clone, Debug, PartialEq)]
pub struct Tag {
    pub batch: u64,
    pub stage: String,
    pub level: u64,
    pub chain: Option<u64>,
    pub margin: Option<f64>,
}

impl Row {
    pub fn failed(&self) -> bool {
        self.error.is_some()
    }

    /// `ok`, `suspect` or `failed`: the `status` column.
    pub fn status(&self) -> &'static str {
        match (&self.error, &self.suspect) {
            (Some(_), _) => "failed",
            (None, Some(_)) => "suspect",
            (None, None) => "ok",
        }
    }
}

/// Names and SI units of the input and output columns.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Columns {
    pub inputs: Vec<(String, String)>,
    pub outputs: Vec<(String, String)>,
    /// The rows carry a [`Tag`]: the columns `batch`, `stage`, `level`, `chain`, `margin`.
    #[serde(default)]
    pub tagged: bool,
    /// Some outputs are optional: the rows carry the `missing` column.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub optional: bool,
    /// The curve columns, after the outputs.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub curves: Vec<CurveColumn>,
}

/// A curve column: per sample, y's values on a grid of x.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CurveColumn {
    pub name: String,
    /// SI unit of y.
    pub unit: String,
    /// The probe whose measure is x, and its SI unit.
    pub x: String,
    pub x_unit: String,
    pub grid: Grid,
}

impl CurveColumn {
    /// The list column's field: y's unit, and x, its unit and the grid in its metadata.
    fn field(&self) -> Field {
        let item = Arc::new(Field::new("item", DataType::Float64, true));
        let f = field(&self.name, DataType::List(item), true, "curve", &self.unit);
        let mut meta = f.metadata().clone();
        meta.extend([
            ("x".to_string(), self.x.clone()),
            ("x_unit".to_string(), self.x_unit.clone()),
            ("grid_start".to_string(), self.grid.start.to_string()),
            ("grid_step".to_string(), self.grid.step.to_string()),
            ("grid_count".to_string(), self.grid.count.to_string()),
        ]);
        f.with_metadata(meta)
    }

    /// The column a field written by [`CurveColumn::field`] describes.
    fn of_field(f: &Field) -> Result<CurveColumn> {
        let meta = f.metadata();
        let get = |k: &str| {
            meta.get(k)
                .with_context(|| format!("curve column `{}` lacks its `{k}`", f.name()))
        };
        let number = |k: &str| -> Result<f64> {
            get(k)?
                .parse()
                .with_context(|| format!("curve column `{}`: `{k}` is not a number", f.name()))
        };
        Ok(CurveColumn {
            name: f.name().clone(),
            unit: meta.get("unit").cloned().unwrap_or_default(),
            x: get("x")?.clone(),
            x_unit: get("x_unit")?.clone(),
            grid: Grid {
                start: number("grid_start")?,
                step: number("grid_step")?,
                count: get("grid_count")?.parse().with_context(|| {
                    format!("curve column `{}`: `grid_count` is not a count", f.name())
                })?,
            },
        })
    }
}

/// Diagnostic columns: (name, unit, description).
pub const DIAGNOSTICS: [(&str, &str, &str); 5] = [
    ("steps", "1", "time steps taken"),
    (
        "max_penetration",
        "m",
        "largest penetration of any contact at a step end",
    ),
    (
        "max_solver_residual",
        "1",
        "largest contact-solver residual of any step",
    ),
    (
        "nonconverged_steps",
        "1",
        "steps whose solver, Newton loop or projection did not converge (counted per kind)",
    ),
    (
        "wall_ms",
        "ms",
        "wall time of the sample (the only column that differs between identical runs)",
    ),
];

/// The column that says why optional outputs have no value: (name, description).
pub const MISSING: (&str, &str) = (
    "missing",
    "why the optional outputs left empty in a run that went through have no value",
);

/// The columns of an adaptive study's rows: (name, description).
pub const TAGS: [(&str, &str); 5] = [
    (
        "batch",
        "the batch of the adaptive study the run belongs to",
    ),
    ("stage", "monte-carlo, subset or importance"),
    (
        "level",
        "the subset level, or the importance-sampling round",
    ),
    ("chain", "the Markov chain of a subset level above 0"),
    (
        "margin",
        "the scaled distance to the nearest limit, negative outside (merged results only)",
    ),
];

/// Parquet key-value metadata keys.
pub const META_HASH: &str = "mc_study.study_hash";
pub const META_STUDY: &str = "mc_study.study_yaml";
pub const META_SCENE: &str = "mc_study.scene_yaml";
pub const META_VERSION: &str = "mc_study.version";
pub const META_NAME: &str = "mc_study.study_name";

fn field(name: &str, ty: DataType, nullable: bool, role: &str, unit: &str) -> Field {
    let mut meta = HashMap::from([("role".to_string(), role.to_string())]);
    if !unit.is_empty() {
        meta.insert("unit".to_string(), unit.to_string());
    }
    Field::new(name, ty, nullable).with_metadata(meta)
}

impl Columns {
    pub fn schema(&self, metadata: HashMap<String, String>) -> Schema {
        let mut fields = vec![field("sample_id", DataType::UInt64, false, "id", "")];
        for (n, u) in &self.inputs {
            fields.push(field(n, DataType::Float64, false, "input", u));
        }
        for (n, u) in &self.outputs {
            fields.push(field(n, DataType::Float64, true, "output", u));
        }
        for c in &self.curves {
            fields.push(c.field());
        }
        for (n, u, _) in DIAGNOSTICS {
            let ty = if matches!(n, "steps" | "nonconverged_steps") {
                DataType::UInt64
            } else {
                DataType::Float64
            };
            fields.push(field(n, ty, false, "diagnostic", u));
        }
        fields.push(field("status", DataType::Utf8, false, "status", ""));
        fields.push(field("error", DataType::Utf8, true, "status", ""));
        if self.optional {
            fields.push(field(MISSING.0, DataType::Utf8, true, "missing", ""));
        }
        if self.tagged {
            fields.push(field("batch", DataType::UInt64, false, "tag", ""));
            fields.push(field("stage", DataType::Utf8, false, "tag", ""));
            fields.push(field("level", DataType::UInt64, false, "tag", ""));
            fields.push(field("chain", DataType::UInt64, true, "tag", ""));
            fields.push(field("margin", DataType::Float64, true, "tag", ""));
        }
        Schema::new_with_metadata(fields, metadata)
    }

    fn batch(&self, rows: &[Row], schema: Arc<Schema>) -> Result<RecordBatch> {
        let f64s = |f: &dyn Fn(&Row) -> f64| -> ArrayRef {
            Arc::new(Float64Array::from_iter_values(rows.iter().map(f)))
        };
        let u64s = |f: &dyn Fn(&Row) -> u64| -> ArrayRef {
            Arc::new(UInt64Array::from_iter_values(rows.iter().map(f)))
        };
        let mut cols: Vec<ArrayRef> = vec![u64s(&|r| r.id)];
        for k in 0..self.inputs.len() {
            cols.push(f64s(&|r| r.inputs[k]));
        }
        for k in 0..self.outputs.len() {
            let v: Float64Array = rows
                .iter()
                .map(|r| Some(r.outputs[k]).filter(|x| !x.is_nan()))
                .collect();
            cols.push(Arc::new(v));
        }
        for (k, c) in self.curves.iter().enumerate() {
            let mut list =
                ListBuilder::new(Float64Builder::with_capacity(rows.len() * c.grid.count))
                    .with_field(Arc::new(Field::new("item", DataType::Float64, true)));
            for r in rows {
                match r.curves.get(k).filter(|v| !v.is_empty()) {
                    Some(v) => {
                        if v.len() != c.grid.count {
                            bail!(
                                "sample {}: curve `{}` has {} points, its grid {}",
                                r.id,
                                c.name,
                                v.len(),
                                c.grid.count
                            );
                        }
                        for x in v {
                            list.values()
                                .append_option(Some(*x).filter(|x| !x.is_nan()));
                        }
                        list.append(true);
                    }
                    None => list.append(false),
                }
            }
            cols.push(Arc::new(list.finish()));
        }
        cols.push(u64s(&|r| r.diagnostics.steps));
        cols.push(f64s(&|r| r.diagnostics.max_penetration));
        cols.push(f64s(&|r| r.diagnostics.max_solver_residual));
        cols.push(u64s(&|r| r.diagnostics.nonconverged_steps));
        cols.push(f64s(&|r| r.diagnostics.wall_ms));
        cols.push(Arc::new(StringArray::from_iter_values(
            rows.iter().map(Row::status),
        )));
        // the failure, or why a run that went through is suspect
        cols.push(Arc::new(
            rows.iter()
                .map(|r| r.error.as_deref().or(r.suspect.as_deref()))
                .collect::<StringArray>(),
        ));
        if self.optional {
            cols.push(Arc::new(
                rows.iter()
                    .map(|r| r.missing.as_deref())
                    .collect::<StringArray>(),
            ));
        }
        if self.tagged {
            let tag = |r: &Row| -> Result<Tag> {
                r.tag
                    .clone()
                    .with_context(|| format!("sample {} of an adaptive study has no tag", r.id))
            };
            let tags: Vec<Tag> = rows.iter().map(tag).collect::<Result<_>>()?;
            cols.push(Arc::new(UInt64Array::from_iter_values(
                tags.iter().map(|t| t.batch),
            )));
            cols.push(Arc::new(StringArray::from_iter_values(
                tags.iter().map(|t| t.stage.as_str()),
            )));
            cols.push(Arc::new(UInt64Array::from_iter_values(
                tags.iter().map(|t| t.level),
            )));
            cols.push(Arc::new(
                tags.iter().map(|t| t.chain).collect::<UInt64Array>(),
            ));
            cols.push(Arc::new(
                tags.iter().map(|t| t.margin).collect::<Float64Array>(),
            ));
        }
        Ok(RecordBatch::try_new(schema, cols)?)
    }
}

/// A file that hashes what is written through it.
struct HashingFile {
    file: File,
    hasher: Sha256,
}

impl std::io::Write for HashingFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// The SHA-256 of a file's bytes, in hex: what a part's integrity is checked against.
pub fn digest(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Writes `rows` to `path` atomically (temporary name, fsync, rename, fsync of the
/// directory); returns the SHA-256 of the file written.
pub fn write(
    path: &Path,
    columns: &Columns,
    rows: &[Row],
    metadata: &HashMap<String, String>,
) -> Result<String> {
    let dir = path.parent().context("a file path has a directory")?;
    let name = path.file_name().context("a file name")?.to_string_lossy();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = write_file(&tmp, columns, rows, metadata);
    let digest = match written {
        Ok(d) => d,
        Err(e) => {
            // a full disk leaves no half-written temporary behind
            let _ = std::fs::remove_file(&tmp);
            return Err(e.context(format!("writing {}", path.display())));
        }
    };
    std::fs::rename(&tmp, path)
        .with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))?;
    File::open(dir)
        .and_then(|d| d.sync_all())
        .with_context(|| format!("syncing {}", dir.display()))?;
    Ok(digest)
}

fn write_file(
    tmp: &Path,
    columns: &Columns,
    rows: &[Row],
    metadata: &HashMap<String, String>,
) -> Result<String> {
    let schema = Arc::new(columns.schema(metadata.clone()));
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::try_new(3)?))
        .build();
    let file = HashingFile {
        file: File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?,
        hasher: Sha256::new(),
    };
    let mut writer = ArrowWriter::try_new(file, schema.clone(), Some(props))?;
    // row groups of at most 64 Ki rows keep readers' memory bounded
    for chunk in rows.chunks(65_536) {
        writer.write(&columns.batch(chunk, schema.clone())?)?;
    }
    let file = writer.into_inner()?;
    file.file.sync_all()?;
    Ok(hex(&file.hasher.finalize()))
}

/// What a study file holds.
pub struct Table {
    pub columns: Columns,
    pub rows: Vec<Row>,
    pub metadata: HashMap<String, String>,
    /// The SHA-256 of the file read (empty for a table built in memory).
    pub digest: String,
}

fn column<'a, T: 'static>(batch: &'a RecordBatch, name: &str) -> Result<&'a T> {
    batch
        .column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<T>())
        .with_context(|| format!("column `{name}` is missing or has the wrong type"))
}

/// The values of a list cell (NaN for a null value; empty for a null list).
fn list_values(list: &ListArray, i: usize) -> Result<Vec<f64>> {
    if list.is_null(i) {
        return Ok(Vec::new());
    }
    let cell = list.value(i);
    let v = cell
        .as_any()
        .downcast_ref::<Float64Array>()
        .context("a curve's values are not 64-bit floats")?;
    Ok((0..v.len())
        .map(|j| if v.is_null(j) { f64::NAN } else { v.value(j) })
        .collect())
}

/// Reads a study file written by [`write`].
pub fn read(path: &Path) -> Result<Table> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let digest = digest(&bytes);
    let builder = ParquetRecordBatchReaderBuilder::try_new(bytes::Bytes::from(bytes))
        .with_context(|| format!("reading {}", path.display()))?;
    let schema = builder.schema().clone();
    let metadata: HashMap<String, String> = schema
        .metadata()
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let role = |f: &Field| f.metadata().get("role").cloned().unwrap_or_default();
    let unit = |f: &Field| f.metadata().get("unit").cloned().unwrap_or_default();
    let pick = |r: &str| -> Vec<(String, String)> {
        schema
            .fields()
            .iter()
            .filter(|f| role(f) == r)
            .map(|f| (f.name().clone(), unit(f)))
            .collect()
    };
    let curves = schema
        .fields()
        .iter()
        .filter(|f| role(f) == "curve")
        .map(|f| CurveColumn::of_field(f))
        .collect::<Result<Vec<_>>>()
        .with_context(|| format!("reading {}", path.display()))?;
    let columns = Columns {
        inputs: pick("input"),
        outputs: pick("output"),
        tagged: !pick("tag").is_empty(),
        optional: !pick("missing").is_empty(),
        curves,
    };
    let mut rows = Vec::new();
    for batch in builder.build()? {
        let batch = batch.with_context(|| format!("reading {}", path.display()))?;
        let ids = column::<UInt64Array>(&batch, "sample_id")?;
        let inputs: Vec<&Float64Array> = columns
            .inputs
            .iter()
            .map(|(n, _)| column(&batch, n))
            .collect::<Result<_>>()?;
        let outputs: Vec<&Float64Array> = columns
            .outputs
            .iter()
            .map(|(n, _)| column(&batch, n))
            .collect::<Result<_>>()?;
        let curves: Vec<&ListArray> = columns
            .curves
            .iter()
            .map(|c| column(&batch, &c.name))
            .collect::<Result<_>>()?;
        let steps = column::<UInt64Array>(&batch, "steps")?;
        let pen = column::<Float64Array>(&batch, "max_penetration")?;
        let res = column::<Float64Array>(&batch, "max_solver_residual")?;
        let nc = column::<UInt64Array>(&batch, "nonconverged_steps")?;
        let wall = column::<Float64Array>(&batch, "wall_ms")?;
        let status = column::<StringArray>(&batch, "status")?;
        let error = column::<StringArray>(&batch, "error")?;
        let missing = match columns.optional {
            true => Some(column::<StringArray>(&batch, MISSING.0)?),
            false => None,
        };
        let tags = if columns.tagged {
            Some((
                column::<UInt64Array>(&batch, "batch")?,
                column::<StringArray>(&batch, "stage")?,
                column::<UInt64Array>(&batch, "level")?,
                column::<UInt64Array>(&batch, "chain")?,
                column::<Float64Array>(&batch, "margin")?,
            ))
        } else {
            None
        };
        for i in 0..batch.num_rows() {
            let text = (!error.is_null(i)).then(|| error.value(i).to_string());
            let (err, suspect) = match (status.value(i), text) {
                ("ok", None) => (None, None),
                ("failed", Some(t)) => (Some(t), None),
                ("suspect", Some(t)) => (None, Some(t)),
                (s, t) => bail!(
                    "{}: row {i} has status `{s}` and error {t:?}",
                    path.display()
                ),
            };
            rows.push(Row {
                id: ids.value(i),
                inputs: inputs.iter().map(|c| c.value(i)).collect(),
                outputs: outputs
                    .iter()
                    .map(|c| if c.is_null(i) { f64::NAN } else { c.value(i) })
                    .collect(),
                diagnostics: Diagnostics {
                    steps: steps.value(i),
                    max_penetration: pen.value(i),
                    max_solver_residual: res.value(i),
                    nonconverged_steps: nc.value(i),
                    wall_ms: wall.value(i),
                },
                error: err,
                suspect,
                missing: missing
                    .filter(|m| !m.is_null(i))
                    .map(|m| m.value(i).to_string()),
                curves: curves
                    .iter()
                    .map(|c| list_values(c, i))
                    .collect::<Result<_>>()
                    .with_context(|| format!("{}: sample {}", path.display(), ids.value(i)))?,
                tag: tags.map(|(b, s, l, c, m)| Tag {
                    batch: b.value(i),
                    stage: s.value(i).to_string(),
                    level: l.value(i),
                    chain: (!c.is_null(i)).then(|| c.value(i)),
                    margin: (!m.is_null(i)).then(|| m.value(i)),
                }),
            });
        }
    }
    Ok(Table {
        columns,
        rows,
        metadata,
        digest,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::columns::{column_name_error, RESERVED};

    /// Every column the store writes of its own is reserved for it, and nothing else is.
    #[test]
    fn the_reserved_names_are_the_stores_own_columns() {
        let mut own: Vec<&str> = ["sample_id", "status", "error", MISSING.0].to_vec();
        own.extend(DIAGNOSTICS.iter().map(|d| d.0));
        own.extend(TAGS.iter().map(|t| t.0));
        let mut reserved = RESERVED.to_vec();
        own.sort_unstable();
        reserved.sort_unstable();
        assert_eq!(own, reserved);
        assert!(column_name_error("margin").is_some());
        assert!(column_name_error(" ").is_some());
        assert_eq!(column_name_error("trip_time"), None);
    }
}
