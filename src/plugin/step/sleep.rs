//! Sleep: a cloth at rest stops stepping until something could move it
//! ([`ClothSleep`] says when it sleeps and what wakes it).

use bevy::prelude::{
    Component, Entity, EntityCommand, EntityWorldMut, Reflect, ReflectComponent, ReflectDefault,
};

use crate::plugin::step::events::{ClothAtRest, ClothWoke};

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
