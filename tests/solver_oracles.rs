//! FC3D solver oracles: random well-posed instances, the exact stick/slip threshold of one
//! contact, and the frictionless case against an enumerated LCP solution.

use mc_study::solver::{natural_map_error, solve_fc3d, Fc3d, NsgsOptions, SolverStorage};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_instance(
    rng: &mut ChaCha8Rng,
    n: usize,
    frictionless: bool,
) -> (DMatrix<f64>, DVector<f64>, Vec<f64>) {
    let m = 3 * n;
    let b = DMatrix::from_fn(m, m, |_, _| rng.random_range(-1.0..1.0) / (m as f64).sqrt());
    let w = &b * b.transpose() + DMatrix::identity(m, m) * 0.5;
    let q = DVector::from_fn(m, |_, _| rng.random_range(-1.0..1.0));
    let mu = (0..n)
        .map(|_| {
            if frictionless {
                0.0
            } else {
                rng.random_range(0.05..1.0)
            }
        })
        .collect();
    (w, q, mu)
}

/// Independent check of the complementarity conditions of a solution.
fn check_solution(w: &DMatrix<f64>, q: &DVector<f64>, mu: &[f64], r: &DVector<f64>, tol: f64) {
    let u = w * r + q;
    let scale = r.amax().max(q.amax());
    for (a, &m) in mu.iter().enumerate() {
        let (rn, rt) = (
            r[3 * a],
            (r[3 * a + 1].powi(2) + r[3 * a + 2].powi(2)).sqrt(),
        );
        let ut = (u[3 * a + 1].powi(2) + u[3 * a + 2].powi(2)).sqrt();
        let un_hat = u[3 * a] + m * ut;
        assert!(
            rn >= -tol * scale && rt <= m * rn + tol * scale,
            "contact {a}: r outside the cone"
        );
        // û ∈ K* (⇔ u_N ≥ 0) and r ⟂ û (⇔ Signorini r_N u_N = 0 with the slip rule below)
        assert!(
            u[3 * a] >= -tol * scale && un_hat >= m * ut - tol * scale,
            "contact {a}: û outside the dual cone"
        );
        let r_dot_uhat = rn * un_hat + r[3 * a + 1] * u[3 * a + 1] + r[3 * a + 2] * u[3 * a + 2];
        assert!(
            r_dot_uhat.abs() <= tol * scale * scale,
            "contact {a}: r·û = {r_dot_uhat}"
        );
        assert!(
            (rn * u[3 * a]).abs() <= tol * scale * scale,
            "contact {a}: r_N u_N = {}",
            rn * u[3 * a]
        );
        if ut > tol * scale && m > 0.0 {
            // sliding: friction at the cone boundary, opposite to the slip
            let dot = (r[3 * a + 1] * u[3 * a + 1] + r[3 * a + 2] * u[3 * a + 2]) / ut;
            assert!(
                (dot + m * rn).abs() <= 1e-8 * scale,
                "contact {a}: friction not opposite to slip"
            );
        }
    }
}

#[test]
fn random_instances_reach_the_tolerance() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let opts = NsgsOptions {
        tolerance: 1e-11,
        max_sweeps: 5000,
        ..Default::default()
    };
    let mut worst_sweeps = 0;
    for n in [1usize, 2, 3, 5, 8, 13, 20, 35, 50] {
        for _ in 0..4 {
            let (w, q, mu) = random_instance(&mut rng, n, false);
            let mut r = DVector::zeros(3 * n);
            let st = solve_fc3d(
                &Fc3d {
                    w: &w,
                    q: &q,
                    mu: &mu,
                },
                &mut r,
                &opts,
                &mut SolverStorage::default(),
            );
            let err = natural_map_error(
                &Fc3d {
                    w: &w,
                    q: &q,
                    mu: &mu,
                },
                &r,
            );
            assert!(
                st.converged && err < 1e-10,
                "n = {n}: residual {err:e} after {} sweeps",
                st.iterations
            );
            check_solution(&w, &q, &mu, &r, 1e-9);
            worst_sweeps = worst_sweeps.max(st.iterations);
        }
    }
    eprintln!("worst sweeps over random instances: {worst_sweeps}");
}

