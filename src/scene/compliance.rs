//! The compliant law of a contact pair or a revolute-clearance joint (`law: compliant`):
//! Hertz's stiffness from the materials and the curvature, or a stiffness given.

use super::error::{line, SceneError};
use super::fields::{positive, scalar, R};
use super::schema::{ComplianceSpec, MaterialSpec, Name};
use crate::input::units::Dim;
use crate::mechanics::contact::compliant::{
    contact_modulus, hertz_stiffness, CompliantLaw, Dissipation,
};
use serde_saphyr::Spanned;

/// The slip speed of the regularised friction where `slip_speed` is left out (m/s).
pub(super) const SLIP_SPEED: f64 = 1e-4;

/// Whether an entry is compliant: its `law` is `rigid` (the default) or `compliant`, and a
/// `compliance` block goes with `law: compliant` only.
pub(super) fn is_compliant(
    law: &Option<Name>,
    compliance: &Option<Spanned<ComplianceSpec>>,
    at: Option<u64>,
    field: &dyn Fn(&str) -> String,
) -> R<bool> {
    let compliant = match law.as_ref().map(|l| l.value.as_str()) {
        None | Some("rigid") => false,
        Some("compliant") => true,
        Some(other) => {
            return Err(SceneError::at(
                law.as_ref().and_then(line),
                field("law"),
                format!("unknown contact law `{other}` (rigid, compliant)"),
            ))
        }
    };
    if !compliant && compliance.is_some() {
        return Err(SceneError::at(
            compliance.as_ref().and_then(line).or(at),
            field("compliance"),
            "applies to `law: compliant` only",
        ));
    }
    Ok(compliant)
}

/// The law of a compliant entry, with friction `mu` and restitution `e`; `radius` is the
/// effective radius R of Hertz's K = (4/3) E* √R where the shapes give one, else why the
/// stiffness must be given.
pub(super) fn compliant_law(
    compliance: &Option<Spanned<ComplianceSpec>>,
    radius: Result<f64, &str>,
    (mu, e): (f64, f64),
    at: Option<u64>,
    field: &dyn Fn(&str) -> String,
) -> R<CompliantLaw> {
    let Some(spec) = compliance else {
        return Err(SceneError::at(
            at,
            field("compliance"),
            "is required with `law: compliant`: give `material: { E, nu }` or `stiffness`",
        ));
    };
    let c = &spec.value;
    let f = |s: &str| field(&format!("compliance.{s}"));
    let exponent = c
        .exponent
        .as_ref()
        .map_or(Ok(1.5), |q| positive(q, Dim::NONE, &f("exponent")))?;
    let kind = c
        .dissipation
        .as_ref()
        .map_or("matched", |d| d.value.as_str());
    if !["matched", "flores", "hunt-crossley"].contains(&kind) {
        return Err(SceneError::at(
            c.dissipation.as_ref().and_then(line),
            f("dissipation"),
            format!("unknown dissipation `{kind}` (matched, flores, hunt-crossley)"),
        ));
    }
    if e <= 0.0 && kind != "hunt-crossley" {
        return Err(SceneError::at(
            line(spec),
            field("e"),
            "must be positive for a compliant contact: a law K δⁿ (1 + D δ̇) that restitutes nothing needs an infinite D (give the e of the impact, or `dissipation: hunt-crossley`, whose D = 3(1 − e)/(2 v₀) stays finite)",
        ));
    }
    let dissipation = match kind {
        "flores" => Dissipation::Flores,
        "hunt-crossley" => Dissipation::HuntCrossley,
        _ => Dissipation::matched(e, exponent),
    };
    let stiffness = match (&c.stiffness, &c.material) {
        (Some(k), None) => positive(k, Dim::NONE, &f("stiffness"))?,
        (None, Some(m)) => {
            if exponent != 1.5 {
                return Err(SceneError::at(
                    c.exponent.as_ref().and_then(line),
                    f("exponent"),
                    "is Hertz's 1.5 where the stiffness follows from `material`; give `stiffness` for another exponent",
                ));
            }
            let first = material(m, &f("material"))?;
            let second = match &c.against_material {
                Some(a) => material(a, &f("against_material"))?,
                None => first,
            };
            let radius = radius.map_err(|why| {
                SceneError::at(
                    line(m),
                    f("material"),
                    format!("gives no stiffness here: {why}; give `stiffness` (N/m^1.5) instead"),
                )
            })?;
            hertz_stiffness(
                contact_modulus(first.0, first.1, second.0, second.1),
                radius,
            )
        }
        (Some(k), Some(_)) => {
            return Err(SceneError::at(
                line(k),
                f("stiffness"),
                "give `stiffness` or `material`, not both",
            ))
        }
        (None, None) => {
            return Err(SceneError::at(
                line(spec),
                field("compliance"),
                "needs `material: { E, nu }` or `stiffness`",
            ))
        }
    };
    let slip_speed = c.slip_speed.as_ref().map_or(Ok(SLIP_SPEED), |q| {
        positive(q, Dim::VELOCITY, &f("slip_speed"))
    })?;
    Ok(CompliantLaw {
        stiffness,
        exponent,
        restitution: e,
        dissipation,
        mu,
        slip_speed,
    })
}

/// (E, ν) of a material entry.
fn material(m: &Spanned<MaterialSpec>, field: &str) -> R<(f64, f64)> {
    let e = positive(
        &m.value.youngs_modulus,
        Dim::PRESSURE,
        &format!("{field}.E"),
    )?;
    let nu = scalar(&m.value.nu, Dim::NONE, &format!("{field}.nu"))?;
    if !(-1.0..0.5).contains(&nu) {
        return Err(SceneError::at(
            line(&m.value.nu),
            format!("{field}.nu"),
            format!("must lie in [−1, 0.5), got {nu}"),
        ));
    }
    Ok((e, nu))
}
