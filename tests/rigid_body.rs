//! Free and pinned rigid bodies: the θ = 1/2 scheme with the gyroscopic Newton loop and
//! the Lie-group rotation update, against an RK4 reference and conservation laws.

mod common;

use common::{bundled, loglog_slope, simulation};
use mc_study::integrator::Simulation;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

const INERTIA: [f64; 3] = [1.0, 2.0, 3.0];

fn free_body(h: f64) -> Simulation {
    let mut scene = bundled("free-body");
    scene.params.h = h;
    simulation(scene)
}

/// RK4 on the exact equations (q̇ = ½ q ⊗ (0, Ω), I Ω̇ = −Ω × IΩ), renormalising q: an
/// independent reference for the attitude.
fn rk4_reference(t_end: f64, h: f64) -> Vec<(f64, UnitQuaternion<f64>, Vector3<f64>)> {
    let i = Matrix3::from_diagonal(&Vector3::from(INERTIA));
    let inv = i.try_inverse().unwrap();
    let f = |q: &Quaternion<f64>, w: &Vector3<f64>| {
        let dq = q * Quaternion::from_parts(0.0, *w) * 0.5;
        let dw = inv * (-w.cross(&(i * w)));
        (dq, dw)
    };
    let mut q = Quaternion::identity();
    let mut w = Vector3::new(0.01, 2.0, 0.01);
    let n = (t_end / h).round() as usize;
    let mut out = vec![(0.0, UnitQuaternion::from_quaternion(q), w)];
    for k in 0..n {
        let (k1q, k1w) = f(&q, &w);
        let (k2q, k2w) = f(&(q + k1q * (h / 2.0)), &(w + k1w * (h / 2.0)));
        let (k3q, k3w) = f(&(q + k2q * (h / 2.0)), &(w + k2w * (h / 2.0)));
        let (k4q, k4w) = f(&(q + k3q * h), &(w + k3w * h));
        q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
        w += (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
        q = q.normalize();
        out.push(((k + 1) as f64 * h, UnitQuaternion::from_quaternion(q), w));
    }
    out
}

#[test]
fn attitude_converges_at_second_order() {
    let t_end = 4.0;
    let reference = rk4_reference(t_end, 1e-4);
    let (_, q_ref, _) = reference.last().unwrap();
    let hs = [0.02, 0.01, 0.005, 0.0025];
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let mut sim = free_body(h);
            sim.run_until(t_end, |_, _| {}).unwrap();
            sim.state.poses[0].p.angle_to(q_ref)
        })
        .collect();
    let slope = loglog_slope(&hs, &errs);
    eprintln!("attitude errors {errs:?}, order {slope:.3}");
    assert!(
        (slope - 2.0).abs() <= 0.2,
        "measured order {slope:.3} (errors {errs:?})"
    );
    assert!(errs[3] < 1e-3, "attitude error at h = 2.5 ms: {}", errs[3]);
}