#[test]
fn single_contact_stick_slip_threshold_is_exact() {
    let (wn, wt, mu, a) = (2.0, 3.0, 0.4, 1.5);
    let w = DMatrix::from_diagonal(&DVector::from_vec(vec![wn, wt, wt]));
    let threshold = mu * a * wt / wn; // |q_T| at which sticking stops being possible
    let solve = |b: f64| {
        let q = DVector::from_vec(vec![-a, b * 0.6, b * 0.8]);
        let mut r = DVector::zeros(3);
        let st = solve_fc3d(
            &Fc3d {
                w: &w,
                q: &q,
                mu: &[mu],
            },
            &mut r,
            &NsgsOptions::default(),
            &mut SolverStorage::default(),
        );
        assert!(st.converged);
        (r.clone(), &w * &r + &q)
    };
    // just below: sticks, u = 0 and the friction is inside the cone
    let (r, u) = solve(threshold * (1.0 - 1e-9));
    assert!(u.norm() < 1e-14, "sticking velocity {u}");
    assert!((r[1].hypot(r[2])) < mu * r[0]);
    // just above: slides, friction on the cone boundary opposite to q_T
    let (r, u) = solve(threshold * (1.0 + 1e-9));
    let ut = u[1].hypot(u[2]);
    assert!(
        ut > 0.0 && (ut - threshold * 1e-9).abs() < 1e-14,
        "slip speed {ut}"
    );
    assert!((r[0] - a / wn).abs() < 1e-14);
    assert!(
        (r[1] + mu * r[0] * 0.6).abs() < 1e-14 && (r[2] + mu * r[0] * 0.8).abs() < 1e-14,
        "r = {r}"
    );
    // separation when the free normal velocity is positive
    let q = DVector::from_vec(vec![0.5, 1.0, 0.0]);
    let mut r = DVector::zeros(3);
    solve_fc3d(
        &Fc3d {
            w: &w,
            q: &q,
            mu: &[mu],
        },
        &mut r,
        &NsgsOptions::default(),
        &mut SolverStorage::default(),
    );
    assert_eq!(r, DVector::zeros(3));
}

/// Solution of LCP(M, q) by enumerating the active sets (small n only).
fn lcp_by_enumeration(m: &DMatrix<f64>, q: &DVector<f64>) -> DVector<f64> {
    let n = q.len();
    for set in 0u32..(1 << n) {
        let idx: Vec<usize> = (0..n).filter(|i| set & (1 << i) != 0).collect();
        let mut z = DVector::zeros(n);
        if !idx.is_empty() {
            let msub = DMatrix::from_fn(idx.len(), idx.len(), |a, b| m[(idx[a], idx[b])]);
            let qsub = DVector::from_fn(idx.len(), |a, _| -q[idx[a]]);
            let Some(sol) = msub.lu().solve(&qsub) else {
                continue;
            };
            for (a, &i) in idx.iter().enumerate() {
                z[i] = sol[a];
            }
        }
        let w = m * &z + q;
        if z.iter().all(|&x| x >= -1e-12) && w.iter().all(|&x| x >= -1e-12) {
            return z;
        }
    }
    panic!("no LCP solution found")
}

#[test]
fn frictionless_case_equals_the_lcp_solution() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for n in 1..=8 {
        let (w, q, mu) = random_instance(&mut rng, n, true);
        let mut r = DVector::zeros(3 * n);
        let st = solve_fc3d(
            &Fc3d {
                w: &w,
                q: &q,
                mu: &mu,
            },
            &mut r,
            &NsgsOptions {
                tolerance: 1e-13,
                max_sweeps: 5000,
                ..Default::default()
            },
            &mut SolverStorage::default(),
        );
        assert!(st.converged);
        let wn = DMatrix::from_fn(n, n, |a, b| w[(3 * a, 3 * b)]);
        let qn = DVector::from_fn(n, |a, _| q[3 * a]);
        let z = lcp_by_enumeration(&wn, &qn);
        for a in 0..n {
            assert!(
                (r[3 * a] - z[a]).abs() < 1e-10 * (1.0 + z.amax()),
                "n = {n}, contact {a}: {} vs LCP {}",
                r[3 * a],
                z[a]
            );
            assert_eq!((r[3 * a + 1], r[3 * a + 2]), (0.0, 0.0));
        }
    }
}

