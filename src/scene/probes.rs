//! Validation of the scene's `probes` into [`Probe`]s: names resolved to contact candidates,
//! bodies and other probes, every error with its field and line.

use super::error::{line, SceneError};
use super::fields::{body_ref, count, opt_vec3, positive, scalar, unit_vec3};
use super::schema::{DistanceSpec, EventSpec, MeasureSpec, Name, ProbeSpec, TimeRef as TimeSpec};
use crate::input::units::{Dim, DisplayUnit};
use crate::mechanics::force::TorsionalSpring;
use crate::mechanics::joint::JointKind;
use crate::mechanics::BodyRef;
use crate::mechanics::Model;
use crate::probe::curve::{Curve, Grid, ReferenceFile};
use crate::probe::{
    Direction, Event, Measure, Part, Probe, ProbeKind, Reduce, RelativeAngle, TimeRef, Transmission,
};
use nalgebra::Vector3;
use serde_saphyr::Spanned;

type R<T> = Result<T, SceneError>;

/// The contact candidates of a contact pair or clearance joint named `name`; the error names
/// `field` and lists the names there are.
pub(crate) fn contact(model: &Model, name: &Name, field: &str) -> R<Vec<usize>> {
    let ids = model.contact_candidates_of(&name.value);
    if ids.is_empty() && model.joints.iter().any(|j| j.name == name.value) {
        return Err(SceneError::at(
            line(name),
            field,
            format!(
                "joint `{}` is ideal (a revolute-clearance joint of clearance 0 is one): it has no contact to measure; its `reaction` gives what it carries",
                name.value
            ),
        ));
    }
    if ids.is_empty() && !model.compliant_points_of(&name.value).is_empty() {
        return Err(SceneError::at(
            line(name),
            field,
            format!(
                "`{}` is compliant: this needs a rigid contact (a compliant contact's force is finite: measure its `contact_force`; its touch and release are `crosses: 0` of its `gap`, `direction: down` and `up`)",
                name.value
            ),
        ));
    }
    if ids.is_empty() {
        let known: Vec<&str> = model
            .contacts
            .iter()
            .map(|c| c.name.as_str())
            .chain(model.clearance_joints.iter().map(|j| j.name.as_str()))
            .chain(model.compliant.iter().map(|c| c.name()))
            .collect();
        return Err(SceneError::at(
            line(name),
            field,
            format!(
                "unknown contact `{}` (contacts and clearance joints: {})",
                name.value,
                known.join(", ")
            ),
        ));
    }
    Ok(ids)
}

/// A joint of the scene by name: an ideal joint's index, or a clearance joint's.
enum JointName {
    Ideal(usize),
    Clearance(usize),
}

fn joint(model: &Model, name: &Name, field: &str) -> R<JointName> {
    if let Some(i) = model.joints.iter().position(|j| j.name == name.value) {
        return Ok(JointName::Ideal(i));
    }
    if let Some(i) = model
        .clearance_joints
        .iter()
        .position(|j| j.name == name.value)
    {
        return Ok(JointName::Clearance(i));
    }
    let known: Vec<&str> = model
        .joints
        .iter()
        .map(|j| j.name.as_str())
        .chain(model.clearance_joints.iter().map(|j| j.name.as_str()))
        .collect();
    Err(SceneError::at(
        line(name),
        field,
        format!(
            "unknown joint `{}` (joints: {})",
            name.value,
            if known.is_empty() {
                "none".into()
            } else {
                known.join(", ")
            }
        ),
    ))
}

/// A moving body by name (the ground has no velocity to measure).
fn body(model: &Model, name: &Name, field: &str) -> R<usize> {
    body_ref(model, name, field)?
        .ok_or_else(|| SceneError::at(line(name), field, "the ground does not move: name a body"))
}

/// A frame by name: `world` (`None`) or a body's.
fn frame(model: &Model, name: &Option<Name>, field: &str) -> R<BodyRef> {
    match name {
        None => Ok(None),
        Some(n) if n.value == "world" => Ok(None),
        Some(n) => body_ref(model, n, field),
    }
}

