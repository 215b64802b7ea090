//! Force elements: point springs and dampers, torsional springs, and prescribed loads
//! (constant or tabulated in time).

use super::error::{line, SceneError};
use super::fields::{body_ref, non_negative, opt_vec3, scalar, unit_vec3, vec3, R};
use super::schema::{ForceSpec, LoadSpec, SpringSpec, TorsionalSpec, Vector, Q};
use crate::input::units::{Dim, Quantity};
use crate::mechanics::force::{frame_angle, ExternalLoad, Frame, PointSpring, TorsionalSpring};
use crate::mechanics::{BodyRef, Force, LoadProfile, Model};
use nalgebra::Vector3;
use serde_saphyr::Spanned;

/// An optional preload ramp time (≥ 0; default 0, no ramp).
fn ramp(q: &Option<Q>, field: &str) -> R<f64> {
    q.as_ref()
        .map_or(Ok(0.0), |q| non_negative(q, Dim::TIME, field))
}

fn table(t: &Spanned<Vec<Vec<Quantity>>>, dim: Dim, field: &str) -> R<LoadProfile> {
    let mut rows = Vec::new();
    for (k, row) in t.value.iter().enumerate() {
        if row.len() != 4 {
            return Err(SceneError::at(
                line(t),
                format!("{field}[{k}]"),
                "rows are [t, x, y, z]",
            ));
        }
        let err = |m: String| SceneError::at(line(t), format!("{field}[{k}]"), m);
        let time = row[0].value(Dim::TIME).map_err(err)?;
        let v = Vector3::new(
            row[1].value(dim).map_err(err)?,
            row[2].value(dim).map_err(err)?,
            row[3].value(dim).map_err(err)?,
        );
        if let Some((prev, _)) = rows.last() {
            if time <= *prev {
                return Err(SceneError::at(
                    line(t),
                    format!("{field}[{k}]"),
                    "times must increase strictly",
                ));
            }
        }
        rows.push((time, v));
    }
    if rows.is_empty() {
        return Err(SceneError::at(line(t), field, "needs at least one row"));
    }
    Ok(LoadProfile::Table(rows))
}

fn profile(
    constant: &Option<Vector>,
    tab: &Option<Spanned<Vec<Vec<Quantity>>>>,
    dim: Dim,
    field: &str,
) -> R<Option<LoadProfile>> {
    match (constant, tab) {
        (Some(c), None) => Ok(Some(LoadProfile::Constant(vec3(c, dim, field)?))),
        (None, Some(t)) => Ok(Some(table(t, dim, &format!("{field}_table"))?)),
        (None, None) => Ok(None),
        (Some(c), Some(_)) => Err(SceneError::at(
            line(c),
            field,
            format!("give `{field}` or `{field}_table`, not both"),
        )),
    }
}

pub(super) fn force(model: &Model, spec: &ForceSpec, i: usize) -> R<Force> {
    let f = |s: &str| format!("forces[{i}].{s}");
    if let Some(n) = &spec.name {
        if n.value.is_empty() || n.value.contains('.') {
            return Err(SceneError::at(
                line(n),
                f("name"),
                "must be non-empty and without `.` (it is part of parameter paths)",
            ));
        }
    }
    let kinds = [
        spec.spring.as_ref().and_then(line),
        spec.torsional_spring.as_ref().and_then(line),
        spec.load.as_ref().and_then(line),
    ];
    let given = [
        spec.spring.is_some(),
        spec.torsional_spring.is_some(),
        spec.load.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(SceneError::at(
            kinds
                .into_iter()
                .flatten()
                .next()
                .or(spec.name.as_ref().and_then(line)),
            format!("forces[{i}]"),
            "needs exactly one of `spring`, `torsional_spring`, `load`",
        ));
    }
    if let Some(s) = &spec.spring {
        point_spring(model, &s.value, &f)
    } else if let Some(s) = &spec.torsional_spring {
        torsional_spring(model, &s.value, &f)
    } else {
        external_load(
            model,
            &spec.load.as_ref().expect("one kind given").value,
            &f,
        )
    }
}

/// The value of an optional quantity, 0 when it is left out.
fn or_zero(q: &Option<Q>, dim: Dim, field: &str) -> R<f64> {
    q.as_ref().map_or(Ok(0.0), |q| scalar(q, dim, field))
}

