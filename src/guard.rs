//! The divergence guard: a cloth whose step blows up is never lost.
//!
//! After every fixed step a cheap check looks for non-finite values, a
//! Type 1 strain above [`GuardSettings::max_strain`] or a particle faster
//! than [`GuardSettings::max_speed`]. When one trips, the step is undone
//! (the cloth goes back to its state before it), the substeps are doubled,
//! or the cloth switches to the fallback integrator, and the step is run
//! again, up to [`GuardSettings::retries`] times and at most
//! [`GuardSettings::max_boost`] times the configured substeps. The stronger
//! setting stays in force for that cloth for a while (see below and
//! [`ClothStats`](crate::ClothStats)), a
//! [`ClothDiverged`] message says what happened, and a warning is logged
//! once per cloth. If every retry trips on a finite state (violent but not
//! diverging: the recoil of an over-stretched cloth), the last attempt is
//! kept with every speed clamped to the bound; if the last attempt was
//! non-finite, the free particles go back to their last good positions at
//! rest and pinned ones keep their prescribed motion. Restoring the full
//! state would trip the same way next step and freeze the cloth. The cloth
//! is never lost and the app never panics.
//!
//! A boost is for the transient that tripped it (an impact, a violent
//! grab), so it does not last. With
//! [`AdaptiveSubsteps`](crate::adaptive::AdaptiveSubsteps) on, the estimate
//! follows the cloth's state and the boost halves every [`RELAX_AFTER`]
//! clean steps until the estimate alone decides again. Without it, the
//! configured substeps may simply be too few, so the guard probes: it
//! halves the boost after [`RELAX_AFTER_FIXED`] clean steps, and every
//! further trip doubles that wait (up to 2¹⁰ times), so a cloth that keeps
//! tripping settles on its boost and pays a redone step ever more rarely.

use bevy::math::Vec3;
use bevy::prelude::{Entity, Message, Reflect};

use crate::connections::{ClothConnections, max_strain};
use crate::particles::ClothParticles;
use crate::settings::Integrator;
use crate::team::{self, SPLIT_PARTICLES};

/// What the guard does when a step blows up.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum Fallback {
    /// Double the substeps (up to the settings' limit).
    MoreSubsteps,
    /// Switch to this integrator (then double the substeps if it also trips).
    Integrator(Integrator),
}

/// Bounds of the divergence guard.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct GuardSettings {
    /// Whether the guard checks at all.
    pub enabled: bool,
    /// Largest Type 1 strain `(ℓ − L)/L` allowed (dimensionless; 3 = 300 %,
    /// beyond any real cloth but well short of a blow-up).
    pub max_strain: f32,
    /// Largest particle speed allowed, m/s.
    pub max_speed: f32,
    /// Retries per fixed step.
    pub retries: u32,
    /// The guard never runs more than this many times the configured
    /// substeps, so a trip more substeps cannot cure (a kinematic grab
    /// stretching the cloth past the bound) cannot make the cost run away.
    pub max_boost: u32,
    /// What a retry changes.
    pub fallback: Fallback,
}

impl Default for GuardSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            max_strain: 3.0,
            max_speed: 200.0,
            retries: 3,
            max_boost: 16,
            fallback: Fallback::MoreSubsteps,
        }
    }
}

/// Why the guard tripped.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum Divergence {
    /// A position or velocity was NaN or infinite.
    NonFinite,
    /// A Type 1 strain (dimensionless) above the bound.
    Strain(f32),
    /// A speed (m/s) above the bound.
    Speed(f32),
}

/// Sent when a cloth's step blew up and was redone.
#[derive(Message, Clone, Debug, PartialEq)]
pub struct ClothDiverged {
    /// The cloth.
    pub cloth: Entity,
    /// What tripped (on the first attempt).
    pub reason: Divergence,
    /// The substeps it runs with now.
    pub substeps: u32,
    /// The integrator it runs with now.
    pub integrator: Integrator,
    /// Whether a retry succeeded (otherwise the cloth stayed at its last
    /// good state for this step).
    pub recovered: bool,
}

