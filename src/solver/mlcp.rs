//! Linear problems with equality and complementarity rows, `w = A z + c`:
//! equality rows have w = 0; inequality rows have 0 ≤ w ⟂ z ≥ 0. Used to eliminate the
//! bilateral joint rows from the one-step problem (Schur complement) and for the
//! position projection.

use super::lu::Lu;
use crate::math::buffer;
use crate::math::sized::sized;
use nalgebra::{DMatrix, DVector};

/// Relative regularisation added to the diagonal: redundant constraints (closed loops)
/// make A singular but the systems stay consistent, and two steps of iterative refinement
/// remove the bias of the regularisation.
const REGULARISATION: f64 = 1e-12;

/// Solver for the systems A z = rhs of the equality rows, A = H W⁻¹ Hᵀ: positive
/// semidefinite in its symmetric part, but not symmetric when W carries the gyroscopic
/// Jacobian, so it is factorised by LU.
pub struct EqualitySolver {
    a: DMatrix<f64>,
    lu: Lu,
}

impl Default for EqualitySolver {
    fn default() -> Self {
        EqualitySolver {
            a: DMatrix::zeros(0, 0),
            lu: Lu::default(),
        }
    }
}

impl EqualitySolver {
    pub fn new(a: DMatrix<f64>) -> Self {
        let mut solver = EqualitySolver {
            a,
            lu: Lu::default(),
        };
        solver.factorise();
        solver
    }

    /// The n × n matrix A, zeroed, to be formed in place and then factorised with
    /// `factorise` (its storage, and that of the factors, kept from one system to the next).
    pub fn zeroed(&mut self, n: usize) -> &mut DMatrix<f64> {
        buffer::zeros_matrix(&mut self.a, n, n);
        &mut self.a
    }

    /// A, as formed.
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.a
    }

    /// Factorises A, regularised.
    pub fn factorise(&mut self) {
        let a = &self.a;
        let scale = (0..a.nrows())
            .map(|i| a[(i, i)])
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        self.lu.refactor(a, REGULARISATION * scale);
    }

    /// A solution of A z = rhs (exact for consistent systems); NaN if the regularised
    /// matrix is singular.
    pub fn solve(&self, rhs: &DVector<f64>) -> DVector<f64> {
        let mut z = rhs.clone();
        let mut work = Vec::new();
        self.solve_in_place(z.as_mut_slice(), &mut work);
        z
    }

    /// Overwrites `b` with the solution of A z = b, with two steps of iterative refinement
    /// in `work` (resized as needed, so that a caller solving many systems allocates once);
    /// NaN if the regularised matrix is singular.
    pub fn solve_in_place(&self, b: &mut [f64], work: &mut Vec<f64>) {
        let n = b.len();
        work.resize(3 * n, 0.0);
        work[..n].copy_from_slice(b);
        if !self.lu.solve_in_place(b) {
            b.fill(f64::NAN);
            return;
        }
        sized!(n, |n| refine(&self.lu, self.a.as_slice(), b, work, n));
    }

    /// Overwrites `b` with the solution of the regularised system, without refinement;
    /// NaN if it is singular.
    pub fn solve_unrefined_in_place(&self, b: &mut [f64]) {
        if !self.lu.solve_in_place(b) {
            b.fill(f64::NAN);
        }
    }

    /// Solves for several right-hand sides at once (columns).
    pub fn solve_matrix(&self, rhs: &DMatrix<f64>) -> DMatrix<f64> {
        let mut out = rhs.clone();
        let mut work = Vec::new();
        for mut column in out.column_iter_mut() {
            self.solve_in_place(column.as_mut_slice(), &mut work);
        }
        out
    }
}

/// Two steps of iterative refinement of the solution `z` of A z = rhs (A n × n,
/// column-major, factorised in `lu`), with `rhs` at the head of `work` and room for two
/// more vectors after it.
#[inline(always)]
fn refine(lu: &Lu, a: &[f64], z: &mut [f64], work: &mut [f64], n: usize) {
    let (rhs, rest) = work.split_at_mut(n);
    let (az, dz) = rest.split_at_mut(n);
    for _ in 0..2 {
        // dz = rhs − A z, with A z summed column by column as nalgebra's product does
        az.fill(0.0);
        for (column, &zj) in a.chunks_exact(n).zip(z.iter()) {
            for (y, x) in az.iter_mut().zip(column) {
                *y += x * zj;
            }
        }
        for ((d, r), y) in dz.iter_mut().zip(rhs.iter()).zip(az.iter()) {
            *d = r - y;
        }
        if lu.solve_in_place(dz) {
            for (z, d) in z.iter_mut().zip(dz.iter()) {
                *z += d;
            }
        }
    }
}

/// Projected Gauss–Seidel for the mixed problem (equality rows where `equality[i]`),
/// from `z` as the initial guess. Returns the number of sweeps, or None if `max_sweeps`
/// was reached before ‖min(w, z)‖∞ and the equality residuals fell below `tol`.
pub fn solve_mixed_pgs(
    a: &DMatrix<f64>,
    c: &DVector<f64>,
    equality: &[bool],
    z: &mut DVector<f64>,
    tol: f64,
    max_sweeps: usize,
) -> Option<usize> {
    let n = c.len();
    for sweep in 1..=max_sweeps {
        for i in 0..n {
            if a[(i, i)] <= 0.0 {
                continue;
            }
            let wi = a.row(i).dot(&z.transpose()) + c[i];
            let zi = z[i] - wi / a[(i, i)];
            z[i] = if equality[i] { zi } else { zi.max(0.0) };
        }
        let w = a * &*z + c;
        let err = (0..n)
            .map(|i| {
                if equality[i] {
                    w[i].abs()
                } else {
                    w[i].min(z[i]).abs().max((-w[i]).max(0.0))
                }
            })
            .fold(0.0, f64::max);
        if err <= tol {
            return Some(sweep);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn redundant_consistent_system_is_solved_exactly() {
        // two identical constraints (a closed loop's redundancy): A is singular
        let h = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 1.0, 2.0, 0.0, 1.0]);
        let a = &h * h.transpose();
        let z_true = DVector::from_vec(vec![0.3, -0.1, 0.7]);
        let rhs = &a * &z_true;
        let z = EqualitySolver::new(a.clone()).solve(&rhs);
        assert!(
            (&a * &z - &rhs).norm() < 1e-12 * rhs.norm(),
            "residual {}",
            (&a * &z - &rhs).norm()
        );
    }

    #[test]
    fn pgs_solves_a_mixed_problem() {
        let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, 2.0]);
        let c = DVector::from_vec(vec![-1.0, 2.0, -3.0]);
        let eq = [true, false, false];
        let mut z = DVector::zeros(3);
        solve_mixed_pgs(&a, &c, &eq, &mut z, 1e-14, 1000).expect("converges");
        let w = &a * &z + &c;
        assert!(w[0].abs() < 1e-13);
        for i in 1..3 {
            assert!(z[i] >= 0.0 && w[i] >= -1e-13 && (z[i] * w[i]).abs() < 1e-13);
        }
        // row 1 separates (z = 0, w > 0), row 2 is pressed (z > 0, w = 0)
        assert!(z[1] == 0.0 && z[2] > 0.0);
    }
}
