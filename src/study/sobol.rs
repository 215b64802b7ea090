//! Owen-scrambled Sobol' points, computed directly from the point index (no sequential
//! state), so that sample i's point depends only on (seed, i).
//!
//! Direction numbers: Joe & Kuo, "Constructing Sobol sequences with better two-dimensional
//! projections", SIAM J. Sci. Comput. 30 (2008), file new-joe-kuo-6.21201, dimensions 2–32
//! (dimension 1 is the van der Corput sequence). Scrambling: Burley, "Practical hash-based
//! Owen scrambling", JCGT 9(4) 2020: a nested uniform scramble from a Laine–Karras hash of
//! the bit-reversed coordinate.

/// (s, a, m_1..m_s) of dimensions 2..=32.
const JOE_KUO: [(u32, u32, &[u32]); 31] = [
    (1, 0, &[1]),
    (2, 1, &[1, 3]),
    (3, 1, &[1, 3, 1]),
    (3, 2, &[1, 1, 1]),
    (4, 1, &[1, 1, 3, 3]),
    (4, 4, &[1, 3, 5, 13]),
    (5, 2, &[1, 1, 5, 5, 17]),
    (5, 4, &[1, 1, 5, 5, 5]),
    (5, 7, &[1, 1, 7, 11, 19]),
    (5, 11, &[1, 1, 5, 1, 1]),
    (5, 13, &[1, 1, 1, 3, 11]),
    (5, 14, &[1, 3, 5, 5, 31]),
    (6, 1, &[1, 3, 3, 9, 7, 49]),
    (6, 13, &[1, 1, 1, 15, 21, 21]),
    (6, 16, &[1, 3, 1, 13, 27, 49]),
    (6, 19, &[1, 1, 1, 15, 7, 5]),
    (6, 22, &[1, 3, 1, 15, 13, 25]),
    (6, 25, &[1, 1, 5, 5, 19, 61]),
    (7, 1, &[1, 3, 7, 11, 23, 15, 103]),
    (7, 4, &[1, 3, 7, 13, 13, 15, 69]),
    (7, 7, &[1, 1, 3, 13, 7, 35, 63]),
    (7, 8, &[1, 3, 5, 9, 1, 25, 53]),
    (7, 14, &[1, 3, 1, 13, 9, 35, 107]),
    (7, 19, &[1, 3, 1, 5, 27, 61, 31]),
    (7, 21, &[1, 1, 5, 11, 19, 41, 61]),
    (7, 28, &[1, 3, 5, 3, 3, 13, 69]),
    (7, 31, &[1, 1, 7, 13, 1, 19, 1]),
    (7, 32, &[1, 3, 7, 5, 13, 19, 59]),
    (7, 37, &[1, 1, 3, 9, 25, 29, 41]),
    (7, 41, &[1, 3, 5, 13, 23, 1, 55]),
    (7, 42, &[1, 3, 7, 3, 13, 59, 17]),
];

/// The largest dimension available.
pub const MAX_DIMENSION: usize = JOE_KUO.len() + 1;

/// Direction numbers v_1..v_32 (left-aligned in 32 bits) of dimension `dim` (from 0).
fn directions(dim: usize) -> [u32; 32] {
    let mut v = [0u32; 32];
    if dim == 0 {
        for (k, x) in v.iter_mut().enumerate() {
            *x = 1 << (31 - k);
        }
        return v;
    }
    let (s, a, m) = JOE_KUO[dim - 1];
    let s = s as usize;
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
