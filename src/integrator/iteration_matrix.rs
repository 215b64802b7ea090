//! The iteration matrix W = M − hθ ∂F/∂v − h²θ² ∂F/∂ν of the θ-scheme's Newton loop
//! (docs/method.md), with ν the body-frame tangent coordinates of the poses.
//!
//! The gyroscopic Jacobian is analytic, and so are the torsional springs' stiffness and
//! damping (`Force::stiffness_jacobian`, `Force::damping_jacobian`); those of the other force
//! elements are central finite differences of each element alone (cheap: an element
//! touches ≤ 2 bodies).
//! W is block diagonal over the groups of bodies that force elements couple (a spring
//! between two moving bodies joins their groups): one 6×6 LU per lone body, one dense LU
//! per coupled group, so a mechanism with a few coupled pairs never pays for a dense
//! factorisation of the whole system.

use crate::math::blocks::vector6_at;
use crate::math::skew;
use crate::mechanics::body::{holds_none, moves, Twist};
use crate::mechanics::force::{Force, RotationBlock};
use crate::mechanics::{Model, Pose};
use nalgebra::{Const, DMatrix, DVector, Dyn, Matrix6, SMatrix, StorageMut, Vector};

/// Relative finite-difference step for force-element Jacobians.
const FD_STEP: f64 = 1e-6;

/// Bodies whose block of W is inverted together. Most groups are single bodies: keeping
/// their 6×6 inverse inline avoids an allocation per body and Newton iteration. The blocks
/// are inverted once per assembly: W⁻¹ is then applied to the residual and to every active
/// contact's Jacobian as a product, cheaper than the triangular solves it replaces and
/// equal to them up to round-off for a well-conditioned W (M dominates it: on the circuit
/// breaker the springs' h²θ²K and the gyroscopic hθ terms are below 1e-3 of M).
#[allow(clippy::large_enum_variant)]
enum Group {
    Single {
        body: usize,
        inverse: Matrix6<f64>,
        /// Whether `inverse` keeps the translations apart from the rotations.
        separable: bool,
    },
    /// Bodies coupled by force elements (ascending), 6 rows each in `inverse`.
    Coupled {
        bodies: Vec<usize>,
        inverse: DMatrix<f64>,
        /// Whether `inverse` keeps each body's translations apart from its rotations and
        /// from the other bodies (`separable`).
        separable: bool,
    },
}

/// Writes the inverse of the N × N rotation part of a group's W (`w`) into the rotation
/// rows and columns of `inv` by the same LU as a dynamic matrix's, in fixed-size storage;
/// false where it is singular. A coupled group of two to four bodies is inverted at every
/// assembly, and the dynamic LU allocates and checks its bounds at every entry.
macro_rules! invert_rotations_fixed {
    ($w:expr, $inv:expr, $n:literal) => {{
        let fixed = SMatrix::<f64, $n, $n>::from_fn(|i, j| $w[(rotation_row(i), rotation_row(j))]);
        match fixed.lu().try_inverse() {
            Some(r) => {
                write_rotations($inv, $n, |i, j| r[(i, j)]);
                true
            }
            None => false,
        }
    }};
}

/// Whether a coupled group's W (6 rows per body) is separable: no entry couples a body's
/// translation to any rotation, nor to another body's translation. Torsional springs and
/// dampers couple only the bodies' rotations.
fn separable(w: &DMatrix<f64>) -> bool {
    let bodies = w.nrows() / 6;
    (0..bodies).all(|i| {
        (0..bodies).all(|j| {
            let zero = |r: usize, c: usize| {
                w.fixed_view::<3, 3>(6 * i + r, 6 * j + c)
                    .iter()
                    .all(|&x| x == 0.0)
            };
            zero(0, 3) && zero(3, 0) && (i == j || zero(0, 0))
        })
    })
}

