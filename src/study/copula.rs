//! Correlated inputs through a Gaussian copula (the Nataf model): each input keeps its own
//! distribution, and the dependence lives in the normal scores z = Φ⁻¹(F(x)), which are
//! jointly normal with correlation matrix R. A design point u ∈ (0, 1)^d becomes
//! independent scores Φ⁻¹(u), then correlated scores L Φ⁻¹(u) with R = L Lᵀ (Cholesky), then
//! inputs through each marginal. The design's structure (LHS strata, Sobol' points) is that
//! of the independent scores; the map to the inputs is one fixed smooth bijection.
//!
//! A Spearman rank correlation ρₛ between two inputs needs ρ = 2 sin(π ρₛ / 6) between
//! their scores, whatever the marginals. A linear (Pearson) correlation needs the
//! Nataf equation ρₓ = E[x₁ x₂] solved for ρ by quadrature; for two normal inputs ρ = ρₓ.

use super::build::at;
use super::distribution::Distribution;
use super::schema::CorrelationSpec;
use super::{Parameter, StudyError};
use crate::scene::error::line;
use nalgebra::DMatrix;
use serde_saphyr::Spanned;

/// The Gaussian copula of the study's inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Copula {
    /// The correlation of the normal scores.
    pub scores: DMatrix<f64>,
    /// Its lower Cholesky factor; `None` for independent inputs.
    factor: Option<DMatrix<f64>>,
}

impl Copula {
    pub fn independent(d: usize) -> Copula {
        Copula {
            scores: DMatrix::identity(d, d),
            factor: None,
        }
    }

    /// The copula with score correlation `r`; `Err(k)` when `r` is not positive definite,
    /// k being the first input whose correlations with those before it cannot all hold.
    pub fn new(r: DMatrix<f64>) -> Result<Copula, usize> {
        let d = r.nrows();
        if r == DMatrix::identity(d, d) {
            return Ok(Copula::independent(d));
        }
        let mut l = DMatrix::zeros(d, d);
        for k in 0..d {
            for j in 0..=k {
                let s: f64 = (0..j).map(|m| l[(k, m)] * l[(j, m)]).sum();
                if j == k {
                    let pivot = r[(k, k)] - s;
                    // a pivot this small leaves the inputs (almost) linearly dependent
                    if pivot.is_nan() || pivot <= 1e-10 {
                        return Err(k);
                    }
                    l[(k, k)] = pivot.sqrt();
                } else {
                    l[(k, j)] = (r[(k, j)] - s) / l[(j, j)];
                }
            }
        }
        Ok(Copula {
            scores: r,
            factor: Some(l),
        })
    }

    pub fn is_independent(&self) -> bool {
        self.factor.is_none()
    }

    /// Independent standard normals z become the correlated scores L z.
    pub fn correlate(&self, z: &[f64]) -> Vec<f64> {
        match &self.factor {
            None => z.to_vec(),
            Some(l) => (0..z.len())
                .map(|k| (0..=k).map(|j| l[(k, j)] * z[j]).sum())
                .collect(),
        }
    }
}

/// The score correlation that gives a Spearman rank correlation `rank`.
pub fn scores_from_rank(rank: f64) -> f64 {
    2.0 * (std::f64::consts::PI * rank / 6.0).sin()
}

/// Gauss–Hermite nodes and weights for E[g(Z)], Z standard normal (Golub–Welsch).
fn hermite(n: usize) -> Vec<(f64, f64)> {
    let jacobi = DMatrix::from_fn(n, n, |i, j| {
        if i + 1 == j || j + 1 == i {
            (i.max(j) as f64).sqrt()
        } else {
            0.0
        }
    });
    let eigen = jacobi.symmetric_eigen();
    (0..n)
        .map(|k| (eigen.eigenvalues[k], eigen.eigenvectors[(0, k)].powi(2)))
        .collect()
}

const NODES: usize = 48;

/// The linear correlation of two inputs whose scores have correlation `rho`.
pub fn linear_from_scores(rho: f64, a: &Distribution, b: &Distribution) -> f64 {
    let gh = hermite(NODES);
    let (ma, sa) = a.moments();
    let (mb, sb) = b.moments();
    let c = (1.0 - rho * rho).max(0.0).sqrt();
    let mut e = 0.0;
    for &(z1, w1) in &gh {
        let xa = a.from_standard(z1) - ma;
        for &(z2, w2) in &gh {
            e += w1 * w2 * xa * (b.from_standard(rho * z1 + c * z2) - mb);
        }
    }
    e / (sa * sb)
}

