//! Importance sampling after subset simulation, with a mixture of unit-covariance normals
//! h(u) = Σ_k π_k φ(u − m_k) fitted to the failing samples the subset search found, and
//! re-centred after every round on the weighted failures so far (cross-entropy updates).
//!
//! P̂ = (1/n) Σ 1{g(u_i) ≤ 0} φ(u_i)/h_r(u_i), each sample weighted by the density of its
//! own round. Shifted unit-covariance components keep the estimator's variance finite for
//! any failure domain: ∫ φ²/φ(· − m) = e^{|m|²}. The coefficient of variation is the sample
//! one, with no chain correlation.

use super::batch::{Cursor, Request, Stage};
use super::normal;
use super::subset::Sample;

#[derive(Clone, Debug, PartialEq)]
pub struct ImportanceSettings {
    /// Simulations per round.
    pub batch: usize,
    pub target_cov: f64,
    /// Simulations after which the stage stops, whatever its CoV.
    pub max_simulations: u64,
    /// The stage gives up once reaching the target would take more simulations than this
    /// (projected from the CoV so far, which falls as 1/√n).
    pub patience: u64,
    pub seed: u64,
}

/// One component of the sampling density: N(mean, I) with weight π.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Component {
    pub mean: Vec<f64>,
    pub weight: f64,
}

/// What the estimate stage found: its figures, and the density of its last round.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ImportanceFigures {
    pub probability: f64,
    pub cov: f64,
    pub simulations: u64,
    pub rounds: u64,
    /// Failing simulations.
    pub failures: u64,
    /// Effective sample size of the failing weights, (Σ w)² / Σ w².
    pub ess: f64,
    /// The largest failing weight's share of their sum.
    pub largest_share: f64,
    pub components: Vec<Component>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ImportanceResult {
    pub figures: ImportanceFigures,
    /// The simulations the target would have taken, when the stage gave up on it.
    pub gave_up: Option<u64>,
    /// Every sample with its weight (0 for a non-failing one), for the design point.
    pub samples: Vec<(Sample, f64)>,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

fn mean(members: &[&Sample]) -> Vec<f64> {
    let d = members[0].u.len();
    let mut m = vec![0.0; d];
    for s in members {
        m.iter_mut().zip(&s.u).for_each(|(a, b)| *a += b);
    }
    m.iter_mut().for_each(|a| *a /= members.len() as f64);
    m
}

/// How much wider than a flat failure boundary a group spreads across its mean direction:
/// the members' mean squared distance from the line through their mean, less the d − 1
/// that φ gives across a flat boundary. Infinite for a group centred on the origin.
fn excess_spread(members: &[&Sample]) -> f64 {
    let m = mean(members);
    let len = norm(&m);
    if len < 1.0 {
        return f64::INFINITY;
    }
    let across = members
        .iter()
        .map(|s| {
            let along = dot(&s.u, &m) / len;
            dot(&s.u, &s.u) - along * along
        })
        .sum::<f64>()
        / members.len() as f64;
    across - (m.len() - 1) as f64
}

/// The spread in excess of a flat boundary's that a group may have: a few units, and a
/// tenth of the dimension for the noise of a mean over correlated chain samples.
fn spread_allowed(d: usize) -> f64 {
    3.0 + 0.1 * (d - 1) as f64
}

/// Splits a group in two by 2-means, started from its member farthest from its mean and
/// the member farthest from that one.
fn split<'a>(members: &[&'a Sample]) -> (Vec<&'a Sample>, Vec<&'a Sample>) {
    let dist = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
    let far = |from: &[f64]| {
        members
            .iter()
            .max_by(|a, b| dist(&a.u, from).total_cmp(&dist(&b.u, from)))
            .expect("members")
            .u
            .clone()
    };
    let mut a = far(&mean(members));
    let mut b = far(&a);
    let mut parts = (Vec::new(), Vec::new());
    for _ in 0..20 {
        parts = members
            .iter()
            .partition(|s| dist(&s.u, &a) <= dist(&s.u, &b));
        if parts.0.is_empty() || parts.1.is_empty() {
            break;
        }
        let (na, nb) = (mean(&parts.0), mean(&parts.1));
        if na == a && nb == b {
            break;
        }
        (a, b) = (na, nb);
    }
    parts
}

