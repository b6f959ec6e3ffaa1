//! When a cloth is at rest, and when a resting cloth sleeps: the thresholds
//! of [`SleepSettings`] and the calm-step count of `RestTracker`, as plain
//! state tested without an `App`.
//!
//! A cloth is *at rest* once every free or grabbed particle has stayed
//! slower than [`SleepSettings::rest_speed`] for
//! [`SleepSettings::rest_steps`] fixed steps. With
//! [`SleepSettings::enabled`] (the default) it then *sleeps*: the plugin
//! stops stepping it until something could move it (the
//! [`ClothSleep`](crate::plugin::step::ClothSleep) lists what wakes it).

use bevy::reflect::Reflect;

use crate::error::ClothError;

/// A free or grabbed particle slower than this, m/s, counts as resting: the
/// default of [`SleepSettings::rest_speed`].
pub const REST_SPEED: f32 = 0.01;
/// A resting cloth that keeps stepping wakes when a free or grabbed particle
/// moves faster than this, m/s: the default of [`SleepSettings::wake_speed`].
pub const WAKE_SPEED: f32 = 0.02;
/// Fixed steps every free or grabbed particle must stay under
/// [`REST_SPEED`] before the cloth is at rest (half a second at 60 Hz): the
/// default of [`SleepSettings::rest_steps`].
pub const REST_STEPS: u32 = 30;

/// When a cloth is at rest and whether it then sleeps (stops stepping until
/// something could move it). Part of
/// [`SimSettings`](crate::sim::settings::SimSettings), so a cloth's own
/// `ClothSettings` turns sleep off for it alone.
///
/// ```
/// # use bevy_cloth::prelude::*;
/// // A flag that must keep answering the wind's slightest change.
/// let mut settings = SimSettings::default();
/// settings.sleep.enabled = false;
/// assert!(settings.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct SleepSettings {
    /// Whether a cloth at rest sleeps (on by default). Off, it keeps
    /// stepping at full cost, and [`ClothAtRest`](crate::plugin::step::events::ClothAtRest)
    /// and [`ClothWoke`](crate::plugin::step::events::ClothWoke) still report its
    /// rest.
    pub enabled: bool,
    /// Speed under which a free or grabbed particle counts as resting, m/s
    /// (finite, ≥ 0).
    pub rest_speed: f32,
    /// Speed past which a resting cloth that keeps stepping (sleep off)
    /// is awake again, m/s (finite, ≥ `rest_speed`).
    pub wake_speed: f32,
    /// Fixed steps of calm before the cloth is at rest (≥ 1).
    pub rest_steps: u32,
    /// How far beyond the cloth's box (grown by its contact thickness) a
    /// collider that appears, disappears or moves wakes a sleeping cloth, m
    /// (finite, ≥ 0).
    pub margin: f32,
}

impl Default for SleepSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            rest_speed: REST_SPEED,
            wake_speed: WAKE_SPEED,
            rest_steps: REST_STEPS,
            margin: 0.05,
        }
    }
}

impl SleepSettings {
    /// Checks the thresholds: finite, non-negative speeds with
    /// `wake_speed ≥ rest_speed`, a finite non-negative margin and at least
    /// one calm step.
    pub fn validate(&self) -> Result<(), ClothError> {
        let finite = |x: f32| x.is_finite() && x >= 0.0;
        if finite(self.rest_speed)
            && finite(self.wake_speed)
            && self.wake_speed >= self.rest_speed
            && finite(self.margin)
            && self.rest_steps >= 1
        {
            Ok(())
        } else {
            Err(ClothError::InvalidSleep {
                rest_speed: self.rest_speed,
                wake_speed: self.wake_speed,
                rest_steps: self.rest_steps,
                margin: self.margin,
            })
        }
    }
}

/// Rest detection of one cloth: counts calm steps and says when the cloth
/// comes to rest or wakes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct RestTracker {
    calm_steps: u32,
    resting: bool,
}

