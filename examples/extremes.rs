//! The full stability-at-the-extremes matrix (`tests/harness/extremes.rs`), printed as the
//! Markdown table of docs/extremes.md: `cargo run --release --example extremes`. `tests/extremes.rs` runs
//! a smaller matrix in CI.

#[path = "../tests/harness/extremes.rs"]
mod extremes;

use extremes::Case;

fn main() {
    let mut cases: Vec<Case> = Vec::new();
    for c in [1e-6, 1e-5, 7e-5, 1e-3] {
        for h in [1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2] {
            cases.push(extremes::clearance_pendulum(c, h, 0.1, 0.0, 1.0, 100_000));
        }
    }
    for e in [0.0, 0.5, 1.0] {
        for mu in [0.0, 0.01, 0.3, 1.0, 5.0] {
            cases.push(extremes::clearance_pendulum(
                7e-5, 1e-4, mu, e, 1.0, 100_000,
            ));
        }
    }
    for h in [1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2] {
        cases.push(extremes::ideal_pendulum(h, 1.0, 100_000));
    }
    for e in [0.0, 0.5, 1.0] {
        for mu in [0.0, 0.01, 0.3, 1.0, 5.0] {
            cases.push(extremes::oblique_ball(e, mu));
        }
    }
    for h in [1e-2, 5e-2] {
        cases.push(extremes::coarse_clearance_pendulum(h, true, 2.0));
    }
    for h in [5e-3, 2e-2] {
        cases.push(extremes::coarse_clearance_pendulum(h, false, 5.0));
    }
    for n in [3, 5, 10] {
        cases.push(extremes::row_of_balls(n));
    }
    cases.push(extremes::spinning_body(1e4, 1e-5, 1_000_000));
    cases.push(extremes::spinning_body(1e4, 1e-4, 1_000_000));
    let long = extremes::clearance_pendulum(7e-5, 1e-5, 0.1, 0.0, 10.0, 1_000_000);
    cases.push(Case {
        group: "long run",
        ..long
    });
    for k in [1e-6, 1e-4, 1e-2, 1.0, 1e2] {
        cases.push(extremes::stiff_spring(k));
    }
    for n in [1, 10] {
        cases.push(extremes::box_stack(n));
    }
    // `cargo run --release --example extremes -- clearance` runs the groups whose name
    // contains the word
    let filter = std::env::args().nth(1).unwrap_or_default();
    cases.retain(|c| c.group.contains(&filter));
    let mut cells = Vec::new();
    for case in cases {
        eprintln!("{} {}", case.group, case.label);
        cells.push(case.run());
        eprintln!(
            "{}",
            extremes::table(&cells[cells.len() - 1..])
                .lines()
                .nth(2)
                .unwrap_or("")
        );
    }
    print!("{}", extremes::table(&cells));
    let failed = cells.iter().filter(|c| !c.pass).count();
    println!(
        "\n{} cells, {} pass, {failed} fail",
        cells.len(),
        cells.len() - failed
    );
}
