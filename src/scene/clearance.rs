//! The revolute joint with clearance: bore on `body_a`, journal and flanges on `body_b`,
//! placed from a world anchor and axis or from body-frame ones.

use super::compliance::{compliant_law, is_compliant};
use super::error::{line, SceneError};
use super::fields::{
    count, given, non_negative, opt_vec3, positive, restitution, unit_vec3, vec3, R,
};
use super::joints::{joint_bodies, BuiltJoint};
use super::schema::{JointSpec, Vector, Q};
use crate::input::units::Dim;
use crate::integrator::assembly::JointStart;
use crate::mechanics::contact::clearance::ClearanceJoint;
use crate::mechanics::joint::{Joint, JointKind};
use crate::mechanics::{BodyRef, Model};
use nalgebra::Vector3;

/// Points on each flange's rim where `rim_points` is left out.
pub(super) const RIM_POINTS: usize = 4;
/// The axial play (m) where `axial_play` is left out.
pub(super) const AXIAL_PLAY: f64 = 1e-4;

/// Joint `i`, a revolute joint with clearance, with the journal's initial eccentricity;
/// with a clearance of 0, the ideal revolute joint it tends to (see [`ideal_limit`]).
pub(super) fn clearance_joint(model: &Model, spec: &JointSpec, i: usize) -> R<BuiltJoint> {
    let f = |s: &str| format!("joints[{i}].{s}");
    let l = line(&spec.name);
    let required = |q: &Option<Q>, name: &str, dim: Dim| -> R<f64> {
        positive(
            given(q, l, &f(name), "for a revolute-clearance joint")?,
            dim,
            &f(name),
        )
    };
    let (a, b) = joint_bodies(model, spec, i)?;
    if spec.drive.is_some() || spec.limits.is_some() {
        return Err(SceneError::at(line(&spec.name), f("drive"), "a revolute-clearance joint has no drive or limits (drive the bodies with an ideal joint)"));
    }
    let journal_radius = required(&spec.journal_radius, "journal_radius", Dim::LENGTH)?;
    let rim = spec
        .rim_points
        .as_ref()
        .map_or(Ok(RIM_POINTS), |q| count(q, &f("rim_points")))?;
    if rim < 3 {
        return Err(SceneError::at(
            spec.rim_points.as_ref().and_then(line),
            f("rim_points"),
            "needs at least 3 points per flange",
        ));
    }
    let e = restitution(&spec.e, &f("e"))?;
    let [bore_center, bore_axis, journal_point, journal_axis] = frames(model, spec, (a, b), &f)?;
    let clearance = non_negative(
        given(
            &spec.clearance,
            l,
            &f("clearance"),
            "for a revolute-clearance joint",
        )?,
        Dim::LENGTH,
        &f("clearance"),
    )?;
    if clearance == 0.0 {
        return ideal_limit(
            model,
            spec,
            i,
            (a, b),
            [bore_center, bore_axis, journal_point, journal_axis],
        );
    }
    // the flange bears on the bore's end face at any eccentricity only beyond the bore
    // radius plus the clearance
    let least = journal_radius + 2.0 * clearance;
    let flange_radius = match &spec.flange_radius {
        None => (1.5 * journal_radius).max(journal_radius + 3.0 * clearance),
        Some(q) => {
            let r = positive(q, Dim::LENGTH, &f("flange_radius"))?;
            if r <= least {
                return Err(SceneError::at(
                    line(q),
                    f("flange_radius"),
                    format!("must exceed the journal radius plus twice the clearance ({least} m), so that the flange bears on the bore's face wherever the journal lies in its bore; got {r}"),
                ));
            }
            r
        }
    };
    let eccentricity = initial_eccentricity(spec, bore_axis, clearance, &f)?;
    let mu = spec
        .mu
        .as_ref()
        .map_or(Ok(0.0), |q| non_negative(q, Dim::NONE, &f("mu")))?;
    // Lankarani and Nikravesh's equivalent sphere of a journal in its bore,
    // R = R_J R_B / (R_B − R_J)
    let radius = journal_radius * (journal_radius + clearance) / clearance;
    let law = match is_compliant(&spec.law, &spec.compliance, l, &f)? {
        true => Some(compliant_law(&spec.compliance, Ok(radius), (mu, e), l, &f)?),
        false => None,
    };
    let joint = ClearanceJoint {
        name: spec.name.value.clone(),
        bore_body: a,
        journal_body: b,
        bore_center,
        bore_axis,
        bore_length: required(&spec.bore_length, "bore_length", Dim::LENGTH)?,
        journal_point,
        journal_axis,
        journal_radius,
        clearance,
        axial_play: spec.axial_play.as_ref().map_or(Ok(AXIAL_PLAY), |q| {
            positive(q, Dim::LENGTH, &f("axial_play"))
        })?,
        flange_radius,
        rim_points: rim,
        mu,
        e,
    };
    Ok(BuiltJoint::Clearance(joint, eccentricity, law))
}