/// Checks `particles` against `guard`'s bounds (`None`: all is well).
pub fn check(
    particles: &ClothParticles,
    connections: &ClothConnections,
    guard: &GuardSettings,
) -> Option<Divergence> {
    check_measured(particles, connections, guard, false).0
}

/// [`check`], and the largest Type 1 strain (as [`max_strain`]) if it got
/// as far as measuring it: the state is finite and slow enough. With
/// `helper`, a cloth of [`SPLIT_PARTICLES`] or more has its shear links
/// measured on the helper thread meanwhile, to the same result (the
/// largest of two largest).
pub(crate) fn check_measured(
    particles: &ClothParticles,
    connections: &ClothConnections,
    guard: &GuardSettings,
    helper: bool,
) -> (Option<Divergence>, Option<f32>) {
    let x = &particles.positions;
    let here = || {
        let finite = particles.is_finite();
        let fastest = particles
            .velocities
            .iter()
            .map(|v| v.length_squared())
            .fold(0.0f32, f32::max)
            .sqrt();
        (finite, fastest)
    };
    let ((finite, fastest), strain) = if helper && particles.len() >= SPLIT_PARTICLES {
        let ((state, structural), shear) = team::both(
            || (here(), max_strain(&connections.structural, x)),
            || max_strain(&connections.shear, x),
        );
        let strain = if structural.is_nan() || shear.is_nan() {
            f32::NAN
        } else {
            structural.max(shear)
        };
        (state, Some(strain))
    } else {
        (here(), None)
    };
    if !finite {
        return (Some(Divergence::NonFinite), None);
    }
    if fastest > guard.max_speed {
        return (Some(Divergence::Speed(fastest)), None);
    }
    let strain = strain.unwrap_or_else(|| max_strain(connections.type1(), x));
    if !strain.is_finite() {
        return (Some(Divergence::NonFinite), None);
    }
    let tripped = (strain > guard.max_strain).then_some(Divergence::Strain(strain));
    (tripped, Some(strain))
}

/// Whether a trip from [`check`] is a divergence: always for non-finite
/// values and for a step that started within the bounds. A step that
/// started beyond a bound (a kinematic grab can stretch a cloth past it, and
/// its recoil is fast) trips only if the strain or speed grew past 1.5
/// times its start, so the cloth may stay there or relax.
pub fn grew(
    reason: Divergence,
    state: &GuardState,
    connections: &ClothConnections,
    guard: &GuardSettings,
) -> bool {
    let (value, start, bound) = match reason {
        Divergence::NonFinite => return true,
        Divergence::Strain(s) => {
            let start = max_strain(connections.type1(), &state.good_x);
            (s, start, guard.max_strain)
        }
        Divergence::Speed(v) => {
            let start = state
                .good_v
                .iter()
                .map(|v| v.length())
                .fold(0.0f32, f32::max);
            (v, start, guard.max_speed)
        }
    };
    start <= bound || value > 1.5 * start
}

/// The last good state of a cloth and what the guard has changed.
#[derive(Clone, Debug, Default)]
pub struct GuardState {
    pub(crate) good_x: Vec<Vec3>,
    pub(crate) good_v: Vec<Vec3>,
    /// Substeps and integrator the guard moved the cloth to.
    pub(crate) boost: Option<(u32, Integrator)>,
    /// A divergence to report at the end of the step.
    pub(crate) pending: Option<(Divergence, u32, Integrator, bool)>,
    pub(crate) warned: bool,
    /// Clean steps since the boost last changed.
    pub(crate) clean: u32,
    /// Fixed steps that tripped the guard so far (saturating).
    pub(crate) trips: u32,
}

/// Clean fixed steps after which an adaptive cloth's boost halves.
pub const RELAX_AFTER: u32 = 10;

/// Clean fixed steps after which the boost of a cloth without adaptive
/// substeps first halves (1 s at 60 Hz); each later trip doubles it.
pub const RELAX_AFTER_FIXED: u32 = 60;

/// The most doublings of [`RELAX_AFTER_FIXED`] (about 17 min at 60 Hz).
const MAX_BACKOFF: u32 = 10;

