//! The scene file: a YAML description of one mechanism (bodies, contacts, forces,
//! integrator settings, duration, recording), parsed with line numbers and validated into a
//! [`Model`](crate::mechanics::Model) and [`IntegrationParameters`].

mod bodies;
mod build;
mod clearance;
pub mod closed_form;
mod compliance;
pub(crate) mod error;
mod fields;
mod forces;
mod integrator;
mod joints;
mod mesh_file;
pub mod parameter_paths;
mod phases;
mod plausibility;
mod probes;
pub mod schema;
mod shapes;

pub use closed_form::FunctionScene;
pub use error::SceneError;
pub use integrator::apply_integrator;
pub use schema::{IntegratorSpec, SceneSpec};

use crate::input::units::{self, Dim};
use crate::integrator::assembly::Assembly;
use crate::integrator::{IntegrationParameters, Schedule, SimError, Simulation};
use crate::mechanics::Model;
use std::path::Path;

/// A change of the integration settings on top of the scene's own `integrator` block: a
/// study's `fidelity` block, a rung of `converge`'s ladder. Kept with the scene, so that
/// the scene rebuilt for a sample is tuned the same way.
#[derive(Clone, Debug)]
pub struct Tuning {
    pub block: IntegratorSpec,
    /// Where the block comes from, for error messages (`fidelity`).
    pub origin: String,
}

/// A validated scene, ready to simulate: its document, and what was built from it.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The parsed document, which a sample's parameters are written into.
    pub spec: SceneSpec,
    /// The file the document came from, for error messages.
    pub file: String,
    /// The tuning layers applied after the document's `integrator` block, in order.
    pub tuning: Vec<Tuning>,
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
    /// Curves of one probe's measure against another's.
    pub curves: Vec<crate::probe::curve::Curve>,
    /// Values that are legal but implausible (a unit slip, most often), each as
    /// `FILE:LINE: FIELD: why`: the commands print them, and the run goes on.
    pub warnings: Vec<String>,
    /// How the written poses and velocities were assembled into the initial state.
    pub assembly: Assembly,
}

/// The `type` a scene text declares, read before the schema that depends on it.
pub fn declared_type(text: &str, file: &str) -> Result<Option<schema::Name>, SceneError> {
    #[derive(serde::Deserialize)]
    struct Kind {
        #[serde(rename = "type")]
        kind: Option<schema::Name>,
    }
    let kind: Kind = serde_saphyr::from_str(text).map_err(|e| SceneError::from_yaml(file, &e))?;
    Ok(kind.kind)
}

impl Scene {
    /// Parses and validates scene YAML text; `file` names the source in error messages.
    pub fn from_yaml(text: &str, file: &str) -> Result<Scene, SceneError> {
        if let Some(k) = declared_type(text, file)?.filter(|k| k.value == "function") {
            return Err(SceneError::at(
                error::line(&k),
                "type",
                "a `type: function` scene has no mechanism to simulate: a study evaluates it (`mc-study run`)",
            )
            .in_file(file));
        }
        let spec: SceneSpec =
            serde_saphyr::from_str(text).map_err(|e| SceneError::from_yaml(file, &e))?;
        build::build(spec, file, Vec::new())
    }

    /// Every parameter path of the scene, with its dimension and its value in the
    /// document (`None` where a default applies).
    pub fn parameters(&self) -> Vec<parameter_paths::ParameterPath> {
        parameter_paths::paths(&self.spec)
    }

    /// The dimension of the value a parameter path takes, or why the path names none.
    pub fn parameter_dim(&self, path: &str) -> Result<Dim, String> {
        parameter_paths::find(&mut self.spec.clone(), path, None)
    }

    /// The scene with `values` (path, SI value) written into its document, rebuilt and
    /// validated; the error names the path, the value and what the scene says of it.
    pub fn with_parameters(&self, values: &[(&str, f64)]) -> Result<Scene, String> {
        if values.is_empty() {
            return Ok(self.clone());
        }
        let mut spec = self.spec.clone();
        for &(path, value) in values {
            if !value.is_finite() {
                return Err(format!(
                    "parameter `{path}`: value must be finite, got {value}"
                ));
            }
            parameter_paths::find(&mut spec, path, Some(value))?;
        }
        build::build(spec, &self.file, self.tuning.clone()).map_err(|e| {
            let set: Vec<String> = values.iter().map(|(p, v)| format!("{p} = {v}")).collect();
            format!("with {}: {e}", set.join(", "))
        })
    }

    /// Writes one parameter (SI value) into the document and rebuilds the scene.
    pub fn set_parameter(&mut self, path: &str, value: f64) -> Result<(), String> {
        *self = self.with_parameters(&[(path, value)])?;
        Ok(())
    }

    /// Applies `PATH=VALUE` (`--set`): the value in SI or with a unit of the parameter's
    /// dimension, e.g. `joints.J3.clearance=0.1mm`.
    pub fn apply_setting(&mut self, setting: &str) -> Result<(), String> {
        let Some((path, value)) = setting.split_once('=') else {
            return Err(format!(
                "`{setting}`: expected PATH=VALUE, e.g. joints.J3.clearance=0.1mm"
            ));
        };
        let path = path.trim();
        let dim = self.parameter_dim(path)?;
        let q = units::parse_quantity(value).map_err(|e| format!("`{setting}`: {e}"))?;
        if let Some(d) = q.dim.filter(|d| *d != dim) {
            return Err(format!(
                "`{setting}`: `{path}` is {}, but the value's unit is {}",
                dim.describe(),
                d.describe()
            ));
        }
        self.set_parameter(path, q.si)
    }

    /// Applies a tuning layer now and keeps it for every rebuild.
    pub fn tune(&mut self, tuning: Tuning) -> Result<(), SceneError> {
        integrator::apply_integrator(&tuning.block, &mut self.params, &tuning.origin)?;
        self.tuning.push(tuning);
        Ok(())
    }

    /// A simulation of the scene from its initial state, with its phases.
    pub fn simulation(&self) -> Result<Simulation, SimError> {
        Simulation::scheduled(
            self.model.clone(),
            self.params.clone(),
            self.schedule.clone(),
        )
    }

    /// A simulation of the bundled scene `studies/<name>/scene.yaml` (for unit tests).
    #[cfg(test)]
    pub(crate) fn bundled_simulation(name: &str) -> Simulation {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("studies")
            .join(name)
            .join("scene.yaml");
        Scene::load(&path).unwrap().simulation().unwrap()
    }

    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text = crate::input::file::read(path).map_err(|e| SceneError {
            file: Some(path.display().to_string()),
            line: None,
            field: String::new(),
            message: format!("cannot read the scene file: {e}"),
        })?;
        Scene::from_yaml(&text, &path.display().to_string())
    }
}
