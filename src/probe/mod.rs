//! Probes: the named outputs of a run (a functional condition, an event time), evaluated
//! online while the simulation steps, so that a sample keeps a few numbers and no trajectory.
//! `run` steps a simulation with its probes (extrapolated over a refinement window).

pub mod curve;
pub mod run;

use crate::input::units::DisplayUnit;
use crate::integrator::Simulation;
use crate::mechanics::force::TorsionalSpring;
use crate::mechanics::joint::Drive;
use crate::mechanics::model::{Candidate, State};
use crate::mechanics::{BodyRef, ContactPoint, Model, Pose};
use curve::{Curve, CurveCells};
use nalgebra::{Matrix3x6, Vector3, Vector6};
use std::collections::VecDeque;
use std::ops::Range;

/// A scalar read off the state after a step.
#[derive(Clone, Debug, PartialEq)]
pub enum Measure {
    /// Smallest gap over these contact candidates (m).
    Gap(Vec<usize>),
    /// Total normal impulse of these candidates over the last step divided by h (N).
    ContactForce(Vec<usize>),
    /// Total normal impulse of these candidates over the last step (N·s): a step's impulse
    /// converges to the impact's as h falls, where the force (impulse / h) grows as 1/h.
    Impulse(Vec<usize>),
    /// Smallest gap of a compliant contact's points (`Model::compliant_points_of`) and of
    /// its rigid candidates (a compliant journal's flanges), m.
    CompliantGap {
        rigid: Vec<usize>,
        compliant: Vec<usize>,
    },
    /// Total normal force of a compliant contact's points at the state, and of its rigid
    /// candidates over the last step (impulse / h), N.
    CompliantForce {
        rigid: Vec<usize>,
        compliant: Vec<usize>,
    },
    /// (p_to − p_from) · axis; the axis is fixed in `frame` (world when `None`).
    Distance {
        from: (BodyRef, Vector3<f64>),
        to: (BodyRef, Vector3<f64>),
        axis: Vector3<f64>,
        frame: BodyRef,
    },
    /// An ideal joint's coordinate (revolute: angle, rad; prismatic: displacement, m), from
    /// the written configuration.
    Coordinate(usize),
    /// The angle of one body relative to another about an axis fixed in the first, from
    /// the written configuration (a revolute-clearance joint's angle), rad.
    RelativeAngle(RelativeAngle),
    /// The angle of body b's frame from body a's about an axis of a's frame (rad): zero
    /// where the frames are aligned, whatever the written configuration.
    FrameAngle {
        a: BodyRef,
        b: BodyRef,
        axis_a: Vector3<f64>,
    },
    /// Velocity of a material point of a body (m/s), as `part` of the world vector.
    PointVelocity {
        body: usize,
        point: Vector3<f64>,
        part: Part,
    },
    /// Angular velocity of a body (rad/s), as `part` of the world vector.
    AngularVelocity { body: usize, part: Part },
    /// What a joint transmits over the last step, divided by h: the force (N), or the
    /// torque about the joint's centre (N·m), that body_a exerts on body_b.
    Reaction {
        through: Transmission,
        torque: bool,
        part: Part,
    },
    /// The torque (N·m) or force (N) a joint's drive applies to its body_b: a position
    /// drive's multiplier over the last step / h, an effort drive's prescribed value.
    DriveEffort(usize),
    /// A clearance joint's journal offset from the bore axis, at the bore's mid-plane (m),
    /// as `part` of the world vector.
    Eccentricity { joint: usize, part: Part },
    /// An ideal revolute joint's eccentricity, the limit of a clearance joint's at
    /// clearance 0: body b's anchor offset from a's axis (m), zero up to the joint's
    /// violation.
    IdealEccentricity { joint: usize, part: Part },
}

/// The angle gauge of a torsional spring, without the spring: zero in the written
/// configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct RelativeAngle(pub TorsionalSpring);

/// What carries a joint reaction.
#[derive(Clone, Debug, PartialEq)]
pub enum Transmission {
    /// An ideal joint: its structural rows (the drive row excluded) among the joints' rows,
    /// and its stops' contact candidates.
    Joint {
        joint: usize,
        rows: Range<usize>,
        stops: Vec<usize>,
    },
    /// A revolute-clearance joint: all its contact candidates.
    Clearance {
        joint: usize,
        candidates: Vec<usize>,
        /// Its compliant rings (`Model::compliant_points_of`), if it is compliant.
        compliant: Vec<usize>,
    },
}