/// The inverse of a coupled group's W (6 rows per body), NaN where W is singular, and
/// whether it is separable. Where W is separable each body's translation block stands
/// alone (inverted in closed form) and only the 3k × 3k rotation part needs a dense LU, an
/// eighth of the work.
fn inverse_coupled(w: DMatrix<f64>) -> (DMatrix<f64>, bool) {
    let n = w.nrows();
    let bodies = n / 6;
    let nan = || (DMatrix::from_element(n, n, f64::NAN), false);
    if !separable(&w) {
        return w.lu().try_inverse().map_or_else(nan, |inv| (inv, false));
    }
    let mut inv = DMatrix::zeros(n, n);
    if !invert_rotations(&w, &mut inv) {
        return nan();
    }
    for b in 0..bodies {
        let t = w.fixed_view::<3, 3>(6 * b, 6 * b).into_owned();
        let Some(t_inv) = t.try_inverse() else {
            return nan();
        };
        inv.fixed_view_mut::<3, 3>(6 * b, 6 * b).copy_from(&t_inv);
    }
    (inv, true)
}

/// The row of a group's W (6 per body) that holds row `i` of its rotation part (3 per body).
fn rotation_row(i: usize) -> usize {
    6 * (i / 3) + 3 + i % 3
}

/// The 3k × 3k rotation part of a group's W.
fn rotation_part(w: &DMatrix<f64>) -> DMatrix<f64> {
    let k = 3 * (w.nrows() / 6);
    DMatrix::from_fn(k, k, |i, j| w[(rotation_row(i), rotation_row(j))])
}

/// Writes the inverse of the rotation part of a group's W into the rotation rows and
/// columns of `inv`, by LU (in fixed-size storage for two to four bodies); false where it
/// is singular.
fn invert_rotations(w: &DMatrix<f64>, inv: &mut DMatrix<f64>) -> bool {
    match w.nrows() / 6 {
        2 => invert_rotations_fixed!(w, inv, 6),
        3 => invert_rotations_fixed!(w, inv, 9),
        4 => invert_rotations_fixed!(w, inv, 12),
        _ => match rotation_part(w).lu().try_inverse() {
            Some(r) => {
                write_rotations(inv, r.nrows(), |i, j| r[(i, j)]);
                true
            }
            None => false,
        },
    }
}

/// Entry (i, j) of an n × n rotation part, written at its rows and columns of `inv`.
fn write_rotations(inv: &mut DMatrix<f64>, n: usize, entry: impl Fn(usize, usize) -> f64) {
    for i in 0..n {
        for j in 0..n {
            inv[(rotation_row(i), rotation_row(j))] = entry(i, j);
        }
    }
}

/// The inverse of a block of W, NaN where W is singular (reported downstream as a
/// non-finite state). A block without translation–rotation coupling (a body under torsional
/// springs and dampers only, with its gyroscopic term) is inverted as two 3×3 blocks in
/// closed form.
#[cfg(test)]
fn inverse6(m: &Matrix6<f64>) -> Matrix6<f64> {
    let mut inverse = Matrix6::zeros();
    inverse6_into(m, &mut inverse);
    inverse
}

/// `inverse6` written into `out`, which holds zeros, where it lies: a 6×6 block built
/// aside and copied into a group is read back in pieces that straddle those it was stored
/// in, and the copy waits for the stores. Returns whether the inverse is separable: its
/// translation–rotation blocks zero.
fn inverse6_into(m: &Matrix6<f64>, out: &mut Matrix6<f64>) -> bool {
    let uncoupled = m.fixed_view::<3, 3>(0, 3).iter().all(|&x| x == 0.0)
        && m.fixed_view::<3, 3>(3, 0).iter().all(|&x| x == 0.0);
    if uncoupled {
        let a = m.fixed_view::<3, 3>(0, 0).into_owned().try_inverse();
        let b = m.fixed_view::<3, 3>(3, 3).into_owned().try_inverse();
        if let (Some(a), Some(b)) = (a, b) {
            out.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
            out.fixed_view_mut::<3, 3>(3, 3).copy_from(&b);
            return true;
        }
    } else if let Some(inverse) = m.lu().try_inverse() {
        *out = inverse;
        return false;
    }
    out.fill(f64::NAN);
    false
}

