//! The combined scheme's activation loop: contacts enter the velocity problem when the
//! end-of-step position closes them or the step jumps across them (`tunnelling.rs`; the
//! step is redone with them), clearance guards when
//! the step would carry a journal across its clearance; the joints and the pressed or
//! penetrating contacts are then projected onto their manifolds.

use super::moreau_jean::VelocityStep;
use super::params::IntegrationParameters;
use super::projection::{ContactRows, ProjectionOutcome};
use super::simulation::{Closing, Outcome, Simulation, StepReport};
use super::workspace::{ProjectionWorkspace, StepWorkspace};
use crate::math::buffer::keep_larger;
use crate::mechanics::model::{Guards, Placing};
use crate::mechanics::{ContactPoint, Pose};

/// A guard enters the velocity problem only when the step would carry the journal past it
/// by more than this fraction of the clearance. A shallower crossing leaves the journal
/// within a few tenths of c outside its ring, which the projection removes in 2–3
/// iterations, and an extra contact next to a pressed ring point only makes the friction
/// problem harder (at μ = 1 it makes steps fail).
const GUARD_DEPTH: f64 = 0.5;

/// Normal speed (m/s) below which a pressed contact counts as staying closed.
const SEPARATION_SPEED: f64 = 1e-9;

/// The activation loop's lists. Each is cleared before it is filled.
#[derive(Default)]
pub(super) struct ActivationLists {
    /// Per candidate: in the velocity problem; closed at the step's end.
    in_active: Vec<bool>,
    closed: Vec<bool>,
    /// Per ring, how far the step can move any of its points along their normals (h times
    /// the θ-weighted bound of `ClearanceJoint::ring_speed_bounds`).
    travel: Vec<f64>,
    /// Per ring crossed, its most crossed guard: (ring, candidate, gap).
    worst: Vec<(usize, usize, f64)>,
    /// The active contacts the projection takes, and the candidates that closed.
    pool: Vec<usize>,
    new: Vec<usize>,
    /// The candidates a pass jumps across, with their linearised end-of-step gaps.
    crossed: Vec<(usize, f64)>,
    /// Storage for a pass's end-of-step contact points: the points a state held before
    /// its step, or a pass's that a later pass replaced, written over.
    points: Vec<ContactPoint>,
}

impl ActivationLists {
    /// Keeps a list of contact points, once done with, for a later pass's.
    pub(super) fn keep_points(&mut self, points: Option<Vec<ContactPoint>>) {
        if let Some(points) = points {
            keep_larger(&mut self.points, points);
        }
    }
}

impl Simulation {
    /// The combined projection + activation loop (docs/method.md), started from the
    /// previous step's active set (kept while pressed or closed; guards are not kept, they
    /// are chosen afresh each step): the active set, the velocity step, the end-of-step
    /// poses, the contact points evaluated there (of the guards, their gaps), and the
    /// contacts that closed. `None` where the step needs the guards' points and the state
    /// holds their gaps alone (`crossed_guards`).
    pub(super) fn combined(
        &self,
        mut report: StepReport,
        ws: &mut StepWorkspace,
    ) -> Option<Outcome> {
        let p = &self.step_params();
        let mut closing = Vec::new();
        let mut active: Vec<usize> = self
            .active
            .iter()
            .copied()
            .filter(|&i| !self.is_guard(i))
            .filter(|&i| self.impulses[i].x > 0.0 || self.points[i].gap() <= p.activation_margin)
            .collect();
        let (mut last, mut settled) = (None, false);
        // whether a pass has looked for closing contacts yet (a pass that adds crossed
        // guards does not)
        let mut looked = false;
        let StepWorkspace {
            velocity,
            projection,
            activation: lists,
        } = ws;
        for pass in 1..=p.max_active_set_passes {
            let mut vs = self.velocity(&active, velocity);
            lists.in_active.clear();
            lists.in_active.resize(self.points.len(), false);
            active.iter().for_each(|&i| lists.in_active[i] = true);
            if !self.crossed_guards(p, &vs, lists) {
                velocity.step.keep_spent(vs);
                return None;
            }
            if !lists.worst.is_empty() && pass < p.max_active_set_passes {
                active.extend(lists.worst.iter().map(|w| w.1));
                active.sort_unstable();
                continue;
            }
            let mut poses = velocity.step.copy_poses(&vs.poses);
            let after;
            (report.projection, after) =
                self.project_pass(&active, &mut vs, &mut poses, lists, projection);
            report.active_set_passes = pass;
            let (in_active, new) = (&lists.in_active, &mut lists.new);
            new.clear();
            new.extend(
                (0..after.len())
                    .filter(|&i| !in_active[i] && !self.is_guard(i) && after[i].gap() <= 0.0),
            );
            self.jumped_across(in_active, &vs, &mut lists.crossed);
            new.extend(lists.crossed.iter().map(|c| c.0));
            if new.is_empty() {
                settled = true;
                if let Some((_, vs, poses, points)) = last.replace((active, vs, poses, after)) {
                    velocity.step.keep_spent(vs);
                    velocity.step.keep_poses(poses);
                    keep_larger(&mut lists.points, points);
                }
                break;
            }
            // a contact that the first pass (the motion without this step's new impulses)
            // leaves open is knocked shut by another contact's impact, however it was moving
            // at the start: a ball drifting towards the next one still passes a blow on
            // after it has taken it
            let crossed = &lists.crossed;
            let end_gap = |i: usize| match crossed.iter().find(|c| c.0 == i) {
                Some(c) => c.1,
                None => after[i].gap(),
            };
            closing.extend(new.iter().map(|&i| Closing {
                candidate: i,
                end_gap: end_gap(i),
                knocked: looked,
            }));
            if let Some((_, vs, poses, points)) = last.replace((active.clone(), vs, poses, after)) {
                velocity.step.keep_spent(vs);
                velocity.step.keep_poses(poses);
                keep_larger(&mut lists.points, points);
            }
            looked = true;
            active.extend(new.iter().copied());
            active.sort_unstable();
        }
        // an active set that did not settle within the allowed passes keeps the last pass,
        // flagged
        report.projection.converged &= settled;
        let (active, vs, poses, after) = last.expect("at least one pass");
        Some(Outcome {
            active,
            vs,
            poses,
            points: Some(after),
            closing,
            sinking: Vec::new(),
            report,
        })
    }