/// The score correlation that gives the linear correlation `linear` between inputs with
/// marginals `a` and `b` (Nataf), or why none does.
pub fn scores_from_linear(linear: f64, a: &Distribution, b: &Distribution) -> Result<f64, String> {
    let f = |rho: f64| linear_from_scores(rho, a, b) - linear;
    let (mut lo, mut hi) = (-0.999_999, 0.999_999);
    let (flo, fhi) = (f(lo), f(hi));
    if flo > 0.0 || fhi < 0.0 {
        return Err(format!(
            "these two distributions reach linear correlations in [{:.3}, {:.3}] only",
            flo + linear,
            fhi + linear
        ));
    }
    // ρₓ grows monotonically with ρ
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// The `correlations:` list: the copula of the normal scores, checked pair by pair and as
/// a whole (positive definite).
pub(super) fn from_spec(
    specs: &[Spanned<CorrelationSpec>],
    parameters: &[Parameter],
) -> Result<Copula, StudyError> {
    let d = parameters.len();
    let mut r = DMatrix::identity(d, d);
    let mut given: Vec<(usize, usize, usize)> = Vec::new();
    for (i, c) in specs.iter().enumerate() {
        let field = format!("correlations[{i}]");
        let between = &c.value.between;
        if between.len() != 2 {
            return Err(at(
                line(c),
                format!("{field}.between"),
                format!("names two parameters, got {}", between.len()),
            ));
        }
        let mut index = [0usize; 2];
        for (k, n) in between.iter().enumerate() {
            index[k] = parameters
                .iter()
                .position(|p| p.path == n.value)
                .ok_or_else(|| {
                    at(
                        line(n),
                        format!("{field}.between[{k}]"),
                        format!(
                            "`{}` is not a sampled parameter (the study samples: {})",
                            n.value,
                            parameters
                                .iter()
                                .map(|p| p.path.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                })?;
            if matches!(parameters[index[k]].distribution, Distribution::Fixed(_)) {
                return Err(at(
                    line(n),
                    format!("{field}.between[{k}]"),
                    format!("`{}` is fixed: it correlates with nothing", n.value),
                ));
            }
        }
        let [a, b] = index;
        if a == b {
            return Err(at(
                line(c),
                format!("{field}.between"),
                "names the same parameter twice",
            ));
        }
        if let Some(&(_, _, j)) = given
            .iter()
            .find(|&&(x, y, _)| (x, y) == (a, b) || (x, y) == (b, a))
        {
            return Err(at(
                line(c),
                field,
                format!("this pair is already correlated in correlations[{j}]"),
            ));
        }
        let (value, score) = match (&c.value.rank, &c.value.linear) {
            (Some(v), None) => (v, None),
            (None, Some(v)) => (v, Some(())),
            _ => {
                return Err(at(
                    line(c),
                    field,
                    "give `rank` (Spearman) or `linear` (Pearson), one of them",
                ))
            }
        };
        let kind = if score.is_some() { "linear" } else { "rank" };
        if !(value.value > -1.0 && value.value < 1.0) {
            return Err(at(
                line(value),
                format!("{field}.{kind}"),
                format!("a correlation lies in (−1, 1), got {}", value.value),
            ));
        }
        let rho = match score {
            None => scores_from_rank(value.value),
            Some(()) => scores_from_linear(
                value.value,
                &parameters[a].distribution,
                &parameters[b].distribution,
            )
            .map_err(|m| at(line(value), format!("{field}.linear"), m))?,
        };
        r[(a, b)] = rho;
        r[(b, a)] = rho;
        given.push((a, b, i));
    }
    Copula::new(r).map_err(|k| {
        // the pair given last among those that involve input k and an earlier one
        let &(a, b, i) = given
            .iter()
            .rev()
            .find(|&&(a, b, _)| a.max(b) == k)
            .expect("a non-identity row has a correlation");
        at(
            line(&specs[i]),
            format!("correlations[{i}]"),
            format!(
                "the correlations are not consistent (the matrix is not positive definite): `{}`–`{}` cannot hold together with the correlations given before it; weaken it or them",
                parameters[a].path, parameters[b].path
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_rule_integrates_normal_moments() {
        let gh = hermite(NODES);
        let m = |p: i32| gh.iter().map(|(x, w)| w * x.powi(p)).sum::<f64>();
        assert!((m(0) - 1.0).abs() < 1e-12);
        assert!(m(1).abs() < 1e-12);
        assert!((m(2) - 1.0).abs() < 1e-10);
        assert!((m(4) - 3.0).abs() < 1e-9);
    }

    #[test]
    fn nataf_is_the_identity_for_normals_and_known_for_uniforms() {
        let n = Distribution::Normal { mean: 3.0, sd: 2.0 };
        assert!((linear_from_scores(0.6, &n, &n) - 0.6).abs() < 1e-9);
        // two uniforms: ρₓ = (6/π) asin(ρ/2), the rank correlation's formula
        let u = Distribution::Uniform {
            lower: 0.0,
            upper: 1.0,
        };
        let expected = 6.0 / std::f64::consts::PI * (0.6f64 / 2.0).asin();
        assert!((linear_from_scores(0.6, &u, &u) - expected).abs() < 2e-4);
        let back = scores_from_linear(expected, &u, &u).unwrap();
        assert!((back - 0.6).abs() < 2e-3, "{back}");
        assert!((scores_from_rank(0.8) - 0.813_473).abs() < 1e-6);
    }

    #[test]
    fn lognormal_pairs_cannot_reach_every_correlation() {
        let l = Distribution::lognormal(1.0, 1.5).unwrap();
        assert!(scores_from_linear(-0.9, &l, &l).is_err());
    }

    #[test]
    fn cholesky_reproduces_the_matrix_and_names_the_bad_input() {
        let r = DMatrix::from_row_slice(3, 3, &[1.0, 0.5, 0.2, 0.5, 1.0, 0.3, 0.2, 0.3, 1.0]);
        let c = Copula::new(r.clone()).unwrap();
        let l = c.factor.clone().unwrap();
        assert!((&l * l.transpose() - r).norm() < 1e-12);
        let bad = DMatrix::from_row_slice(3, 3, &[1.0, 0.9, 0.9, 0.9, 1.0, -0.9, 0.9, -0.9, 1.0]);
        assert_eq!(Copula::new(bad), Err(2));
    }
}
