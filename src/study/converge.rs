//! `mc-study converge`: the accuracy–cost trade of a study's fidelity. The nominal sample
//! (the scene as written) and K samples of the study's design run over a ladder of
//! fidelities (step sizes, solver tolerances, schemes); every output is compared with a
//! reference run at the finest setting, and the error is set against the output's
//! Monte-Carlo σ when a result directory gives it. The cheapest fidelity whose error on
//! every output stays below the target is recommended as a study `fidelity` block.

use super::sample_run::Subject;
use super::summary::Summary;
use super::Study;
use crate::integrator::{IntegrationParameters, Preset, Scheme, StepControl};
use crate::scene::parameter_paths::written;
use crate::scene::schema::{IntegratorSpec, StepControlBlock, StepControlSpec, ToleranceSpec};
use crate::scene::Tuning;
use rayon::prelude::*;
use serde_saphyr::{Location, Spanned};
use std::fmt::Write;

/// A setting in exponent form without the round-off of the ladder's products (1e-4, not
/// 9.999999999999999e-5).
fn exp_form(x: f64) -> String {
    let rounded: f64 = format!("{x:.6e}").parse().unwrap_or(x);
    format!("{rounded:e}")
}

/// One rung of the ladder: the integrator settings that trade accuracy for speed.
#[derive(Clone, Debug, PartialEq)]
pub struct Fidelity {
    pub h: f64,
    pub scheme: Scheme,
    pub theta: f64,
    pub solver_tolerance: f64,
    pub projection_tolerance: f64,
    /// Impacts located within their steps (`IntegrationParameters::locate_impacts`).
    pub locate_impacts: bool,
    /// Whether the scene's refinement window is extrapolated (`refine.extrapolate`); `None`
    /// leaves it as the scene has it.
    pub extrapolate: Option<bool>,
    /// The preset this rung is, if any (`fast`, `balanced`, `accurate`).
    pub preset: Option<Preset>,
    /// The step-size control of an adaptive rung (`h` is then its first step); `None` for
    /// a fixed step.
    pub step_control: Option<StepControl>,
}

impl Fidelity {
    pub fn of(p: &IntegrationParameters) -> Fidelity {
        Fidelity {
            h: p.h,
            scheme: p.scheme,
            theta: p.theta,
            solver_tolerance: p.solver.tolerance,
            projection_tolerance: p.projection_tolerance,
            locate_impacts: p.locate_impacts,
            extrapolate: None,
            preset: None,
            step_control: p.step_control.clone(),
        }
    }

    /// The rung of a preset applied to the scene's settings `p`.
    pub fn preset(preset: Preset, p: &IntegrationParameters) -> Fidelity {
        let mut q = p.clone();
        preset.apply(&mut q);
        Fidelity {
            preset: Some(preset),
            ..Fidelity::of(&q)
        }
    }

    /// The rung as a tuning layer of a scene: every setting it fixes, so that a scene
    /// rebuilt for a sample runs at the rung too.
    fn tuning(&self) -> Tuning {
        let tolerance = |t: f64| {
            Some(ToleranceSpec {
                tolerance: Some(written(t)),
                max_iterations: None,
            })
        };
        let block = IntegratorSpec {
            h: Some(written(self.h)),
            theta: Some(written(self.theta)),
            scheme: Some(Spanned::new(
                self.scheme.name().to_string(),
                Location::UNKNOWN,
                Location::UNKNOWN,
            )),
            solver: tolerance(self.solver_tolerance),
            projection: tolerance(self.projection_tolerance),
            locate_impacts: Some(self.locate_impacts),
            step_control: Some(match &self.step_control {
                None => StepControlSpec::Off,
                Some(c) => StepControlSpec::On(Box::new(StepControlBlock {
                    tolerance: Some(written(c.tolerance)),
                    h_max: Some(written(c.h_max)),
                    h_min: Some(written(c.h_min)),
                    length: Some(written(c.length)),
                    speed: Some(written(c.speed)),
                })),
            }),
            ..IntegratorSpec::default()
        };
        Tuning {
            block,
            origin: format!("converge rung `{}`", self.label()),
        }
    }