/// The centre of a one-group domain: along the direction of the sum of the levels' means,
/// at the failures' mean distance along it. Every level's mean points towards the domain,
/// each with its own noise across that direction, so their sum points there with less
/// noise than the failures' mean alone: in d dimensions that noise costs e^{|δ⊥|²} in
/// variance, with |δ⊥|² ≈ (d − 1)/n_eff for the failures' mean.
fn single_centre(levels: &[Vec<Sample>], failures: &[Sample]) -> Vec<f64> {
    let d = failures[0].u.len();
    let mut sum = mean(&failures.iter().collect::<Vec<_>>());
    for level in levels.iter().skip(1) {
        let m = mean(&level.iter().collect::<Vec<_>>());
        sum.iter_mut().zip(&m).for_each(|(a, b)| *a += b);
    }
    let len = norm(&sum);
    let e: Vec<f64> = sum.iter().map(|x| x / len).collect();
    let r = failures.iter().map(|s| dot(&s.u, &e)).sum::<f64>() / failures.len() as f64;
    (0..d).map(|i| r * e[i]).collect()
}

/// Groups samples: starting from one group, a group that spreads wider than a flat
/// boundary allows is split in two, until every group is flat. `Err` when that takes more
/// than `max_groups` groups.
fn groups(samples: &[Sample], max_groups: usize) -> Result<Vec<Vec<&Sample>>, String> {
    let d = samples[0].u.len();
    let mut groups: Vec<Vec<&Sample>> = vec![samples.iter().collect()];
    loop {
        let wide = groups
            .iter()
            .position(|g| g.len() >= 5 && excess_spread(g) > spread_allowed(d));
        let Some(k) = wide else { break };
        if groups.len() >= max_groups {
            return Err(format!(
                "they do not fall into {max_groups} or fewer groups with flat boundaries (a failure domain curved around the origin, or in several parts)"
            ));
        }
        let (a, b) = split(&groups[k]);
        if a.is_empty() || b.is_empty() {
            return Err(
                "they cannot be split into groups with flat boundaries (a failure domain curved around the origin)"
                    .into(),
            );
        }
        groups.swap_remove(k);
        groups.push(a);
        groups.push(b);
    }
    if groups.iter().any(|g| norm(&mean(g)) < 1.0) {
        return Err("a group of them is centred near the origin".into());
    }
    Ok(groups)
}

/// Fits the first density. The samples of every subset level above 0 (each conditioned on
/// a threshold) must form at most `max_components` groups with flat boundaries, so that a
/// part of the domain that the last level's failures missed still shows; one component
/// then sits at the mean of each group of failing samples, weighted by its size (blended
/// with an equal share). `Err` says why importance sampling does not suit the domain.
pub fn fit(
    levels: &[Vec<Sample>],
    failures: &[Sample],
    max_components: usize,
) -> Result<Vec<Component>, String> {
    if failures.is_empty() {
        return Err("subset simulation found no failing sample to fit a density to".into());
    }
    for (j, level) in levels.iter().enumerate().skip(1) {
        groups(level, max_components)
            .map_err(|e| format!("the samples of subset level {j}: {e}"))?;
    }
    let found =
        groups(failures, max_components).map_err(|e| format!("the failing samples: {e}"))?;
    let k = found.len();
    if k == 1 {
        return Ok(vec![Component {
            mean: single_centre(levels, failures),
            weight: 1.0,
        }]);
    }
    let total = failures.len() as f64;
    Ok(found
        .iter()
        .map(|g| Component {
            mean: mean(g),
            weight: blend(g.len() as f64 / total, k),
        })
        .collect())
}

