//! Contacts that a step jumps across. A body that travels farther in one step than a part
//! is thick ends the step on the part's far side: the gap at the step's start was too wide
//! for the forecast to take the contact, and the gap at the step's end is measured to the
//! far face. The motion along the start's normal still shows the crossing: a contact whose
//! gap the step's motion takes below zero, while the geometry at the step's end shows less
//! than half that depth or a normal turned against the start's (the body sank past the
//! part's middle), and which is closed where the motion crosses the start's tangent plane,
//! was jumped across. The step is then taken again with that contact.

use super::moreau_jean::{advance_poses_into, VelocityStep};
use super::simulation::Simulation;
use crate::mechanics::model::Candidate;

/// How far the contact may be open where the motion crosses its start plane, as a fraction
/// of the step's travel along the normal, and count as met. A body that clears the part's
/// edge by more has passed beside it.
const GRAZE: f64 = 0.01;

impl Simulation {
    /// Into `crossed`, the contact pairs' candidates outside `in_active` that the step `vs`
    /// carries across their part, with the linearised gap the step's motion leaves them
    /// (negative). The gaps are those of the step's own motion, before any projection.
    /// A clearance joint's journal cannot jump its bore (its guards see to that), and a
    /// joint stop's gap is a coordinate, which no step jumps across.
    pub(super) fn jumped_across(
        &self,
        in_active: &[bool],
        vs: &VelocityStep,
        crossed: &mut Vec<(usize, f64)>,
    ) {
        crossed.clear();
        let p = self.step_params();
        let (h, theta) = (p.h, p.theta);
        let (v0, v1) = (self.state.v.as_slice(), vs.v.as_slice());
        let depth = p.admissible_depth();
        let mut at = Vec::new();
        let mut point_at = |poses: &[_], i: usize| {
            self.model
                .evaluate_selected(poses, &self.candidates[i..=i], &mut at);
            at[0]
        };
        for (i, c) in self.points.iter().enumerate() {
            if in_active[i] || !matches!(self.candidates[i], Candidate::Pair { .. }) {
                continue;
            }
            let g0 = c.gap();
            if g0 <= p.activation_margin {
                continue;
            }
            let travel =
                h * ((1.0 - theta) * c.normal_velocity(v0) + theta * c.normal_velocity(v1));
            let swept = g0 + travel;
            if swept >= -depth {
                continue;
            }
            let end = point_at(&vs.poses, i);
            let turned = end.geometry.normal.dot(&c.geometry.normal) < 0.0;
            if end.gap() <= 0.5 * swept && !turned {
                continue;
            }
            // the contact where the motion crosses the start's tangent plane
            let mut poses = Vec::new();
            let (q0, u0) = (&self.state.poses, &self.state.v);
            advance_poses_into(&mut poses, q0, u0, &vs.v, h * g0 / -travel, theta);
            if point_at(&poses, i).gap() <= GRAZE * -travel {
                crossed.push((i, swept));
            }
        }
    }
}
