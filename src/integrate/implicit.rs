//! Implicit integrators: linearised backward Euler (Baraff–Witkin, MODEL.md
//! §6.5) and Choi & Ko's second-order BDF (§6.6), solved matrix-free by a
//! filtered, block-Jacobi preconditioned conjugate gradient.
//!
//! Both solve `A Δv = b` with `A = M(1 + αc) − α D − β K`, where `K = ∂F/∂x`
//! and `D = ∂F/∂v` come as per-connection 3×3 blocks from
//! [`assemble`](crate::model::jacobian::assemble) and `c` is the absolute
//! damping (`∂(−cMv)/∂v = −cM`):
//!
//! | scheme | α | β | b |
//! |---|---|---|---|
//! | backward Euler | h | h² | `h(F₀ + hKv₀)` |
//! | BDF2 | ⅔h | 4⁄9h² | `⅓M(vₙ − vₙ₋₁) + ⅔h[Fₙ + K(⅓(xₙ − xₙ₋₁) + ⅔h vₙ)]` |
//!
//! **Pins** are handled by the filter of BW §5: a pinned particle's rows
//! are zeroed, so its `Δv` is exactly 0 and it keeps the velocity it was
//! given (0, or an anchor's). No step allocates once the buffers are warm.

use bevy::math::{Mat3A, Vec3, Vec3A};

use crate::model::Dynamics;
use crate::model::jacobian::{Block, assemble};
use crate::settings::{ImplicitParams, SlackStiffness};

/// Preallocated state of the implicit integrators for one cloth.
#[derive(Clone, Debug, Default)]
pub struct ImplicitBuffers {
    /// Jacobian blocks of the current step.
    pub blocks: Vec<Block>,
    /// The particles of each block, and its `C = αD + βK`: what the
    /// conjugate gradient reads, packed.
    pairs: Vec<[u32; 2]>,
    combined: Vec<Mat3A>,
    precond: Vec<Mat3A>,
    force: Vec<Vec3>,
    // The solver's vectors are 16-byte `Vec3A`s, so that the operator's
    // gathers and scatters are one SIMD load or store each.
    rhs: Vec<Vec3A>,
    dv: Vec<Vec3A>,
    r: Vec<Vec3A>,
    d: Vec<Vec3A>,
    q: Vec<Vec3A>,
    y: Vec<Vec3A>,
    tmp: Vec<Vec3>,
    w_term: Vec<Vec3>,
    prev_x: Vec<Vec3>,
    prev_v: Vec<Vec3>,
    expected_x: Vec<Vec3>,
    /// Step length of the stored BDF2 history, if there is one.
    history: Option<f32>,
    /// Whether `dv` holds the last step's solution, the next solve's
    /// starting guess (a warm start).
    warm: bool,
    /// Conjugate-gradient iterations of the last solve.
    pub last_iterations: u32,
    /// `√(rᵀP⁻¹r / bᵀP⁻¹b)` at the end of the last solve (dimensionless).
    pub last_residual: f32,
}

impl ImplicitBuffers {
    fn resize(&mut self, n: usize) {
        if self.force.len() != n {
            self.history = None;
            self.warm = false;
        }
        for buf in [
            &mut self.rhs,
            &mut self.dv,
            &mut self.r,
            &mut self.d,
            &mut self.q,
            &mut self.y,
        ] {
            buf.resize(n, Vec3A::ZERO);
        }
        for buf in [
            &mut self.force,
            &mut self.tmp,
            &mut self.w_term,
            &mut self.prev_x,
            &mut self.prev_v,
            &mut self.expected_x,
        ] {
            buf.resize(n, Vec3::ZERO);
        }
        self.precond.resize(n, Mat3A::IDENTITY);
    }

    /// Forgets the BDF2 history, so the next BDF2 step is backward Euler.
    pub fn reset_history(&mut self) {
        self.history = None;
        self.warm = false;
    }
}

/// `out = K w`: `(K w)_a = Σ H (w_b − w_a)`, `(K w)_b = Σ H (w_a − w_b)`.
pub fn k_times(blocks: &[Block], w: &[Vec3], out: &mut [Vec3]) {
    out.fill(Vec3::ZERO);
    for blk in blocks {
        let t = blk.k * (w[blk.b as usize] - w[blk.a as usize]);
        out[blk.a as usize] += t;
        out[blk.b as usize] -= t;
    }
}

