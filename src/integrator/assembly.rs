//! Assembly at t = 0: the scene's written poses, which only need to be approximate, are
//! moved to the nearest configuration, in the mass metric, at which every joint holds:
//! ideal joints exactly (their position drives at their start value), clearance joints
//! with the journal centred in its bore or at its declared eccentricity, and each joint's
//! `initial` coordinate. It is the position projection of the combined scheme
//! (`projection.rs`) with those rows; a target far from the written configuration is
//! reached in steps of at most [`STAGE`] rad (continuation), so that Gauss–Newton stays on
//! the branch the written poses are near.
//!
//! The initial twists are then projected, in the same metric, onto the velocity
//! constraints of the same rows with the drives' rates and the `initial` rates:
//! v ← v − M⁻¹Hᵀ (H M⁻¹ Hᵀ)⁻¹ (H v − b), the smallest change in kinetic energy.

use super::projection::{inverse_mass, project, ContactRows, ProjectionStorage};
use super::rows;
use crate::mechanics::contact::clearance::ClearanceJoint;
use crate::mechanics::joint::{BilateralRow, Drive, Joint, JointKind, RowUnit, ScalarProfile};
use crate::mechanics::{Model, Motion, Pose};
use crate::solver::EqualitySolver;
use nalgebra::{DVector, Matrix6, Vector3};
use std::fmt;

/// The joint-space initial condition of an ideal joint (from its `initial` block): its
/// coordinate from the written configuration, and its rate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointStart {
    pub coordinate: Option<f64>,
    pub rate: Option<f64>,
}

/// What the assembly aims at, besides the joints themselves.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Targets {
    /// Per ideal joint of the model, in order.
    pub joints: Vec<JointStart>,
    /// Per clearance joint, the journal's offset from the bore axis (bore body frame).
    pub eccentricities: Vec<Vector3<f64>>,
}

/// How far assembly moved one body, and how much it changed its initial twist.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyMove {
    pub body: String,
    /// Displacement of the reference point (m) and rotation (rad).
    pub translation: f64,
    pub rotation: f64,
    /// Change of the velocity (m/s) and of the angular velocity (rad/s).
    pub velocity: f64,
    pub angular_velocity: f64,
}

/// What the assembly did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Assembly {
    /// Every moving body, in the model's order.
    pub bodies: Vec<BodyMove>,
    /// The largest row violation left (m or rad), and the projection's iterations.
    pub residual: f64,
    pub iterations: usize,
}

/// Why a scene cannot be assembled: the joint whose row is furthest off, and by how much.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AssemblyError {
    #[error("the mechanism cannot be assembled: joint `{joint}` stays {residual:.3e} {unit} off after the projection (are the written poses near an assembled configuration, and can the joints close with these dimensions?)")]
    Positions {
        joint: String,
        residual: f64,
        unit: &'static str,
    },
    #[error("the initial velocities contradict each other at joint `{joint}` (a residual of {residual:.3e} {unit}/s): check its `initial` rate and the drives")]
    Velocities {
        joint: String,
        residual: f64,
        unit: &'static str,
    },
}

/// Largest continuation stage (rad) towards an initial angle.
const STAGE: f64 = 0.25;

/// Rows at or below this violation (m, rad) count as assembled.
const TOLERANCE: f64 = 1e-13;

/// Projection iterations per stage.
const ITERATIONS: usize = 100;

/// A clearance joint as the ideal revolute joint of its journal at its initial offset.
fn centred(j: &ClearanceJoint, offset: &Vector3<f64>, poses: &[Pose]) -> Joint {
    Joint::new(
        j.name.clone(),
        JointKind::Revolute,
        j.bore_body,
        j.journal_body,
        j.bore_center + offset,
        j.journal_point,
        j.bore_axis,
        j.journal_axis,
        poses,
        None,
    )
}

/// The joint held at `coordinate` (and moving at `rate`) at t = 0, as a position drive.
fn held(j: &Joint, coordinate: f64, rate: f64) -> Joint {
    let mut j = j.clone();
    j.drive = Some(Drive::Position(ScalarProfile::Rate {
        start: coordinate,
        rate,
    }));
    j
}

