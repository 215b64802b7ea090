//! The model: bodies, gravity, force elements and contact pairs. Immutable during a
//! simulation; the evolving state lives in [`State`], so that one model can be run many
//! times (a Monte-Carlo sample is "model + initial state → outputs").

use super::body::{Motion, Pose, RigidBody};
use super::contact::clearance::ClearanceJoint;
use super::contact::{ContactPair, ContactPoint};
use super::force::{Force, Twist};
use super::joint::Joint;
use nalgebra::{DVector, Vector3};

/// A unilateral contact candidate: a point of a contact pair, or a joint stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Candidate {
    Pair { pair: usize, point: usize },
    Limit { joint: usize, upper: bool },
    Clearance { joint: usize, point: usize },
}

/// A body index, or `None` for the ground (the fixed inertial frame).
pub type BodyRef = Option<usize>;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    pub bodies: Vec<RigidBody>,
    pub gravity: Vector3<f64>,
    pub forces: Vec<Force>,
    pub contacts: Vec<ContactPair>,
    pub joints: Vec<Joint>,
    /// Revolute joints with clearance: sets of unilateral contacts.
    pub clearance_joints: Vec<ClearanceJoint>,
    /// The settling phase of a preloaded mechanism, if the scene has one.
    pub settle: Option<Settle>,
    /// A window of finer steps that a contact's first closing opens, if the scene has one.
    pub refine: Option<Refine>,
}

/// A window of finer steps (`refine:` in the scene): from the end of the step in which one
/// of the `trigger` candidates first carries an impulse, for `duration`, the step is
/// `step_ratio` times h (the last one ending at the window's end). A mechanism's trip, a
/// burst of blows and sliding under turning loads, needs a finer step than the approach
/// before it and the swing after it, and it starts at a contact event whose time changes
/// from sample to sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Refine {
    /// The contact candidates (one pair or clearance joint) whose closing opens the window.
    pub trigger: Vec<usize>,
    /// Length of the window (s).
    pub duration: f64,
    /// The window's step over the integrator's h: a ratio, so that a fidelity that changes
    /// h refines the window with it.
    pub step_ratio: f64,
    /// Whether runs with probes take the window twice, at its step and at half of it, and
    /// report each probe as 2 f(h/2) − f(h) (`probe_run`): Richardson extrapolation, which
    /// removes the first-order error that the window's sliding contacts leave.
    pub extrapolate: bool,
}

/// A settling phase (`settle:` in the scene): until `until` every moving body is damped in
/// proportion to its mass, F = −α M v, and friction may be withdrawn from some contacts. A
/// preloaded mechanism that starts from its nominal assembly then comes to rest in the
/// equilibrium its clearances give. Without friction that equilibrium is unique; a
/// frictional one is any state inside the friction cones, so where the chain stops depends
/// on the path it settled along, and that path (impacts, bounces, stick–slip) changes with
/// the step size.
#[derive(Clone, Debug, PartialEq)]
pub struct Settle {
    /// End of the phase (s).
    pub until: f64,
    /// α (1/s).
    pub damping: f64,
    /// The contact pairs and clearance joints that keep their friction during the phase
    /// (by name); `None`: all of them.
    pub friction: Option<Vec<String>>,
    /// The settle's step over the integrator's h (`None`: the same step). A ratio, so that
    /// a fidelity that changes h (a study's `fidelity`, the `converge` ladder) refines the
    /// settle with it. A damped approach to rest needs a coarser step than the dynamics
    /// after it.
    pub step_ratio: Option<f64>,
    /// The contact solver's tolerance while settling over the integrator's (`None`: the
    /// same), a ratio for the same reason. Where the frictionless rest leaves the load
    /// split between a journal's two rings to the solver, a loose tolerance can end the
    /// settle elsewhere, and the trip with it.
    pub tolerance_ratio: Option<f64>,
}

/// Positions (one pose per body) and the generalized velocity (6 per body: v_G inertial,
/// Ω body frame) at time `t`.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    pub t: f64,
    pub poses: Vec<Pose>,
    pub v: DVector<f64>,
}

impl State {
    pub fn twist(&self, i: usize) -> Twist {
        Twist::from_column_slice(&self.v.as_slice()[6 * i..6 * i + 6])
    }
}

