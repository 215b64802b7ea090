//! The model: bodies, gravity, force elements and contact pairs. Immutable during a
//! simulation; the evolving state lives in [`State`], so that one model can be run many
//! times (a Monte-Carlo sample is "model + initial state → outputs").

use super::body::{Motion, Pose, RigidBody, Twist};
use super::contact::clearance::{ClearanceJoint, Placed, Placements};
use super::contact::compliant::{CompliantContact, CompliantSource};
use super::contact::{ContactPair, ContactPoint};
use super::force::Force;
use super::joint::{BilateralRow, Drive, Joint};
use crate::math::blocks::vector6_at;
use nalgebra::{DVector, Vector3};
use std::ops::Range;

/// A unilateral contact candidate: a point of a contact pair, or a joint stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Candidate {
    Pair { pair: usize, point: usize },
    Limit { joint: usize, upper: bool },
    Clearance { joint: usize, point: usize },
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    pub bodies: Vec<RigidBody>,
    pub gravity: Vector3<f64>,
    pub forces: Vec<Force>,
    pub contacts: Vec<ContactPair>,
    pub joints: Vec<Joint>,
    /// Revolute joints with clearance: sets of unilateral contacts.
    pub clearance_joints: Vec<ClearanceJoint>,
    /// Contact pairs and clearance joints under a compliant law: smooth forces, outside
    /// the contact candidates.
    pub compliant: Vec<CompliantContact>,
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
        vector6_at(self.v.as_slice(), 6 * i)
    }
}