    pub fn label(&self) -> String {
        let preset = self
            .preset
            .map_or(String::new(), |p| format!("{}: ", p.name()));
        let located = if self.locate_impacts {
            " impacts located"
        } else {
            ""
        };
        let window = match self.extrapolate {
            Some(true) => " window extrapolated",
            Some(false) => " window not extrapolated",
            None => "",
        };
        let step = match &self.step_control {
            Some(c) => format!("τ={} adaptive", exp_form(c.tolerance)),
            None => format!("h={}", exp_form(self.h)),
        };
        format!(
            "{preset}{step} {} θ={} tol={} proj={}{located}{window}",
            self.scheme.name(),
            self.theta,
            exp_form(self.solver_tolerance),
            exp_form(self.projection_tolerance)
        )
    }

    /// The study YAML block selecting this fidelity (with, for a rung that changes the
    /// refinement window, what to change in the scene: a study's fidelity does not reach it).
    pub fn yaml(&self) -> String {
        let window = self.extrapolate.map_or(String::new(), |x| {
            format!("# and in the scene: refine: {{ …, extrapolate: {x} }}\n")
        });
        let block = match self.preset {
            Some(p) => format!("fidelity: {{ preset: {} }}\n", p.name()),
            None => format!(
                "fidelity:\n  h: {}\n  scheme: {}\n  theta: {}\n  solver: {{ tolerance: {} }}\n  projection: {{ tolerance: {} }}\n  locate_impacts: {}\n  step_control: {}\n",
                exp_form(self.h),
                self.scheme.name(),
                self.theta,
                exp_form(self.solver_tolerance),
                exp_form(self.projection_tolerance),
                self.locate_impacts,
                match &self.step_control {
                    None => "off".to_string(),
                    Some(c) => format!(
                        "{{ tolerance: {}, h_max: {} s, h_min: {} s, length: {} m, speed: {} m/s }}",
                        exp_form(c.tolerance),
                        exp_form(c.h_max),
                        exp_form(c.h_min),
                        exp_form(c.length),
                        exp_form(c.speed)
                    ),
                }
            ),
        };
        block + &window
    }
}

/// What to sweep.
#[derive(Clone, Debug)]
pub struct Ladder {
    pub fidelities: Vec<Fidelity>,
    pub reference: Fidelity,
    /// Design samples besides the nominal one.
    pub samples: u64,
}

impl Ladder {
    /// The default ladder around the scene's settings `p` (h₀, scheme, θ₀, tolerance τ₀,
    /// projection tolerance π₀): h₀ × {10, 5, 2, 1, ½}; τ₀ × 100 and τ₀ / 100; π₀ × 100;
    /// θ = 1 if θ₀ ≠ 1; impacts located or not, the other way from the scene (combined
    /// projection only); the other schemes; the `fast` and `accurate` presets; adaptive
    /// steps (`step_control`) at the tolerances of [`Ladder::adaptive`]. The reference is
    /// the fixed step h₀ / 10 at min(τ₀ / 100, 1e-8). Every rung but the adaptive ones and
    /// the presets runs at a fixed step, also where the scene controls its step.
    pub fn around(p: &IntegrationParameters, samples: u64) -> Ladder {
        let base = Fidelity {
            step_control: None,
            ..Fidelity::of(p)
        };
        let mut fidelities: Vec<Fidelity> = [10.0, 5.0, 2.0, 1.0, 0.5]
            .iter()
            .map(|k| Fidelity {
                h: base.h * k,
                ..base.clone()
            })
            .collect();
        for tol in [base.solver_tolerance * 100.0, base.solver_tolerance / 100.0] {
            fidelities.push(Fidelity {
                solver_tolerance: tol,
                ..base.clone()
            });
        }
        fidelities.push(Fidelity {
            projection_tolerance: base.projection_tolerance * 100.0,
            ..base.clone()
        });
        if base.theta != 1.0 {
            fidelities.push(Fidelity {
                theta: 1.0,
                ..base.clone()
            });
        }
        // only the combined scheme's activation loop finds the impacts to locate
        if base.scheme == Scheme::CombinedProjection {
            fidelities.push(Fidelity {
                locate_impacts: !base.locate_impacts,
                ..base.clone()
            });
        }
        for scheme in [
            Scheme::MoreauJean,
            Scheme::CombinedProjection,
            Scheme::DirectProjection,
        ] {
            if scheme != base.scheme {
                fidelities.push(Fidelity {
                    scheme,
                    ..base.clone()
                });
            }
        }
        for preset in [Preset::Fast, Preset::Accurate] {
            fidelities.push(Fidelity::preset(preset, p));
        }
        fidelities.extend(Ladder::adaptive(p));
        Ladder {
            fidelities,
            reference: Fidelity {
                h: base.h / 10.0,
                solver_tolerance: (base.solver_tolerance / 100.0).min(1e-8),
                ..base.clone()
            },
            samples,
        }
    }

