//! Error-controlled step size (`IntegrationParameters::step_control`).
//!
//! The θ = 1/2 Moreau–Jean step is the trapezoidal rule on smooth stretches: positions and
//! velocities both carry a local error of −h³/12 times their third derivative (order
//! p = 2). The controller estimates that error from the mean accelerations of the last
//! steps, aⱼ = (vⱼ₊₁ − vⱼ)/hⱼ, at no extra cost a step:
//! - positions: q''' = a', estimated by the divided difference of the last two a;
//! - velocities: v''' = a'', by the second divided difference of the last three.
//!
//! Contacts and joints act through impulses that meet their conditions at the step's end:
//! a step in which one carries an impulse is of first order in the velocities (p = 1), with
//! a local error of h²/2 · a', and the controller holds that to the tolerance instead.
//!
//! A step whose estimate exceeds the tolerance is taken again, smaller; an accepted one
//! sets the next to h · min(2, max(0.2, 0.9 (τ/e)^(1/(p+1)))). A step in which a contact
//! closes carries an impulse, not a force, and no smooth estimate: its error is the
//! impact's. Located (`locate_impacts`), the impact is taken at its instant; otherwise the
//! step moves the bodies with the mean of the velocities before and after the jump Δv, a
//! misplacement of up to h/2 · Δv, and the step is taken again until that is within the
//! tolerance. The estimate then starts afresh after the impact, from a step no longer than
//! the impact's nor than the scene's `h` (the run's first step, which no estimate judges
//! either). A step that ends inside a contact open at its start (a scheme without
//! projection activates a contact only within its forecast's reach) is taken again until
//! that depth is within the tolerance too.

use nalgebra::DVector;

/// The accuracy a controlled run keeps, and the bounds of its step.
#[derive(Clone, Debug, PartialEq)]
pub struct StepControl {
    /// τ: the local error allowed in one step, relative to `length` for positions and to
    /// `speed` for velocities.
    pub tolerance: f64,
    /// Largest step (s): it bounds what the estimate does not see (the drift of a journal
    /// creeping in its bore under friction, whose rate the step sets).
    pub h_max: f64,
    /// Smallest step (s): the controller accepts a step this small whatever its error.
    pub h_min: f64,
    /// Length scale of the position error (m). A body's error is its centre's displacement
    /// plus its radius of gyration times its rotation.
    pub length: f64,
    /// Speed scale of the velocity error (m/s), with the same weighting.
    pub speed: f64,
}

/// The largest step by default, in steps of the scene's `h`.
pub const H_MAX_IN_STEPS: f64 = 10.0;

impl StepControl {
    /// The control at tolerance τ with the defaults for a scene of step `h`: h_max = 10 h,
    /// h_min = 10 ns (or h / 10 where that is smaller), length 1 mm, speed 1 m/s.
    pub fn for_step(tolerance: f64, h: f64) -> StepControl {
        StepControl {
            tolerance,
            h_max: H_MAX_IN_STEPS * h,
            h_min: (1e-8f64).min(0.1 * h),
            length: 1e-3,
            speed: 1.0,
        }
    }

    /// Checks every value; the error names the offending field.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (name, x) in [
            ("step_control.tolerance", self.tolerance),
            ("step_control.h_max", self.h_max),
            ("step_control.h_min", self.h_min),
            ("step_control.length", self.length),
            ("step_control.speed", self.speed),
        ] {
            if !(x.is_finite() && x > 0.0) {
                return Err((name, format!("must be a positive number, got {x}")));
            }
        }
        if self.h_min > self.h_max {
            return Err((
                "step_control.h_min",
                format!(
                    "must not exceed h_max ({} s), got {} s",
                    self.h_max, self.h_min
                ),
            ));
        }
        Ok(())
    }
}

/// Largest growth and shrink of the step from one step to the next, and the safety factor
/// on the step the estimate asks for.
const GROWTH_MAX: f64 = 2.0;
pub(super) const SHRINK_MAX: f64 = 0.2;
const SAFETY: f64 = 0.9;

/// The controller's memory: the mean accelerations of the last smooth steps, newest first,
/// each with its step, and the step to try next.
#[derive(Clone, Debug)]
pub(super) struct Controller {
    history: Vec<(f64, DVector<f64>)>,
    pub(super) proposal: f64,
    /// The first step of the run, and of the stretch after each impact.
    restart: f64,
    /// Per body, its radius of gyration (m): the weight of its rotation in the error.
    radii: Vec<f64>,
}

/// What the controller makes of a step just taken.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Verdict {
    Accept,
    /// Take it again with this step.
    Retry(f64),
}

