//! The standard normal space of a rare-event study: Φ, Φ⁻¹ with their tails, and normal
//! draws keyed by (seed, batch, chain, component), so that every draw is a pure function of
//! where it is used and a resumed or sharded run draws the same numbers.

use crate::study::design::splitmix64;
use statrs::distribution::{Continuous, ContinuousCDF, Normal};

/// Φ(x), accurate in both tails (the upper tail through the complement).
pub fn cdf(x: f64) -> f64 {
    Normal::standard().cdf(x)
}

/// 1 − Φ(x) without cancellation.
pub fn upper_tail(x: f64) -> f64 {
    Normal::standard().sf(x)
}

/// Φ⁻¹(p), p in (0, 1).
pub fn quantile(p: f64) -> f64 {
    Normal::standard().inverse_cdf(p)
}

/// The density φ(x).
pub fn pdf(x: f64) -> f64 {
    Normal::standard().pdf(x)
}

/// The reliability index β = −Φ⁻¹(p) of a probability p in (0, 1).
pub fn beta(p: f64) -> f64 {
    if p <= 0.0 {
        f64::INFINITY
    } else if p >= 1.0 {
        f64::NEG_INFINITY
    } else {
        -quantile(p)
    }
}

/// A uniform draw in (0, 1) keyed by `key`: the same key gives the same number on every
/// machine, thread and run.
pub fn keyed_unit(key: &[u64]) -> f64 {
    let mut h = 0x6d63_2d73_7475_6479_u64; // "mc-study"
    for &k in key {
        h = splitmix64(h ^ splitmix64(k));
    }
    // 53 random bits, never 0 or 1
    ((h >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// A standard normal draw keyed by `key`.
pub fn keyed(key: &[u64]) -> f64 {
    quantile(keyed_unit(key))
}

/// A vector of `d` keyed standard normal draws: component i has key (key…, i).
pub fn keyed_vector(key: &[u64], d: usize) -> Vec<f64> {
    let mut k = key.to_vec();
    k.push(0);
    (0..d)
        .map(|i| {
            *k.last_mut().expect("pushed") = i as u64;
            keyed(&k)
        })
        .collect()
}

/// log φ_d(u), the d-variate standard normal log-density.
pub fn log_density(u: &[f64]) -> f64 {
    let d = u.len() as f64;
    -0.5 * (u.iter().map(|x| x * x).sum::<f64>() + d * (2.0 * std::f64::consts::PI).ln())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tails_and_beta() {
        // Φ(−4.753) = 1.00210e-6 (tabulated)
        assert!((cdf(-4.753) / 1.00210e-6 - 1.0).abs() < 1e-4);
        assert!((upper_tail(4.753) / 1.00210e-6 - 1.0).abs() < 1e-4);
        assert!((beta(1.00210e-6) - 4.753).abs() < 1e-4);
        assert!((pdf(0.0) - 0.398_942_280_401_432_7).abs() < 1e-15);
    }

    #[test]
    fn keyed_draws_are_standard_normal() {
        let n = 20_000;
        let x: Vec<f64> = (0..n).map(|i| keyed(&[7, 1, i])).collect();
        let m = x.iter().sum::<f64>() / n as f64;
        let v = x.iter().map(|a| (a - m).powi(2)).sum::<f64>() / (n - 1) as f64;
        // mean within 4 standard errors, variance within 4 of its standard error (√(2/n))
        assert!(m.abs() < 4.0 / (n as f64).sqrt(), "mean {m}");
        assert!(
            (v - 1.0).abs() < 4.0 * (2.0 / n as f64).sqrt(),
            "variance {v}"
        );
        // tail mass beyond 2: 2.275 %, binomial standard error 0.105 %
        let tail = x.iter().filter(|a| **a > 2.0).count() as f64 / n as f64;
        assert!((tail - 0.02275).abs() < 4.0 * 0.00105, "tail {tail}");
        // keys that differ in one place give different draws
        assert_ne!(keyed(&[7, 1, 0]), keyed(&[7, 0, 1]));
        assert_eq!(keyed(&[7, 1, 0]), keyed(&[7, 1, 0]));
    }
}
