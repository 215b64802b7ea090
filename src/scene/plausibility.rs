//! Values that are legal but implausible, most often a unit slip (a bare `0.1` meant as
//! millimetres is 100 mm): warned about at load, never refused, since an unusual
//! mechanism may mean them.

use super::error::line;
use super::schema::SceneSpec;
use crate::mechanics::body::{Motion, Shape};
use crate::mechanics::Model;

/// The densities a solid part can have (kg/m³): from foams to beyond tungsten.
const DENSITY: (f64, f64) = (10.0, 1e5);
/// How far a given inertia may be from its shape's, as a ratio of their traces.
const INERTIA_RATIO: (f64, f64) = (0.01, 100.0);

fn volume(s: &Shape) -> f64 {
    match *s {
        Shape::Box { size } => size.x * size.y * size.z,
        Shape::Cylinder { radius, length } => std::f64::consts::PI * radius * radius * length,
        Shape::Sphere { radius } => 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
    }
}

/// The scene's implausible values, each as `FILE:LINE: FIELD: why`.
pub(super) fn warnings(spec: &SceneSpec, model: &Model, file: &str) -> Vec<String> {
    let mut out = Vec::new();
    let at = |l: Option<u64>| l.map_or(file.to_string(), |l| format!("{file}:{l}"));
    for b in &spec.bodies {
        let Some(body) = model.bodies.iter().find(|m| m.name == b.name.value) else {
            continue;
        };
        let (Some(mass), Some(shape)) = (&b.mass, &b.shape) else {
            continue;
        };
        if body.motion == Motion::Fixed {
            continue;
        }
        let field = format!("bodies.{}", b.name.value);
        let Ok(solid) = super::bodies::shape(&shape.value, &field, None) else {
            continue;
        };
        let density = body.mass / volume(&solid);
        if !(DENSITY.0..=DENSITY.1).contains(&density) {
            out.push(format!(
                "{}: {field}.mass: {} kg in its shape is a density of {density:.3e} kg/m³, where solids lie between {} and {} (steel: 7850): is the unit of the mass or of the shape right?",
                at(line(mass)),
                body.mass,
                DENSITY.0,
                DENSITY.1
            ));
        }
        if let (Some(given), Motion::Free) = (&b.inertia, body.motion) {
            let ratio = body.inertia.trace() / solid.inertia(body.mass).trace();
            if !(INERTIA_RATIO.0..=INERTIA_RATIO.1).contains(&ratio) {
                out.push(format!(
                    "{}: {field}.inertia is {ratio:.3e} times that of its shape at its mass: is its unit right (kg*m^2)?",
                    at(line(given))
                ));
            }
        }
    }
    for c in &model.clearance_joints {
        if c.clearance > c.journal_radius {
            let written = spec.joints.iter().find(|j| j.name.value == c.name);
            let l = written.and_then(|j| j.clearance.as_ref()).and_then(line);
            out.push(format!(
                "{}: joints.{}.clearance: {} m is larger than the journal radius ({} m): is its unit right?",
                at(l),
                c.name,
                c.clearance,
                c.journal_radius
            ));
        }
    }
    out
}
