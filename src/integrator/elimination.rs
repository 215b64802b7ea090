//! The joints' rows eliminated from a velocity step (Schur complement). The impulses Q act
//! along the rows at the step's midpoint, G = H(q_{k+½}), and the velocity meets the rows
//! at its end, H = H(q_{k+1}): H v_{k+1} = b(t_{k+1}). So v = v_free + Z Q with Z = W⁻¹Gᵀ
//! and S = H Z.
//!
//! The midpoint direction keeps the θ = 1/2 scheme second order on constrained motion
//! (start-of-step rows, as in Siconos, are first order); the end-of-step condition leaves
//! no free mode: imposing the midpoint rows on the mean velocity, G (v_k + v_{k+1})/2 = b,
//! leaves v_{k+1} = 2b − v_k free to alternate step after step, which any impact excites
//! and nothing damps. Z is nonzero only on the bodies W couples to jointed ones, so a
//! contact away from the joints keeps its plain response.
//!
//! W is block diagonal and each row touches at most two bodies, so Z, S and the products
//! with G and H are formed block by block (`rows.rs`), never as dense matrices over all the
//! degrees of freedom.

use super::iteration_matrix::IterationMatrix;
use super::moreau_jean::JointRowsAt;
use super::rows;
use crate::math::buffer;
use crate::mechanics::joint::BilateralRow;
use crate::mechanics::Pose;
use crate::solver::EqualitySolver;
use nalgebra::{DMatrix, DVector, Matrix6x3, RowVector6, Vector6};

/// The elimination, kept from one step to the next with all its storage (a velocity step
/// re-forms it at every Newton iteration).
#[derive(Default)]
pub(super) struct Elimination {
    /// G, the rows the impulses act along, and H, those the end-of-step velocity meets
    /// (held degrees of freedom zeroed).
    g: Vec<BilateralRow>,
    h: Vec<BilateralRow>,
    /// Z = W⁻¹Gᵀ by body: its nonzero blocks (row of G, W⁻¹ g_bᵀ on the body), those of
    /// body b at `z[z_start[b]..z_start[b + 1]]`.
    z: Vec<(usize, Vector6<f64>)>,
    z_start: Vec<usize>,
    schur: EqualitySolver,
    /// Bodies on which H has nonzero blocks.
    h_bodies: Vec<usize>,
    /// Scratch: Z's blocks as (body, row, block) before they are sorted by body, a row's
    /// response, the next free place of each body's blocks, the bodies H touches, and the
    /// solves' refinement.
    unsorted: Vec<(usize, usize, Vector6<f64>)>,
    response: Vec<(usize, Vector6<f64>)>,
    next: Vec<usize>,
    on_h: Vec<bool>,
    work: Vec<f64>,
    /// The multipliers of `chord_step`.
    chord: DVector<f64>,
}