/// What a step changed about a cloth's rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RestChange {
    /// It has been calm for [`SleepSettings::rest_steps`].
    CameToRest,
    /// It was at rest and moves again.
    Woke,
}

impl RestTracker {
    /// Feeds one fixed step's fastest free or grabbed particle speed (m/s).
    /// A non-finite speed is never rest, and wakes a resting cloth.
    pub fn step(&mut self, max_speed: f32, settings: &SleepSettings) -> Option<RestChange> {
        let calm = max_speed < settings.rest_speed;
        if self.resting {
            if max_speed.is_nan() || max_speed > settings.wake_speed {
                self.wake();
                return Some(RestChange::Woke);
            }
            return None;
        }
        self.calm_steps = if calm { self.calm_steps + 1 } else { 0 };
        if self.calm_steps >= settings.rest_steps {
            self.resting = true;
            return Some(RestChange::CameToRest);
        }
        None
    }

    /// Wakes it, from rest or not: the calm count starts again, so a cloth
    /// woken from sleep steps at least [`SleepSettings::rest_steps`] before
    /// it can sleep again.
    pub fn wake(&mut self) {
        self.resting = false;
        self.calm_steps = 0;
    }

    /// Whether the cloth is at rest.
    pub fn resting(&self) -> bool {
        self.resting
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_needs_calm_steps_and_wakes_past_the_wake_speed() {
        let s = SleepSettings::default();
        let mut t = RestTracker::default();
        for _ in 0..REST_STEPS - 1 {
            assert_eq!(t.step(0.001, &s), None);
        }
        // A fast step resets the count.
        assert_eq!(t.step(0.5, &s), None);
        for _ in 0..REST_STEPS - 1 {
            assert_eq!(t.step(0.005, &s), None);
        }
        assert_eq!(t.step(0.005, &s), Some(RestChange::CameToRest));
        assert!(t.resting());
        // Between the rest and the wake speed it stays at rest.
        assert_eq!(t.step(0.015, &s), None);
        assert_eq!(t.step(0.03, &s), Some(RestChange::Woke));
        assert!(!t.resting());
        assert_eq!(t.step(f32::NAN, &s), None);
    }

    #[test]
    fn a_non_finite_speed_wakes_a_resting_cloth() {
        let s = SleepSettings::default();
        let mut t = RestTracker::default();
        for _ in 0..REST_STEPS {
            t.step(0.0, &s);
        }
        assert!(t.resting());
        assert_eq!(t.step(f32::NAN, &s), Some(RestChange::Woke));
    }

    #[test]
    fn the_thresholds_come_from_the_settings() {
        let s = SleepSettings {
            rest_speed: 0.1,
            wake_speed: 0.2,
            rest_steps: 2,
            ..SleepSettings::default()
        };
        let mut t = RestTracker::default();
        assert_eq!(t.step(0.05, &s), None);
        assert_eq!(t.step(0.05, &s), Some(RestChange::CameToRest));
        assert_eq!(t.step(0.15, &s), None);
        t.wake();
        assert!(!t.resting());
        assert_eq!(t.step(0.05, &s), None);
    }

    #[test]
    fn bad_thresholds_are_an_error() {
        for bad in [
            SleepSettings {
                rest_speed: f32::NAN,
                ..SleepSettings::default()
            },
            SleepSettings {
                rest_speed: -1.0,
                wake_speed: -1.0,
                ..SleepSettings::default()
            },
            SleepSettings {
                wake_speed: 0.001,
                ..SleepSettings::default()
            },
            SleepSettings {
                margin: f32::INFINITY,
                ..SleepSettings::default()
            },
            SleepSettings {
                rest_steps: 0,
                ..SleepSettings::default()
            },
        ] {
            assert!(
                matches!(bad.validate(), Err(ClothError::InvalidSleep { .. })),
                "{bad:?}"
            );
        }
        assert!(SleepSettings::default().validate().is_ok());
    }
}
