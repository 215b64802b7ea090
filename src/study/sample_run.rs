//! What a study samples: a mechanism scene (simulated, outputs from its probes) or an
//! analytic function scene. One sample = set the parameters, run, read the outputs.

use super::Output;
use crate::input::units::Dim;
use crate::probe::run::run_probes;
use crate::scene::{declared_type, FunctionScene, Scene, SceneError};
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

/// The result of one sample: every output (NaN when failed), diagnostics, the error that
/// failed it, and why its values are suspect if the run went through with a fault.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub outputs: Vec<f64>,
    pub diagnostics: Diagnostics,
    pub error: Option<String>,
    pub suspect: Option<String>,
    /// The optional outputs without a value (NaN there), each by index with why.
    pub missing: Vec<(usize, String)>,
    /// Every curve of the subject on its grid; empty lists when the run failed.
    pub curves: Vec<Vec<f64>>,
}

/// A run of plain Moreau–Jean (which does not project) is suspect once a contact sinks by
/// more than this fraction of the model's smallest clearance: the clearance is what the
/// study measures.
const PLAIN_PENETRATION: f64 = 0.1;

/// Why a run that finished is not to be trusted as it stands, if it is not: steps that did
/// not converge, bodies that overlapped at the start, penetration or joint violation beyond
/// a projecting scheme's tolerance, or penetration beyond `PLAIN_PENETRATION` of the
/// smallest `clearance` for plain Moreau–Jean.
fn suspicion(
    st: &crate::integrator::RunStats,
    params: &crate::integrator::IntegrationParameters,
    initial_overlap: Option<&(String, f64)>,
    clearance: f64,
) -> Option<String> {
    let mut why = Vec::new();
    let nonconverged = st.solver_failures + st.newton_failures + st.projection_failures;
    if nonconverged > 0 {
        why.push(format!(
            "steps did not converge ({nonconverged} of {})",
            st.steps
        ));
    }
    let allowed = params.admissible_depth();
    if let Some((what, depth)) = initial_overlap {
        why.push(format!(
            "bodies overlapped at the start: {what} (by {depth:.3e} m)"
        ));
    }
    if !params.scheme.projects() && st.max_penetration > PLAIN_PENETRATION * clearance {
        why.push(format!(
            "penetration of {:.3e} m, beyond {PLAIN_PENETRATION} of the smallest clearance ({clearance:.3e} m): plain Moreau–Jean does not project, so its penetration grows with h",
            st.max_penetration
        ));
    }
    if st.sank_through > 0 {
        why.push(format!(
            "a body sank through the middle of a part ({} steps): h·v exceeds half the part's thickness{}",
            st.sank_through,
            if params.scheme.projects() { "" } else { " (plain Moreau–Jean sinks up to h·v; combined-projection does not)" }
        ));
    }
    if st.squeezed_steps > 0 {
        why.push(format!(
            "a journal was squeezed across its ring ({} steps): two points on opposite sides of one ring pushed at once, which the step's motion across the clearance causes; lower h",
            st.squeezed_steps
        ));
    }
    if params.scheme.projects() {
        if st.max_penetration > allowed {
            why.push(format!(
                "penetration beyond the scheme's tolerance ({:.3e} m > {allowed:.0e} m)",
                st.max_penetration
            ));
        }
        if st.max_joint_violation > allowed {
            why.push(format!(
                "joint violation beyond the scheme's tolerance ({:.3e} m > {allowed:.0e} m)",
                st.max_joint_violation
            ));
        }
    }
    (!why.is_empty()).then(|| why.join("; "))
}