impl Model {
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    pub fn dofs(&self) -> usize {
        6 * self.bodies.len()
    }

    pub fn initial_state(&self) -> State {
        let mut v = DVector::zeros(self.dofs());
        for (i, b) in self.bodies.iter().enumerate() {
            let mask = b.dof_mask();
            for k in 0..3 {
                if mask[k] {
                    v[6 * i + k] = b.velocity[k];
                }
                if mask[3 + k] {
                    v[6 * i + 3 + k] = b.angular_velocity[k];
                }
            }
        }
        State {
            t: 0.0,
            poses: self.bodies.iter().map(|b| b.pose).collect(),
            v,
        }
    }

    /// Per-dof flag: integrated (true) or held fixed (false).
    pub fn dof_mask(&self) -> Vec<bool> {
        self.bodies.iter().flat_map(|b| b.dof_mask()).collect()
    }

    /// The settling phase, if the step that starts at `t` is in it.
    pub fn settling(&self, t: f64) -> Option<&Settle> {
        self.settle.as_ref().filter(|s| t < s.until)
    }

    /// The settling phase's damping rate α in the step that starts at `t` (0 outside it).
    pub fn settle_damping(&self, t: f64) -> f64 {
        self.settling(t).map_or(0.0, |s| s.damping)
    }

    /// Whether the candidate loses its friction during the settling phase.
    pub fn frictionless_while_settling(&self, c: Candidate) -> bool {
        self.settle
            .as_ref()
            .and_then(|s| s.friction.as_ref())
            .is_some_and(|keep| !keep.iter().any(|n| *n == self.candidate_owner(c)))
    }

    /// The name of the contact pair, joint or clearance joint a candidate belongs to.
    pub fn candidate_owner(&self, c: Candidate) -> &str {
        match c {
            Candidate::Pair { pair, .. } => &self.contacts[pair].name,
            Candidate::Limit { joint, .. } => &self.joints[joint].name,
            Candidate::Clearance { joint, .. } => &self.clearance_joints[joint].name,
        }
    }

    /// Generalized mass times `v` (diag(m I, I_body) per body).
    pub fn mass_times(&self, v: &DVector<f64>, out: &mut DVector<f64>) {
        for (i, b) in self.bodies.iter().enumerate() {
            let o = 6 * i;
            for k in 0..3 {
                out[o + k] = b.mass * v[o + k];
            }
            let w = v.fixed_rows::<3>(o + 3);
            out.fixed_rows_mut::<3>(o + 3).copy_from(&(b.inertia * w));
        }
    }

    /// Generalized applied wrench F(t, q, v): gravity, −Ω × IΩ and the force elements.
    /// Entries of held degrees of freedom are zero. (The settling damping is the step's:
    /// `velocity_step` adds it.)
    pub fn wrench(&self, t: f64, poses: &[Pose], v: &DVector<f64>, out: &mut DVector<f64>) {
        out.fill(0.0);
        for (i, b) in self.bodies.iter().enumerate() {
            if b.motion == Motion::Fixed {
                continue;
            }
            let om = v.fixed_rows::<3>(6 * i + 3).into_owned();
            let gyro = -om.cross(&(b.inertia * om));
            out.fixed_rows_mut::<3>(6 * i)
                .copy_from(&(self.gravity * b.mass));
            out.fixed_rows_mut::<3>(6 * i + 3).copy_from(&gyro);
        }
        for f in &self.forces {
            f.apply(t, poses, v.as_slice(), out.as_mut_slice());
        }
        for j in &self.joints {
            j.apply_effort(t, poses, out.as_mut_slice());
        }
        for (i, b) in self.bodies.iter().enumerate() {
            if b.motion != Motion::Free {
                let mask = b.dof_mask();
                for k in 0..6 {
                    if !mask[k] {
                        out[6 * i + k] = 0.0;
                    }
                }
            }
        }
    }

