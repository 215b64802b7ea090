//! Rare-event probabilities: the chance that a mechanism's outputs leave their limits, down
//! to parts per million, with an interval, in thousands of simulations rather than
//! hundreds of millions. See docs/reliability.md.
//!
//! The algorithms work in standard-normal space on a margin g(u) whose sign says pass
//! (g > 0) or fail (g ≤ 0): [`subset`] simulation finds its way to the failure domain level
//! by level, and [`importance`] sampling refines the estimate with a density fitted to the
//! failures it found. Both ask the runner for batches through [`batch`]; [`study`] turns a
//! study's outputs and limits into the margin and stores every simulation.

pub mod batch;
pub mod importance;
pub mod normal;
pub mod study;
pub mod subset;

use batch::{Cursor, Margins, Request, Stage};
use importance::{ImportanceFigures, ImportanceSettings};
use subset::{Level, SubsetSettings};

/// Which estimator a reliability study runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Subset simulation, refined by importance sampling where the failure domain allows.
    Subset,
    /// Plain Monte-Carlo in batches, until the target CoV or the budget: the reference at
    /// moderate rates.
    MonteCarlo,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Subset => "subset",
            Method::MonteCarlo => "monte-carlo",
        }
    }
}

/// How a rare-event estimate is run.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub method: Method,
    /// Samples per subset level, and per importance or Monte-Carlo batch.
    pub level_samples: usize,
    pub p0: f64,
    /// The coefficient of variation to reach.
    pub target_cov: f64,
    /// Refine subset simulation by importance sampling.
    pub importance: bool,
    pub max_simulations: u64,
    pub max_levels: usize,
    pub max_components: usize,
    pub seed: u64,
}

impl Settings {
    pub fn new(method: Method, level_samples: usize, target_cov: f64, seed: u64) -> Settings {
        Settings {
            method,
            level_samples,
            p0: 0.1,
            target_cov,
            importance: true,
            max_simulations: 100_000,
            max_levels: 20,
            max_components: 1,
            seed,
        }
    }

    fn subset(&self) -> SubsetSettings {
        SubsetSettings {
            level_samples: self.level_samples,
            p0: self.p0,
            max_levels: self.max_levels,
            max_simulations: self.max_simulations,
            seed: self.seed,
        }
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(self.target_cov > 0.0 && self.target_cov.is_finite()) {
            return Err(format!("target_cov must be > 0, got {}", self.target_cov));
        }
        if self.level_samples < 2 {
            return Err("needs at least 2 samples per level".into());
        }
        if self.max_simulations < self.level_samples as u64 {
            return Err(format!(
                "max_simulations ({}) is smaller than one level ({} samples)",
                self.max_simulations, self.level_samples
            ));
        }
        match self.method {
            Method::Subset => self.subset().validate(),
            Method::MonteCarlo => Ok(()),
        }
    }
}

/// The subset stage's figures.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SubsetSummary {
    pub probability: f64,
    pub cov: f64,
    pub simulations: u64,
    pub levels: Vec<Level>,
}

/// The importance stage's figures, and how far it lies from subset simulation's.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ImportanceSummary {
    #[serde(flatten)]
    pub figures: ImportanceFigures,
    /// |ln P_IS − ln P_subset| over their combined log-scale standard deviation, the subset
    /// one at its upper bound (levels fully correlated).
    pub disagreement: f64,
}

/// A rare-event estimate, with its uncertainty and how it was reached.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub method: String,
    pub probability: f64,
    /// Coefficient of variation of the probability.
    pub cov: f64,
    /// 95 % interval of the probability.
    pub interval: (f64, f64),
    /// β = −Φ⁻¹(p), and its 95 % interval.
    pub beta: f64,
    pub beta_interval: (f64, f64),
    pub simulations: u64,
    /// Samples per subset level (or per Monte-Carlo batch).
    pub level_samples: u64,
    /// The stage whose number is the final one.
    pub stage: String,
    /// The figure is an upper bound, not an estimate (the failure domain was not reached).
    pub upper_bound: bool,
    pub failures_seen: u64,
    pub subset: Option<SubsetSummary>,
    pub importance: Option<ImportanceSummary>,
    /// What the reader must know: a stage skipped or overruled, a target not met.
    pub notes: Vec<String>,
    /// The failing simulation closest to the origin in standard space (the most probable
    /// failure point), its id, and its margin.
    pub design_point: Option<DesignPoint>,
    /// (m, P(g ≤ m), its CoV) for the tail plot.
    pub tail: Vec<(f64, f64, f64)>,
}

#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DesignPoint {
    pub u: Vec<f64>,
    pub margin: f64,
    /// |u|: the reliability index a linear margin through this point would give.
    pub distance: f64,
}

/// Where an estimate stands: done, or waiting for a batch.
#[derive(Clone, Debug, PartialEq)]
pub enum Progress {
    Done(Box<Estimate>),
    Needs(Request),
}

