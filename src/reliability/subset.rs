//! Subset simulation (Au & Beck 2001) with adaptive conditional sampling (Papaioannou,
//! Betz, Zwirglmaier & Straub 2015), in standard-normal space.
//!
//! P(g ≤ 0) = Π_j P(g ≤ b_j | g ≤ b_{j−1}). Level 0 samples N points of φ; each level
//! keeps its N p₀ smallest margins as seeds, sets the threshold b_j at the largest of them,
//! and grows from each seed a chain of 1/p₀ states that stays in {g ≤ b_j}. The chains
//! step together, one batch per step, so that a batch's simulations run in parallel.
//!
//! Each level's coefficient of variation δ_j is Au & Beck's: the binomial one inflated by
//! the correlation of the level's chains. The levels' estimates are correlated too (each
//! level grows from the one before), by an amount one run cannot measure: √Σ δ_j² (levels
//! independent) understates the spread and Σ δ_j (fully dependent) overstates it. The CoV
//! reported is their geometric mean; the tests measure it against the spread of many runs.

use super::batch::{Cursor, Request, Stage};
use super::normal;

/// How subset simulation runs.
#[derive(Clone, Debug, PartialEq)]
pub struct SubsetSettings {
    /// Samples per level N; N p₀ and 1/p₀ must be whole numbers.
    pub level_samples: usize,
    /// Conditional probability of each level p₀.
    pub p0: f64,
    /// Levels after which the search gives up.
    pub max_levels: usize,
    /// Simulations after which the search gives up.
    pub max_simulations: u64,
    pub seed: u64,
}

/// One level's figures.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Level {
    /// The threshold this level's samples are conditioned on (+∞ for level 0).
    pub conditioned_on: f64,
    /// The next threshold (0 at the last level).
    pub threshold: f64,
    /// The estimated conditional probability P(g ≤ threshold | g ≤ conditioned_on).
    pub probability: f64,
    /// Its coefficient of variation, chain correlation included.
    pub cov: f64,
    /// The chains' correlation factor γ (0 at level 0).
    pub gamma: f64,
    /// The share of accepted candidates (level 0: 1).
    pub acceptance: f64,
    /// Simulations run at this level.
    pub simulations: u64,
}

/// A sample of the search: its point and margin.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub u: Vec<f64>,
    pub g: f64,
}

/// The outcome of subset simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct SubsetResult {
    pub probability: f64,
    /// The coefficient of variation reported: the geometric mean of the two bounds below.
    pub cov: f64,
    /// Au & Beck's coefficient of variation with levels uncorrelated, √Σ δ_j², which
    /// understates the spread…
    pub cov_lower: f64,
    /// …and with levels fully correlated, Σ δ_j, which overstates it.
    pub cov_upper: f64,
    pub levels: Vec<Level>,
    pub simulations: u64,
    /// Every level's samples, chain by chain: the last level's failing ones fit the
    /// importance density, and all of them give the tail curve.
    pub all_levels: Vec<Vec<Sample>>,
    /// Why the search stopped before reaching the failure domain, if it did.
    pub incomplete: Option<String>,
}

impl SubsetSettings {
    fn chains(&self) -> usize {
        (self.level_samples as f64 * self.p0).round() as usize
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(self.p0 > 0.0 && self.p0 < 1.0) {
            return Err(format!("p0 must lie in (0, 1), got {}", self.p0));
        }
        let nc = self.chains();
        let whole = |x: f64| (x - x.round()).abs() < 1e-9;
        if !whole(1.0 / self.p0) || !whole(self.level_samples as f64 * self.p0) || nc < 2 {
            return Err(format!(
                "the samples per level ({}) times p0 ({}) and 1/p0 must be whole numbers, with at least 2 chains (e.g. 100, 200, 500 or 1000 samples at p0 = 0.1)",
                self.level_samples, self.p0
            ));
        }
        Ok(())
    }
}

