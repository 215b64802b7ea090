//! Integration parameters with documented defaults (never magic numbers in the loop).

use super::step_control::StepControl;
use crate::mechanics::ContactPoint;
use crate::solver::NsgsOptions;

/// Which time-stepping scheme runs. All share one velocity step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Scheme {
    /// Plain Moreau–Jean: velocity-level contact with the γ-forecast activation
    /// `g + γ h u_N ≤ margin`, joints at velocity level only. Fast; may penetrate by
    /// O(h·u_N) and lets joints drift.
    MoreauJean,
    /// Activation from the end-of-step position (a contact with g(q_{k+1}) ≤ 0 outside the
    /// active set is added and the step redone), then projection of the pressed or
    /// penetrating active contacts and of the joints onto g = 0, h = 0. The reference
    /// scheme: no penetration, no drift, velocities from the Moreau–Jean step.
    #[default]
    CombinedProjection,
    /// Plain step, then projection of the active contacts as inequalities and the joints.
    DirectProjection,
}

impl Scheme {
    pub fn name(&self) -> &'static str {
        match self {
            Scheme::MoreauJean => "moreau-jean",
            Scheme::CombinedProjection => "combined-projection",
            Scheme::DirectProjection => "direct-projection",
        }
    }

    /// Whether the scheme projects positions onto the admissible set after the velocity
    /// step (every scheme but plain Moreau–Jean).
    pub fn projects(&self) -> bool {
        *self != Scheme::MoreauJean
    }

    pub fn parse(name: &str) -> Option<Scheme> {
        [
            Scheme::MoreauJean,
            Scheme::CombinedProjection,
            Scheme::DirectProjection,
        ]
        .into_iter()
        .find(|s| s.name() == name)
    }
}

/// Fidelity presets of a study (`fidelity: { preset: fast }`), relative to the scene's own
/// integrator settings (with `step_control`, its tolerance instead of h), which its author chose for that mechanism: a step that suits a
/// bouncing ball is 100× too coarse for a latch. Their measured error and cost on the
/// bundled scenes are in the README (`mc-study converge` prints them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// h × 4 and the contact-solver tolerance × 100: a quick look at a study.
    Fast,
    /// The scene as written.
    Balanced,
    /// h / 4 and the contact-solver tolerance / 100 (not below 1e-12).
    Accurate,
}

impl Preset {
    pub const ALL: [Preset; 3] = [Preset::Fast, Preset::Balanced, Preset::Accurate];

    pub fn name(&self) -> &'static str {
        match self {
            Preset::Fast => "fast",
            Preset::Balanced => "balanced",
            Preset::Accurate => "accurate",
        }
    }

    pub fn parse(name: &str) -> Option<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == name)
    }

    pub fn apply(&self, p: &mut IntegrationParameters) {
        match self {
            Preset::Fast => {
                p.h *= 4.0;
                p.solver.tolerance *= 100.0;
                if let Some(c) = &mut p.step_control {
                    c.tolerance *= STEP_RATIO_CUBED;
                }
            }
            Preset::Balanced => {}
            Preset::Accurate => {
                p.h /= 4.0;
                p.solver.tolerance = (p.solver.tolerance / 100.0).max(1e-12);
                if let Some(c) = &mut p.step_control {
                    c.tolerance /= STEP_RATIO_CUBED;
                }
            }
        }
    }
}

/// A preset's change of a controlled run's tolerance: the local error goes with h³, so
/// 4³ matches the fixed step's × 4.
const STEP_RATIO_CUBED: f64 = 64.0;