    /// The adaptive rungs around the scene's settings `p`: with a step control of
    /// tolerance τ₀, τ₀ × {10, 1, 1/10}; without, τ ∈ {1e-3, 3e-4, 1e-4} with the control's
    /// defaults otherwise.
    pub fn adaptive(p: &IntegrationParameters) -> Vec<Fidelity> {
        let (control, factors) = match &p.step_control {
            Some(c) => (c.clone(), [10.0, 1.0, 0.1]),
            None => (StepControl::for_step(1e-3, p.h), [1.0, 0.3, 0.1]),
        };
        factors
            .iter()
            .map(|k| Fidelity {
                step_control: Some(StepControl {
                    tolerance: control.tolerance * k,
                    ..control.clone()
                }),
                ..Fidelity::of(p)
            })
            .collect()
    }

    /// The default ladder around a mechanism scene's settings: [`Ladder::around`] and, when
    /// the scene has a refinement window, its extrapolation the other way from the scene.
    pub fn around_scene(scene: &crate::scene::Scene, samples: u64) -> Ladder {
        let mut ladder = Ladder::around(&scene.params, samples);
        if let Some(r) = &scene.schedule.refine {
            ladder.fidelities.push(Fidelity {
                extrapolate: Some(!r.extrapolate),
                step_control: None,
                ..Fidelity::of(&scene.params)
            });
        }
        ladder
    }
}

/// Each output's Monte-Carlo σ from a summary: NaN for an output that is constant to
/// round-off (its errors are then relative to its value); `None` unless the summary has
/// every output and at least one with a spread.
pub fn sigma_of(summary: &Summary, outputs: &[String]) -> Option<Vec<f64>> {
    let sigma: Vec<f64> = outputs
        .iter()
        .map(|o| {
            let s = summary.output(o)?;
            let spread = s.sd > 0.0 && !s.constant;
            Some(if spread { s.sd } else { f64::NAN })
        })
        .collect::<Option<_>>()?;
    sigma.iter().any(|s| s.is_finite()).then_some(sigma)
}

/// An output whose values drift apart as h falls: its change between the two coarsest steps
/// and between the two finest, and those steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Drift {
    pub output: usize,
    pub coarse: f64,
    pub fine: f64,
    pub from: (f64, f64),
    pub to: (f64, f64),
}

/// One run: outputs (NaN where failed), its steps, wall time and the failure, if any.
#[derive(Clone, Debug)]
pub struct Run {
    pub outputs: Vec<f64>,
    /// Steps taken: the cost of a fidelity that does not depend on the machine or on
    /// how many runs share it.
    pub steps: u64,
    pub wall_ms: f64,
    pub error: Option<String>,
}

