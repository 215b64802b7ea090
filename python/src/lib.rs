//! The Python bindings of mc-study (`mc_study._native`): a thin layer over the Rust crate,
//! with no logic of its own. The Python package `mc_study` wraps these in its documented
//! API (docs/python.md); the engine's errors become `McStudyError` with the same messages.

use mc_study::commands::MAX_THREADS;
use mc_study::single_run::{simulate as simulate_scene, SimulateOptions};
use mc_study::study::merge::merge;
use mc_study::study::runner::{self, RunOptions, Shard};
use mc_study::study::sample_run::Subject;
use mc_study::study::Study;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::sync::Arc;
use std::time::Duration;

create_exception!(_native, McStudyError, PyException);

/// Any engine error as a `McStudyError` carrying its message (file, line and field).
fn error(e: impl std::fmt::Display) -> PyErr {
    McStudyError::new_err(e.to_string())
}

/// Refuses a thread count the command line would refuse (`--threads`).
fn check_threads(threads: Option<usize>) -> PyResult<()> {
    match threads {
        Some(t) if !(1..=MAX_THREADS).contains(&t) => Err(error(format!(
            "threads = {t}: give a number from 1 to {MAX_THREADS} (default: all cores)"
        ))),
        _ => Ok(()),
    }
}

/// Runs `work` with the GIL released, on its own thread, while this one checks Python's
/// signals every 20 ms until it ends: on Ctrl-C (or any signal whose Python handler
/// raises) it sets `stop`, which the work polls to finish early and cleanly, and the
/// exception is returned with the work's result.
fn interruptible<T: Send>(
    py: Python<'_>,
    stop: &AtomicBool,
    work: impl FnOnce() -> T + Send,
) -> (T, Option<PyErr>) {
    py.detach(|| {
        std::thread::scope(|scope| {
            let (done, finished) = std::sync::mpsc::channel();
            let handle = scope.spawn(move || {
                let value = work();
                let _ = done.send(());
                value
            });
            let mut raised = None;
            // woken at once when the work ends, every 20 ms otherwise
            while let Err(RecvTimeoutError::Timeout) =
                finished.recv_timeout(Duration::from_millis(20))
            {
                if raised.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        stop.store(true, Ordering::SeqCst);
                        raised = Some(e);
                    }
                }
            }
            let value = handle
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p));
            (value, raised)
        })
    })
}

/// A mechanism or function scene, with `--set`'s parameter paths.
#[pyclass(name = "Scene", module = "mc_study._native")]
#[derive(Clone)]
struct PyScene {
    subject: Subject,
    source: String,
}

#[pymethods]
impl PyScene {
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let source = path.display().to_string();
        let text = mc_study::input::file::read(&path)
            .map_err(|e| error(format!("{source}: cannot read the scene file: {e}")))?;
        Ok(PyScene {
            subject: Subject::from_yaml(&text, &source).map_err(error)?,
            source,
        })
    }

    #[staticmethod]
    #[pyo3(signature = (text, name = "scene"))]
    fn from_yaml(text: &str, name: &str) -> PyResult<Self> {
        Ok(PyScene {
            subject: Subject::from_yaml(text, name).map_err(error)?,
            source: name.to_string(),
        })
    }

    /// Sets a parameter path to a number (SI) or a string with a unit (`"0.1 mm"`).
    fn set(&mut self, path: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let si = match value.extract::<f64>() {
            Ok(v) => v,
            Err(_) => {
                let text: String = value.extract()?;
                if let Subject::Mechanism(s) = &mut self.subject {
                    // as `--set PATH=VALUE`: the unit is checked against the path's
                    return s.apply_setting(&format!("{path}={text}")).map_err(error);
                }
                text.trim()
                    .parse()
                    .map_err(|_| error(format!("{path}: `{text}` is not a number")))?
            }
        };
        match &mut self.subject {
            Subject::Mechanism(s) => s.set_parameter(path, si).map_err(error),
            Subject::Function(f) => f.set_parameter(path, si).map_err(error),
        }
    }

    /// The parameter paths the scene accepts.
    fn paths(&self) -> Vec<String> {
        match &self.subject {
            Subject::Mechanism(s) => s.parameters().into_iter().map(|p| p.path).collect(),
            Subject::Function(f) => f.inputs.clone(),
        }
    }

    /// The outputs' names, in order.
    fn outputs(&self) -> Vec<String> {
        self.subject.outputs().into_iter().map(|o| o.name).collect()
    }

    #[getter]
    fn source(&self) -> String {
        self.source.clone()
    }
}

