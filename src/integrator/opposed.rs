//! Contacts that face each other across a gap, such as the two flanges of a journal with
//! axial play or the two walls of a slot: their normal rows nearly cancel, so the velocity
//! problem alone cannot tell how much of an equal and opposite pair of impulses they carry.

use super::simulation::Simulation;
use crate::mechanics::body::BodyRef;
use crate::mechanics::ContactPoint;
use nalgebra::Vector3;

/// Normals at least this close to antiparallel face each other (2.6°).
const FACING_COS: f64 = -0.999;

impl Simulation {
    /// Per contact of `active`, whether it stays out of the velocity problem: it faces
    /// another active contact of the same two bodies, and the step's forecast
    /// g + γ h u_N,k opens it, and opens it more than that contact. `None` where none does.
    ///
    /// A step that carries a part across its play in a slot (a journal leaving one flange
    /// and striking the other) has both walls active: the one it leaves, pressed in the
    /// last step, and the one it strikes. Their conditions then hold at one normal velocity
    /// only (U ≥ −e a on the one, −U ≥ e a on the other), round-off makes them slightly
    /// infeasible, and the solver drifts along the pair to impulses of any size, whose
    /// round-off gives the mechanism energy. The wall the
    /// step leaves has nothing to say while the other one holds; if the step brings the
    /// part back onto it after all, the activation and the projection see it at the step's
    /// end, as any other contact. Walls pressed from both sides (forecasts within the
    /// activation margin) both stay. `facing` is the list it works in.
    pub(super) fn behind_opposed(
        &self,
        active: &[usize],
        facing: &mut Vec<Option<Facing>>,
    ) -> Option<Vec<bool>> {
        let p = self.step_params();
        let v0 = self.state.v.as_slice();
        // the normal oriented from the body of higher index to the lower, and that pair
        let oriented = |c: &ContactPoint| {
            let bodies = c.bodies();
            let n = c.normal();
            (bodies, if bodies.0 == c.body1 { n } else { -n })
        };
        facing.clear();
        facing.extend(active.iter().map(|&i| {
            let c = &self.points[i];
            (!self.is_guard(i) && !c.gap_law).then(|| (oriented(c), p.forecast(c, v0)))
        }));
        let behind = |me: &Option<Facing>| {
            let Some(((bodies, n), f)) = *me else {
                return false;
            };
            f > p.activation_margin
                && facing
                    .iter()
                    .flatten()
                    .any(|&((other, m), g)| other == bodies && n.dot(&m) < FACING_COS && g < f)
        };
        let dropped = facing
            .iter()
            .any(behind)
            .then(|| facing.iter().map(behind).collect());
        dropped
    }
}

/// An active contact's bodies, its normal oriented from the body of higher index to the
/// lower, and its forecast.
pub(super) type Facing = (((BodyRef, BodyRef), Vector3<f64>), f64);
