//! Implicit integrators: linearised backward Euler (Baraff–Witkin, MODEL.md
//! §6.5) and Choi & Ko's second-order BDF (§6.6), solved matrix-free by a
//! filtered, preconditioned conjugate gradient: block-Jacobi, plus a
//! coarse correction over aggregates of particles: a multigrid V-cycle over
//! grid squares for grid cloths (`coarse.rs`), over groups grown over the
//! links for other cloths (`mesh_coarse.rs`;
//! [`ImplicitSettings::coarse_grid`](crate::sim::settings::ImplicitSettings::coarse_grid)).
//! The operator is stored by grid offset, so its product runs as SIMD loops
//! (`operator.rs`); the pairs of other cloths run as one list over the
//! vector copied particle by particle. From 2048 particles the iterations
//! of a grid cloth are shared with a
//! helper thread, each running every pass on half the particles
//! (`halves.rs`, `crate::sim::team`;
//! [`ImplicitSettings::helper_thread`](crate::sim::settings::ImplicitSettings::helper_thread)),
//! to the same bits as on one thread.
//!
//! Both solve `A Δv = b` with `A = M(1 + αc) − α D − β K`, where `K = ∂F/∂x`
//! and `D = ∂F/∂v` come as per-connection blocks
//! ([`jacobian`](crate::sim::model::jacobian)), formed for the grid families a
//! stream at a time together with the forces and the product `K w` the
//! right-hand side needs (`assemble_streamed`), and `c` is the absolute
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

use bevy::platform::time::Instant;

use bevy::math::{DMat3, DVec3, Vec3};

use coarse::Coarse;
use halves::Halves;
use mesh_coarse::MeshCoarse;

pub(crate) use contacts::NO_BODY;
pub use contacts::{ContactBuffers, Hold, SolveBody, SolveContact};

use crate::sim::team;
use operator::{Operator, Soa, dot};

use crate::sim::model::Dynamics;
#[cfg(test)]
use crate::sim::model::jacobian::add_k_times;
use crate::sim::model::jacobian::{Block, assemble_streamed};
use crate::sim::model::streams::ForceStreams;
use crate::sim::settings::{ImplicitSettings, SlackStiffness};

/// Preallocated state of the implicit integrators for one cloth.
#[derive(Clone, Debug, Default)]
pub(crate) struct ImplicitBuffers {
    /// Jacobian blocks of the current step's links outside the streams
    /// (crease springs, links of an unusual step).
    pub blocks: Vec<Block>,
    /// The grid families by index step, whose forces and blocks are formed
    /// a stream at a time.
    streams: ForceStreams,
    /// The operator `A` of the current step, by grid offset.
    op: Operator,
    /// The coarse-grid correction of the preconditioner.
    coarse: Coarse,
    /// Whether `coarse` holds this step's factored operator.
    coarse_active: bool,
    /// The coarse correction of a cloth that is not a grid.
    mesh_coarse: MeshCoarse,
    /// Whether `mesh_coarse` holds this step's factored operator.
    mesh_coarse_active: bool,
    /// The generation of the links the steps take, if their owner keeps
    /// one ([`set_links_generation`](Self::set_links_generation)).
    links_generation: Option<u64>,
    force: Vec<Vec3>,
    // The solver's vectors, component by component (see `operator`).
    rhs: Soa,
    dv: Soa,
    r: Soa,
    d: Soa,
    q: Soa,
    y: Soa,
    tmp: Vec<Vec3>,
    w_term: Vec<Vec3>,
    prev_x: Vec<Vec3>,
    prev_v: Vec<Vec3>,
    expected_x: Vec<Vec3>,
    /// Step length of the stored BDF2 history, if there is one.
    history: Option<f32>,
    /// The last step's implicit equation, `x₁ = a + γv₁` and
    /// `M(v₁ − b) = γF(x₁, v₁)`: `b` (m/s) per particle and `γ` (s), for
    /// [`newton_correction`].
    target_v: Vec<Vec3>,
    gamma: f32,
    /// The contacts the solve holds ([`contacts`]).
    pub contacts: ContactBuffers,
    /// This step's right-hand-side terms of sliding contacts: particle and
    /// momentum (N·s).
    contact_rhs: Vec<(usize, Vec3)>,
    /// Whether `dv` holds the last step's solution, the next solve's
    /// starting guess (a warm start).
    warm: bool,
    /// Conjugate-gradient iterations of the last solve.
    pub last_iterations: u32,
    /// `√(rᵀP⁻¹r / bᵀP⁻¹b)` at the end of the last solve (dimensionless).
    pub last_residual: f32,
    /// Threads the last solve's iterations ran on: 2 when it shared them
    /// with the helper thread ([`ImplicitSettings::helper_thread`]).
    pub last_threads: u32,
    /// The last steps' solutions, for the next solve's starting guess.
    past: past::Past,
    /// Whether sharing them pays, by the last solves' times.
    choice: halves::Choice,
    /// Whether this step's solve is to share them, as `choice` had it.
    share: bool,
}