/// How a step went, as the controller sees it.
pub(super) struct Taken<'a> {
    pub h: f64,
    pub v0: &'a DVector<f64>,
    pub v1: &'a DVector<f64>,
    /// A contact closed in the step (it carries an impact).
    pub closed: bool,
    /// A contact or joint carried an impulse in the step: the velocity step is then of
    /// first order (the impulse is the reaction at the step's end).
    pub constrained: bool,
    /// How deep (m) the step ended in a contact that was open at its start: an impact it
    /// stepped past (a scheme that does not project activates a contact only within
    /// reach of the step's forecast).
    pub overshoot: f64,
    /// The impact was located (the step split at it).
    pub located: bool,
    /// The step ended early at a phase's end, a probe's instant or the run's end.
    pub clipped: bool,
}

impl Controller {
    pub(super) fn new(h0: f64, radii: Vec<f64>) -> Self {
        Controller {
            history: Vec::with_capacity(2),
            proposal: h0,
            restart: h0,
            radii,
        }
    }

    /// Judges a step just taken and, when it stands, remembers it and sets the next step.
    pub(super) fn judge(&mut self, c: &StepControl, step: &Taken) -> Verdict {
        let h = step.h;
        let a = (step.v1 - step.v0) / h;
        let shrinkable = h > c.h_min * (1.0 + 1e-9);
        let overshoot = step.overshoot / c.length;
        if overshoot > c.tolerance && shrinkable {
            let f = (SAFETY * c.tolerance / overshoot).max(SHRINK_MAX);
            return Verdict::Retry((h * f).max(c.h_min));
        }
        if step.closed {
            if !step.located && shrinkable {
                // the step moved the bodies with the mean of the velocities around the jump
                let smooth = self.history.first().map(|(_, a1)| a1 * h);
                let jump = match smooth {
                    Some(s) => step.v1 - step.v0 - s,
                    None => step.v1 - step.v0,
                };
                let misplaced = 0.5 * h * self.weighted(&jump) / c.length;
                if misplaced > c.tolerance {
                    let h_new = h * SAFETY * c.tolerance / misplaced;
                    return Verdict::Retry(h_new.max(c.h_min));
                }
            }
            // the impulse is no force: the estimate starts afresh after the impact, from the
            // first step, which it cannot judge
            self.history.clear();
            self.proposal = self.bounded(c, self.restart.min(h));
            return Verdict::Accept;
        }
        let factor = match self.error(c, h, &a, step.constrained) {
            None => 1.0,
            Some((e, order)) => {
                let f = SAFETY * (c.tolerance / e).powf(1.0 / (order + 1.0));
                if e > c.tolerance && shrinkable {
                    return Verdict::Retry((h * f.max(SHRINK_MAX)).max(c.h_min));
                }
                f.clamp(SHRINK_MAX, GROWTH_MAX)
            }
        };
        self.history.truncate(1);
        self.history.insert(0, (h, a));
        self.proposal = self.bounded(c, (h * factor).max(self.proposal_if(step.clipped)));
        Verdict::Accept
    }

    /// The step proposed before a step that ended early: that end says nothing about the
    /// step the motion allows.
    fn proposal_if(&self, clipped: bool) -> f64 {
        if clipped {
            self.proposal
        } else {
            0.0
        }
    }

    fn bounded(&self, c: &StepControl, h: f64) -> f64 {
        h.clamp(c.h_min, c.h_max)
    }

    /// The estimated local error of a smooth step of size `h` with mean acceleration `a`,
    /// in units of the tolerance's scales, and the order of the term that dominates it;
    /// `None` before a smooth step is known. A `constrained` step's velocity error is of
    /// first order: h²/2 · a'.
    pub(super) fn error(
        &self,
        c: &StepControl,
        h: f64,
        a: &DVector<f64>,
        constrained: bool,
    ) -> Option<(f64, f64)> {
        let (h1, a1) = self.history.first()?;
        // a' at the step's start, from the mean accelerations at the two steps' middles
        let d1 = (a - a1) / (0.5 * (h + h1));
        let k = h * h * h / 12.0;
        let slope = self.weighted(&d1);
        let position = k * slope / c.length;
        if constrained {
            let velocity = 0.5 * h * h * slope / c.speed;
            return Some(match velocity > position {
                true => (velocity, 1.0),
                false => (position, 2.0),
            });
        }
        let velocity = match self.history.get(1) {
            Some((h2, a2)) => {
                let d1_before = (a1 - a2) / (0.5 * (h1 + h2));
                let d2 = (d1 - d1_before) / (0.25 * (h + 2.0 * h1 + h2));
                k * self.weighted(&d2) / c.speed
            }
            None => 0.0,
        };
        Some((position.max(velocity), 2.0))
    }

