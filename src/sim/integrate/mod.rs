//! Time integrators as plain functions over slices. The folder imports the
//! force models (`model`), the foundations (`settings`, `connections`,
//! `soa`, `simd`, `team`) and `adaptive`, and nothing that schedules a
//! cloth.
//!
//! Each integrator advances positions `x` (m) and velocities `v` (m/s) by one
//! step `dt` (s), calling `accel(x, v, out)` to get accelerations (m/s²) as
//! often as its scheme needs. All scratch memory lives in [`StepBuffers`],
//! allocated once per cloth: no step allocates.
//!
//! | integrator | evaluations | order | stable for (one mode, MODEL.md §6.4) |
//! |---|---|---|---|
//! | `explicit_euler` | 1 | 1 | `dt ≤ c/ω²` |
//! | `symplectic_euler` | 1 | 1 | `dt ≲ 2/ω` |
//! | `rk4` | 4 | 4 | `dt ≲ 2.83/ω` |
//! | `backward_euler` | 1 + a linear solve | 1 | any `dt` |
//! | `bdf2` | 1 + a linear solve | 2 | any `dt` |
//!
//! Pinned particles have zero acceleration, so every scheme moves them
//! exactly along their prescribed velocity.

mod explicit_euler;
pub(crate) mod implicit;
pub(crate) mod refine;
mod rk4;
mod symplectic_euler;

pub(crate) use explicit_euler::explicit_euler;
pub(crate) use implicit::{ImplicitBuffers, backward_euler, bdf2};
pub(crate) use rk4::rk4;
pub(crate) use symplectic_euler::symplectic_euler;

use bevy::math::Vec3;

use crate::sim::model::Dynamics;
use crate::sim::settings::Integrator;

/// The components of `v` as one flat array (x, y, z of each vector in
/// turn), so that element-wise loops vectorise.
#[inline]
fn flat(v: &[Vec3]) -> &[f32] {
    bytemuck::cast_slice(v)
}

/// [`flat`] for writing.
#[inline]
fn flat_mut(v: &mut [Vec3]) -> &mut [f32] {
    bytemuck::cast_slice_mut(v)
}

/// Preallocated per-cloth scratch for the integrators, kept between steps
/// (its contents are the integrators' own).
#[derive(Clone, Debug, Default)]
pub struct StepBuffers {
    /// Accelerations of the current stage (m/s²).
    pub(crate) accel: Vec<Vec3>,
    /// Stage positions (RK4), m.
    pub(crate) stage_x: Vec<Vec3>,
    /// Stage velocities (RK4), m/s.
    pub(crate) stage_v: Vec<Vec3>,
    /// Weighted sum of the position slopes (RK4), m/s.
    pub(crate) sum_x: Vec<Vec3>,
    /// Weighted sum of the velocity slopes (RK4), m/s².
    pub(crate) sum_v: Vec<Vec3>,
    /// Positions at the start of the substep (m), kept only when contacts
    /// are resolved (see [`step_cloth_with`](crate::sim::step::step_cloth_with)).
    pub(crate) substep_start: Vec<Vec3>,
    /// Buffers of the implicit integrators (sized on first use).
    pub(crate) implicit: ImplicitBuffers,
    /// The explicit integrators' force streams (built on first use).
    pub(crate) streams: crate::sim::model::streams::ForceStreams,
    /// Per-particle sums of the adaptive substep estimate
    /// ([`adaptive`](crate::sim::adaptive)), filled only when it is on.
    pub(crate) mode_sums: Vec<crate::sim::adaptive::ModeSums>,
    /// The threads the step may spread its force bands over (none by
    /// default: the calling thread alone).
    pub(crate) workers: crate::sim::workers::Pool,
}

impl StepBuffers {
    /// Buffers for `n` particles.
    pub fn new(n: usize) -> Self {
        let mut b = Self::default();
        b.resize(n);
        b
    }

    /// Lets the step spread its force bands over `workers` (by default it
    /// runs on the calling thread alone).
    pub fn with_workers(mut self, workers: crate::sim::workers::Pool) -> Self {
        self.workers = workers;
        self
    }

    /// Names the connections the following steps take by `generation`, a
    /// number the caller changes whenever they change (an edit, a tear, a
    /// crease, other connections passed): while it stays the same, the
    /// caches built from the links (the force streams, a mesh cloth's
    /// coarse correction) trust them unchanged instead of comparing or
    /// hashing them each step. `None`, the default, compares them every
    /// step. [`ClothPlugin`](crate::ClothPlugin) sets it from the
    /// [`ClothConnections`](crate::plugin::step::components::ClothConnections)
    /// component's change ticks.
    pub fn set_links_generation(&mut self, generation: Option<u64>) {
        self.streams.set_links_generation(generation);
        self.implicit.set_links_generation(generation);
    }

    /// Forgets the implicit integrators' history (BDF2's last step and the
    /// contacts' holds), as after a teleport: the next BDF2 step is a
    /// backward-Euler one.
    pub fn reset_history(&mut self) {
        self.implicit.reset_history();
    }

    /// Conjugate-gradient iterations of the last implicit substep.
    pub fn solver_iterations(&self) -> u32 {
        self.implicit.last_iterations
    }

    /// Makes room for `n` particles; allocates only when `n` changes.
    pub fn resize(&mut self, n: usize) {
        for buf in [
            &mut self.accel,
            &mut self.stage_x,
            &mut self.stage_v,
            &mut self.sum_x,
            &mut self.sum_v,
        ] {
            buf.resize(n, Vec3::ZERO);
        }
    }
}

/// Brings the force streams of an explicit integrator up to date with the
/// connections of `dynamics`, for `n` particles.
pub(crate) fn sync(integrator: Integrator, dynamics: &Dynamics, n: usize, b: &mut StepBuffers) {
    if !integrator.is_implicit() {
        dynamics.sync_streams(&mut b.streams, n);
    }
}

