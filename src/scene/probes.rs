//! Validation of the scene's `probes` into [`Probe`]s: names resolved to contact candidates,
//! bodies and other probes, every error with its field and line.

use super::error::{line, SceneError};
use super::fields::{body_ref, count, opt_vec3, scalar, unit_vec3};
use super::schema::{EventSpec, MeasureSpec, Name, ProbeSpec, TimeRef as TimeSpec};
use super::units::{Dim, DisplayUnit};
use crate::mechanics::model::Candidate;
use crate::mechanics::Model;
use crate::probe::{Direction, Event, Measure, Probe, ProbeKind, Reduce, TimeRef};
use serde_saphyr::Spanned;

type R<T> = Result<T, SceneError>;

/// The contact candidates of a contact pair or clearance joint named `name`; the error names
/// `field` and lists the names there are.
pub(crate) fn contact(model: &Model, name: &Name, field: &str) -> R<Vec<usize>> {
    let ids: Vec<usize> = model
        .contact_candidates()
        .iter()
        .enumerate()
        .filter(|(_, &c)| {
            !matches!(c, Candidate::Limit { .. }) && model.candidate_owner(c) == name.value
        })
        .map(|(i, _)| i)
        .collect();
    if ids.is_empty() {
        let known: Vec<&str> = model
            .contacts
            .iter()
            .map(|c| c.name.as_str())
            .chain(model.clearance_joints.iter().map(|j| j.name.as_str()))
            .collect();
        return Err(SceneError::at(
            line(name),
            field,
            format!(
                "unknown contact `{}` (contacts and clearance joints: {})",
                name.value,
                known.join(", ")
            ),
        ));
    }
    Ok(ids)
}

fn measure(model: &Model, m: &Spanned<MeasureSpec>, field: &str) -> R<(Measure, Dim)> {
    let s = &m.value;
    let given = [
        s.gap.is_some(),
        s.contact_force.is_some(),
        s.distance.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(SceneError::at(
            line(m),
            field,
            "needs exactly one of `gap`, `contact_force`, `distance`",
        ));
    }
    if let Some(n) = &s.gap {
        return Ok((
            Measure::Gap(contact(model, n, &format!("{field}.gap"))?),
            Dim::LENGTH,
        ));
    }
    if let Some(n) = &s.contact_force {
        let ids = contact(model, n, &format!("{field}.contact_force"))?;
        return Ok((Measure::ContactForce(ids), Dim::FORCE));
    }
    let d = &s.distance.as_ref().expect("checked above").value;
    let f = |s: &str| format!("{field}.distance.{s}");
    let frame = match &d.frame {
        Some(n) if n.value == "world" => None,
        Some(n) => body_ref(model, n, &f("frame"))?,
        None => None,
    };
    Ok((
        Measure::Distance {
            from: (
                body_ref(model, &d.from.body, &f("from.body"))?,
                opt_vec3(&d.from.point, Dim::LENGTH, &f("from.point"))?,
            ),
            to: (
                body_ref(model, &d.to.body, &f("to.body"))?,
                opt_vec3(&d.to.point, Dim::LENGTH, &f("to.point"))?,
            ),
            axis: unit_vec3(&d.axis, &f("axis"))?,
            frame,
        },
        Dim::LENGTH,
    ))
}

fn event(model: &Model, e: &Spanned<EventSpec>, field: &str) -> R<(Event, usize)> {
    let s = &e.value;
    let f = |s: &str| format!("{field}.{s}");
    let occurrence = s
        .occurrence
        .as_ref()
        .map_or(Ok(1), |q| count(q, &f("occurrence")))?;
    let kinds = [s.closes.is_some(), s.opens.is_some(), s.crosses.is_some()];
    if kinds.iter().filter(|&&k| k).count() != 1 {
        return Err(SceneError::at(
            line(e),
            field,
            "needs exactly one of `closes`, `opens`, `crosses`",
        ));
    }
    if let Some(n) = &s.closes {
        return Ok((Event::Closes(contact(model, n, &f("closes"))?), occurrence));
    }
    if let Some(n) = &s.opens {
        return Ok((Event::Opens(contact(model, n, &f("opens"))?), occurrence));
    }
    let Some(m) = &s.measure else {
        return Err(SceneError::at(
            line(e),
            f("measure"),
            "`crosses` needs the `measure` that crosses",
        ));
    };
    let (measure, dim) = measure(model, m, &f("measure"))?;
    let threshold = scalar(
        s.crosses.as_ref().expect("checked above"),
        dim,
        &f("crosses"),
    )?;
    let direction = match s.direction.as_ref().map(|d| (d.value.as_str(), d)) {
        None | Some(("either", _)) => Direction::Either,
        Some(("up", _)) => Direction::Up,
        Some(("down", _)) => Direction::Down,
        Some((other, d)) => {
            return Err(SceneError::at(
                line(d),
                f("direction"),
                format!("unknown direction `{other}` (up, down, either)"),
            ))
        }
    };
    Ok((
        Event::Crosses {
            measure,
            threshold,
            direction,
        },
        occurrence,
    ))
}