/// The joints that hold at t = 0, with each joint's name per row: positions (`rates`
/// false: the `initial` coordinates) or velocities (the `initial` rates).
fn holding(model: &Model, targets: &Targets, poses: &[Pose], rates: bool) -> Vec<Joint> {
    let mut joints: Vec<Joint> = model
        .joints
        .iter()
        .zip(
            targets
                .joints
                .iter()
                .chain(std::iter::repeat(&JointStart::default())),
        )
        .map(|(j, start)| {
            let driven = matches!(j.drive, Some(Drive::Position(_)));
            match (rates, start.coordinate, start.rate) {
                (_, _, _) if driven => j.clone(),
                (false, Some(c), _) => held(j, c, 0.0),
                (true, _, Some(r)) => held(j, 0.0, r),
                _ => j.clone(),
            }
        })
        .collect();
    for (j, offset) in model.clearance_joints.iter().zip(
        targets
            .eccentricities
            .iter()
            .chain(std::iter::repeat(&Vector3::zeros())),
    ) {
        joints.push(centred(j, offset, poses));
    }
    joints
}

/// The rows of `joints` at `poses` (t = 0), each with its joint's name.
fn rows(joints: &[Joint], poses: &[Pose]) -> (Vec<BilateralRow>, Vec<String>) {
    let (mut rows, mut names) = (Vec::new(), Vec::new());
    for j in joints {
        let before = rows.len();
        j.rows(0.0, poses, &mut rows);
        names.extend(std::iter::repeat_n(j.name.clone(), rows.len() - before));
    }
    (rows, names)
}

fn unit(u: RowUnit) -> &'static str {
    match u {
        RowUnit::Length => "m",
        RowUnit::Angle => "rad",
    }
}

/// Assembles `model` in place: its bodies' poses and initial twists. `tolerance` is the
/// largest row violation accepted (the projection's), the aim being [`TOLERANCE`].
pub fn assemble(
    model: &mut Model,
    targets: &Targets,
    tolerance: f64,
) -> Result<Assembly, AssemblyError> {
    let written: Vec<Pose> = model.bodies.iter().map(|b| b.pose).collect();
    let mask = model.dof_mask();
    let minv = inverse_mass(model, &mask);
    let mut assembly = Assembly::default();
    let poses = positions(model, targets, &written, &minv, &mut assembly)?;
    if assembly.residual > tolerance {
        let (rows, names) = rows(&holding(model, targets, &written, false), &poses);
        let (k, r) = rows
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.value.abs().total_cmp(&b.1.value.abs()))
            .expect("a violation needs a row");
        return Err(AssemblyError::Positions {
            joint: names[k].clone(),
            residual: r.value.abs(),
            unit: unit(r.unit),
        });
    }
    let v0 = model.initial_state().v;
    let v = velocities(model, targets, &written, &poses, &minv, v0.clone())?;
    for (i, body) in model.bodies.iter_mut().enumerate() {
        if body.motion == Motion::Fixed {
            continue;
        }
        let dv = (v.fixed_rows::<3>(6 * i) - v0.fixed_rows::<3>(6 * i)).norm();
        let dw = (v.fixed_rows::<3>(6 * i + 3) - v0.fixed_rows::<3>(6 * i + 3)).norm();
        assembly.bodies.push(BodyMove {
            body: body.name.clone(),
            translation: (poses[i].x - written[i].x).norm(),
            rotation: poses[i].p.angle_to(&written[i].p),
            velocity: dv,
            angular_velocity: dw,
        });
        body.pose = poses[i];
        let mask = body.dof_mask();
        for k in 0..3 {
            if mask[k] {
                body.velocity[k] = v[6 * i + k];
            }
            if mask[3 + k] {
                body.angular_velocity[k] = v[6 * i + 3 + k];
            }
        }
    }
    Ok(assembly)
}

