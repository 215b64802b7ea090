//! Bilateral rows as sparse operators. A row touches at most two bodies, so its products
//! with vectors and matrices that have an entry per degree of freedom go over those two
//! 6-blocks only: a mechanism's rows cost what its joints cost, not rows × degrees of
//! freedom.

use crate::math::buffer;
use crate::mechanics::body::holds_none;
use crate::mechanics::joint::BilateralRow;
use nalgebra::{DMatrix, DVector, Matrix6, RowVector6};

/// The row's blocks on its (at most two) bodies.
pub fn blocks(row: &BilateralRow) -> impl Iterator<Item = &(usize, RowVector6<f64>)> {
    row.a.iter().chain(row.b.iter())
}

/// The rows as a dense matrix (rows × dofs, held dofs zeroed), and their prescribed
/// rates b.
pub fn matrix(rows: &[BilateralRow], mask: &[bool], ndof: usize) -> (DMatrix<f64>, DVector<f64>) {
    let mut hmat = DMatrix::zeros(rows.len(), ndof);
    for (k, row) in rows.iter().enumerate() {
        for (b, g) in blocks(row) {
            for j in 0..6 {
                if mask[6 * b + j] {
                    hmat[(k, 6 * b + j)] += g[j];
                }
            }
        }
    }
    (
        hmat,
        DVector::from_iterator(rows.len(), rows.iter().map(|r| r.rate)),
    )
}

/// M⁻¹ Rᵀ for the rows R (ndof × rows): each row touches at most two bodies, so each
/// column is at most two blocks M_b⁻¹ g_bᵀ (held dofs are zero in `minv`, which masks them).
pub fn inverse_mass_times_rows(
    minv: &[Matrix6<f64>],
    rows: &[BilateralRow],
    ndof: usize,
) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(0, 0);
    inverse_mass_times_rows_into(minv, rows, ndof, &mut out);
    out
}

/// `inverse_mass_times_rows` into `out`, in its storage.
pub fn inverse_mass_times_rows_into(
    minv: &[Matrix6<f64>],
    rows: &[BilateralRow],
    ndof: usize,
    out: &mut DMatrix<f64>,
) {
    buffer::zeros_matrix(out, ndof, rows.len());
    for (k, row) in rows.iter().enumerate() {
        for (b, g) in blocks(row) {
            let mut col = out.fixed_view_mut::<6, 1>(6 * b, k);
            col += minv[*b] * g.transpose();
        }
    }
}

/// Zeroes the held degrees of freedom (`mask` false) in the rows' blocks: what the dense
/// matrix of the rows holds.
pub fn mask(rows: &mut [BilateralRow], mask: &[bool]) {
    for row in rows {
        for (b, g) in row.a.iter_mut().chain(row.b.iter_mut()) {
            if holds_none(mask, *b) {
                continue;
            }
            for (x, &m) in g.as_mut_slice().iter_mut().zip(&mask[6 * *b..6 * *b + 6]) {
                if !m {
                    *x = 0.0;
                }
            }
        }
    }
}

/// g · x for a row's block and the six entries of a body.
fn dot6(g: &RowVector6<f64>, x: &[f64]) -> f64 {
    g.as_slice().iter().zip(x).fold(0.0, |s, (g, x)| s + g * x)
}

/// The row times v, for v with an entry per degree of freedom.
pub fn dot(row: &BilateralRow, v: &[f64]) -> f64 {
    blocks(row)
        .map(|(b, g)| dot6(g, &v[6 * b..6 * b + 6]))
        .sum::<f64>()
}

/// Rᵀ λ into `out`, which has an entry per degree of freedom.
pub fn transposed_times_into(rows: &[BilateralRow], lambda: &DVector<f64>, out: &mut DVector<f64>) {
    out.as_mut_slice().fill(0.0);
    for (row, l) in rows.iter().zip(lambda.iter()) {
        for (b, g) in blocks(row) {
            let mut seg = out.fixed_rows_mut::<6>(6 * b);
            seg += g.transpose() * *l;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanics::joint::RowUnit;

    /// Two rows on three bodies, the middle one with a held degree of freedom: every sparse
    /// product equals the dense matrix's.
    #[test]
    fn sparse_products_match_the_dense_matrix() {
        let row = |a: Option<usize>, b: Option<usize>, seed: f64| BilateralRow {
            a: a.map(|i| (i, RowVector6::from_fn(|_, j| seed + j as f64))),
            b: b.map(|i| (i, RowVector6::from_fn(|_, j| seed * (j as f64 - 2.5)))),
            value: 0.0,
            rate: seed,
            unit: RowUnit::Length,
        };
        let ndof = 18;
        let mut mask = vec![true; ndof];
        mask[6 + 4] = false;
        let mut rows = vec![row(Some(0), Some(1), 1.5), row(None, Some(2), -0.7)];
        let (dense, _) = matrix(&rows, &mask, ndof);
        super::mask(&mut rows, &mask);
        let v = DVector::from_fn(ndof, |i, _| (i as f64 * 0.37).sin());
        let rv = DVector::from_iterator(2, rows.iter().map(|r| dot(r, v.as_slice())));
        assert!((rv - &dense * &v).amax() < 1e-14);
        let lambda = DVector::from_vec(vec![0.3, -2.0]);
        let mut rt = DVector::from_element(ndof, f64::NAN);
        transposed_times_into(&rows, &lambda, &mut rt);
        assert!((rt - dense.tr_mul(&lambda)).amax() < 1e-14);
        // held degrees of freedom are zero in M⁻¹, which masks them
        let mut minv = vec![Matrix6::identity() * 2.0; 3];
        minv[1][(4, 4)] = 0.0;
        let mct = inverse_mass_times_rows(&minv, &rows, ndof);
        assert!((mct - dense.transpose() * 2.0).amax() < 1e-14);
    }
}