    /// The largest over the bodies of |linear part| + r |angular part| of the twist-shaped
    /// vector `x`.
    fn weighted(&self, x: &DVector<f64>) -> f64 {
        self.radii
            .iter()
            .enumerate()
            .map(|(b, r)| {
                let lin = x.fixed_rows::<3>(6 * b).norm();
                let ang = x.fixed_rows::<3>(6 * b + 3).norm();
                lin + r * ang
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step of size `h` from `v0` to `v1` with no contact in it.
    fn smooth<'a>(h: f64, v0: &'a DVector<f64>, v1: &'a DVector<f64>) -> Taken<'a> {
        Taken {
            h,
            v0,
            v1,
            closed: false,
            constrained: false,
            overshoot: 0.0,
            located: false,
            clipped: false,
        }
    }

    fn one_dof(v: f64) -> DVector<f64> {
        let mut x = DVector::zeros(6);
        x[0] = v;
        x
    }

    /// On x(t) = t⁴/24 (v = t³/6, a = t²/2) the trapezoidal rule's local errors
    /// are h³/12 · v'' = h³/12 · t for positions and h³/12 · a'' = h³/12 for velocities: the
    /// estimate finds both from three steps' mean accelerations.
    #[test]
    fn the_estimate_matches_the_trapezoidal_rules_local_error() {
        let c = StepControl {
            length: 1.0,
            speed: 1.0,
            ..StepControl::for_step(1e-4, 1e-4)
        };
        let mut ctl = Controller::new(1e-2, vec![0.0]);
        let v = |t: f64| t * t * t / 6.0;
        let h = 1e-2;
        let t = 1.0;
        let mean_a = |t0: f64| one_dof((v(t0 + h) - v(t0)) / h);
        ctl.history = vec![(h, mean_a(t - h)), (h, mean_a(t - 2.0 * h))];
        let e = ctl.error(&c, h, &mean_a(t), false).unwrap().0;
        let position = h * h * h / 12.0 * t;
        assert!((e / position - 1.0).abs() < 0.02, "{e} vs {position}");
        // with the velocity's error ten times heavier, it dominates
        let c = StepControl { speed: 0.01, ..c };
        let e = ctl.error(&c, h, &mean_a(t), false).unwrap().0;
        let velocity = h * h * h / 12.0 / 0.01;
        assert!((e / velocity - 1.0).abs() < 0.02, "{e} vs {velocity}");
    }

    #[test]
    fn a_large_error_retries_smaller_and_a_small_one_grows_at_most_twofold() {
        let c = StepControl {
            tolerance: 1e-6,
            h_max: 1.0,
            length: 1.0,
            speed: 1.0,
            ..StepControl::for_step(1e-4, 1e-4)
        };
        let mut ctl = Controller::new(1e-3, vec![0.0]);
        let (v0, h) = (one_dof(0.0), 1e-3);
        // constant acceleration: no error, growth capped at 2
        for _ in 0..2 {
            let v1 = one_dof(h * 9.81);
            assert_eq!(ctl.judge(&c, &smooth(h, &v0, &v1)), Verdict::Accept);
        }
        assert_eq!(ctl.proposal, 2.0 * h);
        // an acceleration jump of 1e4 m/s²: e = h²/12 · 1e4 · 2 ≈ 1.7e-3 ≫ 1e-6
        let v1 = one_dof(h * (9.81 + 1e4));
        match ctl.judge(&c, &smooth(h, &v0, &v1)) {
            Verdict::Retry(h_new) => assert_eq!(h_new, SHRINK_MAX * h),
            v => panic!("{v:?}"),
        }
    }

    #[test]
    fn an_unlocated_impact_is_retried_until_its_misplacement_is_within_tolerance() {
        let c = StepControl {
            tolerance: 1e-6,
            length: 1.0,
            ..StepControl::for_step(1e-4, 1e-4)
        };
        let mut ctl = Controller::new(1e-3, vec![0.0]);
        let (v0, v1) = (one_dof(-2.0), one_dof(1.6));
        let closed = |h| Taken {
            closed: true,
            ..smooth(h, &v0, &v1)
        };
        // h/2 · 3.6 m/s = 1.8e-3 m at 1 ms: retried at 0.9 · 1e-6 / 1.8 s
        let Verdict::Retry(h) = ctl.judge(&c, &closed(1e-3)) else {
            panic!()
        };
        assert!((h - 0.9e-6 / 1.8).abs() < 1e-15, "{h}");
        assert_eq!(ctl.judge(&c, &closed(h)), Verdict::Accept);
        // located, the same jump is accepted at any step
        let located = Taken {
            located: true,
            ..closed(1e-3)
        };
        assert_eq!(ctl.judge(&c, &located), Verdict::Accept);
    }
}