/// The poses that hold the joints, from the `written` ones, by continuation towards the
/// initial coordinates; the projection's iterations and residual go into `assembly`.
fn positions(
    model: &Model,
    targets: &Targets,
    written: &[Pose],
    minv: &[Matrix6<f64>],
    assembly: &mut Assembly,
) -> Result<Vec<Pose>, AssemblyError> {
    let mask = model.dof_mask();
    let mut poses = written.to_vec();
    let position_joints = holding(model, targets, written, false);
    // a joint held at a start value, and how far that is from the written configuration
    let start_of = |j: &Joint| match &j.drive {
        Some(Drive::Position(ScalarProfile::Rate { start, rate })) => {
            Some((*start, *rate, j.coordinate(written)))
        }
        _ => None,
    };
    let far = position_joints
        .iter()
        .filter(|j| j.kind != JointKind::Prismatic)
        .filter_map(|j| start_of(j).map(|(start, _, from)| (start - from).abs()))
        .fold(0.0f64, f64::max);
    let stages = (far / STAGE).ceil().max(1.0) as usize;
    let mut staged = model.clone();
    staged.contacts.clear();
    staged.clearance_joints.clear();
    let mut storage = ProjectionStorage::default();
    for stage in 1..=stages {
        let s = stage as f64 / stages as f64;
        staged.joints = position_joints
            .iter()
            .map(|j| match start_of(j) {
                Some((start, rate, from)) if stage < stages => {
                    held(j, from + s * (start - from), rate)
                }
                _ => j.clone(),
            })
            .collect();
        let outcome = project(
            &staged,
            &mask,
            minv,
            0.0,
            &mut poses,
            &|_, _| {},
            ContactRows::Equality,
            TOLERANCE,
            ITERATIONS,
            None,
            &mut storage,
        );
        assembly.iterations += outcome.iterations;
        assembly.residual = outcome.violation_after;
    }
    Ok(poses)
}

/// The initial twists: from `v`, the smallest change in kinetic energy that meets the
/// joints' rates at `poses`.
fn velocities(
    model: &Model,
    targets: &Targets,
    written: &[Pose],
    poses: &[Pose],
    minv: &[Matrix6<f64>],
    mut v: DVector<f64>,
) -> Result<DVector<f64>, AssemblyError> {
    let (mask, ndof) = (model.dof_mask(), model.dofs());
    let velocity_joints = holding(model, targets, written, true);
    let (rows, names) = rows(&velocity_joints, poses);
    if rows.is_empty() {
        return Ok(v);
    }
    let (h, b) = rows::matrix(&rows, &mask, ndof);
    let mht = rows::inverse_mass_times_rows(minv, &rows, ndof);
    let violation = &h * &v - &b;
    let scale = b.amax().max((&h * &v).amax());
    if violation.amax() > 1e-14 * scale.max(f64::MIN_POSITIVE) {
        let lambda = EqualitySolver::new(&h * &mht).solve(&violation);
        v -= &mht * lambda;
        let left = &h * &v - &b;
        if let Some((k, r)) = left
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .filter(|(_, r)| r.abs() > 1e-9 * scale.max(1.0))
        {
            return Err(AssemblyError::Velocities {
                joint: names[k].clone(),
                residual: r.abs(),
                unit: unit(rows[k].unit),
            });
        }
    }
    Ok(v)
}

impl Assembly {
    /// Whether the written poses were kept as they are.
    pub fn poses_kept(&self) -> bool {
        self.bodies
            .iter()
            .all(|b| b.translation == 0.0 && b.rotation == 0.0)
    }

    /// Whether the written velocities were kept as they are.
    pub fn velocities_kept(&self) -> bool {
        self.bodies
            .iter()
            .all(|b| b.velocity == 0.0 && b.angular_velocity == 0.0)
    }
}

/// What the assembly changed: one line per body moved, one per body whose velocity changed.
impl fmt::Display for Assembly {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.poses_kept() {
            writeln!(
                f,
                "assembly         the written poses hold every joint (largest residual {:.1e})",
                self.residual
            )?;
        } else {
            writeln!(
                f,
                "assembly         bodies moved to close the joints (largest residual {:.1e} after {} iterations):",
                self.residual, self.iterations
            )?;
            // bodies moved by round-off alone are left out
            for b in self
                .bodies
                .iter()
                .filter(|b| b.translation > 1e-9 || b.rotation > 1e-9)
            {
                writeln!(
                    f,
                    "  {:<16} moved {:.3} µm, turned {:.4}°",
                    b.body,
                    b.translation * 1e6,
                    b.rotation.to_degrees()
                )?;
            }
        }
        if !self.velocities_kept() {
            writeln!(
                f,
                "initial velocity made consistent with the joints and drives (the smallest change in kinetic energy):"
            )?;
            for b in self
                .bodies
                .iter()
                .filter(|b| b.velocity > 0.0 || b.angular_velocity > 0.0)
            {
                writeln!(
                    f,
                    "  {:<16} velocity changed by {:.4e} m/s, angular velocity by {:.4e} rad/s",
                    b.body, b.velocity, b.angular_velocity
                )?;
            }
        }
        Ok(())
    }
}
