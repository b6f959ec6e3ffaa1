//! Events a game can observe on a cloth entity.
//!
//! Each is an [`EntityEvent`] triggered on the cloth, so an observer on the
//! cloth (or a global one) sees it the fixed step it happens:
//!
//! | event | when |
//! |---|---|
//! | [`ClothGrabbed`] | a grab of [`ClothGrabs`](crate::plugin::interaction::ClothGrabs) first takes hold of its particle |
//! | [`ClothReleased`] | that grab lets go |
//! | [`ClothAtRest`] | no free or grabbed particle has moved faster than [`REST_SPEED`] for [`REST_STEPS`] fixed steps |
//! | [`ClothWoke`] | a resting cloth's fastest free or grabbed particle passes [`WAKE_SPEED`] |
//! | [`ClothDiverged`] | the divergence guard redid a step (also a [`Message`]) |
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

/// A free or grabbed particle slower than this, m/s, counts as resting.
pub const REST_SPEED: f32 = 0.01;
/// A resting cloth wakes when a free or grabbed particle moves faster than
/// this, m/s.
pub const WAKE_SPEED: f32 = 0.02;
/// Fixed steps every free or grabbed particle must stay under [`REST_SPEED`] before
/// the cloth is at rest (half a second at 60 Hz).
pub const REST_STEPS: u32 = 30;

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

/// The cloth came to rest: every free or grabbed particle has stayed slower than
/// [`REST_SPEED`] for [`REST_STEPS`] fixed steps. It keeps being simulated.
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothAtRest {
    /// The cloth.
    pub entity: Entity,
}

/// A resting cloth moves again: a free or grabbed particle passed
/// [`WAKE_SPEED`].
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothWoke {
    /// The cloth.
    pub entity: Entity,
}

/// Rest detection of one cloth: counts calm steps and says when the cloth
/// comes to rest or wakes. Plain state, so it is tested without an `App`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct RestTracker {
    calm_steps: u32,
    resting: bool,
}

/// What a step changed about a cloth's rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RestChange {
    CameToRest,
    Woke,
}

impl RestTracker {
    /// Feeds one fixed step's fastest free or grabbed particle speed (m/s).
    pub(crate) fn step(&mut self, max_speed: f32) -> Option<RestChange> {
        // A non-finite speed is not rest.
        let calm = max_speed < REST_SPEED;
        if self.resting {
            if max_speed.is_nan() || max_speed > WAKE_SPEED {
                self.resting = false;
                self.calm_steps = 0;
                return Some(RestChange::Woke);
            }
            return None;
        }
        self.calm_steps = if calm { self.calm_steps + 1 } else { 0 };
        if self.calm_steps >= REST_STEPS {
            self.resting = true;
            return Some(RestChange::CameToRest);
        }
        None
    }

    /// Whether the cloth is at rest.
    pub(crate) fn resting(&self) -> bool {
        self.resting
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_needs_calm_steps_and_wakes_past_the_wake_speed() {
        let mut t = RestTracker::default();
        for _ in 0..REST_STEPS - 1 {
            assert_eq!(t.step(0.001), None);
        }
        // A fast step resets the count.
        assert_eq!(t.step(0.5), None);
        for _ in 0..REST_STEPS - 1 {
            assert_eq!(t.step(0.005), None);
        }
        assert_eq!(t.step(0.005), Some(RestChange::CameToRest));
        assert!(t.resting());
        // Between the rest and the wake speed it stays at rest.
        assert_eq!(t.step(0.015), None);
        assert_eq!(t.step(0.03), Some(RestChange::Woke));
        assert!(!t.resting());
        assert_eq!(t.step(f32::NAN), None);
    }

    #[test]
    fn a_non_finite_speed_wakes_a_resting_cloth() {
        let mut t = RestTracker::default();
        for _ in 0..REST_STEPS {
            t.step(0.0);
        }
        assert!(t.resting());
        assert_eq!(t.step(f32::NAN), Some(RestChange::Woke));
    }
}
