//! The thin ECS layer of the step: gather a cloth's components, call
//! [`step_cloth`], write back.

use bevy::log::warn;
use bevy::math::Vec3;
use bevy::prelude::{Entity, Query, Res, Time};
use bevy::time::Fixed;

use crate::cloth::ClothError;
use crate::connections::ClothConnections;
use crate::particles::ClothParticles;
use crate::settings::{ClothDefaults, ClothSettings};
use crate::step::{ClothForces, ClothScratch, ClothStats, step_cloth};

/// Checks what the step indexes so that user edits can never make it panic:
/// equal array lengths, and every link inside the particle range.
pub fn check_cloth(
    particles: &ClothParticles,
    connections: &ClothConnections,
) -> Result<(), ClothError> {
    let n = particles.len();
    if particles.velocities.len() != n
        || particles.inverse_masses.len() != n
        || particles.masses.len() != n
    {
        return Err(ClothError::InconsistentParticles);
    }
    match connections.max_index() {
        Some(index) if index as usize >= n => Err(ClothError::ParticleOutOfRange {
            index,
            count: n as u32,
        }),
        _ => Ok(()),
    }
}

/// [`ClothSystems::Integrate`](crate::schedule::ClothSystems::Integrate):
/// steps every cloth over the fixed timestep (never the frame delta).
///
/// A cloth whose settings or arrays are invalid is skipped, with one warning
/// until it is fixed.
#[expect(
    clippy::type_complexity,
    reason = "one query gathers what the step reads"
)]
pub(crate) fn step_cloths(
    time: Res<Time<Fixed>>,
    defaults: Res<ClothDefaults>,
    mut cloths: Query<(
        Entity,
        &mut ClothParticles,
        &ClothConnections,
        Option<&ClothSettings>,
        &ClothForces,
        &mut ClothScratch,
    )>,
) {
    let dt = time.timestep().as_secs_f32();
    cloths.par_iter_mut().for_each(
        |(entity, mut particles, connections, own, forces, mut scratch)| {
            let settings = own.unwrap_or(&defaults);
            let checked = settings
                .validate()
                .and_then(|()| check_cloth(&particles, connections));
            if let Err(error) = checked {
                if !scratch.warned_invalid {
                    warn!("cloth {entity} is not simulated: {error}");
                    scratch.warned_invalid = true;
                }
                return;
            }
            scratch.warned_invalid = false;
            step_cloth(
                &mut particles,
                connections,
                settings,
                &forces.0,
                &mut scratch.buffers,
                dt,
            );
        },
    );
}

/// [`ClothSystems::Writeback`](crate::schedule::ClothSystems::Writeback):
/// clears the external forces and measures [`ClothStats`].
pub(crate) fn finish_step(
    mut cloths: Query<(
        &ClothParticles,
        &ClothConnections,
        &mut ClothForces,
        &mut ClothStats,
    )>,
) {
    for (particles, connections, mut forces, mut stats) in &mut cloths {
        if forces.0.iter().any(|f| *f != Vec3::ZERO) {
            forces.0.fill(Vec3::ZERO);
        }
        stats.steps += 1;
        if check_cloth(particles, connections).is_ok() {
            stats.measure(particles, connections);
        } else {
            stats.finite = particles.is_finite();
        }
    }
}
