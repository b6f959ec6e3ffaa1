//! What the guard remembers of a cloth between steps ([`GuardState`]), and
//! how a boost relaxes.
//!
//! What it may import: the settings and the refinement's undo buffers.

use bevy::math::Vec3;

use crate::sim::integrate::refine::Undo;
use crate::sim::settings::Integrator;

/// The last good state of a cloth and what the guard has changed.
#[derive(Clone, Debug, Default)]
pub struct GuardState {
    /// Positions (m) and velocities (m/s) at the start of the last step.
    pub(crate) good_x: Vec<Vec3>,
    pub(crate) good_v: Vec<Vec3>,
    /// The Type 1 strain the last clean step left (dimensionless).
    pub(super) last_strain: Option<f32>,
    /// Steps the cloth has stayed above the bound without relaxing, with
    /// colliders near (see [`SNAGGED_STEPS`]).
    pub(super) snagged: u32,
    /// The state before an extra Newton iteration or the strain limit's
    /// sweeps, to undo them.
    pub(super) undo: Undo,
    /// Substeps and integrator the guard moved the cloth to.
    pub(crate) boost: Option<(u32, Integrator)>,
    /// Clean steps since the boost last changed.
    pub(crate) clean: u32,
    /// Fixed steps that tripped the guard so far (saturating).
    pub(crate) trips: u32,
}

/// Fixed steps a cloth may stay strained above the guard's bound without
/// relaxing while it has colliders near, before a step without contacts
/// lets it off.
pub(crate) const SNAGGED_STEPS: u32 = 10;

/// The Type 1 strain (dimensionless) past which an implicit step that
/// raised its cloth's strain [`SPIKE_GROWTH`] times over is taken again in
/// twice the substeps.
pub(crate) const SPIKE_STRAIN: f32 = 0.15;

/// How many times the strain the last step left a spike must reach.
pub(crate) const SPIKE_GROWTH: f32 = 2.0;

/// Substeps a spike's retries go up to at most.
pub(crate) const SPIKE_SUBSTEPS: u32 = 8;

/// Smallest relative fall of the worst strain in a step that counts as
/// relaxing (dimensionless): a snagged cloth's trembles less than this.
pub(super) const SNAG_CHANGE: f32 = 1e-3;

/// Clean fixed steps after which an adaptive cloth's boost halves.
pub(crate) const RELAX_AFTER: u32 = 10;

/// Clean fixed steps after which the boost of a cloth without adaptive
/// substeps first halves (1 s at 60 Hz); each later trip doubles it.
pub(crate) const RELAX_AFTER_FIXED: u32 = 60;

/// The most doublings of [`RELAX_AFTER_FIXED`] (about 17 min at 60 Hz).
pub(super) const MAX_BACKOFF: u32 = 10;

impl GuardState {
    /// One clean fixed step. A boost is only needed through the transient
    /// that tripped it: after enough clean steps (10 with
    /// `adaptive` substeps, else 60 doubled for every trip after the
    /// first) the boosted substeps halve; the boost ends
    /// when they reach the configured substeps `floor` or the configured
    /// `integrator` is back.
    pub fn relax(&mut self, integrator: Integrator, floor: u32, adaptive: bool) {
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
