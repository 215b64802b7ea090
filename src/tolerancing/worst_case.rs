//! The worst case: each output's smallest and largest value over the box of the
//! tolerances, and the inputs that reach them.
//!
//! The search runs in the box scaled to [0, 1]^d. It evaluates the centre and every corner
//! (up to [`MAX_CORNER_INPUTS`] inputs; beyond, the centre, the 2d face centres, and for each
//! output the two corners their differences point to). A mechanism's extreme need not sit
//! at a corner, so from the best few points of each output and sense a compass search
//! polls ± Δ along every input (clipped to the box), moves to the best point that improves,
//! and halves Δ when none does, until Δ falls below the tolerance. All searches poll
//! together, one batch per step, so the runs go in parallel; the search is deterministic,
//! and it is replayed from the stored runs to resume.

/// Corners are enumerated up to this many inputs (2^12 = 4096 runs).
pub const MAX_CORNER_INPUTS: usize = 12;

/// How the search runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// The smallest compass step, as a fraction of each input's box width.
    pub tolerance: f64,
    /// Searches per output and sense, from its best points.
    pub starts: usize,
    /// Steps per search at most.
    pub max_steps: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            tolerance: 1e-3,
            starts: 2,
            max_steps: 200,
        }
    }
}

/// A batch of runs the search needs: runs `first..first + points.len()` at `points`
/// (the inputs, SI).
#[derive(Clone, Debug, PartialEq)]
pub struct Batch {
    pub number: u64,
    pub first: u64,
    pub points: Vec<Vec<f64>>,
    /// `corner` or `search`.
    pub stage: &'static str,
    /// The search step (0 for corners).
    pub step: u64,
}

/// The outputs at a batch's points (NaN for a failed run), or `None` while any is to run.
pub trait Evaluate {
    fn outputs(&mut self, batch: &Batch) -> Option<Vec<Vec<f64>>>;
}

/// Evaluation in memory (a closed-form function).
pub struct Function<F: Fn(&[f64]) -> Vec<f64>>(pub F);

impl<F: Fn(&[f64]) -> Vec<f64>> Evaluate for Function<F> {
    fn outputs(&mut self, batch: &Batch) -> Option<Vec<Vec<f64>>> {
        Some(batch.points.iter().map(|x| (self.0)(x)).collect())
    }
}

/// One extreme of one output.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Extreme {
    pub value: f64,
    /// The inputs that reach it (SI).
    pub inputs: Vec<f64>,
    /// Whether it lies at a corner of the box, or inside or on a face.
    pub at_corner: bool,
    /// The best corner's value (what a corner-only analysis would report).
    pub best_corner: f64,
}

/// An output's extremes over the box (`None` when every run failed).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OutputExtremes {
    pub min: Option<Extreme>,
    pub max: Option<Extreme>,
}

/// The search's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Found {
    pub outputs: Vec<OutputExtremes>,
    pub runs: u64,
    pub failed_runs: u64,
}

pub enum Progress {
    Done(Found),
    Needs(Batch),
}

/// An evaluated point: its scaled position, outputs, and whether it is a corner.
struct Evaluated {
    v: Vec<f64>,
    y: Vec<f64>,
    corner: bool,
}

struct Search {
    output: usize,
    /// +1 to maximise, −1 to minimise.
    sense: f64,
    v: Vec<f64>,
    value: f64,
    step: f64,
    done: bool,
}

struct Runner<'a> {
    boxes: &'a [(f64, f64)],
    free: Vec<usize>,
    eval: &'a mut dyn Evaluate,
    next_id: u64,
    next_batch: u64,
    seen: Vec<Evaluated>,
}