/// Which number of a vector measure the spec asks for: `axis` (with `frame`), or
/// `angle_from` about the joint axis `about` (when the measure has one), or the magnitude.
fn part(
    model: &Model,
    s: &MeasureSpec,
    about: Option<(BodyRef, Vector3<f64>)>,
    field: &str,
) -> R<(Part, bool)> {
    let f = |x: &str| format!("{field}.{x}");
    let frame = frame(model, &s.frame, &f("frame"))?;
    match (&s.axis, &s.angle_from) {
        (Some(a), None) => Ok((
            Part::Along {
                axis: unit_vec3(a, &f("axis"))?,
                frame,
            },
            false,
        )),
        (None, Some(r)) => {
            let Some(about) = about else {
                return Err(SceneError::at(
                    line(r),
                    f("angle_from"),
                    "an angle needs a joint axis to turn about: only reactions and eccentricities of revolute joints take `angle_from`",
                ));
            };
            Ok((
                Part::Angle {
                    reference: unit_vec3(r, &f("angle_from"))?,
                    frame,
                    about,
                },
                true,
            ))
        }
        (None, None) => {
            if let Some(n) = &s.frame {
                return Err(SceneError::at(
                    line(n),
                    f("frame"),
                    "`frame` goes with `axis` or `angle_from`",
                ));
            }
            Ok((Part::Magnitude, false))
        }
        (Some(a), Some(_)) => Err(SceneError::at(
            line(a),
            f("axis"),
            "give `axis` (a component) or `angle_from` (a direction), not both",
        )),
    }
}

/// The quantities a measure can be, by their key.
const MEASURES: &str = "gap, contact_force, impulse, distance, angle, displacement, velocity, angular_velocity, reaction, reaction_torque, drive_effort, eccentricity";

fn measure(model: &Model, m: &Spanned<MeasureSpec>, field: &str) -> R<(Measure, Dim)> {
    let s = &m.value;
    let f = |x: &str| format!("{field}.{x}");
    check_one_measure(m, field)?;
    for (n, force) in [(&s.gap, false), (&s.contact_force, true)] {
        let Some(n) = n else { continue };
        let compliant = model.compliant_points_of(&n.value);
        if compliant.is_empty() {
            continue;
        }
        let rigid = model.contact_candidates_of(&n.value);
        return Ok(match force {
            false => (Measure::CompliantGap { rigid, compliant }, Dim::LENGTH),
            true => (Measure::CompliantForce { rigid, compliant }, Dim::FORCE),
        });
    }
    if let Some(n) = &s.gap {
        return Ok((Measure::Gap(contact(model, n, &f("gap"))?), Dim::LENGTH));
    }
    if let Some(n) = &s.contact_force {
        let ids = contact(model, n, &f("contact_force"))?;
        return Ok((Measure::ContactForce(ids), Dim::FORCE));
    }
    if let Some(n) = &s.impulse {
        let ids = contact(model, n, &f("impulse"))?;
        return Ok((Measure::Impulse(ids), Dim::IMPULSE));
    }
    if let Some(d) = &s.distance {
        return distance_measure(model, &d.value, field);
    }
    let frames = zero_at_frames(s, field)?;
    if let Some(n) = s.angle.as_ref().or(s.displacement.as_ref()) {
        return coordinate_measure(model, n, s.angle.is_none(), frames, field);
    }
    if let Some(p) = &s.velocity {
        let b = body(model, &p.value.body, &f("velocity.body"))?;
        let point = opt_vec3(&p.value.point, Dim::LENGTH, &f("velocity.point"))?;
        let (part, angle) = part(model, s, None, field)?;
        debug_assert!(!angle);
        return Ok((
            Measure::PointVelocity {
                body: b,
                point,
                part,
            },
            Dim::VELOCITY,
        ));
    }
    if let Some(n) = &s.angular_velocity {
        let b = body(model, n, &f("angular_velocity"))?;
        let (part, _) = part(model, s, None, field)?;
        return Ok((
            Measure::AngularVelocity { body: b, part },
            Dim::ANGULAR_VELOCITY,
        ));
    }
    if let Some(n) = s.reaction.as_ref().or(s.reaction_torque.as_ref()) {
        return reaction_measure(model, s, n, field);
    }
    if let Some(n) = &s.drive_effort {
        return drive_effort_measure(model, n, field);
    }
    let n = s.eccentricity.as_ref().expect("one measure given");
    let dim = |angle: bool| if angle { Dim::NONE } else { Dim::LENGTH };
    match joint(model, n, &f("eccentricity"))? {
        JointName::Clearance(j) => {
            let c = &model.clearance_joints[j];
            let (part, angle) = part(model, s, Some((c.bore_body, c.bore_axis)), field)?;
            Ok((Measure::Eccentricity { joint: j, part }, dim(angle)))
        }
        // a clearance joint at clearance 0 is an ideal revolute joint: its journal stays on
        // the axis
        JointName::Ideal(j) if model.joints[j].kind == JointKind::Revolute => {
            let ideal = &model.joints[j];
            let (part, angle) = part(model, s, Some((ideal.a, ideal.axis_a)), field)?;
            Ok((Measure::IdealEccentricity { joint: j, part }, dim(angle)))
        }
        JointName::Ideal(_) => Err(SceneError::at(
            line(n),
            f("eccentricity"),
            format!(
                "joint `{}` is not revolute: only a revolute joint, with or without clearance, has an eccentricity",
                n.value
            ),
        )),
    }
}

