#![allow(dead_code)] // each user takes the cells it needs

//! Stability at the extremes: the cases where published integrators break (micrometre
//! clearances, steps from 1e-7 to 1e-2 s, e = 0 and 1, μ up to 5, fast spin, long runs,
//! stiff springs, many contacts), each run to its end and checked. A cell passes when the
//! run ends without NaN or a modelling error, penetration and joint violation stay within
//! tolerance and the energy does not grow where the physics forbids it. Steps whose solver
//! missed its tolerance do not fail a cell, but they are counted and shown, never hidden.
//!
//! A harness for tests and examples, outside the library: `tests/extremes.rs` runs the
//! matrix at a size CI affords; `cargo run --release --example extremes` runs it in full
//! and prints the table of docs/extremes.md.

use mc_study::scene::Scene;
use std::time::Instant;

/// Largest accepted penetration of a contact and violation of a joint (m).
pub const POSITION_TOLERANCE: f64 = 1e-9;

const PENDULUM_CLEARANCE: &str = include_str!("../../studies/pendulum-clearance/scene.yaml");
const PENDULUM: &str = include_str!("../../studies/pendulum/scene.yaml");

/// One cell of the matrix: a scene, how long to run it and what the physics allows.
pub struct Case {
    pub group: &'static str,
    pub label: String,
    pub scene: Scene,
    pub steps: u64,
    /// Energy may not rise above its initial value by more than this fraction of the
    /// energy scale; `None` where an actuator or a prescribed motion adds energy.
    pub energy_growth_allowed: Option<f64>,
    /// Energy scale (J) the growth is measured against; `None`: the initial energy.
    pub energy_scale: Option<f64>,
}

/// What a cell measured.
#[derive(Clone, Debug)]
pub struct Cell {
    pub group: &'static str,
    pub label: String,
    pub h: f64,
    pub steps: u64,
    /// The run's error (NaN, modelling error), if it stopped early.
    pub error: Option<String>,
    pub max_penetration: f64,
    pub max_joint_violation: f64,
    /// Steps whose contact solver, Newton loop or projection missed its tolerance.
    pub failures: u64,
    /// max(E − E₀) over the run, relative to the case's energy scale.
    pub energy_growth: f64,
    /// |E_end − E₀| relative to the energy scale.
    pub energy_drift: f64,
    /// max ||p| − 1| over the bodies at the end.
    pub quaternion_drift: f64,
    pub us_per_step: f64,
    pub pass: bool,
    /// Why it failed, if it did.
    pub verdict: String,
}

impl Case {
    pub fn run(mut self) -> Cell {
        let h = self.scene.params.h;
        let mut sim = match self.scene.simulation() {
            Ok(s) => s,
            Err(e) => return self.failed_to_start(h, e.to_string()),
        };
        let e0 = sim.energy();
        let mut growth = 0.0f64;
        let start = Instant::now();
        let mut error = None;
        for _ in 0..self.steps {
            if let Err(e) = sim.step() {
                error = Some(e.to_string());
                break;
            }
            growth = growth.max(sim.energy() - e0);
        }
        let us = start.elapsed().as_secs_f64() * 1e6 / sim.stats.steps.max(1) as f64;
        let st = sim.stats;
        let quaternion_drift = sim
            .state
            .poses
            .iter()
            .map(|p| (p.p.as_ref().norm() - 1.0).abs())
            .fold(0.0, f64::max);
        let failures = st.solver_failures + st.newton_failures + st.projection_failures;
        let scale = self.energy_scale.unwrap_or(e0.abs()).max(f64::MIN_POSITIVE);
        let mut why = Vec::new();
        if let Some(e) = &error {
            why.push(format!("stopped: {e}"));
        }
        if st.max_penetration > POSITION_TOLERANCE {
            why.push(format!("penetration {:.1e} m", st.max_penetration));
        }
        if st.max_joint_violation > POSITION_TOLERANCE {
            why.push(format!("joint violation {:.1e} m", st.max_joint_violation));
        }
        if let Some(allowed) = self.energy_growth_allowed {
            if growth > allowed * scale {
                why.push(format!("energy grew by {growth:.2e} J"));
            }
        }
        Cell {
            group: self.group,
            label: std::mem::take(&mut self.label),
            h,
            steps: st.steps,
            error,
            max_penetration: st.max_penetration,
            max_joint_violation: st.max_joint_violation,
            failures,
            energy_growth: growth / scale,
            energy_drift: (sim.energy() - e0).abs() / scale,
            quaternion_drift,
            us_per_step: us,
            pass: why.is_empty(),
            verdict: why.join("; "),
        }
    }