    /// Into `lists.worst`, per clearance ring that the step `vs` carries the journal across,
    /// its most crossed guard (ring, candidate, linearised end-of-step gap).
    ///
    /// A guard whose linearised end-of-step gap g + h u_N,θ is negative marks a step that
    /// carries the journal across its clearance: the most crossed guard of each such ring
    /// joins the velocity problem, which is solved again (the guards are far from contact
    /// otherwise, so this never happens while h·v stays below the clearance). One per ring
    /// and pass keeps the problem small and its Delassus matrix regular. A guard whose gap,
    /// less 1.5 times the farthest its ring's points can travel along their normals in the
    /// step, stays above a quarter of the depth below zero cannot be crossed: its speeds are
    /// not formed (the factor and the quarter leave room for rounding). Returns false,
    /// with `lists.worst` incomplete, where a guard may be crossed and the state holds the
    /// guards' gaps alone (`Simulation::guards_evaluated`).
    fn crossed_guards(
        &self,
        p: &IntegrationParameters,
        vs: &VelocityStep,
        lists: &mut ActivationLists,
    ) -> bool {
        let ActivationLists {
            in_active,
            travel,
            worst,
            ..
        } = lists;
        travel.clear();
        travel.extend(self.model.clearance_joints.iter().flat_map(|j| {
            let bounds = |v: &[f64]| j.ring_speed_bounds(&self.state.poses, v);
            let (b0, b1) = (bounds(self.state.v.as_slice()), bounds(vs.v.as_slice()));
            [0, 1].map(|ring| p.h * ((1.0 - p.theta).abs() * b0[ring] + p.theta.abs() * b1[ring]))
        }));
        worst.clear();
        for (i, ring) in self.guard_ring.iter().enumerate() {
            let Some(ring) = *ring else { continue };
            if in_active[i] {
                continue;
            }
            let c = &self.points[i];
            let depth = GUARD_DEPTH * self.model.clearance_joints[ring / 2].clearance;
            if c.gap() - 1.5 * travel[ring] > -0.25 * depth {
                continue;
            }
            if !self.guards_evaluated {
                return false;
            }
            let u0 = c.normal_velocity(self.state.v.as_slice());
            let u1 = c.normal_velocity(vs.v.as_slice());
            let end_gap = c.gap() + p.h * ((1.0 - p.theta) * u0 + p.theta * u1);
            if end_gap < -depth {
                match worst.iter_mut().find(|w| w.0 == ring) {
                    Some(w) if end_gap < w.2 => *w = (ring, i, end_gap),
                    Some(_) => {}
                    None => worst.push((ring, i, end_gap)),
                }
            }
        }
        true
    }

