//! The implicit methods over the solve: linearised backward Euler
//! (MODEL.md §6.5), Choi & Ko's BDF2 (§6.6) and the Newton corrections
//! after a step.

use bevy::math::Vec3;

use super::{ImplicitBuffers, build_held, linearise, linearise_held, pcg, solve};
use crate::sim::model::Dynamics;

/// One step of linearised backward Euler (MODEL.md §6.5):
/// `(M − hD − h²K) Δv = h(F₀ + hKv₀)`, `v₁ = v₀ + Δv`, `x₁ = x₀ + h v₁`.
///
/// `x` in m, `v` in m/s, `h` in s. First order, unconditionally stable for
/// the positive semidefinite Jacobians of
/// [`jacobian`](crate::sim::model::jacobian).
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
    buffers.target_v.copy_from_slice(v);
    buffers.gamma = h;
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
    let held = if buffers.contacts.none() {
        linearise(dynamics, (x, v, v), h, h * h, buffers);
        false
    } else {
        // `prev_v` holds v₀ (copied by `backward_euler`): D = h v₀.
        let v0 = std::mem::take(&mut buffers.prev_v);
        let held = linearise_held(dynamics, (x, v, None), (h, h * h, h), (&v0, h), buffers);
        buffers.prev_v = v0;
        held
    };
    let fill = |buffers: &mut ImplicitBuffers| {
        for i in 0..x.len() {
            let rhs = h * (buffers.force[i] + h * buffers.tmp[i]);
            buffers.rhs.set(i, rhs);
        }
        add_contact_rhs(buffers);
        buffers.rhs.filter(&buffers.op.free);
    };
    solve_revised(dynamics, buffers, (held, v), (h, h * h, h), fill);
    for i in 0..x.len() {
        v[i] += buffers.dv.get(i);
        x[i] += h * v[i];
    }
    if held {
        finish_held(buffers, (x, v), (h, h));
    }
}

/// How many times a step with free bodies among its contacts is revised
/// and solved again, at most ([`revise`]); it stops as soon as a pass
/// changes nothing. Each pass only lets contacts slide or go, so the
/// passes end. Next to a body one correction shows the next: under a plate
/// on a tablecloth, the body's friction shows its grip only once the
/// table's contact slides, and a contact that ends up pulling only once
/// the plate slides. A step with fixed surfaces only is revised once.
const REVISIONS: usize = 8;

/// How many revision passes this step may take ([`REVISIONS`]).
fn revisions(buffers: &ImplicitBuffers) -> usize {
    if buffers.contacts.bodies.is_empty() {
        1
    } else {
        REVISIONS
    }
}

/// After a solve that held contacts: corrects those it got wrong
/// ([`ContactBuffers::revise`]); whether any was, and the step is to be
/// solved again (`v` the velocities the solve started from, m/s; `γ`,
/// `h` in s). Up to [`REVISIONS`] passes: a contact the last solve would
/// correct too keeps its error for that step, as a contact with a fixed
/// surface does.
fn revise(buffers: &mut ImplicitBuffers, v: impl Fn(usize) -> Vec3, steps: (f32, f32)) -> bool {
    let ImplicitBuffers {
        contacts, dv, op, ..
    } = buffers;
    if !op.coupling.is_empty() {
        op.coupling.solved(|i| dv.get(i));
    }
    contacts.revise(|i| v(i) + dv.get(i), |i| dv.get(i), &op.coupling, steps)
}

/// Fills the right-hand side (`fill`) and solves the step; when it holds
/// contacts (`held`), revises them ([`revise`], `v` the velocities the
/// solve started from, m/s) and builds, fills and solves again, up to
/// [`revisions`] times. `α` (s) and `β` (s²) are the operator's, `h` (s)
/// the step's.
fn solve_revised(
    dynamics: &Dynamics,
    buffers: &mut ImplicitBuffers,
    (held, v): (bool, &[Vec3]),
    (alpha, beta, h): (f32, f32, f32),
    fill: impl Fn(&mut ImplicitBuffers),
) {
    fill(buffers);
    solve(dynamics, buffers);
    for _ in 0..revisions(buffers) {
        if !(held && revise(buffers, |i| v[i], (alpha, h))) {
            break;
        }
        build_held(dynamics, (alpha, beta), buffers);
        fill(buffers);
        solve(dynamics, buffers);
    }
}

/// After a step that held contacts, at its end state `(x, v)` (m, m/s):
/// the free bodies' couplings take the solve's `Δv`, and the contacts
/// finish ([`ContactBuffers::finish`](super::ContactBuffers::finish): a
/// reversed sliding stops, the forces and holds for the next step; `γ`,
/// `h` in s).
fn finish_held(
    buffers: &mut ImplicitBuffers,
    (x, v): (&mut [Vec3], &mut [Vec3]),
    steps: (f32, f32),
) {
    let ImplicitBuffers {
        contacts, dv, op, ..
    } = buffers;
    op.coupling.solved(|i| dv.get(i));
    contacts.finish((x, v), |i| dv.get(i), &op.coupling, steps);
}

