//! Impacts located within their steps (`IntegrationParameters::locate_impacts`): a step in
//! which a contact closes is redone as the part before the impact, the impact itself (a
//! step of length 0: Moreau's impact law alone) and the rest of the step; under step
//! control, the step ends at the impact instead.

use super::moreau_jean::VelocityStep;
use super::projection::ProjectionOutcome;
use super::simulation::{LocatedImpact, Outcome, SimError, Simulation, StepReport};
use super::subdivision::{Depth, Sum};
use super::workspace::StepWorkspace;

/// The report of an impact (a velocity step of length 0, nothing projected).
fn impact_report(vs: &VelocityStep) -> StepReport {
    StepReport {
        active_contacts: vs.impulses.len(),
        newton_iterations: vs.newton_iterations,
        newton_converged: vs.newton_converged,
        solver: vs.solver,
        plastic: vs.plastic,
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
        self.closing_instants(trial)
            .filter(|c| c.1 < 1.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The contacts that close within the step `trial` computed, each with the fraction of
    /// the step at which its gap, interpolated linearly, closes (1 for one that closes
    /// exactly at the step's end).
    pub(super) fn closing_instants<'a>(
        &'a self,
        trial: &'a Outcome,
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        trial.closing.iter().filter_map(|c| {
            let g0 = self.points[c.candidate].gap();
            (g0 > 0.0 && c.end_gap <= 0.0).then(|| (c.candidate, g0 / (g0 - c.end_gap)))
        })
    }

    /// The step redone in three parts: up to the impact of contact `i` at fraction `s` of
    /// the step, the impact itself (a step of length 0: the frictional impact law alone, on
    /// the contacts that take it together), and the rest of the step from the post-impact
    /// velocity, which may hold further impacts. The θ-rule would otherwise move the bodies
    /// over the whole step with the mean of the pre- and post-impact velocities, which
    /// misplaces them by up to h/2 times the velocity jump, whatever h resolves elsewhere.
    /// The step's impulses are the sums of its parts' (`parts::Sum`).
    pub(super) fn split_at_impact(
        &mut self,
        i: usize,
        s: f64,
        in_step: &[usize],
        t_end: f64,
        depth: Depth,
        ws: &mut StepWorkspace,
    ) -> Result<StepReport, SimError> {
        let (h, t_start) = (self.h, self.state.t);
        let mut sum = Sum::new(self);
        // The part before ends a hair (1e-6 of it) short of the contact, which it must not
        // close itself; where the gap's curvature over the step put the estimate past the
        // contact or short of it, the secant on the part just computed corrects it. A part
        // shorter than 1e-3 h misplaces the bodies by at most 1e-3 h times the jump.
        let g0 = self.points[i].gap();
        // a gap the impact leaves open stays open under a plastic impact (the contact
        // then holds its load at a distance), so the part must end within a hair of it
        let open_enough = self.params.activation_margin + 1e-5 * g0;
        let mut s = s * (1.0 - 1e-6);
        let mut tries = 0;
        let before = loop {
            s = s.clamp(1e-3, 1.0 - 1e-3);
            self.h = s * h;
            // a part before the impact that is not resolved either (its trial leaves a
            // bore, or its contact problem is unsolved) makes the step one to take in halves
            let part = match self.compute(ws) {
                Ok(part) if !self.too_coarse(&part) => part,
                part if !depth.may_halve() => part?,
                _ => {
                    self.h = h;
                    return self.halves(t_end, depth.unsplit(), ws);
                }
            };
            tries += 1;
            // the contact's gap where the part ends: past the contact where the part
            // closed it, else short of it by what the part leaves open
            let end_gap = match part.closing.iter().find(|c| c.candidate == i) {
                Some(c) => Some(c.end_gap),
                None => part.points.as_ref().map(|p| p[i].gap()),
            };
            let resolved = |g1: f64| g1 >= 0.0 && g1 <= open_enough;
            match end_gap {
                Some(g1) if !resolved(g1) && g1 < g0 && s > 1e-3 && tries < 4 => {
                    s *= g0 / (g0 - g1) * (1.0 - 1e-6)
                }
                _ => break part,
            }
        };
        let first = self.commit(before, t_start + s * h, ws);
        sum.add(self);
        self.h = 0.0;
        let active = self.impact_contacts(i, in_step);
        if active.iter().any(|&k| self.is_guard(k)) {
            self.evaluate_guards();
        }
        let mut vs = self.velocity(&active, &mut ws.velocity);
        // nothing is projected at the impact: the elimination goes back to the workspace,
        // for the velocity steps of the rest of the step
        ws.velocity.step.keep_elimination(vs.elimination.take());
        if vs.v.iter().any(|x| !x.is_finite()) {
            return Err(SimError::NonFinite {
                t: self.state.t,
                step: self.stats.steps,
            });
        }
        self.record_contacts(&active, &vs);
        if self.located_impact.is_none() {
            self.located_impact = Some(LocatedImpact {
                before: self.state.clone(),
                v_after: vs.v.clone(),
                contacts: active
                    .iter()
                    .copied()
                    .filter(|&k| self.impulses[k].x > 0.0)
                    .collect(),
            });
        }
        self.joint_impulses = vs.joint_impulses.clone();
        sum.add(self);
        let impact = impact_report(&vs);
        self.active = active;
        std::mem::swap(&mut self.state.v, &mut vs.v);
        ws.velocity.step.keep_spent(vs);
        self.stats.impact_splits += 1;
        if self.control.is_some() {
            // under step control the step ends at the impact: the controller sizes the
            // steps after it, which the rest of this one would take unjudged
            sum.store(self);
            self.h = s * h;
            let mut report = first;
            report.absorb(&impact);
            return Ok(report);
        }
        self.h = (1.0 - s) * h;
        let mut report = self.advance(t_end, depth, ws)?;
        sum.add(self);
        sum.store(self);
        self.h = h;
        for part in [&first, &impact] {
            report.absorb(part);
        }
        Ok(report)
    }

    /// The contacts that take the impact of contact `i` together, at the poses it happens
    /// at, as Moreau's law has them: those touching then (a gap no wider than the impacting
    /// contact's, plus the activation margin), those of the part before, and those of the
    /// whole step as the unsplit step had them (`in_step`: the two rings of a journal
    /// swinging in its plane, a box's corners; taken one after the other, with e = 0, they
    /// lose other momenta), with the guards that stop a journal the blow drives across its
    /// clearance. A contact that closes later in the step (`in_step` leaves it out) is not
    /// among them unless it touches at this instant: it takes its own impact in the rest of
    /// the step (a row of balls passes the blow on one ball at a time).
    fn impact_contacts(&self, i: usize, in_step: &[usize]) -> Vec<usize> {
        let margin = self.params.activation_margin + self.points[i].gap().max(0.0);
        let mut member = vec![false; self.points.len()];
        in_step.iter().for_each(|&k| member[k] = true);
        self.active
            .iter()
            .for_each(|&k| member[k] |= !self.is_guard(k));
        (0..self.points.len())
            .filter(|&k| {
                member[k] || k == i || (!self.is_guard(k) && self.points[k].gap() <= margin)
            })
            .collect()
    }
}