impl Subject {
    /// Parses a scene text of either type (`type: function` selects the analytic kind).
    pub fn from_yaml(text: &str, file: &str) -> Result<Subject, SceneError> {
        let kind = declared_type(text, file)?;
        if kind.is_some_and(|k| k.value == "function") {
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
            optional: false,
        };
        match self {
            Subject::Mechanism(s) => s
                .probes
                .iter()
                .enumerate()
                .map(|(i, p)| Output {
                    display: p.display.clone(),
                    caution: p.caution.clone(),
                    optional: p.optional,
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

    /// The curves every run of the subject draws.
    pub fn curves(&self) -> &[crate::probe::curve::Curve] {
        match self {
            Subject::Mechanism(s) => &s.curves,
            Subject::Function(_) => &[],
        }
    }

    /// The scene's implausible values, as its load found them.
    pub fn warnings(&self) -> &[String] {
        match self {
            Subject::Mechanism(s) => &s.warnings,
            Subject::Function(_) => &[],
        }
    }

    fn curve_count(&self) -> usize {
        self.curves().len()
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
        let mut o = result.unwrap_or_else(|panic| {
            let msg = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            failed(
                Diagnostics::default(),
                format!("internal error (panic): {msg}"),
            )
        });
        o.diagnostics.wall_ms = start.elapsed().as_secs_f64() * 1e3;
        o.outputs = selected
            .iter()
            .map(|&k| {
                if o.error.is_none() {
                    o.outputs[k]
                } else {
                    f64::NAN
                }
            })
            .collect();
        let curves = self.curve_count();
        if o.error.is_some() || o.curves.len() != curves {
            o.curves = vec![Vec::new(); curves];
        }
        o.missing = std::mem::take(&mut o.missing)
            .into_iter()
            .filter_map(|(k, why)| Some((selected.iter().position(|&s| s == k)?, why)))
            .collect();
        o
    }

    /// The outcome with every output of the subject, in its order.
    fn run_inner(&self, parameters: &[(&str, f64)]) -> Outcome {
        match self {
            Subject::Function(f) => {
                let mut f = f.clone();
                for &(path, v) in parameters {
                    if let Err(e) = f.set_parameter(path, v) {
                        return failed(Diagnostics::default(), e);
                    }
                }
                let values = f.evaluate();
                let error = values
                    .iter()
                    .zip(&f.outputs)
                    .find(|(v, _)| !v.is_finite())
                    .map(|(v, o)| format!("output `{}` is {v}", o.name));
                Outcome {
                    outputs: values,
                    diagnostics: Diagnostics::default(),
                    error,
                    suspect: None,
                    missing: Vec::new(),
                    curves: Vec::new(),
                }
            }
            Subject::Mechanism(scene) => {
                let scene = match scene.with_parameters(parameters) {
                    Ok(s) => s,
                    Err(e) => return failed(Diagnostics::default(), e),
                };
                let sim = match scene.simulation() {
                    Ok(s) => s,
                    Err(e) => return failed(Diagnostics::default(), e.to_string()),
                };
                let initial_overlap = sim.deepest_overlap();
                let clearance = sim
                    .model
                    .clearance_joints
                    .iter()
                    .map(|j| j.clearance)
                    .fold(f64::INFINITY, f64::min);
                let run = run_probes(
                    sim,
                    &scene.probes,
                    &scene.curves,
                    scene.duration,
                    true,
                    |_, _, _| {},
                );
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
                let suspect = suspicion(&st, &scene.params, initial_overlap.as_ref(), clearance);
                let mut missing = Vec::new();
                let values: Result<Vec<f64>, String> = match run.error {
                    Some(e) => Err(e),
                    None => run
                        .values
                        .into_iter()
                        .zip(&scene.probes)
                        .enumerate()
                        .map(|(k, (v, probe))| match v {
                            Err(why) if probe.optional => {
                                missing.push((k, why));
                                Ok(f64::NAN)
                            }
                            v => v,
                        })
                        .collect(),
                };
                match (values, suspect) {
                    (Ok(outputs), suspect) => Outcome {
                        outputs,
                        diagnostics,
                        error: None,
                        suspect,
                        missing,
                        curves: run.curves,
                    },
                    // the fault explains a failure better than its symptom does
                    (Err(e), Some(why)) => {
                        failed(diagnostics, format!("{e}; the run was suspect: {why}"))
                    }
                    (Err(e), None) => failed(diagnostics, e),
                }
            }
        }
    }
}

/// A failed outcome (its outputs are filled in by [`Subject::run`]).
fn failed(diagnostics: Diagnostics, error: String) -> Outcome {
    Outcome {
        outputs: Vec::new(),
        diagnostics,
        error: Some(error),
        suspect: None,
        missing: Vec::new(),
        curves: Vec::new(),
    }
}