impl ImplicitBuffers {
    fn resize(&mut self, n: usize) {
        if self.force.len() != n {
            self.history = None;
            self.warm = false;
            self.past.clear();
        }
        for buf in [
            &mut self.rhs,
            &mut self.dv,
            &mut self.r,
            &mut self.d,
            &mut self.q,
            &mut self.y,
        ] {
            buf.resize(n);
        }
        for buf in [
            &mut self.force,
            &mut self.tmp,
            &mut self.w_term,
            &mut self.prev_x,
            &mut self.prev_v,
            &mut self.expected_x,
            &mut self.target_v,
        ] {
            buf.resize(n, Vec3::ZERO);
        }
    }

    /// Moves the BDF2 history of the particles `i` for which `moves(i)` as
    /// `carry` moves them (positions carried, velocities turned: a moving
    /// frame's carry or a teleport), so that the next BDF2 step finds it
    /// where the particles are.
    pub fn carry_history(
        &mut self,
        carry: &crate::sim::frame::Carry,
        moves: impl Fn(usize) -> bool,
    ) {
        if self.history.is_none() {
            return;
        }
        for i in (0..self.prev_x.len()).filter(|&i| moves(i)) {
            self.prev_x[i] = carry.point(self.prev_x[i]);
            self.expected_x[i] = carry.point(self.expected_x[i]);
            self.prev_v[i] = carry.vector(self.prev_v[i]);
        }
    }

    /// How the last step's end position changes with its end velocity,
    /// `γ` in `x₁ = a + γv₁` (s: `h` for backward Euler, `⅔h` for BDF2),
    /// if that step was taken for `n` particles.
    pub(crate) fn step_gamma(&self, n: usize) -> Option<f32> {
        (n == self.target_v.len() && self.gamma > 0.0).then_some(self.gamma)
    }

    /// Records that the last step's end state moved to `x` (m), for the
    /// next BDF2 step's check of its history.
    pub(crate) fn moved_to(&mut self, x: &[Vec3]) {
        if x.len() == self.expected_x.len() {
            self.expected_x.copy_from_slice(x);
        }
    }

    /// Forgets the BDF2 history, so the next BDF2 step is backward Euler,
    /// and the contacts' holds.
    pub fn reset_history(&mut self) {
        self.history = None;
        self.warm = false;
        self.past.clear();
        self.contacts.clear();
    }

    /// Names the links of the following steps by `generation` (see
    /// [`StepBuffers::set_links_generation`](crate::sim::integrate::StepBuffers::set_links_generation)).
    pub(crate) fn set_links_generation(&mut self, generation: Option<u64>) {
        self.links_generation = generation;
        self.streams.set_links_generation(generation);
    }
}

/// `out = K w`: `(K w)_a = Σ H (w_b − w_a)`, `(K w)_b = Σ H (w_a − w_b)`.
#[cfg(test)]
pub(crate) fn k_times(blocks: &[Block], w: &[Vec3], out: &mut [Vec3]) {
    out.fill(Vec3::ZERO);
    add_k_times(blocks, w, out);
}