impl Runner<'_> {
    /// The inputs at scaled position `v` (free inputs only; the others at their value).
    fn inputs(&self, v: &[f64]) -> Vec<f64> {
        let mut x: Vec<f64> = self.boxes.iter().map(|b| b.0).collect();
        for (k, &j) in self.free.iter().enumerate() {
            let (lo, hi) = self.boxes[j];
            // the ends exactly, so a corner is the box's own corner
            x[j] = match v[k] {
                0.0 => lo,
                1.0 => hi,
                t => lo + t * (hi - lo),
            };
        }
        x
    }

    /// Evaluates `points` (scaled) as one batch, each distinct point once.
    fn evaluate(
        &mut self,
        points: Vec<Vec<f64>>,
        stage: &'static str,
        step: u64,
    ) -> Result<Vec<Vec<f64>>, Batch> {
        let key = |v: &[f64]| v.iter().map(|t| t.to_bits()).collect::<Vec<u64>>();
        let mut distinct: Vec<Vec<f64>> = Vec::new();
        let mut index: std::collections::HashMap<Vec<u64>, usize> = Default::default();
        let slot: Vec<usize> = points
            .iter()
            .map(|v| {
                *index.entry(key(v)).or_insert_with(|| {
                    distinct.push(v.clone());
                    distinct.len() - 1
                })
            })
            .collect();
        let batch = Batch {
            number: self.next_batch,
            first: self.next_id,
            points: distinct.iter().map(|v| self.inputs(v)).collect(),
            stage,
            step,
        };
        let y = self.eval.outputs(&batch).ok_or(batch)?;
        self.next_id += distinct.len() as u64;
        self.next_batch += 1;
        for (v, y) in distinct.into_iter().zip(&y) {
            self.seen.push(Evaluated {
                corner: v.iter().all(|&t| t == 0.0 || t == 1.0),
                v,
                y: y.clone(),
            });
        }
        Ok(slot.into_iter().map(|k| y[k].clone()).collect())
    }
}

/// Searches the extremes of the outputs numbered `outputs` (indices into each run's
/// outputs) over `boxes` (per input, lower and upper end; equal ends hold an input fixed).
pub fn search(
    boxes: &[(f64, f64)],
    outputs: &[usize],
    settings: &Settings,
    eval: &mut dyn Evaluate,
) -> Progress {
    let free: Vec<usize> = (0..boxes.len())
        .filter(|&j| boxes[j].1 > boxes[j].0)
        .collect();
    let mut r = Runner {
        boxes,
        free,
        eval,
        next_id: 0,
        next_batch: 0,
        seen: Vec::new(),
    };
    match run(&mut r, outputs, settings) {
        Ok(()) => Progress::Done(found(&r, outputs)),
        Err(b) => Progress::Needs(b),
    }
}

