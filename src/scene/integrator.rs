//! The `integrator` block of a scene (and a study's `fidelity` block, the same keys):
//! step, θ, γ, scheme, tolerances, presets.

use super::error::{line, SceneError};
use super::fields::{count, non_negative, positive, scalar, R};
use super::schema::IntegratorSpec;
use crate::input::units::Dim;
use crate::integrator::{IntegrationParameters, Preset, Scheme};

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