/// The Au & Beck correlation factor γ = 2 Σ_{k=1}^{Ns−1} (1 − k/Ns) ρ(k) of the indicator
/// `hit` over `chains` chains of equal length stored one after another, at probability p.
fn chain_gamma(hit: &[bool], chains: usize, p: f64) -> f64 {
    let ns = hit.len() / chains;
    let n = hit.len() as f64;
    let r = |k: usize| -> f64 {
        let mut s = 0.0;
        for c in 0..chains {
            let h = &hit[c * ns..(c + 1) * ns];
            for l in 0..ns - k {
                if h[l] && h[l + k] {
                    s += 1.0;
                }
            }
        }
        s / (n - (k * chains) as f64) - p * p
    };
    let r0 = p * (1.0 - p);
    if r0 <= 0.0 {
        return 0.0;
    }
    (1..ns)
        .map(|k| 2.0 * (1.0 - k as f64 / ns as f64) * r(k) / r0)
        .sum::<f64>()
        .max(0.0)
}

/// Sorts samples by margin, ties by position: the order is a function of the values.
fn order(samples: &[Sample]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..samples.len()).collect();
    idx.sort_by(|&a, &b| samples[a].g.total_cmp(&samples[b].g).then(a.cmp(&b)));
    idx
}

/// The conditional-sampling scale's start and the target acceptance (Papaioannou et al.).
const LAMBDA_START: f64 = 0.6;
const TARGET_ACCEPTANCE: f64 = 0.44;

/// Runs subset simulation on the margins behind `cursor`.
pub fn run(s: &SubsetSettings, d: usize, cursor: &mut Cursor) -> Result<SubsetResult, Request> {
    let n = s.level_samples;
    let nc = s.chains();
    let ns = n / nc;
    let start = cursor.simulations();

    let points: Vec<Vec<f64>> = (0..n)
        .map(|i| normal::keyed_vector(&[s.seed, cursor.batch(), i as u64], d))
        .collect();
    let g = cursor.evaluate(points.clone(), |_| (Stage::Subset, 0, None))?;
    let mut samples: Vec<Sample> = points
        .into_iter()
        .zip(g)
        .map(|(u, g)| Sample { u, g })
        .collect();

    let mut levels: Vec<Level> = Vec::new();
    let mut all_levels = Vec::new();
    let mut conditioned_on = f64::INFINITY;
    let mut acceptance = 1.0;
    let mut level_sims = n as u64;
    let mut incomplete = None;
    loop {
        let j = levels.len();
        let sorted = order(&samples);
        let failures = samples.iter().filter(|x| x.g <= 0.0).count();
        let last = failures >= nc;
        let threshold = if last { 0.0 } else { samples[sorted[nc - 1]].g };
        let hits: Vec<bool> = samples.iter().map(|x| x.g <= threshold).collect();
        let p = hits.iter().filter(|h| **h).count() as f64 / n as f64;
        let gamma = if j == 0 {
            0.0
        } else {
            chain_gamma(&hits, nc, p)
        };
        let cov = ((1.0 - p) / (n as f64 * p) * (1.0 + gamma)).sqrt();
        levels.push(Level {
            conditioned_on,
            threshold,
            probability: p,
            cov,
            gamma,
            acceptance,
            simulations: level_sims,
        });
        all_levels.push(samples.clone());
        if last {
            break;
        }
        // a threshold that does not fall means a plateau of the margin (or only failed
        // simulations): more levels would not get closer
        if threshold >= conditioned_on || !threshold.is_finite() {
            incomplete = Some(format!(
                "the margin stopped falling at level {j} (threshold {threshold:.4}): a plateau, or simulations that fail; the estimate is an upper bound"
            ));
            break;
        }
        if j + 1 >= s.max_levels {
            incomplete = Some(format!(
                "no failure within {} levels; the estimate is an upper bound",
                s.max_levels
            ));
            break;
        }
        if cursor.simulations() - start + ((ns - 1) * nc) as u64 > s.max_simulations {
            incomplete = Some(format!(
                "the budget of {} simulations ran out before the failure domain was reached; the estimate is an upper bound",
                s.max_simulations
            ));
            break;
        }
        // seeds: the nc smallest margins
        let seeds: Vec<Sample> = sorted[..nc].iter().map(|&i| samples[i].clone()).collect();
        let spread: Vec<f64> = (0..d)
            .map(|i| {
                let m = seeds.iter().map(|x| x.u[i]).sum::<f64>() / nc as f64;
                (seeds.iter().map(|x| (x.u[i] - m).powi(2)).sum::<f64>() / (nc - 1) as f64).sqrt()
            })
            .collect();
        let mut chains: Vec<Vec<Sample>> = seeds.into_iter().map(|x| vec![x]).collect();
        let mut lambda = LAMBDA_START;
        let mut accepted_total = 0usize;
        for step in 1..ns {
            let sigma: Vec<f64> = spread.iter().map(|sd| (lambda * sd).min(1.0)).collect();
            let batch = cursor.batch();
            let candidates: Vec<Vec<f64>> = chains
                .iter()
                .enumerate()
                .map(|(c, chain)| {
                    let u = &chain.last().expect("a seed").u;
                    let xi = normal::keyed_vector(&[s.seed, batch, c as u64], d);
                    (0..d)
                        .map(|i| (1.0 - sigma[i] * sigma[i]).sqrt() * u[i] + sigma[i] * xi[i])
                        .collect()
                })
                .collect();
            let level = (j + 1) as u64;
            let g = cursor.evaluate(candidates.clone(), |c| {
                (Stage::Subset, level, Some(c as u64))
            })?;
            let mut accepted = 0;
            for ((chain, v), gv) in chains.iter_mut().zip(candidates).zip(g) {
                if gv <= threshold {
                    accepted += 1;
                    chain.push(Sample { u: v, g: gv });
                } else {
                    let stay = chain.last().expect("a seed").clone();
                    chain.push(stay);
                }
            }
            accepted_total += accepted;
            let rate = accepted as f64 / nc as f64;
            lambda = (lambda.ln() + (rate - TARGET_ACCEPTANCE) / (step as f64).sqrt()).exp();
        }
        acceptance = accepted_total as f64 / ((ns - 1) * nc) as f64;
        level_sims = ((ns - 1) * nc) as u64;
        conditioned_on = threshold;
        samples = chains.into_iter().flatten().collect();
    }
    let probability = levels.iter().map(|l| l.probability).product::<f64>();
    let cov_lower = levels.iter().map(|l| l.cov * l.cov).sum::<f64>().sqrt();
    let cov_upper = levels.iter().map(|l| l.cov).sum::<f64>();
    Ok(SubsetResult {
        probability,
        cov: (cov_lower * cov_upper).sqrt(),
        cov_lower,
        cov_upper,
        levels,
        simulations: cursor.simulations() - start,
        all_levels,
        incomplete,
    })
}

