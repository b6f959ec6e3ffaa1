use bevy::math::Vec3;

use super::StepBuffers;

/// Classical fourth-order Runge–Kutta on `(x, v)` (MODEL.md §6.3).
///
/// With slopes that do **not** contain `dt`:
/// `k₁ = (v, a(x, v))`, `k₂ = (v + ½dt·k₁ᵛ, a(x + ½dt·k₁ˣ, v + ½dt·k₁ᵛ))`,
/// `k₃` likewise from `k₂`, `k₄` with a full `dt` from `k₃`, then
/// `x⁺ = x + dt/6·(k₁ˣ + 2k₂ˣ + 2k₃ˣ + k₄ˣ)` and the same for `v`.
///
/// Where the paper differs, and why this code does:
/// - the paper's `kx_i` already contain `dt` and it multiplies their sum by
///   `dt` again, so positions would advance by `v·dt²`: the sum here is
///   multiplied by `dt` once;
/// - the paper evaluates the damping of every stage at the *old* velocity
///   (`−c·v` instead of `−c·(v + ½kv₁)` and so on): here every stage calls
///   the full acceleration at its own stage velocity, so velocity-dependent
///   forces are fourth-order too.
///
/// (Lander's demo RK4 also weights its slopes to 0.75 in total, integrating
/// gravity as ¾g; the weights here sum to 1.)
///
/// Four force evaluations a step; stable to about `dt ≤ 2.83/ω_max`.
/// `x` in m, `v` in m/s, `dt` in s; `buffers` must be sized for `x.len()`.
#[inline(always)]
pub fn rk4(
    x: &mut [Vec3],
    v: &mut [Vec3],
    dt: f32,
    buffers: &mut StepBuffers,
    mut accel: impl FnMut(&[Vec3], &[Vec3], &mut [Vec3]),
) {
    let StepBuffers {
        accel: a,
        stage_x,
        stage_v,
        sum_x,
        sum_v,
        ..
    } = buffers;
    let half = 0.5 * dt;
    let n = 3 * x.len();
    // The updates run over flat component arrays, which vectorise.
    use super::{flat, flat_mut};

    // Stage 1 at (x, v): k₁ = (v, a₁).
    accel(x, v, a);
    {
        let (x, v, a) = (&flat(x)[..n], &flat(v)[..n], &flat(a)[..n]);
        let (sx, sv) = (&mut flat_mut(sum_x)[..n], &mut flat_mut(sum_v)[..n]);
        let (tx, tv) = (&mut flat_mut(stage_x)[..n], &mut flat_mut(stage_v)[..n]);
        for i in 0..n {
            sx[i] = v[i];
            sv[i] = a[i];
            tx[i] = x[i] + half * v[i];
            tv[i] = v[i] + half * a[i];
        }
    }
    // Stages 2 and 3: k = (stage_v, a(stage)), next stage from x, v and k.
    for h in [half, dt] {
        accel(stage_x, stage_v, a);
        let (x, v, a) = (&flat(x)[..n], &flat(v)[..n], &flat(a)[..n]);
        let (sx, sv) = (&mut flat_mut(sum_x)[..n], &mut flat_mut(sum_v)[..n]);
        let (tx, tv) = (&mut flat_mut(stage_x)[..n], &mut flat_mut(stage_v)[..n]);
        for i in 0..n {
            sx[i] += 2.0 * tv[i];
            sv[i] += 2.0 * a[i];
            tx[i] = x[i] + h * tv[i];
            tv[i] = v[i] + h * a[i];
        }
    }
    // Stage 4 at (x + dt·k₃ˣ, v + dt·k₃ᵛ), then the weighted update.
    accel(stage_x, stage_v, a);
    let sixth = dt / 6.0;
    let (x, v) = (&mut flat_mut(x)[..n], &mut flat_mut(v)[..n]);
    let (sx, sv) = (&flat(sum_x)[..n], &flat(sum_v)[..n]);
    let (tv, a) = (&flat(stage_v)[..n], &flat(a)[..n]);
    for i in 0..n {
        x[i] += sixth * (sx[i] + tv[i]);
        v[i] += sixth * (sv[i] + a[i]);
    }
}
