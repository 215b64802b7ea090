//! Scene parameters a study overrides per sample, by path:
//! `joints.<name>.clearance | axial_play | mu | e` (clearance joints),
//! `contacts.<name>.mu | e`, `bodies.<name>.mass`, `bodies.<name>.position.x|y|z` and
//! `bodies.<name>.velocity.x|y|z` (initial conditions). Values are SI.

use super::units::Dim;
use super::Scene;

/// What a parameter path designates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Clearance(usize),
    AxialPlay(usize),
    JointMu(usize),
    JointE(usize),
    ContactMu(usize),
    ContactE(usize),
    Mass(usize),
    Position(usize, usize),
    Velocity(usize, usize),
}

/// The admissible values of a target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Range {
    Positive,
    NonNegative,
    Unit,
    Any,
}

const PATHS: &str = "joints.<name>.clearance|axial_play|mu|e, contacts.<name>.mu|e, \
bodies.<name>.mass|position.x|position.y|position.z|velocity.x|velocity.y|velocity.z";

impl Target {
    fn dim_and_range(self) -> (Dim, Range) {
        match self {
            Target::Clearance(_) | Target::AxialPlay(_) => (Dim::LENGTH, Range::Positive),
            Target::JointMu(_) | Target::ContactMu(_) => (Dim::NONE, Range::NonNegative),
            Target::JointE(_) | Target::ContactE(_) => (Dim::NONE, Range::Unit),
            Target::Mass(_) => (Dim::MASS, Range::Positive),
            Target::Position(..) => (Dim::LENGTH, Range::Any),
            Target::Velocity(..) => (Dim::VELOCITY, Range::Any),
        }
    }
}

impl Scene {
    fn resolve(&self, path: &str) -> Result<Target, String> {
        let bad = |why: &str| Err(format!("parameter `{path}`: {why}"));
        let parts: Vec<&str> = path.split('.').collect();
        let m = &self.model;
        Ok(match parts.as_slice() {
            ["joints", name, field] => {
                let Some(j) = m.clearance_joints.iter().position(|j| j.name == *name) else {
                    return if m.joints.iter().any(|j| j.name == *name) {
                        bad("this joint is ideal; make it `revolute-clearance` to vary its clearance")
                    } else {
                        let known: Vec<&str> =
                            m.clearance_joints.iter().map(|j| j.name.as_str()).collect();
                        bad(&format!(
                            "no such joint (clearance joints: {})",
                            known.join(", ")
                        ))
                    };
                };
                match *field {
                    "clearance" => Target::Clearance(j),
                    "axial_play" => Target::AxialPlay(j),
                    "mu" => Target::JointMu(j),
                    "e" => Target::JointE(j),
                    _ => return bad("unknown field (clearance, axial_play, mu, e)"),
                }
            }
            ["contacts", name, field] => {
                let Some(c) = m.contacts.iter().position(|c| c.name == *name) else {
                    let known: Vec<&str> = m.contacts.iter().map(|c| c.name.as_str()).collect();
                    return bad(&format!("no such contact (contacts: {})", known.join(", ")));
                };
                match *field {
                    "mu" => Target::ContactMu(c),
                    "e" => Target::ContactE(c),
                    _ => return bad("unknown field (mu, e)"),
                }
            }
            ["bodies", name, rest @ ..] => {
                let Some(b) = m.body_index(name) else {
                    let known: Vec<&str> = m.bodies.iter().map(|b| b.name.as_str()).collect();
                    return bad(&format!("no such body (bodies: {})", known.join(", ")));
                };
                let axis = |a: &str| ["x", "y", "z"].iter().position(|x| *x == a);
                match rest {
                    ["mass"] => Target::Mass(b),
                    ["position", a] if axis(a).is_some() => Target::Position(b, axis(a).unwrap()),
                    ["velocity", a] if axis(a).is_some() => Target::Velocity(b, axis(a).unwrap()),
                    _ => return bad("unknown field (mass, position.x|y|z, velocity.x|y|z)"),
                }
            }
            _ => return bad(&format!("unknown path ({PATHS})")),
        })
    }

    /// The dimension of the value a parameter path takes, or why the path is not one.
    pub fn parameter_dim(&self, path: &str) -> Result<Dim, String> {
        Ok(self.resolve(path)?.dim_and_range().0)
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
        let q = super::units::parse_quantity(value).map_err(|e| format!("`{setting}`: {e}"))?;
        if let Some(d) = q.dim.filter(|d| *d != dim) {
            return Err(format!(
                "`{setting}`: `{path}` is {}, but the value's unit is {}",
                dim.describe(),
                d.describe()
            ));
        }
        self.set_parameter(path, q.si)
    }

    /// Overrides one scene parameter by its path (SI value), as a study does per sample.
    /// A body's initial position moves that body only: joints and springs keep the anchors
    /// and rest lengths assembled from the scene file. The error names the path and says
    /// what is accepted.
    pub fn set_parameter(&mut self, path: &str, value: f64) -> Result<(), String> {
        let target = self.resolve(path)?;
        let bad = |why: &str| Err(format!("parameter `{path}`: {why}, got {value}"));
        if !value.is_finite() {
            return bad("value must be finite");
        }
        let outside = match target.dim_and_range().1 {
            Range::Positive => (value <= 0.0).then_some("must be > 0"),
            Range::NonNegative => (value < 0.0).then_some("must be ≥ 0"),
            Range::Unit => (!(0.0..=1.0).contains(&value)).then_some("must be in [0, 1]"),
            Range::Any => None,
        };
        if let Some(why) = outside {
            return bad(why);
        }
        let m = &mut self.model;
        match target {
            Target::Clearance(j) => m.clearance_joints[j].clearance = value,
            Target::AxialPlay(j) => m.clearance_joints[j].axial_play = value,
            Target::JointMu(j) => m.clearance_joints[j].mu = value,
            Target::JointE(j) => m.clearance_joints[j].e = value,
            Target::ContactMu(c) => m.contacts[c].mu = value,
            Target::ContactE(c) => m.contacts[c].e = value,
            Target::Mass(b) => {
                let b = &mut m.bodies[b];
                // inertia scales with the mass at fixed geometry
                b.inertia *= value / b.mass;
                b.mass = value;
            }
            Target::Position(b, k) => m.bodies[b].pose.x[k] = value,
            Target::Velocity(b, k) => m.bodies[b].velocity[k] = value,
        }
        Ok(())
    }
}