#[test]
fn long_run_conserves_energy_momentum_and_unit_norm_and_flips() {
    let h = 1e-3;
    let mut sim = free_body(h);
    let i = Matrix3::from_diagonal(&Vector3::from(INERTIA));
    let e0 = sim.energy();
    let l0 = (i * Vector3::new(0.01, 2.0, 0.01)).norm();
    let (mut worst_norm, mut e_first, mut e_second, mut l_first, mut l_second) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut flips = Vec::new();
    let mut last_sign = 1.0;
    sim.run_until(100.0, |s, r| {
        assert!(r.newton_converged);
        let p = s.state.poses[0].p;
        worst_norm = worst_norm.max((p.quaternion().norm() - 1.0).abs());
        let w = s.state.v.fixed_rows::<3>(3).into_owned();
        let de = ((s.energy() - e0) / e0).abs();
        let dl = (((i * w).norm() - l0) / l0).abs();
        if s.state.t <= 50.0 {
            e_first = e_first.max(de);
            l_first = l_first.max(dl);
        } else {
            e_second = e_second.max(de);
            l_second = l_second.max(dl);
        }
        if w.y.signum() != last_sign {
            flips.push(s.state.t);
            last_sign = w.y.signum();
        }
    })
    .unwrap();
    assert_eq!(sim.stats.steps, 100_000);
    eprintln!("|p|-1 {worst_norm:e}; energy err {e_first:e}/{e_second:e}; |L| err {l_first:e}/{l_second:e}; flips {:?}", &flips[..4.min(flips.len())]);
    assert!(
        worst_norm < 1e-10,
        "| |p| − 1 | reached {worst_norm:e} without renormalisation"
    );
    // bounded errors, no secular drift: the second half is no worse than the first
    assert!(
        e_first < 1e-5 && e_second < 1.5 * e_first + 1e-12,
        "energy errors {e_first:e}, {e_second:e}"
    );
    assert!(
        l_first < 1e-5 && l_second < 1.5 * l_first + 1e-12,
        "|L| errors {l_first:e}, {l_second:e}"
    );
    // Dzhanibekov: the spin about the intermediate axis flips, on the schedule of the
    // exact solution
    let reference = rk4_reference(30.0, 1e-4);
    let first_ref = reference
        .windows(2)
        .find(|w| w[0].2.y > 0.0 && w[1].2.y <= 0.0)
        .expect("reference flips")[1]
        .0;
    assert!(flips.len() >= 4, "flips at {flips:?}");
    assert!(
        (flips[0] - first_ref).abs() / first_ref < 0.01,
        "first flip at {} vs reference {first_ref}",
        flips[0]
    );
}

#[test]
fn heavy_top_keeps_its_hamiltonian() {
    let mut sim = simulation(bundled("heavy-top"));
    let hamiltonian = |s: &Simulation| {
        let w = s.state.v.fixed_rows::<3>(3).into_owned();
        let j = Vector3::new(5.0, 5.0, 1.0);
        let axis = s.state.poses[0].p * Vector3::z();
        0.5 * w.dot(&j.component_mul(&w)) + 20.0 * axis.z
    };
    let h0 = hamiltonian(&sim);
    assert!((h0 - 1269.975005).abs() < 1e-6, "initial H {h0}");
    assert!(
        (sim.energy() - h0).abs() < 1e-9,
        "the engine's energy is the Hamiltonian"
    );
    let mut worst: f64 = 0.0;
    let mut spin_err: f64 = 0.0;
    sim.run_until(10.0, |s, _| {
        worst = worst.max((hamiltonian(s) - h0).abs() / h0);
        spin_err = spin_err.max((s.state.v[5] - 50.0).abs());
        assert!(s.state.poses[0].x.norm() == 0.0, "the pivot stays put");
    })
    .unwrap();
    eprintln!("heavy top: max relative H error {worst:e}, spin error {spin_err:e}");
    assert!(worst < 1e-3, "relative Hamiltonian error {worst:e}");
    assert!(spin_err < 1e-9, "body spin J₃W₃ drifted by {spin_err:e}");
    // the top precesses: its axis has moved away from the start
    assert!(sim.state.poses[0].p.angle_to(&UnitQuaternion::identity()) > 0.01);
}

/// A run whose duration is not a multiple of h ends on the duration: its last step is cut
/// short. A body thrown up in free flight (which the θ = 1/2 scheme integrates exactly)
/// is where the closed form has it at t = 0.05 s with h = 0.03 s.
#[test]
fn a_run_ends_on_its_duration() {
    let yaml = r#"
duration: 0.05 s
integrator: { h: 0.03 s }
bodies:
  - { name: stone, mass: 1 kg, shape: { sphere: { radius: 10 mm } }, velocity: [0, 0, 2] }
"#;
    let scene = mc_study::scene::Scene::from_yaml(yaml, "stone").unwrap();
    let mut sim = scene.simulation().unwrap();
    sim.run_until(scene.duration, |_, _| {}).unwrap();
    let t = 0.05;
    assert_eq!(sim.state.t, t);
    assert_eq!(sim.stats.steps, 2);
    let z = 2.0 * t - 0.5 * 9.81 * t * t;
    assert!(
        (sim.state.poses[0].x.z - z).abs() < 1e-15,
        "{}",
        sim.state.poses[0].x.z
    );
}