/// A spring between two points, its rest length by default the written distance.
fn point_spring(model: &Model, s: &SpringSpec, f: &dyn Fn(&str) -> String) -> R<Force> {
    let opt = |q: &Option<Q>, dim: Dim, name: &str| or_zero(q, dim, &f(name));
    let a = body_ref(model, &s.body_a, &f("spring.body_a"))?;
    let b = body_ref(model, &s.body_b, &f("spring.body_b"))?;
    let point_a = opt_vec3(&s.point_a, Dim::LENGTH, &f("spring.point_a"))?;
    let point_b = opt_vec3(&s.point_b, Dim::LENGTH, &f("spring.point_b"))?;
    let pose = |r: BodyRef| r.map_or(crate::mechanics::Pose::identity(), |i| model.bodies[i].pose);
    let initial = (pose(b).point(&point_b) - pose(a).point(&point_a)).norm();
    let damping = s.damping.as_ref().map_or(Ok(0.0), |q| {
        non_negative(q, Dim::DAMPING, &f("spring.damping"))
    })?;
    Ok(Force::Spring(PointSpring {
        a,
        point_a,
        b,
        point_b,
        stiffness: non_negative(&s.stiffness, Dim::STIFFNESS, &f("spring.stiffness"))?,
        damping,
        rest_length: s.rest_length.as_ref().map_or(Ok(initial), |q| {
            non_negative(q, Dim::LENGTH, &f("spring.rest_length"))
        })?,
        preload: opt(&s.preload, Dim::FORCE, "spring.preload")?,
        ramp: ramp(&s.ramp, &f("spring.ramp"))?,
    }))
}

/// A torsional spring about an axis, at rest at `rest_angle` from the written
/// configuration or at `free_angle` from the aligned frames.
fn torsional_spring(model: &Model, s: &TorsionalSpec, f: &dyn Fn(&str) -> String) -> R<Force> {
    let opt = |q: &Option<Q>, dim: Dim, name: &str| or_zero(q, dim, &f(name));
    let a = body_ref(model, &s.body_a, &f("torsional_spring.body_a"))?;
    let b = body_ref(model, &s.body_b, &f("torsional_spring.body_b"))?;
    let poses: Vec<_> = model.bodies.iter().map(|b| b.pose).collect();
    let axis = unit_vec3(&s.axis, &f("torsional_spring.axis"))?;
    let rest_angle = match (&s.rest_angle, &s.free_angle) {
        (Some(r), Some(_)) => {
            return Err(SceneError::at(
                line(r),
                f("torsional_spring.free_angle"),
                "give `rest_angle` (from the written configuration) or `free_angle` (from the frames aligned), not both",
            ))
        }
        (_, Some(free)) => {
            scalar(free, Dim::NONE, &f("torsional_spring.free_angle"))?
                - frame_angle(a, b, &axis, &poses)
        }
        (rest, None) => opt(rest, Dim::NONE, "torsional_spring.rest_angle")?,
    };
    let mut spring = TorsionalSpring::new(
        a,
        b,
        axis,
        &poses,
        non_negative(&s.stiffness, Dim::TORQUE, &f("torsional_spring.stiffness"))?,
        s.damping.as_ref().map_or(Ok(0.0), |q| {
            non_negative(q, Dim::ROTATIONAL_DAMPING, &f("torsional_spring.damping"))
        })?,
        opt(&s.preload, Dim::TORQUE, "torsional_spring.preload")?,
        rest_angle,
    );
    spring.ramp = ramp(&s.ramp, &f("torsional_spring.ramp"))?;
    Ok(Force::Torsional(spring))
}

/// An external load (a force and a torque in time) on a body.
fn external_load(model: &Model, l: &LoadSpec, f: &dyn Fn(&str) -> String) -> R<Force> {
    let body = body_ref(model, &l.body, &f("load.body"))?.ok_or_else(|| {
        SceneError::at(
            line(&l.body),
            f("load.body"),
            "a load acts on a body, not on the ground",
        )
    })?;
    let frame = match l.frame.as_ref().map(|s| s.value.as_str()) {
        None | Some("world") => Frame::World,
        Some("body") => Frame::Body,
        Some(o) => {
            return Err(SceneError::at(
                l.frame.as_ref().and_then(line),
                f("load.frame"),
                format!("unknown frame `{o}` (world or body)"),
            ))
        }
    };
    let force = profile(&l.force, &l.force_table, Dim::FORCE, &f("load.force"))?;
    let torque = profile(&l.torque, &l.torque_table, Dim::TORQUE, &f("load.torque"))?;
    if force.is_none() && torque.is_none() {
        return Err(SceneError::at(
            line(&l.body),
            f("load"),
            "needs a force or a torque",
        ));
    }
    Ok(Force::External(ExternalLoad {
        body,
        point: opt_vec3(&l.point, Dim::LENGTH, &f("load.point"))?,
        force,
        torque,
        frame,
    }))
}
