//! Experimental designs: sample i's point in the unit cube (0, 1)^d, a pure function of
//! (seed, design, N, i). Nothing sequential, so that any thread, shard or resumed run
//! computes the same point for the same i.

use super::sobol::ScrambledSobol;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesignKind {
    /// Plain Monte Carlo: ChaCha8 with the stream set to the sample index.
    Random,
    /// Latin hypercube: one point per 1/N stratum in every coordinate.
    Lhs,
    /// Owen-scrambled Sobol' points.
    Sobol,
    /// Saltelli's scheme for Sobol' indices: base matrices A and B from a scrambled Sobol'
    /// sequence in 2d dimensions and, for each input j, A with column j from B; N(d + 2)
    /// runs, in blocks [A, B, AB_1, …, AB_d] per base row.
    Saltelli,
}

impl DesignKind {
    pub fn parse(name: &str) -> Option<DesignKind> {
        Some(match name {
            "random" => DesignKind::Random,
            "lhs" => DesignKind::Lhs,
            "sobol" => DesignKind::Sobol,
            "saltelli" => DesignKind::Saltelli,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            DesignKind::Random => "random",
            DesignKind::Lhs => "lhs",
            DesignKind::Sobol => "sobol",
            DesignKind::Saltelli => "saltelli",
        }
    }
}

/// SplitMix64: derives independent 64-bit keys from the seed.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform in (0, 1) from 53 random bits, never 0 or 1.
fn open_unit(bits: u64) -> f64 {
    ((bits >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// A pseudo-random permutation of 0..n, evaluated at one index: a 4-round Feistel network
/// on the smallest power-of-two domain, cycle-walked back into 0..n. O(1) memory.
#[derive(Clone, Debug)]
struct Permutation {
    n: u64,
    half_bits: u32,
    keys: [u64; 4],
}

impl Permutation {
    fn new(n: u64, key: u64) -> Self {
        let bits = 64 - n.saturating_sub(1).leading_zeros();
        let half_bits = bits.div_ceil(2).max(1);
        let keys = [1, 2, 3, 4].map(|r| splitmix64(key ^ splitmix64(r)));
        Permutation { n, half_bits, keys }
    }

    fn feistel(&self, x: u64) -> u64 {
        let mask = (1u64 << self.half_bits) - 1;
        let (mut l, mut r) = (x >> self.half_bits, x & mask);
        for k in self.keys {
            let f = splitmix64(r ^ k) & mask;
            (l, r) = (r, l ^ f);
        }
        (l << self.half_bits) | r
    }

    fn apply(&self, i: u64) -> u64 {
        let mut x = self.feistel(i);
        while x >= self.n {
            x = self.feistel(x);
        }
        x
    }
}

/// Maps a sample index to its point in the unit cube.
#[derive(Clone, Debug)]
pub struct Design {
    pub kind: DesignKind,
    /// Number of inputs d.
    pub dimension: usize,
    /// Base sample count N (runs: N, or N(d + 2) for Saltelli).
    pub base: u64,
    seed: u64,
    sobol: Option<ScrambledSobol>,
    permutations: Vec<Permutation>,
}

impl Design {
    pub fn new(kind: DesignKind, dimension: usize, base: u64, seed: u64) -> Result<Self, String> {
        let sobol_dim = match kind {
            DesignKind::Sobol => dimension,
            DesignKind::Saltelli => 2 * dimension,
            _ => 0,
        };
        let sobol = (sobol_dim > 0)
            .then(|| {
                let seeds = (0..sobol_dim)
                    .map(|j| splitmix64(seed ^ splitmix64(0x50b0_1000 + j as u64)) as u32)
                    .collect();
                ScrambledSobol::new(sobol_dim, Some(seeds))
            })
            .transpose()
            .map_err(|e| {
                format!(
                    "{e}{}",
                    if kind == DesignKind::Saltelli {
                        " (Saltelli uses 2d)"
                    } else {
                        ""
                    }
                )
            })?;
        let permutations = if kind == DesignKind::Lhs {
            (0..dimension)
                .map(|j| {
                    Permutation::new(base, splitmix64(seed ^ splitmix64(0x1a5_0000 + j as u64)))
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(Design {
            kind,
            dimension,
            base,
            seed,
            sobol,
            permutations,
        })
    }

    /// Total runs: N, or N(d + 2) for Saltelli.
    pub fn runs(&self) -> u64 {
        match self.kind {
            DesignKind::Saltelli => self.base * (self.dimension as u64 + 2),
            _ => self.base,
        }
    }

    fn stream(&self, i: u64) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(i);
        rng
    }

    /// Sample i's point in (0, 1)^d.
    pub fn point(&self, i: u64) -> Vec<f64> {
        let d = self.dimension;
        match self.kind {
            DesignKind::Random => {
                let mut rng = self.stream(i);
                (0..d).map(|_| open_unit(rng.next_u64())).collect()
            }
            DesignKind::Lhs => {
                let mut rng = self.stream(i);
                let n = self.base as f64;
                self.permutations
                    .iter()
                    .map(|p| (p.apply(i) as f64 + open_unit(rng.next_u64())) / n)
                    .collect()
            }
            DesignKind::Sobol => self.sobol.as_ref().expect("built").point(i),
            DesignKind::Saltelli => {
                let (row, k) = self.saltelli_block(i);
                let p = self.sobol.as_ref().expect("built").point(row);
                let (a, b) = p.split_at(d);
                match k {
                    0 => a.to_vec(),
                    1 => b.to_vec(),
                    j => {
                        let mut ab = a.to_vec();
                        ab[j - 2] = b[j - 2];
                        ab
                    }
                }
            }
        }
    }

    /// For Saltelli: (base row, block) of run i, block 0 = A, 1 = B, 2 + j = AB_j.
    pub fn saltelli_block(&self, i: u64) -> (u64, usize) {
        let w = self.dimension as u64 + 2;
        (i / w, (i % w) as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutation_is_a_bijection_for_awkward_sizes() {
        for n in [1u64, 2, 3, 7, 100, 1000, 4097] {
            let p = Permutation::new(n, 42);
            let mut seen = vec![false; n as usize];
            for i in 0..n {
                let j = p.apply(i) as usize;
                assert!(!seen[j]);
                seen[j] = true;
            }
        }
    }

    #[test]
    fn lhs_puts_one_point_in_every_stratum() {
        let n = 500;
        let d = Design::new(DesignKind::Lhs, 3, n, 7).unwrap();
        for dim in 0..3 {
            let mut seen = vec![false; n as usize];
            for i in 0..n {
                let u = d.point(i)[dim];
                let c = (u * n as f64) as usize;
                assert!(!seen[c]);
                seen[c] = true;
            }
        }
    }

    #[test]
    fn points_depend_only_on_seed_and_index() {
        for kind in [
            DesignKind::Random,
            DesignKind::Lhs,
            DesignKind::Sobol,
            DesignKind::Saltelli,
        ] {
            let a = Design::new(kind, 4, 64, 11).unwrap();
            let b = Design::new(kind, 4, 64, 11).unwrap();
            let c = Design::new(kind, 4, 64, 12).unwrap();
            assert_eq!(a.point(37), b.point(37));
            assert_ne!(a.point(37), c.point(37));
            assert!(a.point(5).iter().all(|&u| u > 0.0 && u < 1.0));
        }
        let s = Design::new(DesignKind::Saltelli, 3, 10, 1).unwrap();
        assert_eq!(s.runs(), 50);
        let (a, b, ab2) = (s.point(10), s.point(11), s.point(14));
        assert_eq!(ab2, vec![a[0], a[1], b[2]]);
    }
}