/// Solves `A Δv = b` (b already filtered) into `buffers.dv` by PCG with the
/// preconditioner `P⁻¹ = B⁻¹ (+ the coarse correction)`. It starts from the
/// last step's `Δv` when there is one and it is closer than `Δv = 0` (a
/// warm start), after hard solves from the best combination of the last
/// steps' solutions ([`past`], [`ImplicitSettings::past_solutions`]), and
/// stops once `rᵀP⁻¹r ≤ ε² bᵀP⁻¹b` either way.
/// Returns (iterations, relative residual).
fn pcg(params: &ImplicitSettings, buffers: &mut ImplicitBuffers) -> (u32, f32) {
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
fn balance(op: &mut Operator, dv: &mut Soa, r: &Soa, [d, q]: [&mut Soa; 2]) {
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
fn precondition(
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

/// Assembles forces and blocks at `(x, v)`, adds gravity, damping and the
/// external forces to `buffers.force` (N), writes `K w` (N) into
/// `buffers.tmp` (`w` in m), and builds the operator
/// `A = M(1 + αc) − αD − βK` (and the coarse one when it is wanted).
fn linearise(
    dynamics: &Dynamics,
    (x, v, w): (&[Vec3], &[Vec3], &[Vec3]),
    alpha: f32,
    beta: f32,
    buffers: &mut ImplicitBuffers,
) {
    assemble(dynamics, (x, v, w), alpha, beta, buffers);
    // No contact is held: none of the last held step's terms may stay,
    // in the operator or on the right-hand side.
    buffers.op.extra.clear();
    buffers.op.coupling.clear();
    buffers.contact_rhs.clear();
    build(dynamics, dynamics.inverse_masses, alpha, beta, buffers);
}

/// The first half of [`linearise`]: forces, `K w` and the blocks.
fn assemble(
    dynamics: &Dynamics,
    (x, v, w): (&[Vec3], &[Vec3], &[Vec3]),
    alpha: f32,
    beta: f32,
    buffers: &mut ImplicitBuffers,
) {
    if dynamics.connections.columns == 0 && dynamics.settings.implicit.coarse_grid {
        buffers.mesh_coarse.place(x);
    }
    buffers.share = x.len() >= halves::MIN_PARTICLES
        && dynamics.settings.implicit.helper_thread
        && buffers.choice.share();
    if buffers.share {
        // The solve is to share its passes with the helper thread: have it
        // running by the time the set-up is done.
        team::wake();
    }
    let s = dynamics.settings;
    let keep_slack = match s.implicit.slack_stiffness {
        SlackStiffness::Keep => true,
        SlackStiffness::Drop => false,
        SlackStiffness::Auto => {
            // β = h² (BE) or 4⁄9h² (BDF2): resolved when h²·k/m_min < 1.
            let lightest = dynamics.inverse_masses.iter().copied().fold(0.0, f32::max);
            let k = s.choi_ko.stiffness.max(s.choi_ko.shear_stiffness);
            beta * k * lightest > 1.0
        }
    };
    assemble_streamed(
        s,
        dynamics.connections,
        (keep_slack, alpha, beta),
        x,
        v,
        w,
        (&mut buffers.force, &mut buffers.tmp),
        &mut buffers.blocks,
        &mut buffers.streams,
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
}

/// The second half of [`linearise`]: the operator (and the coarse one) for
/// the inverse masses `w` (1/kg) with the contacts' blocks already in
/// `op.extra`.
fn build(dynamics: &Dynamics, w: &[f32], alpha: f32, beta: f32, buffers: &mut ImplicitBuffers) {
    let s = dynamics.settings;
    let columns = dynamics.connections.columns as usize;
    let mass_scale = 1.0 + alpha * s.damping;
    let ImplicitBuffers {
        blocks,
        streams,
        op,
        coarse,
        mesh_coarse,
        links_generation,
        ..
    } = buffers;
    let generation = *links_generation;
    let (blocks, streams) = (&blocks[..], &*streams);
    let share = buffers.share;
    let extra = op.extra.clone();
    let mut build = move || {
        op.build_with(
            columns,
            (w, mass_scale),
            (blocks, streams.blocks()),
            (alpha, beta),
        )
    };
    let connections = dynamics.connections;
    let mut build_coarse = move || {
        if !s.implicit.coarse_grid {
            return (false, false);
        }
        if columns == 0 {
            let mesh = mesh_coarse.begin(connections, generation, w, mass_scale) && {
                mesh_coarse.add_pairs(w.len(), (blocks, streams.blocks()), (alpha, beta));
                for (i, c) in &extra {
                    mesh_coarse.add_diagonal(*i as usize, c);
                }
                mesh_coarse.finish()
            };
            return (false, mesh);
        }
        let grid = coarse.begin(columns, w, mass_scale) && {
            coarse.add_pairs(w.len(), (blocks, streams.blocks()), (alpha, beta));
            for (i, c) in &extra {
                coarse.add_diagonal(*i as usize, c);
            }
            coarse.finish()
        };
        (grid, false)
    };
    // The coarse grid's assembly and factorisation need only the blocks:
    // on the helper, when the solve is to share with it, it is awake.
    let ((), (grid, mesh)) = if share {
        team::both(build, build_coarse)
    } else {
        (build(), build_coarse())
    };
    buffers.coarse_active = grid;
    buffers.mesh_coarse_active = mesh;
}

/// Assembles the step at `(x, v)` (`w` as for [`linearise`]), holds this
/// step's contacts ([`ContactBuffers::begin`]) and builds the operator. `displacement` is
/// what the step moves each particle besides `γ Δv` (m), as a slice and a
/// scale; `h` the step (s). Returns whether any contact is held.
fn linearise_held(
    dynamics: &Dynamics,
    (x, v, w): (&[Vec3], &[Vec3], Option<&[Vec3]>),
    (alpha, beta, h): (f32, f32, f32),
    displacement: (&[Vec3], f32),
    buffers: &mut ImplicitBuffers,
) -> bool {
    assemble(dynamics, (x, v, w.unwrap_or(v)), alpha, beta, buffers);
    let ImplicitBuffers {
        contacts, force, ..
    } = buffers;
    let held = contacts.begin(
        dynamics.inverse_masses,
        force,
        (x, v),
        displacement,
        (alpha, beta, h),
    );
    build_held(dynamics, (alpha, beta), buffers);
    held
}

/// The operator with the held contacts' current terms
/// ([`ContactBuffers::emit`]) in it, and their right-hand sides in
/// `contact_rhs`.
fn build_held(dynamics: &Dynamics, (alpha, beta): (f32, f32), buffers: &mut ImplicitBuffers) {
    let ImplicitBuffers {
        contacts,
        op,
        contact_rhs,
        ..
    } = buffers;
    contact_rhs.clear();
    contacts.emit(&mut op.extra, &mut op.coupling, |p, r| {
        contact_rhs.push((p, r))
    });
    build(dynamics, dynamics.inverse_masses, alpha, beta, buffers);
}

/// The particle pairs `A` couples: every link, and the blocks besides.
fn coupled<'a>(
    c: &'a crate::sim::connections::Connections,
    blocks: &'a [Block],
) -> impl Iterator<Item = (u32, u32)> + 'a {
    [
        &c.structural,
        &c.shear,
        &c.bend,
        &c.bend_diagonal,
        &c.crease,
    ]
    .into_iter()
    .flatten()
    .map(|l| (l.a, l.b))
    .chain(blocks.iter().map(|b| (b.a, b.b)))
}

fn solve(dynamics: &Dynamics, buffers: &mut ImplicitBuffers) {
    let params = &dynamics.settings.implicit;
    if buffers.past.wanted() {
        let links = coupled(dynamics.connections, &buffers.blocks);
        let n = buffers.force.len();
        buffers.past.find_pieces(links, n, buffers.links_generation);
    }
    let (iterations, residual) = pcg(params, buffers);
    let keep = params.past_solutions as usize;
    buffers
        .past
        .remember(&buffers.dv, keep, (iterations, params.max_iterations));
    buffers.last_iterations = iterations;
    buffers.last_residual = residual;
}

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
    fill(buffers);
    solve(dynamics, buffers);
    for _ in 0..revisions(buffers) {
        if !(held && revise(buffers, |i| v[i], (h, h))) {
            break;
        }
        build_held(dynamics, (h, h * h), buffers);
        fill(buffers);
        solve(dynamics, buffers);
    }
    for i in 0..x.len() {
        v[i] += buffers.dv.get(i);
        x[i] += h * v[i];
    }
    if held {
        let ImplicitBuffers {
            contacts, dv, op, ..
        } = buffers;
        op.coupling.solved(|i| dv.get(i));
        contacts.finish((x, v), |i| dv.get(i), &op.coupling, (h, h));
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
        let ImplicitBuffers {
            contacts, dv, op, ..
        } = buffers;
        op.coupling.solved(|i| dv.get(i));
        contacts.finish((x, v), |i| dv.get(i), &op.coupling, (alpha, h));
    }
    buffers.expected_x.copy_from_slice(x);
}

/// The factor on both solver tolerances of the solve of a
/// [`newton_correction`] (dimensionless): 0.1 solves it ten times tighter
/// than a step.
pub(crate) const NEWTON_TOLERANCE: f32 = 0.1;

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

#[cfg(test)]
mod tests;

mod bodies;
mod coarse;
pub(crate) mod contacts;
mod halves;
mod mesh_coarse;
mod operator;
mod past;
mod separate;
