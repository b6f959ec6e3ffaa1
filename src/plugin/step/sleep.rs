//! Sleep: a cloth at rest stops stepping until something could move it
//! ([`ClothSleep`] says when it sleeps and what wakes it).

use bevy::prelude::{
    Component, Entity, EntityCommand, EntityWorldMut, Reflect, ReflectComponent, ReflectDefault,
};

use bevy::ecs::change_detection::Tick;
use bevy::math::Vec3;

use crate::plugin::step::events::{ClothAtRest, ClothWoke};
use crate::sim::collision::scene::{ClothContactLayers, ColliderScene, ColliderWatch};
use crate::sim::sleep::SleepSettings;

/// Whether a cloth sleeps: on every cloth, set by the plugin. Read it to
/// skip work on sleeping cloths; wake one with [`WakeCloth`] or
/// [`ClothSleep::wake`].
///
/// A cloth sleeps from the fixed step after [`ClothAtRest`] (with
/// [`SleepSettings::enabled`](crate::sim::sleep::SleepSettings::enabled),
/// the default): it is not stepped, its statistics and step count stand
/// still (its step time reads 0), its mesh is not rewritten, and its
/// anchors, skin and wind are not evaluated. Its [`ClothSleep`] says so.
///
/// It wakes, and is stepped in the same fixed step, when
/// - a collider appears, disappears or moves within its box (grown by its
///   contact thickness and
///   [`SleepSettings::margin`](crate::sim::sleep::SleepSettings::margin));
/// - the wind ([`ClothWind`](crate::plugin::wind::ClothWind)) starts, changes
///   (gusts included) or stops;
/// - a grab takes hold of it, an anchor's target, its skin's skeleton or its
///   [`ClothInertia`](crate::plugin::worn::frame::ClothInertia) frame moves;
/// - anything writes its particles (a pin, picking, [`TeleportCloth`](crate::plugin::worn::frame::TeleportCloth),
///   game code), its connections (creases), its material or settings, the
///   global `ClothSettingsDefaults`, its collision settings or tethers;
/// - a force is written into its [`ClothForces`](crate::ClothForces);
/// - game code queues [`WakeCloth`].
///
/// A woken cloth continues from the state it slept in (positions and
/// velocities as they were), fires [`ClothWoke`], and steps at least
/// `rest_steps` before it can sleep again. A cloth held by a grab, or near
/// a body that feels the cloth (a dynamic body of a physics bridge), does
/// not sleep: the body would lose its support.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// /// Shake every sleeping banner awake when the gong sounds.
/// fn gong(mut commands: Commands, banners: Query<(Entity, &ClothSleep)>) {
///     for (banner, sleep) in &banners {
///         if sleep.is_asleep() {
///             commands.entity(banner).queue(WakeCloth);
///         }
///     }
/// }
/// ```
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component, Default)]
pub struct ClothSleep {
    asleep: bool,
    wake: bool,
}

impl ClothSleep {
    /// Whether the cloth sleeps (is not stepped).
    pub fn is_asleep(&self) -> bool {
        self.asleep
    }

    /// Asks for the cloth to be awake at the next fixed step, and to step at
    /// least `rest_steps` before it sleeps again.
    pub fn wake(&mut self) {
        self.wake = true;
    }

    /// Whether a wake was asked for since the last step.
    pub(crate) fn wake_requested(&self) -> bool {
        self.wake
    }

    /// Takes the wake request.
    pub(crate) fn take_wake(&mut self) -> bool {
        std::mem::take(&mut self.wake)
    }

    /// Sets whether it sleeps.
    pub(crate) fn set_asleep(&mut self, asleep: bool) {
        self.asleep = asleep;
    }
}

/// Wakes a cloth, as a command: it is stepped at the next fixed step and
/// steps at least `rest_steps` before it sleeps again. Harmless on an awake
/// cloth or an entity that is not one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WakeCloth;

impl EntityCommand for WakeCloth {
    type Out = ();

    fn apply(self, mut entity: EntityWorldMut) {
        if let Some(mut sleep) = entity.get_mut::<ClothSleep>() {
            sleep.wake();
        }
    }
}

/// A change of sleep to report at the end of the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Change {
    /// [`ClothAtRest`].
    Rested,
    /// [`ClothWoke`].
    Woke,
}

impl Change {
    /// Triggers its event on `entity`.
    pub(crate) fn trigger(self, entity: Entity, commands: &mut bevy::prelude::Commands) {
        match self {
            Change::Rested => commands.trigger(ClothAtRest { entity }),
            Change::Woke => commands.trigger(ClothWoke { entity }),
        }
    }
}

/// What a sleeping cloth remembers of the moment it fell asleep, to see
/// what has changed since (not reflected).
#[derive(Clone, Debug, Default)]
pub(crate) struct SleepWatch {
    /// The particles' change tick when it fell asleep.
    pub(crate) tick: Option<Tick>,
    /// The colliders around it then.
    colliders: ColliderWatch,
    /// The thresholds of its last step.
    pub(crate) settings: SleepSettings,
    /// An event to trigger at the end of the step.
    pub(crate) event: Option<Change>,
}

impl SleepWatch {
    /// Remembers the colliders of `scene` that meet `layers` around a
    /// cloth falling asleep within `bounds` (its box grown by thickness and
    /// margin, m), and its particles' change `tick`. `false` if it must
    /// stay awake: a body that feels the cloth is there.
    pub(crate) fn fall_asleep(
        &mut self,
        scene: &ColliderScene,
        bounds: (Vec3, Vec3),
        layers: ClothContactLayers,
        tick: Tick,
    ) -> bool {
        let asleep = self.colliders.fall_asleep(scene, bounds, layers);
        self.tick = asleep.then_some(tick);
        asleep
    }

    /// Whether the colliders around the sleeping cloth have changed (one
    /// appeared, left, or moved by more than `tolerance` m or rad).
    pub(crate) fn scene_changed(
        &mut self,
        scene: &ColliderScene,
        layers: ClothContactLayers,
        tolerance: f32,
    ) -> bool {
        self.colliders.scene_changed(scene, layers, tolerance)
    }
}
