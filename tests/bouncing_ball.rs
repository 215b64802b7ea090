//! Bouncing ball: a Newton–Euler sphere with the Newton impact law,
//! against closed-form impact times, the Zeno point, rest impulses and energy.

mod common;

use common::{bundled, simulation};

const G: f64 = 9.81;
const GAP0: f64 = 0.9;

/// Analytic impact times t_{n+1} = t_n + 2 eⁿ v₁ / g and the accumulation time.
fn impact_times(e: f64, n: usize) -> (Vec<f64>, f64) {
    let t1 = (2.0 * GAP0 / G).sqrt();
    let v1 = G * t1;
    let mut t = vec![t1];
    for k in 1..n {
        t.push(t[k - 1] + 2.0 * e.powi(k as i32) * v1 / G);
    }
    (t, t1 + 2.0 * e * v1 / (G * (1.0 - e)))
}

fn ball(e: f64, h: f64) -> mc_study::integrator::Simulation {
    let mut scene = bundled("bouncing-ball");
    scene.model.contacts[0].e = e;
    scene.params.h = h;
    simulation(scene)
}

#[test]
fn impact_times_zeno_point_and_rest_e09() {
    let h = 1e-3;
    let mut sim = ball(0.9, h);
    let (analytic, t_inf) = impact_times(0.9, 8);
    assert!(
        (t_inf - 8.138706).abs() < 1e-6,
        "reference Zeno time {t_inf}"
    );
    let mut impacts = Vec::new();
    let mut in_contact = false;
    let mut rest_checked = 0;
    sim.run_until(10.0, |s, _| {
        let pn = s.impulses()[0].x;
        if pn > 0.0 && !in_contact {
            impacts.push(s.state.t);
        }
        in_contact = pn > 0.0;
        // Past the accumulation point the residual micro-bounces decay by a factor e per step
        // (the Newton law acting on u_N ~ 1e-6 m/s); 0.3 s later the ball is at rest: the
        // impulse per step carries the weight exactly and no velocity remains.
        if s.state.t > t_inf + 0.3 {
            assert!(
                (pn - 1.0 * G * h).abs() <= 1e-9 * G * h,
                "t = {}: impulse {pn}",
                s.state.t
            );
            assert!(
                s.state.v.norm() < 1e-12,
                "t = {}: v = {}",
                s.state.t,
                s.state.v.norm()
            );
            rest_checked += 1;
        }
    })
    .unwrap();
    assert!(rest_checked > 1500);
    assert!(
        impacts.iter().any(|&t| t > 8.0),
        "the scheme reaches the accumulation point"
    );
    // The first impact lands within one step. Each impact then costs the event-capturing
    // scheme up to about one step (the impulse acts over a whole step, during which the
    // ball stalls at the ground), so the n-th impact lags by at most n + 1 steps.
    for (k, (t_num, t_ref)) in impacts.iter().zip(&analytic).enumerate() {
        assert!(
            (t_num - t_ref).abs() <= (k as f64 + 1.0) * h,
            "impact {k}: numerical {t_num} vs analytic {t_ref} (|Δ| = {:.2e} > {} h)",
            (t_num - t_ref).abs(),
            k + 1
        );
    }
    assert!(
        impacts.len() >= analytic.len(),
        "only {} impacts",
        impacts.len()
    );
    // resting gap: the plain scheme keeps a penetration of at most O(h·v) from the last
    // impacts, well under one step's travel at the first impact speed
    let gap = sim.contact_points()[0].gap();
    assert!(gap.abs() < 1e-4, "resting gap {gap}");
    assert_eq!(sim.stats.solver_failures, 0);
}

/// Impact times converge at first order: ten times smaller steps, ten times smaller lag.
#[test]
fn impact_times_converge_first_order() {
    let (analytic, _) = impact_times(0.9, 8);
    let lag = |h: f64| {
        let mut sim = ball(0.9, h);
        let mut impacts = Vec::new();
        let mut in_contact = false;
        sim.run_until(5.0, |s, _| {
            let pn = s.impulses()[0].x;
            if pn > 0.0 && !in_contact {
                impacts.push(s.state.t);
            }
            in_contact = pn > 0.0;
        })
        .unwrap();
        assert!(impacts.len() >= 8);
        impacts
            .iter()
            .zip(&analytic)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    };
    let (coarse, fine) = (lag(1e-3), lag(1e-4));
    assert!(
        coarse < 1e-2 && fine < 1e-3,
        "lags {coarse:.2e}, {fine:.2e}"
    );
    assert!(
        coarse / fine > 5.0,
        "impact-time error ratio {:.2} for a 10× smaller step",
        coarse / fine
    );
}

#[test]
fn elastic_impacts_conserve_energy_e1() {
    for h in [0.05, 1e-3] {
        let mut sim = ball(1.0, h);
        let e0 = sim.energy();
        let mut worst: f64 = 0.0;
        let mut impacts = 0;
        sim.run_until(10.0, |s, _| {
            worst = worst.max((s.energy() - e0).abs() / e0);
            impacts += usize::from(s.impulses()[0].x > 0.0);
        })
        .unwrap();
        assert!(impacts >= 5, "h = {h}: only {impacts} impact steps");
        assert!(worst < 1e-9, "h = {h}: relative energy error {worst:.3e}");
        // still bouncing to its initial height: apex of the last flight ≈ start
        assert!(sim.stats.max_penetration < 0.5 * 4.2 * h + 1e-12);
    }
}

#[test]
fn plastic_impact_does_not_rebound_e0() {
    let mut sim = ball(0.0, 1e-3);
    let mut hit = None;
    let mut max_up: f64 = 0.0;
    sim.run_until(2.0, |s, _| {
        if hit.is_none() && s.impulses()[0].x > 0.0 {
            hit = Some(s.state.t);
        }
        if hit.is_some() {
            max_up = max_up.max(s.state.v[2]);
        }
    })
    .unwrap();
    let t = hit.expect("the ball hits the ground");
    assert!((t - 0.428353).abs() <= 1e-3);
    assert!(
        max_up <= 1e-12,
        "upward velocity {max_up} after a plastic impact"
    );
}
