//! What a study samples: a mechanism scene (simulated, outputs from its probes) or an
//! analytic function scene. One sample = set the parameters, run, read the outputs.

use super::Output;
use crate::probe_run::run_probes;
use crate::scene::units::Dim;
use crate::scene::{FunctionScene, Scene, SceneError};
use serde::Deserialize;
use std::time::Instant;

#[derive(Clone, Debug)]
pub enum Subject {
    Mechanism(Box<Scene>),
    Function(FunctionScene),
}

/// Per-sample diagnostics, stored beside the outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Diagnostics {
    pub steps: u64,
    /// Largest penetration over all contact candidates at step ends (m).
    pub max_penetration: f64,
    pub max_solver_residual: f64,
    /// Steps whose contact solver, Newton loop or projection did not converge.
    pub nonconverged_steps: u64,
    pub wall_ms: f64,
}

/// The result of one sample: every output (NaN when failed), diagnostics, and the error
/// that failed it.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub outputs: Vec<f64>,
    pub diagnostics: Diagnostics,
    pub error: Option<String>,
}

#[derive(Deserialize)]
struct Kind {
    #[serde(rename = "type")]
    kind: Option<String>,
}

impl Subject {
    /// Parses a scene text of either type (`type: function` selects the analytic kind).
    pub fn from_yaml(text: &str, file: &str) -> Result<Subject, SceneError> {
        let kind: Option<Kind> = serde_saphyr::from_str(text).ok();
        if kind.and_then(|k| k.kind).as_deref() == Some("function") {
            Ok(Subject::Function(FunctionScene::from_yaml(text, file)?))
        } else {
            Ok(Subject::Mechanism(Box::new(Scene::from_yaml(text, file)?)))
        }
    }

    /// Every output the scene defines, in its order (no limits: the study sets them).
    pub fn outputs(&self) -> Vec<Output> {
        let output = |index: usize, name: &str, unit: &str| Output {
            name: name.to_string(),
            unit: unit.to_string(),
            index,
            lower: None,
            upper: None,
            display: None,
            caution: None,
        };
        match self {
            Subject::Mechanism(s) => s
                .probes
                .iter()
                .enumerate()
                .map(|(i, p)| Output {
                    display: p.display.clone(),
                    caution: p.caution.clone(),
                    ..output(i, &p.name, &p.unit)
                })
                .collect(),
            Subject::Function(f) => f
                .outputs
                .iter()
                .enumerate()
                .map(|(i, o)| output(i, &o.name, &o.unit))
                .collect(),
        }
    }

    /// The dimension of a parameter path (`None`: a function input, any unit).
    pub fn parameter_dim(&self, path: &str) -> Result<Option<Dim>, String> {
        match self {
            Subject::Mechanism(s) => s.parameter_dim(path).map(Some),
            Subject::Function(f) => f.input_index(path).map(|_| None),
        }
    }

    /// Runs one sample with `parameters` (path, SI value) and returns the outputs selected
    /// by index. Never panics: a panic inside the engine becomes a failed outcome.
    pub fn run(&self, parameters: &[(&str, f64)], selected: &[usize]) -> Outcome {
        let start = Instant::now();
        let result =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.run_inner(parameters)));
        let (values, mut diagnostics, error) = match result {
            Ok(r) => r,
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                (
                    Vec::new(),
                    Diagnostics::default(),
                    Some(format!("internal error (panic): {msg}")),
                )
            }
        };
        diagnostics.wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let outputs = selected
            .iter()
            .map(|&k| if error.is_none() { values[k] } else { f64::NAN })
            .collect();
        Outcome {
            outputs,
            diagnostics,
            error,
        }
    }

    fn run_inner(&self, parameters: &[(&str, f64)]) -> (Vec<f64>, Diagnostics, Option<String>) {
        match self {
            Subject::Function(f) => {
                let mut f = f.clone();
                for &(path, v) in parameters {
                    if let Err(e) = f.set_parameter(path, v) {
                        return (Vec::new(), Diagnostics::default(), Some(e));
                    }
                }
                let values = f.evaluate();
                let error = values
                    .iter()
                    .zip(&f.outputs)
                    .find(|(v, _)| !v.is_finite())
                    .map(|(v, o)| format!("output `{}` is {v}", o.name));
                (values, Diagnostics::default(), error)
            }
            Subject::Mechanism(scene) => {
                let scene = match scene.with_parameters(parameters) {
                    Ok(s) => s,
                    Err(e) => return (Vec::new(), Diagnostics::default(), Some(e)),
                };
                let sim = match scene.simulation() {
                    Ok(s) => s,
                    Err(e) => return (Vec::new(), Diagnostics::default(), Some(e.to_string())),
                };
                let run = run_probes(sim, &scene.probes, scene.duration, true, |_, _, _| {});
                let st = run.stats;
                let diagnostics = Diagnostics {
                    steps: st.steps,
                    max_penetration: st.max_penetration,
                    max_solver_residual: st.max_solver_residual,
                    nonconverged_steps: st.solver_failures
                        + st.newton_failures
                        + st.projection_failures,
                    wall_ms: 0.0,
                };
                if let Some(e) = run.error {
                    return (Vec::new(), diagnostics, Some(e));
                }
                match run.values.into_iter().collect() {
                    Ok(values) => (values, diagnostics, None),
                    Err(e) => (Vec::new(), diagnostics, Some(e)),
                }
            }
        }
    }
}
