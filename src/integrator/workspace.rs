//! The storage a simulation's steps reuse from one step to the next. The simulation owns
//! it and lends each stage of a step its part by `&mut`: the velocity step, the
//! projection, the activation loop. Every entry is written before it is read, so a step's
//! result does not depend on what an earlier step left in it; a cloned simulation starts
//! with a fresh workspace.

use super::activation::ActivationLists;
use super::moreau_jean::VelocityStorage;
use super::opposed::Facing;
use super::projection::ProjectionStorage;
use super::simulation::{ProjectionLists, VelocityLists};

/// A simulation's step storage.
#[derive(Default)]
pub(crate) struct StepWorkspace {
    pub(super) velocity: VelocityWorkspace,
    pub(super) projection: ProjectionWorkspace,
    pub(super) activation: ActivationLists,
}

/// A fresh workspace: a copy steps on its own, in its own storage.
impl Clone for StepWorkspace {
    fn clone(&self) -> Self {
        StepWorkspace::default()
    }
}

/// What `Simulation::velocity` works in: the velocity step's storage, the lists that set
/// its problem up, and the facing contacts' list (`opposed.rs`).
#[derive(Default)]
pub(super) struct VelocityWorkspace {
    pub(super) step: VelocityStorage,
    pub(super) lists: VelocityLists,
    pub(super) facing: Vec<Option<Facing>>,
}

/// What `Simulation::project_poses` works in: its lists and the projection's storage.
#[derive(Default)]
pub(super) struct ProjectionWorkspace {
    pub(super) lists: ProjectionLists,
    pub(super) project: ProjectionStorage,
}