/// W, kept as the inverses of its groups. Its buffers are reused when it is assembled
/// again (`assemble`): a step keeps one across its Newton iterations and the next steps.
#[derive(Default)]
pub struct IterationMatrix {
    mask: Vec<bool>,
    groups: Vec<Group>,
    /// Group index of each body.
    group_of: Vec<usize>,
    /// Each body's diagonal block of W, while it is assembled.
    diag: Vec<Matrix6<f64>>,
    /// W's nonzero off-diagonal blocks ((row body, column body), block), while it is
    /// assembled, and a force element's closed-form Jacobian blocks.
    off: Vec<((usize, usize), Matrix6<f64>)>,
    jacobian: Vec<RotationBlock>,
}

/// The off-diagonal block (x, y) of `off`, added as zeros if it is not there yet.
fn off_block(
    off: &mut Vec<((usize, usize), Matrix6<f64>)>,
    x: usize,
    y: usize,
) -> &mut Matrix6<f64> {
    let k = match off.iter().position(|(key, _)| *key == (x, y)) {
        Some(k) => k,
        None => {
            off.push(((x, y), Matrix6::zeros()));
            off.len() - 1
        }
    };
    &mut off[k].1
}

/// Scratch space of the finite differences: the force buffers of the two perturbations
/// and the perturbed copies of the poses and twists.
struct Differences {
    plus: Vec<f64>,
    minus: Vec<f64>,
    poses: Vec<Pose>,
    twists: Vec<f64>,
}

/// The component of each body under the coupling pairs, named by its smallest body.
fn component_roots(n: usize, pairs: impl Iterator<Item = (usize, usize)>) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (a, b) in pairs {
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    (0..n).map(|i| root(&mut parent, i)).collect()
}

/// Where the force blocks of W are formed: the model, its moving degrees of freedom, the
/// Newton iterate (t, poses, twists), and the weights of ∂F/∂v (hθ) and ∂F/∂q (h²θ²).
struct FormedAt<'a> {
    model: &'a Model,
    mask: &'a [bool],
    t: f64,
    poses: &'a [Pose],
    twists: &'a [f64],
    /// The compliant contacts' closing speeds (`Model::wrench`).
    onset: &'a [Option<f64>],
    velocity_weight: f64,
    pose_weight: f64,
}

/// Each body's diagonal block: its mass and inertia (times 1 + hθα under the settling
/// damping α) and hθ times its gyroscopic term at the twists `v`.
fn mass_blocks(
    diag: &mut [Matrix6<f64>],
    model: &Model,
    v: &DVector<f64>,
    h: f64,
    theta: f64,
    damping: f64,
) {
    let damped = 1.0 + h * theta * damping;
    for (i, b) in model.bodies.iter().enumerate() {
        let d = &mut diag[i];
        for k in 0..3 {
            d[(k, k)] = b.mass * damped;
        }
        d.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(b.inertia * damped));
        let om = v.fixed_rows::<3>(6 * i + 3).into_owned();
        let gyro = skew(&om) * b.inertia - skew(&(b.inertia * om));
        let mut rot = d.fixed_view_mut::<3, 3>(3, 3);
        rot += gyro * (h * theta);
    }
}

/// Closed-form rotation blocks ∂τ_x/∂(δ or ω)_y, weighted into W.
fn add_rotation_blocks(
    diag: &mut [Matrix6<f64>],
    off: &mut Vec<((usize, usize), Matrix6<f64>)>,
    blocks: &[RotationBlock],
    mask: &[bool],
    weight: f64,
) {
    for &(x, y, d) in blocks
        .iter()
        .filter(|b| moves(mask, b.0) && moves(mask, b.1))
    {
        let blk = if x == y {
            &mut diag[x]
        } else {
            off_block(off, x, y)
        };
        let mut rot = blk.fixed_view_mut::<3, 3>(3, 3);
        rot -= d * weight;
    }
}