/// The filtered operator `A`, from per-block `C = αD + βK` and the scaled
/// mass `M(1 + αc)`.
struct Operator<'a> {
    pairs: &'a [[u32; 2]],
    combined: &'a [Mat3A],
    inverse_masses: &'a [f32],
    mass_scale: f32,
}

impl Operator<'_> {
    fn apply(&self, d: &[Vec3A], out: &mut [Vec3A]) {
        for ((o, &w), &di) in out.iter_mut().zip(self.inverse_masses).zip(d) {
            *o = if w == 0.0 {
                Vec3A::ZERO
            } else {
                di * (self.mass_scale / w)
            };
        }
        for (&[a, b], c) in self.pairs.iter().zip(self.combined) {
            let (a, b) = (a as usize, b as usize);
            let t = *c * (d[b] - d[a]);
            out[a] -= t;
            out[b] += t;
        }
        for (o, &w) in out.iter_mut().zip(self.inverse_masses) {
            if w == 0.0 {
                *o = Vec3A::ZERO;
            }
        }
    }

    /// Inverses of the 3×3 diagonal blocks of `A` (identity for pins).
    fn precondition(&self, out: &mut [Mat3A]) {
        for (p, &w) in out.iter_mut().zip(self.inverse_masses) {
            *p = if w == 0.0 {
                Mat3A::ZERO
            } else {
                Mat3A::from_diagonal(Vec3::splat(self.mass_scale / w))
            };
        }
        for (&[a, b], c) in self.pairs.iter().zip(self.combined) {
            out[a as usize] += *c;
            out[b as usize] += *c;
        }
        for (p, &w) in out.iter_mut().zip(self.inverse_masses) {
            let det = p.determinant();
            *p = if w == 0.0 {
                Mat3A::IDENTITY
            } else if det.abs() > 1e-30 && det.is_finite() {
                p.inverse()
            } else {
                // Fall back to the diagonal.
                Mat3A::from_diagonal(Vec3::new(
                    1.0 / p.x_axis.x,
                    1.0 / p.y_axis.y,
                    1.0 / p.z_axis.z,
                ))
            };
        }
    }
}

fn dot(a: &[Vec3A], b: &[Vec3A]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(*y) as f64).sum()
}

/// Solves `A Δv = b` (b already filtered) into `buffers.dv` by PCG with the
/// block-Jacobi preconditioner `buffers.precond`. It starts from the last
/// step's `Δv` when there is one and it is closer than `Δv = 0` (a warm
/// start), and stops once `rᵀP r ≤ ε² bᵀP b` either way.
/// Returns (iterations, relative residual).
fn pcg(op: &Operator, params: &ImplicitParams, buffers: &mut ImplicitBuffers) -> (u32, f32) {
    let ImplicitBuffers {
        precond,
        rhs,
        dv,
        r,
        d,
        q,
        y,
        warm,
        ..
    } = buffers;
    // y = P r for the block-Jacobi preconditioner P.
    let precondition = |y: &mut [Vec3A], r: &[Vec3A]| {
        for ((yi, pi), ri) in y.iter_mut().zip(precond.iter()).zip(r) {
            *yi = *pi * *ri;
        }
    };
    precondition(y, rhs);
    let delta0 = dot(rhs, y);
    if !(delta0 > 0.0 && delta0.is_finite()) {
        dv.fill(Vec3A::ZERO);
        *warm = false;
        return (0, 0.0);
    }
    let tried_warm = *warm;
    let mut delta = f64::NAN;
    if tried_warm {
        filter(op.inverse_masses, dv);
        op.apply(dv, q);
        for ((ri, bi), qi) in r.iter_mut().zip(rhs.iter()).zip(q.iter()) {
            *ri = *bi - *qi;
        }
        precondition(y, r);
        delta = dot(r, y);
    }
    if delta.is_nan() || delta >= delta0 {
        // Cold start: Δv = 0, r = b (and y = P b, unless the warm try overwrote it).
        dv.fill(Vec3A::ZERO);
        r.copy_from_slice(rhs);
        if tried_warm {
            precondition(y, r);
        }
        delta = delta0;
    }
    *warm = true;
    d.copy_from_slice(y);
    let tol2 = (params.tolerance as f64).powi(2);
    let mut iterations = 0;
    while iterations < params.max_iterations && delta > tol2 * delta0 {
        op.apply(d, q);
        let dq = dot(d, q);
        if !(dq > 0.0 && dq.is_finite()) {
            break; // not positive definite along d: stop with what we have
        }
        let alpha = (delta / dq) as f32;
        let mut next = 0.0;
        for ((((dvi, ri), yi), &di), (&qi, pi)) in dv
            .iter_mut()
            .zip(r.iter_mut())
            .zip(y.iter_mut())
            .zip(d.iter())
            .zip(q.iter().zip(precond.iter()))
        {
            *dvi += alpha * di;
            *ri -= alpha * qi;
            *yi = *pi * *ri;
            next += ri.dot(*yi) as f64;
        }
        let beta = (next / delta) as f32;
        for (di, &yi) in d.iter_mut().zip(y.iter()) {
            *di = yi + beta * *di;
        }
        delta = next;
        iterations += 1;
    }
    (iterations, (delta / delta0).max(0.0).sqrt() as f32)
}