    /// Total mechanical energy: kinetic, gravity and the potentials of the force elements.
    pub fn energy(&self, state: &State) -> f64 {
        let mut e = 0.0;
        for (i, b) in self.bodies.iter().enumerate() {
            if b.motion == Motion::Fixed {
                continue;
            }
            let tw = state.twist(i);
            e += b.kinetic_energy(
                &tw.fixed_rows::<3>(0).into_owned(),
                &tw.fixed_rows::<3>(3).into_owned(),
            );
            if b.motion == Motion::Free {
                e -= b.mass * self.gravity.dot(&state.poses[i].x);
            }
        }
        e + self
            .forces
            .iter()
            .map(|f| f.potential(&state.poses))
            .sum::<f64>()
    }

    /// Every candidate contact point, in a fixed order: the points of each contact pair,
    /// then the lower and upper stops of each joint with limits.
    pub fn contact_candidates(&self) -> Vec<Candidate> {
        let pairs = self.contacts.iter().enumerate().flat_map(|(i, c)| {
            (0..c.candidates()).map(move |k| Candidate::Pair { pair: i, point: k })
        });
        let limits = self
            .joints
            .iter()
            .enumerate()
            .filter(|(_, j)| j.limits.is_some())
            .flat_map(|(i, _)| [false, true].map(|upper| Candidate::Limit { joint: i, upper }));
        let clearance = self.clearance_joints.iter().enumerate().flat_map(|(i, j)| {
            (0..j.candidates()).map(move |k| Candidate::Clearance { joint: i, point: k })
        });
        pairs.chain(limits).chain(clearance).collect()
    }

    /// Every candidate of `contact_candidates`, in its order, evaluated at `poses` into
    /// `out`. (It lists the candidates anew; `Simulation` keeps its list and calls
    /// `evaluate_selected` with it.)
    pub fn evaluate_candidates(&self, poses: &[Pose], out: &mut Vec<ContactPoint>) {
        self.evaluate_selected(poses, &self.contact_candidates(), out);
    }

    /// The candidates `selected` (in the order of `contact_candidates`) evaluated at
    /// `poses` into `out`, each clearance joint placed once for its run of points: all of
    /// them at a step's start and end, the projection's few active ones at its trial poses.
    pub fn evaluate_selected(
        &self,
        poses: &[Pose],
        selected: &[Candidate],
        out: &mut Vec<ContactPoint>,
    ) {
        out.clear();
        out.reserve(selected.len());
        let mut rest = selected;
        while let Some((&first, tail)) = rest.split_first() {
            rest = tail;
            match first {
                Candidate::Pair { pair, point } => {
                    out.push(self.contacts[pair].evaluate(point, poses))
                }
                Candidate::Limit { joint, upper } => {
                    out.push(self.joints[joint].limit_point(upper, poses))
                }
                Candidate::Clearance { joint, point } => {
                    // this joint's run of points, placed once
                    let same = |c: &Candidate| match *c {
                        Candidate::Clearance { joint: j, point } if j == joint => Some(point),
                        _ => None,
                    };
                    let run = rest.iter().map_while(same).count();
                    let points = std::iter::once(point).chain(rest.iter().map_while(same));
                    self.clearance_joints[joint].evaluate_points(poses, points, out);
                    rest = &rest[run..];
                }
            }
        }
    }

    /// A readable name of the candidate for outputs: `floor`, `box[3]`, `J1.upper`.
    pub fn candidate_name(&self, c: Candidate) -> String {
        match c {
            Candidate::Pair { pair, point } => {
                let p = &self.contacts[pair];
                if p.candidates() == 1 {
                    p.name.clone()
                } else {
                    format!("{}[{point}]", p.name)
                }
            }
            Candidate::Limit { joint, upper } => format!(
                "{}.{}",
                self.joints[joint].name,
                if upper { "upper" } else { "lower" }
            ),
            Candidate::Clearance { joint, point } => {
                let j = &self.clearance_joints[joint];
                match point {
                    0 => format!("{}.ring-", j.name),
                    1 => format!("{}.ring+", j.name),
                    k if j.is_guard(k) => {
                        let (side, q) = j.guard(k);
                        let sign = if side < 0.0 { '-' } else { '+' };
                        format!("{}.guard{sign}[{q}]", j.name)
                    }
                    k if k - 2 < j.rim_points => format!("{}.flange-[{}]", j.name, k - 2),
                    k => format!("{}.flange+[{}]", j.name, k - 2 - j.rim_points),
                }
            }
        }
    }
}
