//! Monte-Carlo studies: the study file (scene, design, input distributions, outputs,
//! limits, fidelity), the sampled inputs of each run, the parallel runner and its Parquet
//! store, merging, and the summary statistics. See docs/studies.md.

mod build;
pub mod compare;
pub mod converge;
pub mod copula;
pub mod curves;
pub mod design;
pub mod distribution;
pub mod given_data;
pub mod manifest;
pub mod merge;
pub mod runner;
pub mod sample_run;
mod schema;
pub mod sensitivity;
pub mod slurm;
pub mod sobol;
pub mod statistics;
pub mod stop_signals;
pub mod store;
pub mod summary;
pub mod tolerance;

use crate::input::units::DisplayUnit;
use crate::scene::{SceneError, Tuning};
pub use copula::Copula;
pub use design::{Design, DesignKind};
pub use distribution::Distribution;
pub use sample_run::{Diagnostics, Outcome, Subject};
use schema::{DistributionSpec, StudySpec, ToleranceSpec};
use serde_saphyr::Spanned;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
pub use tolerance::{Cost, Drawing};

/// An error in a study: in the study file itself (its file, line and field), in the scene
/// the study names (the scene file's own line and field), or in a shard specification.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyError {
    #[error("{0}")]
    Study(SceneError),
    #[error("{0}")]
    Scene(SceneError),
    #[error("{0}")]
    Shard(String),
}

/// Errors located in the study file (the scene's are wrapped explicitly).
impl From<SceneError> for StudyError {
    fn from(e: SceneError) -> Self {
        StudyError::Study(e)
    }
}

impl StudyError {
    /// The located error (file, line, field), for the study and scene variants.
    pub fn located(&self) -> Option<&SceneError> {
        match self {
            StudyError::Study(e) | StudyError::Scene(e) => Some(e),
            StudyError::Shard(_) => None,
        }
    }
}

/// A sampled input.
#[derive(Clone, Debug, PartialEq)]
pub struct Parameter {
    pub path: String,
    pub distribution: Distribution,
    /// SI unit of the values ("m", "1"; empty for function inputs).
    pub unit: String,
    /// The drawing's statement, for a parameter given as a `tolerance`.
    pub drawing: Option<Drawing>,
    /// The cost of its tolerance (tolerance allocation).
    pub cost: Cost,
}

/// An output of the subject, with what the study says of it (its specification limits).
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    pub name: String,
    /// SI unit of the values.
    pub unit: String,
    /// Index among the subject's outputs.
    pub index: usize,
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    /// The unit the scene asks to show it in; `None`: chosen from the values.
    pub display: Option<DisplayUnit>,
    /// Why the value depends on the step size, for an output that is not a converged
    /// quantity (the peak of an impulsive force); `None` otherwise.
    pub caution: Option<String>,
    /// The output may have no value in a run that otherwise went through (an optional
    /// probe whose event did not happen).
    pub optional: bool,
}

/// A validated study, ready to run.
#[derive(Clone, Debug)]
pub struct Study {
    pub name: String,
    pub description: String,
    /// The study file's text and the scene file's text (stored with the results).
    pub text: String,
    pub scene_text: String,
    pub scene_path: PathBuf,
    pub subject: Subject,
    pub design: Design,
    pub seed: u64,
    pub parameters: Vec<Parameter>,
    pub outputs: Vec<Output>,
    pub output_dir: PathBuf,
    /// Suspect samples count as failures (`suspect: fail`) rather than as flagged values.
    pub suspect_fails: bool,
    /// A rare-event estimate instead of plain sampling (`reliability:`).
    pub reliability: Option<RareEvent>,
    /// The dependence between the parameters (`correlations:`).
    pub copula: Copula,
    /// What `mc-study allocate` must meet (`allocation:`).
    pub allocation: Option<AllocationTarget>,
    /// For the runs of an adaptive search (the worst case) rather than of the design.
    pub search: Option<Search>,
    /// The measured points of the curves that name a `reference`, read from their files
    /// (empty for a study rebuilt from the texts stored with its results).
    pub references: Vec<curves::Reference>,
}

/// An adaptive search run as a study: its kind and the most runs it may take.
#[derive(Clone, Debug, PartialEq)]
pub struct Search {
    pub kind: &'static str,
    pub runs: u64,
}

/// The `allocation:` block of a study, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct AllocationTarget {
    /// The smallest Cpk each output must reach (a ppm target converts to it through the
    /// normal model).
    pub cpk: f64,
    /// The ppm the study asked for, if it did.
    pub ppm: Option<f64>,
    /// The outputs (indices into `Study::outputs`) the target applies to.
    pub outputs: Vec<usize>,
    /// The range of tolerance ratios t / t₀ allowed.
    pub narrowest: f64,
    pub widest: f64,
}

/// What a sample whose simulation failed counts as in a rare-event study.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailedSamples {
    /// A failure of the mechanism (the default: near the limits, a failed run must not
    /// pass silently).
    Fail,
    Pass,
    /// Stop the study with an error.
    Error,
}

