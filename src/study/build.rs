//! Validation of a study file: its parameters (distributions, drawing tolerances,
//! correlations), outputs and limits, design, fidelity, and the blocks of the adaptive
//! studies, into a [`Study`], each error naming the file, line and field.

use super::schema::LimitSpec;
use super::*;
use crate::input::units::Dim;
use crate::scene::error::line;
use crate::scene::parameter_paths::integrator_paths;
use crate::scene::schema::{Name, Q};
use crate::scene::IntegratorSpec;

/// The scene parameter paths (`integrator.h`, …) that a `fidelity` block sets.
fn fidelity_keys(f: &crate::scene::IntegratorSpec) -> Vec<String> {
    integrator_paths(f)
        .into_iter()
        .filter(|p| p.value.is_some())
        .map(|p| p.path)
        .collect()
}

/// An error at `field` (and `line`) of the study file.
pub(super) fn at(
    line: Option<u64>,
    field: impl Into<String>,
    message: impl Into<String>,
) -> StudyError {
    StudyError::Study(SceneError::at(line, field, message))
}

fn quantity(q: &Q, dim: Option<Dim>, field: &str) -> Result<f64, StudyError> {
    let v = match dim {
        Some(d) => q.value.value(d).map_err(|m| at(line(q), field, m))?,
        None => q.value.si,
    };
    if v.is_nan() {
        return Err(at(line(q), field, "must be a number"));
    }
    Ok(v)
}

fn distribution(
    spec: &Spanned<DistributionSpec>,
    dim: Option<Dim>,
    field: &str,
) -> Result<Distribution, StudyError> {
    let f = |s: &str| format!("{field}.{s}");
    let q = |x: &Q, name: &str| quantity(x, dim, &f(name));
    let finite = |x: &Q, name: &str| -> Result<f64, StudyError> {
        let v = q(x, name)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(at(line(x), f(name), "must be finite"))
        }
    };
    let (d, kind) = match &spec.value {
        DistributionSpec::Normal { mean, sd } => (
            Distribution::Normal {
                mean: finite(mean, "normal.mean")?,
                sd: finite(sd, "normal.sd")?,
            },
            "normal",
        ),
        DistributionSpec::TruncatedNormal {
            mean,
            sd,
            lower,
            upper,
        } => (
            Distribution::TruncatedNormal {
                mean: finite(mean, "truncated_normal.mean")?,
                sd: finite(sd, "truncated_normal.sd")?,
                lower: lower
                    .as_ref()
                    .map_or(Ok(f64::NEG_INFINITY), |x| q(x, "truncated_normal.lower"))?,
                upper: upper
                    .as_ref()
                    .map_or(Ok(f64::INFINITY), |x| q(x, "truncated_normal.upper"))?,
            },
            "truncated_normal",
        ),
        DistributionSpec::Uniform { lower, upper } => (
            Distribution::Uniform {
                lower: finite(lower, "uniform.lower")?,
                upper: finite(upper, "uniform.upper")?,
            },
            "uniform",
        ),
        DistributionSpec::Lognormal { mean, sd } => {
            let (m, s) = (finite(mean, "lognormal.mean")?, finite(sd, "lognormal.sd")?);
            if s < 0.0 {
                return Err(at(
                    line(sd),
                    f("lognormal.sd"),
                    format!("must be ≥ 0, got {s}"),
                ));
            }
            (
                Distribution::lognormal(m, s)
                    .map_err(|e| at(line(mean), f("lognormal.mean"), e))?,
                "lognormal",
            )
        }
        DistributionSpec::Triangular { lower, mode, upper } => (
            Distribution::Triangular {
                lower: finite(lower, "triangular.lower")?,
                mode: finite(mode, "triangular.mode")?,
                upper: finite(upper, "triangular.upper")?,
            },
            "triangular",
        ),
        DistributionSpec::Fixed(v) => (Distribution::Fixed(finite(v, "fixed")?), "fixed"),
    };
    d.validate().map_err(|m| {
        let l = match &spec.value {
            DistributionSpec::Normal { sd, .. } | DistributionSpec::TruncatedNormal { sd, .. }
                if m.starts_with("sd") =>
            {
                line(sd)
            }
            _ => line(spec),
        };
        at(l, f(kind), m)
    })?;
    Ok(d)
}