impl Model {
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// The instants at which a prescribed force, drive or preload ramp bends in time,
    /// sorted. The θ-rule is of second order only where the loads are smooth in time: a
    /// step across such a knot leaves an error of first order in the step.
    pub fn knots(&self) -> Vec<f64> {
        let drives = self.joints.iter().flat_map(|j| match &j.drive {
            Some(Drive::Position(p) | Drive::Effort(p)) => p.knots(),
            None => Vec::new(),
        });
        let mut knots: Vec<f64> = drives
            .chain(self.forces.iter().flat_map(|f| f.knots()))
            .collect();
        knots.sort_by(f64::total_cmp);
        knots.dedup();
        knots
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

    /// The bilateral rows of every joint at time `t` and `poses`, in joint order (sized
    /// once: a step asks for them several times).
    pub fn joint_rows(&self, t: f64, poses: &[Pose]) -> Vec<BilateralRow> {
        let mut rows = Vec::with_capacity(self.joints.iter().map(Joint::row_count).sum());
        self.joint_rows_into(t, poses, &mut rows);
        rows
    }

    /// `joint_rows` appended to `out`.
    pub fn joint_rows_into(&self, t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>) {
        for j in &self.joints {
            j.rows(t, poses, out);
        }
    }

    /// The joints' rows without their gradients (`Joint::row_values`), appended to `out`.
    pub fn joint_row_values_into(&self, t: f64, poses: &[Pose], out: &mut Vec<BilateralRow>) {
        for j in &self.joints {
            j.row_values(t, poses, out);
        }
    }

    /// Per-dof flag: integrated (true) or held fixed (false).
    pub fn dof_mask(&self) -> Vec<bool> {
        self.bodies.iter().flat_map(|b| b.dof_mask()).collect()
    }

    /// The name of the contact pair, joint or clearance joint a candidate belongs to.
    pub fn candidate_owner(&self, c: Candidate) -> &str {
        match c {
            Candidate::Pair { pair, .. } => &self.contacts[pair].name,
            Candidate::Limit { joint, .. } => &self.joints[joint].name,
            Candidate::Clearance { joint, .. } => &self.clearance_joints[joint].name,
        }
    }

    /// The candidates (by index) of the contact pair or clearance joint named `name`; a
    /// joint's stops are not among them.
    pub fn contact_candidates_of(&self, name: &str) -> Vec<usize> {
        self.contact_candidates()
            .iter()
            .enumerate()
            .filter(|(_, &c)| {
                !matches!(c, Candidate::Limit { .. }) && self.candidate_owner(c) == name
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// The points (in `compliant_points` order) of the compliant contact named `name`.
    pub fn compliant_points_of(&self, name: &str) -> Vec<usize> {
        self.compliant_spans()
            .filter(|(c, _)| c.name() == name)
            .flat_map(|(_, span)| span)
            .collect()
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

    /// Points of the compliant contacts, over all of them in order: one closing speed each
    /// in `wrench`'s `onset`.
    pub fn compliant_points(&self) -> usize {
        self.compliant.iter().map(CompliantContact::points).sum()
    }

    /// Each compliant contact with the span of its points in `compliant_points` order.
    pub fn compliant_spans(&self) -> impl Iterator<Item = (&CompliantContact, Range<usize>)> {
        self.compliant.iter().scan(0, |first, c| {
            let span = *first..*first + c.points();
            *first = span.end;
            Some((c, span))
        })
    }

    /// Generalized applied wrench F(t, q, v): gravity, −Ω × IΩ, the force elements and the
    /// compliant contacts, whose points closed at the speeds `onset` (`compliant_points`
    /// entries; `None` for a point closing now). Entries of held degrees of freedom are
    /// zero. (The settling damping is the step's: the integrator adds it.)
    pub fn wrench(
        &self,
        t: f64,
        poses: &[Pose],
        v: &DVector<f64>,
        onset: &[Option<f64>],
        out: &mut DVector<f64>,
    ) {
        out.as_mut_slice().fill(0.0);
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
        for (c, span) in self.compliant_spans() {
            c.apply(poses, v.as_slice(), &onset[span], out.as_mut_slice());
        }
        for (i, b) in self.bodies.iter().enumerate() {
            if b.motion != Motion::Free || b.planar.is_some() {
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
            + self
                .compliant
                .iter()
                .map(|c| c.potential(&state.poses))
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
        // a compliant journal's rings (and their guards) are its compliant contact's
        let compliant = |j: &ClearanceJoint| {
            self.compliant
                .iter()
                .any(|c| matches!(&c.source, CompliantSource::Journal(g) if g.name == j.name))
        };
        let clearance = self.clearance_joints.iter().enumerate().flat_map(|(i, j)| {
            let rigid_rings = !compliant(j);
            (0..j.candidates())
                .filter(move |&k| rigid_rings || (k >= 2 && !j.is_guard(k)))
                .map(move |k| Candidate::Clearance { joint: i, point: k })
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
    /// `out` may hold stale entries: the points are written over them (a clearance joint's
    /// are built in place there), and `out` ends with one entry per candidate.
    pub fn evaluate_selected(
        &self,
        poses: &[Pose],
        selected: &[Candidate],
        out: &mut Vec<ContactPoint>,
    ) {
        let placing = Placing::Fresh;
        self.evaluate_selected_knowing(poses, selected, |_| None, Guards::Points, placing, out);
    }

    /// `evaluate_selected`, keeping each clearance joint's placement in `placements` (in
    /// place of those it held) for a later evaluation at the same poses.
    pub fn evaluate_selected_keeping(
        &self,
        poses: &[Pose],
        selected: &[Candidate],
        placements: &mut Placements,
        out: &mut Vec<ContactPoint>,
    ) {
        placements.clear();
        let placing = Placing::Keep(placements);
        self.evaluate_selected_knowing(poses, selected, |_| None, Guards::Points, placing, out);
    }

    /// `evaluate_selected`, taking the points of contact pairs and joint stops that
    /// `known(k)` gives for the k-th selected candidate (evaluated at the same poses)
    /// instead of evaluating them again, of the clearance joints' guards what `guards`
    /// asks for, and the joints' placements as `placing` says.
    pub fn evaluate_selected_knowing<'a>(
        &self,
        poses: &[Pose],
        selected: &[Candidate],
        known: impl Fn(usize) -> Option<&'a ContactPoint>,
        guards: Guards,
        mut placing: Placing,
        out: &mut Vec<ContactPoint>,
    ) {
        // one growth at most, where `out` holds fewer entries than there are candidates
        out.reserve(selected.len().saturating_sub(out.len()));
        let mut rest = selected;
        while let Some((&first, tail)) = rest.split_first() {
            let k = selected.len() - rest.len();
            rest = tail;
            match first {
                Candidate::Pair { pair, point } => match (known(k), out.get_mut(k)) {
                    (Some(p), _) => put(out, k, || *p),
                    (None, Some(slot)) => self.contacts[pair].write(point, poses, slot),
                    (None, None) => out.push(self.contacts[pair].evaluate(point, poses)),
                },
                Candidate::Limit { joint, upper } => put(out, k, || match known(k) {
                    Some(p) => *p,
                    None => self.joints[joint].limit_point(upper, poses),
                }),
                Candidate::Clearance { joint, point } => {
                    // this joint's run of points, placed once
                    let same = |c: &Candidate| match *c {
                        Candidate::Clearance { joint: j, point } if j == joint => Some(point),
                        _ => None,
                    };
                    let run = rest.iter().map_while(same).count();
                    let points = std::iter::once(point).chain(rest.iter().map_while(same));
                    let clearance = &self.clearance_joints[joint];
                    let fresh;
                    let placed = match &mut placing {
                        Placing::Keep(kept) => kept.keep(joint, clearance.place(poses)),
                        Placing::Known(known) if known.get(joint).is_some() => {
                            known.get(joint).expect("known")
                        }
                        _ => {
                            fresh = clearance.place(poses);
                            &fresh
                        }
                    };
                    for (j, point) in points.enumerate() {
                        let gap_alone = guards == Guards::Gaps && clearance.is_guard(point);
                        match out.get_mut(k + j) {
                            Some(slot) if gap_alone => clearance.write_gap(point, placed, slot),
                            Some(slot) => clearance.write_point(point, placed, slot),
                            None => out.push(clearance.point(point, placed)),
                        }
                    }
                    rest = &rest[run..];
                }
            }
        }
        out.truncate(selected.len());
    }

    /// The points of the clearance joints' guards among `selected` at `poses`, written
    /// over their entries of `out` (one per selected candidate); the other entries are
    /// left as they are.
    pub fn evaluate_guards(
        &self,
        poses: &[Pose],
        selected: &[Candidate],
        out: &mut [ContactPoint],
    ) {
        let mut placed: Option<(usize, Placed)> = None;
        for (slot, &c) in out.iter_mut().zip(selected) {
            let Candidate::Clearance { joint, point } = c else {
                continue;
            };
            let clearance = &self.clearance_joints[joint];
            if !clearance.is_guard(point) {
                continue;
            }
            // each joint placed once: its points are consecutive
            let at = match placed.take() {
                Some((j, at)) if j == joint => at,
                _ => clearance.place(poses),
            };
            clearance.write_point(point, &at, slot);
            placed = Some((joint, at));
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

/// Where an evaluation takes its clearance joints' placements from.
pub enum Placing<'p> {
    /// Each joint placed anew.
    Fresh,
    /// Those kept at the same poses, the others placed anew.
    Known(&'p Placements),
    /// Each joint placed anew and kept.
    Keep(&'p mut Placements),
}

/// What an evaluation writes of a clearance joint's guards (`ClearanceJoint::is_guard`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Guards {
    /// Their whole points.
    Points,
    /// Their gaps alone, over the gaps of the entries there (an entry the list lacks gets
    /// the whole point): the rest of a guard's point is needed only by a step that may
    /// carry the journal across its clearance, and it costs as much as the rest of the
    /// joint's points.
    Gaps,
}

/// Sets entry `k` of `out` (which holds at least `k` entries) to the point `make` gives:
/// over the stale entry there, or pushed.
fn put(out: &mut Vec<ContactPoint>, k: usize, make: impl FnOnce() -> ContactPoint) {
    match out.get_mut(k) {
        Some(slot) => *slot = make(),
        None => out.push(make()),
    }
}

#[cfg(test)]
mod tests {
    use super::{Candidate, Guards, Placing};
    use crate::mechanics::contact::clearance::Placements;
    use crate::mechanics::{ContactPoint, Pose};
    use crate::scene::Scene;

    /// Points written over the stale entries of a list, shorter or longer than the
    /// selection, are those evaluated into an empty one, bit for bit: on the circuit
    /// breaker (contact pairs, joint stops and seven clearance joints), its stale entries
    /// NaN or other candidates' points (guards on the linearised gap, rings with a lateral
    /// curvature, where the selection has flange points without either).
    #[test]
    fn points_written_over_stale_entries_are_those_of_an_empty_list() {
        let mut sim = Scene::bundled_simulation("c60");
        sim.run_until(0.01, |_, _| {}).unwrap();
        let (model, poses) = (&sim.model, &sim.state.poses);
        let all = sim.contact_ids().to_vec();
        let bits = |points: &[ContactPoint]| format!("{points:?}");
        let mut reversed = Vec::new();
        model.evaluate_selected(poses, &all, &mut reversed);
        reversed.reverse();
        let nan = {
            let mut p = reversed[0];
            p.geometry.gap = f64::NAN;
            p.frame.fill(f64::NAN);
            p.mu = f64::NAN;
            p
        };
        let selections = [
            all.clone(),
            all.iter().copied().step_by(3).collect(),
            all[all.len() / 2..].to_vec(),
        ];
        for selected in &selections {
            let mut fresh = Vec::new();
            model.evaluate_selected(poses, selected, &mut fresh);
            assert_eq!(fresh.len(), selected.len());
            for stale in [
                vec![nan; selected.len() + 5],
                vec![nan; selected.len() / 2],
                reversed.clone(),
            ] {
                let mut out = stale;
                model.evaluate_selected(poses, selected, &mut out);
                assert_eq!(bits(&out), bits(&fresh), "{} selected", selected.len());
            }
        }
        let kinds = |p: &ContactPoint| (p.gap_law, p.lateral.is_some());
        let present = |k| reversed.iter().any(|p| kinds(p) == k);
        assert!(present((true, false)) && present((false, true)) && present((false, false)));
    }

    /// Placements kept by an evaluation serve a later one at the same poses bit for bit:
    /// on the circuit breaker, every candidate evaluated knowing the placement that an
    /// evaluation of one joint's points kept equals every candidate placed anew. What an
    /// evaluation keeps replaces all that was kept before: placements kept at other poses
    /// (which would move the points) are not used.
    #[test]
    fn kept_placements_give_the_points_of_fresh_ones() {
        let mut sim = Scene::bundled_simulation("c60");
        sim.run_until(0.005, |_, _| {}).unwrap();
        let (model, poses) = (&sim.model, &sim.state.poses);
        let all = sim.contact_ids().to_vec();
        let bits = |points: &[ContactPoint]| format!("{points:?}");
        let mut fresh = Vec::new();
        model.evaluate_selected(poses, &all, &mut fresh);
        let known = |placements: &Placements| {
            let mut out = Vec::new();
            let placing = Placing::Known(placements);
            model.evaluate_selected_knowing(
                poses,
                &all,
                |_| None,
                Guards::Points,
                placing,
                &mut out,
            );
            out
        };
        let moved: Vec<Pose> = poses
            .iter()
            .map(|p| Pose {
                x: p.x.add_scalar(1e-5),
                p: p.p,
            })
            .collect();
        let mut placements = Placements::default();
        let mut scratch = Vec::new();
        model.evaluate_selected_keeping(&moved, &all, &mut placements, &mut scratch);
        assert_ne!(
            bits(&known(&placements)),
            bits(&fresh),
            "the test cannot fail"
        );
        let first_joint: Vec<Candidate> = all
            .iter()
            .copied()
            .filter(|c| matches!(c, Candidate::Clearance { joint: 0, .. }))
            .collect();
        assert!(!first_joint.is_empty() && first_joint.len() < all.len());
        model.evaluate_selected_keeping(poses, &first_joint, &mut placements, &mut scratch);
        assert!(placements.get(0).is_some() && placements.get(1).is_none());
        assert_eq!(bits(&known(&placements)), bits(&fresh));
    }
}