/// Every run of the sweep. `runs[f][s]`: fidelity f (the reference last), sample s (the
/// nominal first).
#[derive(Clone, Debug)]
pub struct Convergence {
    pub outputs: Vec<(String, String)>,
    pub fidelities: Vec<Fidelity>,
    pub sample_names: Vec<String>,
    pub runs: Vec<Vec<Run>>,
    /// Monte-Carlo σ per output, if known (NaN for an output without a spread).
    pub sigma: Option<Vec<f64>>,
    /// Why an output depends on the step size, where the scene says so at load time.
    pub cautions: Vec<Option<String>>,
}

/// Why an output is left out of the recommendation.
#[derive(Clone, Debug, PartialEq)]
pub enum LeftOut {
    /// Its probe is flagged at load time (the peak of an impulsive force).
    Flagged,
    /// Its values drift apart as h falls.
    Drifts(Drift),
}

/// Runs the ladder, every (fidelity, sample) run in parallel on the current rayon pool
/// (each run is independent and deterministic, so the results do not depend on the thread
/// count); `progress` is told each finished run, from the thread that ran it.
pub fn sweep(
    study: &Study,
    ladder: &Ladder,
    sigma: Option<Vec<f64>>,
    progress: impl Fn(&Fidelity, &str, &Run) + Sync,
) -> Result<Convergence, String> {
    let Subject::Mechanism(scene) = &study.subject else {
        return Err("converge needs a mechanism scene: a function scene has no fidelity".into());
    };
    let selected: Vec<usize> = study.outputs.iter().map(|o| o.index).collect();
    let mut samples: Vec<(String, Vec<(&str, f64)>)> = vec![("nominal".into(), Vec::new())];
    for i in 0..ladder.samples.min(study.runs()) {
        let x = study.inputs(i);
        let params = study
            .parameters
            .iter()
            .map(|p| p.path.as_str())
            .zip(x)
            .collect();
        samples.push((format!("sample {i}"), params));
    }
    let mut fidelities = ladder.fidelities.clone();
    fidelities.push(ladder.reference.clone());
    let subjects: Vec<Subject> = fidelities
        .iter()
        .map(|f| {
            let mut s = (**scene).clone();
            s.tune(f.tuning()).map_err(|e| e.to_string())?;
            if let Some(x) = f.extrapolate {
                // in the document too, so that a scene rebuilt for a sample keeps it
                if let Some(r) = s.spec.refine.as_mut() {
                    r.value.extrapolate = x;
                }
                if let Some(r) = s.schedule.refine.as_mut() {
                    r.extrapolate = x;
                }
            }
            Ok(Subject::Mechanism(Box::new(s)))
        })
        .collect::<Result<_, String>>()?;
    let jobs: Vec<(usize, usize)> = (0..fidelities.len())
        .flat_map(|f| (0..samples.len()).map(move |s| (f, s)))
        .collect();
    let done: Vec<Run> = jobs
        .par_iter()
        .map(|&(f, s)| {
            let (name, params) = &samples[s];
            let o = subjects[f].run(params, &selected);
            let run = Run {
                outputs: o.outputs,
                steps: o.diagnostics.steps,
                wall_ms: o.diagnostics.wall_ms,
                error: o.error,
            };
            progress(&fidelities[f], name, &run);
            run
        })
        .collect();
    let runs: Vec<Vec<Run>> = done.chunks(samples.len()).map(<[Run]>::to_vec).collect();
    Ok(Convergence {
        outputs: study
            .outputs
            .iter()
            .map(|o| (o.name.clone(), o.unit.clone()))
            .collect(),
        fidelities,
        sample_names: samples.into_iter().map(|(n, _)| n).collect(),
        runs,
        sigma,
        cautions: study.outputs.iter().map(|o| o.caution.clone()).collect(),
    })
}

impl Convergence {
    fn reference(&self) -> &[Run] {
        self.runs.last().expect("the reference row")
    }