/// Simulates a mechanism scene as `mc-study simulate` does, writing its trajectory to
/// `trajectory` (.parquet or .csv) if given. Returns the probes, diagnostics and error.
#[pyfunction]
#[pyo3(signature = (scene, trajectory = None))]
fn simulate<'py>(
    py: Python<'py>,
    scene: &PyScene,
    trajectory: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    let Subject::Mechanism(s) = &scene.subject else {
        return Err(error(
            "simulate needs a mechanism scene; a function scene is evaluated with `evaluate`",
        ));
    };
    let options = SimulateOptions {
        duration: None,
        trajectory,
        drawing: None,
    };
    let source = scene.source.clone();
    let report = py
        .detach(|| simulate_scene(s, &source, &options))
        .map_err(error)?;
    let probes = PyDict::new(py);
    let probe_errors = PyDict::new(py);
    for p in &report.probes {
        match &p.value {
            Ok(v) => probes.set_item(&p.name, *v)?,
            Err(e) => {
                probes.set_item(&p.name, f64::NAN)?;
                probe_errors.set_item(&p.name, e)?;
            }
        }
    }
    let st = &report.stats;
    let diagnostics = PyDict::new(py);
    diagnostics.set_item("steps", st.steps)?;
    diagnostics.set_item("t_end", report.t_end)?;
    diagnostics.set_item("max_penetration", st.max_penetration)?;
    diagnostics.set_item("max_solver_residual", st.max_solver_residual)?;
    diagnostics.set_item("nonconverged_steps", report.nonconverged_steps())?;
    diagnostics.set_item("impact_splits", st.impact_splits)?;
    diagnostics.set_item("halved_steps", st.halved_steps)?;
    diagnostics.set_item("plastic_steps", st.plastic_steps)?;
    diagnostics.set_item("wall_seconds", report.wall_seconds)?;
    let out = PyDict::new(py);
    out.set_item("probes", probes)?;
    out.set_item("probe_errors", probe_errors)?;
    out.set_item("diagnostics", diagnostics)?;
    out.set_item("error", report.error.clone())?;
    out.set_item("text", report.to_string())?;
    Ok(out)
}

/// A study file, run as `mc-study run` runs it.
#[pyclass(name = "Study", module = "mc_study._native")]
struct PyStudy {
    study: Study,
}

#[pymethods]
impl PyStudy {
    #[staticmethod]
    #[pyo3(signature = (path, samples = None))]
    fn load(path: PathBuf, samples: Option<u64>) -> PyResult<Self> {
        Ok(PyStudy {
            study: Study::load(&path, samples).map_err(error)?,
        })
    }

    /// Runs the study (or shard `"i/n"`) into `out` (default: its `output`), resuming what
    /// is there; merges a complete unsharded run into `out/results.parquet`. Returns the
    /// result directory and whether it was merged.
    #[pyo3(signature = (out = None, threads = None, shard = None))]
    fn run(
        &self,
        py: Python<'_>,
        out: Option<PathBuf>,
        threads: Option<usize>,
        shard: Option<&str>,
    ) -> PyResult<(String, bool)> {
        check_threads(threads)?;
        let out = out.unwrap_or_else(|| self.study.output_dir.clone());
        let mut opts = RunOptions::new(out.clone());
        opts.threads = threads;
        opts.progress = false;
        if let Some(s) = shard {
            opts.shard = Shard::parse(s).map_err(error)?;
        }
        let study = &self.study;
        let stop = opts.stop.clone();
        // on Ctrl-C the runner stops starting samples and writes every finished one
        let (result, raised) = interruptible(py, &stop, || -> anyhow::Result<(String, bool)> {
            if study.reliability.is_some() {
                // a rare-event study: batch after batch, its results written when done
                let done = matches!(
                    mc_study::reliability::study::run(study, &opts)?,
                    mc_study::reliability::study::Ended::Done(_)
                );
                return Ok((out.display().to_string(), done));
            }
            let r = runner::run(study, &opts)?;
            let merged = r.missing.is_empty() && opts.shard.count == 1 && !r.interrupted;
            if merged {
                merge(&out, false)?;
            }
            Ok((out.display().to_string(), merged))
        });
        match raised {
            Some(e) => Err(e),
            None => result.map_err(error),
        }
    }

