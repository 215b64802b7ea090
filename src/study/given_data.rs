//! Sensitivity from the samples a study already has, whatever its design (plain Monte
//! Carlo, LHS or Sobol'): no extra runs.
//!
//! - First-order Sobol' indices by the rank estimator of Gamboa, Klein and Lagnoux (2022),
//!   after Chatterjee's rank correlation (2021): sort the samples by xⱼ; neighbours in that
//!   order share (almost) the same xⱼ, so the covariance of Y with its neighbour's Y is
//!   Var E[Y | xⱼ]. The 95 % interval comes from the spread of the estimate over 20
//!   disjoint groups of samples (its variance falls as 1/n).
//! - HSIC dependence (Gretton et al. 2005; Da Veiga 2015) with Gaussian kernels, normalised
//!   to R²_HSIC in [0, 1], and a permutation p-value: it ranks inputs for outputs that are
//!   neither smooth nor monotone.

use super::sensitivity::Estimate;
use super::statistics as st;

/// Groups for the interval of the rank estimator.
const GROUPS: usize = 20;
/// Student's t quantile (0.975, 19 degrees of freedom).
const T_19: f64 = 2.093;

/// The rank estimate of S = Var E[y | x] / Var y from paired samples (non-finite pairs
/// dropped); NaN when fewer than 3 remain or y is constant.
pub fn rank_first_order(x: &[f64], y: &[f64]) -> f64 {
    let mut pairs: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(&a, &b)| (a, b))
        .collect();
    let n = pairs.len();
    if n < 3 {
        return f64::NAN;
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mean = pairs.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let var = pairs.iter().map(|p| (p.1 - mean).powi(2)).sum::<f64>() / n as f64;
    if var <= 0.0 {
        return f64::NAN;
    }
    let cov = (0..n)
        .map(|k| (pairs[k].1 - mean) * (pairs[(k + 1) % n].1 - mean))
        .sum::<f64>()
        / n as f64;
    cov / var
}

/// The rank estimate with its 95 % interval: the estimate on all samples ± t · the spread
/// of the estimates on 20 disjoint groups (rows k, k + 20, k + 40, …) / √20.
pub fn first_order(x: &[f64], y: &[f64]) -> Estimate {
    let value = rank_first_order(x, y);
    let groups: Vec<f64> = (0..GROUPS)
        .map(|g| {
            let pick = |v: &[f64]| {
                v.iter()
                    .skip(g)
                    .step_by(GROUPS)
                    .copied()
                    .collect::<Vec<_>>()
            };
            rank_first_order(&pick(x), &pick(y))
        })
        .filter(|v| v.is_finite())
        .collect();
    let half = if groups.len() == GROUPS {
        T_19 * st::sd(&groups) / (GROUPS as f64).sqrt()
    } else {
        f64::NAN
    };
    Estimate {
        value,
        ci95: (value - half, value + half),
    }
}

/// Samples HSIC uses at most (its cost grows as n²).
pub const HSIC_SAMPLES: usize = 500;
/// Permutations for its p-value.
const PERMUTATIONS: usize = 49;

/// HSIC of one input with one output.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Dependence {
    /// R²_HSIC = HSIC(x, y) / √(HSIC(x, x) HSIC(y, y)), 0 for independent variables.
    pub r2: f64,
    /// The share of permutations of y whose HSIC is at least the observed one (the chance
    /// of so strong a dependence between independent variables).
    pub p_value: f64,
}

/// The doubly centred Gaussian Gram matrix H K H of `v` (bandwidth: its sample σ).
fn centred_gram(v: &[f64]) -> Vec<f64> {
    let n = v.len();
    let s = st::sd(v);
    let s2 = if s > 0.0 { 2.0 * s * s } else { 1.0 };
    let mut k: Vec<f64> = (0..n * n)
        .map(|ab| (-(v[ab / n] - v[ab % n]).powi(2) / s2).exp())
        .collect();
    let rows: Vec<f64> = (0..n)
        .map(|a| k[a * n..(a + 1) * n].iter().sum::<f64>() / n as f64)
        .collect();
    let all = rows.iter().sum::<f64>() / n as f64;
    for a in 0..n {
        for b in 0..n {
            k[a * n + b] += all - rows[a] - rows[b];
        }
    }
    k
}

/// (1/n²) Σ K̃ₐᵦ L̃_{π(a)π(b)}.
fn hsic(k: &[f64], l: &[f64], perm: &[usize]) -> f64 {
    let n = perm.len();
    let mut s = 0.0;
    for a in 0..n {
        let (ka, la) = (&k[a * n..(a + 1) * n], &l[perm[a] * n..(perm[a] + 1) * n]);
        for b in 0..n {
            s += ka[b] * la[perm[b]];
        }
    }
    s / (n * n) as f64
}

/// HSIC dependence of y on each input column, on at most [`HSIC_SAMPLES`] rows spread
/// evenly over the sample (rows with a non-finite value dropped); `seed` fixes the
/// permutations. `None` with fewer than 20 rows.
pub fn dependence(x: &[Vec<f64>], y: &[f64], seed: u64) -> Option<Vec<Dependence>> {
    let keep: Vec<usize> = (0..y.len())
        .filter(|&i| y[i].is_finite() && x.iter().all(|c| c[i].is_finite()))
        .collect();
    if keep.len() < 20 {
        return None;
    }
    let stride = keep.len().div_ceil(HSIC_SAMPLES);
    let rows: Vec<usize> = keep.iter().step_by(stride).copied().collect();
    let n = rows.len();
    let l = centred_gram(&rows.iter().map(|&i| y[i]).collect::<Vec<_>>());
    let identity: Vec<usize> = (0..n).collect();
    let lyy = hsic(&l, &l, &identity);
    let perms: Vec<Vec<usize>> = (0..PERMUTATIONS)
        .map(|p| {
            use rand::seq::SliceRandom;
            use rand::SeedableRng;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(p as u64);
            let mut v = identity.clone();
            v.shuffle(&mut rng);
            v
        })
        .collect();
    Some(
        x.iter()
            .map(|c| {
                let k = centred_gram(&rows.iter().map(|&i| c[i]).collect::<Vec<_>>());
                let kxx = hsic(&k, &k, &identity);
                let observed = hsic(&k, &l, &identity);
                let r2 = if kxx > 0.0 && lyy > 0.0 {
                    observed / (kxx * lyy).sqrt()
                } else {
                    0.0
                };
                let beaten = perms.iter().filter(|p| hsic(&k, &l, p) >= observed).count();
                Dependence {
                    r2,
                    p_value: (beaten + 1) as f64 / (PERMUTATIONS + 1) as f64,
                }
            })
            .collect(),
    )
}
