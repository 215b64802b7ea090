//! Summary statistics of a sample: moments with a confidence interval, quantiles, the
//! Wilson interval of a proportion, capability indices and rank correlation. Plain
//! functions on slices, checked against closed forms and textbook values.

use statrs::distribution::{ContinuousCDF, Normal, StudentsT};

/// The standard normal quantile Φ⁻¹(p).
pub fn probit(p: f64) -> f64 {
    Normal::standard().inverse_cdf(p)
}

/// Arithmetic mean (NaN for an empty slice).
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Sample standard deviation (n − 1), by a two-pass sum.
pub fn sd(x: &[f64]) -> f64 {
    if x.len() < 2 {
        return f64::NAN;
    }
    let m = mean(x);
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

/// Two-sided 95 % confidence interval of the mean (Student t with n − 1 degrees of freedom).
pub fn mean_ci95(x: &[f64]) -> (f64, f64) {
    let n = x.len();
    if n < 2 {
        return (f64::NAN, f64::NAN);
    }
    let t = StudentsT::new(0.0, 1.0, (n - 1) as f64)
        .expect("n ≥ 2")
        .inverse_cdf(0.975);
    let half = t * sd(x) / (n as f64).sqrt();
    let m = mean(x);
    (m - half, m + half)
}

/// The p-quantile of sorted data, linear interpolation between order statistics
/// (Hyndman & Fan type 7, the default of R and NumPy).
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let h = (n - 1) as f64 * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Wilson score interval (95 %) of a proportion k/n.
pub fn wilson95(k: u64, n: u64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z = Normal::standard().inverse_cdf(0.975);
    let (k, n) = (k as f64, n as f64);
    let p = k / n;
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// Process capability: Cp = (U − L)/6σ (both limits needed) and
/// Cpk = min(U − μ, μ − L)/3σ (over the limits given).
pub fn capability(
    mean: f64,
    sd: f64,
    lower: Option<f64>,
    upper: Option<f64>,
) -> (Option<f64>, Option<f64>) {
    // no spread (one sample, or none): nothing to rate
    if !(sd > 0.0 && sd.is_finite() && mean.is_finite()) {
        return (None, None);
    }
    let cp = match (lower, upper) {
        (Some(l), Some(u)) => Some((u - l) / (6.0 * sd)),
        _ => None,
    };
    let sides: Vec<f64> = [upper.map(|u| u - mean), lower.map(|l| mean - l)]
        .into_iter()
        .flatten()
        .collect();
    let cpk = (!sides.is_empty())
        .then(|| sides.iter().copied().fold(f64::INFINITY, f64::min) / (3.0 * sd));
    (cp, cpk)
}

/// Whether the finite values of `x` are one value, up to round-off: their range within
/// 1e-9 of their largest magnitude. Such a sample has no spread, so no Cp, Cpk or
/// correlation.
pub fn is_constant(x: &[f64]) -> bool {
    let (lo, hi, big) = x.iter().filter(|v| v.is_finite()).fold(
        (f64::INFINITY, f64::NEG_INFINITY, 0.0f64),
        |(lo, hi, big), &v| (lo.min(v), hi.max(v), big.max(v.abs())),
    );
    lo > hi || hi - lo <= 1e-9 * big
}

/// Pearson correlation coefficient; NaN (undefined) when either sample is constant.
pub fn pearson(x: &[f64], y: &[f64]) -> f64 {
    if is_constant(x) || is_constant(y) {
        return f64::NAN;
    }
    let (mx, my) = (mean(x), mean(y));
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx).powi(2);
        syy += (b - my).powi(2);
    }
    sxy / (sxx * syy).sqrt()
}

/// Ranks from 1, ties sharing their mean rank.
pub fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        let rank = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = rank;
        }
        i = j + 1;
    }
    r
}

