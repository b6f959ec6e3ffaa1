//! Events a game can observe on a cloth entity.
//!
//! Each is an [`EntityEvent`] triggered on the cloth, so an observer on the
//! cloth (or a global one) sees it the fixed step it happens:
//!
//! | event | when |
//! |---|---|
//! | [`ClothGrabbed`] | a grab of [`ClothGrabs`](crate::plugin::interaction::grab::ClothGrabs) first takes hold of its particle |
//! | [`ClothReleased`] | that grab lets go |
//! | [`ClothAtRest`] | no free or grabbed particle has moved faster than [`REST_SPEED`] for [`REST_STEPS`] fixed steps (the cloth then sleeps) |
//! | [`ClothWoke`] | a sleeping cloth is woken, or a resting one's fastest free or grabbed particle passes [`WAKE_SPEED`] |
//! | [`ClothDiverged`] | the divergence guard redid a step (also a [`Message`]) |
//! | [`ClothTorn`](crate::plugin::tearing::tear::ClothTorn) | links broke ([`ClothTearing`](crate::plugin::tearing::tear::ClothTearing)) or a [`ClothCut`](crate::plugin::tearing::tear::ClothCut) crossed the cloth |
//!
//! ```
//! # use bevy::prelude::*;
//! # use bevy_cloth::prelude::*;
//! fn spawn(mut commands: Commands) {
//!     let cloth = ClothBuilder::new(16, 16).build().expect("a valid cloth");
//!     commands
//!         .spawn(cloth)
//!         .observe(|rest: On<ClothAtRest>| info!("cloth {} settled", rest.entity))
//!         .observe(|grab: On<ClothGrabbed>| info!("particle {} held", grab.particle));
//! }
//! ```

use bevy::prelude::{Entity, EntityEvent, Message, Reflect};

use crate::sim::guard::Divergence;
use crate::sim::settings::Integrator;
#[cfg(doc)]
use crate::sim::sleep::{REST_SPEED, REST_STEPS, WAKE_SPEED};

/// A grab took hold of a particle (the fixed step it first acts).
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothGrabbed {
    /// The cloth.
    pub entity: Entity,
    /// The held particle's index.
    pub particle: u32,
}

/// A grab let go of its particle (the fixed step after the release).
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothReleased {
    /// The cloth.
    pub entity: Entity,
    /// The released particle's index.
    pub particle: u32,
}

/// The cloth came to rest: every free or grabbed particle has stayed slower
/// than [`SleepSettings::rest_speed`](crate::sim::sleep::SleepSettings::rest_speed)
/// ([`REST_SPEED`] by default) for its `rest_steps` fixed steps. With sleep
/// on (the default) it sleeps from the next step
/// ([`ClothSleep`](crate::plugin::step::sleep::ClothSleep)); with sleep off it
/// keeps being simulated.
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothAtRest {
    /// The cloth.
    pub entity: Entity,
}

/// A resting cloth moves again: a sleeping cloth was woken (the
/// [`ClothSleep`](crate::plugin::step::ClothSleep) lists what wakes it), or, with sleep
/// off, a free or grabbed particle passed
/// [`SleepSettings::wake_speed`](crate::sim::sleep::SleepSettings::wake_speed)
/// ([`WAKE_SPEED`] by default).
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothWoke {
    /// The cloth.
    pub entity: Entity,
}

/// Sent when a cloth's step blew up and was redone: written as a
/// [`Message`] (read it with `MessageReader<ClothDiverged>`) and triggered
/// on the cloth as an [`EntityEvent`] (observe it with
/// `On<ClothDiverged>`).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn report(mut diverged: MessageReader<ClothDiverged>) {
///     for d in diverged.read() {
///         warn!("cloth {} diverged: {:?}", d.cloth, d.reason);
///     }
/// }
/// ```
#[derive(Message, EntityEvent, Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ClothDiverged {
    /// The cloth.
    #[event_target]
    pub cloth: Entity,
    /// What tripped (on the first attempt).
    pub reason: Divergence,
    /// The substeps it runs with now.
    pub substeps: u32,
    /// The integrator it runs with now.
    pub integrator: Integrator,
    /// Whether a retry succeeded (otherwise the cloth was kept with its
    /// speeds clamped, or held at the start of the step for this one step).
    pub recovered: bool,
}