/// Assembles forces and blocks at `(x, v)`, adds gravity, damping and the
/// external forces to `buffers.force` (N), and fills `combined` with
/// `αD + βK`.
fn linearise(
    dynamics: &Dynamics,
    x: &[Vec3],
    v: &[Vec3],
    alpha: f32,
    beta: f32,
    buffers: &mut ImplicitBuffers,
) {
    let s = dynamics.settings;
    let keep_slack = match s.implicit.slack_stiffness {
        SlackStiffness::Keep => true,
        SlackStiffness::Drop => false,
        SlackStiffness::Auto => {
            // β = h² (BE) or 4⁄9h² (BDF2): resolved when h²·k/m_min < 1.
            let lightest = dynamics.inverse_masses.iter().copied().fold(0.0, f32::max);
            beta * s.choi_ko.stiffness * lightest > 1.0
        }
    };
    assemble(
        s,
        dynamics.connections,
        keep_slack,
        x,
        v,
        &mut buffers.force,
        &mut buffers.blocks,
    );
    let external = (dynamics.external.len() == x.len()).then_some(dynamics.external);
    for i in 0..x.len() {
        let w = dynamics.inverse_masses[i];
        if w == 0.0 {
            buffers.force[i] = Vec3::ZERO;
            continue;
        }
        let m = 1.0 / w;
        buffers.force[i] +=
            m * (s.gravity - s.damping * v[i]) + external.map_or(Vec3::ZERO, |e| e[i]);
    }
    buffers.pairs.clear();
    buffers.combined.clear();
    for blk in interleaved(&buffers.blocks) {
        // A stretched Type 2 link or a dropped slack one adds nothing.
        let c = Mat3A::from(blk.d * alpha + blk.k * beta);
        if c != Mat3A::ZERO {
            buffers.pairs.push([blk.a, blk.b]);
            buffers.combined.push(c);
        }
    }
}

/// Streams the operator reads its blocks in, interleaved.
const STREAMS: usize = 8;

/// `blocks` in the order the operator reads them: [`STREAMS`] stretches of
/// the list, one block of each in turn. Neighbouring blocks of a family
/// share a particle, and a block that adds to the particle the previous one
/// just wrote waits for that store; blocks from far apart in the list share
/// none, so their updates overlap. Each stretch is still read in order.
fn interleaved(blocks: &[Block]) -> impl Iterator<Item = &Block> {
    let stretch = blocks.len().div_ceil(STREAMS);
    (0..stretch).flat_map(move |i| (0..STREAMS).filter_map(move |s| blocks.get(s * stretch + i)))
}

fn solve(dynamics: &Dynamics, alpha: f32, buffers: &mut ImplicitBuffers) {
    let pairs = std::mem::take(&mut buffers.pairs);
    let combined = std::mem::take(&mut buffers.combined);
    let op = Operator {
        pairs: &pairs,
        combined: &combined,
        inverse_masses: dynamics.inverse_masses,
        mass_scale: 1.0 + alpha * dynamics.settings.damping,
    };
    op.precondition(&mut buffers.precond);
    let (iterations, residual) = pcg(&op, &dynamics.settings.implicit, buffers);
    buffers.pairs = pairs;
    buffers.combined = combined;
    buffers.last_iterations = iterations;
    buffers.last_residual = residual;
}

/// Zeroes the rows of pinned particles.
fn filter(inverse_masses: &[f32], v: &mut [Vec3A]) {
    for (vi, &w) in v.iter_mut().zip(inverse_masses) {
        if w == 0.0 {
            *vi = Vec3A::ZERO;
        }
    }
}