/// Which number of a vector a measure gives.
#[derive(Clone, Debug, PartialEq)]
pub enum Part {
    Magnitude,
    /// The component along `axis`, fixed in `frame` (world when `None`).
    Along {
        axis: Vector3<f64>,
        frame: BodyRef,
    },
    /// The angle (rad, in (−π, π]) of the vector's projection on the plane normal to
    /// `about` (a unit vector of body `about_body`'s frame: the joint's axis), measured from
    /// `reference` (fixed in `frame`) in the positive sense about `about`.
    Angle {
        reference: Vector3<f64>,
        frame: BodyRef,
        about: (BodyRef, Vector3<f64>),
    },
}

impl Part {
    /// The number this part takes of the world vector `v`.
    fn of(&self, v: &Vector3<f64>, poses: &[Pose]) -> f64 {
        let dir = |frame: &BodyRef, x: &Vector3<f64>| match frame {
            Some(b) => poses[*b].dir(x),
            None => *x,
        };
        match self {
            Part::Magnitude => v.norm(),
            Part::Along { axis, frame } => v.dot(&dir(frame, axis)),
            Part::Angle {
                reference,
                frame,
                about: (body, axis),
            } => {
                let n = dir(body, axis);
                let r = dir(frame, reference);
                let (r, v) = (r - n * n.dot(&r), v - n * n.dot(v));
                n.dot(&r.cross(&v)).atan2(r.dot(&v))
            }
        }
    }
}

/// The generalized force (world force, body-frame torque about the centre of mass) on
/// body `b` of an impulse `p` through the 3×6 (or 1×6) Jacobian block `g`.
fn add_impulse(w: &mut Vector6<f64>, g: &Matrix3x6<f64>, p: &Vector3<f64>) {
    *w += g.transpose() * p;
}

impl Transmission {
    /// What carries ideal joint `j`'s reaction: its structural rows (a position drive's
    /// row excluded) and its stops.
    pub fn of_joint(model: &Model, j: usize) -> Transmission {
        let joint = &model.joints[j];
        let start: usize = model.joints[..j].iter().map(|j| j.row_count()).sum();
        let structural =
            joint.row_count() - usize::from(matches!(joint.drive, Some(Drive::Position(_))));
        let stops = model
            .contact_candidates()
            .iter()
            .enumerate()
            .filter(|(_, c)| matches!(c, Candidate::Limit { joint, .. } if *joint == j))
            .map(|(i, _)| i)
            .collect();
        Transmission::Joint {
            joint: j,
            rows: start..start + structural,
            stops,
        }
    }

    /// What carries clearance joint `j`'s reaction: all its contact candidates.
    pub fn of_clearance(model: &Model, j: usize) -> Transmission {
        Transmission::Clearance {
            joint: j,
            candidates: model.contact_candidates_of(&model.clearance_joints[j].name),
            compliant: model.compliant_points_of(&model.clearance_joints[j].name),
        }
    }
}

/// The force and the torque about `centre` (both world) that `through` transmits to its
/// joint's body_b over the last step, divided by h.
pub fn reaction(sim: &Simulation, through: &Transmission) -> (Vector3<f64>, Vector3<f64>) {
    let m = &sim.model;
    let poses = &sim.state.poses;
    let (a, b, centre) = match through {
        Transmission::Joint { joint, .. } => {
            let j = &m.joints[*joint];
            let at = |r: BodyRef, p: &Vector3<f64>| r.map_or(*p, |i| poses[i].point(p));
            (j.a, j.b, at(j.b, &j.anchor_b))
        }
        Transmission::Clearance { joint, .. } => {
            let j = &m.clearance_joints[*joint];
            (j.bore_body, j.journal_body, j.centre(poses))
        }
    };
    // the body the wrench is read on: b, or a (the wrench reversed) where b is the ground
    let (target, sign) = match b {
        Some(i) => (i, 1.0),
        None => (a.expect("a joint has a body"), -1.0),
    };
    let mut w = Vector6::zeros();
    // a contact point's impulse `p` (local frame) on the target
    let point = |w: &mut Vector6<f64>, cp: &ContactPoint, p: &Vector3<f64>| {
        let (g1, g2) = cp.blocks();
        if cp.body1 == Some(target) {
            add_impulse(w, &g1, p);
        }
        if cp.body2 == Some(target) {
            add_impulse(w, &g2, p);
        }
    };
    let contact = |w: &mut Vector6<f64>, c: usize| {
        point(w, &sim.contact_points()[c], &sim.impulses()[c]);
    };
    match through {
        Transmission::Joint { joint, rows, stops } => {
            let q = sim.joint_impulses();
            if q.len() >= rows.end {
                let mut all = Vec::new();
                m.joints[*joint].rows(sim.state.t, poses, &mut all);
                for (row, qr) in all.iter().zip(&q[rows.clone()]) {
                    for (i, g) in row.a.iter().chain(row.b.iter()) {
                        if *i == target {
                            w += g.transpose() * *qr;
                        }
                    }
                }
            }
            stops.iter().for_each(|&c| contact(&mut w, c));
        }
        Transmission::Clearance {
            candidates,
            compliant,
            ..
        } => {
            candidates.iter().for_each(|&c| contact(&mut w, c));
            // a compliant ring's force at the state, as the impulse of a step at it
            for &c in compliant {
                let (cp, f) = &sim.compliant_points()[c];
                point(&mut w, cp, &(f * sim.h()));
            }
        }
    }
    let pose = &poses[target];
    let force = w.fixed_rows::<3>(0) / sim.h();
    let torque_g = pose.p * w.fixed_rows::<3>(3) / sim.h();
    let torque = torque_g + (pose.x - centre).cross(&force);
    (force * sign, torque * sign)
}