/// Refuses a measure that names no quantity or more than one, or that gives a vector
/// quantity's `axis`, `angle_from` or `frame` to a scalar one.
fn check_one_measure(m: &Spanned<MeasureSpec>, field: &str) -> R<()> {
    let s = &m.value;
    let f = |x: &str| format!("{field}.{x}");
    let given = [
        s.gap.is_some(),
        s.contact_force.is_some(),
        s.impulse.is_some(),
        s.distance.is_some(),
        s.angle.is_some(),
        s.displacement.is_some(),
        s.velocity.is_some(),
        s.angular_velocity.is_some(),
        s.reaction.is_some(),
        s.reaction_torque.is_some(),
        s.drive_effort.is_some(),
        s.eccentricity.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(SceneError::at(
            line(m),
            field,
            format!("needs exactly one of {MEASURES}"),
        ));
    }
    let vector = s.velocity.is_some()
        || s.angular_velocity.is_some()
        || s.reaction.is_some()
        || s.reaction_torque.is_some()
        || s.eccentricity.is_some();
    if !vector {
        if let Some(x) = [&s.axis, &s.angle_from].into_iter().flatten().next() {
            return Err(SceneError::at(
                line(x),
                field,
                "`axis` and `angle_from` belong to vector quantities (velocity, angular_velocity, reaction, reaction_torque, eccentricity)",
            ));
        }
        if let Some(n) = &s.frame {
            return Err(SceneError::at(
                line(n),
                f("frame"),
                "`frame` belongs to vector quantities",
            ));
        }
    }
    Ok(())
}

/// A `distance` between two points along an axis.
fn distance_measure(model: &Model, d: &DistanceSpec, field: &str) -> R<(Measure, Dim)> {
    let g = |x: &str| format!("{field}.distance.{x}");
    Ok((
        Measure::Distance {
            from: (
                body_ref(model, &d.from.body, &g("from.body"))?,
                opt_vec3(&d.from.point, Dim::LENGTH, &g("from.point"))?,
            ),
            to: (
                body_ref(model, &d.to.body, &g("to.body"))?,
                opt_vec3(&d.to.point, Dim::LENGTH, &g("to.point"))?,
            ),
            axis: unit_vec3(&d.axis, &g("axis"))?,
            frame: frame(model, &d.frame, &g("frame"))?,
        },
        Dim::LENGTH,
    ))
}

/// Whether a joint `angle` counts from the joint's frames (`zero: frames`) rather than
/// from the written configuration.
fn zero_at_frames(s: &MeasureSpec, field: &str) -> R<bool> {
    match s.zero.as_ref().map(|z| (z.value.as_str(), z)) {
        None | Some(("written", _)) => Ok(false),
        Some(("frames", _)) if s.angle.is_some() => Ok(true),
        Some((other, z)) => Err(SceneError::at(
            line(z),
            format!("{field}.zero"),
            if s.angle.is_some() {
                format!("unknown zero `{other}` (written, frames)")
            } else {
                "`zero` goes with a joint `angle`".into()
            },
        )),
    }
}

