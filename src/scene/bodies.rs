//! Bodies: mass and inertia (given, or derived from a solid shape), the written pose and
//! initial twist, and how the body moves (free, pinned, fixed).

use super::error::{line, SceneError};
use super::fields::{opt_vec3, orientation, positive, values, vec3, R};
use super::schema::Name;
use super::schema::{BodySpec, ShapeSpec};
use crate::input::units::Dim;
use crate::mechanics::{Model, Motion, Planar, RigidBody, Shape};
use nalgebra::Matrix3;

pub(super) fn body(spec: &BodySpec, i: usize) -> R<RigidBody> {
    let f = |s: &str| format!("bodies[{i}].{s}");
    let name = spec.name.value.clone();
    if name.is_empty() || name == "ground" || name.contains('.') {
        return Err(SceneError::at(
            line(&spec.name),
            f("name"),
            "must be non-empty, without `.` (names are parts of parameter paths), and not the reserved name `ground`",
        ));
    }
    let motion = match spec.motion.as_ref().map(|m| m.value.as_str()) {
        None | Some("free") => Motion::Free,
        Some("pinned") => Motion::Pinned,
        Some("fixed") => Motion::Fixed,
        Some(other) => {
            return Err(SceneError::at(
                spec.motion.as_ref().and_then(line),
                f("motion"),
                format!("unknown motion `{other}` (use free, pinned or fixed)"),
            ))
        }
    };
    let mut b = if motion == Motion::Fixed {
        RigidBody::fixed(name)
    } else {
        let mass_q = spec.mass.as_ref().ok_or_else(|| {
            SceneError::at(line(&spec.name), f("mass"), "is required for a moving body")
        })?;
        let mass = positive(mass_q, Dim::MASS, &f("mass"))?;
        let inertia = match (&spec.inertia, &spec.shape) {
            (Some(v), _) => {
                let m = match v.value.len() {
                    3 => Matrix3::from_diagonal(&vec3(v, Dim::INERTIA, &f("inertia"))?),
                    9 => Matrix3::from_row_slice(&values(v, Dim::INERTIA, &f("inertia"), 9)?),
                    n => {
                        return Err(SceneError::at(
                            line(v),
                            f("inertia"),
                            format!("needs 3 principal moments or 9 tensor entries, got {n}"),
                        ))
                    }
                };
                let sym = (m - m.transpose()).norm() <= 1e-12 * m.norm();
                let pd = sym && m.cholesky().is_some();
                if !pd {
                    return Err(SceneError::at(
                        line(v),
                        f("inertia"),
                        "must be symmetric positive definite",
                    ));
                }
                m
            }
            (None, Some(s)) => shape(&s.value, &f("shape"), line(s))?.inertia(mass),
            (None, None) => {
                return Err(SceneError::at(
                    line(&spec.name),
                    f("inertia"),
                    "give `inertia` or a `shape` to derive it from",
                ))
            }
        };
        RigidBody::new(name, mass, inertia).with_motion(motion)
    };
    b.pose.x = opt_vec3(&spec.position, Dim::LENGTH, &f("position"))?;
    if let Some(o) = &spec.orientation {
        b.pose.p = orientation(o, &f("orientation"))?;
    }
    if motion != Motion::Fixed {
        b.velocity = opt_vec3(&spec.velocity, Dim::VELOCITY, &f("velocity"))?;
        b.angular_velocity = opt_vec3(
            &spec.angular_velocity,
            Dim::ANGULAR_VELOCITY,
            &f("angular_velocity"),
        )?;
    }
    Ok(b)
}

/// Holds every moving body to the world plane `plane` (`xy`, `xz`, `yz`). Each needs a body
/// axis along the plane's normal, and no written velocity out of the plane.
pub(super) fn hold_to_plane(model: &mut Model, plane: &Name, specs: &[BodySpec]) -> R<()> {
    let normal = match plane.value.as_str() {
        "yz" => 0,
        "xz" => 1,
        "xy" => 2,
        other => {
            return Err(SceneError::at(
                line(plane),
                "plane",
                format!("unknown plane `{other}` (use xy, xz or yz)"),
            ))
        }
    };
    let axis = ["x", "y", "z"][normal];
    for (i, (b, spec)) in model.bodies.iter_mut().zip(specs).enumerate() {
        if b.motion == Motion::Fixed {
            continue;
        }
        let n = nalgebra::Vector3::ith(normal, 1.0);
        let body_n = b.pose.p.inverse() * n;
        let Some(spin) = (0..3).find(|&k| body_n[k].abs() > 1.0 - 1e-12) else {
            return Err(SceneError::at(
                spec.orientation.as_ref().and_then(line).or(line(&spec.name)),
                format!("bodies[{i}].orientation"),
                format!(
                    "in a scene held to the {} plane, every moving body needs one of its axes along {axis}",
                    plane.value
                ),
            ));
        };
        let out_of_plane =
            b.velocity[normal] != 0.0 || (0..3).any(|k| k != spin && b.angular_velocity[k] != 0.0);
        if out_of_plane {
            return Err(SceneError::at(
                line(&spec.name),
                format!("bodies[{i}]"),
                format!(
                    "moves out of the {} plane: its velocity must have no {axis} component and its angular velocity must be about {axis}",
                    plane.value
                ),
            ));
        }
        b.planar = Some(Planar { normal, spin });
    }
    Ok(())
}

pub(super) fn shape(s: &ShapeSpec, field: &str, _line: Option<u64>) -> R<Shape> {
    Ok(match s {
        ShapeSpec::Box { size } => {
            let v = vec3(size, Dim::LENGTH, &format!("{field}.box.size"))?;
            if v.iter().any(|&x| x <= 0.0) {
                return Err(SceneError::at(
                    line(size),
                    format!("{field}.box.size"),
                    "must be positive",
                ));
            }
            Shape::Box { size: v }
        }
        ShapeSpec::Cylinder { radius, length } => Shape::Cylinder {
            radius: positive(radius, Dim::LENGTH, &format!("{field}.cylinder.radius"))?,
            length: positive(length, Dim::LENGTH, &format!("{field}.cylinder.length"))?,
        },
        ShapeSpec::Sphere { radius } => Shape::Sphere {
            radius: positive(radius, Dim::LENGTH, &format!("{field}.sphere.radius"))?,
        },
    })
}
