//! Block on an incline with Coulomb friction, 4 corner contacts in 3D:
//! exact stopping time, no creep after sticking, the sliding acceleration, and friction
//! opposite to the sliding velocity for an oblique start.

mod common;

use mc_study::integrator::Simulation;
use mc_study::scene::Scene;
use nalgebra::Vector3;

const G: f64 = 9.81;

/// A 1 kg, 0.2 × 0.2 × 0.05 m box resting on a plane inclined by `beta` (descending along
/// +x), with initial velocity `v0` given in slope coordinates (down-slope, lateral).
fn incline(beta_deg: f64, mu: f64, v0: (f64, f64), h: f64) -> Simulation {
    let b = beta_deg.to_radians();
    let n = Vector3::new(b.sin(), 0.0, b.cos());
    let down = Vector3::new(b.cos(), 0.0, -b.sin());
    let c = n * 0.025;
    let v = down * v0.0 + Vector3::y() * v0.1;
    let yaml = format!(
        r#"
duration: 3 s
integrator: {{ h: {h}, solver: {{ tolerance: 1e-12 }} }}
bodies:
  - name: block
    mass: 1 kg
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    orientation: {{ axis: [0, 1, 0], angle: {beta_deg} deg }}
    position: [{}, {}, {}]
    velocity: [{}, {}, {}]
contacts:
  - name: slope
    body: block
    shape: {{ box: {{ size: [0.2, 0.2, 0.05] }} }}
    against_shape: {{ plane: {{ normal: [{}, {}, {}] }} }}
    mu: {mu}
"#,
        c.x, c.y, c.z, v.x, v.y, v.z, n.x, n.y, n.z
    );
    let scene = Scene::from_yaml(&yaml, "incline").unwrap_or_else(|e| panic!("{e}"));
    common::simulation(scene)
}

#[test]
fn sliding_block_stops_at_the_analytic_time_and_sticks_without_creep() {
    let h = 1e-3;
    let mut sim = incline(20.0, 0.5, (2.0, 0.0), h);
    let decel = G * (0.5 * 20f64.to_radians().cos() - 20f64.to_radians().sin());
    assert!((decel - 1.25397).abs() < 1e-5);
    let t_star = 2.0 / decel;
    assert!((t_star - 1.59493).abs() < 1e-5);
    let mut stop = None;
    let mut worst_after: f64 = 0.0;
    sim.run_until(3.0, |s, r| {
        assert_eq!(
            r.active_contacts, 4,
            "exactly the 4 bottom corners are active"
        );
        let speed = s.state.v.norm();
        if stop.is_none() && speed < 1e-12 {
            stop = Some(s.state.t);
        }
        if s.state.t > t_star + h {
            worst_after = worst_after.max(speed);
        }
    })
    .unwrap();
    let stop = stop.expect("the block stops");
    assert!(
        (stop - t_star).abs() <= h,
        "stopped at {stop}, analytic {t_star}"
    );
    assert!(
        worst_after < 1e-12,
        "creep after sticking: |v| = {worst_after:e}"
    );
    assert_eq!(sim.stats.solver_failures, 0);
    // distance travelled along the slope = v0 t*/2 = 1.59493 m
    let b = 20f64.to_radians();
    let travelled = (sim.state.poses[0].x - Vector3::new(b.sin(), 0.0, b.cos()) * 0.025).norm();
    assert!(
        (travelled - 1.59493).abs() < 2.0 * h,
        "distance {travelled}"
    );
}

#[test]
fn block_slides_from_rest_with_the_coulomb_acceleration() {
    let h = 1e-3;
    let mut sim = incline(30.0, 0.3, (0.0, 0.0), h);
    let a_ref = G * (30f64.to_radians().sin() - 0.3 * 30f64.to_radians().cos());
    assert!((a_ref - 2.35629).abs() < 1e-5);
    sim.run_until(1.0, |_, _| {}).unwrap();
    let speed = sim.state.v.fixed_rows::<3>(0).norm();
    let a = speed / sim.state.t;
    assert!(
        (a - a_ref).abs() / a_ref < 1e-6,
        "a = {a}, expected {a_ref}"
    );
    assert!(
        sim.state.v.fixed_rows::<3>(3).norm() < 1e-9,
        "the block does not tip or spin"
    );
}

#[test]
fn friction_opposes_an_oblique_sliding_velocity() {
    let mut sim = incline(20.0, 0.5, (1.5, 1.5), 1e-3);
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    sim.run_until(1.0, |s, _| {
        let v = s.state.v.fixed_rows::<3>(0).into_owned();
        if v.norm() < 1e-3 {
            return;
        }
        let mut friction = Vector3::zeros();
        for (cp, p) in s.contact_points().iter().zip(s.impulses()) {
            friction += cp.frame.row(1).transpose() * p.y + cp.frame.row(2).transpose() * p.z;
        }
        if friction.norm() > 0.0 {
            let cos = friction.dot(&v) / (friction.norm() * v.norm());
            worst = worst.max(1.0 + cos);
            checked += 1;
        }
    })
    .unwrap();
    assert!(checked > 500, "{checked} sliding steps checked");
    assert!(
        worst < 1e-9,
        "friction deviates from −v: 1 + cos = {worst:e}"
    );
}
