//! Input distributions, sampled by their inverse CDF so that every design (random, Latin
//! hypercube, Sobol') maps a point of the unit cube to the inputs the same way.

use statrs::distribution::{ContinuousCDF, Normal};

/// A distribution in SI units.
#[derive(Clone, Debug, PartialEq)]
pub enum Distribution {
    Normal {
        mean: f64,
        sd: f64,
    },
    /// Normal(mean, sd) restricted to [lower, upper] (either may be infinite).
    TruncatedNormal {
        mean: f64,
        sd: f64,
        lower: f64,
        upper: f64,
    },
    Uniform {
        lower: f64,
        upper: f64,
    },
    /// ln X ~ Normal(mu, sigma); built from the mean and sd of X itself.
    Lognormal {
        mu: f64,
        sigma: f64,
    },
    Triangular {
        lower: f64,
        mode: f64,
        upper: f64,
    },
    Fixed(f64),
}

fn standard_normal() -> Normal {
    Normal::standard()
}

/// Φ⁻¹(u) for u in (0, 1).
fn probit(u: f64) -> f64 {
    standard_normal().inverse_cdf(u)
}

fn phi(x: f64) -> f64 {
    standard_normal().cdf(x)
}

impl Distribution {
    /// The extreme values a sample can take, where the support is bounded: just inside
    /// each finite end of a continuous distribution (an end itself has probability zero),
    /// or the fixed value.
    pub fn extreme_values(&self) -> Vec<f64> {
        let ends = match *self {
            Distribution::Normal { .. } | Distribution::Lognormal { .. } => vec![],
            Distribution::TruncatedNormal { lower, upper, .. }
            | Distribution::Uniform { lower, upper }
            | Distribution::Triangular { lower, upper, .. } => {
                vec![lower.next_up(), upper.next_down()]
            }
            Distribution::Fixed(v) => vec![v],
        };
        ends.into_iter().filter(|v| v.is_finite()).collect()
    }

    /// Lognormal with the given mean and standard deviation of X (mean > 0).
    pub fn lognormal(mean: f64, sd: f64) -> Result<Distribution, String> {
        if mean <= 0.0 {
            return Err(format!("a lognormal needs mean > 0, got {mean}"));
        }
        let sigma2 = (1.0 + (sd / mean).powi(2)).ln();
        Ok(Distribution::Lognormal {
            mu: mean.ln() - 0.5 * sigma2,
            sigma: sigma2.sqrt(),
        })
    }

    /// Checks the parameters: σ ≥ 0, ordered bounds, a truncation window with mass.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Distribution::Normal { sd, .. } if sd < 0.0 => Err(format!("sd must be ≥ 0, got {sd}")),
            Distribution::TruncatedNormal {
                mean,
                sd,
                lower,
                upper,
            } => {
                if sd < 0.0 {
                    return Err(format!("sd must be ≥ 0, got {sd}"));
                }
                if lower >= upper || lower.is_nan() || upper.is_nan() {
                    return Err(format!("needs lower < upper, got [{lower}, {upper}]"));
                }
                if sd == 0.0 {
                    return if (lower..=upper).contains(&mean) {
                        Ok(())
                    } else {
                        Err(format!(
                            "sd = 0 puts all the mass at {mean}, outside [{lower}, {upper}]: the distribution has no mass"
                        ))
                    };
                }
                let (_, _, mass) = truncation(mean, sd, lower, upper);
                if mass > 0.0 && mass.is_finite() {
                    Ok(())
                } else {
                    Err(format!(
                        "[{lower}, {upper}] lies {:.1} σ or more from the mean: the truncated distribution has no mass",
                        ((lower - mean) / sd).abs().min(((upper - mean) / sd).abs())
                    ))
                }
            }
            Distribution::Uniform { lower, upper } if lower > upper => {
                Err(format!("needs lower ≤ upper, got [{lower}, {upper}]"))
            }
            Distribution::Triangular { lower, mode, upper }
                if !(lower <= mode && mode <= upper && lower < upper) =>
            {
                Err(format!(
                    "needs lower ≤ mode ≤ upper and lower < upper, got {lower}, {mode}, {upper}"
                ))
            }
            _ => Ok(()),
        }
    }

    /// The u-quantile, u in (0, 1).
    pub fn quantile(&self, u: f64) -> f64 {
        match *self {
            Distribution::Normal { mean, sd } => mean + sd * probit(u),
            Distribution::TruncatedNormal {
                mean,
                sd,
                lower,
                upper,
            } => {
                if sd == 0.0 {
                    return mean;
                }
                let (a, flip, mass) = truncation(mean, sd, lower, upper);
                // in the orientation where the window is not in the upper tail, Φ keeps its
                // relative precision; the far-tail case is the mirror image
                let z = probit(a + if flip { 1.0 - u } else { u } * mass);
                let x = if flip { mean - sd * z } else { mean + sd * z };
                x.clamp(lower, upper)
            }
            Distribution::Uniform { lower, upper } => lower + u * (upper - lower),
            Distribution::Lognormal { mu, sigma } => (mu + sigma * probit(u)).exp(),
            Distribution::Triangular { lower, mode, upper } => {
                let w = upper - lower;
                let f = (mode - lower) / w;
                if u < f {
                    lower + (u * w * (mode - lower)).sqrt()
                } else {
                    upper - ((1.0 - u) * w * (upper - mode)).sqrt()
                }
            }
            Distribution::Fixed(v) => v,
        }
    }

    /// P(X ≤ x).
    pub fn cdf(&self, x: f64) -> f64 {
        match *self {
            Distribution::Normal { mean, sd } => phi((x - mean) / sd),
            Distribution::TruncatedNormal {
                mean,
                sd,
                lower,
                upper,
            } => {
                let (a, b) = (phi((lower - mean) / sd), phi((upper - mean) / sd));
                ((phi((x.clamp(lower, upper) - mean) / sd) - a) / (b - a)).clamp(0.0, 1.0)
            }
            Distribution::Uniform { lower, upper } => {
                ((x - lower) / (upper - lower)).clamp(0.0, 1.0)
            }
            Distribution::Lognormal { mu, sigma } => {
                if x <= 0.0 {
                    0.0
                } else {
                    phi((x.ln() - mu) / sigma)
                }
            }
            Distribution::Triangular { lower, mode, upper } => {
                if x <= lower {
                    0.0
                } else if x >= upper {
                    1.0
                } else if x <= mode {
                    (x - lower).powi(2) / ((upper - lower) * (mode - lower))
                } else {
                    1.0 - (upper - x).powi(2) / ((upper - lower) * (upper - mode))
                }
            }
            Distribution::Fixed(v) => f64::from(u8::from(x >= v)),
        }
    }

    /// The value at standard-normal coordinate z: the Φ(z)-quantile, computed directly
    /// where the distribution is a transformed normal so that the far tails keep their
    /// precision.
    pub fn from_standard(&self, z: f64) -> f64 {
        match *self {
            Distribution::Normal { mean, sd } => mean + sd * z,
            Distribution::Lognormal { mu, sigma } => (mu + sigma * z).exp(),
            _ => self.quantile(phi(z)),
        }
    }

    /// Mean and standard deviation in closed form (for reports and tests).
    pub fn moments(&self) -> (f64, f64) {
        match *self {
            Distribution::Normal { mean, sd } => (mean, sd),
            Distribution::TruncatedNormal {
                mean,
                sd,
                lower,
                upper,
            } => {
                if sd == 0.0 {
                    return (mean, 0.0);
                }
                let (al, be) = ((lower - mean) / sd, (upper - mean) / sd);
                let pdf = |x: f64| {
                    if x.is_finite() {
                        (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
                    } else {
                        0.0
                    }
                };
                let xpdf = |x: f64| if x.is_finite() { x * pdf(x) } else { 0.0 };
                let z = phi(be) - phi(al);
                let m = (pdf(al) - pdf(be)) / z;
                let var = 1.0 + (xpdf(al) - xpdf(be)) / z - m * m;
                (mean + sd * m, sd * var.sqrt())
            }
            Distribution::Uniform { lower, upper } => {
                (0.5 * (lower + upper), (upper - lower) / 12f64.sqrt())
            }
            Distribution::Lognormal { mu, sigma } => {
                let m = (mu + 0.5 * sigma * sigma).exp();
                (m, m * ((sigma * sigma).exp() - 1.0).sqrt())
            }
            Distribution::Triangular {
                lower: a,
                mode: c,
                upper: b,
            } => (
                (a + b + c) / 3.0,
                ((a * a + b * b + c * c - a * b - a * c - b * c) / 18.0).sqrt(),
            ),
            Distribution::Fixed(v) => (v, 0.0),
        }
    }
}

