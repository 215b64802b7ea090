//! The combined scheme's activation loop: contacts enter the velocity problem when the
//! end-of-step position closes them (the step is redone with them), clearance guards when
//! the step would carry a journal across its clearance; the joints and the pressed or
//! penetrating contacts are then projected onto their manifolds.

use super::moreau_jean::spare_poses;
use super::projection::ContactRows;
use super::simulation::{
    hand_back_all_points, hand_back_points, spare_all_points, Closing, Outcome, Simulation,
    StepReport,
};
use crate::math::kept;
use crate::mechanics::ContactPoint;

/// A guard enters the velocity problem only when the step would carry the journal past it
/// by more than this fraction of the clearance. A shallower crossing leaves the journal
/// within a few tenths of c outside its ring, which the projection removes in 2–3
/// iterations, and an extra contact next to a pressed ring point only makes the friction
/// problem harder: at μ = 1 on the pendulum, guards at depth 0 added 9 failed steps in
/// 0.2 s (c = 1 µm, h = 0.1 ms) where depth 0.5 adds none.
const GUARD_DEPTH: f64 = 0.5;

/// Normal speed (m/s) below which a pressed contact counts as staying closed.
const SEPARATION_SPEED: f64 = 1e-9;

/// The activation loop's lists, kept from one step to the next on each thread. Each is
/// cleared before it is filled.
#[derive(Default)]
struct Lists {
    /// Per candidate: in the velocity problem; closed at the step's end.
    in_active: Vec<bool>,
    closed: Vec<bool>,
    /// Per ring, how far the step can move any of its points along their normals (h times
    /// the θ-weighted bound of `ClearanceJoint::ring_speed_bound`).
    travel: Vec<f64>,
    /// Per ring crossed, its most crossed guard: (ring, candidate, gap).
    worst: Vec<(usize, usize, f64)>,
    /// The active contacts the projection takes, and the candidates that closed.
    pool: Vec<usize>,
    new: Vec<usize>,
}

thread_local! {
    static LISTS: kept::Slot<Lists> = const { kept::Slot::new(None) };
}

