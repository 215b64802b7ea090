//! A journal squeezed across its ring: a step that carries the journal across its bore
//! (a coarse step under a load out of the joint's plane) can end with the ring's closest
//! point and a guard on the far side of the same ring, or two such guards, both pushing.
//! The clearance leaves no room for both to touch; the velocity problem then finds a pair
//! of large, nearly cancelling impulses (thousands of N·s, where a 1 kg bar's weight over
//! a 10 ms step is 0.1 N·s), and their friction brakes a swinging bar. Such a step is counted
//! (`RunStats::squeezed_steps`), which marks the sample suspect: its step is too coarse
//! for the joint. (Taken in halves, the pair's impulses fall to a few N·s, but the
//! trajectory is no better: the flanges then wedge the journal and the bar gains energy.)

use super::simulation::{Outcome, Simulation};
use crate::mechanics::model::{Candidate, Model};

/// Two points of a ring squeeze the journal when their normals are more than 90° apart
/// and the smaller of their impulses is at least this fraction of the larger.
const SQUEEZE: f64 = 1e-3;

/// Per candidate, the ring (2 × joint + side, side 0 for the − ring) whose closest point or
/// guard it is; `None` for every other contact.
pub(super) fn ring_members(model: &Model, candidates: &[Candidate]) -> Vec<Option<usize>> {
    candidates
        .iter()
        .map(|c| match *c {
            Candidate::Clearance { joint, point } => {
                let j = &model.clearance_joints[joint];
                if j.is_guard(point) {
                    let (side, _) = j.guard(point);
                    Some(2 * joint + usize::from(side > 0.0))
                } else {
                    (point < 2).then_some(2 * joint + point)
                }
            }
            _ => None,
        })
        .collect()
}

impl Simulation {
    /// Whether the step `trial` ends with a journal squeezed across one of its rings: two
    /// points of the ring with opposing normals both carry a normal impulse (the smaller at
    /// least `SQUEEZE` of the larger).
    pub(super) fn squeezed(&self, trial: &Outcome) -> bool {
        let pushing = |k: usize| {
            let i = trial.active[k];
            let p = trial.vs.impulses[k].x;
            self.ring_member[i].filter(|_| p > 0.0).map(|r| (r, i, p))
        };
        let pushed: Vec<(usize, usize, f64)> =
            (0..trial.active.len()).filter_map(pushing).collect();
        pushed.iter().enumerate().any(|(a, &(ra, ia, pa))| {
            pushed[a + 1..].iter().any(|&(rb, ib, pb)| {
                let (na, nb) = (self.points[ia].normal(), self.points[ib].normal());
                ra == rb && na.dot(&nb) < 0.0 && pa.min(pb) >= SQUEEZE * pa.max(pb)
            })
        })
    }
}
