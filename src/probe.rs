//! Probes: the named outputs of a run (a functional condition, an event time), evaluated
//! online while the simulation steps, so that a sample keeps a few numbers and no trajectory.

use crate::integrator::Simulation;
use crate::mechanics::{BodyRef, Pose};
use crate::scene::units::DisplayUnit;
use nalgebra::Vector3;

/// A scalar read off the state after a step.
#[derive(Clone, Debug, PartialEq)]
pub enum Measure {
    /// Smallest gap over these contact candidates (m).
    Gap(Vec<usize>),
    /// Total normal impulse of these candidates over the last step divided by h (N).
    ContactForce(Vec<usize>),
    /// (p_to − p_from) · axis; the axis is fixed in `frame` (world when `None`).
    Distance {
        from: (BodyRef, Vector3<f64>),
        to: (BodyRef, Vector3<f64>),
        axis: Vector3<f64>,
        frame: BodyRef,
    },
}

fn world_point(poses: &[Pose], (body, p): &(BodyRef, Vector3<f64>)) -> Vector3<f64> {
    match body {
        Some(i) => poses[*i].point(p),
        None => *p,
    }
}

impl Measure {
    pub fn value(&self, sim: &Simulation) -> f64 {
        match self {
            Measure::Gap(ids) => ids
                .iter()
                .map(|&i| sim.contact_points()[i].gap())
                .fold(f64::INFINITY, f64::min),
            Measure::ContactForce(ids) => {
                ids.iter().map(|&i| sim.impulses()[i].x).sum::<f64>() / sim.h()
            }
            Measure::Distance {
                from,
                to,
                axis,
                frame,
            } => {
                let poses = &sim.state.poses;
                let axis = match frame {
                    Some(b) => poses[*b].dir(axis),
                    None => *axis,
                };
                (world_point(poses, to) - world_point(poses, from)).dot(&axis)
            }
        }
    }
}