impl Elimination {
    /// Re-forms the elimination of the joints' rows `rows_at` at `g_at` (impulse
    /// directions) and at `h_at` (velocity conditions, with their rates) for the iteration
    /// matrix `w`; `mask` marks the integrated degrees of freedom.
    pub(super) fn assemble(
        &mut self,
        w: &IterationMatrix,
        rows_at: JointRowsAt,
        g_at: (f64, &[Pose]),
        h_at: (f64, &[Pose]),
        mask: &[bool],
    ) {
        for (rows, (t, poses)) in [(&mut self.g, g_at), (&mut self.h, h_at)] {
            rows.clear();
            rows_at(t, poses, rows);
            rows::mask(rows, mask);
        }
        let bodies = mask.len() / 6;
        // Z's blocks, ordered by body (a counting sort keeps each body's in row order)
        let blocks = &mut self.unsorted;
        blocks.clear();
        for (k, row) in self.g.iter().enumerate() {
            let mut on = [(0, RowVector6::zeros()); 2];
            let mut count = 0;
            for &(b, gb) in rows::blocks(row) {
                on[count] = (b, gb);
                count += 1;
            }
            w.solve_blocks_into(&on[..count], &mut self.response);
            blocks.extend(self.response.iter().map(|&(b, y)| (b, k, y)));
        }
        let z_start = &mut self.z_start;
        z_start.clear();
        z_start.resize(bodies + 1, 0);
        blocks.iter().for_each(|&(b, _, _)| z_start[b + 1] += 1);
        for b in 0..bodies {
            z_start[b + 1] += z_start[b];
        }
        self.next.clone_from(z_start);
        self.z.clear();
        self.z.resize(blocks.len(), (0, Vector6::zeros()));
        for &(b, k, y) in blocks.iter() {
            self.z[self.next[b]] = (k, y);
            self.next[b] += 1;
        }
        // S = H Z over the bodies each row of H touches
        let (z, z_start) = (&self.z, &self.z_start);
        let s = self.schur.zeroed(self.h.len());
        debug_assert_eq!(
            self.g.len(),
            self.h.len(),
            "G and H are the same joints' rows"
        );
        self.on_h.clear();
        self.on_h.resize(bodies, false);
        let n = self.h.len();
        let s = s.as_mut_slice();
        for (k, row) in self.h.iter().enumerate() {
            for (b, hb) in rows::blocks(row) {
                self.on_h[*b] |= hb.iter().any(|&x| x != 0.0);
                for (j, y) in &z[z_start[*b]..z_start[b + 1]] {
                    // summed in order from zero, as nalgebra's dot product is
                    let mut dot = 0.0;
                    for (x, y) in hb.iter().zip(y.iter()) {
                        dot += x * y;
                    }
                    s[j * n + k] += dot;
                }
            }
        }
        self.schur.factorise();
        self.h_bodies.clear();
        self.h_bodies.extend((0..bodies).filter(|&b| self.on_h[b]));
    }

    /// The chord step of a projection onto the same joints' rows: Δν = Z S⁻¹(−c) for the
    /// values c of `rows` (those rows at the poses projected), into `dnu`. It meets
    /// H Δν = −c, so it removes the violation to first order as the Gauss–Newton step
    /// M⁻¹Cᵀ(C M⁻¹Cᵀ)⁻¹(−c) does, along directions that differ from it by O(h), with the
    /// factors this step has already formed. S is solved once, without the refinement the
    /// joints' impulses take: the projection evaluates the rows where the step lands and
    /// keeps it only if it halves their violation. False where the rows are not these
    /// (another count) or the solve fails.
    pub(super) fn chord_step(&mut self, rows: &[BilateralRow], dnu: &mut DVector<f64>) -> bool {
        if rows.is_empty() || rows.len() != self.h.len() {
            return false;
        }
        let q = &mut self.chord;
        buffer::fit(q, rows.len());
        for (qk, r) in q.as_mut_slice().iter_mut().zip(rows) {
            *qk = -r.value;
        }
        self.schur.solve_unrefined_in_place(q.as_mut_slice());
        buffer::fit(dnu, 6 * (self.z_start.len() - 1));
        dnu.as_mut_slice().fill(0.0);
        self.add_response(&self.chord, dnu);
        dnu.as_slice().iter().all(|x| x.is_finite())
    }

    /// Z's blocks on body `b`: (row of G, W⁻¹ g_bᵀ).
    fn z_on(&self, b: usize) -> &[(usize, Vector6<f64>)] {
        &self.z[self.z_start[b]..self.z_start[b + 1]]
    }

    /// The joints' impulses Q = S⁻¹(b − H v_free) that make `v_free` meet the rows, into
    /// `q`.
    pub(super) fn impulses_into(&mut self, v_free: &DVector<f64>, q: &mut DVector<f64>) {
        let v = v_free.as_slice();
        buffer::fit(q, self.h.len());
        for (qk, r) in q.as_mut_slice().iter_mut().zip(&self.h) {
            *qk = r.rate - rows::dot(r, v);
        }
        self.schur.solve_in_place(q.as_mut_slice(), &mut self.work);
    }

    /// v + Z Q: the velocity that the joints' impulses Q give `v`.
    pub(super) fn add_response(&self, q: &DVector<f64>, v: &mut DVector<f64>) {
        for b in 0..self.z_start.len() - 1 {
            let mut seg = v.fixed_rows_mut::<6>(6 * b);
            for (j, y) in self.z_on(b) {
                seg += y * q[*j];
            }
        }
    }