/// One step of `integrator` after a [`sync`] since the connections last changed: the
/// connections are compared once per fixed step, not once per substep.
pub(crate) fn step_synced(
    integrator: Integrator,
    dynamics: &Dynamics,
    x: &mut [Vec3],
    v: &mut [Vec3],
    dt: f32,
    buffers: &mut StepBuffers,
) {
    if !integrator.is_implicit() {
        // Compiled for the CPU's vectors, so that the explicit integrators'
        // stage updates and the accelerations' last pass run sixteen lanes
        // wide on AVX-512 (the crate is otherwise built for baseline
        // x86-64's four): about 3 % off a 15×15 RK4 or explicit Euler step
        // on a 2-core x86-64 with AVX-512.
        return explicit_at(
            crate::simd::level(),
            integrator,
            dynamics,
            x,
            v,
            dt,
            buffers,
        );
    }
    step_inner(integrator, dynamics, x, v, dt, buffers);
}

crate::simd::multiversion! {
    /// [`step_inner`] compiled for a SIMD level.
    fn explicit_at(
        integrator: Integrator,
        dynamics: &Dynamics,
        x: &mut [Vec3],
        v: &mut [Vec3],
        dt: f32,
        buffers: &mut StepBuffers,
    ) = step_inner;
}

/// The body of [`step_synced`], inlined into each of its builds.
#[inline(always)]
fn step_inner(
    integrator: Integrator,
    dynamics: &Dynamics,
    x: &mut [Vec3],
    v: &mut [Vec3],
    dt: f32,
    buffers: &mut StepBuffers,
) {
    // Taken out for the step so that `accel` may borrow it while the
    // integrators borrow the other buffers.
    let mut streams = std::mem::take(&mut buffers.streams);
    let accel = |x: &[Vec3], v: &[Vec3], a: &mut [Vec3]| {
        dynamics.accelerations_synced(&mut streams, x, v, a)
    };
    match integrator {
        Integrator::ExplicitEuler => explicit_euler(x, v, dt, &mut buffers.accel, accel),
        Integrator::SymplecticEuler => symplectic_euler(x, v, dt, &mut buffers.accel, accel),
        Integrator::Rk4 => rk4(x, v, dt, buffers, accel),
        Integrator::BackwardEuler => backward_euler(dynamics, x, v, dt, &mut buffers.implicit),
        Integrator::Bdf2 => bdf2(dynamics, x, v, dt, &mut buffers.implicit),
    }
    buffers.streams = streams;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A damped spring–mass `ẍ = −ω²x − c ẋ` from x = 1, v = 0, and its
    /// exact solution at time `t`.
    const OMEGA: f32 = std::f32::consts::TAU;
    const C: f32 = 0.5;

    fn exact(t: f64) -> f64 {
        let (w, c) = (OMEGA as f64, C as f64);
        let zeta_w = c / 2.0;
        let wd = (w * w - zeta_w * zeta_w).sqrt();
        (-zeta_w * t).exp() * ((wd * t).cos() + zeta_w / wd * (wd * t).sin())
    }

    /// One explicit step on a bare acceleration function.
    fn explicit(
        integrator: Integrator,
        x: &mut [Vec3],
        v: &mut [Vec3],
        dt: f32,
        b: &mut StepBuffers,
        f: impl FnMut(&[Vec3], &[Vec3], &mut [Vec3]),
    ) {
        match integrator {
            Integrator::ExplicitEuler => explicit_euler(x, v, dt, &mut b.accel, f),
            Integrator::SymplecticEuler => symplectic_euler(x, v, dt, &mut b.accel, f),
            Integrator::Rk4 => rk4(x, v, dt, b, f),
            _ => unreachable!("explicit integrators only"),
        }
    }

    fn error(integrator: Integrator, dt: f32, t_end: f32) -> f64 {
        let steps = (t_end / dt).round() as usize;
        let (mut x, mut v) = ([Vec3::X], [Vec3::ZERO]);
        let mut buffers = StepBuffers::new(1);
        for _ in 0..steps {
            explicit(integrator, &mut x, &mut v, dt, &mut buffers, |x, v, a| {
                a[0] = -OMEGA * OMEGA * x[0] - C * v[0];
            });
        }
        (x[0].x as f64 - exact(steps as f64 * dt as f64)).abs()
    }

    #[test]
    fn first_order_schemes_halve_their_error_when_dt_halves() {
        for integrator in [Integrator::ExplicitEuler, Integrator::SymplecticEuler] {
            let ratio = error(integrator, 1e-3, 1.0) / error(integrator, 5e-4, 1.0);
            assert!((1.8..2.2).contains(&ratio), "{integrator:?}: ratio {ratio}");
        }
    }

    #[test]
    fn rk4_cuts_its_error_sixteenfold_when_dt_halves() {
        let ratio = error(Integrator::Rk4, 0.04, 1.0) / error(Integrator::Rk4, 0.02, 1.0);
        assert!((13.0..19.0).contains(&ratio), "ratio {ratio}");
    }

    #[test]
    fn pinned_particles_move_exactly_with_their_velocity() {
        for integrator in Integrator::EXPLICIT {
            let mut x = [Vec3::new(0.25, 1.0, -3.0)];
            let start = x;
            let mut v = [Vec3::ZERO];
            let mut buffers = StepBuffers::new(1);
            for _ in 0..1000 {
                explicit(integrator, &mut x, &mut v, 1e-3, &mut buffers, |_, _, a| {
                    a[0] = Vec3::ZERO
                });
            }
            assert_eq!(x, start, "{integrator:?}");
        }
    }
}