/// The blocks of the forces that depend on the poses or the velocities: in closed form
/// where a force gives them, else by central differences.
fn force_blocks(
    diag: &mut [Matrix6<f64>],
    off: &mut Vec<((usize, usize), Matrix6<f64>)>,
    jacobian: &mut Vec<RotationBlock>,
    at: &FormedAt,
) {
    let stiff = at
        .model
        .forces
        .iter()
        .filter(|f| f.depends_on_pose() || f.depends_on_velocity());
    // force buffers and perturbed copies of the state (restored after each difference),
    // made on the first finite difference
    let mut scratch: Option<Differences> = None;
    for f in stiff {
        let mut by_pose = f.depends_on_pose();
        let mut by_vel = f.depends_on_velocity();
        if by_vel && f.damping_jacobian(at.poses, jacobian) {
            add_rotation_blocks(diag, off, jacobian, at.mask, at.velocity_weight);
            by_vel = false;
        }
        if by_pose && f.stiffness_jacobian(at.t, at.poses, at.twists, jacobian) {
            add_rotation_blocks(diag, off, jacobian, at.mask, at.pose_weight);
            by_pose = false;
        }
        if by_pose || by_vel {
            difference_blocks(diag, off, f, (by_pose, by_vel), at, &mut scratch);
        }
    }
    compliant_blocks(diag, off, at);
}

/// The blocks of the compliant contacts, in closed form (`CompliantContact::jacobian`).
fn compliant_blocks(
    diag: &mut [Matrix6<f64>],
    off: &mut Vec<((usize, usize), Matrix6<f64>)>,
    at: &FormedAt,
) {
    let mut blocks = Vec::new();
    for (c, span) in at.model.compliant_spans() {
        blocks.clear();
        c.jacobian(
            at.poses,
            at.twists,
            &at.onset[span],
            (at.pose_weight, at.velocity_weight),
            &mut blocks,
        );
        // the held degrees of freedom are clamped where the blocks are read (`clamp_held`)
        for &(i, j, b) in blocks
            .iter()
            .filter(|(i, j, _)| moves(at.mask, *i) && moves(at.mask, *j))
        {
            let blk = if i == j {
                &mut diag[i]
            } else {
                off_block(off, i, j)
            };
            *blk -= b;
        }
    }
}

/// The blocks of force `f` by central differences in its bodies' poses (`by.0`) and
/// twists (`by.1`), in the scratch space `scratch` (made at its first use).
fn difference_blocks(
    diag: &mut [Matrix6<f64>],
    off: &mut Vec<((usize, usize), Matrix6<f64>)>,
    f: &Force,
    by: (bool, bool),
    at: &FormedAt,
    scratch: &mut Option<Differences>,
) {
    let (by_pose, by_vel) = by;
    let (mask, t, poses, twists) = (at.mask, at.t, at.poses, at.twists);
    let n = at.model.bodies.len();
    let bodies: Vec<usize> = f
        .bodies()
        .iter()
        .flatten()
        .copied()
        .filter(|&i| moves(mask, i))
        .collect();
    let first_dof = if f.rotational_only() { 3 } else { 0 };
    for &b in &bodies {
        for k in (first_dof..6).filter(|&k| mask[6 * b + k]) {
            for (wrt_pose, weight) in [(true, at.pose_weight), (false, at.velocity_weight)] {
                if (wrt_pose && !by_pose) || (!wrt_pose && !by_vel) {
                    continue;
                }
                let mut d = Twist::zeros();
                d[k] = FD_STEP;
                let Differences {
                    plus: buf_p,
                    minus: buf_m,
                    poses: pert_poses,
                    twists: pert_twists,
                } = scratch.get_or_insert_with(|| Differences {
                    plus: vec![0.0; 6 * n],
                    minus: vec![0.0; 6 * n],
                    poses: poses.to_vec(),
                    twists: twists.to_vec(),
                });
                buf_p.fill(0.0);
                buf_m.fill(0.0);
                if wrt_pose {
                    pert_poses[b] = poses[b].advanced(&d);
                    f.apply(t, pert_poses, twists, buf_p);
                    pert_poses[b] = poses[b].advanced(&(-d));
                    f.apply(t, pert_poses, twists, buf_m);
                    pert_poses[b] = poses[b];
                } else {
                    pert_twists[6 * b + k] = twists[6 * b + k] + FD_STEP;
                    f.apply(t, poses, pert_twists, buf_p);
                    pert_twists[6 * b + k] = twists[6 * b + k] - FD_STEP;
                    f.apply(t, poses, pert_twists, buf_m);
                    pert_twists[6 * b + k] = twists[6 * b + k];
                }
                for &c in &bodies {
                    let col = (vector6_at(buf_p, 6 * c) - vector6_at(buf_m, 6 * c))
                        * (-weight / (2.0 * FD_STEP));
                    let blk = if c == b {
                        &mut diag[c]
                    } else {
                        off_block(off, c, b)
                    };
                    blk.column_mut(k).add_assign(&col);
                }
            }
        }
    }
}

