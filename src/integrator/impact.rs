//! Impacts located within their steps (`IntegrationParameters::locate_impacts`): a step in
//! which a contact closes is redone as the part before the impact, the impact itself (a
//! step of length 0: Moreau's impact law alone) and the rest of the step.

use super::moreau_jean::VelocityStep;
use super::projection::ProjectionOutcome;
use super::simulation::{Outcome, SimError, Simulation, StepReport};
use nalgebra::Vector3;

/// The report of an impact (a velocity step of length 0, nothing projected).
fn impact_report(vs: &VelocityStep) -> StepReport {
    StepReport {
        active_contacts: vs.impulses.len(),
        newton_iterations: vs.newton_iterations,
        newton_converged: vs.newton_converged,
        solver: vs.solver,
        active_set_passes: 1,
        projection: ProjectionOutcome {
            converged: true,
            ..ProjectionOutcome::default()
        },
    }
}

impl Simulation {
    /// The earliest contact that closes within the step `trial` computed, and the fraction
    /// of the step at which it closes: its gap interpolated linearly between the step's
    /// start and the end of the pass that activated it. `None` without one.
    pub(super) fn first_impact(&self, trial: &Outcome) -> Option<(usize, f64)> {
        trial
            .closing
            .iter()
            .filter_map(|&(i, end_gap)| {
                let g0 = self.points[i].gap();
                (g0 > 0.0 && end_gap < 0.0).then(|| (i, g0 / (g0 - end_gap)))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The step redone in three parts: up to the impact of contact `i` at fraction `s` of
    /// the step, the impact itself (a step of length 0: the frictional impact law alone, on
    /// the contacts that the whole step closed and those touching then), and the rest of
    /// the step from the post-impact velocity. The θ-rule would otherwise move the bodies over the whole step with the
    /// mean of the pre- and post-impact velocities, which misplaces them by up to h/2 times
    /// the velocity jump, whatever h resolves elsewhere. The step's impulses are the sums
    /// of its parts', so that impulse / h stays the step's mean force.
    pub(super) fn split_at_impact(
        &mut self,
        i: usize,
        s: f64,
        in_step: &[usize],
        t_end: f64,
    ) -> Result<StepReport, SimError> {
        let (h, t_start) = (self.h, self.state.t);
        let mut impulses = vec![Vector3::zeros(); self.points.len()];
        let add = |sim: &Simulation, sum: &mut Vec<Vector3<f64>>| {
            sum.iter_mut().zip(&sim.impulses).for_each(|(a, b)| *a += b);
        };
        // The part before ends a hair (1e-6 of it) short of the contact, which it must not
        // close itself; where the gap's curvature over the step put the estimate past the
        // contact, the secant on the part just computed corrects it. A part shorter than
        // 1e-3 h misplaces the bodies by at most 1e-3 h times the jump.
        let g0 = self.points[i].gap();
        let mut s = s * (1.0 - 1e-6);
        let mut tries = 0;
        let before = loop {
            s = s.clamp(1e-3, 1.0 - 1e-3);
            self.h = s * h;
            let part = self.compute()?;
            tries += 1;
            match part.closing.iter().find(|c| c.0 == i) {
                Some(&(_, end_gap)) if s > 1e-3 && tries < 4 => {
                    s *= g0 / (g0 - end_gap) * (1.0 - 1e-6)
                }
                _ => break part,
            }
        };
        let first = self.commit(before, t_start + s * h);
        add(self, &mut impulses);
        let mut joint_impulses = self.joint_impulses.clone();
        // The impact, at the poses it happens at, on the contacts of the whole step as the
        // unsplit step had them (`in_step`, with the guards that stop a journal crossing
        // its clearance), those of the part before, and every one that touches then (a gap
        // no wider than the impacting contact's, plus the activation margin): the contacts
        // the step closes take its impact together, as Moreau's law has them, not one after
        // the other. Contacts that close together (the two rings of a journal swinging in
        // its plane, a box's corners) and a journal that the blow drives across a tiny
        // clearance (which an ideal joint takes in the same impulse) need it: taken one
        // after the other, with e = 0, they lose other momenta.
        self.h = 0.0;
        let margin = self.params.activation_margin + self.points[i].gap().max(0.0);
        let mut member = vec![false; self.points.len()];
        in_step.iter().for_each(|&k| member[k] = true);
        self.active
            .iter()
            .for_each(|&k| member[k] |= !self.is_guard(k));
        let active: Vec<usize> = (0..self.points.len())
            .filter(|&k| {
                member[k] || k == i || (!self.is_guard(k) && self.points[k].gap() <= margin)
            })
            .collect();
        let vs = self.velocity(&active);
        if vs.v.iter().any(|x| !x.is_finite()) {
            return Err(SimError::NonFinite {
                t: self.state.t,
                step: self.stats.steps,
            });
        }
        self.impulses.iter_mut().for_each(|x| *x = Vector3::zeros());
        for (&k, imp) in active.iter().zip(&vs.impulses) {
            self.impulses[k] = *imp;
        }
        add(self, &mut impulses);
        let impact = impact_report(&vs);
        self.active = active;
        self.state.v = vs.v;
        self.h = (1.0 - s) * h;
        let after = self.compute()?;
        let mut report = self.commit(after, t_end);
        add(self, &mut impulses);
        self.impulses = impulses;
        if joint_impulses.len() == self.joint_impulses.len() {
            let add_rows = |a: &mut Vec<f64>, b: &[f64]| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            };
            add_rows(&mut joint_impulses, &vs.joint_impulses);
            add_rows(&mut joint_impulses, &self.joint_impulses);
            self.joint_impulses = joint_impulses;
        }
        self.h = h;
        for part in [&first, &impact] {
            report.absorb(part);
        }
        self.stats.impact_splits += 1;
        Ok(report)
    }
}