/// log of φ_d(u)/Σ_k π_k φ_d(u − m_k) = −log Σ_k π_k exp(m_k·u − |m_k|²/2).
fn log_weight(u: &[f64], mixture: &[Component]) -> f64 {
    let terms: Vec<f64> = mixture
        .iter()
        .map(|c| c.weight.ln() + dot(&c.mean, u) - 0.5 * dot(&c.mean, &c.mean))
        .collect();
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    -(top + terms.iter().map(|t| (t - top).exp()).sum::<f64>().ln())
}

/// The responsibility of each component for u.
fn responsibilities(u: &[f64], mixture: &[Component]) -> Vec<f64> {
    let terms: Vec<f64> = mixture
        .iter()
        .map(|c| c.weight.ln() + dot(&c.mean, u) - 0.5 * dot(&c.mean, &c.mean))
        .collect();
    let top = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let e: Vec<f64> = terms.iter().map(|t| (t - top).exp()).collect();
    let s: f64 = e.iter().sum();
    e.into_iter().map(|x| x / s).collect()
}

/// The cross-entropy update: each component's mean and share from the weighted failures,
/// split by responsibility; a component no failure reached keeps its mean.
fn recentre(mixture: &[Component], samples: &[(Sample, f64)]) -> Vec<Component> {
    let d = mixture[0].mean.len();
    let mut sums = vec![vec![0.0; d]; mixture.len()];
    let mut mass = vec![0.0; mixture.len()];
    for (s, w) in samples.iter().filter(|(_, w)| *w > 0.0) {
        for (k, r) in responsibilities(&s.u, mixture).into_iter().enumerate() {
            mass[k] += w * r;
            sums[k]
                .iter_mut()
                .zip(&s.u)
                .for_each(|(a, b)| *a += w * r * b);
        }
    }
    let total: f64 = mass.iter().sum();
    if total <= 0.0 {
        return mixture.to_vec();
    }
    // the weighted mean's noise across its direction, |δ⊥|² ≈ (d − 1)/ESS, costs e^{|δ⊥|²}
    let w: Vec<f64> = samples
        .iter()
        .map(|(_, w)| *w)
        .filter(|w| *w > 0.0)
        .collect();
    let ess = w.iter().sum::<f64>().powi(2) / w.iter().map(|x| x * x).sum::<f64>();
    if let ([c], true) = (mixture, (d - 1) as f64 > 0.25 * ess) {
        // then one component keeps its direction, whose noise the levels of subset
        // simulation averaged down, and moves only along it
        let len = norm(&c.mean);
        let along = dot(&sums[0], &c.mean) / (len * mass[0]);
        return vec![Component {
            mean: c.mean.iter().map(|x| x * along / len).collect(),
            weight: 1.0,
        }];
    }
    mixture
        .iter()
        .zip(sums.iter().zip(&mass))
        .map(|(c, (sum, &m))| Component {
            mean: if m > 0.0 {
                sum.iter().map(|x| x / m).collect()
            } else {
                c.mean.clone()
            },
            weight: blend(m / total, mixture.len()),
        })
        .collect()
}

/// A component's weight: half its share of the failures, half an equal share. A part of
/// the domain that the early samples under-hit keeps at least 1/(2K) of the samples, so
/// its weights stay within 2K of φ's and one round cannot starve it.
fn blend(share: f64, components: usize) -> f64 {
    0.5 * share + 0.5 / components as f64
}

/// The estimate and its coefficient of variation from the weights (0 for non-failures).
fn estimate(samples: &[(Sample, f64)]) -> (f64, f64) {
    let n = samples.len() as f64;
    let p = samples.iter().map(|(_, w)| w).sum::<f64>() / n;
    if p <= 0.0 {
        return (0.0, f64::INFINITY);
    }
    let var = samples.iter().map(|(_, w)| (w - p).powi(2)).sum::<f64>() / (n - 1.0);
    (p, (var / n).sqrt() / p)
}

