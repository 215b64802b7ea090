//! What a step changes in a simulation, saved before a step that may be taken again
//! (`step_control.rs`): restoring it puts the simulation back where the step started.

use super::simulation::{LocatedImpact, RunStats, Simulation};
use crate::mechanics::model::State;
use crate::mechanics::{ContactPoint, Pose};
use nalgebra::Vector3;

pub(super) struct Rollback {
    state: State,
    points: Vec<ContactPoint>,
    guards_evaluated: bool,
    impulses: Vec<Vector3<f64>>,
    warm: Vec<Vector3<f64>>,
    joint_impulses: Vec<f64>,
    active: Vec<usize>,
    checked_poses: Vec<Pose>,
    compliant_onset: Vec<Option<f64>>,
    compliant: Vec<(ContactPoint, Vector3<f64>)>,
    stats: RunStats,
    located_impact: Option<LocatedImpact>,
}

impl Rollback {
    pub(super) fn of(sim: &Simulation) -> Rollback {
        Rollback {
            state: sim.state.clone(),
            points: sim.points.clone(),
            guards_evaluated: sim.guards_evaluated,
            impulses: sim.impulses.clone(),
            warm: sim.warm.clone(),
            joint_impulses: sim.joint_impulses.clone(),
            active: sim.active.clone(),
            checked_poses: sim.checked_poses.clone(),
            compliant_onset: sim.compliant_onset.clone(),
            compliant: sim.compliant.clone(),
            stats: sim.stats,
            located_impact: sim.located_impact.clone(),
        }
    }

    /// The impulses the simulation had before the step.
    pub(super) fn impulses(&self) -> &[Vector3<f64>] {
        &self.impulses
    }

    /// The time the step started at.
    pub(super) fn time(&self) -> f64 {
        self.state.t
    }

    /// The contact points at the step's start.
    pub(super) fn points(&self) -> &[ContactPoint] {
        &self.points
    }

    pub(super) fn velocities(&self) -> &nalgebra::DVector<f64> {
        &self.state.v
    }

    pub(super) fn stats(&self) -> &RunStats {
        &self.stats
    }

    pub(super) fn restore(self, sim: &mut Simulation) {
        sim.state = self.state;
        sim.points = self.points;
        sim.guards_evaluated = self.guards_evaluated;
        sim.impulses = self.impulses;
        sim.warm = self.warm;
        sim.joint_impulses = self.joint_impulses;
        sim.active = self.active;
        sim.checked_poses = self.checked_poses;
        sim.compliant_onset = self.compliant_onset;
        sim.compliant = self.compliant;
        sim.stats = self.stats;
        sim.located_impact = self.located_impact;
    }
}