    /// Whether output k is one value to round-off: in the study's results (no σ), or in
    /// every run of the sweep. Its errors are relative to its value, whatever σ says.
    pub fn constant(&self, k: usize) -> bool {
        let no_spread = self.sigma.as_ref().is_some_and(|s| s[k].is_nan());
        let values: Vec<f64> = self.runs.iter().flatten().map(|r| r.outputs[k]).collect();
        no_spread || crate::study::statistics::is_constant(&values)
    }

    /// What an error of output k is measured in: its Monte-Carlo σ when known and the
    /// output has a spread, else |reference| (or 1 where that is zero).
    fn scale(&self, k: usize, reference: f64) -> f64 {
        match &self.sigma {
            Some(s) if !self.constant(k) => s[k],
            _ if reference != 0.0 => reference.abs(),
            _ => 1.0,
        }
    }

    /// Whether the errors of output k are in units of its Monte-Carlo σ.
    pub fn in_sigma(&self, k: usize) -> bool {
        self.sigma.is_some() && !self.constant(k)
    }

    /// Largest error of output k at fidelity f over the samples: in units of the
    /// Monte-Carlo σ when known, else relative to |reference|. Infinite if a run failed.
    /// An optional output empty in both runs agrees; empty in one of them, it does not.
    pub fn error(&self, f: usize, k: usize) -> f64 {
        self.runs[f]
            .iter()
            .zip(self.reference())
            .map(|(r, reference)| {
                let (y, y0) = (r.outputs[k], reference.outputs[k]);
                if r.error.is_some() || reference.error.is_some() {
                    return f64::INFINITY;
                }
                match (y.is_nan(), y0.is_nan()) {
                    (true, true) => return 0.0,
                    (false, false) => {}
                    _ => return f64::INFINITY,
                }
                (y - y0).abs() / self.scale(k, y0)
            })
            .fold(0.0, f64::max)
    }

    /// The outputs left out of the recommendation at `target`, and why.
    pub fn left_out(&self, target: f64) -> Vec<(usize, LeftOut)> {
        // a measured drift says more than the flag
        let mut out: Vec<(usize, LeftOut)> = self
            .step_dependent(target)
            .into_iter()
            .map(|d| (d.output, LeftOut::Drifts(d)))
            .collect();
        for k in 0..self.outputs.len() {
            if self.cautions[k].is_some() && !out.iter().any(|(j, _)| *j == k) {
                out.push((k, LeftOut::Flagged));
            }
        }
        out.sort_by_key(|(k, _)| *k);
        out
    }

    /// Median wall time per sample (ms) at fidelity f.
    pub fn cost(&self, f: usize) -> f64 {
        let mut w: Vec<f64> = self.runs[f].iter().map(|r| r.wall_ms).collect();
        w.sort_by(f64::total_cmp);
        w[w.len() / 2]
    }

    /// Median steps per sample at fidelity f.
    pub fn steps(&self, f: usize) -> u64 {
        let mut n: Vec<u64> = self.runs[f].iter().map(|r| r.steps).collect();
        n.sort_unstable();
        n[n.len() / 2]
    }

    /// The cheapest fidelity (not the reference) whose error on every output that
    /// means something at any step (not [`Convergence::left_out`]) is below `target`.
    pub fn recommend(&self, target: f64) -> Option<usize> {
        let left_out: Vec<usize> = self.left_out(target).iter().map(|(k, _)| *k).collect();
        (0..self.fidelities.len() - 1)
            .filter(|&f| {
                (0..self.outputs.len())
                    .filter(|k| !left_out.contains(k))
                    .all(|k| self.error(f, k) < target)
            })
            .min_by(|&a, &b| self.cost(a).total_cmp(&self.cost(b)))
    }

    /// The failed runs' reasons (first line), each with its count and its first rung
    /// and sample, most frequent first.
    pub fn failures(&self) -> Vec<(String, usize, String)> {
        let mut out: Vec<(String, usize, String)> = Vec::new();
        for (f, runs) in self.runs.iter().enumerate() {
            for (j, r) in runs.iter().enumerate() {
                let Some(e) = &r.error else { continue };
                let reason = e.lines().next().unwrap_or("").to_string();
                match out.iter_mut().find(|(m, _, _)| *m == reason) {
                    Some(x) => x.1 += 1,
                    None => out.push((
                        reason,
                        1,
                        format!("{}, {}", self.fidelities[f].label(), self.sample_names[j]),
                    )),
                }
            }
        }
        out.sort_by_key(|x| std::cmp::Reverse(x.1));
        out
    }

