//! The solve of `A Δv = b`: a filtered conjugate gradient preconditioned
//! by the operator's block diagonal and the coarse corrections, started
//! warm from the last steps' solutions, on one thread or split in halves
//! with the helper thread.

use bevy::math::{DMat3, DVec3};
use bevy::platform::time::Instant;

use super::coarse::Coarse;
use super::halves::{self, Halves};
use super::mesh_coarse::MeshCoarse;
use super::operator::{Operator, Soa, dot};
use super::{ImplicitBuffers, past};
use crate::sim::settings::ImplicitSettings;
use crate::sim::team;

/// Solves `A Δv = b` (b already filtered) into `buffers.dv` by PCG with the
/// preconditioner `P⁻¹ = B⁻¹ (+ the coarse correction)`. It starts from the
/// last step's `Δv` when there is one and it is closer than `Δv = 0` (a
/// warm start), after hard solves from the best combination of the last
/// steps' solutions ([`past`], [`ImplicitSettings::past_solutions`]), and
/// stops once `rᵀP⁻¹r ≤ ε² bᵀP⁻¹b` either way.
/// Returns (iterations, relative residual).
pub(super) fn pcg(params: &ImplicitSettings, buffers: &mut ImplicitBuffers) -> (u32, f32) {
    // Compiled for the CPU's vectors, so that its vector updates, the
    // preconditioner and the coarse correction run as wide as they can.
    pcg_at(crate::simd::level(), params, buffers)
}

crate::simd::multiversion! {
    /// [`pcg_inner`] compiled for a SIMD level.
    fn pcg_at(params: &ImplicitSettings, buffers: &mut ImplicitBuffers) -> (u32, f32) = pcg_inner;
}

/// The body of [`pcg`], inlined into each of its builds.
#[inline(always)]
fn pcg_inner(params: &ImplicitSettings, buffers: &mut ImplicitBuffers) -> (u32, f32) {
    let ImplicitBuffers {
        op,
        rhs,
        dv,
        r,
        d,
        q,
        y,
        warm,
        coarse,
        coarse_active,
        mesh_coarse,
        mesh_coarse_active,
        last_threads: threads,
        choice,
        share,
        past,
        contacts,
        ..
    } = buffers;
    *threads = 1;
    let mut coarse = coarse_active.then_some(coarse);
    let mut mesh = mesh_coarse_active.then_some(mesh_coarse);
    precondition(op, coarse.as_deref_mut(), mesh.as_deref_mut(), rhs, y);
    let delta0 = dot(rhs, y);
    if !(delta0 > 0.0 && delta0.is_finite()) {
        dv.zero();
        *warm = false;
        return (0, 0.0);
    }
    // A mesh cloth's coarse correction is not split between threads.
    let halves = Halves::plan(op, coarse.as_deref()).filter(|_| mesh.is_none());
    let guess = (past.wanted() && contacts.none()).then_some(halves.is_none());
    let (mut delta, projected) = start(
        (op, &mut coarse, &mut mesh),
        rhs,
        [dv, r, y, q],
        (past, guess),
        *warm,
        delta0,
    );
    *warm = true;
    // Stop at the relative tolerance, or once the mass-weighted RMS error
    // of Δv is below the velocity tolerance: `rᵀP⁻¹r ≈ Σ m δv²` (P is
    // mostly the mass), and a cloth at rest has a right-hand side near 0.
    let floor = (params.velocity_tolerance as f64).powi(2) * op.total_mass();
    let tol2 = (params.tolerance as f64).powi(2).max(floor / delta0);
    let may_share = halves.is_some() && params.helper_thread;
    // Sums as the split solve sums them (when it may be split), so that a
    // solve gives the same bits on one thread or two.
    let dot = |a: &Soa, b: &Soa| halves.map_or_else(|| dot(a, b), |h| h.dot(a, b));
    // From the past solutions' guess, the directions leave out what it
    // solved ([`past::Past::deflate`]); the stopping rule still measures
    // `rᵀP⁻¹r`.
    if projected {
        past.deflate(y, dot);
    }
    let started = Instant::now();
    if let Some(halves) = halves
        && may_share
        && *share
        && let Some(claim) = team::claim()
    {
        let limits = (delta, delta0, tol2, params.max_iterations);
        let past = projected.then_some(&*past);
        let (iterations, delta) =
            halves::iterate(&claim, halves, op, coarse, past, [dv, r, y, q], limits);
        balance(op, dv, r, [d, q]);
        *threads = 2;
        choice.record(2, started.elapsed(), iterations);
        return (iterations, (delta / delta0).max(0.0).sqrt() as f32);
    }
    let past = projected.then_some(past);
    let limits = (delta, delta0, tol2, params.max_iterations);
    let (iterations, last) = iterate((op, coarse, mesh), [dv, r, y, q, d], past, dot, limits);
    delta = last;
    balance(op, dv, r, [d, q]);
    if may_share {
        choice.record(1, started.elapsed(), iterations);
    }
    (iterations, (delta / delta0).max(0.0).sqrt() as f32)
}