/// Points of the tail curve (m, P(g ≤ m), CoV) from the levels' samples: within level j,
/// the fraction f of its samples at or below m times the probabilities of the levels
/// before; the CoV combines those levels' with the binomial one of f, inflated by the
/// level's chain correlation, as the final estimate's is.
pub fn tail_curve(result: &SubsetResult) -> Vec<(f64, f64, f64)> {
    let mut curve = Vec::new();
    let mut before = 1.0;
    let (mut lower2, mut upper) = (0.0, 0.0);
    for (level, samples) in result.levels.iter().zip(&result.all_levels) {
        let mut g: Vec<f64> = samples.iter().map(|x| x.g).collect();
        g.sort_by(f64::total_cmp);
        let n = g.len() as f64;
        // from this level's upper end down to the next threshold
        for (k, &m) in g.iter().enumerate().rev() {
            if m < level.threshold && level.threshold != 0.0 {
                break;
            }
            if m.is_finite() && m <= level.conditioned_on {
                let f = (k + 1) as f64 / n;
                let d = ((1.0 - f) / (n * f) * (1.0 + level.gamma)).sqrt();
                let cov = ((lower2 + d * d) * (upper + d)).sqrt().sqrt();
                curve.push((m, before * f, cov));
            }
        }
        before *= level.probability;
        lower2 += level.cov * level.cov;
        upper += level.cov;
    }
    curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    curve.dedup_by(|a, b| a.0 == b.0);
    curve
}