/// A time given as a number or as the time of an event probe (by index).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeRef {
    Time(f64),
    Probe(usize),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Up,
    Down,
    Either,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// The candidates' total normal impulse becomes positive, timed within the step: the
    /// event-capturing step knows only that the contact closed somewhere in [t_k, t_k+1],
    /// so the time is t_k + g_k / (−u), the free flight of the step-start gap at the
    /// approach speed u = (g_k − g_k−1)/h of the step before (error about g·h·τ/|u| under
    /// an acceleration g, against h for the step end).
    Closes(Vec<usize>),
    /// The candidates' total normal impulse returns to zero.
    Opens(Vec<usize>),
    Crosses {
        measure: Measure,
        threshold: f64,
        direction: Direction,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduce {
    At,
    Max,
    Min,
    /// Time-weighted: each step's value (a contact force is the step's impulse / h) counts
    /// for the part of its interval inside the window (a contact force for its whole
    /// impulse in the step of a `from` event), so a window's mean does not jump by a step's
    /// share when one of its ends crosses a step boundary.
    Mean,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ProbeKind {
    /// The time of the `occurrence`-th event (from 1).
    Event { event: Event, occurrence: usize },
    Value {
        measure: Measure,
        reduce: Reduce,
        /// For `Reduce::At`: when (default: the end of the run).
        at: Option<TimeRef>,
        from: Option<TimeRef>,
        to: Option<TimeRef>,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    pub name: String,
    /// SI unit of the value ("s", "m", "N").
    pub unit: String,
    /// The unit to show it in (`unit:` in the scene), if the scene gives one.
    pub display: Option<DisplayUnit>,
    /// Why the value depends on the step size, if it does (a peak of an impulsive force
    /// in a rigid model), with the converged alternative; shown wherever the value is.
    pub caution: Option<String>,
    pub kind: ProbeKind,
}

/// Per-probe progress during a run.
#[derive(Clone, Debug, Default)]
struct Progress {
    /// The final value, once known.
    value: Option<f64>,
    /// Events: occurrences so far; `Max`, `Min`: samples in the window.
    count: usize,
    /// `Mean`: the time the samples cover inside the window (s).
    weight: f64,
    /// Events: whether the contact was closed after the previous step; values: running
    /// reduction.
    closed: bool,
    acc: f64,
    /// The previous observation (t, measure), to interpolate crossings and `at` times.
    previous: Option<(f64, f64)>,
    /// `Closes` events: each candidate's gap at the previous observation and its rate over
    /// the step before it.
    approach: Vec<(f64, f64)>,
}

impl Progress {
    /// The window's max, min or mean, if it held a sample.
    fn reduced(&self, reduce: Reduce) -> Option<f64> {
        match reduce {
            Reduce::Mean => (self.weight > 0.0).then(|| self.acc / self.weight),
            _ => (self.count > 0).then_some(self.acc),
        }
    }
}

/// When, within a step of size h, a contact at gap `gap` approaching at normal velocity
/// `u` (< 0) touches: the free flight gap/(−u), from −h (it touched during the previous
/// step and the step ended penetrating, as plain Moreau–Jean allows) to h. A contact that
/// does not approach closes at the step start if touching, else at the step end.
fn closing_delay(gap: f64, u: f64, h: f64) -> f64 {
    if u < 0.0 {
        (gap / -u).clamp(-h, h)
    } else if gap <= 0.0 {
        0.0
    } else {
        h
    }
}

/// Observes a simulation step by step and produces every probe's value.
#[derive(Clone)]
pub struct ProbeRecorder<'a> {
    probes: &'a [Probe],
    progress: Vec<Progress>,
    /// The previous observation's time: the step just observed covers (last_t, t].
    last_t: Option<f64>,
}

impl<'a> ProbeRecorder<'a> {
    pub fn new(probes: &'a [Probe]) -> Self {
        ProbeRecorder {
            probes,
            progress: vec![Progress::default(); probes.len()],
            last_t: None,
        }
    }

    /// The time of an event probe, if it happened.
    fn time(&self, r: TimeRef) -> Option<f64> {
        match r {
            TimeRef::Time(t) => Some(t),
            TimeRef::Probe(i) => self.progress[i].value,
        }
    }

    /// Updates every probe with the state after a step (and once with the initial state).
    pub fn observe(&mut self, sim: &Simulation) {
        let t = sim.state.t;
        let half_step = 0.5 * sim.h();
        // events first, so that a window opened by an event includes the event's step
        for (p, g) in self.probes.iter().zip(self.progress.iter_mut()) {
            let ProbeKind::Event { event, occurrence } = &p.kind else {
                continue;
            };
            if g.value.is_some() {
                continue;
            }
            let hit = match event {
                Event::Closes(ids) | Event::Opens(ids) => {
                    let pressed = |i: usize| sim.impulses()[i].x > 0.0;
                    let closed = ids.iter().any(|&i| pressed(i));
                    let hit = match event {
                        Event::Closes(_) => (closed && !g.closed).then(|| {
                            let h = sim.h();
                            ids.iter()
                                .zip(&g.approach)
                                .filter(|(&i, _)| pressed(i))
                                .map(|(_, &(gap, u))| t - h + closing_delay(gap, u, h))
                                .fold(t, f64::min)
                        }),
                        _ => (!closed && g.closed).then_some(t),
                    };
                    g.closed = closed;
                    if let Event::Closes(_) = event {
                        // the gap rate over the step just done, not the end-of-step velocity:
                        // with θ = 1/2 a driven body's end velocities alternate about its
                        // prescribed speed (0, 2v, 0, …) while its position moves at v
                        let v = sim.state.v.as_slice();
                        let h = sim.h();
                        let before = std::mem::take(&mut g.approach);
                        g.approach = ids
                            .iter()
                            .enumerate()
                            .map(|(k, &i)| {
                                let c = &sim.contact_points()[i];
                                let rate = before
                                    .get(k)
                                    .map_or(c.local_velocity(v).x, |&(g0, _)| (c.gap() - g0) / h);
                                (c.gap(), rate)
                            })
                            .collect();
                    }
                    hit
                }
                Event::Crosses {
                    measure,
                    threshold,
                    direction,
                } => {
                    let v = measure.value(sim);
                    let hit = g.previous.and_then(|(t0, v0)| {
                        let up = v0 < *threshold && v >= *threshold;
                        let down = v0 > *threshold && v <= *threshold;
                        let wanted = match direction {
                            Direction::Up => up,
                            Direction::Down => down,
                            Direction::Either => up || down,
                        };
                        wanted.then(|| t0 + (t - t0) * (threshold - v0) / (v - v0))
                    });
                    g.previous = Some((t, v));
                    hit
                }
            };
            if let Some(when) = hit {
                g.count += 1;
                if g.count == *occurrence {
                    g.value = Some(when);
                }
            }
        }
        for i in 0..self.probes.len() {
            let ProbeKind::Value {
                measure,
                reduce,
                at,
                from,
                to,
            } = &self.probes[i].kind
            else {
                continue;
            };
            if self.progress[i].value.is_some() {
                continue;
            }
            if *reduce == Reduce::At {
                let v = measure.value(sim);
                if let Some(at) = at.and_then(|r| self.time(r)) {
                    let g = &mut self.progress[i];
                    if t >= at - half_step * 1e-6 {
                        // linear interpolation between the steps around a given time; an
                        // event's time is a step end, where this gives the step's value
                        g.value = Some(match g.previous {
                            Some((t0, v0)) if t > t0 && at > t0 => {
                                v0 + (v - v0) * (at - t0) / (t - t0)
                            }
                            _ => v,
                        });
                    }
                }
                self.progress[i].previous = Some((t, v));
                continue;
            }
            if *reduce == Reduce::Mean {
                // ∫ value dt over [from, to] / (to − from): the step just taken covers
                // (last_t, t] (the initial state covers nothing) and counts for its overlap
                // with the window, except that a contact force counts its whole impulse in
                // the step where a `from` event falls: the impulse is that of the contact
                // the event closed (a `closes` event is timed within its step). A `from`
                // event timed before the step's start (a contact that touched in the step
                // before) counts from the step's start: earlier steps were observed before
                // it was known.
                let Some(t_prev) = self.last_t else {
                    continue;
                };
                let t1 = to.and_then(|r| self.time(r));
                let t0 = match from {
                    None => Some(f64::NEG_INFINITY),
                    Some(r) => self.time(*r),
                };
                let g = &mut self.progress[i];
                if t1.is_some_and(|t1| t_prev >= t1) {
                    g.value = g.reduced(Reduce::Mean);
                    continue;
                }
                let Some(t0) = t0 else {
                    continue;
                };
                let end = t.min(t1.unwrap_or(f64::INFINITY));
                let w = end - t_prev.max(t0);
                let opened_by_event = matches!(from, Some(TimeRef::Probe(_))) && t0 > t_prev;
                let whole_impulse = opened_by_event && matches!(measure, Measure::ContactForce(_));
                // the event's impulse counts even when the event is timed at the step's very
                // end (w = 0): a contact closing late in a step whose free-flight estimate
                // overshoots it is timed there, and its impact would otherwise be dropped
                if w > 0.0 || (whole_impulse && t0 <= end) {
                    let covered = if whole_impulse { end - t_prev } else { w };
                    g.acc += covered * measure.value(sim);
                    g.weight += w.max(0.0);
                }
                continue;
            }
            let started = match from {
                None => true,
                Some(r) => self.time(*r).is_some_and(|t0| t >= t0 - half_step),
            };
            let ended = to
                .and_then(|r| self.time(r))
                .is_some_and(|t1| t > t1 + half_step);
            let g = &mut self.progress[i];
            if ended {
                g.value = g.reduced(*reduce);
                continue;
            }
            if !started {
                continue;
            }
            let v = measure.value(sim);
            g.acc = match (g.count, reduce) {
                (0, _) => v,
                (_, Reduce::Max) => g.acc.max(v),
                // `Min` (a mean accumulates above, `At` before)
                _ => g.acc.min(v),
            };
            g.count += 1;
        }
        self.last_t = Some(t);
    }

    /// Whether every probe is known, so that the run can stop early.
    pub fn done(&self) -> bool {
        self.progress.iter().all(|g| g.value.is_some())
    }

    /// Each probe's value at the end of the run, or why it has none.
    pub fn finish_each(mut self, t_end: f64) -> Vec<Result<f64, String>> {
        let mut out = Vec::with_capacity(self.probes.len());
        for (i, p) in self.probes.iter().enumerate() {
            if let Some(v) = self.progress[i].value {
                out.push(Ok(v));
                continue;
            }
            if let ProbeKind::Value {
                to: Some(TimeRef::Probe(k)),
                ..
            } = p.kind
            {
                if self.progress[k].value.is_none() {
                    out.push(Err(format!(
                        "probe `{}`: its window ends at event `{}`, which did not happen by t = {t_end} s",
                        p.name, self.probes[k].name
                    )));
                    continue;
                }
            }
            let g = &mut self.progress[i];
            out.push(match &p.kind {
                ProbeKind::Event { occurrence, .. } => Err(format!(
                    "probe `{}`: the event happened {} time(s) by t = {t_end} s, occurrence {occurrence} was asked for",
                    p.name, g.count
                )),
                ProbeKind::Value { reduce, at, .. } => {
                    if *reduce == Reduce::At && at.is_none() {
                        g.value = g.previous.map(|(_, v)| v);
                    } else if *reduce != Reduce::At {
                        g.value = g.reduced(*reduce);
                    }
                    g.value.ok_or_else(|| {
                        format!(
                            "probe `{}`: its time or window was not reached by t = {t_end} s",
                            p.name
                        )
                    })
                }
            });
        }
        out
    }
}
