//! The phases of an integration: a settling phase that brings a preloaded mechanism to rest
//! before the dynamics of interest, and a window of finer steps opened by a contact event.
//! They say how to integrate, not what the system is, so they live beside the integration
//! parameters and not in the immutable [`Model`]; a simulation owns its schedule (the fine
//! branch of an extrapolated window halves its own window's step).

use crate::mechanics::model::Candidate;
use crate::mechanics::Model;

/// The phases of a run; both optional.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Schedule {
    /// The settling phase of a preloaded mechanism, if the scene has one.
    pub settle: Option<Settle>,
    /// A window of finer steps that a contact's first closing opens, if the scene has one.
    pub refine: Option<Refine>,
}

/// A window of finer steps (`refine:` in the scene): from the end of the step in which one
/// of the `trigger` candidates first carries an impulse, for `duration`, the step is
/// `step_ratio` times h (the last one ending at the window's end). A mechanism's trip, a
/// burst of blows and sliding under turning loads, needs a finer step than the approach
/// before it and the swing after it, and it starts at a contact event whose time changes
/// from sample to sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Refine {
    /// The contact candidates (one pair or clearance joint) whose closing opens the window.
    pub trigger: Vec<usize>,
    /// Length of the window (s): the longest it lasts.
    pub duration: f64,
    /// The event probe (its index among the scene's value and event probes) whose
    /// happening closes the window at the end of its step, if it comes before `duration`
    /// is over: a run that observes probes closes it (`probe::run`). The events that need
    /// the fine step end at different times in different samples; a window that ends with
    /// them does not run its fine steps on through what follows.
    pub until: Option<usize>,
    /// The window's step over the integrator's h: a ratio, so that a fidelity that changes
    /// h refines the window with it.
    pub step_ratio: f64,
    /// The step over the integrator's h from the settle's end until the window opens
    /// (`None`: h). An approach with the mechanism at rest (an actuator in free flight
    /// towards it) needs a coarser step than the swing after the window.
    pub approach_ratio: Option<f64>,
    /// Whether runs with probes take the window twice, at its step and at half of it, and
    /// report each probe as 2 f(h/2) − f(h) (`probe::run`): Richardson extrapolation, which
    /// removes the first-order error that the window's sliding contacts leave.
    pub extrapolate: bool,
}

/// A settling phase (`settle:` in the scene): until `until` every moving body is damped in
/// proportion to its mass, F = −α M v, and friction may be withdrawn from some contacts. A
/// preloaded mechanism that starts from its nominal assembly then comes to rest in the
/// equilibrium its clearances give. Without friction that equilibrium is unique; a
/// frictional one is any state inside the friction cones, so where the chain stops depends
/// on the path it settled along, and that path (impacts, bounces, stick–slip) changes with
/// the step size.
#[derive(Clone, Debug, PartialEq)]
pub struct Settle {
    /// End of the phase (s).
    pub until: f64,
    /// α (1/s).
    pub damping: f64,
    /// The contact pairs and clearance joints that keep their friction during the phase
    /// (by name); `None`: all of them.
    pub friction: Option<Vec<String>>,
    /// The settle's step over the integrator's h (`None`: the same step). A ratio, so that
    /// a fidelity that changes h (a study's `fidelity`, the `converge` ladder) refines the
    /// settle with it. A damped approach to rest needs a coarser step than the dynamics
    /// after it.
    pub step_ratio: Option<f64>,
    /// The contact solver's tolerance while settling over the integrator's (`None`: the
    /// same), a ratio for the same reason. Where the frictionless rest leaves the load
    /// split between a journal's two rings to the solver, a loose tolerance can end the
    /// settle elsewhere, and the trip with it.
    pub tolerance_ratio: Option<f64>,
}

impl Schedule {
    /// The settling phase, if the step that starts at `t` is in it.
    pub fn settling(&self, t: f64) -> Option<&Settle> {
        self.settle.as_ref().filter(|s| t < s.until)
    }

    /// The settling phase's damping rate α in the step that starts at `t` (0 outside it).
    pub fn settle_damping(&self, t: f64) -> f64 {
        self.settling(t).map_or(0.0, |s| s.damping)
    }

    /// Whether the candidate loses its friction during the settling phase.
    pub fn frictionless_while_settling(&self, model: &Model, c: Candidate) -> bool {
        self.settle
            .as_ref()
            .and_then(|s| s.friction.as_ref())
            .is_some_and(|keep| !keep.iter().any(|n| *n == model.candidate_owner(c)))
    }

    /// Halves the refinement window's step (the fine branch of an extrapolated window).
    pub fn halve_refine_step(&mut self) {
        if let Some(r) = self.refine.as_mut() {
            r.step_ratio *= 0.5;
        }
    }
}
