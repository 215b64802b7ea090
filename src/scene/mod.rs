//! The scene file: a YAML description of one mechanism (bodies, contacts, forces,
//! integrator settings, duration, recording), parsed with line numbers and validated into a
//! [`Model`](crate::mechanics::Model) and [`IntegrationParameters`].

mod build;
mod error;
mod schema;
pub mod units;

pub use error::SceneError;
pub use schema::SceneSpec;

use crate::integrator::IntegrationParameters;
use crate::mechanics::Model;
use std::path::Path;

/// A validated scene, ready to simulate.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub model: Model,
    pub params: IntegrationParameters,
    /// Simulated time span (s).
    pub duration: f64,
    /// Record every n-th step in trajectories.
    pub record_every: usize,
}

impl Scene {
    /// Parses and validates scene YAML text; `file` names the source in error messages.
    pub fn from_yaml(text: &str, file: &str) -> Result<Scene, SceneError> {
        let spec: SceneSpec =
            serde_saphyr::from_str(text).map_err(|e| SceneError::from_yaml(file, &e))?;
        build::build(&spec).map_err(|e| e.in_file(file))
    }

    /// Overrides one scene parameter by its path, as a study does per sample:
    /// `joints.<name>.clearance | axial_play | mu | e` (clearance joints),
    /// `contacts.<name>.mu | e`, `bodies.<name>.mass`. Values are SI. The error names the
    /// path and says what is accepted.
    pub fn set_parameter(&mut self, path: &str, value: f64) -> Result<(), String> {
        let parts: Vec<&str> = path.split('.').collect();
        let bad = |why: &str| Err(format!("parameter `{path}`: {why}"));
        if !value.is_finite() {
            return bad("value must be finite");
        }
        match parts.as_slice() {
            ["joints", name, field] => {
                let Some(j) = self.model.clearance_joints.iter_mut().find(|j| j.name == *name) else {
                    return if self.model.joints.iter().any(|j| j.name == *name) {
                        bad("this joint is ideal; make it `revolute-clearance` to vary its clearance")
                    } else {
                        bad("no such joint")
                    };
                };
                match *field {
                    "clearance" if value > 0.0 => j.clearance = value,
                    "axial_play" if value > 0.0 => j.axial_play = value,
                    "mu" if value >= 0.0 => j.mu = value,
                    "e" if (0.0..=1.0).contains(&value) => j.e = value,
                    "clearance" | "axial_play" => return bad("must be > 0"),
                    "mu" => return bad("must be ≥ 0"),
                    "e" => return bad("must be in [0, 1]"),
                    _ => return bad("unknown field (clearance, axial_play, mu, e)"),
                }
            }
            ["contacts", name, field] => {
                let Some(c) = self.model.contacts.iter_mut().find(|c| c.name == *name) else { return bad("no such contact") };
                match *field {
                    "mu" if value >= 0.0 => c.mu = value,
                    "e" if (0.0..=1.0).contains(&value) => c.e = value,
                    "mu" => return bad("must be ≥ 0"),
                    "e" => return bad("must be in [0, 1]"),
                    _ => return bad("unknown field (mu, e)"),
                }
            }
            ["bodies", name, "mass"] => {
                let Some(b) = self.model.bodies.iter_mut().find(|b| b.name == *name) else { return bad("no such body") };
                if value <= 0.0 {
                    return bad("must be > 0");
                }
                // inertia scales with the mass at fixed geometry
                b.inertia *= value / b.mass;
                b.mass = value;
            }
            _ => return bad("unknown path (joints.<name>.clearance|axial_play|mu|e, contacts.<name>.mu|e, bodies.<name>.mass)"),
        }
        Ok(())
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
