//! Curves across a study: the pointwise median and 5–95 % band of the samples' curves, and
//! how far measured points (a test bench's) lie from them.
//!
//! A reference file is a CSV of two columns, x and y, one point per line. An optional
//! header names the columns and may give their units in brackets (`travel [mm], force
//! [N]`); without units the values are SI. Blank lines and lines starting with `#` are
//! skipped; commas, semicolons, tabs or spaces separate the values.

use super::statistics::quantile_sorted;
use super::store::{CurveColumn, Table};
use crate::input::units::{Dim, DisplayUnit};
use crate::probe::curve::{Curve, Grid};
use crate::scene::SceneError;
use anyhow::Context;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A curve's measured points, read when the study loads.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    pub curve: String,
    /// The file as found (relative to the scene file).
    pub file: PathBuf,
    /// (x, y) in SI units.
    pub points: Vec<(f64, f64)>,
}

/// Reads the reference of every curve that names one, relative to the scene file.
pub fn read_references(curves: &[Curve], scene_path: &Path) -> Result<Vec<Reference>, SceneError> {
    let mut out = Vec::new();
    for c in curves {
        let Some(r) = &c.reference else { continue };
        let file = scene_path.parent().unwrap_or(Path::new("")).join(&r.file);
        let points = read_reference(&file, &c.x_unit, &c.unit).map_err(|e| {
            SceneError::at(r.line, r.field.clone(), e).in_file(&scene_path.display().to_string())
        })?;
        out.push(Reference {
            curve: c.name.clone(),
            file,
            points,
        });
    }
    Ok(out)
}

/// Where a study's results keep the reference of curve `name`: the report reads it there,
/// so that the result directory stands alone.
pub fn reference_path(out: &Path, name: &str) -> PathBuf {
    out.join("reference").join(format!("{name}.csv"))
}

/// A reference file's text: `header`, then one `x, y` line per point (SI, every digit
/// kept).
pub fn points_csv(header: &str, points: &[(f64, f64)]) -> String {
    let mut text = format!("{header}\n");
    for (x, y) in points {
        text.push_str(&format!("{x}, {y}\n"));
    }
    text
}

/// Writes each reference into the result directory, in SI units (atomically: a temporary
/// name, then a rename).
pub fn write_references(out: &Path, references: &[Reference]) -> anyhow::Result<()> {
    for r in references {
        let path = reference_path(out, &r.curve);
        let dir = path.parent().expect("a directory");
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let header = format!(
            "# measured points of curve `{}` in SI units, from {}\nx, y",
            r.curve,
            r.file.display()
        );
        let text = points_csv(&header, &r.points);
        let tmp = dir.join(format!(".{}.{}.tmp", r.curve, std::process::id()));
        std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, &path).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}

/// The reference stored with the results for curve column `c`, if there is one.
pub fn stored_reference(
    out: &Path,
    c: &super::store::CurveColumn,
) -> Option<Result<Vec<(f64, f64)>, String>> {
    let path = reference_path(out, &c.name);
    if !path.exists() {
        return None;
    }
    Some(read_reference(&path, &c.x_unit, &c.unit))
}