/// Block (i, j) with the held degrees of freedom of bodies i and j as identity rows and
/// columns, so that their solution component is zero.
fn clamp_held(mask: &[bool], m: &mut Matrix6<f64>, i: usize, j: usize) {
    if holds_none(mask, i) && holds_none(mask, j) {
        return;
    }
    for r in 0..6 {
        for c in 0..6 {
            if !mask[6 * i + r] || !mask[6 * j + c] {
                m[(r, c)] = if i == j && r == c { 1.0 } else { 0.0 };
            }
        }
    }
}

impl IterationMatrix {
    /// Assembles and factorises W at the Newton iterate (poses, v) for step h and θ, with
    /// the settling damping rate `damping` (α: ∂F/∂v = −α M); `mask` is `model.dof_mask()`.
    /// Everything is overwritten: nothing of the last assembly is read, only its buffers
    /// are reused.
    #[allow(clippy::too_many_arguments)]
    pub fn assemble(
        &mut self,
        model: &Model,
        mask: &[bool],
        t: f64,
        poses: &[Pose],
        v: &DVector<f64>,
        h: f64,
        theta: f64,
        damping: f64,
        onset: &[Option<f64>],
    ) {
        let n = model.bodies.len();
        self.mask.clear();
        self.mask.extend_from_slice(mask);
        let mut diag = std::mem::take(&mut self.diag);
        diag.clear();
        diag.resize(n, Matrix6::zeros());
        let mut off = std::mem::take(&mut self.off);
        off.clear();
        let mut jacobian = std::mem::take(&mut self.jacobian);
        mass_blocks(&mut diag, model, v, h, theta, damping);
        let at = FormedAt {
            model,
            mask,
            t,
            poses,
            twists: v.as_slice(),
            onset,
            velocity_weight: h * theta,
            pose_weight: h * h * theta * theta,
        };
        force_blocks(&mut diag, &mut off, &mut jacobian, &at);
        for (i, d) in diag.iter_mut().enumerate() {
            clamp_held(mask, d, i, i);
        }
        self.factorise(&diag, &off);
        (self.diag, self.off, self.jacobian) = (diag, off, jacobian);
    }

