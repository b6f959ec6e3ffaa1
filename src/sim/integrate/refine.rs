//! The post-solve refinement of an implicit step: extra Newton iterations
//! of a step that strained its links far, then the strain limit
//! ([`limit_strain`]). The divergence guard calls [`refine`] after every
//! implicit attempt and checks what it left.
//!
//! What it may import: the force models, the implicit solve, the strain
//! limit and the foundations.

use bevy::math::Vec3;

use crate::sim::connections::{Connections, max_strain};
use crate::sim::integrate::StepBuffers;
use crate::sim::integrate::implicit::newton_correction;
use crate::sim::model::Dynamics;
use crate::sim::particles::Particles;
use crate::sim::settings::SimSettings;
use crate::sim::strain_limit::{MAX_SWEEPS, limit_strain};

/// What [`refine`] works on: the step's particles, links, settings,
/// external forces (N) and buffers, right after the implicit solve.
pub(crate) struct Refine<'a> {
    /// Positions (m), velocities (m/s) and inverse masses (1/kg).
    pub(crate) particles: &'a mut Particles,
    /// The cloth's links.
    pub(crate) connections: &'a Connections,
    /// The settings the step ran with.
    pub(crate) settings: &'a SimSettings,
    /// External force per particle (N), or empty.
    pub(crate) external: &'a [Vec3],
    /// The integrators' scratch, as the solve left it.
    pub(crate) buffers: &'a mut StepBuffers,
}

/// The positions (m) and velocities (m/s) before a Newton iteration or the
/// strain limit's sweeps, to undo them.
#[derive(Clone, Debug, Default)]
pub(crate) struct Undo {
    x: Vec<Vec3>,
    v: Vec<Vec3>,
}

impl Undo {
    fn save(&mut self, p: &Particles) {
        self.x.clone_from(&p.positions);
        self.v.clone_from(&p.velocities);
    }

    fn restore(&self, p: &mut Particles) {
        p.positions.clone_from(&self.x);
        p.velocities.clone_from(&self.v);
    }
}

/// The worst Type 1 strain (dimensionless) of `particles`, or `None` if a
/// position or velocity is not finite.
fn strain_of(particles: &Particles, connections: &Connections) -> Option<f32> {
    particles
        .is_finite()
        .then(|| max_strain(connections.type1(), &particles.positions))
}

/// Extra Newton iterations of an implicit step whose worst Type 1 `strain`
/// (dimensionless; `None`: not finite) is past
/// [`ImplicitSettings::newton_strain`](crate::sim::settings::ImplicitSettings::newton_strain)
/// and a fifth more than the `last` step left, each followed by
/// `resolve_last` (the contacts over the last substep again, given the
/// substep's start positions); an iteration that does not lower the strain
/// is undone. Then, if a Type 1 link is still strained past
/// [`ImplicitSettings::strain_limit`](crate::sim::settings::ImplicitSettings::strain_limit),
/// the links are shortened to it ([`limit_strain`]), followed by
/// `resolve_last`; sweeps that stop with a link still past the bound and
/// less than half the worst excess taken off (links held stretched between
/// pins) are undone. Neither runs on a step whose solve held contacts.
///
/// Returns whether the particles moved (and are to be checked again).
pub(crate) fn refine(
    r: Refine,
    undo: &mut Undo,
    last: Option<f32>,
    mut strain: Option<f32>,
    mut resolve_last: impl FnMut(&mut Particles, &[Vec3]),
) -> bool {
    if r.buffers.implicit.contacts.any() {
        // Its contacts were held inside the solve: a Newton iteration or
        // the strain limit, without them, would let go of them.
        return false;
    }
    let params = r.settings.implicit;
    let trigger = params.newton_strain.max(1.2 * last.unwrap_or(0.0));
    let mut moved = false;
    for _ in 0..params.newton_iterations {
        let Some(now) = strain else {
            break;
        };
        if now.is_nan() || now <= trigger {
            break;
        }
        undo.save(r.particles);
        let Particles {
            positions,
            velocities,
            inverse_masses,
            ..
        } = &mut *r.particles;
        let dynamics = Dynamics {
            settings: r.settings,
            connections: r.connections,
            inverse_masses,
            external: r.external,
            workers: &r.buffers.workers,
        };
        newton_correction(&dynamics, positions, velocities, &mut r.buffers.implicit);
        resolve_last(r.particles, &r.buffers.substep_start);
        let next = strain_of(r.particles, r.connections);
        if !next.is_some_and(|s| s < now) {
            undo.restore(r.particles);
            break;
        }
        strain = next;
        moved = true;
    }
    let Some(now) = strain else {
        return moved;
    };
    let n = r.particles.positions.len();
    if now > params.strain_limit
        && let Some(gamma) = r.buffers.implicit.step_gamma(n)
    {
        let p = &mut *r.particles;
        undo.save(p);
        let limited = limit_strain(
            &[&r.connections.structural, &r.connections.shear],
            &mut p.positions,
            &mut p.velocities,
            &p.inverse_masses,
            gamma,
            params.strain_limit,
            MAX_SWEEPS,
        );
        // Sweeps that stopped with a link still past the bound and took
        // less than half the worst excess off are up against links held
        // stretched between pinned or grabbed particles: their partial
        // moves would only crumple the cloth around them, so the step
        // stands as the solve left it.
        if limited.strain > 0.0 {
            let excess = |s: f32| s - params.strain_limit;
            let left = max_strain(r.connections.type1(), &p.positions);
            let halved = excess(left) <= 0.5 * excess(now);
            if !halved {
                undo.restore(p);
                return moved;
            }
        }
        r.buffers.implicit.moved_to(&p.positions);
        resolve_last(r.particles, &r.buffers.substep_start);
        moved = true;
    }
    moved
}
