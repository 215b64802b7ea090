//! A body that sinks past the middle of a thin part within one step: the part's far side
//! is then the nearer one, and the contact pushes the body out through it. Plain
//! Moreau–Jean sinks by up to h·v; under combined projection the θ-rule still carries a
//! body that an impact stops by h(1 − θ) times its speed before the projection lifts it,
//! which the projection does along the far side's normal once the body is past the
//! middle. Such a step is too coarse (it is taken in halves), and a run that keeps one
//! counts it (`RunStats::sank_through`).

use super::simulation::Simulation;
use crate::mechanics::model::Candidate;
use crate::mechanics::ContactPoint;
use nalgebra::{DVector, Vector3};

/// A contact pair's point that the step takes into its part: the candidate, its normal at
/// the step's start and the depth the step's motion takes it to along that normal.
pub(super) struct Sinking {
    candidate: usize,
    normal: Vector3<f64>,
    depth: f64,
}

impl Simulation {
    /// The contact pairs' points that the step to the velocities `v1` takes (or leaves)
    /// deeper than the admissible depth into their parts, measured along their start
    /// normals with the θ-rule's motion.
    pub(super) fn sinking(&self, v1: &DVector<f64>) -> Vec<Sinking> {
        let p = &self.params;
        let (h, theta) = (self.h, p.theta);
        let (v0, v1) = (self.state.v.as_slice(), v1.as_slice());
        let mut sinking = Vec::new();
        for (i, c) in self.points.iter().enumerate() {
            if !matches!(self.candidates[i], Candidate::Pair { .. }) {
                continue;
            }
            let g0 = c.gap();
            let travel =
                h * ((1.0 - theta) * c.normal_velocity(v0) + theta * c.normal_velocity(v1));
            let depth = -g0.min(g0 + travel);
            if depth > p.admissible_depth() {
                sinking.push(Sinking {
                    candidate: i,
                    normal: c.geometry.normal,
                    depth,
                });
            }
        }
        sinking
    }

    /// Whether, at the step's end `points`, any of the `sinking` points is past its part's
    /// middle: its own normal turned against the start's, or another point of its pair
    /// faces the other way at a gap below its depth (a profile's far side is a point of
    /// its own).
    pub(super) fn sank_past(&self, sinking: &[Sinking], points: &[ContactPoint]) -> bool {
        sinking.iter().any(|s| {
            let opposed = |j: usize| points[j].geometry.normal.dot(&s.normal) < 0.0;
            if opposed(s.candidate) {
                return true;
            }
            let Candidate::Pair { pair, .. } = self.candidates[s.candidate] else {
                return false;
            };
            (0..points.len()).any(|j| {
                matches!(self.candidates[j], Candidate::Pair { pair: p, .. } if p == pair)
                    && opposed(j)
                    && points[j].gap() < s.depth
            })
        })
    }
}