/// 95 % interval of a positive estimate with coefficient of variation `cov`, lognormal so
/// that it stays positive and is skewed as the estimators are.
pub fn interval(p: f64, cov: f64) -> (f64, f64) {
    if p.is_nan() || p <= 0.0 || !cov.is_finite() {
        return (0.0, if p > 0.0 { 1.0 } else { 0.0 });
    }
    let s = log_sd(cov);
    let z = normal::quantile(0.975);
    (p * (-z * s).exp(), (p * (z * s).exp()).min(1.0))
}

/// The standard deviation of ln P̂ for a lognormal estimate with coefficient of variation
/// `cov`.
fn log_sd(cov: f64) -> f64 {
    (1.0 + cov * cov).ln().sqrt()
}

fn nearest_failure<'a>(points: impl Iterator<Item = (&'a [f64], f64)>) -> Option<DesignPoint> {
    points
        .filter(|(_, g)| *g <= 0.0)
        .map(|(u, g)| (u, g, u.iter().map(|x| x * x).sum::<f64>().sqrt()))
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .map(|(u, g, r)| DesignPoint {
            u: u.to_vec(),
            margin: g,
            distance: r,
        })
}

/// Runs the estimate as far as the stored margins allow.
pub fn run(settings: &Settings, d: usize, margins: &mut dyn Margins) -> Progress {
    let mut cursor = Cursor::new(margins);
    let r = match settings.method {
        Method::Subset => subset_then_importance(settings, d, &mut cursor),
        Method::MonteCarlo => monte_carlo(settings, d, &mut cursor),
    };
    match r {
        Ok(e) => Progress::Done(Box::new(e)),
        Err(request) => Progress::Needs(request),
    }
}

fn finish(mut e: Estimate, target: f64) -> Estimate {
    e.interval = if e.upper_bound {
        (0.0, e.probability)
    } else {
        interval(e.probability, e.cov)
    };
    e.beta = normal::beta(e.probability);
    e.beta_interval = (normal::beta(e.interval.1), normal::beta(e.interval.0));
    if !e.upper_bound && e.cov > target {
        e.notes.push(if e.stage == Stage::Subset.name() {
            format!(
                "the coefficient of variation {:.3} is above the target {target}: subset simulation's falls as 1/√N, so the target would take about {:.0} samples per level",
                e.cov,
                (e.level_samples as f64 * (e.cov / target).powi(2)).ceil()
            )
        } else {
            format!(
                "the coefficient of variation {:.3} is above the target {target}: raise max_simulations",
                e.cov
            )
        });
    }
    e
}

