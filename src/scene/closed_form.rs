//! The analytic `function` scene: outputs are closed-form expressions of named inputs (the
//! Ishigami function, a linear model). It runs the whole study pipeline (designs, store,
//! statistics, sensitivity) against answers known exactly, without a mechanism.
//!
//! ```yaml
//! type: function
//! name: ishigami
//! inputs: [x1, x2, x3]
//! outputs:
//!   - { name: y, expression: "sin(x1) + 7*sin(x2)^2 + 0.1*x3^4*sin(x1)" }
//! ```

use super::error::{line, SceneError};
use super::schema::Name;
use crate::input::expr::Expr;
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FunctionSpec {
    #[serde(rename = "type")]
    _kind: String,
    name: Option<String>,
    #[serde(rename = "description")]
    _description: Option<String>,
    inputs: Vec<Name>,
    outputs: Vec<OutputSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputSpec {
    name: Name,
    expression: Name,
    /// Unit label of the output (default: none).
    unit: Option<String>,
}

/// One output: its name, unit label and expression.
#[derive(Clone, Debug, PartialEq)]
pub struct FunctionOutput {
    pub name: String,
    pub unit: String,
    pub expression: Expr,
}

/// A validated function scene.
#[derive(Clone, Debug, PartialEq)]
pub struct FunctionScene {
    pub name: String,
    pub inputs: Vec<String>,
    /// Values of the inputs before a study overrides them (0).
    pub values: Vec<f64>,
    pub outputs: Vec<FunctionOutput>,
}

impl FunctionScene {
    pub fn from_yaml(text: &str, file: &str) -> Result<FunctionScene, SceneError> {
        let spec: FunctionSpec =
            serde_saphyr::from_str(text).map_err(|e| SceneError::from_yaml(file, &e))?;
        Self::build(spec).map_err(|e| e.in_file(file))
    }

    fn build(spec: FunctionSpec) -> Result<FunctionScene, SceneError> {
        let mut inputs: Vec<String> = Vec::new();
        for (i, n) in spec.inputs.iter().enumerate() {
            let valid = n
                .value
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic())
                && n.value
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !valid || n.value == "pi" {
                return Err(SceneError::at(
                    line(n),
                    format!("inputs[{i}]"),
                    format!(
                        "`{}` is not a valid input name (letters, digits, `_`; not `pi`)",
                        n.value
                    ),
                ));
            }
            if inputs.contains(&n.value) {
                return Err(SceneError::at(
                    line(n),
                    format!("inputs[{i}]"),
                    format!("duplicate input `{}`", n.value),
                ));
            }
            inputs.push(n.value.clone());
        }
        if spec.outputs.is_empty() {
            return Err(SceneError::at(
                None,
                "outputs",
                "a function scene needs at least one output",
            ));
        }
        let mut outputs: Vec<FunctionOutput> = Vec::new();
        for (i, o) in spec.outputs.iter().enumerate() {
            if let Some(why) = crate::input::columns::column_name_error(&o.name.value) {
                return Err(SceneError::at(
                    line(&o.name),
                    format!("outputs[{i}].name"),
                    why,
                ));
            }
            if outputs.iter().any(|p| p.name == o.name.value) {
                return Err(SceneError::at(
                    line(&o.name),
                    format!("outputs[{i}].name"),
                    format!("duplicate output `{}`", o.name.value),
                ));
            }
            let expression = Expr::parse(&o.expression.value, &inputs).map_err(|e| {
                SceneError::at(
                    line(&o.expression),
                    format!("outputs[{i}].expression"),
                    e.to_string(),
                )
            })?;
            outputs.push(FunctionOutput {
                name: o.name.value.clone(),
                unit: o.unit.clone().unwrap_or_default(),
                expression,
            });
        }
        Ok(FunctionScene {
            name: spec.name.unwrap_or_else(|| "function".into()),
            values: vec![0.0; inputs.len()],
            inputs,
            outputs,
        })
    }

    /// Sets input `inputs.<name>`.
    pub fn set_parameter(&mut self, path: &str, value: f64) -> Result<(), String> {
        let i = self.input_index(path)?;
        self.values[i] = value;
        Ok(())
    }

    /// The index of the input a parameter path names, or why it names none.
    pub fn input_index(&self, path: &str) -> Result<usize, String> {
        let name = path.strip_prefix("inputs.").ok_or_else(|| {
            format!("parameter `{path}`: a function scene's parameters are `inputs.<name>`")
        })?;
        self.inputs.iter().position(|n| n == name).ok_or_else(|| {
            format!(
                "parameter `{path}`: no such input (inputs: {})",
                self.inputs.join(", ")
            )
        })
    }

    /// Every output at the current input values.
    pub fn evaluate(&self) -> Vec<f64> {
        self.outputs
            .iter()
            .map(|o| o.expression.eval(&self.values))
            .collect()
    }
}