    /// The rungs that differ from each other in h only, and the reference, coarse to fine:
    /// the step ladder along which an output should settle.
    fn step_ladder(&self) -> Vec<usize> {
        let same_but_h = |a: &Fidelity, b: &Fidelity| {
            a.scheme == b.scheme
                && a.theta == b.theta
                && a.solver_tolerance == b.solver_tolerance
                && a.projection_tolerance == b.projection_tolerance
                && a.locate_impacts == b.locate_impacts
                && a.extrapolate.is_none()
                && a.preset.is_none()
                && a.step_control.is_none()
        };
        let n = self.fidelities.len() - 1;
        let mut ladder: Vec<usize> = (0..n)
            .filter(|&f| same_but_h(&self.fidelities[f], &self.fidelities[0]))
            .collect();
        ladder.sort_by(|&a, &b| self.fidelities[b].h.total_cmp(&self.fidelities[a].h));
        ladder.push(n);
        ladder
    }

    /// The outputs whose values move further apart as h falls: along the step ladder, the
    /// change between the two finest steps is more than twice the change between the two
    /// coarsest (largest over the samples) and larger than `target` (in σ, or relative):
    /// a change below the accuracy asked for is no drift, whatever the ratio. Such an
    /// output depends on the step size itself: the peak of an impulsive force (∝ 1/h in a
    /// rigid model) or a chaotic quantity. Refining h does not converge it.
    pub fn step_dependent(&self, target: f64) -> Vec<Drift> {
        let ladder = self.step_ladder();
        if ladder.len() < 3 {
            return Vec::new();
        }
        let change = |f: usize, g: usize, k: usize| {
            self.runs[f]
                .iter()
                .zip(&self.runs[g])
                .map(|(a, b)| (a.outputs[k] - b.outputs[k]).abs())
                .fold(0.0f64, |m, d| if d.is_finite() { m.max(d) } else { m })
        };
        let last = ladder.len() - 1;
        (0..self.outputs.len())
            .filter_map(|k| {
                let coarse = change(ladder[0], ladder[1], k);
                let fine = change(ladder[last - 1], ladder[last], k);
                let size = self
                    .reference()
                    .iter()
                    .map(|r| r.outputs[k].abs())
                    .fold(0.0, f64::max);
                let scale = self.scale(k, size);
                (fine > 2.0 * coarse && fine > target * scale).then_some(Drift {
                    output: k,
                    coarse,
                    fine,
                    from: (self.fidelities[ladder[0]].h, self.fidelities[ladder[1]].h),
                    to: (
                        self.fidelities[ladder[last - 1]].h,
                        self.fidelities[ladder[last]].h,
                    ),
                })
            })
            .collect()
    }

