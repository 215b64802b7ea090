//! Block LU factorisation of the global Newton method's Jacobian, whose nonzero 3×3 blocks
//! lie in W's symmetric block pattern. The blocks are eliminated in a fill-reducing order
//! (`BlockPattern::minimum_degree_into`) with each diagonal block inverted, so the factors'
//! pattern, the pattern filled in by the elimination, is known before the numbers: storage
//! holds only its blocks, and the arithmetic runs on fixed 3×3 matrices. Pivoting stays
//! within a diagonal block. The contact law keeps those blocks regular (an open contact's
//! is the identity, a sticking one's ρ times W's own block); where redundant contacts make
//! a block of the eliminated system singular, the Newton method's diagonal shift keeps it
//! invertible, and the equations being consistent, the step stays finite.

use super::ordering::BlockPattern;
use nalgebra::{Matrix3, Vector3};

/// No block stored at this place.
const NONE: usize = usize::MAX;

/// The factors L U of a block matrix in a given elimination order, in the storage of the
/// filled pattern. Places are elimination positions: block (k, l) is that of the k-th and
/// l-th contacts eliminated.
#[derive(Clone, Debug, Default)]
pub struct BlockLu {
    n: usize,
    /// The pattern in elimination positions, filled in.
    filled: Vec<bool>,
    /// Where block (k, l) is stored in `blocks`, or `NONE`.
    slot: Vec<usize>,
    blocks: Vec<Matrix3<f64>>,
    /// The slots of the blocks that elimination fills in.
    fill: Vec<usize>,
    /// Below the diagonal in column k, and right of it in row k: `(place, slot)`.
    lower: Vec<Vec<(usize, usize)>>,
    upper: Vec<Vec<(usize, usize)>>,
    /// The inverse of each eliminated diagonal block.
    pivots: Vec<Matrix3<f64>>,
}

impl BlockLu {
    /// Prepares the storage of the factors of a matrix whose blocks lie in `pattern`,
    /// eliminated in `order` (contact `order[k]` at step k); every block reads zero.
    pub fn set_pattern(&mut self, pattern: &BlockPattern, order: &[usize]) {
        let n = order.len();
        self.n = n;
        self.filled.clear();
        self.filled
            .extend((0..n * n).map(|kl| pattern.coupled(order[kl / n], order[kl % n])));
        self.fill.clear();
        let filled = &mut self.filled;
        for k in 0..n {
            // eliminating k couples every pair of its later neighbours
            for i in k + 1..n {
                if filled[i * n + k] {
                    for j in k + 1..n {
                        if filled[k * n + j] {
                            filled[i * n + j] = true;
                        }
                    }
                }
            }
        }
        self.slot.clear();
        self.slot.resize(n * n, NONE);
        let mut count = 0;
        for (kl, &f) in self.filled.iter().enumerate() {
            if f {
                self.slot[kl] = count;
                if !pattern.coupled(order[kl / n], order[kl % n]) {
                    self.fill.push(count);
                }
                count += 1;
            }
        }
        self.blocks.clear();
        self.blocks.resize(count, Matrix3::zeros());
        for list in [&mut self.lower, &mut self.upper] {
            list.iter_mut().for_each(Vec::clear);
            list.resize_with(n, Vec::new);
        }
        for k in 0..n {
            for m in k + 1..n {
                if self.filled[m * n + k] {
                    self.lower[k].push((m, self.slot[m * n + k]));
                }
                if self.filled[k * n + m] {
                    self.upper[k].push((m, self.slot[k * n + m]));
                }
            }
        }
        self.pivots.clear();
        self.pivots.resize(n, Matrix3::zeros());
    }

    /// Sets the blocks that elimination fills in to zero, for the next matrix of the same
    /// pattern, whose every block of `pattern` the caller writes.
    pub fn clear_fill(&mut self) {
        for &s in &self.fill {
            self.blocks[s].fill(0.0);
        }
    }

