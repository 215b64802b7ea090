//! Owen-scrambled Sobol' points, computed directly from the point index (no sequential
//! state), so that sample i's point depends only on (seed, i).
//!
//! Direction numbers: Joe & Kuo, "Constructing Sobol sequences with better two-dimensional
//! projections", SIAM J. Sci. Comput. 30 (2008), file new-joe-kuo-6.21201, dimensions 2–256
//! (`new-joe-kuo-6.256.txt`; dimension 1 is the van der Corput sequence). Scrambling:
//! Burley, "Practical hash-based Owen scrambling", JCGT 9(4) 2020: a nested uniform
//! scramble from a Laine–Karras hash of the bit-reversed coordinate.

use std::sync::OnceLock;

/// The published table: one row per dimension from 2 on.
const JOE_KUO_TABLE: &str = include_str!("new-joe-kuo-6.256.txt");

/// (s, a, m_1..m_s) of each dimension from 2 on, read once from the table.
fn joe_kuo() -> &'static [(u32, u32, Vec<u32>)] {
    static ROWS: OnceLock<Vec<(u32, u32, Vec<u32>)>> = OnceLock::new();
    ROWS.get_or_init(|| {
        JOE_KUO_TABLE
            .lines()
            .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
            .map(|l| {
                let n: Vec<u32> = l
                    .split_whitespace()
                    .map(|x| x.parse().expect("the bundled table holds integers"))
                    .collect();
                (n[1], n[2], n[3..].to_vec())
            })
            .collect()
    })
}

/// The largest dimension available.
pub const MAX_DIMENSION: usize = 256;

/// Direction numbers v_1..v_32 (left-aligned in 32 bits) of dimension `dim` (from 0).
fn directions(dim: usize) -> [u32; 32] {
    let mut v = [0u32; 32];
    if dim == 0 {
        for (k, x) in v.iter_mut().enumerate() {
            *x = 1 << (31 - k);
        }
        return v;
    }
    let (s, a, m) = &joe_kuo()[dim - 1];
    let (s, a) = (*s as usize, *a);
    for k in 0..s.min(32) {
        v[k] = m[k] << (31 - k);
    }
    for k in s..32 {
        let mut x = v[k - s] ^ (v[k - s] >> s);
        for j in 1..s {
            if (a >> (s - 1 - j)) & 1 == 1 {
                x ^= v[k - j];
            }
        }
        v[k] = x;
    }
    v
}

/// Sobol' points of a fixed dimension with one Owen scramble per coordinate.
#[derive(Clone, Debug)]
pub struct ScrambledSobol {
    directions: Vec<[u32; 32]>,
    seeds: Vec<u32>,
}

fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

impl ScrambledSobol {
    /// `seeds` gives one scramble per coordinate; `None` leaves the points unscrambled.
    pub fn new(dimension: usize, seeds: Option<Vec<u32>>) -> Result<Self, String> {
        if dimension > MAX_DIMENSION {
            return Err(format!(
                "Sobol' points are available up to {MAX_DIMENSION} dimensions, {dimension} were asked for"
            ));
        }
        Ok(ScrambledSobol {
            directions: (0..dimension).map(directions).collect(),
            seeds: seeds.unwrap_or_default(),
        })
    }

    /// Coordinate `dim` of point `index` as 32 bits, Gray-code order (the first 2^m points
    /// are the classical net).
    fn bits(&self, index: u64, dim: usize) -> u32 {
        let gray = index ^ (index >> 1);
        let v = &self.directions[dim];
        let mut x = 0u32;
        for (k, d) in v.iter().enumerate() {
            if (gray >> k) & 1 == 1 {
                x ^= d;
            }
        }
        match self.seeds.get(dim) {
            Some(&s) => nested_uniform_scramble(x, s),
            None => x,
        }
    }

    /// The point in (0, 1)^d: the centre of its 2^-32 cell, never 0 or 1.
    pub fn point(&self, index: u64) -> Vec<f64> {
        (0..self.directions.len())
            .map(|d| (f64::from(self.bits(index, d)) + 0.5) / 4_294_967_296.0)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table holds every dimension up to `MAX_DIMENSION`, each row with as many initial
    /// numbers as its degree, each m_k odd and below 2^k (what makes the directions valid);
    /// its first and last rows are those of the published file.
    #[test]
    fn the_direction_table_is_whole() {
        let rows = joe_kuo();
        assert_eq!(rows.len() + 1, MAX_DIMENSION);
        for (d, (s, a, m)) in rows.iter().enumerate() {
            assert_eq!(m.len(), *s as usize, "dimension {}", d + 2);
            assert!(*a < 1 << (s - 1).max(1), "dimension {}", d + 2);
            for (k, &mk) in m.iter().enumerate() {
                assert!(mk % 2 == 1 && mk < 1 << (k + 1), "dimension {}", d + 2);
            }
        }
        assert_eq!(rows[0], (1, 0, vec![1]));
        assert_eq!(rows[30], (7, 42, vec![1, 3, 7, 3, 13, 59, 17]));
        assert_eq!(
            rows[254],
            (11, 560, vec![1, 1, 1, 5, 19, 3, 53, 133, 97, 863, 983])
        );
    }

    #[test]
    fn unscrambled_points_match_the_published_sequence() {
        let s = ScrambledSobol::new(3, None).unwrap();
        let cell =
            |i: u64| -> Vec<f64> { s.point(i).iter().map(|x| (x * 8.0).floor() / 8.0).collect() };
        // Gray-code order: 0, (1/2,1/2,1/2), (3/4,1/4,1/4)... (Joe & Kuo's first points)
        assert_eq!(cell(0), [0.0, 0.0, 0.0]);
        assert_eq!(cell(1), [0.5, 0.5, 0.5]);
        assert_eq!(cell(2), [0.75, 0.25, 0.25]);
        assert_eq!(cell(3), [0.25, 0.75, 0.75]);
    }

    /// Net properties, scrambled or not: in every coordinate each of the 2^m intervals of
    /// width 2^-m holds one of the first 2^m points, and the first two coordinates form a
    /// (0, m, 2)-net (each elementary box 2^-k × 2^-(m-k) holds one point).
    #[test]
    fn first_2m_points_are_stratified() {
        let m = 8;
        let n = 1u64 << m;
        for seeds in [None, Some(vec![7, 99, 12345, 4242, 5, 6, 8, 1, 2, 3])] {
            let s = ScrambledSobol::new(10, seeds).unwrap();
            let pts: Vec<Vec<f64>> = (0..n).map(|i| s.point(i)).collect();
            for d in 0..10 {
                let mut seen = vec![false; n as usize];
                for p in &pts {
                    let c = (p[d] * n as f64) as usize;
                    assert!(!seen[c], "dim {d}: two points in one interval");
                    seen[c] = true;
                }
            }
            for k in 0..=m {
                let (nx, ny) = (1u64 << k, 1u64 << (m - k));
                let mut seen = vec![false; n as usize];
                for p in &pts {
                    let c = (p[0] * nx as f64) as u64 * ny + (p[1] * ny as f64) as u64;
                    assert!(!seen[c as usize], "k {k}: two points in one box");
                    seen[c as usize] = true;
                }
            }
        }
    }
}
