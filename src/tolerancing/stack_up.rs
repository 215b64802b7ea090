//! The linear stack-up (RSS) of a study's own samples: a least-squares fit
//! y ≈ a₀ + Σ aᵢ xᵢ gives the sensitivities, and with the inputs' covariance Σ
//! (marginal σ and their correlation) the predicted σ² = aᵀ Σ a, each input's share of it
//! aᵢ (Σ a)ᵢ / σ², and the linear worst case a₀ + Σ aᵢ cᵢ ± Σ |aᵢ| wᵢ over the tolerance
//! box (centres cᵢ, half-widths wᵢ). R² says how far the linear reading holds: below 0.9
//! the mechanism is not linear enough to trust it.

use crate::study::copula::linear_from_scores;
use crate::study::Study;
use nalgebra::{DMatrix, DVector};

/// R² below which the linear stack-up is not to be trusted.
pub const TRUSTED_R2: f64 = 0.9;

/// The linear stack-up of one output.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StackUp {
    pub output: String,
    /// ∂y/∂xᵢ per input (SI; 0 for a fixed input).
    pub sensitivities: Vec<f64>,
    /// The fit's coefficient of determination.
    pub r2: f64,
    /// The predicted mean a₀ + Σ aᵢ μᵢ and σ.
    pub mean: f64,
    pub sigma: f64,
    /// Each input's share of σ², in % (they add up to 100; a negative share comes from a
    /// correlation that cancels).
    pub contributions: Vec<f64>,
    /// The linear model's extremes over the tolerance box.
    pub linear_worst_case: (f64, f64),
}

impl StackUp {
    /// Whether R² is high enough for the linear reading.
    pub fn trusted(&self) -> bool {
        self.r2 >= TRUSTED_R2
    }
}

/// The inputs' covariance: σᵢ σⱼ times their linear correlation (from the copula).
pub fn input_covariance(study: &Study) -> DMatrix<f64> {
    let p = &study.parameters;
    let d = p.len();
    let sd: Vec<f64> = p.iter().map(|q| q.distribution.moments().1).collect();
    DMatrix::from_fn(d, d, |i, j| {
        let rho = if i == j {
            1.0
        } else {
            let r = study.copula.scores[(i, j)];
            if r == 0.0 {
                0.0
            } else {
                linear_from_scores(r, &p[i].distribution, &p[j].distribution)
            }
        };
        rho * sd[i] * sd[j]
    })
}

/// The stack-up of `y` against the input columns `x` (one per parameter; rows with a
/// non-finite value dropped), its linear worst case over the box of ± `sigmas` σ for
/// unbounded inputs. `None` with fewer rows than inputs + 2, or a constant output.
pub fn stack_up(
    study: &Study,
    output: &str,
    x: &[Vec<f64>],
    y: &[f64],
    sigmas: f64,
) -> Option<StackUp> {
    let d = x.len();
    let keep: Vec<usize> = (0..y.len())
        .filter(|&i| y[i].is_finite() && x.iter().all(|c| c[i].is_finite()))
        .collect();
    let n = keep.len();
    if n < d + 2 {
        return None;
    }
    // centre and scale each column for a well-conditioned fit, then scale back
    let centre = |v: &[f64]| keep.iter().map(|&i| v[i]).sum::<f64>() / n as f64;
    let spread = |v: &[f64], m: f64| {
        (keep.iter().map(|&i| (v[i] - m).powi(2)).sum::<f64>() / n as f64).sqrt()
    };
    let means: Vec<f64> = x.iter().map(|c| centre(c)).collect();
    let scales: Vec<f64> = x.iter().zip(&means).map(|(c, &m)| spread(c, m)).collect();
    let used: Vec<usize> = (0..d).filter(|&j| scales[j] > 0.0).collect();
    let ym = centre(y);
    let ys = spread(y, ym);
    if ys.is_nan() || ys <= 0.0 {
        return None;
    }
    let a = DMatrix::from_fn(n, used.len(), |r, k| {
        let j = used[k];
        (x[j][keep[r]] - means[j]) / scales[j]
    });
    let b = DVector::from_fn(n, |r, _| (y[keep[r]] - ym) / ys);
    let beta = a.clone().svd(true, true).solve(&b, 1e-12).ok()?;
    let resid = &b - &a * &beta;
    let r2 = 1.0 - resid.norm_squared() / b.norm_squared();
    let mut slope = vec![0.0; d];
    for (k, &j) in used.iter().enumerate() {
        slope[j] = beta[k] * ys / scales[j];
    }
    let intercept = ym - (0..d).map(|j| slope[j] * means[j]).sum::<f64>();
    let mu: Vec<f64> = study
        .parameters
        .iter()
        .map(|p| p.distribution.moments().0)
        .collect();
    let cov = input_covariance(study);
    let a_vec = DVector::from_vec(slope.clone());
    let sa = &cov * &a_vec;
    let var = a_vec.dot(&sa);
    let contributions = (0..d)
        .map(|j| {
            if var > 0.0 {
                100.0 * slope[j] * sa[j] / var
            } else {
                0.0
            }
        })
        .collect();
    let (mut centre_y, mut half) = (intercept, 0.0);
    for (j, p) in study.parameters.iter().enumerate() {
        let (lo, hi) = p.tolerance_box(sigmas);
        centre_y += slope[j] * 0.5 * (lo + hi);
        half += (slope[j] * 0.5 * (hi - lo)).abs();
    }
    Some(StackUp {
        output: output.to_string(),
        mean: intercept + (0..d).map(|j| slope[j] * mu[j]).sum::<f64>(),
        sensitivities: slope,
        r2,
        sigma: var.sqrt(),
        contributions,
        linear_worst_case: (centre_y - half, centre_y + half),
    })
}