    /// Block (k, l), which must lie in the pattern.
    pub fn block_mut(&mut self, k: usize, l: usize) -> &mut Matrix3<f64> {
        let s = self.slot[k * self.n + l];
        assert!(s != NONE, "block ({k}, {l}) outside the pattern");
        &mut self.blocks[s]
    }

    /// The largest absolute entry of the matrix held.
    pub fn amax(&self) -> f64 {
        self.blocks.iter().fold(0.0, |m, b| m.max(b.amax()))
    }

    /// Overwrites the matrix held, with `shift` added to its diagonal, by its factors; false
    /// if a diagonal block met in the elimination is singular.
    pub fn factorise(&mut self, shift: f64) -> bool {
        let n = self.n;
        for k in 0..n {
            let d = self.slot[k * n + k];
            self.blocks[d] += Matrix3::from_diagonal_element(shift);
        }
        for k in 0..n {
            let Some(inverse) = self.blocks[self.slot[k * n + k]].try_inverse() else {
                return false;
            };
            self.pivots[k] = inverse;
            for &(_, s) in &self.lower[k] {
                self.blocks[s] *= inverse;
            }
            for &(i, li) in &self.lower[k] {
                let l = self.blocks[li];
                for &(j, uj) in &self.upper[k] {
                    let update = l * self.blocks[uj];
                    let s = self.slot[i * n + j];
                    self.blocks[s] -= update;
                }
            }
        }
        true
    }

