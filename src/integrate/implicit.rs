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
mod tests {
    use super::*;
    use crate::cloth::ClothBuilder;
    use crate::connections::{ClothConnections, Link};
    use crate::settings::{ClothModel, ClothSettings};

    /// Dense `A` (3n × 3n, f64) from the blocks, pinned rows and columns
    /// replaced by the identity.
    #[expect(
        clippy::needless_range_loop,
        reason = "dense matrix indices read best as indices"
    )]
    fn dense(buffers: &ImplicitBuffers, w: &[f32], mass_scale: f32) -> Vec<Vec<f64>> {
        let n = w.len();
        let mut a = vec![vec![0.0f64; 3 * n]; 3 * n];
        for i in 0..n {
            for k in 0..3 {
                a[3 * i + k][3 * i + k] = if w[i] == 0.0 {
                    0.0
                } else {
                    (mass_scale / w[i]) as f64
                };
            }
        }
        for (&[p, q], c) in buffers.pairs.iter().zip(&buffers.combined) {
            let (p, q, c) = (p as usize, q as usize, bevy::math::Mat3::from(*c));
            for r in 0..3 {
                for s in 0..3 {
                    let v = c.col(s)[r] as f64;
                    a[3 * p + r][3 * p + s] += v;
                    a[3 * q + r][3 * q + s] += v;
                    a[3 * p + r][3 * q + s] -= v;
                    a[3 * q + r][3 * p + s] -= v;
                }
            }
        }
        for i in (0..n).filter(|&i| w[i] == 0.0) {
            for k in 0..3 {
                for j in 0..3 * n {
                    a[3 * i + k][j] = 0.0;
                    a[j][3 * i + k] = 0.0;
                }
                a[3 * i + k][3 * i + k] = 1.0;
            }
        }
        a
    }

    #[test]
    fn the_operator_reads_every_block_once_and_neighbours_apart() {
        let cloth = ClothBuilder::new(20, 20).build().unwrap();
        let settings = ClothSettings::default();
        let mut buffers = ImplicitBuffers::default();
        let (x, v) = (&cloth.particles.positions, &cloth.particles.velocities);
        assemble(
            &settings,
            &cloth.connections,
            true,
            x,
            v,
            &mut vec![Vec3::ZERO; 400],
            &mut buffers.blocks,
        );
        let order: Vec<[u32; 2]> = interleaved(&buffers.blocks).map(|b| [b.a, b.b]).collect();
        let mut sorted = order.clone();
        let mut all: Vec<[u32; 2]> = buffers.blocks.iter().map(|b| [b.a, b.b]).collect();
        sorted.sort_unstable();
        all.sort_unstable();
        assert_eq!(sorted, all);
        let shared = order
            .windows(2)
            .filter(|w| w[0].iter().any(|p| w[1].contains(p)))
            .count();
        assert!(shared < order.len() / 100, "{shared} of {}", order.len());
    }

    /// Gaussian elimination with partial pivoting.
    #[expect(
        clippy::needless_range_loop,
        reason = "dense matrix indices read best as indices"
    )]
    fn gauss(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
        let n = b.len();
        for col in 0..n {
            let pivot = (col..n)
                .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
                .unwrap();
            a.swap(col, pivot);
            b.swap(col, pivot);
            for row in col + 1..n {
                let f = a[row][col] / a[col][col];
                for k in col..n {
                    a[row][k] -= f * a[col][k];
                }
                b[row] -= f * b[col];
            }
        }
        let mut x = vec![0.0; n];
        for row in (0..n).rev() {
            let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
            x[row] = (b[row] - s) / a[row][row];
        }
        x
    }

    #[test]
    fn pcg_matches_a_dense_solve_and_leaves_pins_alone() {
        let mut cloth = ClothBuilder::new(4, 4).pin(0).pin(3).build().unwrap();
        // Deform: stretch some links, compress others.
        for (i, x) in cloth.particles.positions.iter_mut().enumerate() {
            let s = i as f32;
            *x += 0.08 * Vec3::new((s * 1.3).sin(), (s * 0.7).cos(), (s * 2.1).sin());
        }
        let v: Vec<Vec3> = (0..16)
            .map(|i| Vec3::splat((i as f32 * 0.4).cos()))
            .collect();
        let mut settings = ClothSettings::default();
        settings.implicit.tolerance = 1e-6;
        settings.implicit.max_iterations = 500;
        let w = cloth.particles.inverse_masses.clone();
        let dynamics = Dynamics {
            settings: &settings,
            connections: &cloth.connections,
            inverse_masses: &w,
            external: &[],
        };
        let h = 1.0 / 30.0;
        let mut buffers = ImplicitBuffers::default();
        buffers.resize(16);
        linearise(
            &dynamics,
            &cloth.particles.positions,
            &v,
            h,
            h * h,
            &mut buffers,
        );
        for (i, r) in buffers.rhs.iter_mut().enumerate() {
            *r = Vec3A::new(1.0, -2.0, 0.5) * (i as f32 * 0.3).sin() * 1e-3;
        }
        filter(&w, &mut buffers.rhs);
        solve(&dynamics, h, &mut buffers);
        let a = dense(&buffers, &w, 1.0 + h * settings.damping);
        let b: Vec<f64> = buffers
            .rhs
            .iter()
            .flat_map(|r| r.to_array().map(|c| c as f64))
            .collect();
        let exact = gauss(a, b);
        let norm: f64 = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
        let err: f64 = buffers
            .dv
            .iter()
            .flat_map(|d| d.to_array())
            .zip(&exact)
            .map(|(g, e)| (g as f64 - e).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            err < 1e-3 * norm,
            "PCG error {err} of {norm} after {} iterations",
            buffers.last_iterations
        );
        assert!(buffers.last_residual <= 1e-6);
        // Pins: Δv exactly zero.
        assert_eq!(buffers.dv[0], Vec3A::ZERO);
        assert_eq!(buffers.dv[3], Vec3A::ZERO);

        // Warm start: the same system again starts at its solution and
        // needs (almost) no iterations; a slightly changed one needs fewer
        // than from zero and meets the same tolerance.
        let cold = buffers.last_iterations;
        let first = buffers.dv.clone();
        solve(&dynamics, h, &mut buffers);
        assert!(buffers.last_iterations <= 1, "{}", buffers.last_iterations);
        for r in &mut buffers.rhs {
            *r *= 1.01;
        }
        solve(&dynamics, h, &mut buffers);
        let warm = buffers.last_iterations;
        assert!(warm < cold, "warm {warm} vs cold {cold} iterations");
        assert!(buffers.last_residual <= 1e-6);
        let scaled = first
            .iter()
            .zip(&buffers.dv)
            .map(|(a, b)| (*a * 1.01 - *b).length());
        assert!(scaled.fold(0.0, f32::max) < 1e-3 * norm as f32);
        // A forgotten history starts cold again.
        buffers.reset_history();
        solve(&dynamics, h, &mut buffers);
        assert_eq!(buffers.last_iterations, cold);
    }

    #[test]
    fn pinned_particles_keep_their_prescribed_velocity_exactly() {
        let mut cloth = ClothBuilder::new(5, 5).pin(0).pin(4).build().unwrap();
        cloth.particles.velocities[4] = Vec3::new(0.3, 0.0, -0.1); // a moving anchor
        let settings = ClothSettings::default();
        for integrator in [backward_euler, bdf2] {
            let mut x = cloth.particles.positions.clone();
            let mut v = cloth.particles.velocities.clone();
            let w = cloth.particles.inverse_masses.clone();
            let dynamics = Dynamics {
                settings: &settings,
                connections: &cloth.connections,
                inverse_masses: &w,
                external: &[],
            };
            let mut buffers = ImplicitBuffers::default();
            for _ in 0..30 {
                integrator(&dynamics, &mut x, &mut v, 1.0 / 60.0, &mut buffers);
            }
            assert_eq!(x[0], cloth.particles.positions[0]);
            assert_eq!(v[0], Vec3::ZERO);
            assert_eq!(v[4], Vec3::new(0.3, 0.0, -0.1));
            assert!((x[4] - (cloth.particles.positions[4] + 0.5 * v[4])).length() < 1e-5);
            assert!(x.iter().all(|p| p.is_finite()));
        }
    }

    /// A mass on a spring to a pin, `ẍ = −ω²x − c ẋ` along the spring.
    fn spring_error(
        step: fn(&Dynamics, &mut [Vec3], &mut [Vec3], f32, &mut ImplicitBuffers),
        dt: f32,
    ) -> f64 {
        let (k, m, c) = (40.0f32, 1.0f32, 0.5f32);
        let mut settings = ClothSettings::default().with_model(ClothModel::Lander);
        settings.gravity = Vec3::ZERO;
        settings.damping = c;
        settings.lander.structural.stiffness = k;
        settings.lander.structural.damping = 0.0;
        settings.implicit.tolerance = 1e-7;
        let connections = ClothConnections {
            structural: vec![Link {
                a: 0,
                b: 1,
                rest_length: 1.0,
            }],
            ..Default::default()
        };
        let w = [0.0, 1.0 / m];
        let dynamics = Dynamics {
            settings: &settings,
            connections: &connections,
            inverse_masses: &w,
            external: &[],
        };
        let mut x = [Vec3::ZERO, Vec3::new(1.1, 0.0, 0.0)];
        let mut v = [Vec3::ZERO; 2];
        let mut buffers = ImplicitBuffers::default();
        // The largest error over 1 s (a single time would depend on phase).
        let steps = (1.0 / dt).round() as usize;
        let (omega2, zw) = ((k / m) as f64, c as f64 / 2.0);
        let wd = (omega2 - zw * zw).sqrt();
        let mut worst = 0.0f64;
        for n in 1..=steps {
            step(&dynamics, &mut x, &mut v, dt, &mut buffers);
            let t = n as f64 * dt as f64;
            let exact = 0.1 * (-zw * t).exp() * ((wd * t).cos() + zw / wd * (wd * t).sin());
            worst = worst.max(((x[1].x - 1.0) as f64 - exact).abs());
        }
        worst
    }

    #[test]
    fn backward_euler_is_first_order_and_bdf2_second_order() {
        // Observed order log₂(e(dt)/e(dt/2)): ~1 for BE (error halves), ~2
        // for BDF2 (error quarters; its first step is BE, so allow 1.7–2.3).
        let order = |s: fn(&Dynamics, &mut [Vec3], &mut [Vec3], f32, &mut ImplicitBuffers)| {
            (spring_error(s, 0.004) / spring_error(s, 0.002)).log2()
        };
        let (be, bdf) = (order(backward_euler), order(bdf2));
        assert!((0.85..1.15).contains(&be), "backward Euler order {be}");
        assert!((1.7..2.3).contains(&bdf), "BDF2 order {bdf}");
    }
}