/// A joint's `angle` or (`prismatic_wanted`) `displacement`, counted from its frames
/// where `frames`.
fn coordinate_measure(
    model: &Model,
    n: &Name,
    prismatic_wanted: bool,
    frames: bool,
    field: &str,
) -> R<(Measure, Dim)> {
    let key = if prismatic_wanted {
        "displacement"
    } else {
        "angle"
    };
    let f = |x: &str| format!("{field}.{x}");
    match joint(model, n, &f(key))? {
        JointName::Ideal(j) => {
            let kind = model.joints[j].kind;
            let prismatic = kind == JointKind::Prismatic;
            let has = matches!(kind, JointKind::Revolute | JointKind::Prismatic);
            if !has || prismatic != prismatic_wanted {
                return Err(SceneError::at(
                    line(n),
                    f(key),
                    format!(
                        "joint `{}` is {} joint: {}",
                        n.value,
                        kind.name(),
                        match kind {
                            JointKind::Revolute => "measure its `angle`",
                            JointKind::Prismatic => "measure its `displacement`",
                            _ => "it has no coordinate",
                        }
                    ),
                ));
            }
            let dim = if prismatic { Dim::LENGTH } else { Dim::NONE };
            if frames {
                let joint = &model.joints[j];
                return Ok((
                    Measure::FrameAngle {
                        a: joint.a,
                        b: joint.b,
                        axis_a: joint.axis_a,
                    },
                    dim,
                ));
            }
            Ok((Measure::Coordinate(j), dim))
        }
        JointName::Clearance(j) if !prismatic_wanted && frames => {
            let c = &model.clearance_joints[j];
            Ok((
                Measure::FrameAngle {
                    a: c.bore_body,
                    b: c.journal_body,
                    axis_a: c.bore_axis,
                },
                Dim::NONE,
            ))
        }
        JointName::Clearance(j) if !prismatic_wanted => {
            let gauge = relative_angle(model, j);
            Ok((Measure::RelativeAngle(gauge), Dim::NONE))
        }
        JointName::Clearance(_) => Err(SceneError::at(
            line(n),
            f(key),
            format!(
                "joint `{}` is a revolute-clearance joint: measure its `angle`",
                n.value
            ),
        )),
    }
}

/// The angle a clearance joint's journal body has turned about the bore axis relative to
/// the bore body, from the written configuration.
fn relative_angle(model: &Model, j: usize) -> RelativeAngle {
    let c = &model.clearance_joints[j];
    let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
    RelativeAngle(TorsionalSpring::new(
        c.bore_body,
        c.journal_body,
        c.bore_axis,
        &poses,
        0.0,
        0.0,
        0.0,
        0.0,
    ))
}

/// The `reaction` (or `reaction_torque`) a joint transmits.
fn reaction_measure(model: &Model, s: &MeasureSpec, n: &Name, field: &str) -> R<(Measure, Dim)> {
    let f = |x: &str| format!("{field}.{x}");
    let torque = s.reaction_torque.is_some();
    let key = if torque {
        "reaction_torque"
    } else {
        "reaction"
    };
    let (through, about) = match joint(model, n, &f(key))? {
        JointName::Ideal(j) => {
            let joint = &model.joints[j];
            let about =
                matches!(joint.kind, JointKind::Revolute).then_some((joint.a, joint.axis_a));
            (Transmission::of_joint(model, j), about)
        }
        JointName::Clearance(j) => {
            let c = &model.clearance_joints[j];
            (
                Transmission::of_clearance(model, j),
                Some((c.bore_body, c.bore_axis)),
            )
        }
    };
    let (part, angle) = part(model, s, about, field)?;
    let dim = match (angle, torque) {
        (true, _) => Dim::NONE,
        (false, true) => Dim::TORQUE,
        (false, false) => Dim::FORCE,
    };
    Ok((
        Measure::Reaction {
            through,
            torque,
            part,
        },
        dim,
    ))
}

