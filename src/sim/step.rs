//! One fixed step of one cloth, as a plain function ([`step_cloth`]), and
//! the contact hook it calls between substeps.

use bevy::math::Vec3;

use crate::sim::connections::Connections;
use crate::sim::integrate::implicit::{ContactBuffers, Hold, SolveContact};
use crate::sim::integrate::{self, StepBuffers};
use crate::sim::model::Dynamics;
use crate::sim::particles::Particles;
use crate::sim::settings::SimSettings;

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

    /// After an implicit substep, before [`resolve`](Self::resolve): the
    /// contacts its solve held, whose [`impulses`](ContactBuffers::impulses)
    /// say what each gave its particle (N·s), with the particles'
    /// positions (m) and velocities (m/s) at the substep's end. Nothing by
    /// default.
    fn solved(&mut self, _x: &[Vec3], _v: &[Vec3], _contacts: &ContactBuffers) {}

    /// The step's attempt so far was undone and is taken again (the
    /// [`guard`](crate::sim::guard)'s retry): forget what it measured.
    /// Nothing by default.
    fn undo(&mut self) {}
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
/// assumed valid ([`SimSettings::validate`]); the ECS layer checks them.
/// Returns the substeps run: `settings.substeps`, or more with
/// [`SimSettings::adaptive`](crate::sim::adaptive::AdaptiveSubsteps).
pub fn step_cloth(
    particles: &mut Particles,
    connections: &Connections,
    settings: &SimSettings,
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
    particles: &mut Particles,
    connections: &Connections,
    settings: &SimSettings,
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
    let substeps = crate::sim::adaptive::substeps_for(
        settings,
        connections,
        particles,
        dt,
        &mut buffers.mode_sums,
    );
    let h = dt / substeps as f32;
    let Particles {
        positions,
        velocities,
        inverse_masses,
        ..
    } = particles;
    let workers = buffers.workers.clone();
    let dynamics = Dynamics {
        settings,
        connections,
        inverse_masses,
        external,
        workers: &workers,
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
            if implicit && buffers.implicit.contacts.any() {
                hook.solved(positions, velocities, &buffers.implicit.contacts);
            }
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
