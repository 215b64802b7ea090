//! LU factorisation with partial pivoting for `mlcp`'s equality systems (the joints' rows
//! and the position projection), whose matrices are block-sparse: a row couples only to
//! the rows that share one of its bodies. It performs nalgebra's `LU` arithmetic operation for operation (the
//! same pivots, the multipliers scaled by the pivot's reciprocal, the same updates in the
//! same order), so its factors and solutions are bit-identical to nalgebra's; it skips the
//! updates whose multiplier or pivot-row entry is zero, which leave an entry unchanged, and
//! runs its inner loops over contiguous slices, unrolled for the sizes up to 6 (`sized!`).

use crate::math::sized::sized;
use nalgebra::{DMatrix, DVector};

/// The factors L U = P A of a square matrix, stored in place (column-major).
#[derive(Clone, Debug, Default)]
pub struct Lu {
    n: usize,
    /// L below the diagonal (unit diagonal implied), U on and above it, column-major.
    lu: Vec<f64>,
    /// The row swaps, in the order they were made.
    swaps: Vec<(usize, usize)>,
    /// Scratch of the factorisation: the rows under the pivot with a nonzero multiplier.
    nonzero: Vec<usize>,
}

impl Lu {
    /// Factorises the square matrix `a`. A column without a nonzero pivot is skipped, as
    /// nalgebra does; `solve` then reports the matrix singular.
    pub fn new(a: DMatrix<f64>) -> Self {
        assert!(a.is_square(), "LU of a non-square matrix");
        let mut factors = Lu {
            n: a.nrows(),
            lu: a.data.into(),
            ..Default::default()
        };
        factors.factorise();
        factors
    }

    /// Factorises `a` with `shift` added to its diagonal in place of the factors held,
    /// reusing their storage (a caller that factorises at every step allocates once).
    pub fn refactor(&mut self, a: &DMatrix<f64>, shift: f64) {
        assert!(a.is_square(), "LU of a non-square matrix");
        self.n = a.nrows();
        self.lu.clear();
        self.lu.extend_from_slice(a.as_slice());
        self.shift_and_factorise(shift);
    }

    /// Adds `shift` to the diagonal of the matrix held in `lu`, then factorises it.
    fn shift_and_factorise(&mut self, shift: f64) {
        let n = self.n;
        for i in 0..n {
            self.lu[i * n + i] += shift;
        }
        self.factorise();
    }

    /// Overwrites the matrix held in `lu` with its factors.
    fn factorise(&mut self) {
        let Lu {
            n,
            lu,
            swaps,
            nonzero,
        } = self;
        swaps.clear();
        sized!(*n, |n| factorise(lu, swaps, nonzero, n));
    }

    /// The nonzero entries of the factors L and U (L's unit diagonal not counted): what a
    /// solve touches, and a measure of the fill-in.
    #[cfg(test)]
    pub fn nonzeros(&self) -> usize {
        self.lu.iter().filter(|&&x| x != 0.0).count()
    }

    /// The solution x of A x = b; `None` if U has a zero on its diagonal.
    pub fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let mut x = b.clone();
        self.solve_in_place(x.as_mut_slice()).then_some(x)
    }

    /// Overwrites `b` with the solution; false if U has a zero on its diagonal.
    pub fn solve_in_place(&self, b: &mut [f64]) -> bool {
        let n = self.n;
        assert_eq!(b.len(), n, "LU solve: dimension mismatch");
        sized!(n, |n| solve(&self.lu, &self.swaps, b, n))
    }
}

/// Overwrites the n × n matrix `lu` (column-major) with its factors, pushing its row
/// swaps onto `swaps`; `rows` is scratch.
#[inline(always)]
fn factorise(lu: &mut [f64], swaps: &mut Vec<(usize, usize)>, rows: &mut Vec<usize>, n: usize) {
    for i in 0..n {
        let column = &lu[i * n..(i + 1) * n];
        let mut piv = i;
        let mut max = column[i].abs();
        for (r, x) in column.iter().enumerate().skip(i + 1) {
            if x.abs() > max {
                max = x.abs();
                piv = r;
            }
        }
        let diag = column[piv];
        if diag == 0.0 {
            continue;
        }
        if piv != i {
            swaps.push((i, piv));
            for c in 0..n {
                lu.swap(c * n + i, c * n + piv);
            }
        }
        let inv_diag = 1.0 / diag;
        let (head, tail) = lu.split_at_mut((i + 1) * n);
        let coeffs = &mut head[i * n + i + 1..];
        rows.clear();
        for (r, x) in coeffs.iter_mut().enumerate() {
            *x *= inv_diag;
            if *x != 0.0 {
                rows.push(r);
            }
        }
        if rows.is_empty() {
            continue;
        }
        let dense = 2 * rows.len() > coeffs.len();
        for column in tail.chunks_exact_mut(n) {
            let p = column[i];
            if p == 0.0 {
                continue;
            }
            let below = &mut column[i + 1..];
            if dense {
                for (y, x) in below.iter_mut().zip(coeffs.iter()) {
                    *y += -p * x;
                }
            } else {
                for &r in rows.iter() {
                    below[r] += -p * coeffs[r];
                }
            }
        }
    }
}

