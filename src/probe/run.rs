//! A run that produces probe values: it steps a simulation, observes its probes, may stop
//! once every probe is known, closes the refinement window at its event probe (`refine:
//! { until: … }`), and extrapolates over the window when the scene asks for it (`refine:
//! { extrapolate: true }`).
//!
//! Extrapolation (Richardson): where the window opens, the run forks. The coarse branch
//! takes the window at its step h_w, the fine branch (the one the caller keeps) at h_w/2;
//! everything before the fork is shared, so probes known by then are identical in both.
//! Each probe is reported as 2 f(h_w/2) − f(h_w), which cancels the error that is first
//! order in h_w: the friction of contacts sliding under turning loads leaves such an error
//! in the Moreau–Jean step, smooth in h_w once impacts are located.

use crate::integrator::{RunStats, SimError, Simulation, StepReport};
use crate::probe::curve::Curve;
use crate::probe::{Probe, ProbeRecorder};

/// Which branch a step belongs to: the main one (the only one without extrapolation, the
/// fine one after the fork) or the coarse one of an extrapolated window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Branch {
    Main,
    Coarse,
}

/// The outcome of [`run_probes`].
pub struct ProbeRun {
    /// The main branch's simulation where it stopped.
    pub sim: Simulation,
    /// Each probe's value (extrapolated when the run forked), or why it has none.
    pub values: Vec<Result<f64, String>>,
    /// Each curve's values on its grid (extrapolated cell by cell when the run forked).
    pub curves: Vec<Vec<f64>>,
    /// The first failure of either branch; the values are then those up to the failure.
    pub error: Option<String>,
    /// Both branches' diagnostics: counts summed (shared steps once), extremes combined.
    pub stats: RunStats,
    /// Where the run forked (the window's opening), if it did.
    pub forked_at: Option<f64>,
}

/// Runs `sim` to `t_end` with `probes` and `curves` (stopping early once all are known
/// if `stop_when_known`), calling `observe` after every step of either branch.
pub fn run_probes(
    mut sim: Simulation,
    probes: &[Probe],
    curves: &[Curve],
    t_end: f64,
    stop_when_known: bool,
    mut observe: impl FnMut(&Simulation, &StepReport, Branch),
) -> ProbeRun {
    let extrapolate = sim.schedule.refine.as_ref().is_some_and(|r| r.extrapolate);
    let mut recorder = ProbeRecorder::new(probes, curves);
    recorder.observe(&sim);
    let mut stop = Stop {
        t_end,
        when_known: stop_when_known,
        at_fork: extrapolate,
    };
    let mut outcome = advance(&mut sim, &mut recorder, &stop, |s, r| {
        observe(s, r, Branch::Main)
    });
    let mut coarse = None;
    if outcome == Ok(Reached::Fork) {
        let (mut c, mut c_recorder) = (sim.clone(), recorder.clone());
        stop.at_fork = false;
        let c_outcome = advance(&mut c, &mut c_recorder, &stop, |s, r| {
            observe(s, r, Branch::Coarse)
        });
        let fork_stats = sim.stats;
        let forked_at = sim.state.t;
        sim.schedule.halve_refine_step();
        outcome = advance(&mut sim, &mut recorder, &stop, |s, r| {
            observe(s, r, Branch::Main)
        });
        coarse = Some((c, c_recorder, c_outcome, fork_stats, forked_at));
    }
    let mut error = outcome.err().map(|e| e.to_string());
    let mut curves = recorder.curves();
    let mut values = recorder.finish_each(sim.state.t);
    let mut stats = sim.stats;
    let mut forked_at = None;
    if let Some((c, c_recorder, c_outcome, fork_stats, at)) = coarse {
        forked_at = Some(at);
        if let (None, Err(e)) = (&error, c_outcome) {
            error = Some(format!("{e} (in the extrapolation's coarse branch)"));
        }
        for (fine, coarse) in curves.iter_mut().zip(c_recorder.curves()) {
            for (f, c) in fine.iter_mut().zip(coarse) {
                *f = 2.0 * *f - c;
            }
        }
        let coarse_values = c_recorder.finish_each(c.state.t);
        values = values
            .into_iter()
            .zip(coarse_values)
            .map(|(fine, coarse)| match (fine, coarse) {
                (Ok(f), Ok(c)) => Ok(2.0 * f - c),
                (Err(e), _) => Err(e),
                (Ok(_), Err(e)) => Err(format!("{e} (in the extrapolation's coarse branch)")),
            })
            .collect();
        stats = merged(&sim.stats, &c.stats, &fork_stats);
    }
    ProbeRun {
        sim,
        values,
        curves,
        error,
        stats,
        forked_at,
    }
}