    fn failed_to_start(self, h: f64, e: String) -> Cell {
        Cell {
            group: self.group,
            label: self.label,
            h,
            steps: 0,
            error: Some(e.clone()),
            max_penetration: 0.0,
            max_joint_violation: 0.0,
            failures: 0,
            energy_growth: 0.0,
            energy_drift: 0.0,
            quaternion_drift: 0.0,
            us_per_step: 0.0,
            pass: false,
            verdict: e,
        }
    }
}

fn scene(text: &str, file: &str) -> Scene {
    Scene::from_yaml(text, file).expect("the extremes scenes are valid")
}

/// The bar of `studies/pendulum-clearance` (1 kg, 1 m; journal radius 5 mm, bore length
/// 10 mm, so it jams at μ ≥ L_B / 2R_J = 1) with clearance c, step h, μ and e, run for
/// `t` seconds (at most `max_steps`).
pub fn clearance_pendulum(c: f64, h: f64, mu: f64, e: f64, t: f64, max_steps: u64) -> Case {
    let mut s = scene(PENDULUM_CLEARANCE, "pendulum-clearance/scene.yaml");
    s.set_parameter("joints.pivot.clearance", c).unwrap();
    s.set_parameter("joints.pivot.mu", mu).unwrap();
    s.set_parameter("joints.pivot.e", e).unwrap();
    s.params.h = h;
    let steps = ((t / h).round() as u64).clamp(1, max_steps);
    Case {
        group: "clearance pendulum",
        label: format!(
            "c = {}, h = {h:e}, μ = {mu}, e = {e}, {}",
            length(c),
            seconds(steps as f64 * h)
        ),
        scene: s,
        steps,
        // friction, e ≤ 1 and the trapezoidal rule do no positive work: allow the O((ωh)²)
        // oscillation of the discrete energy and the projection's 1e-10 m × m g
        energy_growth_allowed: Some(1e-3),
        energy_scale: Some(PENDULUM_ENERGY),
    }
}

/// m g L/2 of the pendulum bar (J): the energy scale of its swing.
const PENDULUM_ENERGY: f64 = 1.0 * 9.81 * 0.5;

/// The ideal-joint pendulum of `studies/pendulum` at step h.
pub fn ideal_pendulum(h: f64, t: f64, max_steps: u64) -> Case {
    let mut s = scene(PENDULUM, "pendulum/scene.yaml");
    s.params.h = h;
    let steps = ((t / h).round() as u64).clamp(1, max_steps);
    Case {
        group: "ideal pendulum",
        label: format!("h = {h:e}, {}", seconds(steps as f64 * h)),
        scene: s,
        steps,
        energy_growth_allowed: Some(1e-3),
        energy_scale: Some(PENDULUM_ENERGY),
    }
}

/// A bar of 1 kg and 1 m on a frictionless joint of 10 mm clearance (journal radius 10 mm,
/// e = 0.5), released horizontal with its journal centred, for `duration` at a step h far
/// coarser than the clearance: 0.01 s carries the journal 30 mm, 0.05 s is five steps to a
/// quarter swing. `planar` holds it in its plane (`plane: xz`); in space its roll grows and
/// brings the journal against both flanges. The scheme takes a step whose trial leaves the
/// bore, or whose projection fails or lands far off, in halves. At 0.05 s in the plane the
/// discrete energy still rises by 0.11 % of m g L/2 over the run (0.0056 J), from the first
/// step: the cell allows 0.3 %.
pub fn coarse_clearance_pendulum(h: f64, planar: bool, duration: f64) -> Case {
    let text = format!(
        "name: coarse-clearance-pendulum
duration: {duration} s
{plane}
integrator: {{ h: {h} }}
bodies:
  - {{ name: bar, mass: 1 kg, shape: {{ box: {{ size: [1 m, 20 mm, 20 mm] }} }}, position: [0.5 m, 0, 0] }}
joints:
  - {{ name: pivot, type: revolute-clearance, body_a: ground, body_b: bar, anchor: [0, 0, 0],
      axis: [0, 1, 0], clearance: 10 mm, journal_radius: 10 mm, bore_length: 20 mm, mu: 0, e: 0.5 }}
",
        plane = if planar { "plane: xz" } else { "" },
    );
    let space = if planar { "in its plane" } else { "in space" };
    Case {
        group: "coarse steps on a 10 mm clearance",
        label: format!("h = {h:e}, e = 0.5, μ = 0, {duration} s {space}"),
        scene: scene(&text, "coarse-clearance-pendulum"),
        steps: (duration / h).round() as u64,
        energy_growth_allowed: Some(if h > 0.02 { 3e-3 } else { 1e-3 }),
        energy_scale: Some(PENDULUM_ENERGY),
    }
}