/// The points of reference file `path`, for x and y of SI units `x_unit` and `y_unit`;
/// the error names the file.
fn read_reference(path: &Path, x_unit: &str, y_unit: &str) -> Result<Vec<(f64, f64)>, String> {
    let dim = |u: &str| Dim::of_unit(u).unwrap_or(Dim::NONE);
    crate::input::file::read(path)
        .and_then(|t| parse_reference(&t, dim(x_unit), dim(y_unit)))
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The population of one curve.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CurveSummary {
    pub name: String,
    /// y's SI unit, and the unit it is shown in (display = SI × factor).
    pub unit: String,
    pub display_unit: String,
    pub display_factor: f64,
    /// The probe whose measure is x, its SI unit and display unit.
    pub x: String,
    pub x_unit: String,
    pub x_display_unit: String,
    pub x_display_factor: f64,
    pub grid: Grid,
    /// Samples that went through (their curves make the band).
    pub samples: u64,
    /// Per grid point: how many samples have a value there, and the 5 %, 50 % and 95 %
    /// quantiles of their values (null where none has).
    pub count: Vec<u64>,
    pub p05: Vec<Option<f64>>,
    pub median: Vec<Option<f64>>,
    pub p95: Vec<Option<f64>>,
}

impl CurveSummary {
    /// The summary of curve column `c` (the k-th) over the samples of `table` that went
    /// through; `display` and `x_display` are the units the scene asks y and x to be
    /// shown in.
    pub fn of(
        table: &Table,
        k: usize,
        c: &CurveColumn,
        display: Option<&DisplayUnit>,
        x_display: Option<&DisplayUnit>,
    ) -> Self {
        let curves: Vec<&Vec<f64>> = table
            .rows
            .iter()
            // the band is the population's: of a rare-event study, its direct samples
            .filter(|r| !r.failed() && r.tag.as_ref().is_none_or(direct))
            .filter_map(|r| r.curves.get(k).filter(|v| v.len() == c.grid.count))
            .collect();
        let (mut count, mut p05, mut median, mut p95) = (vec![], vec![], vec![], vec![]);
        for i in 0..c.grid.count {
            let mut v: Vec<f64> = curves
                .iter()
                .map(|y| y[i])
                .filter(|y| !y.is_nan())
                .collect();
            v.sort_by(f64::total_cmp);
            let q = |p: f64| (!v.is_empty()).then(|| quantile_sorted(&v, p));
            count.push(v.len() as u64);
            p05.push(q(0.05));
            median.push(q(0.5));
            p95.push(q(0.95));
        }
        let unit_of = |si: &str, big: f64| match Dim::of_unit(si) {
            Some(dim) => DisplayUnit::auto(dim, big),
            None => DisplayUnit::for_values(si, &[]),
        };
        let big_y = p05
            .iter()
            .chain(&p95)
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let y = display.cloned().unwrap_or_else(|| unit_of(&c.unit, big_y));
        let last = c.grid.point(c.grid.count - 1);
        let x = x_display
            .cloned()
            .unwrap_or_else(|| unit_of(&c.x_unit, c.grid.start.abs().max(last.abs())));
        CurveSummary {
            name: c.name.clone(),
            unit: c.unit.clone(),
            display_unit: y.label,
            display_factor: y.per_si,
            x: c.x.clone(),
            x_unit: c.x_unit.clone(),
            x_display_unit: x.label,
            x_display_factor: x.per_si,
            grid: c.grid,
            samples: curves.len() as u64,
            count,
            p05,
            median,
            p95,
        }
    }

    /// The summaries of every curve of `table`, with the display units `curves` (the
    /// scene's) ask for.
    pub fn all(table: &Table, curves: &[Curve]) -> Vec<CurveSummary> {
        table
            .columns
            .curves
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let scene = curves.iter().find(|s| s.name == c.name);
                let display = scene.and_then(|s| s.display.as_ref());
                let x_display = scene.and_then(|s| s.x_display.as_ref());
                CurveSummary::of(table, k, c, display, x_display)
            })
            .collect()
    }

    /// The unit y is shown in.
    pub fn display(&self) -> DisplayUnit {
        DisplayUnit {
            label: self.display_unit.clone(),
            per_si: self.display_factor,
        }
    }

    /// The unit x is shown in.
    pub fn x_display(&self) -> DisplayUnit {
        DisplayUnit {
            label: self.x_display_unit.clone(),
            per_si: self.x_display_factor,
        }
    }

    /// A pointwise statistic at x, linearly interpolated between the grid points around
    /// it; `None` outside the grid or next to a point without a value.
    pub fn at(&self, values: &[Option<f64>], x: f64) -> Option<f64> {
        let g = &self.grid;
        let s = (x - g.start) / g.step;
        let last = (g.count - 1) as f64;
        if !(s >= -1e-9 && s <= last + 1e-9) {
            return None;
        }
        let s = s.clamp(0.0, last);
        let i = s.floor() as usize;
        let w = s - i as f64;
        if w <= 1e-9 {
            return values[i];
        }
        let (a, b) = (values[i]?, values[i + 1]?);
        Some(a + (b - a) * w)
    }

    /// How far the measured `points` (x, y in SI) lie from the population.
    pub fn compare(&self, points: &[(f64, f64)]) -> Comparison {
        let mut errors: Vec<(f64, f64)> = Vec::new();
        let mut inside = 0u64;
        for &(x, y) in points {
            let Some(m) = self.at(&self.median, x) else {
                continue;
            };
            errors.push((x, m - y));
            let lo = self.at(&self.p05, x);
            let hi = self.at(&self.p95, x);
            if lo.is_some_and(|lo| y >= lo) && hi.is_some_and(|hi| y <= hi) {
                inside += 1;
            }
        }
        let n = errors.len();
        let rms = (errors.iter().map(|e| e.1 * e.1).sum::<f64>() / n as f64).sqrt();
        let worst = errors
            .iter()
            .copied()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        Comparison {
            compared: n as u64,
            outside_grid: (points.len() - n) as u64,
            rms: (n > 0).then_some(rms),
            max_abs: worst.map(|w| w.1.abs()),
            max_at: worst.map(|w| w.0),
            in_band: (n > 0).then(|| inside as f64 / n as f64),
        }
    }
}

/// Whether a rare-event study's run samples the inputs' own distribution: plain Monte
/// Carlo, or subset simulation's first level (the later levels and importance sampling
/// draw elsewhere and carry weights).
fn direct(t: &super::store::Tag) -> bool {
    t.stage == "monte-carlo" || (t.stage == "subset" && t.level == 0)
}

