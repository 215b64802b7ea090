//! The scene file: a YAML description of one mechanism (bodies, contacts, forces,
//! integrator settings, duration, recording), parsed with line numbers and validated into a
//! [`Model`](crate::mechanics::Model) and [`IntegrationParameters`].

mod bodies;
mod build;
mod clearance;
pub(crate) mod error;
mod fields;
mod forces;
pub mod function;
mod integrator;
mod joints;
mod parameter;
mod phases;
mod probes;
pub mod schema;
mod shapes;
pub mod units;

pub use error::SceneError;
pub use function::FunctionScene;
pub use integrator::apply_integrator;
pub use schema::{IntegratorSpec, SceneSpec};

use crate::integrator::{IntegrationParameters, Schedule, SimError, Simulation};
use crate::mechanics::Model;
use std::path::Path;

/// A validated scene, ready to simulate.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub model: Model,
    pub params: IntegrationParameters,
    /// The run's phases (settling, refinement window).
    pub schedule: Schedule,
    /// Simulated time span (s).
    pub duration: f64,
    /// Record every n-th step in trajectories.
    pub record_every: usize,
    /// Named outputs of a run.
    pub probes: Vec<crate::probe::Probe>,
}

impl Scene {
    /// Parses and validates scene YAML text; `file` names the source in error messages.
    pub fn from_yaml(text: &str, file: &str) -> Result<Scene, SceneError> {
        let spec: SceneSpec =
            serde_saphyr::from_str(text).map_err(|e| SceneError::from_yaml(file, &e))?;
        build::build(&spec).map_err(|e| e.in_file(file))
    }

    /// A simulation of the scene from its initial state, with its phases.
    pub fn simulation(&self) -> Result<Simulation, SimError> {
        Simulation::scheduled(
            self.model.clone(),
            self.params.clone(),
            self.schedule.clone(),
        )
    }

    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|e| SceneError {
            file: Some(path.display().to_string()),
            line: None,
            field: String::new(),
            message: format!("cannot read the scene file: {e}"),
        })?;
        Scene::from_yaml(&text, &path.display().to_string())
    }
}
