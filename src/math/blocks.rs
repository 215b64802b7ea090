//! 3- and 6-vectors and 3×3 blocks of slices, dynamic vectors and matrices, read and
//! written by index. A fixed-size view checks its bounds and strides each time it is made,
//! and a fixed-size vector built from a slice goes through an iterator; in the contact
//! solvers' inner loops, which make one per contact and sweep, that costs more than the
//! arithmetic on the block. The values are the same, so every product with them is the
//! same, bit for bit.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3, Vector6};

/// Entries `o`, `o + 1`, `o + 2` of `s`.
#[inline]
pub fn vector3_at(s: &[f64], o: usize) -> Vector3<f64> {
    let x = &s[o..o + 3];
    Vector3::new(x[0], x[1], x[2])
}

/// Entries `o` to `o + 5` of `s` (a body's twist or wrench in a vector of all of them).
#[inline]
pub fn vector6_at(s: &[f64], o: usize) -> Vector6<f64> {
    let x = &s[o..o + 6];
    Vector6::new(x[0], x[1], x[2], x[3], x[4], x[5])
}

/// Entries `o`, `o + 1`, `o + 2` of `v`.
#[inline]
pub fn vector3(v: &DVector<f64>, o: usize) -> Vector3<f64> {
    vector3_at(v.as_slice(), o)
}

/// Writes `x` into entries `o`, `o + 1`, `o + 2` of `v`.
#[inline]
pub fn set_vector3(v: &mut DVector<f64>, o: usize, x: &Vector3<f64>) {
    v.as_mut_slice()[o..o + 3].copy_from_slice(x.as_slice());
}

/// The 3×3 block of `w` whose top-left entry is (`row`, `col`).
#[inline]
pub fn block3(w: &DMatrix<f64>, row: usize, col: usize) -> Matrix3<f64> {
    let m = w.nrows();
    let data = w.as_slice();
    let column = |j: usize| {
        let c = &data[(col + j) * m + row..][..3];
        (c[0], c[1], c[2])
    };
    let (c0, c1, c2) = (column(0), column(1), column(2));
    Matrix3::new(c0.0, c1.0, c2.0, c0.1, c1.1, c2.1, c0.2, c1.2, c2.2)
}

/// Writes `b` into the 3×3 block of `w` whose top-left entry is (`row`, `col`).
#[inline]
pub fn set_block3(w: &mut DMatrix<f64>, row: usize, col: usize, b: &Matrix3<f64>) {
    let m = w.nrows();
    let data = w.as_mut_slice();
    for j in 0..3 {
        data[(col + j) * m + row..][..3].copy_from_slice(b.column(j).as_slice());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_and_vectors_are_the_views_entries() {
        let w = DMatrix::from_fn(7, 8, |i, j| (10 * i + j) as f64 + 0.5);
        for (row, col) in [(0, 0), (3, 5), (4, 2)] {
            assert_eq!(
                block3(&w, row, col),
                w.fixed_view::<3, 3>(row, col).into_owned()
            );
        }
        let mut m = w.clone();
        let b = Matrix3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0);
        set_block3(&mut m, 2, 4, &b);
        assert_eq!(m.fixed_view::<3, 3>(2, 4).into_owned(), b);
        m.fixed_view_mut::<3, 3>(2, 4)
            .copy_from(&w.fixed_view::<3, 3>(2, 4));
        assert_eq!(m, w, "only the block changed");

        let mut v = DVector::from_fn(7, |i, _| i as f64 * 1.5);
        assert_eq!(vector3(&v, 4), v.fixed_rows::<3>(4).into_owned());
        assert_eq!(
            vector6_at(v.as_slice(), 1),
            Vector6::from_column_slice(&v.as_slice()[1..7])
        );
        set_vector3(&mut v, 1, &Vector3::new(-1.0, -2.0, -3.0));
        assert_eq!(v.as_slice(), &[0.0, -1.0, -2.0, -3.0, 6.0, 7.5, 9.0]);
    }
}