/// Newton's cradle: `n` balls of 1 kg, e = 1, frictionless, 0.1 mm apart, the first
/// striking at 1 m/s, at h = 1 ms: every impact of the row falls within one step (gap ≪ v h).
pub fn row_of_balls(n: usize) -> Case {
    let mut text = String::from(
        "name: row-of-balls
duration: 0.01 s
gravity: [0, 0, 0]
integrator: { h: 1 ms, scheme: combined-projection }
bodies:
",
    );
    for k in 0..n {
        let v = if k == 0 { ", velocity: [1, 0, 0]" } else { "" };
        text += &format!(
            "  - {{ name: b{k}, mass: 1 kg, shape: {{ sphere: {{ radius: 0.05 }} }}, position: [{}, 0, 0]{v} }}\n",
            k as f64 * 0.1001
        );
    }
    text += "contacts:\n";
    for k in 1..n {
        text += &format!(
            "  - {{ name: c{k}, body: b{}, shape: {{ sphere: {{ radius: 0.05 }} }}, against: b{k}, against_shape: {{ sphere: {{ radius: 0.05 }} }}, mu: 0, e: 1 }}\n",
            k - 1
        );
    }
    Case {
        group: "impacts closer than v h",
        label: format!("{n} balls, gaps 0.1 mm, v h = 1 mm"),
        scene: scene(&text, "row-of-balls"),
        steps: 10,
        energy_growth_allowed: Some(1e-9),
        energy_scale: None,
    }
}

/// A 1 kg ball of radius 0.1 m thrown at 2 m/s horizontally with 30 rad/s of backspin from
/// 1 m onto a plane with restitution e and friction μ, for 2 s at h = 1 ms.
pub fn oblique_ball(e: f64, mu: f64) -> Case {
    let text = format!(
        "name: oblique-ball
duration: 2 s
integrator: {{ h: 1 ms, scheme: combined-projection }}
bodies:
  - {{ name: ball, mass: 1 kg, shape: {{ sphere: {{ radius: 0.1 m }} }}, position: [0, 0, 1 m],
      velocity: [2, 0, 0], angular_velocity: [0, -30, 0] }}
contacts:
  - {{ name: floor, body: ball, shape: {{ sphere: {{ radius: 0.1 m }} }}, against: ground,
      against_shape: {{ plane: {{ point: [0, 0, 0], normal: [0, 0, 1] }} }}, mu: {mu}, e: {e} }}
"
    );
    let s = scene(&text, "oblique-ball");
    Case {
        group: "restitution × friction (oblique ball)",
        label: format!("e = {e}, μ = {mu}"),
        scene: s,
        steps: 2000,
        energy_growth_allowed: Some(1e-9),
        energy_scale: None,
    }
}

/// A free body, inertia diag(1, 2, 3) kg m², spinning at `omega` rad/s about its major axis
/// with a 1 % wobble, no gravity, step h. The trapezoidal rule's energy error is bounded,
/// O((hΩ)²): the energy may not rise above E₀ by more than 1e-4 (hΩ)² E₀.
pub fn spinning_body(omega: f64, h: f64, steps: u64) -> Case {
    let text = format!(
        "name: spinning-body
duration: 1 s
gravity: [0, 0, 0]
integrator: {{ h: {h} }}
bodies:
  - {{ name: body, mass: 1 kg, inertia: [1, 2, 3], angular_velocity: [{w1}, {w2}, {omega}] }}
",
        w1 = 0.01 * omega,
        w2 = 0.01 * omega,
    );
    let s = scene(&text, "spinning-body");
    Case {
        group: "fast rotation",
        label: format!("Ω = {omega:e} rad/s, h = {h:e}, hΩ = {}", h * omega),
        scene: s,
        steps,
        energy_growth_allowed: Some(1e-4 * (h * omega).powi(2)),
        energy_scale: None,
    }
}

