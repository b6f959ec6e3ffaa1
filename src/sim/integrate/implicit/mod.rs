//! Implicit integrators: linearised backward Euler (Baraff–Witkin, MODEL.md
//! §6.5) and Choi & Ko's second-order BDF (§6.6) (`methods.rs`), solved
//! matrix-free by a filtered, preconditioned conjugate gradient
//! (`pcg.rs`): block-Jacobi, plus a
//! coarse correction over aggregates of particles: a multigrid V-cycle over
//! grid squares for grid cloths (`coarse.rs`), over groups grown over the
//! links for other cloths (`mesh_coarse.rs`;
//! [`ImplicitSettings::coarse_grid`](crate::sim::settings::ImplicitSettings::coarse_grid)).
//! The operator is stored by grid offset, so its product runs as SIMD loops
//! (`operator/`); the pairs of other cloths run as one list over the
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

use bevy::math::Vec3;

use coarse::Coarse;
use mesh_coarse::MeshCoarse;

pub(crate) use contacts::NO_BODY;
pub use contacts::{ContactBuffers, Hold, SolveBody, SolveContact};

use crate::sim::team;
use operator::{Operator, Soa};

use crate::sim::model::Dynamics;
#[cfg(test)]
use crate::sim::model::jacobian::add_k_times;
use crate::sim::model::jacobian::{Block, assemble_streamed};
use crate::sim::model::streams::ForceStreams;
use crate::sim::settings::SlackStiffness;

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

/// Assembles forces and blocks at `(x, v)`, adds gravity, damping and the
/// external forces to `buffers.force` (N), writes `K w` (N) into
/// `buffers.tmp` (`w` in m), and builds the operator
/// `A = M(1 + αc) − αD − βK` (and the coarse one when it is wanted).
pub(super) fn linearise(
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
pub(super) fn linearise_held(
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
pub(super) fn build_held(
    dynamics: &Dynamics,
    (alpha, beta): (f32, f32),
    buffers: &mut ImplicitBuffers,
) {
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

pub(super) fn solve(dynamics: &Dynamics, buffers: &mut ImplicitBuffers) {
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

#[cfg(test)]
mod tests;

mod bodies;
mod coarse;
pub(crate) mod contacts;
mod halves;
mod mesh_coarse;
mod methods;
mod operator;
mod past;
mod pcg;

pub(crate) use methods::newton_correction;
pub use methods::{backward_euler, bdf2};
use pcg::pcg;
mod separate;
