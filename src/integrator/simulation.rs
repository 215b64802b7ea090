//! The time loop: contact detection and activation, the velocity step, the position update,
//! and per-step diagnostics accumulated over the run.

use super::moreau_jean::{advance_poses, velocity_step};
use super::params::{IntegrationParameters, Scheme};
use crate::mechanics::model::State;
use crate::mechanics::{ContactPoint, Model};
use crate::solver::SolverStatus;
use nalgebra::Vector3;

/// Diagnostics of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    pub active_contacts: usize,
    pub newton_iterations: usize,
    pub newton_converged: bool,
    pub solver: SolverStatus,
}

/// Diagnostics accumulated over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunStats {
    pub steps: u64,
    /// Largest −gap seen over all contact candidates at the step ends (m); 0 if none.
    pub max_penetration: f64,
    /// Steps whose contact solver did not reach its tolerance.
    pub solver_failures: u64,
    /// Steps whose Newton loop did not reach its tolerance.
    pub newton_failures: u64,
    pub max_solver_residual: f64,
    pub max_active_contacts: usize,
}

#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SimError {
    #[error("invalid integration parameter `{0}`: {1}")]
    Parameters(&'static str, String),
    #[error("the state became non-finite (NaN or infinite) at t = {t} s, step {step}")]
    NonFinite { t: f64, step: u64 },
}

pub struct Simulation {
    pub model: Model,
    pub params: IntegrationParameters,
    pub state: State,
    candidates: Vec<(usize, usize)>,
    mask: Vec<bool>,
    points: Vec<ContactPoint>,
    impulses: Vec<Vector3<f64>>,
    t0: f64,
    pub stats: RunStats,
}

impl Simulation {
    pub fn new(model: Model, params: IntegrationParameters) -> Result<Self, SimError> {
        params
            .validate()
            .map_err(|(f, m)| SimError::Parameters(f, m))?;
        let state = model.initial_state();
        let candidates = model.contact_candidates();
        let mut sim = Simulation {
            mask: model.dof_mask(),
            impulses: vec![Vector3::zeros(); candidates.len()],
            points: Vec::new(),
            candidates,
            t0: state.t,
            model,
            params,
            state,
            stats: RunStats::default(),
        };
        sim.update_geometry();
        Ok(sim)
    }

    fn update_geometry(&mut self) {
        let poses = &self.state.poses;
        self.points.clear();
        self.points.extend(
            self.candidates
                .iter()
                .map(|&(c, k)| self.model.contacts[c].evaluate(k, poses)),
        );
        for p in &self.points {
            self.stats.max_penetration = self.stats.max_penetration.max(-p.gap());
        }
    }

    /// Contact candidates evaluated at the current state, in `Model::contact_candidates` order.
    pub fn contact_points(&self) -> &[ContactPoint] {
        &self.points
    }

    /// `(pair, candidate)` of each contact point.
    pub fn contact_ids(&self) -> &[(usize, usize)] {
        &self.candidates
    }

    /// Impulse (P_N, P_T1, P_T2) of each candidate over the last step (zero if inactive).
    pub fn impulses(&self) -> &[Vector3<f64>] {
        &self.impulses
    }

    pub fn energy(&self) -> f64 {
        self.model.energy(&self.state)
    }

    /// Advances one step of size h.
    pub fn step(&mut self) -> Result<StepReport, SimError> {
        let p = &self.params;
        let v0 = &self.state.v;
        let active: Vec<usize> = match p.scheme {
            Scheme::MoreauJean => (0..self.points.len())
                .filter(|&i| {
                    let c = &self.points[i];
                    c.gap() + p.gamma * p.h * c.local_velocity(v0.as_slice()).x
                        <= p.activation_margin
                })
                .collect(),
        };
        let refs: Vec<&ContactPoint> = active.iter().map(|&i| &self.points[i]).collect();
        let warm: Vec<Vector3<f64>> = active.iter().map(|&i| self.impulses[i]).collect();
        let vs = velocity_step(
            &self.model,
            &self.mask,
            p,
            self.state.t,
            &self.state.poses,
            v0,
            &refs,
            &warm,
        );
        if vs.v.iter().any(|x| !x.is_finite()) {
            return Err(SimError::NonFinite {
                t: self.state.t,
                step: self.stats.steps,
            });
        }
        let poses = advance_poses(&self.state.poses, v0, &vs.v, p.h, p.theta);
        self.impulses.iter_mut().for_each(|x| *x = Vector3::zeros());
        for (&i, imp) in active.iter().zip(&vs.impulses) {
            self.impulses[i] = *imp;
        }
        self.stats.steps += 1;
        self.state = State {
            t: self.t0 + self.stats.steps as f64 * p.h,
            poses,
            v: vs.v,
        };
        self.update_geometry();
        let report = StepReport {
            active_contacts: active.len(),
            newton_iterations: vs.newton_iterations,
            newton_converged: vs.newton_converged,
            solver: vs.solver,
        };
        let s = &mut self.stats;
        s.solver_failures += u64::from(!report.solver.converged);
        s.newton_failures += u64::from(!report.newton_converged);
        s.max_solver_residual = s.max_solver_residual.max(report.solver.residual);
        s.max_active_contacts = s.max_active_contacts.max(report.active_contacts);
        Ok(report)
    }

    /// Steps until `t_end` (to the nearest step), calling `observe` after every step.
    pub fn run_until(
        &mut self,
        t_end: f64,
        mut observe: impl FnMut(&Simulation, &StepReport),
    ) -> Result<(), SimError> {
        let n = ((t_end - self.state.t) / self.params.h).round().max(0.0) as u64;
        for _ in 0..n {
            let r = self.step()?;
            observe(self, &r);
        }
        Ok(())
    }
}