fn time_ref(specs: &[ProbeSpec], t: &Spanned<TimeSpec>, field: &str) -> R<TimeRef> {
    match &t.value {
        TimeSpec::Time(q) => {
            let v = q
                .value(Dim::TIME)
                .map_err(|m| SceneError::at(line(t), field, m))?;
            if !(v >= 0.0 && v.is_finite()) {
                return Err(SceneError::at(
                    line(t),
                    field,
                    format!("must be a time ≥ 0, got {v}"),
                ));
            }
            Ok(TimeRef::Time(v))
        }
        TimeSpec::Probe(name) => {
            let Some(k) = specs.iter().position(|p| p.name.value == *name) else {
                return Err(SceneError::at(
                    line(t),
                    field,
                    format!("`{name}` is neither a time (\"20 ms\") nor a probe name"),
                ));
            };
            if specs[k].event.is_none() {
                return Err(SceneError::at(
                    line(t),
                    field,
                    format!(
                        "probe `{name}` is not an event probe; only event times can bound a window"
                    ),
                ));
            }
            Ok(TimeRef::Probe(k))
        }
    }
}

/// Builds every probe of the scene against `model`.
pub(super) fn probes(model: &Model, specs: &[ProbeSpec]) -> R<Vec<Probe>> {
    let mut out: Vec<Probe> = Vec::new();
    for (i, p) in specs.iter().enumerate() {
        let f = |s: &str| format!("probes[{i}].{s}");
        if out.iter().any(|q| q.name == p.name.value) {
            return Err(SceneError::at(
                line(&p.name),
                f("name"),
                format!("duplicate probe name `{}`", p.name.value),
            ));
        }
        let (kind, dim) = match (&p.event, &p.measure) {
            (Some(e), None) => {
                if let Some(extra) = [&p.at, &p.from, &p.to].into_iter().flatten().next() {
                    return Err(SceneError::at(
                        line(extra),
                        f("event"),
                        "an event probe takes no `at`, `from` or `to`",
                    ));
                }
                let (event, occurrence) = event(model, e, &f("event"))?;
                (ProbeKind::Event { event, occurrence }, Dim::TIME)
            }
            (None, Some(m)) => {
                let (measure, dim) = measure(model, m, &f("measure"))?;
                let reduce = match p.reduce.as_ref().map(|r| (r.value.as_str(), r)) {
                    None | Some(("at", _)) => Reduce::At,
                    Some(("max", _)) => Reduce::Max,
                    Some(("min", _)) => Reduce::Min,
                    Some(("mean", _)) => Reduce::Mean,
                    Some((other, r)) => {
                        return Err(SceneError::at(
                            line(r),
                            f("reduce"),
                            format!("unknown reduction `{other}` (at, max, min, mean)"),
                        ))
                    }
                };
                let opt = |t: &Option<Spanned<TimeSpec>>, name: &str| {
                    t.as_ref().map(|t| time_ref(specs, t, &f(name))).transpose()
                };
                let (at, from, to) = (opt(&p.at, "at")?, opt(&p.from, "from")?, opt(&p.to, "to")?);
                if reduce == Reduce::At && (from.is_some() || to.is_some()) {
                    return Err(SceneError::at(
                        line(&p.name),
                        f("reduce"),
                        "`from`/`to` need a reduction over the window (max, min, mean)",
                    ));
                }
                if reduce != Reduce::At && at.is_some() {
                    return Err(SceneError::at(
                        line(&p.name),
                        f("at"),
                        "`at` goes with `reduce: at`",
                    ));
                }
                (
                    ProbeKind::Value {
                        measure,
                        reduce,
                        at,
                        from,
                        to,
                    },
                    dim,
                )
            }
            _ => {
                return Err(SceneError::at(
                    line(&p.name),
                    format!("probes[{i}]"),
                    "needs exactly one of `event` and `measure`",
                ))
            }
        };
        let display = match &p.unit {
            None => None,
            Some(u) => Some(
                DisplayUnit::parse(&u.value, dim)
                    .map_err(|m| SceneError::at(line(u), f("unit"), m))?,
            ),
        };
        out.push(Probe {
            name: p.name.value.clone(),
            unit: dim.si_unit(),
            display,
            caution: None,
            kind,
        });
    }
    Ok(out)
}