impl Simulation {
    /// The combined projection + activation loop (docs/method.md), started from the
    /// previous step's active set (kept while pressed or closed; guards are not kept, they
    /// are chosen afresh each step): the active set, the velocity step, the end-of-step
    /// poses, the contact points evaluated there, and the contacts that closed.
    pub(super) fn combined(&self, mut report: StepReport) -> Outcome {
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
        let mut lists = kept::take(&LISTS);
        let Lists {
            in_active,
            closed,
            travel,
            worst,
            pool,
            new,
        } = &mut *lists;
        for pass in 1..=p.max_active_set_passes {
            let mut vs = self.velocity(&active);
            in_active.clear();
            in_active.resize(self.points.len(), false);
            active.iter().for_each(|&i| in_active[i] = true);
            // A guard whose linearised end-of-step gap g + h u_N,θ is negative marks a step
            // that carries the journal across its clearance: put the most crossed guard of
            // each such ring in the velocity problem and solve again (the guards are far from
            // contact otherwise, so this never happens while h·v stays below the clearance).
            // One per ring and pass keeps the problem small and its Delassus matrix regular.
            // A guard whose gap, less 1.5 times the farthest its ring's points can travel
            // along their normals in the step, stays above a quarter of the depth below
            // zero cannot be crossed: its speeds are not formed (the factor and the quarter
            // leave room for rounding).
            travel.clear();
            travel.extend(self.model.clearance_joints.iter().flat_map(|j| {
                [-1.0, 1.0].map(|side| {
                    let bound = |v: &[f64]| j.ring_speed_bound(side, &self.state.poses, v);
                    let (b0, b1) = (bound(self.state.v.as_slice()), bound(vs.v.as_slice()));
                    p.h * ((1.0 - p.theta).abs() * b0 + p.theta.abs() * b1)
                })
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
            if !worst.is_empty() && pass < p.max_active_set_passes {
                active.extend(worst.iter().map(|w| w.1));
                active.sort_unstable();
                continue;
            }
            let mut poses = spare_poses(&vs.poses);
            // Project onto g = 0, as equalities, the active contacts that penetrate and those
            // that stay closed (pressed, not separating: u_N,k+1 ≤ e|u_N,k|/2). A contact that
            // rebounds (e > 0) and ended with g > 0 is left where it is: pulling it down onto
            // the surface (as Siconos' combined scheme does with every active contact) throws
            // away m g·g of energy per impact, 60 % at e = 1 and h = 0.05 on the ball.
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
            let mut pool_points;
            (report.projection, pool_points) = self.project_poses(
                &mut poses,
                pool,
                &selected,
                ContactRows::Equality,
                vs.elimination.as_deref_mut(),
            );
            // Held shut together, the closed contacts may admit no poses near the trial (a
            // tilted journal pressed on one flange and held at the other, 45 µm open, by
            // the last step's impulse): then let every active contact open, g ≥ 0, which
            // the start of the step satisfies, from the trial poses again.
            if !report.projection.converged {
                poses.copy_from_slice(&vs.poses);
                (report.projection, pool_points) = self.project_poses(
                    &mut poses,
                    pool,
                    &|_, _| true,
                    ContactRows::Inequality,
                    vs.elimination.as_deref_mut(),
                );
            }
            report.active_set_passes = pass;
            // activation from the end-of-step position (the pool's pair contacts and joint
            // stops as the projection left them)
            let known = |k: usize| {
                let points = pool_points.as_ref()?;
                pool.binary_search(&k).ok().map(|j| &points[j])
            };
            let mut after = spare_all_points();
            self.model
                .evaluate_selected_knowing(&poses, &self.candidates, known, &mut after);
            if let Some(points) = pool_points {
                hand_back_points(points);
            }
            new.clear();
            new.extend(
                (0..after.len())
                    .filter(|&i| !in_active[i] && !self.is_guard(i) && after[i].gap() <= 0.0),
            );
            if new.is_empty() {
                settled = true;
                if let Some((.., passed)) = last.replace((active, vs, poses, after)) {
                    hand_back_all_points(passed);
                }
                break;
            }
            // a contact that the first pass (the motion without this step's new impulses)
            // leaves open, and that was not approaching at the start, is knocked shut by
            // another contact's impact
            closing.extend(new.iter().map(|&i| Closing {
                candidate: i,
                end_gap: after[i].gap(),
                knocked: pass > 1 && self.points[i].normal_velocity(self.state.v.as_slice()) >= 0.0,
            }));
            if let Some((.., passed)) = last.replace((active.clone(), vs, poses, after)) {
                hand_back_all_points(passed);
            }
            active.extend(new.iter().copied());
            active.sort_unstable();
        }
        // an active set that did not settle within the allowed passes keeps the last pass,
        // flagged
        report.projection.converged &= settled;
        let (active, vs, poses, after) = last.expect("at least one pass");
        Outcome {
            active,
            vs,
            poses,
            points: Some(after),
            closing,
            report,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;

    /// A step reads nothing that the lists kept on its thread hold: the incline block (four
    /// contacts on a turning box) and the clearance pendulum (a journal's rings and flanges,
    /// guards, projections that fall back) run to the same bits on a fresh thread and on
    /// one whose lists hold stale entries of other sizes, and the block is pressed (its
    /// contacts carry impulses) and the journal touches its bore.
    #[test]
    fn a_step_reads_nothing_its_lists_held() {
        let run = |name: &'static str, duration: f64, poison: bool| {
            std::thread::spawn(move || {
                if poison {
                    super::LISTS.set(Some(Box::new(super::Lists {
                        in_active: vec![true; 40],
                        closed: vec![true; 40],
                        travel: vec![-1.0; 9],
                        worst: vec![(7, 7, f64::NAN); 5],
                        pool: vec![39; 12],
                        new: vec![38; 12],
                    })));
                    crate::integrator::simulation::poison_lists();
                    crate::integrator::opposed::poison_lists();
                    crate::integrator::moreau_jean::poison_lists();
                }
                let mut sim = Scene::bundled_simulation(name);
                let mut pressed = 0;
                sim.run_until(duration, |sim, _| {
                    pressed += usize::from(sim.impulses().iter().any(|p| p.x > 0.0));
                })
                .unwrap();
                (sim.state, sim.stats, pressed)
            })
            .join()
            .unwrap()
        };
        for (name, duration) in [("incline-block", 0.3), ("pendulum-clearance", 0.05)] {
            let (fresh, stats, pressed) = run(name, duration, false);
            assert!(pressed > 10, "{name}: {pressed} steps with an impulse");
            let (poisoned, stats2, _) = run(name, duration, true);
            assert_eq!(fresh, poisoned, "{name}");
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