/// The effort of a joint's drive.
fn drive_effort_measure(model: &Model, n: &Name, field: &str) -> R<(Measure, Dim)> {
    let f = |x: &str| format!("{field}.{x}");
    let JointName::Ideal(j) = joint(model, n, &f("drive_effort"))? else {
        return Err(SceneError::at(
            line(n),
            f("drive_effort"),
            format!(
                "joint `{}` is a revolute-clearance joint, which has no drive",
                n.value
            ),
        ));
    };
    let joint = &model.joints[j];
    if joint.drive.is_none() {
        return Err(SceneError::at(
            line(n),
            f("drive_effort"),
            format!("joint `{}` has no drive", n.value),
        ));
    }
    let dim = if joint.kind == JointKind::Prismatic {
        Dim::FORCE
    } else {
        Dim::TORQUE
    };
    Ok((Measure::DriveEffort(j), dim))
}

/// Why a reduction of a measure depends on the step size, if it does: in a rigid model an
/// impact is an impulse, so the peak of a force over steps that contain impacts grows as
/// 1/h. Forces are impulsive wherever the scene has unilateral contacts. The minimum of a
/// contact's normal force is exempt: that force is never negative, so an impulse can only
/// raise it, and its minimum is the margin of a contact that must hold (a cam follower).
fn caution(
    model: &Model,
    measure: &Measure,
    reduce: Reduce,
    averaged: bool,
    field: &str,
) -> Option<String> {
    let unilateral = !model.contacts.is_empty()
        || !model.clearance_joints.is_empty()
        || model.joints.iter().any(|j| j.limits.is_some());
    let force = matches!(
        measure,
        Measure::ContactForce(_) | Measure::Reaction { .. } | Measure::DriveEffort(_)
    );
    let normal_force_minimum = matches!(measure, Measure::ContactForce(_)) && reduce == Reduce::Min;
    let peak = matches!(reduce, Reduce::Max | Reduce::Min) && !normal_force_minimum;
    (unilateral && force && peak && !averaged).then(|| {
        format!(
            "`{field}` takes the {} of a force in a mechanism with impacts: a rigid impact is an impulse, so the peak force grows as 1/h and this value depends on the step size. Converged alternatives: the quasi-static peak, the peak of the force's mean over a fixed time (`mean_over: 1 ms` beside `reduce`), the largest impact impulse (`impulse:` with `reduce: max`), or the force's mean over a window (`reduce: mean`)",
            if reduce == Reduce::Max { "maximum" } else { "minimum" }
        )
    })
}

fn event(model: &Model, e: &Spanned<EventSpec>, field: &str) -> R<(Event, usize)> {
    let s = &e.value;
    let f = |s: &str| format!("{field}.{s}");
    let occurrence = s
        .occurrence
        .as_ref()
        .map_or(Ok(1), |q| count(q, &f("occurrence")))?;
    let kinds = [s.closes.is_some(), s.opens.is_some(), s.crosses.is_some()];
    if kinds.iter().filter(|&&k| k).count() != 1 {
        return Err(SceneError::at(
            line(e),
            field,
            "needs exactly one of `closes`, `opens`, `crosses`",
        ));
    }
    if let Some(n) = &s.closes {
        return Ok((Event::Closes(contact(model, n, &f("closes"))?), occurrence));
    }
    if let Some(n) = &s.opens {
        return Ok((Event::Opens(contact(model, n, &f("opens"))?), occurrence));
    }
    let Some(m) = &s.measure else {
        return Err(SceneError::at(
            line(e),
            f("measure"),
            "`crosses` needs the `measure` that crosses",
        ));
    };
    let (measure, dim) = measure(model, m, &f("measure"))?;
    let threshold = scalar(
        s.crosses.as_ref().expect("checked above"),
        dim,
        &f("crosses"),
    )?;
    let direction = match s.direction.as_ref().map(|d| (d.value.as_str(), d)) {
        None | Some(("either", _)) => Direction::Either,
        Some(("up", _)) => Direction::Up,
        Some(("down", _)) => Direction::Down,
        Some((other, d)) => {
            return Err(SceneError::at(
                line(d),
                f("direction"),
                format!("unknown direction `{other}` (up, down, either)"),
            ))
        }
    };
    Ok((
        Event::Crosses {
            measure,
            threshold,
            direction,
        },
        occurrence,
    ))
}

