//! The block pattern of a contact problem and a fill-reducing order of its contacts. W's
//! 3×3 blocks are nonzero only between contacts that share a body (or bodies a force
//! element couples), and so are those of the global Newton method's Jacobian: products
//! over the pattern skip the zero blocks, and factorising in a good order touches far
//! fewer entries. On the circuit breaker a third of the blocks are nonzero, and in the
//! contacts' index order the LU fills in almost completely.

use crate::math::blocks::{block3, set_vector3, vector3};
use crate::math::buffer;
use nalgebra::{DMatrix, DVector};

/// Whether the 3×3 block (a, b) of W has a nonzero entry (x != 0.0: NaN counts, −0.0
/// does not), read from its three columns, contiguous in W's storage. The entries' bits
/// are or-ed without their signs, branch-free: most blocks of a mechanism's W are zero.
pub fn block_is_nonzero(w: &DMatrix<f64>, a: usize, b: usize) -> bool {
    let (m, data) = (w.nrows(), w.as_slice());
    let bits = (0..3).fold(0u64, |bits, c| {
        let column = &data[(3 * b + c) * m + 3 * a..][..3];
        bits | column[0].to_bits() | column[1].to_bits() | column[2].to_bits()
    });
    bits << 1 != 0
}

/// Which 3×3 blocks of a contact problem's W are nonzero, symmetrised (a and b coupled when
/// W_ab or W_ba is nonzero); the diagonal blocks always count.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockPattern {
    n: usize,
    coupled: Vec<bool>,
    /// The blocks of row a, ascending, are `columns[start[a]..start[a + 1]]`.
    start: Vec<usize>,
    columns: Vec<usize>,
}

impl BlockPattern {
    /// The pattern of W (3n × 3n), read column by column (contiguous in its storage).
    pub fn of(w: &DMatrix<f64>) -> Self {
        let n = w.nrows() / 3;
        let pairs = (0..n).flat_map(|b| (0..n).map(move |a| (a, b)));
        Self::of_pairs(
            n,
            pairs.filter(|&(a, b)| a != b && block_is_nonzero(w, a, b)),
        )
    }

    /// The pattern of n contacts whose off-diagonal blocks (a, b) are `pairs`, for a caller
    /// that has already found them (NSGS, which keeps W's nonzero blocks).
    pub fn of_pairs(n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut pattern = Self::default();
        pattern.set_pairs(n, pairs);
        pattern
    }

    /// `of_pairs` in this pattern's storage.
    pub fn set_pairs(&mut self, n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) {
        self.n = n;
        self.coupled.clear();
        self.coupled.resize(n * n, false);
        for a in 0..n {
            self.coupled[a * n + a] = true;
        }
        for (a, b) in pairs {
            self.coupled[a * n + b] = true;
            self.coupled[b * n + a] = true;
        }
        self.list_rows();
    }

    /// Each row's blocks, listed from `coupled`.
    fn list_rows(&mut self) {
        let BlockPattern {
            n,
            coupled,
            start,
            columns,
        } = self;
        start.clear();
        columns.clear();
        for a in 0..*n {
            start.push(columns.len());
            columns.extend((0..*n).filter(|&b| coupled[a * *n + b]));
        }
        start.push(columns.len());
    }

    /// Whether blocks (a, b) and (b, a) may be nonzero.
    pub fn coupled(&self, a: usize, b: usize) -> bool {
        self.coupled[a * self.n + b]
    }

    /// The blocks b of row a that may be nonzero, ascending.
    pub fn row(&self, a: usize) -> &[usize] {
        &self.columns[self.start[a]..self.start[a + 1]]
    }

    /// u = W r + q over the blocks of the pattern only, into `u` (in its storage).
    pub fn velocity_into(
        &self,
        w: &DMatrix<f64>,
        r: &DVector<f64>,
        q: &DVector<f64>,
        u: &mut DVector<f64>,
    ) {
        buffer::copy_into(u, q);
        for a in 0..self.n {
            let mut ua = vector3(u, 3 * a);
            for &b in self.row(a) {
                ua += block3(w, 3 * a, 3 * b) * vector3(r, 3 * b);
            }
            set_vector3(u, 3 * a, &ua);
        }
    }

    /// Into `order`, a fill-reducing elimination order of the contacts, by minimum degree:
    /// at each step the contact with the fewest neighbours left (the lowest index on a tie)
    /// goes next, and its neighbours become coupled, as its elimination couples them.
    /// `scratch` is the elimination's storage, reused from one call to the next.
    pub fn minimum_degree_into(&self, order: &mut Vec<usize>, scratch: &mut MinimumDegree) {
        let n = self.n;
        let MinimumDegree {
            coupled,
            degree,
            left,
            neighbours,
        } = scratch;
        coupled.clone_from(&self.coupled);
        degree.clear();
        degree.extend((0..n).map(|a| self.row(a).len() - 1));
        left.clear();
        left.resize(n, true);
        order.clear();
        for _ in 0..n {
            let next = (0..n)
                .filter(|&a| left[a])
                .min_by_key(|&a| (degree[a], a))
                .expect("a contact left");
            order.push(next);
            left[next] = false;
            neighbours.clear();
            neighbours.extend((0..n).filter(|&b| left[b] && coupled[next * n + b]));
            for &b in neighbours.iter() {
                degree[b] -= 1;
            }
            for (k, &a) in neighbours.iter().enumerate() {
                for &b in &neighbours[k + 1..] {
                    if !coupled[a * n + b] {
                        coupled[a * n + b] = true;
                        coupled[b * n + a] = true;
                        degree[a] += 1;
                        degree[b] += 1;
                    }
                }
            }
        }
    }
}