fn world_point(poses: &[Pose], (body, p): &(BodyRef, Vector3<f64>)) -> Vector3<f64> {
    match body {
        Some(i) => poses[*i].point(p),
        None => *p,
    }
}

impl Measure {
    /// How long before the state's time the value stands: a force read off the last step's
    /// impulse is the step's mean, which stands at its middle (h/2); a state quantity at the
    /// step's end (0). Reading a step mean at the step's end would shift it by h/2, an O(h)
    /// error in anything interpolated in time (a value `at` an instant, a crossing).
    pub fn lag(&self, sim: &Simulation) -> f64 {
        let step_mean = match self {
            Measure::ContactForce(_) | Measure::Impulse(_) | Measure::Reaction { .. } => true,
            Measure::DriveEffort(j) => {
                matches!(sim.model.joints[*j].drive, Some(Drive::Position(_)))
            }
            _ => false,
        };
        if step_mean && sim.stats.steps > 0 {
            0.5 * sim.h()
        } else {
            0.0
        }
    }

    /// The value after the last step: at the state, or over the step for the step's
    /// quantities (gaps, impulses and the forces they stand for).
    pub fn value(&self, sim: &Simulation) -> f64 {
        if let Some(v) = self.of_state(sim, &sim.state) {
            return v;
        }
        match self {
            Measure::Gap(ids) => ids
                .iter()
                .map(|&i| sim.contact_points()[i].gap())
                .fold(f64::INFINITY, f64::min),
            Measure::ContactForce(ids) => {
                ids.iter().map(|&i| sim.impulses()[i].x).sum::<f64>() / sim.h()
            }
            Measure::Impulse(ids) => ids.iter().map(|&i| sim.impulses()[i].x).sum::<f64>(),
            Measure::CompliantGap { rigid, compliant } => {
                let points = sim.compliant_points();
                rigid
                    .iter()
                    .map(|&i| sim.contact_points()[i].gap())
                    .chain(compliant.iter().map(|&i| points[i].0.gap()))
                    .fold(f64::INFINITY, f64::min)
            }
            Measure::CompliantForce { rigid, compliant } => {
                let points = sim.compliant_points();
                rigid.iter().map(|&i| sim.impulses()[i].x).sum::<f64>() / sim.h()
                    + compliant.iter().map(|&i| points[i].1.x).sum::<f64>()
            }
            Measure::Reaction {
                through,
                torque,
                part,
            } => {
                let (f, t) = reaction(sim, through);
                part.of(if *torque { &t } else { &f }, &sim.state.poses)
            }
            Measure::DriveEffort(j) => {
                // a position drive's effort is its row's impulse over the step, the row
                // being the joint's last
                let end: usize = sim.model.joints[..=*j].iter().map(|j| j.row_count()).sum();
                sim.joint_impulses()
                    .get(end.wrapping_sub(1))
                    .map_or(0.0, |q| q / sim.h())
            }
            _ => unreachable!("a function of the state"),
        }
    }

