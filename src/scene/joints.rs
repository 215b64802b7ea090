//! Ideal joints (revolute, prismatic, spherical, fixed) with their drives and limits; the
//! revolute joint with clearance is built in `clearance.rs`.

use super::clearance::clearance_joint;
use super::error::{line, SceneError};
use super::fields::{body_ref, opt_vec3, restitution, scalar, unit_vec3, vec3, R};
use super::schema::{JointSpec, Vector};
use super::units::{Dim, Quantity};
use crate::mechanics::contact::clearance::ClearanceJoint;
use crate::mechanics::joint::{Drive, Joint, JointKind, JointLimits, ScalarProfile};
use crate::mechanics::{BodyRef, Model, Motion};
use nalgebra::Vector3;
use serde_saphyr::Spanned;

fn scalar_table(t: &Spanned<Vec<Vec<Quantity>>>, dim: Dim, field: &str) -> R<ScalarProfile> {
    let mut rows: Vec<(f64, f64)> = Vec::new();
    for (k, row) in t.value.iter().enumerate() {
        let err = |m: String| SceneError::at(line(t), format!("{field}[{k}]"), m);
        if row.len() != 2 {
            return Err(err("rows are [t, value]".into()));
        }
        let time = row[0].value(Dim::TIME).map_err(err)?;
        let v = row[1].value(dim).map_err(err)?;
        if rows.last().is_some_and(|(p, _)| time <= *p) {
            return Err(err("times must increase strictly".into()));
        }
        rows.push((time, v));
    }
    if rows.is_empty() {
        return Err(SceneError::at(line(t), field, "needs at least one row"));
    }
    Ok(ScalarProfile::Table(rows))
}

/// The two bodies of joint `i`: different, and at least one of them moving.
pub(super) fn joint_bodies(model: &Model, spec: &JointSpec, i: usize) -> R<(BodyRef, BodyRef)> {
    let f = |s: &str| format!("joints[{i}].{s}");
    let a = body_ref(model, &spec.body_a, &f("body_a"))?;
    let b = body_ref(model, &spec.body_b, &f("body_b"))?;
    let moving = |r: BodyRef| r.is_some_and(|i| model.bodies[i].motion != Motion::Fixed);
    if a == b || !(moving(a) || moving(b)) {
        return Err(SceneError::at(
            line(&spec.body_b),
            f("body_b"),
            "a joint needs two different bodies, at least one of them moving",
        ));
    }
    Ok((a, b))
}

/// A joint of the scene: ideal (bilateral rows) or with clearance (contacts).
pub(super) enum BuiltJoint {
    Ideal(Joint),
    Clearance(ClearanceJoint),
}