/// A tolerance as a drawing states it: normal, centred on the band [n − minus, n + plus],
/// with σ = (plus + minus) / (6 Cp); or uniform over the band.
fn tolerance(
    spec: &Spanned<ToleranceSpec>,
    dim: Option<Dim>,
    field: &str,
) -> Result<Drawing, StudyError> {
    let t = &spec.value;
    let f = |s: &str| format!("{field}.{s}");
    let finite = |x: &Q, name: &str| -> Result<f64, StudyError> {
        let v = quantity(x, dim, &f(name))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(at(line(x), f(name), "must be finite"))
        }
    };
    let width = |x: &Q, name: &str| -> Result<f64, StudyError> {
        let v = finite(x, name)?;
        if v < 0.0 {
            return Err(at(
                line(x),
                f(name),
                format!("a tolerance is a width ≥ 0, got {v}"),
            ));
        }
        Ok(v)
    };
    let nominal = finite(&t.nominal, "nominal")?;
    let (plus, minus) = match (&t.plus_minus, &t.plus, &t.minus) {
        (Some(pm), None, None) => {
            let w = width(pm, "plus_minus")?;
            (w, w)
        }
        (None, Some(p), Some(m)) => (width(p, "plus")?, width(m, "minus")?),
        _ => {
            return Err(at(
                line(spec),
                field,
                "give `plus_minus`, or both `plus` and `minus`",
            ))
        }
    };
    if plus + minus <= 0.0 {
        return Err(at(line(spec), field, "the tolerance band has no width"));
    }
    let kind = t
        .distribution
        .as_ref()
        .map_or("normal", |d| d.value.as_str());
    match kind {
        "normal" => {
            let cp = t.cp.as_ref().map_or(1.0, |c| c.value);
            if !(cp > 0.0 && cp.is_finite()) {
                return Err(at(
                    t.cp.as_ref().and_then(line),
                    f("cp"),
                    format!("a process capability must be > 0, got {cp}"),
                ));
            }
            Ok(Drawing {
                nominal,
                plus,
                minus,
                cp: Some(cp),
            })
        }
        "uniform" => {
            if let Some(c) = &t.cp {
                return Err(at(
                    line(c),
                    f("cp"),
                    "a uniform tolerance has no process capability: drop `cp`",
                ));
            }
            Ok(Drawing {
                nominal,
                plus,
                minus,
                cp: None,
            })
        }
        other => Err(at(
            t.distribution.as_ref().and_then(line),
            f("distribution"),
            format!("`{other}`: expected normal or uniform"),
        )),
    }
}

impl Study {
    pub(super) fn build(
        spec: StudySpec,
        text: &str,
        base: &Path,
        scene_text: Option<&str>,
        samples: Option<u64>,
    ) -> Result<Study, StudyError> {
        let scene_path = base.join(&spec.scene.value);
        let from_files = scene_text.is_none();
        let scene_text = match scene_text {
            Some(t) => t.to_string(),
            None => crate::input::file::read(&scene_path).map_err(|e| {
                at(
                    line(&spec.scene),
                    "scene",
                    format!("cannot read `{}`: {e}", scene_path.display()),
                )
            })?,
        };
        let mut subject = Subject::from_yaml(&scene_text, &scene_path.display().to_string())
            .map_err(StudyError::Scene)?;
        // a study loaded from its files reads its curves' measured points; one rebuilt
        // from the texts stored with its results finds them in the result directory
        let references = match from_files {
            true => super::curves::read_references(subject.curves(), &scene_path)
                .map_err(StudyError::Scene)?,
            false => Vec::new(),
        };
        let n = sample_count(&spec, samples)?;
        let kind = match &spec.design {
            None => DesignKind::Random,
            Some(d) => DesignKind::parse(&d.value).ok_or_else(|| {
                at(
                    line(d),
                    "design",
                    format!(
                        "unknown design `{}` (random, lhs, sobol, saltelli)",
                        d.value
                    ),
                )
            })?,
        };
        let parameters = parameters(&spec, &subject)?;
        let outputs = outputs(&spec, &subject)?;
        if let Some(f) = &spec.fidelity {
            tune(&mut subject, f, &spec, &parameters)?;
        }
        let seed = spec.seed.as_ref().map_or(0, |s| s.value);
        let design = Design::new(kind, parameters.len(), n, seed)
            .map_err(|m| at(spec.design.as_ref().and_then(line), "design", m))?;
        if parameters.is_empty() && kind != DesignKind::Random {
            return Err(at(
                spec.design.as_ref().and_then(line),
                "design",
                "needs at least one parameter",
            ));
        }
        let name = study_name(&spec, &subject)?;
        let output_dir = match &spec.output {
            None => PathBuf::from("results").join(&name),
            Some(o) if o.value.trim().is_empty() => {
                return Err(at(line(o), "output", "must name a directory"))
            }
            Some(o) => base.join(&o.value),
        };
        let suspect_fails = match &spec.suspect {
            None => false,
            Some(s) if s.value == "keep" => false,
            Some(s) if s.value == "fail" => true,
            Some(s) => {
                return Err(at(
                    line(s),
                    "suspect",
                    format!("`{}`: expected keep or fail", s.value),
                ))
            }
        };
        let reliability = match &spec.reliability {
            None => None,
            Some(r) => Some(rare_event(r, &outputs, &parameters, kind, &spec, n)?),
        };
        let copula = copula::from_spec(&spec.correlations, &parameters)?;
        let allocation = spec
            .allocation
            .as_ref()
            .map(|a| tolerance::allocation_target(a, &outputs))
            .transpose()?;
        Ok(Study {
            copula,
            allocation,
            search: None,
            name,
            description: spec.description.clone().unwrap_or_default(),
            text: text.to_string(),
            scene_text,
            scene_path,
            subject,
            design,
            seed,
            parameters,
            outputs,
            output_dir,
            suspect_fails,
            reliability,
            references,
        })
    }
}

