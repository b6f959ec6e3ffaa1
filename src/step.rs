//! One fixed step of one cloth, as a plain function ([`step_cloth`]), and the
//! small per-cloth components the step reads and writes.

use bevy::math::Vec3;
use bevy::prelude::{Component, Reflect, ReflectComponent};

use crate::connections::{ClothConnections, max_strain};
use crate::integrate::implicit::{Hold, SolveContact};
use crate::integrate::{self, StepBuffers};
use crate::model::Dynamics;
use crate::particles::ClothParticles;
use crate::settings::ClothSettings;

/// External forces on each particle in N, held constant through one fixed
/// step and cleared after it.
///
/// Systems in [`ClothSystems::Forces`](crate::schedule::ClothSystems::Forces)
/// add to it (wind, a grab spring, a game's explosion); an empty vector
/// means no external force and costs nothing.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothForces(pub Vec<Vec3>);

impl ClothForces {
    /// Adds `force` (N) to particle `p`, sizing the buffer for `count`
    /// particles on first use. Out-of-range indices are ignored.
    pub fn add(&mut self, p: usize, force: Vec3, count: usize) {
        if self.0.len() != count {
            self.0.clear();
            self.0.resize(count, Vec3::ZERO);
        }
        if let Some(f) = self.0.get_mut(p) {
            *f += force;
        }
    }
}

/// What the last fixed step of a cloth looked like.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn report(cloths: Query<(Entity, &ClothStats)>) {
///     for (cloth, stats) in &cloths {
///         if stats.max_strain > 0.1 {
///             info!("cloth {cloth} stretched {:.0} %", 100.0 * stats.max_strain);
///         }
///     }
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothStats {
    /// Fixed steps simulated so far.
    pub steps: u64,
    /// Largest stretch `(ℓ − L)/L` of the stretch links (Type 1 for Choi–Ko,
    /// structural and shear for Lander), dimensionless.
    pub max_strain: f32,
    /// Kinetic energy of the free particles in J.
    pub kinetic_energy: f32,
    /// Whether every position and velocity is finite.
    pub finite: bool,
    /// Conjugate-gradient iterations of the last implicit substep (0 for
    /// the explicit integrators).
    pub solver_iterations: u32,
    /// Wall-clock time of the last fixed step's integration, µs (for
    /// display; never asserted on).
    pub step_micros: f32,
    /// Substeps the last step ran with (more than the settings' after the
    /// divergence guard stepped in).
    pub substeps: u32,
    /// Integrator the last step ran with.
    pub integrator: crate::settings::Integrator,
    /// Speed of the fastest free particle, m/s.
    pub max_speed: f32,
    /// Whether the cloth is at rest (see [`ClothAtRest`](crate::events::ClothAtRest)).
    pub resting: bool,
}

impl ClothStats {
    /// Measures `particles` against `connections`.
    pub fn measure(&mut self, particles: &ClothParticles, connections: &ClothConnections) {
        self.measure_with(
            particles,
            max_strain(connections.type1(), &particles.positions),
        );
    }

    /// [`ClothStats::measure`] given the largest strain, measured already.
    pub(crate) fn measure_with(&mut self, particles: &ClothParticles, max_strain: f32) {
        self.max_strain = max_strain;
        self.kinetic_energy = particles.kinetic_energy();
        self.max_speed = particles.max_speed();
        self.finite = particles.is_finite();
    }
}

/// One substep, as a contact hook sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Substep {
    /// Start of the substep as a fraction of the fixed step, in [0, 1).
    pub from: f32,
    /// End of the substep as a fraction of the fixed step, in (0, 1].
    pub to: f32,
    /// Length of the substep in s.
    pub dt: f32,
}