    /// The groups of bodies that the off-diagonal blocks `off` couple, each with its
    /// inverse, in order of their first body.
    fn factorise(&mut self, diag: &[Matrix6<f64>], off: &[((usize, usize), Matrix6<f64>)]) {
        let n = diag.len();
        self.groups.clear();
        self.group_of.clear();
        if off.is_empty() {
            // no force element couples two moving bodies: every body is its own group
            for (body, d) in diag.iter().enumerate() {
                self.groups.push(Group::Single {
                    body,
                    inverse: Matrix6::zeros(),
                    separable: false,
                });
                if let Some(Group::Single {
                    inverse, separable, ..
                }) = self.groups.last_mut()
                {
                    *separable = inverse6_into(d, inverse);
                }
            }
            self.group_of.extend(0..n);
            return;
        }
        let roots = component_roots(n, off.iter().map(|(key, _)| *key));
        let mut size = vec![0usize; n];
        roots.iter().for_each(|&r| size[r] += 1);
        self.group_of.resize(n, 0);
        for first in (0..n).filter(|&i| roots[i] == i) {
            let group = if size[first] == 1 {
                self.group_of[first] = self.groups.len();
                let mut inverse = Matrix6::zeros();
                let separable = inverse6_into(&diag[first], &mut inverse);
                Group::Single {
                    body: first,
                    inverse,
                    separable,
                }
            } else {
                let bodies: Vec<usize> = (first..n).filter(|&b| roots[b] == first).collect();
                for &b in &bodies {
                    self.group_of[b] = self.groups.len();
                }
                let w = self.coupled_block(&bodies, diag, off);
                let (inverse, separable) = inverse_coupled(w);
                Group::Coupled {
                    bodies,
                    inverse,
                    separable,
                }
            };
            self.groups.push(group);
        }
    }

    /// The block of W on the coupled `bodies`.
    fn coupled_block(
        &self,
        bodies: &[usize],
        diag: &[Matrix6<f64>],
        off: &[((usize, usize), Matrix6<f64>)],
    ) -> DMatrix<f64> {
        let k = bodies.len();
        let mut w = DMatrix::zeros(6 * k, 6 * k);
        for (gi, &i) in bodies.iter().enumerate() {
            for (gj, &j) in bodies.iter().enumerate() {
                let block = if i == j {
                    Some(diag[i])
                } else {
                    off.iter().find(|(key, _)| *key == (i, j)).map(|(_, m)| {
                        let mut m = *m;
                        clamp_held(&self.mask, &mut m, i, j);
                        m
                    })
                };
                if let Some(block) = block {
                    w.fixed_view_mut::<6, 6>(6 * gi, 6 * gj).copy_from(&block);
                }
            }
        }
        w
    }

    /// W⁻¹ rhs (held dofs give zero).
    pub fn solve(&self, rhs: &DVector<f64>) -> DVector<f64> {
        let mut x = rhs.clone();
        self.solve_mut(&mut x);
        x
    }

    /// Overwrites x with W⁻¹ x (held dofs give zero).
    pub fn solve_mut<S: StorageMut<f64, Dyn>>(&self, x: &mut Vector<f64, Dyn, S>) {
        for (k, &m) in self.mask.iter().enumerate() {
            if !m {
                x[k] = 0.0;
            }
        }
        for g in &self.groups {
            match g {
                Group::Single {
                    body: i, inverse, ..
                } => {
                    let s: Twist = inverse * x.fixed_rows::<6>(6 * i);
                    x.fixed_rows_mut::<6>(6 * i).copy_from(&s);
                }
                Group::Coupled {
                    bodies, inverse, ..
                } => {
                    let mut y = DVector::zeros(6 * bodies.len());
                    for (gi, &i) in bodies.iter().enumerate() {
                        y.fixed_rows_mut::<6>(6 * gi)
                            .copy_from(&x.fixed_rows::<6>(6 * i));
                    }
                    let y = inverse * y;
                    for (gi, &i) in bodies.iter().enumerate() {
                        x.fixed_rows_mut::<6>(6 * i)
                            .copy_from(&y.fixed_rows::<6>(6 * gi));
                    }
                }
            }
        }
    }

    /// W⁻¹ Gᵀ for R rows (a contact's three, a joint's one) with Jacobian blocks on at most
    /// two bodies: the nonzero 6×R blocks per body.
    pub fn solve_blocks<const R: usize>(
        &self,
        blocks: &[(usize, SMatrix<f64, R, 6>)],
    ) -> Vec<(usize, SMatrix<f64, 6, R>)> {
        let mut out = Vec::with_capacity(blocks.len());
        self.solve_blocks_into(blocks, &mut out);
        out
    }

