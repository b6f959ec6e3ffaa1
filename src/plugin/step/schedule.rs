//! [`ClothSystems`]: the public, chained system sets of one cloth step.
//!
//! Everything runs in [`FixedUpdate`](bevy::app::FixedUpdate), once per fixed
//! step, in this order:
//!
//! 1. [`Prepare`](ClothSystems::Prepare): anchored particles take their
//!    anchor's velocity for this step.
//! 2. [`Crease`](ClothSystems::Crease): crease edits to the connections.
//! 3. [`Forces`](ClothSystems::Forces): external forces are added to
//!    [`ClothForces`](crate::plugin::step::components::ClothForces); order your own force
//!    systems (wind, explosions) here.
//! 4. [`Integrate`](ClothSystems::Integrate): `substeps` integrator steps of
//!    the internal forces plus gravity, damping and the external forces.
//! 5. [`Collide`](ClothSystems::Collide): collision response.
//! 6. [`Writeback`](ClothSystems::Writeback): anchored particles snap exactly
//!    to their anchors, external forces are cleared, [`ClothStats`](crate::plugin::step::components::ClothStats)
//!    are measured. Read the stepped state after this set.
//!
//! All six sets run only while the simulation is not paused ([`ClothPause`])
//! and there is a cloth: a world without one runs none of their systems,
//! yours in them included (but for one step after the last cloth is gone,
//! which clears what it left).
//!
//! The plugin's systems in these sets run on the main thread, which waits
//! for the schedule anyway: a schedule whose systems all run there never
//! wakes a parked pool thread, which on a 2-core x86-64 costs some 45 µs a
//! schedule (a `FixedUpdate` of one empty system takes 0.29 ms a frame
//! against 0.24 ms with none or with one on the main thread). Your systems in the sets still run on the pool,
//! alongside them.
//!
//! The rendered mesh is written later, in `PostUpdate`
//! ([`ClothMeshSystems`](crate::plugin::render::mesh::ClothMeshSystems)).

use bevy::ecs::schedule::SystemSet;
use bevy::ecs::system::NonSendMarker;
use bevy::prelude::{Local, Query, Reflect, ReflectResource, Res, ResMut, Resource, With};

use crate::plugin::step::components::Cloth;

/// The stages of a cloth step in `FixedUpdate`, chained in declaration order.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ClothSystems {
    /// Anchors hand their motion to the pinned particles they carry.
    Prepare,
    /// Creases edit connection rest lengths before forces are computed.
    Crease,
    /// External forces for this step are accumulated; add yours here.
    Forces,
    /// The cloths are integrated over the fixed step.
    Integrate,
    /// Particles are pushed out of colliders.
    Collide,
    /// Pins are made exact, per-step buffers cleared, statistics measured.
    Writeback,
}

/// The parameter that makes a system run on the main thread (see the
/// module docs): the step's own systems have no use for a pool thread, as
/// they run one after another and the step shares its large solves with its
/// own helper thread.
pub(crate) type MainThread = NonSendMarker;

/// Pauses every cloth, or runs a given number of fixed steps while paused.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn keys(keys: Res<ButtonInput<KeyCode>>, mut pause: ResMut<ClothPause>) {
///     if keys.just_pressed(KeyCode::Space) {
///         pause.paused = !pause.paused;
///     }
///     if keys.just_pressed(KeyCode::Period) {
///         pause.steps += 1; // one step while paused
///     }
/// }
/// ```
#[derive(Resource, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct ClothPause {
    /// Whether the simulation is paused.
    pub paused: bool,
    /// Fixed steps still to run while paused (single stepping).
    pub steps: u32,
}

/// Run condition of the [`ClothSystems`] sets: not paused, or a step asked for.
pub fn cloth_running(pause: Option<Res<ClothPause>>) -> bool {
    pause.is_none_or(|p| !p.paused || p.steps > 0)
}

/// Run condition of the [`ClothSystems`] sets: there is a cloth, or there
/// was one at the last step. The step after the last cloth is gone runs
/// once more, so that what the cloths left behind is cleared (the collider
/// scene, the contacts' impulses, the bridges' forces on the bodies they
/// held up); after it nothing runs until a cloth appears.
pub(crate) fn cloths_present(cloths: Query<(), With<Cloth>>, mut had: Local<bool>) -> bool {
    let any = !cloths.is_empty();
    let run = any || *had;
    *had = any;
    run
}

/// Run condition of [`consume_step`]: the simulation is paused.
pub(crate) fn paused(pause: Option<Res<ClothPause>>) -> bool {
    pause.is_some_and(|p| p.paused)
}

/// Uses up one single step at the end of a paused fixed step.
pub(crate) fn consume_step(
    _main: crate::plugin::step::schedule::MainThread,
    pause: Option<ResMut<ClothPause>>,
) {
    if let Some(mut pause) = pause
        && pause.paused
        && pause.steps > 0
    {
        pause.steps -= 1;
    }
}