/// Stage 1 of [`pcg_inner`]: the `Δv` (m/s) to start from, with its
/// residual `r = b − AΔv` and `y = P⁻¹r` (`q` scratch), and `rᵀP⁻¹r` for
/// it. With `warm`, the last step's `Δv` (or, when `guess` is given, the
/// best combination of the last steps' solutions, `true` in the result;
/// `guess` says whether it is combined piece by piece, as in a solve not
/// split between threads) when that is closer than `Δv = 0` (whose
/// `rᵀP⁻¹r` is `delta0`); else `Δv = 0`.
#[inline(always)]
fn start(
    (op, coarse, mesh): (
        &mut Operator,
        &mut Option<&mut Coarse>,
        &mut Option<&mut MeshCoarse>,
    ),
    rhs: &Soa,
    [dv, r, y, q]: [&mut Soa; 4],
    (past, guess): (&mut past::Past, Option<bool>),
    warm: bool,
    delta0: f64,
) -> (f64, bool) {
    let mut delta = f64::NAN;
    let mut projected = false;
    if warm {
        // After hard solves: the best combination of the last ones'
        // solutions rather than the last alone. Not while the solve holds
        // contacts: their stiff springs come and go from one step to the
        // next, and the last steps' motion does not foretell them.
        // A split solve deflates the whole cloth's combination.
        if let Some(by_piece) = guess {
            projected = past.guess(op, rhs, dv, by_piece);
        }
        dv.filter(&op.free);
        op.apply(dv, q);
        for ((r, b), q) in r.0.iter_mut().zip(&rhs.0).zip(&q.0) {
            for ((ri, bi), qi) in r.iter_mut().zip(b).zip(q) {
                *ri = bi - qi;
            }
        }
        precondition(op, coarse.as_deref_mut(), mesh.as_deref_mut(), r, y);
        delta = dot(r, y);
    }
    if delta.is_nan() || delta >= delta0 {
        // Cold start: Δv = 0, r = b (and y = P⁻¹b, unless the warm try overwrote it).
        dv.zero();
        r.copy_from(rhs);
        if warm {
            precondition(op, coarse.as_deref_mut(), mesh.as_deref_mut(), r, y);
        }
        delta = delta0;
        projected = false;
    }
    (delta, projected)
}

