//! A parsed scene validated into a model, integration parameters, phases and probes; every
//! check names the field and its line. Each part of the scene has its own file (`bodies`,
//! `shapes`, `forces`, `joints`, `clearance`, `integrator`, `phases`, `probes`); this one
//! puts them together in the order they refer to each other.

use super::error::{line, SceneError};
use super::fields::{count, positive, vec3, R};
use super::integrator::apply_integrator;
use super::joints::{joint, BuiltJoint};
use super::schema::SceneSpec;
use super::shapes::BuiltContact;
use super::{Scene, Tuning};
use crate::input::units::Dim;
use crate::integrator::assembly::{assemble, AssemblyError, Targets};
use crate::integrator::IntegrationParameters;
use crate::mechanics::contact::compliant::{CompliantContact, CompliantSource};
use crate::mechanics::Model;

/// Every how many steps `simulate --out` records where `record.every` is left out.
pub(super) const RECORD_EVERY: usize = 1;
use nalgebra::Vector3;

/// Builds the scene of the document `spec` (from `file`), tuned by `tuning`.
pub(crate) fn build(spec: SceneSpec, file: &str, tuning: Vec<Tuning>) -> Result<Scene, SceneError> {
    parts(spec, file, tuning).map_err(|e| e.in_file(file))
}

fn parts(document: SceneSpec, file: &str, tuning: Vec<Tuning>) -> R<Scene> {
    let spec = &document;
    if let Some(k) = spec.kind.as_ref().filter(|k| k.value != "mechanism") {
        return Err(SceneError::at(
            line(k),
            "type",
            format!("unknown scene type `{}` (mechanism, function)", k.value),
        ));
    }
    let mut model = Model {
        gravity: match &spec.gravity {
            Some(g) => vec3(g, Dim::ACCELERATION, "gravity")?,
            None => Vector3::new(0.0, 0.0, -9.81),
        },
        ..Default::default()
    };
    add_bodies(&mut model, spec)?;
    if let Some(plane) = &spec.plane {
        super::bodies::hold_to_plane(&mut model, plane, &spec.bodies)?;
    }
    for (i, c) in spec.contacts.iter().enumerate() {
        match super::shapes::contact(&model, c, i, file)? {
            BuiltContact::Rigid(pair) => model.contacts.push(pair),
            BuiltContact::Compliant(c) => model.compliant.push(c),
        }
    }
    for (i, fs) in spec.forces.iter().enumerate() {
        let f = super::forces::force(&model, fs, i)?;
        model.forces.push(f);
    }
    let targets = add_joints(&mut model, spec)?;
    let duration = positive(&spec.duration, Dim::TIME, "duration")?;
    let mut params = IntegrationParameters::default();
    apply_integrator(&spec.integrator, &mut params, "integrator")?;
    // the phases' steps and tolerances are ratios of the document's own
    let schedule = super::phases::schedule(spec, &model, &params)?;
    // probes measure from the written configuration, so they are built before assembly
    let (probes, curves) = super::probes::probes(&model, &spec.probes)?;
    let warnings = super::plausibility::warnings(spec, &model, file);
    let assembly = assemble(&mut model, &targets, params.projection_tolerance).map_err(|e| {
        let joint = match &e {
            AssemblyError::Positions { joint, .. } | AssemblyError::Velocities { joint, .. } => {
                joint
            }
        };
        let i = spec.joints.iter().position(|j| j.name.value == *joint);
        SceneError::at(
            i.and_then(|i| line(&spec.joints[i].name)),
            i.map_or("joints".into(), |i| format!("joints[{i}]")),
            e.to_string(),
        )
    })?;
    for t in &tuning {
        apply_integrator(&t.block, &mut params, &t.origin)?;
    }
    let record_every = spec
        .record
        .every
        .as_ref()
        .map_or(Ok(RECORD_EVERY), |q| count(q, "record.every"))?;
    Ok(Scene {
        name: spec.name.clone().unwrap_or_else(|| "scene".into()),
        spec: document,
        file: file.to_string(),
        tuning,
        probes,
        curves,
        warnings,
        assembly,
        params,
        schedule,
        model,
        duration,
        record_every,
    })
}

/// The document's bodies, each name once.
fn add_bodies(model: &mut Model, spec: &SceneSpec) -> R<()> {
    if spec.bodies.is_empty() {
        return Err(SceneError::at(
            None,
            "bodies",
            "a scene needs at least one body",
        ));
    }
    for (i, b) in spec.bodies.iter().enumerate() {
        if model.body_index(&b.name.value).is_some() {
            return Err(SceneError::at(
                line(&b.name),
                format!("bodies[{i}].name"),
                format!("duplicate body name `{}`", b.name.value),
            ));
        }
        model.bodies.push(super::bodies::body(b, i)?);
    }
    Ok(())
}

/// The document's joints, each name once and fit for parameter paths, with the
/// coordinates and eccentricities the assembly aims at.
fn add_joints(model: &mut Model, spec: &SceneSpec) -> R<Targets> {
    let mut targets = Targets::default();
    for (i, j) in spec.joints.iter().enumerate() {
        if j.name.value.is_empty() || j.name.value.contains('.') {
            return Err(SceneError::at(
                line(&j.name),
                format!("joints[{i}].name"),
                "must be non-empty and without `.` (names are parts of parameter paths)",
            ));
        }
        if model.joints.iter().any(|k| k.name == j.name.value)
            || model
                .clearance_joints
                .iter()
                .any(|k| k.name == j.name.value)
        {
            return Err(SceneError::at(
                line(&j.name),
                format!("joints[{i}].name"),
                format!("duplicate joint name `{}`", j.name.value),
            ));
        }
        match joint(model, j, i)? {
            BuiltJoint::Ideal(joint, start) => {
                model.joints.push(joint);
                targets.joints.push(start);
            }
            BuiltJoint::Clearance(joint, offset, law) => {
                if let Some(law) = law {
                    model.compliant.push(CompliantContact {
                        source: CompliantSource::Journal(joint.clone()),
                        law,
                    });
                }
                model.clearance_joints.push(joint);
                targets.eccentricities.push(offset);
            }
        }
    }
    Ok(targets)
}