/// A revolute-clearance joint of clearance 0: the ideal revolute joint about the bore's
/// axis, with neither radial nor axial play. Its coordinate's zero is the written
/// configuration, as the clearance joint's angle's is. It has no pin friction, so a
/// friction coefficient is refused rather than dropped: the limit of a journal with
/// friction is not the frictionless joint.
fn ideal_limit(
    model: &Model,
    spec: &JointSpec,
    i: usize,
    (a, b): (BodyRef, BodyRef),
    [bore_center, bore_axis, journal_point, journal_axis]: [Vector3<f64>; 4],
) -> R<BuiltJoint> {
    let f = |s: &str| format!("joints[{i}].{s}");
    let mu = spec
        .mu
        .as_ref()
        .map_or(Ok(0.0), |q| non_negative(q, Dim::NONE, &f("mu")))?;
    if mu > 0.0 {
        return Err(SceneError::at(
            spec.mu.as_ref().and_then(line),
            f("mu"),
            format!("a clearance of 0 makes `{}` the ideal revolute joint, which has no pin friction: set `mu: 0` to compare with the ideal joint (got mu = {mu})", spec.name.value),
        ));
    }
    if let Some(q) = spec
        .initial
        .as_ref()
        .and_then(|init| init.value.eccentricity.as_ref())
    {
        let ecc = opt_vec3(&Some(q.clone()), Dim::LENGTH, &f("initial.eccentricity"))?;
        if ecc.norm() > 0.0 {
            return Err(SceneError::at(
                line(q),
                f("initial.eccentricity"),
                "a joint of clearance 0 has its journal on the bore axis: no eccentricity",
            ));
        }
    }
    let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
    let joint = Joint::new(
        spec.name.value.clone(),
        JointKind::Revolute,
        a,
        b,
        bore_center,
        journal_point,
        bore_axis,
        journal_axis,
        &poses,
        None,
    );
    Ok(BuiltJoint::Ideal(joint, JointStart::default()))
}

/// The bore's centre and axis in the bore body's frame and the journal's point and axis in
/// the journal body's frame, in this order: from a world anchor and axis at the written
/// configuration, or given in the body frames.
fn frames(
    model: &Model,
    spec: &JointSpec,
    bodies: (BodyRef, BodyRef),
    f: &dyn Fn(&str) -> String,
) -> R<[Vector3<f64>; 4]> {
    let (a, b) = bodies;
    let l = line(&spec.name);
    let pose = |r: BodyRef| r.map_or(crate::mechanics::Pose::identity(), |i| model.bodies[i].pose);
    Ok(if spec.anchor.is_some() || spec.axis.is_some() {
        let anchor = given(
            &spec.anchor,
            l,
            &f("anchor"),
            "(bore centre, world, at assembly)",
        )?;
        let anchor = vec3(anchor, Dim::LENGTH, &f("anchor"))?;
        let axis = given(&spec.axis, l, &f("axis"), "for a revolute-clearance joint")?;
        let axis = unit_vec3(axis, &f("axis"))?;
        let (pa, pb) = (pose(a), pose(b));
        [
            pa.local(&anchor),
            pa.p.inverse_transform_vector(&axis),
            pb.local(&anchor),
            pb.p.inverse_transform_vector(&axis),
        ]
    } else {
        let why = "(or give anchor and axis in world coordinates)";
        let point = |v: &Option<Vector>, name: &str| {
            vec3(given(v, l, &f(name), why)?, Dim::LENGTH, &f(name))
        };
        let direction =
            |v: &Option<Vector>, name: &str| unit_vec3(given(v, l, &f(name), why)?, &f(name));
        [
            point(&spec.anchor_a, "anchor_a")?,
            direction(&spec.axis_a, "axis_a")?,
            point(&spec.anchor_b, "anchor_b")?,
            direction(&spec.axis_b, "axis_b")?,
        ]
    })
}

/// The journal's initial eccentricity in its bore (default: centred): perpendicular to
/// the bore axis and shorter than the clearance.
fn initial_eccentricity(
    spec: &JointSpec,
    bore_axis: Vector3<f64>,
    clearance: f64,
    f: &dyn Fn(&str) -> String,
) -> R<Vector3<f64>> {
    Ok(match spec.initial.as_ref() {
        None => Vector3::zeros(),
        Some(init) => {
            let s = &init.value;
            if [&s.angle, &s.rate, &s.position, &s.speed]
                .iter()
                .any(|q| q.is_some())
            {
                return Err(SceneError::at(
                    line(init),
                    f("initial"),
                    "a revolute-clearance joint starts with its journal at an `eccentricity` (default: centred); its bodies' velocities give its rate",
                ));
            }
            let ecc = opt_vec3(&s.eccentricity, Dim::LENGTH, &f("initial.eccentricity"))?;
            let axial = ecc.dot(&bore_axis);
            let radial = (ecc - bore_axis * axial).norm();
            if axial.abs() > 1e-12 * (1.0 + radial) || radial >= clearance {
                return Err(SceneError::at(
                    s.eccentricity.as_ref().and_then(line),
                    f("initial.eccentricity"),
                    format!("must be perpendicular to the bore axis and shorter than the clearance ({clearance} m), got {radial} m radial, {axial} m axial"),
                ));
            }
            ecc
        }
    })
}