#[derive(Clone, Debug, PartialEq)]
pub struct IntegrationParameters {
    /// Time step h (s). Default 1e-4 s, the Siconos mechanisms toolbox default.
    pub h: f64,
    /// θ of the θ-rule on the smooth forces, in [1/2, 1]. Default 1/2 (trapezoidal: no
    /// numerical dissipation; conserves energy with e = 1).
    pub theta: f64,
    /// γ of the activation forecast `g + γ h u_N ≤ 0`. Default 1/2.
    pub gamma: f64,
    pub scheme: Scheme,
    /// A contact enters the velocity problem when `g + γ h u_N ≤ activation_margin` (m).
    /// Default 1e-9 m. The small positive margin keeps resting contacts (a box on four
    /// corners, u_N ≈ ±1e-12 from round-off) from flickering in and out of the active set,
    /// which would rock the body; an active contact with a positive gap still separates
    /// freely, so the margin only bounds how early an approach is stopped.
    pub activation_margin: f64,
    /// FC3D solver tolerance (relative natural-map error) and sweep limit.
    /// Defaults 1e-10 (the Siconos slider-crank setting; redundant contacts such as the
    /// two rings of a clearance joint in a planar mechanism floor the error near 1e-12)
    /// and 1000.
    pub solver: NsgsOptions,
    /// Newton loop on the smooth forces: relative residual tolerance (default 1e-10) and
    /// iteration limit (default 15), as in the Siconos mechanisms toolbox.
    pub newton_tolerance: f64,
    pub newton_max_iterations: usize,
    /// Position projection: largest accepted violation of a projected row (m for gaps and
    /// joint anchors, rad for joint angles). Default 1e-10, far below a 1 µm clearance.
    pub projection_tolerance: f64,
    /// Gauss–Newton iterations of the projection per step. Default 20.
    pub projection_max_iterations: usize,
    /// Passes of the combined scheme's activation loop per step. Default 50.
    pub max_active_set_passes: usize,
    /// Redo a step in which a contact closes as the part before the impact, the impact
    /// itself and the part after it (`Simulation::step`; combined projection only, whose
    /// activation loop finds the closing contacts). Default false. The θ-rule moves
    /// the bodies over an impact's step with the mean of the pre- and post-impact
    /// velocities, an error of up to h/2 times the jump that falls with h only at first
    /// order and changes sign with where the impact falls in its step.
    pub locate_impacts: bool,
    /// Error-controlled step size (`step_control.rs`): h is then the first step, and the
    /// controller sizes the others. None (the default) keeps every step at h.
    pub step_control: Option<StepControl>,
}

impl Default for IntegrationParameters {
    fn default() -> Self {
        IntegrationParameters {
            h: 1e-4,
            theta: 0.5,
            gamma: 0.5,
            scheme: Scheme::CombinedProjection,
            activation_margin: 1e-9,
            solver: NsgsOptions::default(),
            newton_tolerance: 1e-10,
            newton_max_iterations: 15,
            projection_tolerance: 1e-10,
            projection_max_iterations: 20,
            max_active_set_passes: 50,
            locate_impacts: false,
            step_control: None,
        }
    }
}

/// Depth, in projection tolerances, to which a state counts as admissible.
const ADMISSIBLE_DEPTH: f64 = 10.0;

impl IntegrationParameters {
    /// The penetration or joint violation (m) within which a state counts as admissible:
    /// `ADMISSIBLE_DEPTH` projection tolerances. A projecting scheme holds contacts and
    /// joints to its tolerance; a run whose states end up farther off did not do what the
    /// scheme promises (a study marks it `suspect`).
    pub fn admissible_depth(&self) -> f64 {
        ADMISSIBLE_DEPTH * self.projection_tolerance
    }

    /// The activation forecast of contact `c` over a step of size `h` from the velocities
    /// `v0`: g + γ h u_N. The contact enters the velocity problem when it is at most
    /// `activation_margin`.
    pub fn forecast(&self, c: &ContactPoint, v0: &[f64]) -> f64 {
        c.gap() + self.gamma * self.h * c.normal_velocity(v0)
    }

    /// Checks every value; the error names the offending field.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let positive = |name: &'static str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err((name, format!("must be a positive number, got {x}")))
            }
        };
        positive("h", self.h)?;
        if !(0.5..=1.0).contains(&self.theta) {
            return Err(("theta", format!("must be in [0.5, 1], got {}", self.theta)));
        }
        if !(0.0..=1.0).contains(&self.gamma) {
            return Err(("gamma", format!("must be in [0, 1], got {}", self.gamma)));
        }
        if !(self.activation_margin.is_finite() && self.activation_margin >= 0.0) {
            return Err((
                "activation_margin",
                format!("must be ≥ 0, got {}", self.activation_margin),
            ));
        }
        positive("solver.tolerance", self.solver.tolerance)?;
        positive("newton.tolerance", self.newton_tolerance)?;
        if self.solver.max_sweeps == 0 {
            return Err(("solver.max_iterations", "must be at least 1".into()));
        }
        positive("projection.tolerance", self.projection_tolerance)?;
        if self.projection_max_iterations == 0 {
            return Err(("projection.max_iterations", "must be at least 1".into()));
        }
        if self.max_active_set_passes == 0 {
            return Err(("max_active_set_passes", "must be at least 1".into()));
        }
        if self.newton_max_iterations == 0 {
            return Err(("newton.max_iterations", "must be at least 1".into()));
        }
        if let Some(c) = &self.step_control {
            c.validate()?;
        }
        Ok(())
    }
}