/// The `reliability:` block of a study, validated.
#[derive(Clone, Debug, PartialEq)]
pub struct RareEvent {
    /// `subset` or `monte-carlo`.
    pub method: String,
    pub target_cov: f64,
    pub p0: f64,
    pub max_simulations: u64,
    pub importance: bool,
    /// The outputs (indices into `Study::outputs`) whose limits define failure.
    pub outputs: Vec<usize>,
    pub failed_samples: FailedSamples,
}

impl Study {
    /// Reads and validates a study file; `samples` overrides its `samples`.
    pub fn load(path: &Path, samples: Option<u64>) -> Result<Study, StudyError> {
        let file = path.display().to_string();
        let text = crate::input::file::read(path).map_err(|e| SceneError {
            file: Some(file.clone()),
            line: None,
            field: String::new(),
            message: format!("cannot read the study file: {e}"),
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Study::from_yaml(&text, &file, base, samples)
    }

    /// Parses and validates study text; `base` is the directory of the study file, which
    /// the paths written in it (`scene`, `output`) are relative to.
    pub fn from_yaml(
        text: &str,
        file: &str,
        base: &Path,
        samples: Option<u64>,
    ) -> Result<Study, StudyError> {
        Study::parse(text, file, base, None, samples)
    }

    /// The study of a result directory, from the study and scene texts stored with its
    /// results (nothing is read from disk).
    pub fn from_texts(
        text: &str,
        scene_text: &str,
        file: &str,
        samples: Option<u64>,
    ) -> Result<Study, StudyError> {
        Study::parse(text, file, Path::new(""), Some(scene_text), samples)
    }

    fn parse(
        text: &str,
        file: &str,
        base: &Path,
        scene_text: Option<&str>,
        samples: Option<u64>,
    ) -> Result<Study, StudyError> {
        let spec: StudySpec =
            serde_saphyr::from_str(text).map_err(|e| SceneError::from_yaml(file, &e))?;
        Study::build(spec, text, base, scene_text, samples).map_err(|e| match e {
            StudyError::Study(e) if e.file.is_none() => StudyError::Study(e.in_file(file)),
            e => e,
        })
    }

    /// Total runs (sample ids 0..runs); for a rare-event study, the most it may take.
    pub fn runs(&self) -> u64 {
        match (&self.search, &self.reliability) {
            (Some(s), _) => s.runs,
            (None, Some(r)) => r.max_simulations,
            (None, None) => self.design.runs(),
        }
    }

    /// The study as the runs of an adaptive search into `out`: `settings` (written into
    /// the stored study text) make its result directory its own.
    pub fn for_search(&self, kind: &'static str, settings: &str, runs: u64, out: PathBuf) -> Study {
        let mut s = self.clone();
        s.text = format!("{}\n# {kind}: {settings}\n", self.text.trim_end());
        s.output_dir = out;
        s.search = Some(Search { kind, runs });
        s
    }

    /// The inputs (SI) at standard-normal coordinates u, one per parameter.
    /// The coordinates are independent; correlated parameters take them through the copula.
    pub fn inputs_at_standard(&self, u: &[f64]) -> Vec<f64> {
        self.parameters
            .iter()
            .zip(self.copula.correlate(u))
            .map(|(p, z)| p.distribution.from_standard(z))
            .collect()
    }

    /// Sample i's inputs (SI), in `parameters` order.
    pub fn inputs(&self, i: u64) -> Vec<f64> {
        let point = self.design.point(i);
        if !self.copula.is_independent() {
            let z: Vec<f64> = point.iter().map(|&u| statistics::probit(u)).collect();
            return self.inputs_at_standard(&z);
        }
        point
            .iter()
            .zip(&self.parameters)
            .map(|(&u, p)| p.distribution.quantile(u))
            .collect()
    }

    /// Runs sample i.
    pub fn run_sample(&self, i: u64) -> (Vec<f64>, Outcome) {
        let x = self.inputs(i);
        (x.clone(), self.run_inputs(&x))
    }

    /// Runs the subject at inputs `x` (SI, in `parameters` order).
    pub fn run_inputs(&self, x: &[f64]) -> Outcome {
        let params: Vec<(&str, f64)> = self
            .parameters
            .iter()
            .map(|p| p.path.as_str())
            .zip(x.iter().copied())
            .collect();
        let selected: Vec<usize> = self.outputs.iter().map(|o| o.index).collect();
        self.subject.run(&params, &selected)
    }

    /// SHA-256 over what determines the results: the tool version, the study and scene
    /// texts and the effective sample count.
    pub fn hash(&self) -> String {
        let mut h = Sha256::new();
        h.update(format!("mc-study {}\n", env!("CARGO_PKG_VERSION")));
        h.update(self.text.as_bytes());
        h.update(b"\n--- scene ---\n");
        h.update(self.scene_text.as_bytes());
        h.update(format!("\n--- samples {} ---\n", self.design.base));
        h.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }
}