fn run(r: &mut Runner, outputs: &[usize], settings: &Settings) -> Result<(), Batch> {
    let d = r.free.len();
    let centre = vec![0.5; d];
    if d <= MAX_CORNER_INPUTS {
        let mut points = vec![centre];
        points.extend((0..1u64 << d).map(|c| {
            (0..d)
                .map(|j| if c >> j & 1 == 1 { 1.0 } else { 0.0 })
                .collect()
        }));
        r.evaluate(points, "corner", 0)?;
    } else {
        let mut points = vec![centre.clone()];
        for j in 0..d {
            for end in [0.0, 1.0] {
                let mut v = centre.clone();
                v[j] = end;
                points.push(v);
            }
        }
        let y = r.evaluate(points, "corner", 0)?;
        let mut corners = Vec::new();
        for &k in outputs {
            let up: Vec<f64> = (0..d)
                .map(|j| {
                    if y[2 + 2 * j][k] >= y[1 + 2 * j][k] {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect();
            corners.push(up.iter().map(|t| 1.0 - t).collect());
            corners.push(up);
        }
        r.evaluate(corners, "corner", 0)?;
    }
    if d == 0 {
        return Ok(());
    }
    // the searches start from the best distinct points of each output and sense
    let mut searches: Vec<Search> = Vec::new();
    for &k in outputs {
        for sense in [-1.0, 1.0] {
            let mut order: Vec<&Evaluated> = r.seen.iter().filter(|e| e.y[k].is_finite()).collect();
            order.sort_by(|a, b| (sense * b.y[k]).total_cmp(&(sense * a.y[k])));
            for e in order.into_iter().take(settings.starts) {
                searches.push(Search {
                    output: k,
                    sense,
                    v: e.v.clone(),
                    value: e.y[k],
                    step: 0.25,
                    done: false,
                });
            }
        }
    }
    for step in 1..=settings.max_steps {
        let active: Vec<usize> = (0..searches.len()).filter(|&s| !searches[s].done).collect();
        if active.is_empty() {
            break;
        }
        let mut points = Vec::new();
        let mut owner = Vec::new();
        for &s in &active {
            let sr = &searches[s];
            for j in 0..d {
                for dir in [-1.0, 1.0] {
                    let mut v = sr.v.clone();
                    v[j] = (v[j] + dir * sr.step).clamp(0.0, 1.0);
                    if v[j] != sr.v[j] {
                        points.push(v);
                        owner.push(s);
                    }
                }
            }
        }
        let y = r.evaluate(points.clone(), "search", step)?;
        for &s in &active {
            let sr = &mut searches[s];
            let best = (0..points.len())
                .filter(|&p| owner[p] == s && y[p][sr.output].is_finite())
                .max_by(|&a, &b| {
                    (sr.sense * y[a][sr.output]).total_cmp(&(sr.sense * y[b][sr.output]))
                });
            match best {
                Some(p) if sr.sense * (y[p][sr.output] - sr.value) > 0.0 => {
                    sr.v = points[p].clone();
                    sr.value = y[p][sr.output];
                }
                _ => {
                    sr.step *= 0.5;
                    sr.done = sr.step < settings.tolerance;
                }
            }
        }
    }
    Ok(())
}

fn found(r: &Runner, outputs: &[usize]) -> Found {
    let extreme = |k: usize, sense: f64| -> Option<Extreme> {
        let ok = || r.seen.iter().filter(|e| e.y[k].is_finite());
        // the first point evaluated among equals: a corner before a search point
        let best = ok().fold(None, |best: Option<&Evaluated>, e| match best {
            Some(b) if sense * e.y[k] <= sense * b.y[k] => Some(b),
            _ => Some(e),
        })?;
        let best_corner = ok()
            .filter(|e| e.corner)
            .map(|e| e.y[k])
            .max_by(|a, b| (sense * a).total_cmp(&(sense * b)))
            .unwrap_or(f64::NAN);
        Some(Extreme {
            value: best.y[k],
            inputs: r.inputs(&best.v),
            at_corner: best.corner,
            best_corner,
        })
    };
    Found {
        outputs: outputs
            .iter()
            .map(|&k| OutputExtremes {
                min: extreme(k, -1.0),
                max: extreme(k, 1.0),
            })
            .collect(),
        runs: r.next_id,
        failed_runs: r
            .seen
            .iter()
            .filter(|e| outputs.iter().any(|&k| !e.y[k].is_finite()))
            .count() as u64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn done(p: Progress) -> Found {
        match p {
            Progress::Done(f) => f,
            Progress::Needs(_) => panic!("a function never waits"),
        }
    }

    #[test]
    fn a_linear_stack_has_its_extremes_at_the_corners() {
        let a = [1.5, -2.0, 0.5, 3.0];
        let boxes = [(-1.0, 1.0), (0.0, 2.0), (10.0, 10.5), (-0.1, 0.3)];
        let f = |x: &[f64]| vec![a.iter().zip(x).map(|(a, x)| a * x).sum::<f64>()];
        let got = done(search(&boxes, &[0], &Settings::default(), &mut Function(f)));
        let (mut lo, mut hi) = (0.0, 0.0);
        for (a, b) in a.iter().zip(&boxes) {
            lo += (a * b.0).min(a * b.1);
            hi += (a * b.0).max(a * b.1);
        }
        let max = got.outputs[0].max.as_ref().unwrap();
        let min = got.outputs[0].min.as_ref().unwrap();
        assert_eq!(max.value, hi);
        assert_eq!(min.value, lo);
        assert!(max.at_corner && min.at_corner);
        assert_eq!(max.inputs, vec![1.0, 0.0, 10.5, 0.3]);
    }

    #[test]
    fn an_interior_maximum_is_found_to_the_tolerance() {
        let f = |x: &[f64]| vec![-(x[0] - 0.3).powi(2) + x[1]];
        let got = done(search(
            &[(0.0, 1.0), (0.0, 1.0)],
            &[0],
            &Settings::default(),
            &mut Function(f),
        ));
        let max = got.outputs[0].max.as_ref().unwrap();
        assert!((max.value - 1.0).abs() < 1e-6, "{}", max.value);
        assert!((max.inputs[0] - 0.3).abs() < 1e-3 && max.inputs[1] == 1.0);
        assert!(!max.at_corner);
        assert!((max.best_corner - (1.0 - 0.09)).abs() < 1e-12);
    }
}
