//! Vectors and matrices kept from one step to the next (a solver's or a step's scratch):
//! sized and filled in their own storage, which is allocated again only when it grows.

use nalgebra::{DMatrix, DVector};

/// Gives `buf` the length `n`, keeping its entries when it has that length already: for a
/// caller that writes every entry next.
pub fn fit(buf: &mut DVector<f64>, n: usize) {
    if buf.len() != n {
        zeros(buf, n);
    }
}

/// Sets `buf` to `n` zeros.
pub fn zeros(buf: &mut DVector<f64>, n: usize) {
    if buf.len() == n {
        buf.as_mut_slice().fill(0.0);
    } else {
        let data = resized(std::mem::replace(buf, DVector::zeros(0)).data.into(), n);
        *buf = DVector::from_vec(data);
    }
}

/// Sets `buf` to the `rows` × `cols` zero matrix.
pub fn zeros_matrix(buf: &mut DMatrix<f64>, rows: usize, cols: usize) {
    if buf.shape() == (rows, cols) {
        buf.as_mut_slice().fill(0.0);
    } else {
        let data = resized(matrix_storage(buf), rows * cols);
        *buf = DMatrix::from_vec(rows, cols, data);
    }
}

/// The storage of `buf`, emptied, for a caller to form a matrix in; `buf` is left 0 × 0.
pub fn matrix_storage(buf: &mut DMatrix<f64>) -> Vec<f64> {
    let mut data: Vec<f64> = std::mem::replace(buf, DMatrix::zeros(0, 0)).data.into();
    data.clear();
    data
}

/// `n` zeros in the storage of `data`.
fn resized(mut data: Vec<f64>, n: usize) -> Vec<f64> {
    data.clear();
    data.resize(n, 0.0);
    data
}

/// Keeps `v`, a list done with, in place of `kept` where it holds at least as much
/// storage: the next list built there reuses it instead of allocating.
pub fn keep_larger<T>(kept: &mut Vec<T>, v: Vec<T>) {
    if v.capacity() >= kept.capacity() {
        *kept = v;
    }
}

/// Copies `src` into `dst`.
pub fn copy_into(dst: &mut DVector<f64>, src: &DVector<f64>) {
    fit(dst, src.len());
    dst.copy_from(src);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each keeps the storage of a buffer that is large enough and resizes one that is not.
    #[test]
    fn buffers_are_sized_and_filled() {
        let mut buf = DVector::from_element(3, f64::NAN);
        let at = buf.as_ptr();
        zeros(&mut buf, 3);
        assert_eq!((buf.as_ptr(), buf.as_slice()), (at, &[0.0; 3][..]));
        zeros(&mut buf, 2);
        assert_eq!(buf.as_slice(), &[0.0; 2]);
        let src = DVector::from_vec(vec![1.0, -2.0, 3.5, 4.0]);
        copy_into(&mut buf, &src);
        assert_eq!(buf, src);
        let at = buf.as_ptr();
        copy_into(&mut buf, &(&src * 2.0));
        assert_eq!((buf.as_ptr(), buf[1]), (at, -4.0));
        fit(&mut buf, 4);
        assert_eq!((buf.as_ptr(), buf[3]), (at, 8.0));
        fit(&mut buf, 1);
        assert_eq!((buf.as_ptr(), buf.as_slice()), (at, &[0.0][..]));
        let mut m = DMatrix::from_element(3, 2, f64::NAN);
        let at = m.as_ptr();
        zeros_matrix(&mut m, 2, 2);
        assert_eq!((m.as_ptr(), &m), (at, &DMatrix::zeros(2, 2)));
        zeros_matrix(&mut m, 4, 3);
        assert_eq!(m, DMatrix::zeros(4, 3));
        let at = m.as_ptr();
        let data = matrix_storage(&mut m);
        assert_eq!((data.as_ptr(), data.len(), m.shape()), (at, 0, (0, 0)));
        assert!(data.capacity() >= 12);
    }
}
