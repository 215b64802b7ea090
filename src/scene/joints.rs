//! Ideal joints (revolute, prismatic, spherical, fixed) with their drives and limits; the
//! revolute joint with clearance is built in `clearance.rs`.

use super::clearance::clearance_joint;
use super::error::{line, SceneError};
use super::fields::{body_ref, given, opt_vec3, restitution, scalar, unit_vec3, vec3, R};
use super::schema::{DriveSpec, JointSpec, LimitsSpec, Vector};
use crate::input::units::{Dim, Quantity};
use crate::integrator::assembly::JointStart;
use crate::mechanics::contact::clearance::ClearanceJoint;
use crate::mechanics::contact::compliant::CompliantLaw;
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

/// A joint of the scene: ideal (bilateral rows) or with clearance (contacts), with the
/// initial condition the assembly gives it.
pub(super) enum BuiltJoint {
    Ideal(Joint, JointStart),
    /// The journal's initial offset from the bore axis (bore body frame).
    /// A clearance joint, its journal's initial eccentricity, and its radial contact's
    /// compliant law where it has one.
    Clearance(ClearanceJoint, Vector3<f64>, Option<CompliantLaw>),
}

/// The `initial` block of an ideal joint (revolute: angle and rate; prismatic: position
/// and speed); spherical and fixed joints take none.
fn initial(spec: &JointSpec, kind: JointKind, i: usize) -> R<JointStart> {
    let f = |s: &str| format!("joints[{i}].initial.{s}");
    let Some(init) = &spec.initial else {
        return Ok(JointStart::default());
    };
    let s = &init.value;
    if s.eccentricity.is_some() {
        return Err(SceneError::at(
            line(init),
            f("eccentricity"),
            "only a revolute-clearance joint has an eccentricity",
        ));
    }
    let (coordinate, rate) = match kind {
        JointKind::Revolute => {
            if s.position.is_some() || s.speed.is_some() {
                return Err(SceneError::at(
                    line(init),
                    f("position"),
                    "a revolute joint starts at an `angle` with a `rate`",
                ));
            }
            (
                s.angle
                    .as_ref()
                    .map(|q| scalar(q, Dim::NONE, &f("angle")))
                    .transpose()?,
                s.rate
                    .as_ref()
                    .map(|q| scalar(q, Dim::ANGULAR_VELOCITY, &f("rate")))
                    .transpose()?,
            )
        }
        JointKind::Prismatic => {
            if s.angle.is_some() || s.rate.is_some() {
                return Err(SceneError::at(
                    line(init),
                    f("angle"),
                    "a prismatic joint starts at a `position` with a `speed`",
                ));
            }
            (
                s.position
                    .as_ref()
                    .map(|q| scalar(q, Dim::LENGTH, &f("position")))
                    .transpose()?,
                s.speed
                    .as_ref()
                    .map(|q| scalar(q, Dim::VELOCITY, &f("speed")))
                    .transpose()?,
            )
        }
        _ => {
            if [&s.angle, &s.rate, &s.position, &s.speed]
                .iter()
                .any(|q| q.is_some())
            {
                return Err(SceneError::at(
                    line(init),
                    format!("joints[{i}].initial"),
                    format!("a {} joint has no coordinate to start from", kind.name()),
                ));
            }
            (None, None)
        }
    };
    Ok(JointStart { coordinate, rate })
}