/// A 1 kg mass on a linear spring (no gravity) with k h²/m = `stiffness`, h = 1 ms,
/// released 10 mm from rest, for 10⁴ steps.
pub fn stiff_spring(stiffness: f64) -> Case {
    let h = 1e-3;
    let k = stiffness / (h * h);
    let text = format!(
        "name: stiff-spring
duration: 10 s
gravity: [0, 0, 0]
integrator: {{ h: {h} }}
bodies:
  - {{ name: mass, mass: 1 kg, inertia: [1, 1, 1], position: [0.01, 0, 0] }}
forces:
  - spring: {{ body_a: mass, body_b: ground, point_b: [0, 0, 0], stiffness: {k}, rest_length: 0 }}
"
    );
    let s = scene(&text, "stiff-spring");
    Case {
        group: "stiff spring",
        label: format!("k h²/m = {stiffness:e}"),
        scene: s,
        steps: 10_000,
        energy_growth_allowed: Some(1e-8),
        energy_scale: None,
    }
}

/// `n` boxes (0.2 × 0.2 × 0.1 m, 1 kg) stacked on the ground, each resting on its four
/// bottom corners (point contacts against the box below, or the plane), μ = 0.5, released
/// at rest; 1 s at h = 1 ms. n = 1 is the box on four corners.
pub fn box_stack(n: usize) -> Case {
    let mut text = String::from(
        "name: box-stack
duration: 1 s
integrator: { h: 1 ms, scheme: combined-projection }
bodies:
",
    );
    for i in 0..n {
        text += &format!(
            "  - {{ name: b{i}, mass: 1 kg, shape: {{ box: {{ size: [0.2, 0.2, 0.1] }} }}, position: [0, 0, {}] }}\n",
            0.05 + 0.1 * i as f64
        );
    }
    text += "contacts:\n";
    let corners = [(0.09, 0.09), (0.09, -0.09), (-0.09, 0.09), (-0.09, -0.09)];
    for i in 0..n {
        for (k, (x, y)) in corners.iter().enumerate() {
            let against = if i == 0 {
                "against: ground, against_shape: { plane: { point: [0, 0, 0], normal: [0, 0, 1] } }"
                    .to_string()
            } else {
                format!(
                    "against: b{}, against_shape: {{ box: {{ size: [0.2, 0.2, 0.1] }} }}",
                    i - 1
                )
            };
            text += &format!(
                "  - {{ name: c{i}_{k}, body: b{i}, shape: {{ point: {{ position: [{x}, {y}, -0.05] }} }}, {against}, mu: 0.5, e: 0 }}\n"
            );
        }
    }
    let s = scene(&text, "box-stack");
    Case {
        group: "many contacts",
        label: format!(
            "{n} box{} on {} corner contacts",
            if n > 1 { "es" } else { "" },
            4 * n
        ),
        scene: s,
        steps: 1000,
        // at rest: the energy may not rise beyond round-off
        energy_growth_allowed: Some(1e-9),
        energy_scale: None,
    }
}

/// A duration in seconds for labels, without round-off digits.
fn seconds(t: f64) -> String {
    format!("{} s", (t * 1e9).round() / 1e9)
}

/// A length in µm or mm for labels.
fn length(c: f64) -> String {
    if c < 1e-3 {
        format!("{} µm", (c * 1e6 * 1e3).round() / 1e3)
    } else {
        format!("{} mm", (c * 1e3 * 1e3).round() / 1e3)
    }
}

/// The cells as a Markdown table.
pub fn table(cells: &[Cell]) -> String {
    let mut s = String::from(
        "| group | case | steps | max penetration (m) | joint violation (m) | failed steps | energy growth / scale | \\|E − E₀\\| / scale | \\|\\|p\\| − 1\\| | µs/step | result |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for c in cells {
        s += &format!(
            "| {} | {} | {} | {:.1e} | {:.1e} | {} | {:.1e} | {:.1e} | {:.1e} | {:.1} | {} |\n",
            c.group,
            c.label,
            c.steps,
            c.max_penetration,
            c.max_joint_violation,
            c.failures,
            c.energy_growth,
            c.energy_drift,
            c.quaternion_drift,
            c.us_per_step,
            if c.pass && c.failures > 0 {
                format!("pass ({} failed steps reported)", c.failures)
            } else if c.pass {
                "pass".to_string()
            } else {
                format!("**fail**: {}", c.verdict)
            }
        );
    }
    s
}