/// Overwrites `b` with the solution of L U x = P b; false if U has a zero on its diagonal.
#[inline(always)]
fn solve(lu: &[f64], swaps: &[(usize, usize)], b: &mut [f64], n: usize) -> bool {
    for &(i, j) in swaps {
        b.swap(i, j);
    }
    for i in 0..n.saturating_sub(1) {
        let coeff = b[i];
        if coeff == 0.0 {
            continue;
        }
        let column = &lu[i * n + i + 1..(i + 1) * n];
        for (y, l) in b[i + 1..].iter_mut().zip(column) {
            *y += -coeff * l;
        }
    }
    for i in (0..n).rev() {
        let diag = lu[i * n + i];
        if diag == 0.0 {
            return false;
        }
        let coeff = b[i] / diag;
        b[i] = coeff;
        if coeff == 0.0 {
            continue;
        }
        let column = &lu[i * n..i * n + i];
        for (y, u) in b[..i].iter_mut().zip(column) {
            *y += -coeff * u;
        }
    }
    true
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A deterministic pseudo-random matrix with the block pattern of a contact problem:
    /// 3×3 blocks, nonzero on the diagonal and where `coupled(a, b)`.
    pub(crate) fn blocky(
        blocks: usize,
        seed: u64,
        coupled: impl Fn(usize, usize) -> bool,
    ) -> DMatrix<f64> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let n = 3 * blocks;
        DMatrix::from_fn(n, n, |r, c| {
            if r / 3 == c / 3 || coupled(r / 3, c / 3) {
                next() + if r == c { 0.3 } else { 0.0 }
            } else {
                0.0
            }
        })
    }

    fn bits(v: &DVector<f64>) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Whether block (a, b) of a `blocky` matrix is filled.
    pub(crate) type Coupled = fn(usize, usize) -> bool;

    /// Block patterns of contact problems, by name.
    pub(crate) const PATTERNS: [(&str, Coupled); 4] = [
        ("dense", |_, _| true),
        ("chain", |a, b| a.abs_diff(b) == 1),
        ("arrow", |a, b| a == 0 || b == 0),
        ("sparse", |a, b| (a * 7 + b * 3).is_multiple_of(5)),
    ];

    /// The factors' solutions are nalgebra's bit for bit, on dense and block-sparse
    /// matrices (whose updates it skips), and they solve the system.
    #[test]
    fn solutions_are_nalgebras_bit_for_bit() {
        for (name, coupled) in PATTERNS {
            for seed in 1..20 {
                let a = blocky(19, seed, coupled);
                let b = DVector::from_fn(a.nrows(), |i, _| (i as f64 * 0.37).sin());
                let ours = Lu::new(a.clone()).solve(&b).expect("regular");
                let theirs = a.clone().lu().solve(&b).expect("regular");
                assert_eq!(bits(&ours), bits(&theirs), "{name}, seed {seed}");
                assert!((&a * &ours - &b).amax() < 1e-9 * ours.amax(), "{name}");
            }
        }
    }

    /// The sizes of joint and contact systems, which run loops compiled for their size
    /// (`sized!`), give nalgebra's solutions bit for bit too, pivoting and skipping zeros.
    #[test]
    fn small_systems_are_nalgebras_bit_for_bit() {
        for n in 1..=7 {
            for seed in 1..40u64 {
                let mut state = seed * 7919 + n as u64;
                let mut next = move || {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
                };
                // entries of either sign, a fifth of them zero, so that rows are swapped
                // and updates skipped
                let a = DMatrix::from_fn(n, n, |_, _| {
                    let x = next();
                    if x.abs() < 0.1 {
                        0.0
                    } else {
                        x
                    }
                });
                let b = DVector::from_fn(n, |i, _| (i as f64 * 0.37 + seed as f64).sin());
                let ours = Lu::new(a.clone()).solve(&b);
                let theirs = a.clone().lu().solve(&b);
                assert_eq!(ours.as_ref().map(bits), theirs.map(|x| bits(&x)), "n = {n}");
                if let Some(x) = ours {
                    assert!((&a * &x - &b).amax() < 1e-8 * x.amax().max(1.0), "n = {n}");
                }
            }
        }
    }

    /// A singular matrix (a zero column, two equal rows) is reported, as nalgebra does.
    #[test]
    fn singular_matrices_are_reported() {
        let mut a = blocky(4, 3, |_, _| true);
        a.column_mut(5).fill(0.0);
        let b = DVector::from_element(12, 1.0);
        assert!(Lu::new(a.clone()).solve(&b).is_none());
        assert!(a.lu().solve(&b).is_none());
        let mut a = blocky(4, 5, |_, _| true);
        let row = a.row(2).into_owned();
        a.row_mut(7).copy_from(&row);
        assert_eq!(
            Lu::new(a.clone()).solve(&b).map(|x| bits(&x)),
            a.lu().solve(&b).map(|x| bits(&x))
        );
    }
}
