//! Curve probes: one measure against another (a force against a displacement), resampled
//! onto a fixed grid of the first, so that every sample's curve has the same length and a
//! study can summarise its curves point by point.
//!
//! Each grid point stands for a cell of one grid step centred on it, and its value is the
//! mean of y over the time x spends in that cell: within a step x moves linearly from its
//! value at the step's start to its value at the step's end, and y holds the step's value
//! (a force read off an impulse is the step's mean force). The cell mean converges as h
//! falls, where y sampled at the instant x crosses a grid point would carry a rigid
//! impact's 1/h spike; an impact in a cell counts as its impulse over the time x spends
//! there. A cell that x never enters has no value (NaN).

use super::{Measure, TimeRef};
use crate::input::units::DisplayUnit;

/// Grid points `start + i·step`, i = 0..count.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Grid {
    pub start: f64,
    pub step: f64,
    pub count: usize,
}

impl Grid {
    /// The most grid points a curve may have: far beyond what a test-bench curve needs,
    /// small enough that a study's curves stay a fraction of its store.
    pub const MAX_POINTS: usize = 100_000;

    pub fn point(&self, i: usize) -> f64 {
        self.start + self.step * i as f64
    }

    pub fn points(&self) -> Vec<f64> {
        (0..self.count).map(|i| self.point(i)).collect()
    }

    /// The grid from `from` to `to` (inclusive, to a part in 1e9 of a step) by `step`.
    pub fn span(from: f64, to: f64, step: f64) -> Result<Grid, String> {
        if !(from.is_finite() && to.is_finite() && step.is_finite()) {
            return Err("the grid's ends and step must be finite".into());
        }
        if step <= 0.0 {
            return Err(format!("the grid's step must be positive, got {step}"));
        }
        if to <= from {
            return Err(format!(
                "the grid must run upward: its end ({to}) is not above its start ({from})"
            ));
        }
        let intervals = ((to - from) / step + 1e-9).floor();
        if intervals + 1.0 > Self::MAX_POINTS as f64 {
            return Err(format!(
                "the grid has {intervals:.0} steps; at most {} points are allowed: take a larger step",
                Self::MAX_POINTS
            ));
        }
        Ok(Grid {
            start: from,
            step,
            count: intervals as usize + 1,
        })
    }
}

/// A curve probe, validated against its scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub name: String,
    /// The probes whose measures the curve draws, by name (the x axis, then the y axis).
    pub x_name: String,
    pub y_name: String,
    pub x: Measure,
    pub y: Measure,
    /// SI units of x and y.
    pub x_unit: String,
    pub unit: String,
    /// The units to show y (the curve's `unit:`) and x (x's probe's `unit:`) in, where the
    /// scene gives them.
    pub display: Option<DisplayUnit>,
    pub x_display: Option<DisplayUnit>,
    pub grid: Grid,
    /// The part of the run the curve takes (default: all of it).
    pub from: Option<TimeRef>,
    pub to: Option<TimeRef>,
    /// Measured points to compare with.
    pub reference: Option<ReferenceFile>,
}

/// A curve's `reference:` as the scene writes it: a file relative to the scene file, and
/// where the scene names it (for errors).
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceFile {
    pub file: String,
    pub line: Option<u64>,
    pub field: String,
}

/// The running cell sums of one curve.
#[derive(Clone, Debug)]
pub(super) struct CurveCells {
    /// ∫ y dt and ∫ dt over the time x spends in each cell.
    area: Vec<f64>,
    time: Vec<f64>,
    /// x at the previous observation.
    pub(super) previous_x: Option<f64>,
    /// The window has closed: nothing more is added.
    pub(super) closed: bool,
}

impl CurveCells {
    pub(super) fn new(grid: &Grid) -> CurveCells {
        CurveCells {
            area: vec![0.0; grid.count],
            time: vec![0.0; grid.count],
            previous_x: None,
            closed: false,
        }
    }