pub(super) fn joint(model: &Model, spec: &JointSpec, i: usize) -> R<BuiltJoint> {
    let f = |s: &str| format!("joints[{i}].{s}");
    if spec.kind.value == "revolute-clearance" {
        return clearance_joint(model, spec, i);
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
    let initial = initial(spec, kind, i)?;
    let drive = match &spec.drive {
        None => None,
        Some(d) => Some(drive(d, kind, &initial, &f)?),
    };
    let limits = match &spec.limits {
        None => None,
        Some(l) => Some(limits(l, kind, &initial, &f)?),
    };
    let joint = placed(model, spec, kind, (a, b), drive, &f)?;
    let joint = match limits {
        Some(l) => joint.with_limits(l),
        None => joint,
    };
    Ok(BuiltJoint::Ideal(joint, initial))
}

/// Refuses a drive or limits (`what` they give) on a joint of `kind` without a coordinate:
/// only revolute and prismatic joints have one.
fn has_coordinate(kind: JointKind, at: Option<u64>, field: String, what: &str) -> R<()> {
    match kind {
        JointKind::Revolute | JointKind::Prismatic => Ok(()),
        _ => Err(SceneError::at(
            at,
            field,
            format!("only revolute and prismatic joints {what}"),
        )),
    }
}

/// A joint's drive: a velocity, a position table, an effort or an effort table.
fn drive(
    d: &Spanned<DriveSpec>,
    kind: JointKind,
    initial: &JointStart,
    f: &dyn Fn(&str) -> String,
) -> R<Drive> {
    has_coordinate(kind, line(d), f("drive"), "can be driven")?;
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
    Ok(if let Some(v) = &s.velocity {
        let rate = scalar(v, vel_dim, &f("drive.velocity"))?;
        if initial.rate.is_some_and(|r| r != rate) {
            return Err(SceneError::at(
                line(v),
                f("initial"),
                format!(
                    "the initial rate contradicts the drive's velocity {rate}: give one of them"
                ),
            ));
        }
        Drive::Position(ScalarProfile::Rate {
            start: initial.coordinate.unwrap_or(0.0),
            rate,
        })
    } else if let Some(t) = &s.position_table {
        if initial.coordinate.is_some() || initial.rate.is_some() {
            return Err(SceneError::at(
                line(t),
                f("initial"),
                "a joint driven by a position table starts where the table does: give no initial condition",
            ));
        }
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

/// A joint's limits, around its initial coordinate.
fn limits(
    l: &Spanned<LimitsSpec>,
    kind: JointKind,
    initial: &JointStart,
    f: &dyn Fn(&str) -> String,
) -> R<JointLimits> {
    has_coordinate(kind, line(l), f("limits"), "have limits")?;
    let dim = if kind == JointKind::Revolute {
        Dim::NONE
    } else {
        Dim::LENGTH
    };
    let lower = scalar(&l.value.lower, dim, &f("limits.lower"))?;
    let upper = scalar(&l.value.upper, dim, &f("limits.upper"))?;
    let start = initial.coordinate.unwrap_or(0.0);
    if lower > start || upper < start || lower >= upper {
        return Err(SceneError::at(
            line(l),
            f("limits"),
            format!("need lower ≤ {start} ≤ upper and lower < upper (the joint starts at {start}, measured from the written configuration), got [{lower}, {upper}]"),
        ));
    }
    let e = restitution(&l.value.e, &f("limits.e"))?;
    Ok(JointLimits { lower, upper, e })
}

/// The joint of `kind` between `bodies`, placed by its world anchor and axis (at the
/// written configuration) or by its anchors and axes in the two body frames.
fn placed(
    model: &Model,
    spec: &JointSpec,
    kind: JointKind,
    bodies: (BodyRef, BodyRef),
    drive: Option<Drive>,
    f: &dyn Fn(&str) -> String,
) -> R<Joint> {
    let (a, b) = bodies;
    let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
    let world = spec.anchor.is_some() || spec.axis.is_some();
    let local = [&spec.anchor_a, &spec.anchor_b, &spec.axis_a, &spec.axis_b]
        .iter()
        .any(|x| x.is_some());
    if world && local {
        return Err(SceneError::at(line(&spec.name), f("anchor"), "give `anchor`/`axis` (world) or `anchor_a`, `anchor_b`, `axis_a`, `axis_b` (body frames), not both"));
    }
    // a spherical joint has no axis: z stands in
    let needs_axis = kind != JointKind::Spherical;
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
    Ok(if world || !local {
        let anchor = given(
            &spec.anchor,
            line(&spec.name),
            &f("anchor"),
            "(world point at the assembled configuration)",
        )?;
        let axis = axis_of(&spec.axis, "axis")?;
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
    })
}