    /// R − Gᵀ Q: what of the residual `r` the joints' impulses Q do not account for, into
    /// `out`.
    pub(super) fn unreacted(&self, q: &DVector<f64>, r: &DVector<f64>, out: &mut DVector<f64>) {
        buffer::fit(out, r.len());
        rows::transposed_times_into(&self.g, q, out);
        out.zip_apply(r, |o, ri| *o = ri - *o);
    }

    /// Turns a contact's response y = W⁻¹Gᵀ into the constrained one, y − Z S⁻¹ H y, and
    /// returns S⁻¹ H y (what its impulse takes from the joints' ones); None when H y = 0.
    pub(super) fn constrain(&self, y: &mut Vec<(usize, Matrix6x3<f64>)>) -> Option<DMatrix<f64>> {
        if !y.iter().any(|(b, _)| self.h_bodies.contains(b)) {
            return None;
        }
        let mut hy = DMatrix::zeros(self.h.len(), 3);
        for (k, row) in self.h.iter().enumerate() {
            for (b, hb) in rows::blocks(row) {
                if let Some((_, yb)) = y.iter().find(|(bb, _)| bb == b) {
                    let mut out = hy.fixed_view_mut::<1, 3>(k, 0);
                    out += hb * yb;
                }
            }
        }
        let corr = self.schur.solve_matrix(&hy);
        for b in 0..self.z_start.len() - 1 {
            let on = self.z_on(b);
            if on.is_empty() {
                continue;
            }
            let mut blk = Matrix6x3::zeros();
            for (j, zb) in on {
                blk += zb * corr.fixed_view::<1, 3>(*j, 0);
            }
            match y.iter_mut().find(|(bb, _)| *bb == b) {
                Some((_, yb)) => *yb -= blk,
                None => y.push((b, -blk)),
            }
        }
        Some(corr)
    }
}

#[cfg(test)]
mod tests {
    use super::super::projection::mass_distance;
    use super::super::rows;
    use crate::scene::Scene;
    use crate::solver::EqualitySolver;
    use nalgebra::DVector;

    /// The chord step that a projection takes on a velocity step's elimination meets the
    /// joints' rows at the step's end to first order, and it is the Gauss–Newton step but
    /// for O(h) of it: on the pendulum and on the driven four-bar (a closed loop, whose 21
    /// rows on 18 degrees of freedom are redundant), swinging, at their own step.
    #[test]
    fn the_chord_step_meets_the_rows_at_the_step_end() {
        for name in ["pendulum", "four-bar"] {
            let mut sim = Scene::bundled_simulation(name);
            sim.run_until(0.25, |_, _| {}).unwrap();
            let mut vs = sim.velocity(&[], &mut Default::default());
            let t = sim.state.t + sim.h;
            let rows = sim.model.joint_rows(t, &vs.poses);
            let c = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.value));
            let mut chord = DVector::zeros(0);
            let elimination = vs.elimination.as_deref_mut().expect("joints");
            assert!(elimination.chord_step(&rows, &mut chord), "{name}");
            let left = DVector::from_iterator(
                rows.len(),
                rows.iter()
                    .map(|r| r.value + rows::dot(r, chord.as_slice())),
            );
            // Gauss–Newton: M⁻¹Cᵀ(C M⁻¹Cᵀ)⁻¹(−c)
            let ndof = chord.len();
            let mct = rows::inverse_mass_times_rows(&sim.minv, &rows, ndof);
            let (cmat, _) = rows::matrix(&rows, &sim.mask, ndof);
            let gauss_newton = &mct * EqualitySolver::new(&cmat * &mct).solve(&(-&c));
            let place = |d: &DVector<f64>| -> Vec<_> {
                let twist = |b: usize| d.fixed_rows::<6>(6 * b).into_owned();
                (vs.poses.iter().enumerate())
                    .map(|(b, p)| p.advanced(&twist(b)))
                    .collect()
            };
            let apart = mass_distance(&sim.model, &place(&chord), &place(&gauss_newton));
            let length = mass_distance(&sim.model, &vs.poses, &place(&gauss_newton));
            assert!(
                c.amax() > 1e-10,
                "{name}: the step leaves a violation to remove"
            );
            assert!(left.amax() <= 1e-3 * c.amax(), "{name}: {left}");
            // measured: 1.5 h on the pendulum, 3e-6 on the (planar) four-bar
            assert!(apart <= 5.0 * sim.h * length, "{name}: {apart} of {length}");
        }
    }
}
