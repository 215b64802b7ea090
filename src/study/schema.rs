//! The study YAML schema, as serde structs; scalars keep their line for error messages.

use crate::scene::schema::{Name, Q};
use crate::scene::IntegratorSpec;
use serde::Deserialize;
use serde_saphyr::Spanned;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudySpec {
    pub name: Option<Name>,
    pub description: Option<String>,
    /// Scene file, relative to the study file.
    pub scene: Name,
    /// Number of samples N (base rows for `saltelli`).
    pub samples: Q,
    /// Default 0.
    pub seed: Option<Spanned<u64>>,
    /// `random` (default), `lhs`, `sobol` or `saltelli`.
    pub design: Option<Name>,
    #[serde(default)]
    pub parameters: Vec<ParameterSpec>,
    /// The scene's probes to keep (default: all).
    pub outputs: Option<Vec<Name>>,
    /// Specification limits per output name.
    #[serde(default)]
    pub limits: Vec<LimitSpec>,
    /// Integrator overrides (same keys as a scene's `integrator`).
    pub fidelity: Option<IntegratorSpec>,
    /// Output directory, relative to the working directory (default `results/<name>`).
    pub output: Option<Name>,
    /// What a suspect sample counts as: `keep` (default: its values count, flagged) or
    /// `fail` (a failure: its values are left out).
    pub suspect: Option<Name>,
    /// A rare-event estimate of the out-of-spec probability instead of plain sampling.
    pub reliability: Option<Spanned<ReliabilitySpec>>,
    /// Correlations between pairs of parameters (a Gaussian copula).
    #[serde(default)]
    pub correlations: Vec<Spanned<CorrelationSpec>>,
    /// The target of `mc-study allocate`.
    pub allocation: Option<Spanned<AllocationSpec>>,
}

/// `{ between: [a, b], rank: 0.8 }` or `{ between: [a, b], linear: 0.8 }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CorrelationSpec {
    pub between: Vec<Name>,
    /// Spearman's rank correlation.
    pub rank: Option<Spanned<f64>>,
    /// Pearson's linear correlation.
    pub linear: Option<Spanned<f64>>,
}

/// What tolerance allocation must meet, per output with limits.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AllocationSpec {
    /// Smallest Cpk of every output with limits.
    pub cpk: Option<Spanned<f64>>,
    /// Largest out-of-spec rate, in parts per million (through the normal model).
    pub ppm: Option<Spanned<f64>>,
    /// The outputs the target applies to (default: every output with limits).
    pub outputs: Option<Vec<Name>>,
    /// The widest a tolerance may become, as a ratio to today's (default 4).
    pub widest: Option<Spanned<f64>>,
    /// The narrowest, as a ratio to today's (default 0.1).
    pub narrowest: Option<Spanned<f64>>,
}

/// The cost of a tolerance t: a + b t₀ / t, with t₀ today's tolerance.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostSpec {
    /// The fixed part (default 0).
    pub a: Option<Spanned<f64>>,
    /// What today's precision costs (default 1).
    pub b: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReliabilitySpec {
    /// `subset` (default) or `monte-carlo`.
    pub method: Option<Name>,
    /// Coefficient of variation to reach (default 0.1).
    pub target_cov: Option<Spanned<f64>>,
    /// Conditional probability of a subset level (default 0.1).
    pub p0: Option<Spanned<f64>>,
    /// Simulations at most (default 100000).
    pub max_simulations: Option<Spanned<u64>>,
    /// Refine subset simulation by importance sampling (default true).
    pub importance: Option<Spanned<bool>>,
    /// The one output whose limits define failure (default: any output with limits).
    pub output: Option<Name>,
    /// What a sample whose simulation fails counts as: `fail` (default), `pass` or `error`.
    pub failed_samples: Option<Name>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    /// Scene parameter path, e.g. `joints.J1.clearance`.
    pub path: Name,
    pub distribution: Option<Spanned<DistributionSpec>>,
    /// The parameter as a drawing states it (instead of `distribution`).
    pub tolerance: Option<Spanned<ToleranceSpec>>,
    /// The cost of its tolerance, for `mc-study allocate` (default: 1 / t).
    pub cost: Option<Spanned<CostSpec>>,
}

/// A nominal value with its tolerance band and process capability:
/// `{ nominal: 55 mm, plus_minus: 0.05 mm, cp: 1.33 }` or
/// `{ nominal: 55 mm, plus: 0.05 mm, minus: 0.02 mm }`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToleranceSpec {
    pub nominal: Q,
    /// A symmetric band ±t.
    pub plus_minus: Option<Q>,
    /// An asymmetric band [nominal − minus, nominal + plus].
    pub plus: Option<Q>,
    pub minus: Option<Q>,
    /// Process capability Cp (default 1): σ = band width / (6 Cp).
    pub cp: Option<Spanned<f64>>,
    /// `normal` (default, centred on the band) or `uniform` (over the band).
    pub distribution: Option<Name>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum DistributionSpec {
    Normal {
        mean: Q,
        sd: Q,
    },
    TruncatedNormal {
        mean: Q,
        sd: Q,
        lower: Option<Q>,
        upper: Option<Q>,
    },
    Uniform {
        lower: Q,
        upper: Q,
    },
    /// Mean and standard deviation of the variable itself.
    Lognormal {
        mean: Q,
        sd: Q,
    },
    Triangular {
        lower: Q,
        mode: Q,
        upper: Q,
    },
    Fixed(Q),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitSpec {
    pub output: Name,
    pub lower: Option<Q>,
    pub upper: Option<Q>,
}