/// The last resort for rank-deficient problems: two coincident contacts on a point mass
/// (W = [[I, I], [I, I]] / m, singular), pressed at 1 m/s and sliding at 0.3 m/s. Only the
/// sum of the two impulses is determined, and it is known in closed form: m·(1, −0.3, 0)
/// when μ = 0.5 sticks, m·(1, −μ, 0) when μ = 0.2 slips. Proximal-point Newton must reach
/// the tolerance and that sum, from a start far from it.
#[test]
fn proximal_newton_solves_coincident_contacts_to_the_closed_form() {
    use mc_study::solver::newton::proximal_newton;
    use mc_study::solver::ordering::BlockPattern;
    let m = 2.0;
    let mut w = DMatrix::zeros(6, 6);
    for i in 0..3 {
        for (a, b) in [(0, 0), (0, 3), (3, 0), (3, 3)] {
            w[(a + i, b + i)] = 1.0 / m;
        }
    }
    let q = DVector::from_vec(vec![-1.0, 0.3, 0.0, -1.0, 0.3, 0.0]);
    for (mu, rt) in [(0.5, -0.3), (0.2, -0.2)] {
        let mus = [mu, mu];
        let p = Fc3d {
            w: &w,
            q: &q,
            mu: &mus,
        };
        let mut r = DVector::from_vec(vec![5.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let storage = &mut Default::default();
        proximal_newton(&p, &BlockPattern::of(&w), &mut r, 1e-10, 50, storage).expect("converges");
        assert!(natural_map_error(&p, &r) <= 1e-10);
        check_solution(&w, &q, &mus, &r, 1e-8);
        let total = [r[0] + r[3], r[1] + r[4], r[2] + r[5]];
        assert!((total[0] - m).abs() < 1e-8, "μ = {mu}: {total:?}");
        assert!((total[1] - rt * m).abs() < 1e-8, "μ = {mu}: {total:?}");
        assert!(total[2].abs() < 1e-8, "μ = {mu}: {total:?}");
    }
}

/// The global Newton method on a block-sparse problem, as a mechanism gives: contacts along
/// a chain of bodies (contact k between bodies k and k + 1, W = H M⁻¹ Hᵀ with random
/// Jacobian blocks), numbered in a shuffled order so that the method reorders them
/// (`BlockPattern::minimum_degree`). The solution meets the complementarity conditions and
/// is the one found on the same problem numbered along the chain, where no reordering
/// happens.
#[test]
fn global_newton_solves_a_shuffled_chain_in_its_own_order() {
    use mc_study::solver::newton::global_newton;
    use mc_study::solver::ordering::BlockPattern;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 12;
    let (m, dofs) = (3 * n, 6 * (n + 1));
    // along the chain: H has contact k's blocks on bodies k and k + 1
    let mut h = DMatrix::zeros(m, dofs);
    for k in 0..n {
        for body in [k, k + 1] {
            for i in 0..3 {
                for j in 0..6 {
                    h[(3 * k + i, 6 * body + j)] = rng.random_range(-1.0..1.0);
                }
            }
        }
    }
    let inverse_mass = DMatrix::from_fn(dofs, dofs, |i, j| {
        if i == j {
            rng.random_range(0.5..2.0)
        } else {
            0.0
        }
    });
    let chain_w = &h * inverse_mass * h.transpose() + DMatrix::identity(m, m) * 1e-3;
    let chain_q = DVector::from_fn(m, |_, _| rng.random_range(-1.0..1.0));
    let chain_mu: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..0.8)).collect();
    let order_of = |w: &DMatrix<f64>| {
        let mut order = Vec::new();
        BlockPattern::of(w).minimum_degree_into(&mut order, &mut Default::default());
        order
    };
    assert_eq!(order_of(&chain_w), (0..n).collect::<Vec<_>>());
    // the same contacts numbered in a shuffled order: contact k is chain contact shuffle[k]
    let shuffle = [5, 0, 9, 2, 11, 7, 3, 10, 1, 6, 8, 4];
    let index = |i: usize| 3 * shuffle[i / 3] + i % 3;
    let w = DMatrix::from_fn(m, m, |i, j| chain_w[(index(i), index(j))]);
    let q = DVector::from_fn(m, |i, _| chain_q[index(i)]);
    let mu: Vec<f64> = shuffle.iter().map(|&k| chain_mu[k]).collect();
    assert_ne!(order_of(&w), (0..n).collect::<Vec<_>>());
    let solve = |w: &DMatrix<f64>, q: &DVector<f64>, mu: &[f64]| {
        let mut r = DVector::zeros(m);
        let p = Fc3d { w, q, mu };
        let storage = &mut Default::default();
        // from r = 0, where the velocity W r + q is q
        let mut u = q.clone();
        global_newton(
            &p,
            &BlockPattern::of(w),
            &mut r,
            &mut u,
            1e-12,
            100,
            storage,
        )
        .expect("converges");
        check_solution(w, q, mu, &r, 1e-9);
        r
    };
    let (shuffled, chain) = (solve(&w, &q, &mu), solve(&chain_w, &chain_q, &chain_mu));
    for i in 0..m {
        assert!(
            (shuffled[i] - chain[index(i)]).abs() <= 1e-9 * chain.amax(),
            "entry {i}: {} vs {}",
            shuffled[i],
            chain[index(i)]
        );
    }
}