    /// The study's scene, with its fidelity settings applied.
    fn scene(&self) -> PyScene {
        PyScene {
            subject: self.study.subject.clone(),
            source: self.study.scene_path.display().to_string(),
        }
    }

    /// The study's outputs' names, in order.
    fn outputs(&self) -> Vec<String> {
        self.study.outputs.iter().map(|o| o.name.clone()).collect()
    }

    /// The study's parameter paths, in order.
    fn parameters(&self) -> Vec<String> {
        self.study
            .parameters
            .iter()
            .map(|p| p.path.clone())
            .collect()
    }

    #[getter]
    fn output_dir(&self) -> String {
        self.study.output_dir.display().to_string()
    }
}

/// The outputs of `subject` (a scene: all its outputs; a study: the study's) for each row
/// of `x` (little-endian f64, `n` rows of `len(paths)`), in parallel on `threads` (rayon,
/// the GIL released). Returns the n × k outputs as bytes (NaN where a row failed) and
/// each row's failure reason (None where it ran).
#[pyfunction]
#[pyo3(signature = (subject, paths, x, n, threads = None))]
fn evaluate<'py>(
    py: Python<'py>,
    subject: &Bound<'py, PyAny>,
    paths: Vec<String>,
    x: &[u8],
    n: usize,
    threads: Option<usize>,
) -> PyResult<(Bound<'py, PyBytes>, Vec<Option<String>>)> {
    let (subject, selected): (Subject, Vec<usize>) =
        if let Ok(study) = subject.extract::<PyRef<PyStudy>>() {
            let s = &study.study;
            (
                s.subject.clone(),
                s.outputs.iter().map(|o| o.index).collect(),
            )
        } else {
            let scene: PyRef<PyScene> = subject.extract()?;
            let k = scene.subject.outputs().len();
            (scene.subject.clone(), (0..k).collect())
        };
    for p in &paths {
        subject.parameter_dim(p).map_err(error)?;
    }
    let d = paths.len();
    if x.len() != 8 * n * d {
        return Err(error(format!(
            "X has {} values, not n × d = {n} × {d}",
            x.len() / 8
        )));
    }
    check_threads(threads)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        pool = pool.num_threads(t);
    }
    let pool = pool.build().map_err(error)?;
    let k = selected.len();
    let mut values = vec![f64::NAN; n * k];
    let mut reasons: Vec<Option<String>> = vec![None; n];
    let stop = Arc::new(AtomicBool::new(false));
    // each row reads its inputs from `x` and writes its outputs in place: nothing serial
    // per row but the final copy into bytes
    let ((), raised) = interruptible(py, &stop, || {
        pool.install(|| {
            values
                .par_chunks_mut(k.max(1))
                .zip(reasons.par_iter_mut())
                .enumerate()
                .with_min_len(16)
                .for_each(|(i, (outputs, reason))| {
                    if stop.load(Ordering::Relaxed) {
                        *reason = Some("interrupted".into());
                        return;
                    }
                    let row = &x[8 * i * d..8 * (i + 1) * d];
                    let parameters: Vec<(&str, f64)> = paths
                        .iter()
                        .zip(row.chunks_exact(8))
                        .map(|(p, b)| {
                            (
                                p.as_str(),
                                f64::from_le_bytes(b.try_into().expect("8 bytes")),
                            )
                        })
                        .collect();
                    let o = subject.run(&parameters, &selected);
                    outputs[..k].copy_from_slice(&o.outputs);
                    *reason = o.error;
                })
        })
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let out: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    Ok((PyBytes::new(py, &out), reasons))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyScene>()?;
    m.add_class::<PyStudy>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add("McStudyError", m.py().get_type::<McStudyError>())?;
    Ok(())
}