/// Spearman rank correlation (Pearson on ranks, ties averaged); NaN (undefined) when
/// either sample is constant, round-off included.
pub fn spearman(x: &[f64], y: &[f64]) -> f64 {
    if is_constant(x) || is_constant(y) {
        return f64::NAN;
    }
    pearson(&ranks(x), &ranks(y))
}

/// Histogram counts over [min, max] with Freedman–Diaconis bins (between 5 and 60):
/// (lower edge, bin width, counts).
pub fn histogram(sorted: &[f64]) -> (f64, f64, Vec<u64>) {
    let n = sorted.len();
    if n == 0 {
        return (0.0, 0.0, Vec::new());
    }
    let (lo, hi) = (sorted[0], sorted[n - 1]);
    let iqr = quantile_sorted(sorted, 0.75) - quantile_sorted(sorted, 0.25);
    let fd = 2.0 * iqr / (n as f64).cbrt();
    let bins = if fd > 0.0 && hi > lo {
        ((hi - lo) / fd).ceil() as usize
    } else {
        1
    }
    .clamp(5, 60);
    let width = if hi > lo {
        (hi - lo) / bins as f64
    } else {
        1.0
    };
    let mut counts = vec![0u64; bins];
    for &v in sorted {
        let k = (((v - lo) / width) as usize).min(bins - 1);
        counts[k] += 1;
    }
    (lo, width, counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_newcombe_1998() {
        // Newcombe, Statistics in Medicine 17 (1998), Table I, method 3 (score, no continuity
        // correction)
        let cases = [
            (81, 263, 0.2553, 0.3662),
            (15, 148, 0.0624, 0.1605),
            (0, 20, 0.0, 0.1611),
            (1, 29, 0.0061, 0.1718),
        ];
        for (k, n, lo, hi) in cases {
            let (a, b) = wilson95(k, n);
            assert!(
                (a - lo).abs() < 6e-5 && (b - hi).abs() < 6e-5,
                "{k}/{n}: {a:.4}–{b:.4}"
            );
        }
    }

    #[test]
    fn quantiles_are_type_7() {
        let x = [1.0, 2.0, 3.0, 4.0, 10.0];
        assert_eq!(quantile_sorted(&x, 0.5), 3.0);
        assert!((quantile_sorted(&x, 0.9) - 7.6).abs() < 1e-12);
        assert_eq!(quantile_sorted(&x, 0.0), 1.0);
        assert_eq!(quantile_sorted(&x, 1.0), 10.0);
    }

    #[test]
    fn moments_ci_and_capability() {
        let x = [2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0];
        assert_eq!(mean(&x), 5.0);
        assert!((sd(&x) - (32.0f64 / 7.0).sqrt()).abs() < 1e-15);
        // t_{0.975, 7} = 2.364624
        let (a, b) = mean_ci95(&x);
        let half = 2.364_624_251_6 * (32.0f64 / 7.0).sqrt() / 8f64.sqrt();
        assert!((a - (5.0 - half)).abs() < 1e-8 && (b - (5.0 + half)).abs() < 1e-8);
        let (cp, cpk) = capability(10.0, 1.0, Some(4.0), Some(13.0));
        assert_eq!(cp, Some(1.5));
        assert_eq!(cpk, Some(1.0));
        assert_eq!(capability(10.0, 2.0, None, Some(16.0)), (None, Some(1.0)));
    }

    #[test]
    fn rank_correlations() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        let y: Vec<f64> = x.iter().map(|v: &f64| v.powi(3)).collect();
        assert!((spearman(&x, &y) - 1.0).abs() < 1e-15);
        assert!(pearson(&x, &y) < 0.99);
        assert_eq!(ranks(&[3.0, 1.0, 3.0, 2.0]), vec![3.5, 1.0, 3.5, 2.0]);
        let z = [5.0, 4.0, 3.0, 2.0, 1.0];
        assert!((pearson(&x, &z) + 1.0).abs() < 1e-15);
    }
}