fn time_ref(specs: &[ProbeSpec], t: &Spanned<TimeSpec>, field: &str) -> R<TimeRef> {
    match &t.value {
        TimeSpec::Time(q) => {
            let v = q
                .value(Dim::TIME)
                .map_err(|m| SceneError::at(line(t), field, m))?;
            if !(v >= 0.0 && v.is_finite()) {
                return Err(SceneError::at(
                    line(t),
                    field,
                    format!("must be a time ≥ 0, got {v}"),
                ));
            }
            Ok(TimeRef::Time(v))
        }
        TimeSpec::Probe(name) => {
            let Some(k) = specs.iter().position(|p| p.name.value == *name) else {
                return Err(SceneError::at(
                    line(t),
                    field,
                    format!("`{name}` is neither a time (\"20 ms\") nor a probe name"),
                ));
            };
            if specs[k].event.is_none() {
                return Err(SceneError::at(
                    line(t),
                    field,
                    format!(
                        "probe `{name}` is not an event probe; only event times can bound a window"
                    ),
                ));
            }
            Ok(TimeRef::Probe(k))
        }
    }
}

/// Builds every probe of the scene against `model`: the value and event probes, then the
/// curves, which draw value probes' measures.
pub(super) fn probes(model: &Model, specs: &[ProbeSpec]) -> R<(Vec<Probe>, Vec<Curve>)> {
    // windows and curves refer to value and event probes by their index among them
    let scalars: Vec<ProbeSpec> = specs
        .iter()
        .filter(|p| p.curve.is_none())
        .cloned()
        .collect();
    let mut out: Vec<Probe> = Vec::new();
    let mut curves: Vec<Curve> = Vec::new();
    let mut curve_specs = Vec::new();
    for (i, p) in specs.iter().enumerate() {
        let f = |s: &str| format!("probes[{i}].{s}");
        if let Some(why) = crate::input::columns::column_name_error(&p.name.value) {
            return Err(SceneError::at(line(&p.name), f("name"), why));
        }
        if specs[..i].iter().any(|q| q.name.value == p.name.value) {
            return Err(SceneError::at(
                line(&p.name),
                f("name"),
                format!("duplicate probe name `{}`", p.name.value),
            ));
        }
        if p.curve.is_some() {
            curve_specs.push((i, p));
            continue;
        }
        if let Some(r) = &p.reference {
            return Err(SceneError::at(
                line(r),
                f("reference"),
                "`reference` holds measured points of a curve: it goes with `curve`",
            ));
        }
        out.push(scalar_probe(model, &scalars, p, i)?);
    }
    for (i, p) in curve_specs {
        curves.push(curve_probe(&scalars, &out, p, i)?);
    }
    Ok((out, curves))
}

/// A value or event probe.
fn scalar_probe(model: &Model, scalars: &[ProbeSpec], p: &ProbeSpec, i: usize) -> R<Probe> {
    let f = |s: &str| format!("probes[{i}].{s}");
    let mut caution = None;
    let (kind, dim) = match (&p.event, &p.measure) {
        (Some(e), None) => {
            if let Some(extra) = [&p.at, &p.from, &p.to].into_iter().flatten().next() {
                return Err(SceneError::at(
                    line(extra),
                    f("event"),
                    "an event probe takes no `at`, `from` or `to`",
                ));
            }
            let (event, occurrence) = event(model, e, &f("event"))?;
            (ProbeKind::Event { event, occurrence }, Dim::TIME)
        }
        (None, Some(m)) => {
            let (measure, dim) = measure(model, m, &f("measure"))?;
            let (kind, reduce) = value_probe(scalars, p, measure, &f)?;
            if let ProbeKind::Value {
                measure, mean_over, ..
            } = &kind
            {
                let averaged = mean_over.is_some();
                caution = self::caution(model, measure, reduce, averaged, &p.name.value);
            }
            (kind, dim)
        }
        _ => {
            return Err(SceneError::at(
                line(&p.name),
                format!("probes[{i}]"),
                "needs exactly one of `event`, `measure` and `curve`",
            ))
        }
    };
    Ok(Probe {
        name: p.name.value.clone(),
        unit: dim.si_unit(),
        display: display_unit(p, dim, i)?,
        caution,
        optional: p.optional,
        kind,
    })
}