/// The minimum-degree elimination's storage; every entry is written before it is read.
#[derive(Default)]
pub struct MinimumDegree {
    /// The pattern as elimination fills it in, each contact's degree, whether it is left,
    /// and the neighbours of the one eliminated.
    coupled: Vec<bool>,
    degree: Vec<usize>,
    left: Vec<bool>,
    neighbours: Vec<usize>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::Lu;
    use nalgebra::DVector;

    /// The minimum-degree order of `pattern`, formed in a list that held another one.
    fn order_of(pattern: &BlockPattern) -> Vec<usize> {
        let mut order = vec![7; 9];
        pattern.minimum_degree_into(&mut order, &mut MinimumDegree::default());
        order
    }

    /// W of an arrow: contact 0 coupled to every other, the others to nobody else.
    fn arrow(n: usize) -> DMatrix<f64> {
        DMatrix::from_fn(3 * n, 3 * n, |i, j| {
            let (a, b) = (i / 3, j / 3);
            if i == j {
                10.0 + i as f64
            } else if a == b || a == 0 || b == 0 {
                1.0 / (1.0 + (i + 2 * j) as f64)
            } else {
                0.0
            }
        })
    }

    /// In index order, eliminating the arrow's hub first would couple every contact;
    /// minimum degree keeps it until one neighbour is left (a tie with that neighbour,
    /// which the lower index wins).
    #[test]
    fn an_arrow_is_eliminated_hub_last() {
        assert_eq!(
            order_of(&BlockPattern::of(&arrow(6))),
            vec![1, 2, 3, 4, 0, 5]
        );
    }

    /// A chain (each contact coupled to its two neighbours) keeps its natural order: the
    /// two ends have degree 1, and eliminating an end creates no fill.
    #[test]
    fn a_chain_is_eliminated_from_one_end() {
        let n = 5;
        let w = DMatrix::from_fn(3 * n, 3 * n, |i, j| {
            if (i / 3).abs_diff(j / 3) <= 1 {
                1.0 + (i * j) as f64
            } else {
                0.0
            }
        });
        assert_eq!(order_of(&BlockPattern::of(&w)), vec![0, 1, 2, 3, 4]);
    }

    /// The permuted system has the same solution, and the order makes the LU's factors no
    /// denser than the matrix (in index order they fill in completely).
    #[test]
    fn permuted_arrow_solves_the_same_without_fill() {
        let n = 6;
        let w = arrow(n);
        let b = DVector::from_fn(3 * n, |i, _| (i as f64 * 0.7).sin());
        let x = Lu::new(w.clone()).solve(&b).unwrap();
        let order = order_of(&BlockPattern::of(&w));
        let index = |k: usize| 3 * order[k / 3] + k % 3;
        let wp = DMatrix::from_fn(3 * n, 3 * n, |i, j| w[(index(i), index(j))]);
        let bp = DVector::from_fn(3 * n, |i, _| b[index(i)]);
        let xp = Lu::new(wp.clone()).solve(&bp).unwrap();
        for k in 0..3 * n {
            assert!((xp[k] - x[index(k)]).abs() < 1e-12);
        }
        // the pattern of the arrow's off-diagonal pairs (hub–spoke, either way round) is
        // the pattern read from W (also when formed in the storage of a larger one), and
        // products over it are W r + q
        let spokes = (1..n).flat_map(|a| [(0, a), (a, 0)]);
        assert_eq!(
            BlockPattern::of_pairs(n, spokes.clone()),
            BlockPattern::of(&w)
        );
        let mut refilled = BlockPattern::of(&arrow(n + 2));
        refilled.set_pairs(n, spokes);
        assert_eq!(refilled, BlockPattern::of(&w));
        let q = DVector::from_fn(3 * n, |i, _| (i as f64 * 1.3).cos());
        let mut u = DVector::zeros(0);
        BlockPattern::of(&w).velocity_into(&w, &b, &q, &mut u);
        assert!((u - (&w * &b + &q)).amax() < 1e-14);
        let filled = |m: DMatrix<f64>| Lu::new(m).nonzeros();
        let pattern = w.iter().filter(|&&x| x != 0.0).count();
        assert_eq!(filled(wp), pattern);
        assert_eq!(filled(w), 9 * n * n);
    }
}