/// (Φ(lower standardised), whether the window was mirrored, Φ-mass of the window), in the
/// orientation where the window does not lie in the upper tail.
fn truncation(mean: f64, sd: f64, lower: f64, upper: f64) -> (f64, bool, f64) {
    let (al, be) = ((lower - mean) / sd, (upper - mean) / sd);
    let flip = al > 0.0;
    let (al, be) = if flip { (-be, -al) } else { (al, be) };
    let (a, b) = (phi(al), phi(be));
    (a, flip, b - a)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_quantiles_match_tables() {
        let d = Distribution::Normal { mean: 1.0, sd: 2.0 };
        assert!((d.quantile(0.975) - (1.0 + 2.0 * 1.959_963_984_540_054)).abs() < 1e-12);
        assert!((d.quantile(0.5) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn truncated_normal_stays_inside_and_far_tails_keep_mass() {
        let d = Distribution::TruncatedNormal {
            mean: 0.07,
            sd: 0.0175,
            lower: 0.0,
            upper: f64::INFINITY,
        };
        d.validate().unwrap();
        assert!(d.quantile(1e-12) >= 0.0);
        // median of N(0,1) truncated to [8, ∞) (mirrored branch): 8 + ln 2/8 to first order
        let t = Distribution::TruncatedNormal {
            mean: 0.0,
            sd: 1.0,
            lower: 8.0,
            upper: f64::INFINITY,
        };
        t.validate().unwrap();
        let m = t.quantile(0.5);
        assert!(m > 8.0 && (m - 8.0 - 2f64.ln() / 8.0).abs() < 0.01, "{m}");
        let none = Distribution::TruncatedNormal {
            mean: 0.0,
            sd: 1.0,
            lower: 40.0,
            upper: 41.0,
        };
        assert!(none.validate().unwrap_err().contains("no mass"));
    }

    #[test]
    fn triangular_and_lognormal_invert_their_cdfs() {
        let t = Distribution::Triangular {
            lower: 0.0,
            mode: 1.0,
            upper: 3.0,
        };
        // CDF at the mode is (c − a)/(b − a) = 1/3
        assert!((t.quantile(1.0 / 3.0) - 1.0).abs() < 1e-12);
        let l = Distribution::lognormal(2.0, 0.5).unwrap();
        let (m, s) = l.moments();
        assert!((m - 2.0).abs() < 1e-12 && (s - 0.5).abs() < 1e-12);
        // median of a lognormal is exp(mu)
        let Distribution::Lognormal { mu, .. } = l else {
            unreachable!()
        };
        assert!((l.quantile(0.5) - mu.exp()).abs() < 1e-12);
    }
}
