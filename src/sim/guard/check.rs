//! The guard's check of a stepped cloth: non-finite values, strain and
//! speed against the bounds ([`check_measured`]), and how far a step may take them
//! before it counts as a divergence ([`Limits`]).
//!
//! What it may import: the links, the particles, the settings and the
//! helper thread.

use bevy::math::Vec3;

use super::Divergence;
use crate::sim::connections::{Connections, max_strain};
use crate::sim::particles::Particles;
use crate::sim::settings::GuardSettings;
use crate::sim::team::{self, SPLIT_PARTICLES};

/// Checks `particles` against `guard`'s bounds (`None`: all is well), as if
/// the cloth were at rest before (no allowance for growth), and gives the
/// largest Type 1 strain (as [`max_strain`]) if it got as far as measuring
/// it: the state is finite and slow enough. With
/// `helper`, a cloth of [`SPLIT_PARTICLES`] or more has its shear links
/// measured on the helper thread meanwhile, to the same result (the
/// largest of two largest).
pub(crate) fn check_measured(
    particles: &Particles,
    connections: &Connections,
    guard: &GuardSettings,
    helper: bool,
) -> (Option<Divergence>, Option<f32>) {
    let x = &particles.positions;
    let here = || {
        let finite = particles.is_finite();
        (finite, fastest_free(particles))
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

/// The largest speed (m/s) of a free particle.
fn fastest_free(particles: &Particles) -> f32 {
    fastest(&particles.velocities, &particles.inverse_masses, false)
}

/// The largest speed (m/s) among the velocities `v` of the pinned particles
/// (`pinned`: inverse mass `w` 0; a grab or an anchor carrying them) or of
/// the free ones.
pub(super) fn fastest(v: &[Vec3], w: &[f32], pinned: bool) -> f32 {
    v.iter()
        .zip(w)
        .filter(|(_, w)| (**w == 0.0) == pinned)
        .map(|(v, _)| v.length_squared())
        .fold(0.0f32, f32::max)
        .sqrt()
}

/// How far strain and speed may go in one step before the guard calls it a
/// divergence: beyond the bound, beyond 1.5 times what the step started
/// from, and beyond what the pinned particles' prescribed motion can cause
/// in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Limits {
    /// Largest Type 1 strain (dimensionless).
    pub strain: f32,
    /// Largest free particle speed (m/s).
    pub speed: f32,
}

impl Limits {
    /// The limits of a step of `dt` s that started at positions `x` (m) and
    /// velocities `v` (m/s), with inverse masses `w` (1/kg), under `guard`:
    /// a pinned particle moving at speed `u` moves `u·dt` in the step and
    /// can stretch a link of rest length `L` by `u·dt/L` more, and drag its
    /// free neighbours up to about twice its speed.
    pub fn new(
        (x, v, w): (&[Vec3], &[Vec3], &[f32]),
        connections: &Connections,
        guard: &GuardSettings,
        dt: f32,
    ) -> Self {
        let start_strain = max_strain(connections.type1(), x);
        let start_speed = fastest(v, w, false);
        let pinned_speed = fastest(v, w, true);
        let reach = pinned_reach(pinned_speed, connections, dt);
        let grown = |start: f32, bound: f32| {
            if start.is_finite() {
                bound.max(1.5 * start)
            } else {
                bound
            }
        };
        Self {
            strain: grown(start_strain, guard.max_strain) + reach,
            speed: grown(start_speed, guard.max_speed).max(2.0 * pinned_speed),
        }
    }

    /// Whether `reason` (from [`check`]) is a divergence under these limits.
    pub fn exceeded(&self, reason: Divergence) -> bool {
        match reason {
            Divergence::NonFinite | Divergence::NonFiniteInput => true,
            Divergence::Strain(s) => s > self.strain,
            Divergence::Speed(v) => v > self.speed,
        }
    }
}

/// The strain pinned particles moving at up to `pinned_speed` (m/s) can
/// add to a link in a step of `dt` s: `u·dt/L` for the shortest rest
/// length `L` (dimensionless).
pub(super) fn pinned_reach(pinned_speed: f32, connections: &Connections, dt: f32) -> f32 {
    if pinned_speed > 0.0 {
        let shortest = connections
            .type1()
            .map(|l| l.rest_length)
            .fold(f32::INFINITY, f32::min);
        pinned_speed * dt / shortest.max(1e-6)
    } else {
        0.0
    }
}
