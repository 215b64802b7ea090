//! The `integrator` block of a scene (and a study's `fidelity` block, the same keys):
//! step, θ, γ, scheme, tolerances, presets.

use super::error::{line, SceneError};
use super::fields::{count, non_negative, positive, scalar, R};
use super::schema::{IntegratorSpec, StepControlSpec};
use crate::input::units::Dim;
use crate::integrator::{IntegrationParameters, Preset, Scheme, StepControl};

/// Applies an `integrator` block (or a study's `fidelity` block, named by `prefix`) on top
/// of `p`.
pub fn apply_integrator(
    spec: &IntegratorSpec,
    p: &mut IntegrationParameters,
    prefix: &str,
) -> R<()> {
    if let Some(name) = &spec.preset {
        let preset = Preset::parse(&name.value).ok_or_else(|| {
            SceneError::at(
                line(name),
                format!("{prefix}.preset"),
                format!(
                    "unknown preset `{}` (available: fast, balanced, accurate)",
                    name.value
                ),
            )
        })?;
        preset.apply(p);
    }
    if let Some(h) = &spec.h {
        p.h = positive(h, Dim::TIME, &format!("{prefix}.h"))?;
    }
    if let Some(t) = &spec.theta {
        p.theta = scalar(t, Dim::NONE, &format!("{prefix}.theta"))?;
    }
    if let Some(g) = &spec.gamma {
        p.gamma = scalar(g, Dim::NONE, &format!("{prefix}.gamma"))?;
    }
    if let Some(s) = &spec.scheme {
        p.scheme = Scheme::parse(&s.value).ok_or_else(|| {
            SceneError::at(
                line(s),
                format!("{prefix}.scheme"),
                format!("unknown scheme `{}` (available: moreau-jean, combined-projection, direct-projection)", s.value),
            )
        })?;
    }
    if let Some(m) = &spec.activation_margin {
        p.activation_margin = non_negative(m, Dim::LENGTH, &format!("{prefix}.activation_margin"))?;
    }
    if let Some(s) = &spec.solver {
        if let Some(t) = &s.tolerance {
            p.solver.tolerance = positive(t, Dim::NONE, &format!("{prefix}.solver.tolerance"))?;
        }
        if let Some(m) = &s.max_iterations {
            p.solver.max_sweeps = count(m, &format!("{prefix}.solver.max_iterations"))?;
        }
    }
    if let Some(l) = spec.locate_impacts {
        p.locate_impacts = l;
    }
    if let Some(c) = &spec.step_control {
        p.step_control = step_control(c, p.step_control.take(), p.h, prefix)?;
    }
    if let Some(s) = &spec.projection {
        if let Some(t) = &s.tolerance {
            p.projection_tolerance =
                positive(t, Dim::NONE, &format!("{prefix}.projection.tolerance"))?;
        }
        if let Some(m) = &s.max_iterations {
            p.projection_max_iterations = count(m, &format!("{prefix}.projection.max_iterations"))?;
        }
    }
    if let Some(s) = &spec.newton {
        if let Some(t) = &s.tolerance {
            p.newton_tolerance = positive(t, Dim::NONE, &format!("{prefix}.newton.tolerance"))?;
        }
        if let Some(m) = &s.max_iterations {
            p.newton_max_iterations = count(m, &format!("{prefix}.newton.max_iterations"))?;
        }
    }
    let field_line = |name: &str| -> Option<u64> {
        match name {
            "theta" => spec.theta.as_ref().and_then(line),
            "gamma" => spec.gamma.as_ref().and_then(line),
            _ => None,
        }
    };
    p.validate()
        .map_err(|(f, m)| SceneError::at(field_line(f), format!("{prefix}.{f}"), m))
}

/// The step control's tolerance where a block leaves it out.
const DEFAULT_TOLERANCE: f64 = 1e-4;

/// A `step_control` block on top of the control already set (`present`; else the
/// defaults for the step `h`), or `off`.
fn step_control(
    spec: &StepControlSpec,
    present: Option<StepControl>,
    h: f64,
    prefix: &str,
) -> R<Option<StepControl>> {
    let field = |name: &str| format!("{prefix}.step_control.{name}");
    let block = match spec {
        StepControlSpec::Off => return Ok(None),
        StepControlSpec::On(block) => block,
    };
    let mut c = present.unwrap_or_else(|| StepControl::for_step(DEFAULT_TOLERANCE, h));
    let set = |q: &Option<super::schema::Q>, dim: Dim, name: &str, x: &mut f64| -> R<()> {
        if let Some(q) = q {
            *x = positive(q, dim, &field(name))?;
        }
        Ok(())
    };
    set(&block.tolerance, Dim::NONE, "tolerance", &mut c.tolerance)?;
    set(&block.h_max, Dim::TIME, "h_max", &mut c.h_max)?;
    set(&block.h_min, Dim::TIME, "h_min", &mut c.h_min)?;
    set(&block.length, Dim::LENGTH, "length", &mut c.length)?;
    set(&block.speed, Dim::VELOCITY, "speed", &mut c.speed)?;
    if c.h_min > c.h_max {
        let l = block.h_min.as_ref().or(block.h_max.as_ref()).and_then(line);
        return Err(SceneError::at(
            l,
            field("h_min"),
            format!("must not exceed h_max ({} s), got {} s", c.h_max, c.h_min),
        ));
    }
    Ok(Some(c))
}