impl GuardState {
    /// One clean fixed step. A boost is only needed through the transient
    /// that tripped it: after enough clean steps ([`RELAX_AFTER`] with
    /// `adaptive` substeps, else [`RELAX_AFTER_FIXED`] doubled for every
    /// trip after the first) the boosted substeps halve; the boost ends
    /// when they reach the configured substeps `floor` or the configured
    /// `integrator` is back.
    pub(crate) fn relax(&mut self, integrator: Integrator, floor: u32, adaptive: bool) {
        let Some((substeps, boosted)) = self.boost else {
            return;
        };
        self.clean += 1;
        let wait = if adaptive {
            RELAX_AFTER
        } else {
            RELAX_AFTER_FIXED << self.trips.saturating_sub(1).min(MAX_BACKOFF)
        };
        if self.clean < wait {
            return;
        }
        self.clean = 0;
        self.boost = if boosted != integrator {
            // A fallback integrator goes back to the configured one.
            None
        } else {
            (substeps / 2 > floor).then_some((substeps / 2, boosted))
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::connections::Link;

    #[test]
    fn a_trip_counts_unless_the_step_started_beyond_the_bound_and_did_not_grow() {
        let mut connections = ClothConnections::default();
        connections.structural.push(Link {
            a: 0,
            b: 1,
            rest_length: 1.0,
        });
        let guard = GuardSettings::default();
        let state = |len: f32, speed: f32| GuardState {
            good_x: vec![Vec3::ZERO, Vec3::X * len],
            good_v: vec![Vec3::ZERO, Vec3::Y * speed],
            ..GuardState::default()
        };
        let grew = |r, s: &GuardState| grew(r, s, &connections, &guard);
        // Started within the bounds (strain 10 %, 1 m/s): every trip counts.
        let calm = state(1.1, 1.0);
        assert!(grew(Divergence::Strain(3.1), &calm));
        assert!(grew(Divergence::Speed(201.0), &calm));
        assert!(grew(Divergence::NonFinite, &calm));
        // Started over-stretched (strain 4) and fast (300 m/s): staying or
        // relaxing is not a divergence, growing 1.5× is.
        let wild = state(5.0, 300.0);
        assert!(!grew(Divergence::Strain(4.0), &wild));
        assert!(grew(Divergence::Strain(6.5), &wild));
        assert!(!grew(Divergence::Speed(350.0), &wild));
        assert!(grew(Divergence::Speed(460.0), &wild));
        assert!(grew(Divergence::NonFinite, &wild));
    }

    #[test]
    fn an_adaptive_boost_halves_every_few_clean_steps_down_to_the_floor() {
        let se = Integrator::SymplecticEuler;
        let mut state = GuardState {
            boost: Some((64, se)),
            ..GuardState::default()
        };
        let mut seen = Vec::new();
        for _ in 0..5 * RELAX_AFTER {
            state.relax(se, 10, true);
            seen.push(state.boost.map(|(s, _)| s));
        }
        let at = |k: u32| seen[(k * RELAX_AFTER - 1) as usize];
        assert_eq!(seen[0], Some(64));
        assert_eq!([at(1), at(2), at(3)], [Some(32), Some(16), None]);
        // A fallback integrator ends at once after the clean steps.
        state.boost = Some((40, Integrator::BackwardEuler));
        for _ in 0..RELAX_AFTER {
            state.relax(se, 10, true);
        }
        assert_eq!(state.boost, None);
    }

    #[test]
    fn a_fixed_boost_relaxes_later_after_every_trip() {
        let be = Integrator::BackwardEuler;
        // Clean steps until a boost of 4 substeps over a floor of 1 halves.
        let wait = |trips: u32| {
            let mut state = GuardState {
                boost: Some((4, be)),
                trips,
                ..GuardState::default()
            };
            (1..)
                .find(|_| {
                    state.relax(be, 1, false);
                    state.boost != Some((4, be))
                })
                .unwrap()
        };
        assert_eq!(wait(1), RELAX_AFTER_FIXED);
        assert_eq!(wait(2), 2 * RELAX_AFTER_FIXED);
        assert_eq!(wait(4), 8 * RELAX_AFTER_FIXED);
        assert_eq!(wait(400), RELAX_AFTER_FIXED << MAX_BACKOFF);
    }
}