/// Draws `n` points of the mixture for batch `batch`.
fn draw(s: &ImportanceSettings, mixture: &[Component], batch: u64, n: usize) -> Vec<Vec<f64>> {
    let d = mixture[0].mean.len();
    (0..n)
        .map(|i| {
            let pick = normal::keyed_unit(&[s.seed, batch, i as u64, u64::MAX]);
            let mut acc = 0.0;
            let k = mixture
                .iter()
                .position(|c| {
                    acc += c.weight;
                    pick < acc
                })
                .unwrap_or(mixture.len() - 1);
            let xi = normal::keyed_vector(&[s.seed, batch, i as u64], d);
            xi.iter()
                .zip(&mixture[k].mean)
                .map(|(x, m)| x + m)
                .collect()
        })
        .collect()
}

/// Simulates one round at `mixture`; every sample with its weight (0 if it passes).
fn round(
    s: &ImportanceSettings,
    mixture: &[Component],
    n: usize,
    level: u64,
    cursor: &mut Cursor,
) -> Result<Vec<(Sample, f64)>, Request> {
    let points = draw(s, mixture, cursor.batch(), n);
    let g = cursor.evaluate(points.clone(), |_| (Stage::Importance, level, None))?;
    Ok(points
        .into_iter()
        .zip(g)
        .map(|(u, g)| {
            let w = if g <= 0.0 {
                log_weight(&u, mixture).exp()
            } else {
                0.0
            };
            (Sample { u, g }, w)
        })
        .collect())
}

/// Pilot rounds before the estimate.
const PILOT_ROUNDS: u64 = 1;

/// Rounds of the estimate after which it stops, whatever its CoV.
const MAX_ROUNDS: u64 = 50;

/// Adapts the mixture over pilot rounds (cross-entropy updates), then estimates at the
/// adapted mixture, held fixed, in rounds until the CoV meets the target. The estimate
/// uses those rounds alone, so the pilot's choices do not bias it.
pub fn run(
    s: &ImportanceSettings,
    mut mixture: Vec<Component>,
    cursor: &mut Cursor,
) -> Result<ImportanceResult, Request> {
    let start = cursor.simulations();
    let mut pilot: Vec<(Sample, f64)> = Vec::new();
    for r in 0..PILOT_ROUNDS {
        if cursor.simulations() - start + 2 * s.batch as u64 > s.max_simulations {
            break;
        }
        pilot.extend(round(s, &mixture, s.batch, r, cursor)?);
        mixture = recentre(&mixture, &pilot);
    }
    let mut samples: Vec<(Sample, f64)> = Vec::new();
    let (mut p, mut cov) = (0.0, f64::INFINITY);
    let mut gave_up = None;
    for r in PILOT_ROUNDS..PILOT_ROUNDS + MAX_ROUNDS {
        if cursor.simulations() - start + s.batch as u64 > s.max_simulations {
            break;
        }
        samples.extend(round(s, &mixture, s.batch, r, cursor)?);
        (p, cov) = estimate(&samples);
        if cov <= s.target_cov && samples.iter().filter(|(_, w)| *w > 0.0).count() >= 10 {
            break;
        }
        let projected = samples.len() as f64 * (cov / s.target_cov).powi(2);
        if samples.len() >= 2 * s.batch && projected > s.patience as f64 {
            gave_up = Some(projected.ceil() as u64);
            break;
        }
    }
    let weights: Vec<f64> = samples
        .iter()
        .map(|(_, w)| *w)
        .filter(|w| *w > 0.0)
        .collect();
    let sum: f64 = weights.iter().sum();
    let sq: f64 = weights.iter().map(|w| w * w).sum();
    let rounds = PILOT_ROUNDS + (samples.len() / s.batch) as u64;
    pilot.extend(samples);
    Ok(ImportanceResult {
        figures: ImportanceFigures {
            probability: p,
            cov,
            simulations: cursor.simulations() - start,
            rounds,
            failures: weights.len() as u64,
            ess: if sq > 0.0 { sum * sum / sq } else { 0.0 },
            largest_share: if sum > 0.0 {
                weights.iter().copied().fold(0.0, f64::max) / sum
            } else {
                0.0
            },
            components: mixture,
        },
        gave_up,
        samples: pilot,
    })
}