    /// The printed table: one row per fidelity, its cost (time and steps a sample) and each
    /// output's error.
    fn table(&self) -> String {
        let unit = if self.sigma.is_some() {
            "error / Monte-Carlo σ (max over samples)"
        } else {
            "relative error (max over samples)"
        };
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{unit}; reference: {}",
            self.fidelities.last().unwrap().label()
        );
        let _ = write!(s, "{:<72} {:>10} {:>8}", "fidelity", "ms/sample", "steps");
        for (name, _) in &self.outputs {
            let _ = write!(s, " {:>12}", short(name));
        }
        s.push('\n');
        for f in 0..self.fidelities.len() {
            let _ = write!(
                s,
                "{:<72} {:>10.1} {:>8}",
                self.fidelities[f].label(),
                self.cost(f),
                self.steps(f)
            );
            for k in 0..self.outputs.len() {
                if f + 1 == self.fidelities.len() {
                    let _ = write!(s, " {:>12}", "ref");
                } else {
                    let mark = if self.in_sigma(k) || self.sigma.is_none() {
                        ""
                    } else {
                        "r"
                    };
                    let _ = write!(s, " {:>12}", format!("{:.2e}{mark}", self.error(f, k)));
                }
            }
            s.push('\n');
        }
        s
    }

    /// Every run as CSV: fidelity, sample, output, value, reference, error, wall ms, steps.
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "h,step_tolerance,scheme,theta,solver_tolerance,projection_tolerance,locate_impacts,extrapolate,preset,sample,output,unit,value,reference,abs_error,wall_ms,steps,error\n",
        );
        let reference = self.reference();
        for (f, fid) in self.fidelities.iter().enumerate() {
            for (j, run) in self.runs[f].iter().enumerate() {
                for (k, (name, unit)) in self.outputs.iter().enumerate() {
                    let (y, y0) = (run.outputs[k], reference[j].outputs[k]);
                    let _ = writeln!(
                        s,
                        "{:e},{},{},{},{:e},{:e},{},{},{},{},{},{},{:e},{:e},{:e},{:.3},{},{}",
                        fid.h,
                        fid.step_control
                            .as_ref()
                            .map_or(String::new(), |c| format!("{:e}", c.tolerance)),
                        fid.scheme.name(),
                        fid.theta,
                        fid.solver_tolerance,
                        fid.projection_tolerance,
                        fid.locate_impacts,
                        fid.extrapolate.map_or(String::new(), |x| x.to_string()),
                        fid.preset.map_or("", |p| p.name()),
                        self.sample_names[j],
                        name,
                        unit,
                        y,
                        y0,
                        (y - y0).abs(),
                        run.wall_ms,
                        run.steps,
                        run.error.as_deref().unwrap_or("").replace([',', '\n'], ";")
                    );
                }
            }
        }
        s
    }
}

/// Column heading: an output name cut to 12 characters.
fn short(name: &str) -> String {
    name.chars().take(12).collect()
}

impl Convergence {
    /// The table, then the constant outputs, the failed runs with their reasons, and a
    /// verdict for each output left out of the recommendation at `target`.
    pub fn describe(&self, target: f64) -> String {
        let mut s = self.table();
        for k in (0..self.outputs.len()).filter(|&k| self.constant(k)) {
            let (name, _) = &self.outputs[k];
            let r = if self.sigma.is_some() { " (r)" } else { "" };
            let _ = writeln!(
                s,
                "{name}: constant to round-off; its errors{r} are relative to its value, not to a spread, and it stays out of the plot"
            );
        }
        for (reason, n, first) in self.failures() {
            let _ = writeln!(s, "failed ×{n} (shown as inf; first at {first}): {reason}");
        }
        for (k, why) in self.left_out(target) {
            let (name, unit) = &self.outputs[k];
            let unit = if unit == "1" { "" } else { unit.as_str() };
            let _ = match why {
                LeftOut::Flagged => writeln!(
                    s,
                    "(!) {name}: left out of the recommendation: flagged at load time, though it did not drift on this ladder: {}",
                    self.cautions[k].as_deref().unwrap_or("")
                ),
                LeftOut::Drifts(d) => writeln!(
                    s,
                    "(!) {name}: does not converge with h: it changes by {:.3e} {unit} from h = {:e} to {:e} s, and by {:.3e} {unit} from h = {:e} to {:e} s, beyond the target. It depends on the step size itself (the peak of an impulsive force grows as 1/h in a rigid model; a chaotic quantity, or a force held by static friction, whose value depends on how the mechanism came to rest, changes at random): refining h makes it no better. Measure a converged quantity instead (an impact impulse, a window mean, a quasi-static peak), or report its statistics over a study. It is left out of the recommendation.",
                    d.coarse, d.from.0, d.from.1, d.fine, d.to.0, d.to.1
                ),
            };
        }
        s
    }
}