    /// Projects `poses`, the end-of-step poses of the pass `vs` with the contacts `active`;
    /// returns the projection's outcome and every candidate's point there (the pool's pair
    /// contacts and joint stops as the projection left them).
    ///
    /// Project onto g = 0, as equalities, the active contacts that penetrate and those that
    /// stay closed (pressed, not separating: u_N,k+1 ≤ e|u_N,k|/2). A contact that rebounds
    /// (e > 0) and ended with g > 0 is left where it is: pulling it down onto the surface
    /// (as Siconos' combined scheme does with every active contact) throws away m g·g of
    /// energy per impact. Held shut together, the closed contacts may admit no poses near
    /// the trial (a tilted journal pressed on one flange and held at the other by the last
    /// step's impulse): then every active contact may open, g ≥ 0, which the start of the
    /// step satisfies, from the trial poses again.
    fn project_pass(
        &self,
        active: &[usize],
        vs: &mut VelocityStep,
        poses: &mut [Pose],
        lists: &mut ActivationLists,
        projection: &mut ProjectionWorkspace,
    ) -> (ProjectionOutcome, Vec<ContactPoint>) {
        let ActivationLists {
            closed,
            pool,
            points,
            ..
        } = lists;
        closed.clear();
        closed.resize(self.points.len(), false);
        for (k, &i) in active.iter().enumerate() {
            let c = &self.points[i];
            let u0 = c.normal_velocity(self.state.v.as_slice());
            let u1 = vs.normal_speeds[k];
            closed[i] =
                vs.impulses[k].x > 0.0 && u1 <= 0.5 * c.e * (-u0).max(0.0) + SEPARATION_SPEED;
        }
        pool.clear();
        pool.extend(
            active
                .iter()
                .copied()
                .filter(|&i| self.guard_ring[i].is_none()),
        );
        let closed = &*closed;
        let selected = |i: usize, cp: &ContactPoint| closed[i] || cp.gap() < 0.0;
        let chord = vs.elimination.as_deref_mut();
        let equality = ContactRows::Equality;
        let (mut outcome, mut evaluated) =
            self.project_poses(poses, pool, &selected, equality, chord, projection);
        if !outcome.converged {
            poses.copy_from_slice(&vs.poses);
            let all = |_: usize, _: &ContactPoint| true;
            let chord = vs.elimination.as_deref_mut();
            let inequality = ContactRows::Inequality;
            (outcome, evaluated) =
                self.project_poses(poses, pool, &all, inequality, chord, projection);
        }
        let known = |k: usize| {
            let (points, _) = evaluated?;
            pool.binary_search(&k).ok().map(|j| &points[j])
        };
        let placing = evaluated.map_or(Placing::Fresh, |(_, placed)| Placing::Known(placed));
        let mut after = std::mem::take(points);
        let (candidates, gaps) = (&self.candidates, Guards::Gaps);
        self.model
            .evaluate_selected_knowing(poses, candidates, known, gaps, placing, &mut after);
        (outcome, after)
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;

    /// A step reads nothing that its workspace held: the incline block (four contacts on a
    /// turning box) and the clearance pendulum (a journal's rings and flanges, guards,
    /// projections that fall back) run to the same bits in a fresh workspace and in one
    /// that the other scene used, with the activation lists holding stale entries of
    /// other sizes; and the block is pressed (its contacts carry impulses) and the journal
    /// touches its bore.
    #[test]
    fn a_step_reads_nothing_its_workspace_held() {
        let run = |name: &str, duration: f64, used_by: Option<&str>| {
            let mut sim = Scene::bundled_simulation(name);
            if let Some(other) = used_by {
                let mut donor = Scene::bundled_simulation(other);
                donor.run_until(0.05, |_, _| {}).unwrap();
                sim.workspace = donor.workspace.take();
                sim.workspace.as_mut().expect("used").activation = super::ActivationLists {
                    in_active: vec![true; 40],
                    closed: vec![true; 40],
                    travel: vec![-1.0; 9],
                    worst: vec![(7, 7, f64::NAN); 5],
                    pool: vec![39; 12],
                    new: vec![38; 12],
                    crossed: vec![(37, -1.0); 3],
                    points: donor.contact_points().to_vec(),
                };
            }
            let mut pressed = 0;
            sim.run_until(duration, |sim, _| {
                pressed += usize::from(sim.impulses().iter().any(|p| p.x > 0.0));
            })
            .unwrap();
            (sim.state, sim.stats, pressed)
        };
        for (name, duration, other) in [
            ("incline-block", 0.3, "pendulum-clearance"),
            ("pendulum-clearance", 0.05, "incline-block"),
        ] {
            let (fresh, stats, pressed) = run(name, duration, None);
            assert!(pressed > 10, "{name}: {pressed} steps with an impulse");
            let (reused, stats2, _) = run(name, duration, Some(other));
            assert_eq!(fresh, reused, "{name}");
            assert_eq!(stats, stats2, "{name}");
        }
    }

    /// The contact points a step leaves (the activation's, some of them handed on by the
    /// projection) are those a fresh evaluation at the step's end gives, bit for bit: on
    /// the incline block (contact pairs, which the projection hands on) and the cam
    /// follower (a follower on a cam profile, with joints).
    #[test]
    fn a_step_leaves_the_points_of_its_end_poses() {
        for (name, duration) in [("incline-block", 0.5), ("cam-follower", 0.05)] {
            let mut sim = Scene::bundled_simulation(name);
            let candidates = sim.contact_ids().to_vec();
            let mut fresh = Vec::new();
            let mut steps = 0;
            sim.run_until(duration, |sim, _| {
                sim.model
                    .evaluate_selected(&sim.state.poses, &candidates, &mut fresh);
                for (k, (left, fresh)) in sim.contact_points().iter().zip(&fresh).enumerate() {
                    let v = sim.state.v.as_slice();
                    assert_eq!(left.gap().to_bits(), fresh.gap().to_bits(), "{name} {k}");
                    assert_eq!(left.frame, fresh.frame, "{name} {k}");
                    assert_eq!(
                        left.local_velocity(v),
                        fresh.local_velocity(v),
                        "{name} {k}"
                    );
                }
                steps += 1;
            })
            .unwrap();
            assert!(steps > 10, "{name}");
        }
    }

    /// The clearance guards' entries a step leaves hold their gaps at the step's end, bit for
    /// bit, and where a guard carries an impulse (or the step evaluated the guards) its
    /// whole point: on the clearance pendulum at c = 1 µm and h = 1 ms, whose steps carry
    /// the journal across its bore (guards join the velocity problem), and on the
    /// slider-crank, whose pin impacts split steps. Every other entry is the point a fresh
    /// evaluation gives.
    #[test]
    fn a_step_leaves_the_gaps_of_its_guards() {
        for (name, clearance, duration) in [
            ("pendulum-clearance", "joints.pivot.clearance", 0.5),
            ("slider-crank-clearance", "", 0.05),
        ] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("studies")
                .join(name)
                .join("scene.yaml");
            let mut scene = Scene::load(&path).unwrap();
            if !clearance.is_empty() {
                scene.set_parameter(clearance, 1e-6).unwrap();
                scene.params.h = 1e-3;
            }
            let mut sim = scene.simulation().unwrap();
            let candidates = sim.contact_ids().to_vec();
            let mut fresh = Vec::new();
            let (mut lazy, mut pushed) = (0, 0);
            sim.run_until(duration, |sim, _| {
                sim.model
                    .evaluate_selected(&sim.state.poses, &candidates, &mut fresh);
                lazy += usize::from(!sim.guards_evaluated);
                for (k, (left, fresh)) in sim.contact_points().iter().zip(&fresh).enumerate() {
                    assert_eq!(left.gap().to_bits(), fresh.gap().to_bits(), "{name} {k}");
                    let whole = !sim.is_guard(k) || sim.guards_evaluated;
                    pushed += usize::from(sim.is_guard(k) && sim.impulses()[k].x > 0.0);
                    if whole || sim.impulses()[k].x > 0.0 {
                        assert_eq!(format!("{left:?}"), format!("{fresh:?}"), "{name} {k}");
                    }
                }
            })
            .unwrap();
            assert!(
                lazy > 10,
                "{name}: {lazy} steps left the guards' gaps alone"
            );
            assert!(
                pushed > 0 || clearance.is_empty(),
                "{name}: no guard pushed"
            );
        }
    }

