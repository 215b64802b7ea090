//! Tolerance allocation: the tolerance widths of least total cost under which every
//! output with limits still reaches its Cpk.
//!
//! Each toleranced parameter's band is scaled by a ratio rᵢ = tᵢ / tᵢ⁰ in
//! [narrowest, widest], its cost being aᵢ + bᵢ / rᵢ. The problem
//!   minimise Σ cᵢ(rᵢ)  subject to  σₖ(r) ≤ sₖ = min(U − μ, μ − L)ₖ / (3 Cpk)  for each k
//! is solved on the linear stack-up σₖ(r)² = Σᵢ Aₖᵢ rᵢ² + Fₖ of the stored samples (Aₖᵢ
//! the variance input i gives at today's tolerance; Fₖ the rest): its Lagrange conditions
//! give rᵢ = (bᵢ / 2 Σₖ λₖ Aₖᵢ)^(1/3) (Chase et al. 1990), clipped to the ratio bounds, with
//! the multipliers λₖ found one at a time. A nonlinear output is then corrected on the
//! stored samples themselves: changing a tolerance changes the input density, not the
//! model, so the samples reweighted by f_r(x) / f₀(x) give the Cpk at r, and each budget
//! sₖ² is scaled until that Cpk is the target. Where the weights grow too uneven (their
//! effective sample size below a quarter of the samples), new runs are needed: the
//! confirmation study at the allocation then serves as the next round's samples.

use crate::study::{Cost, Study};

/// The reweighting is trusted down to this share of effective samples.
pub const MIN_ESS_SHARE: f64 = 0.25;

/// Ratios r of least cost Σ cost(rᵢ) under Σᵢ a[k][i] rᵢ² ≤ budget[k] for every k, with
/// r within `bounds`; `Err(k)` when output k cannot meet its budget even at the narrowest.
pub fn lagrange(
    costs: &[Cost],
    a: &[Vec<f64>],
    budget: &[f64],
    bounds: (f64, f64),
) -> Result<Vec<f64>, usize> {
    let d = costs.len();
    let m = a.len();
    let ratios = |lambda: &[f64]| -> Vec<f64> {
        (0..d)
            .map(|i| {
                let pull: f64 = (0..m).map(|k| lambda[k] * a[k][i]).sum();
                if pull <= 0.0 {
                    bounds.1
                } else {
                    (costs[i].b / (2.0 * pull)).cbrt().clamp(bounds.0, bounds.1)
                }
            })
            .collect()
    };
    let excess = |k: usize, r: &[f64]| -> f64 {
        (0..d).map(|i| a[k][i] * r[i] * r[i]).sum::<f64>() - budget[k]
    };
    // infeasible at the narrowest ratios: no allocation meets output k
    let narrowest = vec![bounds.0; d];
    if let Some(k) = (0..m).find(|&k| excess(k, &narrowest) > 1e-12 * budget[k].abs()) {
        return Err(k);
    }
    let mut lambda = vec![0.0; m];
    for _sweep in 0..200 {
        let before = lambda.clone();
        for k in 0..m {
            lambda[k] = 0.0;
            if excess(k, &ratios(&lambda)) <= 0.0 {
                continue;
            }
            // excess falls as λₖ grows: bisect on log λₖ
            let (mut lo, mut hi) = (-80.0f64, 80.0f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                lambda[k] = mid.exp();
                if excess(k, &ratios(&lambda)) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lambda[k] = hi.exp();
        }
        let moved = (0..m).any(|k| (lambda[k] - before[k]).abs() > 1e-12 * lambda[k].max(1e-300));
        if !moved {
            break;
        }
    }
    Ok(ratios(&lambda))
}

/// The log of the density of inputs `x` under `study`'s distributions with each toleranced
/// parameter's band scaled by `ratios`, up to a constant that does not depend on the
/// ratios; −∞ outside the support.
pub fn log_density(study: &Study, ratios: &[f64], x: &[f64]) -> f64 {
    let mut log_f = 0.0;
    let mut z = Vec::with_capacity(x.len());
    for ((p, &r), &xi) in study.parameters.iter().zip(ratios).zip(x) {
        let Some(d) = &p.drawing else {
            // unchanged by the allocation: its factor cancels in a ratio of densities
            z.push(f64::NAN);
            continue;
        };
        let d = d.scaled(r);
        let (zi, log_fi) = match d.distribution() {
            crate::study::Distribution::Normal { mean, sd } => {
                let zi = (xi - mean) / sd;
                (zi, -sd.ln() - 0.5 * zi * zi)
            }
            crate::study::Distribution::Uniform { lower, upper } => {
                if !(lower..=upper).contains(&xi) {
                    return f64::NEG_INFINITY;
                }
                let u = ((xi - lower) / (upper - lower)).clamp(1e-300, 1.0 - 1e-16);
                (crate::study::statistics::probit(u), -(upper - lower).ln())
            }
            _ => unreachable!("a drawing is normal or uniform"),
        };
        log_f += log_fi;
        z.push(zi);
    }
    if study.copula.is_independent() {
        return log_f;
    }
    // the copula density φ_R(z) / Π φ(zᵢ): the scores of unchanged inputs from their own
    // marginal (the same under every ratio)
    for (j, p) in study.parameters.iter().enumerate() {
        if z[j].is_nan() {
            z[j] = match p.distribution {
                crate::study::Distribution::Fixed(_) => 0.0,
                ref d => crate::study::statistics::probit(d.cdf(x[j]).clamp(1e-300, 1.0 - 1e-16)),
            };
        }
    }
    let r = &study.copula.scores;
    let zv = nalgebra::DVector::from_vec(z.clone());
    let inv = r
        .clone()
        .try_inverse()
        .expect("a copula's matrix is positive definite");
    let quad = zv.dot(&(&inv * &zv));
    log_f - 0.5 * quad + 0.5 * z.iter().map(|v| v * v).sum::<f64>()
}

/// Normalised importance weights of `rows` (inputs) drawn at ratios `from`, for the
/// density at ratios `to`, and their effective sample size (Σw)² / Σw².
pub fn weights(study: &Study, from: &[f64], to: &[f64], rows: &[&[f64]]) -> (Vec<f64>, f64) {
    let log_w: Vec<f64> = rows
        .iter()
        .map(|x| log_density(study, to, x) - log_density(study, from, x))
        .collect();
    let top = log_w.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return (vec![0.0; rows.len()], 0.0);
    }
    let w: Vec<f64> = log_w.iter().map(|l| (l - top).exp()).collect();
    let sum: f64 = w.iter().sum();
    let w: Vec<f64> = w.iter().map(|v| v / sum).collect();
    let ess = 1.0 / w.iter().map(|v| v * v).sum::<f64>();
    (w, ess)
}