pub(super) fn joint(model: &Model, spec: &JointSpec, i: usize) -> R<BuiltJoint> {
    let f = |s: &str| format!("joints[{i}].{s}");
    if spec.kind.value == "revolute-clearance" {
        return clearance_joint(model, spec, i).map(BuiltJoint::Clearance);
    }
    let kind = match spec.kind.value.as_str() {
        "revolute" => JointKind::Revolute,
        "prismatic" => JointKind::Prismatic,
        "spherical" => JointKind::Spherical,
        "fixed" => JointKind::Fixed,
        other => {
            return Err(SceneError::at(
                line(&spec.kind),
                f("type"),
                format!("unknown joint type `{other}` (revolute, revolute-clearance, prismatic, spherical, fixed)"),
            ))
        }
    };
    let (a, b) = joint_bodies(model, spec, i)?;
    let drive = match &spec.drive {
        None => None,
        Some(d) => {
            if kind != JointKind::Revolute && kind != JointKind::Prismatic {
                return Err(SceneError::at(
                    line(d),
                    f("drive"),
                    "only revolute and prismatic joints can be driven",
                ));
            }
            let rot = kind == JointKind::Revolute;
            let (vel_dim, pos_dim, eff_dim) = if rot {
                (Dim::ANGULAR_VELOCITY, Dim::NONE, Dim::TORQUE)
            } else {
                (Dim::VELOCITY, Dim::LENGTH, Dim::FORCE)
            };
            let s = &d.value;
            let given = [
                s.velocity.is_some(),
                s.position_table.is_some(),
                s.effort.is_some(),
                s.effort_table.is_some(),
            ];
            if given.iter().filter(|&&g| g).count() != 1 {
                return Err(SceneError::at(
                    line(d),
                    f("drive"),
                    "give exactly one of `velocity`, `position_table`, `effort`, `effort_table`",
                ));
            }
            Some(if let Some(v) = &s.velocity {
                Drive::Position(ScalarProfile::Rate {
                    start: 0.0,
                    rate: scalar(v, vel_dim, &f("drive.velocity"))?,
                })
            } else if let Some(t) = &s.position_table {
                Drive::Position(scalar_table(t, pos_dim, &f("drive.position_table"))?)
            } else if let Some(e) = &s.effort {
                Drive::Effort(ScalarProfile::Rate {
                    start: scalar(e, eff_dim, &f("drive.effort"))?,
                    rate: 0.0,
                })
            } else {
                Drive::Effort(scalar_table(
                    s.effort_table.as_ref().expect("one drive given"),
                    eff_dim,
                    &f("drive.effort_table"),
                )?)
            })
        }
    };
    let limits = match &spec.limits {
        None => None,
        Some(l) => {
            if kind != JointKind::Revolute && kind != JointKind::Prismatic {
                return Err(SceneError::at(
                    line(l),
                    f("limits"),
                    "only revolute and prismatic joints have limits",
                ));
            }
            let dim = if kind == JointKind::Revolute {
                Dim::NONE
            } else {
                Dim::LENGTH
            };
            let lower = scalar(&l.value.lower, dim, &f("limits.lower"))?;
            let upper = scalar(&l.value.upper, dim, &f("limits.upper"))?;
            if lower > 0.0 || upper < 0.0 || lower >= upper {
                return Err(SceneError::at(
                    line(l),
                    f("limits"),
                    format!("need lower ≤ 0 ≤ upper and lower < upper (the assembled configuration is 0), got [{lower}, {upper}]"),
                ));
            }
            let e = restitution(&l.value.e, &f("limits.e"))?;
            Some(JointLimits { lower, upper, e })
        }
    };
    let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
    let world = spec.anchor.is_some() || spec.axis.is_some();
    let local = [&spec.anchor_a, &spec.anchor_b, &spec.axis_a, &spec.axis_b]
        .iter()
        .any(|x| x.is_some());
    if world && local {
        return Err(SceneError::at(line(&spec.name), f("anchor"), "give `anchor`/`axis` (world) or `anchor_a`, `anchor_b`, `axis_a`, `axis_b` (body frames), not both"));
    }
    let needs_axis = kind != JointKind::Spherical;
    let joint = if world || !local {
        let anchor = spec.anchor.as_ref().ok_or_else(|| {
            SceneError::at(
                line(&spec.name),
                f("anchor"),
                "is required (world point at the assembled configuration)",
            )
        })?;
        let axis = match &spec.axis {
            Some(x) => unit_vec3(x, &f("axis"))?,
            None if needs_axis => {
                return Err(SceneError::at(
                    line(&spec.name),
                    f("axis"),
                    format!("is required for a {} joint", kind.name()),
                ))
            }
            None => Vector3::z(),
        };
        Joint::from_world(
            spec.name.value.clone(),
            kind,
            a,
            b,
            vec3(anchor, Dim::LENGTH, &f("anchor"))?,
            axis,
            &poses,
            drive,
        )
    } else {
        let axis_of = |x: &Option<Vector>, n: &str| -> R<Vector3<f64>> {
            match x {
                Some(x) => unit_vec3(x, &f(n)),
                None if needs_axis => Err(SceneError::at(
                    line(&spec.name),
                    f(n),
                    format!("is required for a {} joint", kind.name()),
                )),
                None => Ok(Vector3::z()),
            }
        };
        Joint::new(
            spec.name.value.clone(),
            kind,
            a,
            b,
            opt_vec3(&spec.anchor_a, Dim::LENGTH, &f("anchor_a"))?,
            opt_vec3(&spec.anchor_b, Dim::LENGTH, &f("anchor_b"))?,
            axis_of(&spec.axis_a, "axis_a")?,
            axis_of(&spec.axis_b, "axis_b")?,
            &poses,
            drive,
        )
    };
    Ok(BuiltJoint::Ideal(match limits {
        Some(l) => joint.with_limits(l),
        None => joint,
    }))
}