/// Measured points against a curve's population: the median's error at each point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// The points inside the grid, where the median has a value.
    pub compared: u64,
    /// The points left out: beyond the grid, or where the curves have no value.
    pub outside_grid: u64,
    /// Root mean square and largest |median − measured| (SI units of y), and the x of the
    /// largest.
    pub rms: Option<f64>,
    pub max_abs: Option<f64>,
    pub max_at: Option<f64>,
    /// The share of the compared points inside the 5–95 % band.
    pub in_band: Option<f64>,
}

/// Parses a reference CSV (see the module's note): the points in SI units, or an error
/// naming the line.
pub fn parse_reference(text: &str, x_dim: Dim, y_dim: Dim) -> Result<Vec<(f64, f64)>, String> {
    let mut scale = (1.0, 1.0);
    let mut points = Vec::new();
    let mut first = true;
    for (n, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split([',', ';', '\t', ' '])
            .map(str::trim)
            .filter(|f| !f.is_empty())
            .collect();
        let header = first && fields.first().is_some_and(|f| f.parse::<f64>().is_err());
        first = false;
        if header {
            let cells: Vec<&str> = line.split([',', ';', '\t']).map(str::trim).collect();
            if cells.len() != 2 {
                return Err(format!(
                    "line {}: the header must name two columns (x, y), found {}",
                    n + 1,
                    cells.len()
                ));
            }
            let unit = |cell: &str, dim: Dim| -> Result<f64, String> {
                match (cell.find('['), cell.rfind(']')) {
                    (Some(a), Some(b)) if b > a => DisplayUnit::parse(cell[a + 1..b].trim(), dim)
                        .map(|u| 1.0 / u.per_si)
                        .map_err(|e| format!("line {}: `{cell}`: {e}", n + 1)),
                    _ => Ok(1.0),
                }
            };
            scale = (unit(cells[0], x_dim)?, unit(cells[1], y_dim)?);
            continue;
        }
        if fields.len() != 2 {
            return Err(format!(
                "line {}: expected two values (x, y), found {}",
                n + 1,
                fields.len()
            ));
        }
        let number = |f: &str| -> Result<f64, String> {
            f.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("line {}: `{f}` is not a finite number", n + 1))
        };
        points.push((number(fields[0])? * scale.0, number(fields[1])? * scale.1));
    }
    if points.is_empty() {
        return Err("no points".into());
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reference_reads_its_units_from_the_header() {
        let text = "# bench 3\ntravel [mm], force [N]\n0.5, 1.25\n1.0;2.5\n\n2\t4\n";
        let p = parse_reference(text, Dim::LENGTH, Dim::FORCE).unwrap();
        assert_eq!(p, vec![(5e-4, 1.25), (1e-3, 2.5), (2e-3, 4.0)]);
        let si = parse_reference("0.001 3\n", Dim::LENGTH, Dim::FORCE).unwrap();
        assert_eq!(si, vec![(0.001, 3.0)]);
        let bad = parse_reference("x [mm], y [N]\n1, 2\n3, nan\n", Dim::LENGTH, Dim::FORCE);
        assert_eq!(bad.unwrap_err(), "line 3: `nan` is not a finite number");
        let unit = parse_reference("x [s], y [N]\n1, 2\n", Dim::LENGTH, Dim::FORCE);
        assert!(unit.unwrap_err().starts_with("line 1: `x [s]`"));
        assert!(parse_reference("1, 2, 3\n", Dim::LENGTH, Dim::FORCE).is_err());
    }

    fn summary(median: Vec<Option<f64>>) -> CurveSummary {
        let n = median.len();
        CurveSummary {
            name: "c".into(),
            unit: "N".into(),
            display_unit: "N".into(),
            display_factor: 1.0,
            x: "x".into(),
            x_unit: "m".into(),
            x_display_unit: "m".into(),
            x_display_factor: 1.0,
            grid: Grid {
                start: 1.0,
                step: 0.5,
                count: n,
            },
            samples: 1,
            count: vec![1; n],
            p05: median.iter().map(|m| m.map(|v| v - 1.0)).collect(),
            p95: median.iter().map(|m| m.map(|v| v + 1.0)).collect(),
            median,
        }
    }

    /// Median 2x on x ∈ [1, 2.5] (one point missing at 2.5): points at 1.25 (error 0.5),
    /// 2.0 (error −2, outside the band), 2.5 (no median) and 3 (beyond the grid).
    #[test]
    fn the_comparison_interpolates_the_median_and_counts_the_band() {
        let s = summary(vec![Some(2.0), Some(3.0), Some(4.0), None]);
        let c = s.compare(&[(1.25, 2.0), (2.0, 6.0), (2.5, 5.0), (3.0, 6.0)]);
        assert_eq!(c.compared, 2);
        assert_eq!(c.outside_grid, 2);
        assert!((c.rms.unwrap() - ((0.25 + 4.0) / 2.0f64).sqrt()).abs() < 1e-15);
        assert_eq!(c.max_abs, Some(2.0));
        assert_eq!(c.max_at, Some(2.0));
        assert_eq!(c.in_band, Some(0.5));
    }
}