/// The weighted mean and σ of `y`.
pub fn weighted_moments(w: &[f64], y: &[f64]) -> (f64, f64) {
    let mean: f64 = w.iter().zip(y).map(|(w, y)| w * y).sum();
    let var: f64 = w.iter().zip(y).map(|(w, y)| w * (y - mean).powi(2)).sum();
    (mean, var.sqrt())
}

/// Cpk = min(U − μ, μ − L) / 3σ (one-sided where only one limit is given).
pub fn cpk(mean: f64, sd: f64, lower: Option<f64>, upper: Option<f64>) -> f64 {
    let up = upper.map_or(f64::INFINITY, |u| u - mean);
    let low = lower.map_or(f64::INFINITY, |l| mean - l);
    up.min(low) / (3.0 * sd)
}

/// Bissell's (1990) approximate 95 % interval of an estimated Cpk from n samples.
pub fn cpk_interval(cpk: f64, n: usize) -> (f64, f64) {
    let n = n as f64;
    let se = (1.0 / (9.0 * n) + cpk * cpk / (2.0 * (n - 1.0))).sqrt();
    (cpk - 1.96 * se, cpk + 1.96 * se)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lagrange_matches_the_closed_form_of_one_rss_constraint() {
        // cost Σ bᵢ / rᵢ under Σ aᵢ rᵢ² = s²: rᵢ ∝ (bᵢ / aᵢ)^(1/3)
        let b = [1.0, 2.0, 0.5, 4.0];
        let a = vec![vec![1.0, 0.3, 2.0, 0.8]];
        let costs: Vec<Cost> = b.iter().map(|&b| Cost { a: 0.0, b }).collect();
        let r = lagrange(&costs, &a, &[1.2], (1e-6, 1e6)).unwrap();
        let shape: Vec<f64> = (0..4).map(|i| (b[i] / a[0][i]).cbrt()).collect();
        let used: f64 = (0..4).map(|i| a[0][i] * r[i] * r[i]).sum();
        assert!((used - 1.2).abs() < 1e-9, "{used}");
        for i in 1..4 {
            assert!((r[i] / r[0] - shape[i] / shape[0]).abs() < 1e-9);
        }
    }

    #[test]
    fn bounds_hold_and_infeasibility_names_the_output() {
        let costs = vec![Cost::default(); 2];
        let a = vec![vec![1.0, 0.0], vec![0.0, 1.0]];
        let r = lagrange(&costs, &a, &[0.25, 100.0], (0.1, 4.0)).unwrap();
        assert!((r[0] - 0.5).abs() < 1e-9 && r[1] == 4.0, "{r:?}");
        assert_eq!(lagrange(&costs, &a, &[0.25, 0.001], (0.1, 4.0)), Err(1));
    }

    #[test]
    fn bissell_interval_covers_about_95_percent() {
        use crate::reliability::normal::keyed;
        let mut hits = 0;
        let trials = 400;
        for s in 0..trials {
            let n = 200;
            let y: Vec<f64> = (0..n).map(|i| keyed(&[s, i as u64])).collect();
            let w = vec![1.0 / n as f64; n];
            let (m, sd) = weighted_moments(&w, &y);
            let c = cpk(m, sd, Some(-4.0), Some(4.0));
            let (lo, hi) = cpk_interval(c, n);
            hits += usize::from(lo <= 4.0 / 3.0 && 4.0 / 3.0 <= hi);
        }
        let cover = hits as f64 / trials as f64;
        assert!((0.91..=0.98).contains(&cover), "{cover}");
    }
}