    /// The value at `state` of a measure that is a function of the state (poses,
    /// velocities, time); `None` for the step's quantities.
    fn of_state(&self, sim: &Simulation, state: &State) -> Option<f64> {
        let poses = &state.poses;
        Some(match self {
            Measure::Gap(_)
            | Measure::ContactForce(_)
            | Measure::Impulse(_)
            | Measure::CompliantGap { .. }
            | Measure::CompliantForce { .. }
            | Measure::Reaction { .. } => return None,
            Measure::Coordinate(j) => sim.model.joints[*j].coordinate(poses),
            Measure::RelativeAngle(g) => g.0.angle(poses).0,
            Measure::FrameAngle { a, b, axis_a } => {
                crate::mechanics::force::frame_angle(*a, *b, axis_a, poses)
            }
            Measure::PointVelocity { body, point, part } => {
                let pose = &poses[*body];
                let tw = state.twist(*body);
                let omega = pose.p * tw.fixed_rows::<3>(3);
                let v = tw.fixed_rows::<3>(0) + omega.cross(&(pose.dir(point)));
                part.of(&v, poses)
            }
            Measure::AngularVelocity { body, part } => {
                let omega = poses[*body].p * state.twist(*body).fixed_rows::<3>(3);
                part.of(&omega, poses)
            }
            Measure::DriveEffort(j) => match &sim.model.joints[*j].drive {
                Some(Drive::Effort(profile)) => profile.value(state.t),
                Some(Drive::Position(_)) => return None,
                None => 0.0,
            },
            Measure::Eccentricity { joint, part } => {
                let e = sim.model.clearance_joints[*joint].eccentricity(poses);
                part.of(&e, poses)
            }
            Measure::IdealEccentricity { joint, part } => {
                let j = &sim.model.joints[*joint];
                let offset =
                    world_point(poses, &(j.b, j.anchor_b)) - world_point(poses, &(j.a, j.anchor_a));
                let axis = j.a.map_or(j.axis_a, |i| poses[i].dir(&j.axis_a));
                part.of(&(offset - axis * axis.dot(&offset)), poses)
            }
            Measure::Distance {
                from,
                to,
                axis,
                frame,
            } => {
                let axis = match frame {
                    Some(b) => poses[*b].dir(axis),
                    None => *axis,
                };
                (world_point(poses, to) - world_point(poses, from)).dot(&axis)
            }
        })
    }

    /// The measure over the step just taken as a polyline of (time, value) from its
    /// previous value `(t0, v0)` to its value now: a straight line, with a corner at the
    /// impact located within the step for a function of the state (the value just before
    /// the impact, then just after it, which differ for a velocity).
    fn over_step(&self, sim: &Simulation, (t0, v0): (f64, f64), now: (f64, f64)) -> StepPath {
        let corner = sim.located_impact().and_then(|impact| {
            let before = self.of_state(sim, &impact.before)?;
            let after = State {
                v: impact.v_after.clone(),
                ..impact.before.clone()
            };
            let ti = impact.before.t;
            Some([(ti, before), (ti, self.of_state(sim, &after)?)])
        });
        let mut path = StepPath::default();
        path.points[0] = (t0, v0);
        let inner = corner.filter(|c| c[0].0 > t0 && c[0].0 < now.0);
        for p in inner.iter().flatten() {
            path.len += 1;
            path.points[path.len] = *p;
        }
        path.len += 1;
        path.points[path.len] = now;
        path.len += 1;
        path
    }
}

/// A measure over one step: at most four (time, value) points, straight between them.
#[derive(Clone, Copy, Debug, Default)]
struct StepPath {
    points: [(f64, f64); 4],
    len: usize,
}

impl StepPath {
    fn segments(&self) -> impl Iterator<Item = ((f64, f64), (f64, f64))> + '_ {
        self.points[..self.len].windows(2).map(|w| (w[0], w[1]))
    }

    /// The value at time `t` within the path (the value just before a corner's jump at
    /// its own time).
    fn at(&self, t: f64) -> f64 {
        for ((ta, va), (tb, vb)) in self.segments() {
            if t <= tb && tb > ta {
                return va + (vb - va) * ((t - ta) / (tb - ta)).max(0.0);
            }
        }
        self.points[self.len - 1].1
    }

    /// The first time the path crosses `threshold` in `direction`, a jump at its instant.
    fn crossing(&self, threshold: f64, direction: Direction) -> Option<f64> {
        self.segments().find_map(|((ta, va), (tb, vb))| {
            let up = va < threshold && vb >= threshold;
            let down = va > threshold && vb <= threshold;
            let wanted = match direction {
                Direction::Up => up,
                Direction::Down => down,
                Direction::Either => up || down,
            };
            wanted.then(|| ta + (tb - ta) * (threshold - va) / (vb - va))
        })
    }
}