    /// The run's largest joint violations, which a step takes from its projection where it
    /// can, are those of fresh evaluations at every step's end, bit for bit: on the driven
    /// four-bar (its rows depend on time), on the pendulum (its rows do not, and its
    /// projection's time differs from the step's end in the last bit in about a third of
    /// its steps) and on the slider-crank, whose impacts on its clearance pin split steps.
    #[test]
    fn a_step_records_the_joint_violations_of_its_end_poses() {
        use crate::integrator::projection::JointViolation;
        for (name, duration) in [
            ("four-bar", 0.3),
            ("pendulum", 0.5),
            ("slider-crank-clearance", 0.05),
        ] {
            let mut sim = Scene::bundled_simulation(name);
            let (mut length, mut angle) = (
                sim.stats.max_joint_violation,
                sim.stats.max_joint_angle_violation,
            );
            sim.run_until(duration, |sim, _| {
                let rows = sim.model.joint_rows(sim.state.t, &sim.state.poses);
                let v = JointViolation::of(sim.state.t, &rows);
                (length, angle) = (length.max(v.length), angle.max(v.angle));
                assert_eq!(sim.stats.max_joint_violation.to_bits(), length.to_bits());
                assert_eq!(
                    sim.stats.max_joint_angle_violation.to_bits(),
                    angle.to_bits()
                );
            })
            .unwrap();
            // the pendulum turns about its axis alone: its angle rows stay exactly zero
            assert!(
                length > 0.0 && (angle > 0.0 || name == "pendulum"),
                "{name}"
            );
        }
    }
}