fn subset_then_importance(
    s: &Settings,
    d: usize,
    cursor: &mut Cursor,
) -> Result<Estimate, Request> {
    let sus = subset::run(&s.subset(), d, cursor)?;
    let mut notes = Vec::new();
    let mut chosen = (sus.probability, sus.cov, Stage::Subset);
    let mut importance = None;
    let mut is_samples = Vec::new();
    if let Some(why) = &sus.incomplete {
        notes.push(why.clone());
    } else if s.importance && sus.cov > s.target_cov {
        let failures: Vec<_> = sus
            .all_levels
            .last()
            .expect("level 0 at least")
            .iter()
            .filter(|x| x.g <= 0.0)
            .cloned()
            .collect();
        let budget = s.max_simulations.saturating_sub(cursor.simulations());
        match importance::fit(&sus.all_levels, &failures, s.max_components) {
            Err(why) => notes.push(format!(
                "importance sampling skipped: {why}; the subset estimate stands"
            )),
            Ok(_) if budget < 3 * s.level_samples as u64 => notes.push(
                "importance sampling skipped: the budget is spent; the subset estimate stands"
                    .into(),
            ),
            Ok(mixture) => {
                let importance::ImportanceResult {
                    figures: r,
                    gave_up,
                    samples,
                } = importance::run(
                    &ImportanceSettings {
                        batch: s.level_samples,
                        target_cov: s.target_cov,
                        max_simulations: budget,
                        patience: 10 * sus.simulations,
                        seed: s.seed,
                    },
                    mixture,
                    cursor,
                )?;
                let z = if r.probability > 0.0 {
                    (r.probability.ln() - sus.probability.ln()).abs()
                        / (log_sd(r.cov).powi(2) + log_sd(sus.cov_upper).powi(2)).sqrt()
                } else {
                    f64::INFINITY
                };
                let overruled = if let Some(n) = gave_up {
                    Some(format!(
                        "it stopped after {} simulations: at its CoV of {:.3} the target would take about {n} (the sampling density fits the failure domain poorly)",
                        r.simulations, r.cov
                    ))
                } else if r.cov >= sus.cov {
                    Some(format!(
                        "its CoV {:.3} is no better than subset simulation's {:.3} (the sampling density fits the failure domain poorly)",
                        r.cov, sus.cov
                    ))
                } else if r.failures < 10 {
                    Some(format!("only {} failing samples", r.failures))
                } else if r.largest_share > 0.5 {
                    Some(format!(
                        "one sample carries {:.0} % of the weight",
                        100.0 * r.largest_share
                    ))
                } else if z > 3.0 {
                    Some(format!(
                        "it disagrees with subset simulation ({:.3e} against {:.3e}, {z:.1} combined standard deviations apart): a finding to look into, not noise",
                        r.probability, sus.probability
                    ))
                } else {
                    None
                };
                match overruled {
                    Some(why) => notes.push(format!(
                        "importance sampling overruled: {why}; the subset estimate stands"
                    )),
                    None => chosen = (r.probability, r.cov, Stage::Importance),
                }
                importance = Some(ImportanceSummary {
                    figures: r,
                    disagreement: z,
                });
                is_samples = samples;
            }
        }
    }
    let failures_seen = sus
        .all_levels
        .iter()
        .flatten()
        .filter(|x| x.g <= 0.0)
        .count()
        + is_samples.iter().filter(|(x, _)| x.g <= 0.0).count();
    let design_point = nearest_failure(
        sus.all_levels
            .iter()
            .flatten()
            .chain(is_samples.iter().map(|(x, _)| x))
            .map(|x| (x.u.as_slice(), x.g)),
    );
    let e = Estimate {
        method: Method::Subset.name().into(),
        probability: chosen.0,
        cov: chosen.1,
        interval: (0.0, 0.0),
        beta: 0.0,
        beta_interval: (0.0, 0.0),
        simulations: cursor.simulations(),
        level_samples: s.level_samples as u64,
        stage: chosen.2.name().into(),
        upper_bound: sus.incomplete.is_some(),
        failures_seen: failures_seen as u64,
        tail: subset::tail_curve(&sus),
        subset: Some(SubsetSummary {
            probability: sus.probability,
            cov: sus.cov,
            simulations: sus.simulations,
            levels: sus.levels,
        }),
        importance,
        notes,
        design_point,
    };
    Ok(finish(e, s.target_cov))
}

fn monte_carlo(s: &Settings, d: usize, cursor: &mut Cursor) -> Result<Estimate, Request> {
    let mut failing: Vec<(Vec<f64>, f64)> = Vec::new();
    let mut all_g = Vec::new();
    let (mut p, mut cov) = (0.0, f64::INFINITY);
    while cursor.simulations() + s.level_samples as u64 <= s.max_simulations {
        let batch = cursor.batch();
        let points: Vec<Vec<f64>> = (0..s.level_samples)
            .map(|i| normal::keyed_vector(&[s.seed, batch, i as u64], d))
            .collect();
        let round = batch;
        let g = cursor.evaluate(points.clone(), |_| (Stage::MonteCarlo, round, None))?;
        for (u, g) in points.into_iter().zip(g) {
            all_g.push(g);
            if g <= 0.0 {
                failing.push((u, g));
            }
        }
        let n = all_g.len() as f64;
        p = failing.len() as f64 / n;
        cov = ((1.0 - p) / (n * p)).sqrt();
        if cov <= s.target_cov {
            break;
        }
    }
    let n = cursor.simulations();
    let k = failing.len() as u64;
    all_g.sort_by(f64::total_cmp);
    let tail = all_g
        .iter()
        .enumerate()
        .filter(|(_, g)| g.is_finite())
        .map(|(i, &g)| {
            let p = (i + 1) as f64 / n as f64;
            (g, p, ((1.0 - p) / (n as f64 * p)).sqrt())
        })
        .collect();
    let mut e = Estimate {
        method: Method::MonteCarlo.name().into(),
        probability: p,
        cov,
        interval: (0.0, 0.0),
        beta: 0.0,
        beta_interval: (0.0, 0.0),
        simulations: n,
        level_samples: s.level_samples as u64,
        stage: Stage::MonteCarlo.name().into(),
        upper_bound: k == 0,
        failures_seen: k,
        subset: None,
        importance: None,
        notes: Vec::new(),
        design_point: nearest_failure(failing.iter().map(|(u, g)| (u.as_slice(), *g))),
        tail,
    };
    if k == 0 {
        // the exact one-sided 95 % bound for no failure in n trials
        e.probability = 1.0 - 0.05f64.powf(1.0 / n as f64);
        e.notes.push(format!(
            "no failure in {n} simulations: the figure is the 95 % upper bound"
        ));
    }
    let mut e = finish(e, s.target_cov);
    if k > 0 {
        e.interval = crate::study::statistics::wilson95(k, n);
        e.beta_interval = (normal::beta(e.interval.1), normal::beta(e.interval.0));
    }
    Ok(e)
}