/// When a branch stops stepping.
struct Stop {
    t_end: f64,
    when_known: bool,
    /// Stop where the refinement window opens (to fork there).
    at_fork: bool,
}

#[derive(Debug, PartialEq)]
enum Reached {
    End,
    Fork,
}

/// Steps one branch until `stop` says so.
fn advance(
    sim: &mut Simulation,
    recorder: &mut ProbeRecorder,
    stop: &Stop,
    mut observe: impl FnMut(&Simulation, &StepReport),
) -> Result<Reached, SimError> {
    while !sim.reached(stop.t_end) {
        let opened = sim.refine_window_end().is_some();
        // a controlled run ends a step at each probe's instant; a fixed one keeps its grid
        let until = match sim.params.step_control {
            Some(_) => recorder
                .next_instant(sim.state.t)
                .map_or(stop.t_end, |x| x.min(stop.t_end)),
            None => stop.t_end,
        };
        let report = sim.step_until(until)?;
        recorder.observe(sim);
        // the window's closing event (a no-op before it opens and once it has closed)
        let closing = sim.schedule.refine.as_ref().and_then(|r| r.until);
        if closing.is_some_and(|k| recorder.known(k)) {
            sim.close_refine_window();
        }
        observe(sim, &report);
        if stop.when_known && recorder.done() {
            break;
        }
        if stop.at_fork && !opened && sim.refine_window_end().is_some() {
            return Ok(Reached::Fork);
        }
    }
    Ok(Reached::End)
}

/// The diagnostics of a forked run: the fine branch's, plus what the coarse branch did
/// after the fork (`fork` holds the counts at the fork, shared by both).
fn merged(fine: &RunStats, coarse: &RunStats, fork: &RunStats) -> RunStats {
    let after = |c: u64, f: u64| c - f;
    RunStats {
        steps: fine.steps + after(coarse.steps, fork.steps),
        solver_failures: fine.solver_failures + after(coarse.solver_failures, fork.solver_failures),
        newton_failures: fine.newton_failures + after(coarse.newton_failures, fork.newton_failures),
        projection_failures: fine.projection_failures
            + after(coarse.projection_failures, fork.projection_failures),
        impact_splits: fine.impact_splits + after(coarse.impact_splits, fork.impact_splits),
        halved_steps: fine.halved_steps + after(coarse.halved_steps, fork.halved_steps),
        plastic_steps: fine.plastic_steps + after(coarse.plastic_steps, fork.plastic_steps),
        sank_through: fine.sank_through + after(coarse.sank_through, fork.sank_through),
        squeezed_steps: fine.squeezed_steps + after(coarse.squeezed_steps, fork.squeezed_steps),
        rejected_steps: fine.rejected_steps + after(coarse.rejected_steps, fork.rejected_steps),
        max_penetration: fine.max_penetration.max(coarse.max_penetration),
        max_joint_violation: fine.max_joint_violation.max(coarse.max_joint_violation),
        max_joint_angle_violation: fine
            .max_joint_angle_violation
            .max(coarse.max_joint_angle_violation),
        max_solver_residual: fine.max_solver_residual.max(coarse.max_solver_residual),
        max_active_contacts: fine.max_active_contacts.max(coarse.max_active_contacts),
        max_active_set_passes: fine.max_active_set_passes.max(coarse.max_active_set_passes),
        max_projection_iterations: fine
            .max_projection_iterations
            .max(coarse.max_projection_iterations),
    }
}
