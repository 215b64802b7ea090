//! Stability at the extremes at a size CI affords (`harness/extremes.rs`; the full matrix
//! is `cargo run --release --example extremes`, its table in docs/extremes.md). Every cell must run
//! to its end without NaN or modelling error, with penetration and joint violation within
//! 1e-9 m and no energy growth beyond what the physics allows.

#[path = "harness/extremes.rs"]
mod extremes;

use extremes::{Case, Cell};

fn check(cases: Vec<Case>) -> Vec<Cell> {
    let cells: Vec<Cell> = cases.into_iter().map(Case::run).collect();
    eprint!("{}", extremes::table(&cells));
    for c in &cells {
        assert!(c.pass, "{} {}: {}", c.group, c.label, c.verdict);
    }
    cells
}

#[test]
fn clearance_from_a_micrometre_to_a_millimetre_at_the_smallest_and_usual_steps() {
    let mut cases = Vec::new();
    for c in [1e-6, 1e-3] {
        cases.push(extremes::clearance_pendulum(c, 1e-7, 0.1, 0.0, 1.0, 2_000));
        cases.push(extremes::clearance_pendulum(c, 1e-4, 0.1, 0.0, 0.2, 2_000));
    }
    for h in [1e-7, 1e-2] {
        cases.push(extremes::ideal_pendulum(h, 1.0, 2_000));
    }
    check(cases);
}

/// Steps of 1 ms and 10 ms carry the journal across a 1 µm…1 mm clearance in one step
/// (h·v ≫ c): the ring guards keep it in its bore, within the penetration tolerance. The
/// joint's friction (μ = 0.1) takes 5e-3 of m g L/2 in the first second at fine steps;
/// these steps may take a few times more (2.6e-2 at 10 ms), never a swing's worth (0.67
/// at 1 ms and 1 µm when the ring and its guards carried large cancelling impulses).
#[test]
fn clearance_at_steps_that_cross_the_whole_clearance() {
    let mut cases = Vec::new();
    for c in [1e-6, 1e-3] {
        for h in [1e-3, 1e-2] {
            cases.push(extremes::clearance_pendulum(c, h, 0.1, 0.0, 1.0, 2_000));
        }
    }
    for cell in check(cases) {
        assert!(
            cell.energy_drift < 0.05,
            "{}: lost {:.3} of m g L/2",
            cell.label,
            cell.energy_drift
        );
    }
}

#[test]
fn restitution_and_friction_from_zero_to_the_extremes() {
    let mut cases = Vec::new();
    for e in [0.0, 0.5, 1.0] {
        for mu in [0.0, 0.01, 0.3, 1.0, 5.0] {
            cases.push(extremes::oblique_ball(e, mu));
            cases.push(extremes::clearance_pendulum(7e-5, 1e-4, mu, e, 0.05, 500));
        }
    }
    let cells = check(cases);
    // the elastic frictionless ball keeps its energy; friction or e < 1 take some away
    for c in cells.iter().filter(|c| c.group.contains("ball")) {
        if c.label == "e = 1, μ = 0" {
            assert!(c.energy_drift < 1e-12, "{}: {}", c.label, c.energy_drift);
        } else {
            assert!(c.energy_drift > 1e-3, "{}: {}", c.label, c.energy_drift);
        }
    }
}

#[test]
fn fast_spin_long_run_stiff_springs_and_a_stack_of_boxes() {
    let mut cases = vec![
        extremes::spinning_body(1e4, 1e-5, 100_000),
        extremes::clearance_pendulum(7e-5, 1e-5, 0.1, 0.0, 1.0, 100_000),
    ];
    for k in [1e-6, 1e-4, 1e-2, 1.0, 1e2] {
        cases.push(extremes::stiff_spring(k));
    }
    for n in [1, 10] {
        cases.push(extremes::box_stack(n));
    }
    let cells = check(cases);
    // |p| stays a unit quaternion without renormalisation through 10⁵ steps at 10⁴ rad/s
    assert!(
        cells[0].quaternion_drift < 1e-12,
        "{}",
        cells[0].quaternion_drift
    );
    assert_eq!(cells[1].steps, 100_000);
    // the stack stays at rest: its energy does not move
    assert!(cells.last().unwrap().energy_drift < 1e-9);
}

/// Steps far coarser than a 10 mm clearance (h = 0.01 and 0.05 s in the plane, 0.005 and
/// 0.02 s in space), and a row of balls whose impacts all fall in one step: they run to
/// their ends, within the tolerances.
#[test]
fn coarse_steps_on_a_wide_clearance_and_impacts_closer_than_v_h() {
    let mut cases = vec![
        extremes::coarse_clearance_pendulum(1e-2, true, 2.0),
        extremes::coarse_clearance_pendulum(5e-2, true, 2.0),
        extremes::coarse_clearance_pendulum(5e-3, false, 5.0),
        extremes::coarse_clearance_pendulum(2e-2, false, 5.0),
    ];
    for n in [3, 5] {
        cases.push(extremes::row_of_balls(n));
    }
    let cells = check(cases);
    // the elastic frictionless row keeps its energy
    for c in &cells[4..] {
        assert!(c.energy_drift < 1e-12, "{}: {}", c.label, c.energy_drift);
    }
}