/// One step of linearised backward Euler (MODEL.md §6.5):
/// `(M − hD − h²K) Δv = h(F₀ + hKv₀)`, `v₁ = v₀ + Δv`, `x₁ = x₀ + h v₁`.
///
/// `x` in m, `v` in m/s, `h` in s. First order, unconditionally stable for
/// the positive semidefinite Jacobians of
/// [`jacobian`](crate::model::jacobian).
pub fn backward_euler(
    dynamics: &Dynamics,
    x: &mut [Vec3],
    v: &mut [Vec3],
    h: f32,
    buffers: &mut ImplicitBuffers,
) {
    buffers.resize(x.len());
    buffers.prev_x.copy_from_slice(x);
    buffers.prev_v.copy_from_slice(v);
    backward_euler_step(dynamics, x, v, h, buffers);
    buffers.history = Some(h);
    buffers.expected_x.copy_from_slice(x);
}

fn backward_euler_step(
    dynamics: &Dynamics,
    x: &mut [Vec3],
    v: &mut [Vec3],
    h: f32,
    buffers: &mut ImplicitBuffers,
) {
    linearise(dynamics, x, v, h, h * h, buffers);
    k_times(&buffers.blocks, v, &mut buffers.tmp);
    for i in 0..x.len() {
        buffers.rhs[i] = (h * (buffers.force[i] + h * buffers.tmp[i])).into();
    }
    filter(dynamics.inverse_masses, &mut buffers.rhs);
    solve(dynamics, h, buffers);
    for i in 0..x.len() {
        v[i] += Vec3::from(buffers.dv[i]);
        x[i] += h * v[i];
    }
}

/// How far (m) the state may have moved from where the last step left it
/// before the BDF2 history is considered stale (a reset, a teleport).
/// Collision corrections are far smaller.
const HISTORY_SLACK: f32 = 0.01;

/// One step of second-order BDF (MODEL.md §6.6), the integrator Choi & Ko
/// used, linearised with one Newton step:
/// `(M − ⅔hD − 4⁄9h²K) Δv = ⅓M(vₙ − vₙ₋₁) + ⅔h[Fₙ + K(⅓(xₙ − xₙ₋₁) + ⅔h vₙ)]`,
/// `vₙ₊₁ = vₙ + Δv`, `xₙ₊₁ = 4⁄3xₙ − ⅓xₙ₋₁ + ⅔h vₙ₊₁`.
///
/// Without a usable history (the first step, a changed `h` or particle
/// count, or a state moved more than 1 cm from where the last step left it)
/// the step is backward Euler. `x` in m, `v` in m/s, `h` in s.
pub fn bdf2(
    dynamics: &Dynamics,
    x: &mut [Vec3],
    v: &mut [Vec3],
    h: f32,
    buffers: &mut ImplicitBuffers,
) {
    buffers.resize(x.len());
    let fresh = buffers.history == Some(h)
        && x.iter()
            .zip(&buffers.expected_x)
            .all(|(a, b)| a.distance_squared(*b) <= HISTORY_SLACK * HISTORY_SLACK);
    if !fresh {
        backward_euler(dynamics, x, v, h, buffers);
        return;
    }
    let (alpha, beta) = (2.0 / 3.0 * h, 4.0 / 9.0 * h * h);
    linearise(dynamics, x, v, alpha, beta, buffers);
    for i in 0..x.len() {
        buffers.w_term[i] = (x[i] - buffers.prev_x[i]) / 3.0 + 2.0 / 3.0 * h * v[i];
    }
    k_times(&buffers.blocks, &buffers.w_term, &mut buffers.tmp);
    for (i, &w) in dynamics.inverse_masses.iter().enumerate() {
        let inertia = if w == 0.0 {
            Vec3::ZERO
        } else {
            (v[i] - buffers.prev_v[i]) / (3.0 * w)
        };
        buffers.rhs[i] = (inertia + 2.0 / 3.0 * h * (buffers.force[i] + buffers.tmp[i])).into();
    }
    filter(dynamics.inverse_masses, &mut buffers.rhs);
    solve(dynamics, alpha, buffers);
    for i in 0..x.len() {
        let (xn, vn) = (x[i], v[i]);
        let v1 = vn + Vec3::from(buffers.dv[i]);
        // 4⁄3xₙ − ⅓xₙ₋₁ + ⅔hv written as xₙ plus a small increment, so f32
        // rounds once per step instead of cancelling large terms.
        let x1 = xn + ((xn - buffers.prev_x[i]) / 3.0 + 2.0 / 3.0 * h * v1);
        buffers.prev_x[i] = xn;
        buffers.prev_v[i] = vn;
        x[i] = x1;
        v[i] = v1;
    }
    buffers.expected_x.copy_from_slice(x);
}

#[cfg(test)]
mod tests;