/// Stage 2 of [`pcg_inner`] on this thread: conjugate gradient iterations
/// from `Δv`, `r` and `y` (`d`, `q` scratch) until `rᵀP⁻¹r ≤ tol2 · delta0`
/// or `max` iterations, its directions deflated by the `past` solutions
/// when the start was their guess. Returns the iterations and the last
/// `rᵀP⁻¹r`.
#[inline(always)]
fn iterate(
    (op, mut coarse, mut mesh): (&mut Operator, Option<&mut Coarse>, Option<&mut MeshCoarse>),
    [dv, r, y, q, d]: [&mut Soa; 5],
    mut past: Option<&mut past::Past>,
    dot: impl Fn(&Soa, &Soa) -> f64 + Copy,
    (mut delta, delta0, tol2, max): (f64, f64, f64, u32),
) -> (u32, f64) {
    d.copy_from(y);
    let mut iterations = 0;
    while iterations < max && delta > tol2 * delta0 {
        op.apply(d, q);
        let dq = dot(d, q);
        if !(dq > 0.0 && dq.is_finite()) {
            break; // not positive definite along d: stop with what we have
        }
        let alpha = (delta / dq) as f32;
        for k in 0..3 {
            for ((dvi, ri), (&di, &qi)) in dv.0[k]
                .iter_mut()
                .zip(r.0[k].iter_mut())
                .zip(d.0[k].iter().zip(&q.0[k]))
            {
                *dvi += alpha * di;
                *ri -= alpha * qi;
            }
        }
        precondition(op, coarse.as_deref_mut(), mesh.as_deref_mut(), r, y);
        let next = dot(r, y);
        if let Some(past) = past.as_deref_mut() {
            past.deflate(y, dot);
        }
        let beta = (next / delta) as f32;
        for (d, y) in d.0.iter_mut().zip(&y.0) {
            for (di, &yi) in d.iter_mut().zip(y) {
                *di = yi + beta * *di;
            }
        }
        delta = next;
        iterations += 1;
    }
    (iterations, delta)
}

/// After the conjugate gradient: corrects `Δv` (m/s) by the one uniform
/// velocity `δ` of the free particles that leaves no net residual,
/// `δ = (ZᵀAZ)⁻¹ Zᵀr` with `Z` the free particles' three translations
/// (`d`, `q` scratch).
///
/// A solve stopped at its tolerance leaves a residual `r = b − AΔv` (N·s)
/// whose sum is momentum the step made from nothing: the internal forces
/// sum to zero, their error need not. Small per step, it is the same each
/// step on a cloth doing the same thing, and moves it as a whole (uncorrected,
/// a paper napkin folding on a table walks off it at 0.3 m/s). This is a Galerkin
/// correction on the translations, so it also never raises the error in
/// the solver's energy norm; the step's momentum then changes by exactly
/// the external impulse, contacts and pins included. Three products.
pub(super) fn balance(op: &mut Operator, dv: &mut Soa, r: &Soa, [d, q]: [&mut Soa; 2]) {
    let net = |s: &Soa| {
        s.0.each_ref()
            .map(|c| c.iter().map(|&x| x as f64).sum::<f64>())
    };
    let left = DVec3::from(net(r));
    if left == DVec3::ZERO || !left.is_finite() {
        return;
    }
    let mut zaz = DMat3::ZERO;
    for k in 0..3 {
        for (c, comp) in d.0.iter_mut().enumerate() {
            comp.fill(if c == k { 1.0 } else { 0.0 });
        }
        d.filter(&op.free);
        op.apply(d, q);
        q.filter(&op.free);
        *zaz.col_mut(k) = DVec3::from(net(q));
    }
    let det = zaz.determinant();
    if det.is_nan() || det <= 0.0 {
        return;
    }
    let delta = (zaz.inverse() * left).as_vec3();
    if !delta.is_finite() {
        return;
    }
    for (comp, dk) in dv.0.iter_mut().zip(delta.to_array()) {
        for (v, &f) in comp.iter_mut().zip(op.free.iter()) {
            *v += dk * f;
        }
    }
}

/// `y = P⁻¹ r`: block-Jacobi, plus the coarse correction when there is one.
/// A function rather than a closure, so that it is inlined into (and
/// compiled for the SIMD width of) each build of [`pcg`]: as a closure it
/// ran as SSE and took 14 % of a 64×64 frame.
#[inline(always)]
pub(super) fn precondition(
    op: &Operator,
    coarse: Option<&mut Coarse>,
    mesh: Option<&mut MeshCoarse>,
    r: &Soa,
    y: &mut Soa,
) {
    op.precondition(r, y);
    if let Some(c) = coarse {
        c.add(r, y, &op.free);
    }
    if let Some(c) = mesh {
        c.add(r, y, &op.free);
    }
}