/// A time given as a number or as the time of an event probe (by index).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeRef {
    Time(f64),
    Probe(usize),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Up,
    Down,
    Either,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// The candidates' total normal impulse becomes positive, timed within the step: at
    /// the impact's own time where the step located it (`locate_impacts`); else the
    /// event-capturing step knows only that the contact closed somewhere in [t_k, t_k+1],
    /// so the time is t_k + g_k / (−u), the free flight of the step-start gap at the
    /// approach speed u = (g_k − g_k−1)/h of the step before (error about g·h·τ/|u| under
    /// an acceleration g, against h for the step end).
    Closes(Vec<usize>),
    /// The candidates' total normal impulse returns to zero.
    Opens(Vec<usize>),
    Crosses {
        measure: Measure,
        threshold: f64,
        direction: Direction,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    At,
    Max,
    Min,
    /// Time-weighted: each step's value (a contact force is the step's impulse / h) counts
    /// for the part of its interval inside the window (a contact force for its whole
    /// impulse in the step of a `from` event), so a window's mean does not jump by a step's
    /// share when one of its ends crosses a step boundary.
    Mean,
    /// The sum over the window of a step's impulse: each step counts for the part of its
    /// interval inside the window, the step of a `from` event for its whole impulse.
    Sum,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ProbeKind {
    /// The time of the `occurrence`-th event (from 1).
    Event { event: Event, occurrence: usize },
    Value {
        measure: Measure,
        reduce: Reduce,
        /// For `Reduce::At`: when (default: the end of the run).
        at: Option<TimeRef>,
        from: Option<TimeRef>,
        to: Option<TimeRef>,
        /// For `Reduce::Max` and `Min`: the peak of the measure's mean over a trailing
        /// window of this length (s) instead of the peak of its step values. An impact's
        /// impulse then counts as impulse / length, so the peak converges as h falls,
        /// where a step's force (impulse / h) grows as 1/h.
        mean_over: Option<f64>,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    pub name: String,
    /// SI unit of the value ("s", "m", "N").
    pub unit: String,
    /// The unit to show it in (`unit:` in the scene), if the scene gives one.
    pub display: Option<DisplayUnit>,
    /// Why the value depends on the step size, if it does (a peak of an impulsive force
    /// in a rigid model), with the converged alternative; shown wherever the value is.
    pub caution: Option<String>,
    /// When the probe has no value (its event never happens), its output is left empty and
    /// the run keeps its other outputs, instead of failing.
    pub optional: bool,
    pub kind: ProbeKind,
}

/// Per-probe progress during a run.
#[derive(Clone, Debug, Default)]
struct Progress {
    /// The final value, once known.
    value: Option<f64>,
    /// Events: occurrences so far; `Max`, `Min`: samples in the window.
    count: usize,
    /// `Mean`: the time the samples cover inside the window (s).
    weight: f64,
    /// Events: whether the contact was closed after the previous step; values: running
    /// reduction.
    closed: bool,
    acc: f64,
    /// The previous observation (t, measure), to interpolate crossings and `at` times.
    previous: Option<(f64, f64)>,
    /// `Closes` events: each candidate's gap at the previous observation and its rate over
    /// the step before it.
    approach: Vec<(f64, f64)>,
    /// `mean_over`: the measure's integral over the window so far, (time, ∫ value dt), at
    /// step ends back to one before the trailing averaging window.
    integral: VecDeque<(f64, f64)>,
}

impl Progress {
    /// The window's max, min or mean, if it held a sample.
    fn reduced(&self, reduce: Reduce) -> Option<f64> {
        match reduce {
            Reduce::Mean => (self.weight > 0.0).then(|| self.acc / self.weight),
            Reduce::Sum => Some(self.acc),
            _ => (self.count > 0).then_some(self.acc),
        }
    }

    /// Adds a step's share of the window, (start, end] with `area` = ∫ value dt, and
    /// updates the peak (`reduce`: max or min) of the mean over the trailing `length`.
    /// The value is constant over each step, so the integral is exact between step ends.
    fn slide(&mut self, start: f64, end: f64, area: f64, length: f64, reduce: Reduce) {
        let total = self.integral.back().map_or(0.0, |p| p.1) + area;
        if self.integral.is_empty() {
            self.integral.push_back((start, 0.0));
        }
        self.integral.push_back((end, total));
        self.weight += (end - start).max(0.0);
        if self.weight < length * (1.0 - 1e-9) {
            return;
        }
        let back = end - length;
        while self.integral.len() > 2 && self.integral[1].0 <= back {
            self.integral.pop_front();
        }
        let ((ta, ia), (tb, ib)) = (self.integral[0], self.integral[1]);
        let earlier = if tb > ta {
            ia + (ib - ia) * ((back - ta) / (tb - ta)).clamp(0.0, 1.0)
        } else {
            ib
        };
        let mean = (total - earlier) / length;
        self.acc = match (self.count, reduce) {
            (0, _) => mean,
            (_, Reduce::Min) => self.acc.min(mean),
            _ => self.acc.max(mean),
        };
        self.count += 1;
    }
}

/// When, within a step of size h, a contact at gap `gap` approaching at normal velocity
/// `u` (< 0) touches: the free flight gap/(−u), from −h (it touched during the previous
/// step and the step ended penetrating, as plain Moreau–Jean allows) to h. A contact that
/// does not approach closes at the step start if touching, else at the step end.
fn closing_delay(gap: f64, u: f64, h: f64) -> f64 {
    if u < 0.0 {
        (gap / -u).clamp(-h, h)
    } else if gap <= 0.0 {
        0.0
    } else {
        h
    }
}

/// The time `r` stands for, if known (an event probe's time once it happened).
fn time_of(progress: &[Progress], r: TimeRef) -> Option<f64> {
    match r {
        TimeRef::Time(t) => Some(t),
        TimeRef::Probe(i) => progress[i].value,
    }
}

/// Observes a simulation step by step and produces every probe's value and every curve.
#[derive(Clone)]
pub struct ProbeRecorder<'a> {
    probes: &'a [Probe],
    progress: Vec<Progress>,
    curves: &'a [Curve],
    cells: Vec<CurveCells>,
    /// The previous observation's time: the step just observed covers (last_t, t].
    last_t: Option<f64>,
}

impl<'a> ProbeRecorder<'a> {
    pub fn new(probes: &'a [Probe], curves: &'a [Curve]) -> Self {
        ProbeRecorder {
            probes,
            progress: vec![Progress::default(); probes.len()],
            curves,
            cells: curves.iter().map(|c| CurveCells::new(&c.grid)).collect(),
            last_t: None,
        }
    }

    /// The time of an event probe, if it happened.
    fn time(&self, r: TimeRef) -> Option<f64> {
        time_of(&self.progress, r)
    }

    /// The earliest instant after `t` that a probe reads a value at or bounds a window by
    /// (`at`, `from`, `to`, given as times or as events already timed): a controlled run
    /// ends a step there, where interpolating across a long step would cost accuracy.
    pub fn next_instant(&self, t: f64) -> Option<f64> {
        self.probes
            .iter()
            .filter_map(|p| match &p.kind {
                ProbeKind::Value { at, from, to, .. } => Some([*at, *from, *to]),
                ProbeKind::Event { .. } => None,
            })
            .flatten()
            .flatten()
            .filter_map(|r| self.time(r))
            .filter(|&x| x > t * (1.0 + 1e-12) + 1e-15)
            .min_by(f64::total_cmp)
    }

    /// Adds the step just taken, (last_t, t], to every curve whose window it meets.
    fn observe_curves(&mut self, sim: &Simulation) {
        let t = sim.state.t;
        for (c, cells) in self.curves.iter().zip(self.cells.iter_mut()) {
            if cells.closed {
                continue;
            }
            let x = c.x.value(sim);
            let previous = cells.previous_x.replace(x);
            let (Some(t_prev), Some(xa)) = (self.last_t, previous) else {
                continue;
            };
            let t1 = c.to.and_then(|r| time_of(&self.progress, r));
            if t1.is_some_and(|t1| t_prev >= t1) {
                cells.closed = true;
                continue;
            }
            let t0 = match c.from {
                None => f64::NEG_INFINITY,
                Some(r) => match time_of(&self.progress, r) {
                    Some(t0) => t0,
                    None => continue,
                },
            };
            let (a, b) = (t_prev.max(t0), t.min(t1.unwrap_or(f64::INFINITY)));
            if b > a {
                let along = |s: f64| xa + (x - xa) * ((s - t_prev) / (t - t_prev));
                cells.add(&c.grid, along(a), along(b), c.y.value(sim), b - a);
            }
        }
    }

    /// Updates every probe with the state after a step (and once with the initial state).
    pub fn observe(&mut self, sim: &Simulation) {
        let t = sim.state.t;
        let half_step = 0.5 * sim.h();
        // events first, so that a window opened by an event includes the event's step
        for (p, g) in self.probes.iter().zip(self.progress.iter_mut()) {
            let ProbeKind::Event { event, occurrence } = &p.kind else {
                continue;
            };
            if g.value.is_some() {
                continue;
            }
            let hit = match event {
                Event::Closes(ids) | Event::Opens(ids) => {
                    let pressed = |i: usize| sim.impulses()[i].x > 0.0;
                    let closed = ids.iter().any(|&i| pressed(i));
                    let hit = match event {
                        Event::Closes(_) => (closed && !g.closed).then(|| {
                            // a located impact has its own time; a contact closing
                            // without one is timed by its free flight
                            let h = sim.h();
                            let impact = sim.located_impact();
                            ids.iter()
                                .zip(&g.approach)
                                .filter(|(&i, _)| pressed(i))
                                .map(|(&i, &(gap, u))| match impact {
                                    Some(m) if m.contacts.contains(&i) => m.before.t,
                                    _ => t - h + closing_delay(gap, u, h),
                                })
                                .fold(t, f64::min)
                        }),
                        _ => (!closed && g.closed).then_some(t),
                    };
                    g.closed = closed;
                    if let Event::Closes(_) = event {
                        // the gap rate over the step just done, not the end-of-step velocity:
                        // with θ = 1/2 a driven body's end velocities alternate about its
                        // prescribed speed (0, 2v, 0, …) while its position moves at v
                        let v = sim.state.v.as_slice();
                        let h = sim.h();
                        let before = std::mem::take(&mut g.approach);
                        g.approach = ids
                            .iter()
                            .enumerate()
                            .map(|(k, &i)| {
                                let c = &sim.contact_points()[i];
                                let rate = before
                                    .get(k)
                                    .map_or(c.normal_velocity(v), |&(g0, _)| (c.gap() - g0) / h);
                                (c.gap(), rate)
                            })
                            .collect();
                    }
                    hit
                }
                Event::Crosses {
                    measure,
                    threshold,
                    direction,
                } => {
                    let v = measure.value(sim);
                    let t = t - measure.lag(sim);
                    let hit = g.previous.and_then(|previous| {
                        measure
                            .over_step(sim, previous, (t, v))
                            .crossing(*threshold, *direction)
                    });
                    g.previous = Some((t, v));
                    hit
                }
            };
            if let Some(when) = hit {
                g.count += 1;
                if g.count == *occurrence {
                    g.value = Some(when);
                }
            }
        }
        for i in 0..self.probes.len() {
            let ProbeKind::Value {
                measure,
                reduce,
                at,
                from,
                to,
                mean_over,
            } = &self.probes[i].kind
            else {
                continue;
            };
            if self.progress[i].value.is_some() {
                continue;
            }
            if *reduce == Reduce::At {
                let v = measure.value(sim);
                let t = t - measure.lag(sim);
                if let Some(at) = at.and_then(|r| self.time(r)) {
                    let g = &mut self.progress[i];
                    if t >= at - half_step * 1e-6 {
                        // interpolated between the steps around a given time, through the
                        // corner of an impact located between them (at the impact's own
                        // time: the value just before it)
                        g.value = Some(match g.previous {
                            Some((t0, v0)) if t > t0 && at > t0 => {
                                measure.over_step(sim, (t0, v0), (t, v)).at(at)
                            }
                            _ => v,
                        });
                    }
                }
                self.progress[i].previous = Some((t, v));
                continue;
            }
            if matches!(reduce, Reduce::Mean | Reduce::Sum) || mean_over.is_some() {
                // ∫ value dt over [from, to] / (to − from): the step just taken covers
                // (last_t, t] (the initial state covers nothing) and counts for its overlap
                // with the window, except that a contact force counts its whole impulse in
                // the step where a `from` event falls: the impulse is that of the contact
                // the event closed (a `closes` event is timed within its step). A `from`
                // event timed before the step's start (a contact that touched in the step
                // before) counts from the step's start: earlier steps were observed before
                // it was known.
                let Some(t_prev) = self.last_t else {
                    continue;
                };
                let t1 = to.and_then(|r| self.time(r));
                let t0 = match from {
                    None => Some(f64::NEG_INFINITY),
                    Some(r) => self.time(*r),
                };
                let g = &mut self.progress[i];
                if t1.is_some_and(|t1| t_prev >= t1) {
                    g.value = g.reduced(*reduce);
                    continue;
                }
                let Some(t0) = t0 else {
                    continue;
                };
                let end = t.min(t1.unwrap_or(f64::INFINITY));
                let w = end - t_prev.max(t0);
                let opened_by_event = matches!(from, Some(TimeRef::Probe(_))) && t0 > t_prev;
                let whole_impulse = opened_by_event
                    && matches!(measure, Measure::ContactForce(_) | Measure::Impulse(_));
                // the event's impulse counts even when the event is timed at the step's very
                // end (w = 0): a contact closing late in a step whose free-flight estimate
                // overshoots it is timed there, and its impact would otherwise be dropped
                if w > 0.0 || (whole_impulse && t0 <= end) {
                    let covered = if whole_impulse { end - t_prev } else { w };
                    if let Some(length) = mean_over {
                        let area = covered * measure.value(sim);
                        g.slide(t_prev.max(t0), end, area, *length, *reduce);
                        continue;
                    }
                    // a mean weighs each step's value by its time in the window; a sum of
                    // impulses takes each step's by the share of the step in the window
                    let weight = match reduce {
                        Reduce::Sum => covered / (t - t_prev),
                        _ => covered,
                    };
                    g.acc += weight * measure.value(sim);
                    g.weight += w.max(0.0);
                }
                continue;
            }
            let started = match from {
                None => true,
                Some(r) => self.time(*r).is_some_and(|t0| t >= t0 - half_step),
            };
            let ended = to
                .and_then(|r| self.time(r))
                .is_some_and(|t1| t > t1 + half_step);
            let g = &mut self.progress[i];
            if ended {
                g.value = g.reduced(*reduce);
                continue;
            }
            if !started {
                continue;
            }
            let v = measure.value(sim);
            g.acc = match (g.count, reduce) {
                (0, _) => v,
                (_, Reduce::Max) => g.acc.max(v),
                // `Min` (a mean accumulates above, `At` before)
                _ => g.acc.min(v),
            };
            g.count += 1;
        }
        self.observe_curves(sim);
        self.last_t = Some(t);
    }

    /// Whether probe `i` has its value (an event probe: whether its event happened).
    pub fn known(&self, i: usize) -> bool {
        self.progress[i].value.is_some()
    }

    /// Whether every probe is known and every curve's window closed, so that the run can
    /// stop early.
    pub fn done(&self) -> bool {
        self.progress.iter().all(|g| g.value.is_some()) && self.cells.iter().all(|c| c.closed)
    }

    /// Each curve's values on its grid so far (NaN in cells x has not entered).
    pub fn curves(&self) -> Vec<Vec<f64>> {
        self.cells.iter().map(CurveCells::values).collect()
    }

    /// Each probe's value at the end of the run, or why it has none.
    pub fn finish_each(mut self, t_end: f64) -> Vec<Result<f64, String>> {
        let mut out = Vec::with_capacity(self.probes.len());
        for (i, p) in self.probes.iter().enumerate() {
            if let Some(v) = self.progress[i].value {
                out.push(Ok(v));
                continue;
            }
            if let ProbeKind::Value {
                to: Some(TimeRef::Probe(k)),
                ..
            } = p.kind
            {
                if self.progress[k].value.is_none() {
                    out.push(Err(format!(
                        "probe `{}`: its window ends at event `{}`, which did not happen by t = {t_end} s",
                        p.name, self.probes[k].name
                    )));
                    continue;
                }
            }
            let g = &mut self.progress[i];
            out.push(match &p.kind {
                ProbeKind::Event { occurrence, .. } => Err(format!(
                    "probe `{}`: the event happened {} time(s) by t = {t_end} s, occurrence {occurrence} was asked for",
                    p.name, g.count
                )),
                ProbeKind::Value {
                    reduce,
                    at,
                    mean_over,
                    ..
                } => {
                    if *reduce == Reduce::At && at.is_none() {
                        g.value = g.previous.map(|(_, v)| v);
                    } else if *reduce != Reduce::At {
                        g.value = g.reduced(*reduce);
                    }
                    g.value.ok_or_else(|| match mean_over {
                        Some(length) if g.weight > 0.0 => format!(
                            "probe `{}`: its window ({:.6} s) is shorter than `mean_over` ({length} s)",
                            p.name, g.weight
                        ),
                        _ => format!(
                            "probe `{}`: its time or window was not reached by t = {t_end} s",
                            p.name
                        ),
                    })
                }
            });
        }
        out
    }
}
