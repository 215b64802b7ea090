//! A step taken in parts: as two halves where it is not resolved (its contact or projection
//! problem unsolved, or a journal that would leave its bore), or split at an impact
//! (`impact.rs`). The step's impulses are the sums of its parts', so that impulse / h stays
//! the step's mean force.

use super::simulation::{Outcome, SimError, Simulation, StepReport};
use super::workspace::StepWorkspace;
use nalgebra::Vector3;

/// Halvings of one step at most: a step is never cut below 1/64 of its size.
const MAX_HALVINGS: usize = 6;

/// Impact splits within one step at most (a row of balls passes a blow on through one
/// split per ball).
const MAX_SPLITS: usize = 16;

/// How far a step has been cut: the halvings and the impact splits above the part being
/// taken.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Depth {
    halvings: usize,
    splits: usize,
}

impl Depth {
    /// Whether the part may still be taken in halves.
    pub(super) fn may_halve(&self) -> bool {
        self.halvings < MAX_HALVINGS
    }

    /// The depth of the step a split was made in.
    pub(super) fn unsplit(self) -> Depth {
        Depth {
            splits: self.splits - 1,
            ..self
        }
    }
}

/// The impulses of the parts of a step, summed.
pub(super) struct Sum {
    impulses: Vec<Vector3<f64>>,
    joint_impulses: Option<Vec<f64>>,
}

impl Sum {
    pub(super) fn new(sim: &Simulation) -> Self {
        Sum {
            impulses: vec![Vector3::zeros(); sim.impulses.len()],
            joint_impulses: None,
        }
    }

    /// Adds the impulses of the part just taken.
    pub(super) fn add(&mut self, sim: &Simulation) {
        self.impulses
            .iter_mut()
            .zip(&sim.impulses)
            .for_each(|(a, b)| *a += b);
        match &mut self.joint_impulses {
            None => self.joint_impulses = Some(sim.joint_impulses.clone()),
            Some(sum) if sum.len() == sim.joint_impulses.len() => sum
                .iter_mut()
                .zip(&sim.joint_impulses)
                .for_each(|(a, b)| *a += b),
            Some(_) => {}
        }
    }

    /// The sums as the step's impulses.
    pub(super) fn store(self, sim: &mut Simulation) {
        sim.impulses = self.impulses;
        if let Some(joint) = self.joint_impulses {
            sim.joint_impulses = joint;
        }
    }
}

impl Simulation {
    /// Takes the step of size `self.h` from the current state to `t_end`: as two halves
    /// where it is not resolved (`too_coarse`, or a trial that fails on its geometry, such
    /// as a journal that would leave its bore), split at an impact with `locate_impacts` or
    /// where one impact knocks another contact shut.
    pub(super) fn advance(
        &mut self,
        t_end: f64,
        depth: Depth,
        ws: &mut StepWorkspace,
    ) -> Result<StepReport, SimError> {
        let trial = self.compute(ws);
        let coarse = match &trial {
            Err(SimError::Geometry { .. } | SimError::NonFinite { .. }) => true,
            Err(_) => false,
            Ok(outcome) => self.too_coarse(outcome),
        };
        if coarse && depth.may_halve() {
            return self.halves(t_end, depth, ws);
        }
        let squeezed = matches!(&trial, Ok(outcome) if self.squeezed(outcome));
        self.stats.squeezed_steps += u64::from(squeezed);
        let trial = trial?;
        // Impacts are located on request (but not in a fixed-step settle: its path is
        // damped away, and only the rest it reaches is read), and always where one knocks
        // another contact shut within the step or two contacts close in it, and in the
        // rest of a step split at one: taken together, they would share their momentum as
        // a simultaneous impact does (a row of balls struck at one end would leave at
        // (−1/3, 2/3, 2/3), not (0, 0, 1)).
        let knocked = trial.closing.iter().any(|c| c.knocked);
        let settling = self.control.is_none() && self.schedule.settling(self.state.t).is_some();
        let requested = self.params.locate_impacts && !settling;
        let locate = requested || knocked || self.closings_apart(&trial) || depth.splits > 0;
        let impact = match locate && depth.splits < MAX_SPLITS {
            true => self.first_impact(&trial),
            false => None,
        };
        let Some((i, s)) = impact else {
            return Ok(self.commit(trial, t_end, ws));
        };
        // the contacts the impact takes together: those of the step less the others that
        // close within it, which take their own impacts at their own instants (or this
        // one, where they touch at it)
        let in_step: Vec<usize> = trial
            .active
            .iter()
            .copied()
            .filter(|&k| k == i || trial.closing.iter().all(|c| c.candidate != k))
            .collect();
        let depth = Depth {
            splits: depth.splits + 1,
            ..depth
        };
        self.split_at_impact(i, s, &in_step, t_end, depth, ws)
    }

    /// Whether two contacts close within the step at instants apart (by more than 1e-6 of
    /// it, as the gaps' secants place them): the θ-rule would take their impacts as one.
    fn closings_apart(&self, trial: &Outcome) -> bool {
        let (first, last) = self
            .closing_instants(trial)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (_, s)| {
                (a.min(s), b.max(s))
            });
        last - first > 1e-6
    }

    /// The step as two halves, each taken as `advance` takes a step.
    pub(super) fn halves(
        &mut self,
        t_end: f64,
        depth: Depth,
        ws: &mut StepWorkspace,
    ) -> Result<StepReport, SimError> {
        let h = self.h;
        let top = depth.halvings == 0 && depth.splits == 0;
        let depth = Depth {
            halvings: depth.halvings + 1,
            ..depth
        };
        let t_mid = self.state.t + 0.5 * h;
        let mut sum = Sum::new(self);
        self.h = 0.5 * h;
        let first = self.advance(t_mid, depth, ws)?;
        sum.add(self);
        if self.control.is_some() && self.state.t < t_mid {
            // the first half ended at an impact (`split_at_impact`): so does the step
            sum.store(self);
            self.h = self.state.t - (t_mid - 0.5 * h);
            self.stats.halved_steps += u64::from(top);
            return Ok(first);
        }
        self.h = t_end - self.state.t;
        let mut report = self.advance(t_end, depth, ws)?;
        sum.add(self);
        sum.store(self);
        self.h = h;
        report.absorb(&first);
        self.stats.halved_steps += u64::from(top);
        Ok(report)
    }

    /// Whether the step is too coarse for its contacts: the contact problem was not solved,
    /// the projection found no admissible position, or it left a body past the middle of
    /// a part (`sinking.rs`). A coarse step on a clearance joint (a journal swept around
    /// its bore, or across it) is one such; its halves are not.
    pub(super) fn too_coarse(&self, trial: &Outcome) -> bool {
        let projected = self.params.scheme.projects();
        let sank = || {
            trial
                .points
                .as_deref()
                .is_some_and(|points| self.sank_past(&trial.sinking, points))
        };
        !trial.vs.solver.converged || (projected && !trial.report.projection.converged) || sank()
    }
}