/// The number of samples: `samples` where given (the command line's), else the study's.
fn sample_count(spec: &StudySpec, samples: Option<u64>) -> Result<u64, StudyError> {
    let n = match samples {
        Some(n) => n as f64,
        None => quantity(&spec.samples, Some(Dim::NONE), "samples")?,
    };
    if !(n >= 1.0 && n.fract() == 0.0 && n <= 1e12) {
        return Err(at(
            if samples.is_some() {
                None
            } else {
                line(&spec.samples)
            },
            "samples",
            format!("must be a whole number ≥ 1, got {n}"),
        ));
    }
    Ok(n as u64)
}

/// The sampled parameters, each a path of the scene sampled once, by a distribution or a
/// drawing's tolerance whose every value the scene accepts.
fn parameters(spec: &StudySpec, subject: &Subject) -> Result<Vec<Parameter>, StudyError> {
    let mut parameters: Vec<Parameter> = Vec::new();
    for (i, p) in spec.parameters.iter().enumerate() {
        let field = format!("parameters[{i}]");
        if parameters.iter().any(|q| q.path == p.path.value) {
            return Err(at(
                line(&p.path),
                format!("{field}.path"),
                format!("`{}` is sampled twice", p.path.value),
            ));
        }
        let dim = subject
            .parameter_dim(&p.path.value)
            .map_err(|m| at(line(&p.path), format!("{field}.path"), m))?;
        if let (Some(c), None) = (&p.cost, &p.tolerance) {
            return Err(at(
                line(c),
                format!("{field}.cost"),
                "a cost belongs to a tolerance: write the parameter as `tolerance: { nominal, plus_minus, cp }`",
            ));
        }
        let (distribution, drawing, spec_line, spec_field) = match (&p.distribution, &p.tolerance) {
            (Some(d), None) => {
                let f = format!("{field}.distribution");
                (distribution(d, dim, &f)?, None, line(d), f)
            }
            (None, Some(t)) => {
                let f = format!("{field}.tolerance");
                let drawing = tolerance(t, dim, &f)?;
                (drawing.distribution(), Some(drawing), line(t), f)
            }
            (Some(_), Some(t)) => {
                return Err(at(
                    line(t),
                    format!("{field}.tolerance"),
                    "give `distribution` or `tolerance`, not both",
                ))
            }
            (None, None) => {
                return Err(at(
                    line(&p.path),
                    field,
                    "give a `distribution` or a `tolerance`",
                ))
            }
        };
        if let Subject::Mechanism(scene) = &subject {
            // every value the distribution can give must be one the scene accepts
            for v in distribution.extreme_values() {
                if let Err(e) = scene.with_parameters(&[(&p.path.value, v)]) {
                    return Err(at(
                        spec_line,
                        spec_field.clone(),
                        format!("its support reaches {v}{}, which the scene refuses ({e}); narrow or truncate it to values the scene accepts", dim.filter(|d| *d != Dim::NONE).map(|d| format!(" {}", d.si_unit())).unwrap_or_default()),
                    ));
                }
            }
        }
        parameters.push(Parameter {
            path: p.path.value.clone(),
            distribution,
            unit: dim.map(|d| d.si_unit()).unwrap_or_default(),
            drawing,
            cost: tolerance::cost(p.cost.as_ref(), &format!("{field}.cost"))?,
        });
    }
    Ok(parameters)
}