/// Contacts with the world over a step: what the implicit solve should
/// hold, and what is left to resolve after each substep.
///
/// A closure `|substep, start, x, v, w| …` is a hook that only resolves
/// after each substep.
pub trait ContactHook {
    /// After each substep: the substep, positions at its start (m), and
    /// the particles' positions (m), velocities (m/s) and inverse masses
    /// (1/kg) at its end, which it may correct. `held` says which particles
    /// the implicit solve held on a surface this substep (empty when none);
    /// their contacts are resolved already.
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        held: &[Hold],
    );

    /// Before an implicit substep: the contacts its solve is to hold
    /// (positions m, velocities m/s, inverse masses 1/kg at the substep's
    /// start) into `out`. None by default.
    fn predict(
        &mut self,
        _sub: Substep,
        _x: &[Vec3],
        _v: &[Vec3],
        _w: &[f32],
        _out: &mut Vec<SolveContact>,
    ) {
    }
}

impl<F: FnMut(Substep, &[Vec3], &mut [Vec3], &mut [Vec3], &[f32])> ContactHook for F {
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        _held: &[Hold],
    ) {
        self(sub, start, x, v, w)
    }
}

/// The hook of a step without contacts.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoContacts;

impl ContactHook for NoContacts {
    fn resolve(
        &mut self,
        _: Substep,
        _: &[Vec3],
        _: &mut [Vec3],
        _: &mut [Vec3],
        _: &[f32],
        _: &[Hold],
    ) {
    }
}

/// Advances one cloth by `dt` seconds in `settings.substeps` equal substeps.
///
/// `external` holds one force per particle in N, or is empty. `buffers` are
/// resized if the particle count changed (the only allocation). Settings are
/// assumed valid ([`ClothSettings::validate`]); the ECS layer checks them.
/// Returns the substeps run: `settings.substeps`, or more with
/// [`ClothSettings::adaptive`](crate::adaptive::AdaptiveSubsteps).
pub fn step_cloth(
    particles: &mut ClothParticles,
    connections: &ClothConnections,
    settings: &ClothSettings,
    external: &[Vec3],
    buffers: &mut StepBuffers,
    dt: f32,
) -> u32 {
    step_cloth_with(
        particles,
        connections,
        settings,
        external,
        buffers,
        dt,
        None::<&mut NoContacts>,
    )
}

/// [`step_cloth`] with a contact hook called after every substep, so that
/// contacts are resolved at the time scale of the stiff springs rather than
/// once per fixed step (which lets the cloth gain energy against a collider).
pub fn step_cloth_with(
    particles: &mut ClothParticles,
    connections: &ClothConnections,
    settings: &ClothSettings,
    external: &[Vec3],
    buffers: &mut StepBuffers,
    dt: f32,
    mut contacts: Option<&mut impl ContactHook>,
) -> u32 {
    let n = particles.len();
    buffers.resize(n);
    if contacts.is_some() {
        buffers.substep_start.resize(n, Vec3::ZERO);
    }
    let substeps =
        crate::adaptive::substeps_for(settings, connections, particles, dt, &mut buffers.mode_sums);
    let h = dt / substeps as f32;
    let ClothParticles {
        positions,
        velocities,
        inverse_masses,
        ..
    } = particles;
    let dynamics = Dynamics {
        settings,
        connections,
        inverse_masses,
        external,
    };
    // The connections cannot change during the step: compare them once.
    integrate::sync(settings.integrator, &dynamics, n, buffers);
    let implicit = settings.integrator.is_implicit();
    for k in 0..substeps {
        let sub = Substep {
            from: k as f32 / substeps as f32,
            to: (k + 1) as f32 / substeps as f32,
            dt: h,
        };
        buffers.implicit.contacts.list.clear();
        if let Some(hook) = contacts.as_mut() {
            buffers.substep_start.copy_from_slice(positions);
            if implicit {
                hook.predict(
                    sub,
                    positions,
                    velocities,
                    inverse_masses,
                    &mut buffers.implicit.contacts.list,
                );
            }
        }
        integrate::step_synced(
            settings.integrator,
            &dynamics,
            positions,
            velocities,
            h,
            buffers,
        );
        if let Some(hook) = contacts.as_mut() {
            let held = if implicit {
                buffers.implicit.contacts.holds()
            } else {
                &[]
            };
            hook.resolve(
                sub,
                &buffers.substep_start,
                positions,
                velocities,
                inverse_masses,
                held,
            );
        }
    }
    substeps
}
