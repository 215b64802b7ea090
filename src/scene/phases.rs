//! The phases of a run: the settling of a preloaded mechanism (`settle`) and the window of
//! finer steps a contact opens (`refine`), as the integrator's [`Schedule`].

use super::error::{line, SceneError};
use super::fields::{non_negative, positive, R};
use super::schema::{Name, SceneSpec};
use crate::input::units::Dim;
use crate::integrator::{IntegrationParameters, Refine, Schedule, Settle};
use crate::mechanics::Model;
use serde_saphyr::Spanned;

/// The contact pairs and clearance joints that keep their friction while settling: names
/// of the scene's contacts or joints.
fn settle_friction(model: &Model, names: &Spanned<Vec<Name>>) -> R<Vec<String>> {
    let known = |n: &str| {
        model.contacts.iter().any(|c| c.name == n)
            || model.clearance_joints.iter().any(|j| j.name == n)
            || model.joints.iter().any(|j| j.name == n)
            || model.compliant.iter().any(|c| c.name() == n)
    };
    names
        .value
        .iter()
        .enumerate()
        .map(|(i, n)| {
            if known(&n.value) {
                Ok(n.value.clone())
            } else {
                Err(SceneError::at(
                    line(n),
                    format!("settle.friction[{i}]"),
                    format!("unknown contact or joint `{}`", n.value),
                ))
            }
        })
        .collect()
}

/// The index of the event probe `name` among the scene's value and event probes (curves
/// left out, as the probes number them): the event that closes the refinement window.
fn closing_event(spec: &SceneSpec, name: &Name) -> R<usize> {
    let scalars = || spec.probes.iter().filter(|p| p.curve.is_none());
    match scalars().position(|p| p.name.value == name.value) {
        Some(k) if scalars().nth(k).is_some_and(|p| p.event.is_some()) => Ok(k),
        Some(_) => Err(SceneError::at(
            line(name),
            "refine.until",
            format!(
                "probe `{}` is not an event probe; only an event can close the window",
                name.value
            ),
        )),
        None => Err(SceneError::at(
            line(name),
            "refine.until",
            format!("unknown event probe `{}`", name.value),
        )),
    }
}

/// The scene's phases, their steps and tolerances as ratios of `params`' (so that a
/// fidelity that changes h or the tolerance scales them in proportion).
pub(super) fn schedule(
    spec: &SceneSpec,
    model: &Model,
    params: &IntegrationParameters,
) -> R<Schedule> {
    let mut schedule = Schedule::default();
    if let Some(s) = &spec.settle {
        schedule.settle = Some(Settle {
            until: positive(&s.value.until, Dim::TIME, "settle.until")?,
            damping: s.value.damping.as_ref().map_or(Ok(0.0), |q| {
                non_negative(q, Dim::ANGULAR_VELOCITY, "settle.damping")
            })?,
            friction: match &s.value.friction {
                None => None,
                Some(names) => Some(settle_friction(model, names)?),
            },
            step_ratio: match &s.value.h {
                None => None,
                Some(h) => Some(positive(h, Dim::TIME, "settle.h")? / params.h),
            },
            tolerance_ratio: match &s.value.tolerance {
                None => None,
                Some(t) => {
                    Some(positive(t, Dim::NONE, "settle.tolerance")? / params.solver.tolerance)
                }
            },
        });
    }
    if let Some(r) = &spec.refine {
        schedule.refine = Some(Refine {
            trigger: super::probes::contact(model, &r.value.after, "refine.after")?,
            duration: positive(&r.value.duration, Dim::TIME, "refine.for")?,
            step_ratio: positive(&r.value.h, Dim::TIME, "refine.h")? / params.h,
            until: match &r.value.until {
                None => None,
                Some(name) => Some(closing_event(spec, name)?),
            },
            approach_ratio: match &r.value.approach {
                None => None,
                Some(h) => Some(positive(h, Dim::TIME, "refine.approach")? / params.h),
            },
            extrapolate: r.value.extrapolate,
        });
    }
    Ok(schedule)
}