/// Adds the sliding contacts' terms to the right-hand side.
fn add_contact_rhs(buffers: &mut ImplicitBuffers) {
    for &(p, r) in &buffers.contact_rhs {
        buffers.rhs.set(p, buffers.rhs.get(p) + r);
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
    // A pinned particle moves by exactly h·v (its prescribed motion), not
    // by the BDF2 extrapolation of its history: a grab that let go of it
    // leaves it where it is.
    let pinned = |i: usize| dynamics.inverse_masses.get(i) == Some(&0.0);
    for i in 0..x.len() {
        buffers.w_term[i] = if pinned(i) {
            h * v[i]
        } else {
            (x[i] - buffers.prev_x[i]) / 3.0 + 2.0 / 3.0 * h * v[i]
        };
    }
    let w_term = std::mem::take(&mut buffers.w_term);
    let held = if buffers.contacts.none() {
        linearise(dynamics, (x, v, &w_term), alpha, beta, buffers);
        false
    } else {
        let h = 1.5 * alpha;
        linearise_held(
            dynamics,
            (x, v, Some(&w_term)),
            (alpha, beta, h),
            (&w_term, 1.0),
            buffers,
        )
    };
    buffers.w_term = w_term;
    for ((target, &vn), &vp) in buffers.target_v.iter_mut().zip(&*v).zip(&buffers.prev_v) {
        *target = vn + (vn - vp) / 3.0;
    }
    buffers.gamma = 2.0 / 3.0 * h;
    let fill = |buffers: &mut ImplicitBuffers| {
        for (i, &w) in dynamics.inverse_masses.iter().enumerate() {
            let inertia = if w == 0.0 {
                Vec3::ZERO
            } else {
                (v[i] - buffers.prev_v[i]) / (3.0 * w)
            };
            let rhs = inertia + 2.0 / 3.0 * h * (buffers.force[i] + buffers.tmp[i]);
            buffers.rhs.set(i, rhs);
        }
        add_contact_rhs(buffers);
        buffers.rhs.filter(&buffers.op.free);
    };
    solve_revised(dynamics, buffers, (held, v), (alpha, beta, h), fill);
    for i in 0..x.len() {
        let (xn, vn) = (x[i], v[i]);
        let v1 = vn + buffers.dv.get(i);
        // 4⁄3xₙ − ⅓xₙ₋₁ + ⅔hv written as xₙ plus a small increment, so f32
        // rounds once per step instead of cancelling large terms.
        let x1 = if pinned(i) {
            xn + h * v1
        } else {
            xn + ((xn - buffers.prev_x[i]) / 3.0 + 2.0 / 3.0 * h * v1)
        };
        buffers.prev_x[i] = xn;
        buffers.prev_v[i] = vn;
        x[i] = x1;
        v[i] = v1;
    }
    if held {
        finish_held(buffers, (x, v), (alpha, h));
    }
    buffers.expected_x.copy_from_slice(x);
}

/// The factor on both solver tolerances of the solve of a
/// [`newton_correction`] (dimensionless): 0.1 solves it ten times tighter
/// than a step.
const NEWTON_TOLERANCE: f32 = 0.1;

/// One more Newton iteration of the last implicit step, at the state
/// `(x, v)` it left (m, m/s): with that step written as `x₁ = a + γv₁` and
/// `M(v₁ − b) = γF(x₁, v₁)` (backward Euler: `b = v₀`, `γ = h`; BDF2:
/// `b = ⁴⁄₃vₙ − ⅓vₙ₋₁`, `γ = ⅔h`), solves
/// `(M − γD − γ²K(x₁)) δ = γF(x₁, v₁) − M(v₁ − b)` and moves
/// `v₁ += δ`, `x₁ += γδ`.
///
/// The step itself linearises the forces at its start. When it moves the
/// cloth far from there (a strong gust on a slack sheet, whose linearised
/// stiffness across its plane is zero), the forces at the end differ from
/// the linearisation and the links overshoot; an iteration at the end
/// brings them back. Call it only right after [`backward_euler`] or
/// [`bdf2`] with the same `dynamics`.
pub(crate) fn newton_correction(
    dynamics: &Dynamics,
    x: &mut [Vec3],
    v: &mut [Vec3],
    buffers: &mut ImplicitBuffers,
) {
    let gamma = buffers.gamma;
    if x.len() != buffers.target_v.len() || gamma.is_nan() || gamma <= 0.0 {
        return;
    }
    linearise(dynamics, (x, v, v), gamma, gamma * gamma, buffers);
    for (i, &w) in dynamics.inverse_masses.iter().enumerate() {
        let inertia = if w == 0.0 {
            Vec3::ZERO
        } else {
            (v[i] - buffers.target_v[i]) / w
        };
        buffers.rhs.set(i, gamma * buffers.force[i] - inertia);
    }
    buffers.rhs.filter(&buffers.op.free);
    buffers.warm = false;
    // A step that strained a link this far was not linearised where it
    // ended: its correction is solved to tighter tolerances, or it would
    // leave much of the strain it is there to remove.
    let mut params = dynamics.settings.implicit;
    params.tolerance *= NEWTON_TOLERANCE;
    params.velocity_tolerance *= NEWTON_TOLERANCE;
    let (iterations, residual) = pcg(&params, buffers);
    buffers.last_iterations = iterations;
    buffers.last_residual = residual;
    buffers.warm = false;
    for i in 0..x.len() {
        let delta = buffers.dv.get(i);
        v[i] += delta;
        x[i] += gamma * delta;
    }
    buffers.expected_x.copy_from_slice(x);
}