    /// Overwrites `b`, in elimination positions (3 entries a block), with the solution.
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let n = self.n;
        assert_eq!(b.len(), 3 * n, "block LU solve: dimension mismatch");
        let at = |b: &[f64], k: usize| Vector3::new(b[3 * k], b[3 * k + 1], b[3 * k + 2]);
        let put = |b: &mut [f64], k: usize, x: Vector3<f64>| {
            b[3 * k..3 * k + 3].copy_from_slice(x.as_slice())
        };
        for k in 0..n {
            let y = at(b, k);
            for &(i, s) in &self.lower[k] {
                let yi = at(b, i) - self.blocks[s] * y;
                put(b, i, yi);
            }
        }
        for k in (0..n).rev() {
            let mut y = at(b, k);
            for &(j, s) in &self.upper[k] {
                y -= self.blocks[s] * at(b, j);
            }
            put(b, k, self.pivots[k] * y);
        }
    }

    /// The number of blocks stored: the filled pattern's.
    #[cfg(test)]
    pub fn stored_blocks(&self) -> usize {
        self.blocks.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::ordering::MinimumDegree;
    use nalgebra::{DMatrix, DVector};

    /// `lu`'s pseudo-random block matrix, its pattern symmetrised and its diagonal made
    /// strong enough for elimination without pivoting.
    fn blocky(blocks: usize, seed: u64, coupled: impl Fn(usize, usize) -> bool) -> DMatrix<f64> {
        let symmetric = |a, b| coupled(a, b) || coupled(b, a);
        let mut m = crate::solver::lu::tests::blocky(blocks, seed, symmetric);
        for i in 0..3 * blocks {
            m[(i, i)] += 3.0;
        }
        m
    }

    /// Factors of `a` in `order` (the matrix copied into the filled pattern's storage).
    fn factors(a: &DMatrix<f64>, order: &[usize], lu: &mut BlockLu) -> bool {
        let pattern = BlockPattern::of(a);
        lu.set_pattern(&pattern, order);
        for (k, &i) in order.iter().enumerate() {
            for (l, &j) in order.iter().enumerate() {
                if pattern.coupled(i, j) {
                    lu.block_mut(k, l)
                        .copy_from(&a.fixed_view::<3, 3>(3 * i, 3 * j));
                }
            }
        }
        lu.factorise(0.0)
    }

    /// The solution of a x = b through the factors, in the original numbering.
    fn solve(lu: &BlockLu, order: &[usize], b: &DVector<f64>) -> DVector<f64> {
        let mut x: Vec<f64> = order
            .iter()
            .flat_map(|&i| [b[3 * i], b[3 * i + 1], b[3 * i + 2]])
            .collect();
        lu.solve_in_place(&mut x);
        let mut out = DVector::zeros(b.len());
        for (k, &i) in order.iter().enumerate() {
            out.fixed_rows_mut::<3>(3 * i)
                .copy_from_slice(&x[3 * k..3 * k + 3]);
        }
        out
    }

    /// The factors solve block-sparse systems of several patterns, in the index order and
    /// in the minimum-degree order, to rounding; the residual test would see a wrong sign
    /// or a block dropped from the fill.
    #[test]
    fn solves_block_sparse_systems() {
        for (name, coupled) in crate::solver::lu::tests::PATTERNS {
            for seed in 1..12 {
                let a = blocky(13, seed, coupled);
                let b = DVector::from_fn(a.nrows(), |i, _| (i as f64 * 0.37).sin());
                let exact = a.clone().lu().solve(&b).expect("regular");
                let mut md = Vec::new();
                BlockPattern::of(&a).minimum_degree_into(&mut md, &mut MinimumDegree::default());
                let natural: Vec<usize> = (0..13).collect();
                for order in [natural, md] {
                    let mut lu = BlockLu::default();
                    assert!(factors(&a, &order, &mut lu), "{name}");
                    let x = solve(&lu, &order, &b);
                    assert!((&a * &x - &b).amax() < 1e-12, "{name}, seed {seed}");
                    assert!((&x - &exact).amax() < 1e-10 * exact.amax(), "{name}");
                }
            }
        }
    }

    /// The factors store the filled pattern only: an arrow with its hub eliminated last
    /// has no fill, with its hub first it fills in completely.
    #[test]
    fn stores_the_filled_pattern() {
        let n = 6;
        let a = blocky(n, 3, |a, b| a == 0 || b == 0);
        let arrow_blocks = n + 2 * (n - 1);
        let mut lu = BlockLu::default();
        assert!(factors(&a, &[1, 2, 3, 4, 5, 0], &mut lu));
        assert_eq!(lu.stored_blocks(), arrow_blocks);
        assert!(factors(&a, &[0, 1, 2, 3, 4, 5], &mut lu));
        assert_eq!(lu.stored_blocks(), n * n);
    }

    /// Factorising in storage another matrix left gives the same bits as in fresh storage,
    /// whether the pattern changed or not.
    #[test]
    fn reused_storage_gives_the_same_bits() {
        let bits = |x: &DVector<f64>| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let a = blocky(7, 5, |a: usize, b: usize| a.abs_diff(b) <= 2);
        let b = DVector::from_fn(21, |i, _| (i as f64 * 0.61).cos());
        let order = [3, 0, 6, 1, 5, 2, 4];
        let mut fresh = BlockLu::default();
        assert!(factors(&a, &order, &mut fresh));
        let expected = bits(&solve(&fresh, &order, &b));
        let mut used = BlockLu::default();
        assert!(factors(
            &blocky(9, 2, |_, _| true),
            &[0, 1, 2, 3, 4, 5, 6, 7, 8],
            &mut used
        ));
        assert!(factors(&a, &order, &mut used));
        assert_eq!(bits(&solve(&used, &order, &b)), expected);
        // the same pattern again, other numbers first
        assert!(factors(
            &blocky(7, 9, |a: usize, b: usize| a.abs_diff(b) <= 2),
            &order,
            &mut used
        ));
        assert!(factors(&a, &order, &mut used));
        assert_eq!(bits(&solve(&used, &order, &b)), expected);
    }

    /// A singular diagonal block is reported; the shift makes it regular.
    #[test]
    fn a_singular_pivot_is_reported() {
        let mut a = blocky(3, 7, |_, _| false);
        a.fixed_view_mut::<3, 3>(3, 3).fill(0.0);
        let mut lu = BlockLu::default();
        assert!(!factors(&a, &[0, 1, 2], &mut lu));
        let pattern = BlockPattern::of(&a);
        lu.set_pattern(&pattern, &[0, 1, 2]);
        assert!(lu.factorise(1.0));
    }
}