/// The unit a probe asks its values to be shown in (`unit:`), if it asks.
fn display_unit(p: &ProbeSpec, dim: Dim, i: usize) -> R<Option<DisplayUnit>> {
    p.unit
        .as_ref()
        .map(|u| {
            DisplayUnit::parse(&u.value, dim)
                .map_err(|m| SceneError::at(line(u), format!("probes[{i}].unit"), m))
        })
        .transpose()
}

/// A curve: the measures of two value probes of `built` (in the order of `scalars`), its
/// grid and its window.
fn curve_probe(scalars: &[ProbeSpec], built: &[Probe], p: &ProbeSpec, i: usize) -> R<Curve> {
    let f = |s: &str| format!("probes[{i}].{s}");
    let c = p.curve.as_ref().expect("a curve probe");
    let extra = [
        p.event.as_ref().map(|e| (line(e), "event")),
        p.measure.as_ref().map(|m| (line(m), "measure")),
        p.reduce.as_ref().map(|r| (line(r), "reduce")),
        p.at.as_ref().map(|a| (line(a), "at")),
        p.mean_over.as_ref().map(|q| (line(q), "mean_over")),
    ];
    if let Some((at, key)) = extra.into_iter().flatten().next() {
        return Err(SceneError::at(
            at,
            f(key),
            format!("a curve takes no `{key}`: it draws two value probes' measures (`x`, `y`) on a grid, over the window `from`–`to`"),
        ));
    }
    if p.optional {
        return Err(SceneError::at(
            line(c),
            f("optional"),
            "a curve is never missing as a whole: the grid points its x never reaches are left empty",
        ));
    }
    let axis = |name: &Name, key: &str| -> R<(Measure, Dim, Option<DisplayUnit>)> {
        let Some(k) = built.iter().position(|q| q.name == name.value) else {
            return Err(SceneError::at(
                line(name),
                f(&format!("curve.{key}")),
                format!(
                    "`{}` is not a value probe of the scene (value probes: {})",
                    name.value,
                    built
                        .iter()
                        .filter(|q| matches!(q.kind, ProbeKind::Value { .. }))
                        .map(|q| q.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        };
        match &built[k].kind {
            ProbeKind::Value { measure, .. } => Ok((
                measure.clone(),
                Dim::of_unit(&built[k].unit).unwrap_or(Dim::NONE),
                built[k].display.clone(),
            )),
            ProbeKind::Event { .. } => Err(SceneError::at(
                line(name),
                f(&format!("curve.{key}")),
                format!(
                    "`{}` is an event probe: a curve draws value probes' measures",
                    name.value
                ),
            )),
        }
    };
    let (x, x_dim, x_display) = axis(&c.value.x, "x")?;
    let (y, y_dim, y_display) = axis(&c.value.y, "y")?;
    let grid = grid(&c.value.grid.value, x_dim)
        .map_err(|m| SceneError::at(line(&c.value.grid), f("curve.grid"), m))?;
    let opt = |t: &Option<Spanned<TimeSpec>>, name: &str| {
        t.as_ref()
            .map(|t| time_ref(scalars, t, &f(name)))
            .transpose()
    };
    Ok(Curve {
        name: p.name.value.clone(),
        x_name: c.value.x.value.clone(),
        y_name: c.value.y.value.clone(),
        x,
        y,
        x_unit: x_dim.si_unit(),
        unit: y_dim.si_unit(),
        display: display_unit(p, y_dim, i)?.or(y_display),
        x_display,
        grid,
        from: opt(&p.from, "from")?,
        to: opt(&p.to, "to")?,
        reference: p.reference.as_ref().map(|r| ReferenceFile {
            file: r.value.clone(),
            line: line(r),
            field: f("reference"),
        }),
    })
}

/// A grid written `FROM .. TO step STEP`, each with a unit of x's dimension (or SI).
fn grid(text: &str, dim: Dim) -> Result<Grid, String> {
    let form = "write it as `FROM .. TO step STEP`, e.g. `0 mm .. 6 mm step 0.05 mm`";
    let (from, rest) = text
        .split_once("..")
        .ok_or_else(|| format!("`{text}`: {form}"))?;
    let (to, step) = rest
        .split_once("step")
        .ok_or_else(|| format!("`{text}`: {form}"))?;
    let value = |part: &str, what: &str| -> Result<f64, String> {
        crate::input::units::parse_quantity(part)
            .and_then(|q| q.value(dim))
            .map_err(|e| format!("`{text}`: the grid's {what} `{}` {e}", part.trim()))
    };
    Grid::span(
        value(from, "start")?,
        value(to, "end")?,
        value(step, "step")?,
    )
    .map_err(|e| format!("`{text}`: {e}"))
}

/// A probe that reduces `measure` over time: its reduction and its window (`at`, or
/// `from` and `to`, times that may name other probes of `specs`).
fn value_probe(
    specs: &[ProbeSpec],
    p: &ProbeSpec,
    measure: Measure,
    f: &dyn Fn(&str) -> String,
) -> R<(ProbeKind, Reduce)> {
    let reduce = match p.reduce.as_ref().map(|r| (r.value.as_str(), r)) {
        None | Some(("at", _)) => Reduce::At,
        Some(("max", _)) => Reduce::Max,
        Some(("min", _)) => Reduce::Min,
        Some(("mean", _)) => Reduce::Mean,
        Some(("sum", _)) => Reduce::Sum,
        Some((other, r)) => {
            return Err(SceneError::at(
                line(r),
                f("reduce"),
                format!("unknown reduction `{other}` (at, max, min, mean, sum)"),
            ))
        }
    };
    // an impulse is a step's: summed over a window it is the momentum exchanged; its mean
    // over the steps would shrink with h
    let impulse = matches!(measure, Measure::Impulse(_));
    if let Some(r) = &p.reduce {
        if reduce == Reduce::Sum && !impulse {
            return Err(SceneError::at(
                line(r),
                f("reduce"),
                "`sum` adds up impulses: it goes with `impulse`",
            ));
        }
        if reduce == Reduce::Mean && impulse {
            return Err(SceneError::at(
                line(r),
                f("reduce"),
                "the mean of a step's impulse shrinks with the step: use `sum` (the impulse over the window) or the window mean of `contact_force`",
            ));
        }
    }
    let opt = |t: &Option<Spanned<TimeSpec>>, name: &str| {
        t.as_ref().map(|t| time_ref(specs, t, &f(name))).transpose()
    };
    let (at, from, to) = (opt(&p.at, "at")?, opt(&p.from, "from")?, opt(&p.to, "to")?);
    if reduce == Reduce::At && (from.is_some() || to.is_some()) {
        return Err(SceneError::at(
            line(&p.name),
            f("reduce"),
            "`from`/`to` need a reduction over the window (max, min, mean, sum)",
        ));
    }
    if reduce != Reduce::At && at.is_some() {
        return Err(SceneError::at(
            line(&p.name),
            f("at"),
            "`at` goes with `reduce: at`",
        ));
    }
    let mean_over = p
        .mean_over
        .as_ref()
        .map(|q| {
            if !matches!(reduce, Reduce::Max | Reduce::Min) {
                return Err(SceneError::at(
                    line(q),
                    f("mean_over"),
                    "`mean_over` takes the peak of a running mean: it goes with `reduce: max` or `min`",
                ));
            }
            positive(q, Dim::TIME, &f("mean_over"))
        })
        .transpose()?;
    let kind = ProbeKind::Value {
        measure,
        reduce,
        at,
        from,
        to,
        mean_over,
    };
    Ok((kind, reduce))
}