    /// Adds a stretch of `duration` over which x runs linearly from `xa` to `xb` and y
    /// holds `y`: each cell takes the share of the stretch during which x is inside it.
    pub(super) fn add(&mut self, grid: &Grid, xa: f64, xb: f64, y: f64, duration: f64) {
        if !(duration > 0.0 && xa.is_finite() && xb.is_finite() && y.is_finite()) {
            return;
        }
        // cell i covers [start + (i − ½) step, start + (i + ½) step)
        let cell = |x: f64| (x - grid.start) / grid.step + 0.5;
        let (lo, hi) = (cell(xa.min(xb)), cell(xa.max(xb)));
        let last = grid.count as f64;
        if hi < 0.0 || lo >= last {
            return;
        }
        if hi == lo {
            let i = lo.floor() as usize;
            self.area[i] += y * duration;
            self.time[i] += duration;
            return;
        }
        let first = lo.max(0.0).floor() as usize;
        let end = (hi.min(last - 1e-12).floor() as usize).min(grid.count - 1);
        for i in first..=end {
            let overlap = hi.min(i as f64 + 1.0) - lo.max(i as f64);
            if overlap > 0.0 {
                let dt = duration * overlap / (hi - lo);
                self.area[i] += y * dt;
                self.time[i] += dt;
            }
        }
    }

    /// Each cell's mean of y, NaN where x never was.
    pub(super) fn values(&self) -> Vec<f64> {
        self.area
            .iter()
            .zip(&self.time)
            .map(|(a, t)| if *t > 0.0 { a / t } else { f64::NAN })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x = t on [0, 1], y = x²: each interior cell's mean is (1/s)∫ x² over the cell,
    /// g² + s²/12, whatever the steps' alignment with the cells.
    #[test]
    fn a_cell_mean_is_the_mean_over_the_time_spent_in_the_cell() {
        let grid = Grid::span(0.1, 0.9, 0.1).unwrap();
        assert_eq!(grid.count, 9);
        for steps in [7usize, 100, 1013] {
            let mut c = CurveCells::new(&grid);
            let h = 1.0 / steps as f64;
            // y over a step is its mean of x² (the step's mean force, say)
            for k in 0..steps {
                let (a, b) = (k as f64 * h, (k + 1) as f64 * h);
                let mean = (b * b * b - a * a * a) / (3.0 * h);
                c.add(&grid, a, b, mean, h);
            }
            for (i, v) in c.values().iter().enumerate() {
                let g = grid.point(i);
                let exact = g * g + 0.01 / 12.0;
                // a step straddling a cell edge gives its mean to both cells: an error of
                // at most h² per cell
                assert!(
                    (v - exact).abs() < 2.0 * h * h,
                    "{steps} steps, cell {i}: {v} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn cells_never_entered_are_empty_and_a_standing_x_fills_its_cell() {
        let grid = Grid::span(0.0, 1.0, 0.25).unwrap();
        let mut c = CurveCells::new(&grid);
        c.add(&grid, 0.3, 0.3, 2.0, 0.5);
        c.add(&grid, 0.3, 0.3, 4.0, 0.5);
        c.add(&grid, 5.0, 6.0, 1.0, 1.0);
        let v = c.values();
        assert_eq!(v[1], 3.0);
        assert!(v[0].is_nan() && v[2].is_nan() && v[4].is_nan());
        // backwards motion counts like forwards motion
        c.add(&grid, 1.1, 0.9, 8.0, 1.0);
        assert_eq!(c.values()[4], 8.0);
    }

    #[test]
    fn a_grid_counts_its_end_and_refuses_nonsense() {
        assert_eq!(Grid::span(0.0, 6e-3, 5e-5).unwrap().count, 121);
        assert!(Grid::span(0.0, 1.0, 0.0).is_err());
        assert!(Grid::span(1.0, 0.0, 0.1).is_err());
        assert!(Grid::span(0.0, 1.0, 1e-7).is_err());
    }
}