    /// `solve_blocks` into `out` (cleared first), whose allocation a caller solving for
    /// many rows reuses.
    pub fn solve_blocks_into<const R: usize>(
        &self,
        blocks: &[(usize, SMatrix<f64, R, 6>)],
        out: &mut Vec<(usize, SMatrix<f64, 6, R>)>,
    ) {
        let masked = |b: usize, g: &SMatrix<f64, R, 6>| {
            let mut gt = g.transpose();
            if holds_none(&self.mask, b) {
                return gt;
            }
            for k in 0..6 {
                if !self.mask[6 * b + k] {
                    gt.row_mut(k).fill(0.0);
                }
            }
            gt
        };
        debug_assert!(blocks.len() <= 2, "rows touch at most two bodies");
        out.clear();
        // the groups already solved for
        let mut done = [usize::MAX; 2];
        for (k, &(b, _)) in blocks.iter().enumerate() {
            let gi = self.group_of[b];
            if done.contains(&gi) {
                continue;
            }
            done[k] = gi;
            match &self.groups[gi] {
                Group::Single {
                    inverse, separable, ..
                } => {
                    let mut gt = SMatrix::<f64, 6, R>::zeros();
                    for (bb, gb) in blocks.iter().filter(|(bb, _)| *bb == b) {
                        gt += masked(*bb, gb);
                    }
                    let y = match separable {
                        true => separable_product(&inverse.fixed_view::<6, 6>(0, 0), &gt, true),
                        false => inverse * gt,
                    };
                    out.push((b, y));
                }
                Group::Coupled {
                    bodies,
                    inverse,
                    separable,
                } => {
                    // only the columns of W⁻¹ of the contact's bodies enter
                    let mut terms = [(0, SMatrix::<f64, 6, R>::zeros()); 2];
                    let mut count = 0;
                    for (bb, gb) in blocks {
                        if let Some(gk) = bodies.iter().position(|x| x == bb) {
                            terms[count] = (gk, masked(*bb, gb));
                            count += 1;
                        }
                    }
                    for (gj, &bb) in bodies.iter().enumerate() {
                        if moves(&self.mask, bb) {
                            let mut y = SMatrix::<f64, 6, R>::zeros();
                            for (gk, g) in &terms[..count] {
                                let block = inverse.fixed_view::<6, 6>(6 * gj, 6 * gk);
                                match separable {
                                    true => y += separable_product(&block, g, gj == *gk),
                                    false => y += block * g,
                                }
                            }
                            out.push((bb, y));
                        }
                    }
                }
            }
        }
    }
}

/// `block` × `g` for a 6×6 block of a separable inverse: its translation–rotation blocks
/// are zero, and so is its translation block unless it is a body's own (`own`). The zero
/// blocks' terms are left out, which changes no sum but for the sign of a zero.
fn separable_product<S: nalgebra::Storage<f64, Const<6>, Const<6>>, const R: usize>(
    block: &nalgebra::Matrix<f64, Const<6>, Const<6>, S>,
    g: &SMatrix<f64, 6, R>,
    own: bool,
) -> SMatrix<f64, 6, R> {
    let mut y = SMatrix::<f64, 6, R>::zeros();
    if own {
        y.fixed_rows_mut::<3>(0)
            .copy_from(&(block.fixed_view::<3, 3>(0, 0) * g.fixed_rows::<3>(0)));
    }
    y.fixed_rows_mut::<3>(3)
        .copy_from(&(block.fixed_view::<3, 3>(3, 3) * g.fixed_rows::<3>(3)));
    y
}

use std::ops::AddAssign;

#[cfg(test)]
mod tests {
    use super::*;