/// The outputs the study keeps (all the scene's by default), with their limits.
fn outputs(spec: &StudySpec, subject: &Subject) -> Result<Vec<Output>, StudyError> {
    let available = subject.outputs();
    let names = |v: &[Output]| {
        v.iter()
            .map(|o| o.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let find = |n: &Name, field: &str| {
        available
            .iter()
            .position(|o| o.name == n.value)
            .ok_or_else(|| {
                at(
                    line(n),
                    field,
                    format!(
                        "unknown output `{}` (the scene's outputs: {})",
                        n.value,
                        names(&available)
                    ),
                )
            })
    };
    let mut outputs: Vec<Output> = Vec::new();
    match &spec.outputs {
        Some(list) => {
            for (i, n) in list.iter().enumerate() {
                let index = find(n, &format!("outputs[{i}]"))?;
                if outputs.iter().any(|o| o.index == index) {
                    return Err(at(
                        line(n),
                        format!("outputs[{i}]"),
                        format!("`{}` is listed twice", n.value),
                    ));
                }
                outputs.push(available[index].clone());
            }
        }
        None => outputs = available.clone(),
    }
    if outputs.is_empty() {
        return Err(at(
            None,
            "outputs",
            "the study keeps no output (the scene defines no probes?)",
        ));
    }
    for (i, l) in spec.limits.iter().enumerate() {
        let field = format!("limits[{i}]");
        let index = find(&l.output, &format!("{field}.output"))?;
        let dim = Dim::of_unit(&available[index].unit);
        let Some(o) = outputs.iter_mut().find(|o| o.index == index) else {
            return Err(at(
                line(&l.output),
                format!("{field}.output"),
                format!("`{}` is not among the study's outputs", l.output.value),
            ));
        };
        limits(o, l, dim, &field)?;
    }
    Ok(outputs)
}

/// The limits `l` on output `o`, in its dimension `dim`.
fn limits(o: &mut Output, l: &LimitSpec, dim: Option<Dim>, field: &str) -> Result<(), StudyError> {
    o.lower = l
        .lower
        .as_ref()
        .map(|q| quantity(q, dim, &format!("{field}.lower")))
        .transpose()?;
    o.upper = l
        .upper
        .as_ref()
        .map(|q| quantity(q, dim, &format!("{field}.upper")))
        .transpose()?;
    if let (Some(a), Some(b)) = (o.lower, o.upper) {
        if a >= b {
            return Err(at(
                line(&l.output),
                field,
                format!("needs lower < upper, got [{a}, {b}]"),
            ));
        }
    }
    if o.lower.is_none() && o.upper.is_none() {
        return Err(at(line(&l.output), field, "give `lower`, `upper` or both"));
    }
    Ok(())
}

/// Tunes a mechanism with the study's `fidelity` block, which may not set a sampled path.
fn tune(
    subject: &mut Subject,
    f: &IntegratorSpec,
    spec: &StudySpec,
    parameters: &[Parameter],
) -> Result<(), StudyError> {
    match subject {
        Subject::Mechanism(scene) => {
            // the block applies on top of the scene's integrator block, sampled
            // values included: a key set both ways would silently lose the sample
            let overridden = fidelity_keys(f);
            if let Some((i, p)) = parameters
                .iter()
                .enumerate()
                .find(|(_, p)| overridden.contains(&p.path))
            {
                return Err(at(
                    line(&spec.parameters[i].path),
                    format!("parameters[{i}].path"),
                    format!("`{}` is sampled, but the study's `fidelity` block sets it for every sample; drop one of the two", p.path),
                ));
            }
            scene.tune(Tuning {
                block: f.clone(),
                origin: "fidelity".into(),
            })?
        }
        Subject::Function(_) => {
            return Err(at(
                None,
                "fidelity",
                "a function scene has no integrator to set",
            ));
        }
    }
    Ok(())
}

/// The study's name (the scene's by default): one plain name, since it names the default
/// output directory.
fn study_name(spec: &StudySpec, subject: &Subject) -> Result<String, StudyError> {
    let name = spec
        .name
        .as_ref()
        .map(|n| n.value.clone())
        .unwrap_or_else(|| match &subject {
            Subject::Mechanism(s) => s.name.clone(),
            Subject::Function(f) => f.name.clone(),
        });
    // the name makes the default output directory: it must stay one plain name
    if name.trim().is_empty() || name == "." || name == ".." || name.contains(['/', '\\', '\0']) {
        let (l, field) = match &spec.name {
            Some(n) => (line(n), "name"),
            None => (line(&spec.scene), "scene"),
        };
        return Err(at(
            l,
            field,
            format!("the study's name `{name}` must be a plain name (no `/`, `\\` or `..`): it names the default output directory results/<name>"),
        ));
    }
    Ok(name)
}

/// Validates a study's `reliability:` block.
fn rare_event(
    r: &Spanned<schema::ReliabilitySpec>,
    outputs: &[Output],
    parameters: &[Parameter],
    kind: DesignKind,
    spec: &StudySpec,
    n: u64,
) -> Result<RareEvent, StudyError> {
    let v = &r.value;
    let method = match &v.method {
        None => "subset".to_string(),
        Some(m) if m.value == "subset" || m.value == "monte-carlo" => m.value.clone(),
        Some(m) => {
            return Err(at(
                line(m),
                "reliability.method",
                format!("unknown method `{}` (subset, monte-carlo)", m.value),
            ))
        }
    };
    if kind != DesignKind::Random {
        return Err(at(
            spec.design.as_ref().and_then(line),
            "design",
            "a rare-event study draws its own samples: leave `design` out, or set it to random",
        ));
    }
    if parameters.is_empty() {
        return Err(at(
            line(r),
            "reliability",
            "needs at least one sampled parameter",
        ));
    }
    let target_cov = v.target_cov.as_ref().map_or(0.1, |t| t.value);
    if !(target_cov > 0.0 && target_cov < 10.0) {
        return Err(at(
            v.target_cov.as_ref().and_then(line),
            "reliability.target_cov",
            format!("must lie in (0, 10), got {target_cov}"),
        ));
    }
    let p0 = v.p0.as_ref().map_or(0.1, |t| t.value);
    if !(p0 > 0.0 && p0 <= 0.5) {
        return Err(at(
            v.p0.as_ref().and_then(line),
            "reliability.p0",
            format!("must lie in (0, 0.5], got {p0}"),
        ));
    }
    let max_simulations = v.max_simulations.as_ref().map_or(100_000, |t| t.value);
    let limited: Vec<usize> = (0..outputs.len())
        .filter(|&k| outputs[k].lower.is_some() || outputs[k].upper.is_some())
        .collect();
    let chosen = match &v.output {
        None if limited.is_empty() => {
            return Err(at(
                line(r),
                "reliability",
                "failure is an output outside its limits, and the study gives no `limits`",
            ))
        }
        None => limited,
        Some(n) => {
            let Some(k) = outputs.iter().position(|o| o.name == n.value) else {
                return Err(at(
                    line(n),
                    "reliability.output",
                    format!(
                        "`{}` is not among the study's outputs ({})",
                        n.value,
                        outputs
                            .iter()
                            .map(|o| o.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            };
            if !limited.contains(&k) {
                return Err(at(
                    line(n),
                    "reliability.output",
                    format!(
                        "`{}` has no `limits`: give it a lower or upper limit",
                        n.value
                    ),
                ));
            }
            vec![k]
        }
    };
    let failed_samples = match v.failed_samples.as_ref().map(|f| f.value.as_str()) {
        None | Some("fail") => FailedSamples::Fail,
        Some("pass") => FailedSamples::Pass,
        Some("error") => FailedSamples::Error,
        Some(other) => {
            return Err(at(
                v.failed_samples.as_ref().and_then(line),
                "reliability.failed_samples",
                format!("`{other}`: expected fail, pass or error"),
            ))
        }
    };
    if method == "subset" {
        // a level keeps N p₀ seeds and grows a chain of 1/p₀ states from each
        let whole = |x: f64| (x - x.round()).abs() < 1e-9;
        let seeds = n as f64 * p0;
        if !whole(1.0 / p0) || !whole(seeds) || seeds < 2.0 {
            return Err(at(
                line(&spec.samples),
                "samples",
                format!("with `reliability`: the samples per level ({n}) times p0 ({p0}) and 1/p0 must be whole numbers, with at least 2 chains (e.g. 100, 200, 500 or 1000 samples at p0 = 0.1)"),
            ));
        }
    }
    if max_simulations < n {
        return Err(at(
            v.max_simulations.as_ref().and_then(line),
            "reliability.max_simulations",
            format!("{max_simulations} is fewer than one batch of {n} samples"),
        ));
    }
    Ok(RareEvent {
        method,
        target_cov,
        p0,
        max_simulations,
        importance: v.importance.as_ref().is_none_or(|b| b.value),
        outputs: chosen,
        failed_samples,
    })
}
