//! [`ClothWind`]: the air around every cloth, as a resource, and the system
//! that turns it into forces per face ([`crate::sim::wind`] holds the
//! aerodynamics). With no resource, or zero wind, nothing runs.

use bevy::math::Vec3;
use bevy::prelude::{
    Deref, DerefMut, DetectChanges, Local, Query, Reflect, ReflectDefault, ReflectResource, Res,
    Resource, Time,
};
use bevy::time::Fixed;

use crate::plugin::lod::ClothDetail;
use crate::plugin::step::components::{Cloth, ClothForces, ClothParticles};
use crate::plugin::step::sleep::ClothSleep;
use crate::sim::wind::{Wind, step_wind_forces};

/// The air around every cloth: a [`Wind`], which it dereferences to.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// /// A steady 4 m/s breeze along +z.
/// fn breeze(mut commands: Commands) {
///     commands.insert_resource(ClothWind(Wind { velocity: Vec3::Z * 4.0, ..default() }));
/// }
/// ```
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Reflect, Deref, DerefMut)]
#[reflect(Resource, Default)]
pub struct ClothWind(pub Wind);

/// Whether there is wind to apply (a run condition).
pub(crate) fn wind_blows(wind: Option<Res<ClothWind>>) -> bool {
    wind.is_some_and(|w| w.blows())
}

/// [`ClothSystems::Forces`](crate::ClothSystems::Forces): wind on every cloth.
pub(crate) fn apply_wind(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    wind: Res<ClothWind>,
    mut scratch: Local<(Vec<Vec3>, Vec<f32>)>,
    mut last: Local<Option<Vec3>>,
    mut cloths: Query<(
        &Cloth,
        &ClothParticles,
        &mut ClothForces,
        &ClothSleep,
        Option<&ClothDetail>,
    )>,
) {
    let air = wind.at(time.elapsed_secs());
    let dt = time.timestep().as_secs_f32();
    let (wind_f, rates) = &mut *scratch;
    // A wind that starts, changes or gusts reaches sleeping cloths too, and
    // its force wakes them; a steady one leaves them asleep.
    let changed = wind.is_changed() || last.replace(air) != Some(air);
    for (cloth, particles, mut forces, sleep, detail) in &mut cloths {
        // A reduced cloth feels the wind on the fixed steps it takes, over
        // the fixed steps it combines (their forces act as their mean).
        let steps = detail.map_or(1, ClothDetail::steps_now);
        if (sleep.is_asleep() && !changed) || steps == 0 {
            continue;
        }
        let n = particles.len();
        if cloth.len() != n || particles.inverse_masses.len() != n {
            continue;
        }
        if forces.0.len() != n {
            forces.0.clear();
            forces.0.resize(n, Vec3::ZERO);
        }
        wind_f.resize(n, Vec3::ZERO);
        let state = (
            &particles.positions[..],
            &particles.velocities[..],
            &particles.inverse_masses[..],
        );
        let span = dt * steps as f32;
        step_wind_forces(cloth, &wind, air, state, span, wind_f, rates);
        let times = steps as f32;
        for (f, w) in forces.0.iter_mut().zip(wind_f.iter()) {
            *f += *w * times;
        }
    }
}