    /// A W-like matrix for `bodies` bodies: masses on the translations, an inertia with a
    /// gyroscopic (skew) part on the rotations, rotations coupled between bodies, and,
    /// when `mixed`, a translation–rotation coupling that makes it inseparable.
    fn w_like(bodies: usize, mixed: bool) -> DMatrix<f64> {
        let n = 6 * bodies;
        let mut w = DMatrix::from_fn(n, n, |r, c| {
            let (tr, tc) = (r % 6 < 3, c % 6 < 3);
            if tr && tc && r / 6 == c / 6 {
                if r == c {
                    2.0 + r as f64
                } else {
                    0.0
                }
            } else if !tr && !tc {
                let base = if r == c { 0.5 + 0.1 * r as f64 } else { 0.0 };
                base + 0.01 * ((3 * r + 7 * c) % 11) as f64 - 0.004 * ((5 * r + c) % 7) as f64
            } else {
                0.0
            }
        });
        if mixed {
            w[(0, 4)] = 0.3;
        }
        w
    }

    /// The product by a separable inverse's block, its zero blocks left out, equals the
    /// whole product (== counts −0 and +0 as equal), on a body's own block and another's;
    /// and an inverse with a translation–rotation entry is not taken as separable.
    #[test]
    fn separable_products_equal_whole_ones() {
        let (inv, separable) = inverse_coupled(w_like(3, false));
        assert!(separable);
        let g = SMatrix::<f64, 6, 3>::from_fn(|i, j| 0.3 * i as f64 - 0.7 * j as f64 + 0.11);
        for (gj, gk) in [(0, 0), (1, 1), (0, 2), (2, 1)] {
            let block = inv.fixed_view::<6, 6>(6 * gj, 6 * gk);
            let whole = block * g;
            assert_eq!(separable_product(&block, &g, gj == gk), whole);
            assert!(whole.amax() > 0.0, "({gj}, {gk})");
        }
        let mut single = Matrix6::zeros();
        assert!(inverse6_into(
            &w_like(1, false).fixed_view::<6, 6>(0, 0).into_owned(),
            &mut single
        ));
        assert_eq!(separable_product(&single, &g, true), single * g);
        let mut mixed = Matrix6::zeros();
        assert!(!inverse6_into(
            &w_like(1, true).fixed_view::<6, 6>(0, 0).into_owned(),
            &mut mixed
        ));
    }

    /// The separable inverse (closed-form translations, LU on the rotations) is W⁻¹: it
    /// agrees with the LU inverse of the whole matrix, and W W⁻¹ = I, with or without the
    /// rotation coupling; an inseparable matrix takes the general path.
    #[test]
    fn coupled_and_single_inverses_are_inverses() {
        for (bodies, mixed) in [(3, false), (2, false), (2, true)] {
            let w = w_like(bodies, mixed);
            let (inv, separable) = inverse_coupled(w.clone());
            assert_eq!(separable, !mixed, "{bodies} bodies, mixed {mixed}");
            let reference = w.clone().lu().try_inverse().unwrap();
            assert!(
                (&inv - &reference).amax() < 1e-12,
                "{bodies} bodies, mixed {mixed}"
            );
            let id = &w * &inv;
            assert!((id - DMatrix::identity(6 * bodies, 6 * bodies)).amax() < 1e-12);
        }
        for mixed in [false, true] {
            let w: Matrix6<f64> = w_like(1, mixed).fixed_view::<6, 6>(0, 0).into_owned();
            let inv = inverse6(&w);
            assert!(
                (w * inv - Matrix6::identity()).amax() < 1e-12,
                "mixed {mixed}"
            );
        }
        // the fixed-size LU of two to four bodies' rotations is the dynamic one, bit for bit
        for bodies in 2..=4 {
            let w = w_like(bodies, false);
            let dynamic = rotation_part(&w).lu().try_inverse();
            let dynamic = dynamic.unwrap_or_else(|| panic!("{bodies} bodies"));
            let mut fixed = DMatrix::zeros(6 * bodies, 6 * bodies);
            assert!(invert_rotations(&w, &mut fixed), "{bodies} bodies");
            assert_eq!(rotation_part(&fixed), dynamic, "{bodies} bodies");
        }
        assert!(inverse_coupled(DMatrix::zeros(12, 12)).0[(0, 0)].is_nan());
        assert!(!inverse_coupled(DMatrix::zeros(12, 12)).1);
        assert!(inverse6(&Matrix6::zeros())[(0, 0)].is_nan());
    }
}
