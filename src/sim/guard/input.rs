//! What [`step_guarded`](super::step_guarded) is given ([`StepInput`]), and
//! its repair: non-finite external forces ignored, non-finite particles put
//! back.
//!
//! What it may import: the particles, the links, the settings, the step's
//! contact hook and the guard's types.

use bevy::math::Vec3;

use super::{Divergence, GuardState};
use crate::sim::connections::Connections;
use crate::sim::integrate::StepBuffers;
use crate::sim::particles::Particles;
use crate::sim::settings::SimSettings;
use crate::sim::step::{ContactHook, NoContacts};

/// One fixed step of one cloth, as [`step_guarded`](super::step_guarded) takes it: the cloth's
/// state, its links and settings, the step length, and optionally external
/// forces, a contact hook and the helper thread. Made by [`StepInput::new`]
/// and the `with_…` methods, so that a new option does not break callers.
#[non_exhaustive]
pub struct StepInput<'a, H: ContactHook = NoContacts> {
    /// Positions (m), velocities (m/s) and inverse masses (1/kg).
    pub particles: &'a mut Particles,
    /// The cloth's links.
    pub connections: &'a Connections,
    /// The step's settings.
    pub settings: &'a SimSettings,
    /// External force per particle (N), or empty for none.
    pub external: &'a [Vec3],
    /// The integrators' scratch, kept between steps.
    pub buffers: &'a mut StepBuffers,
    /// The guard's memory, kept between steps.
    pub state: &'a mut GuardState,
    /// The step's length, s.
    pub dt: f32,
    /// Resolves contacts after every substep (and inside the implicit
    /// solve), if any.
    pub contacts: Option<&'a mut H>,
    /// Whether a large cloth may measure its strain on the helper thread.
    pub helper_thread: bool,
}

impl<'a> StepInput<'a, NoContacts> {
    /// A step of `dt` s of the cloth `particles` with `connections` under
    /// `settings`, keeping its scratch in `buffers` and the guard's memory
    /// in `state`: no external force, no contacts, no helper thread.
    pub fn new(
        particles: &'a mut Particles,
        connections: &'a Connections,
        settings: &'a SimSettings,
        buffers: &'a mut StepBuffers,
        state: &'a mut GuardState,
        dt: f32,
    ) -> Self {
        Self {
            particles,
            connections,
            settings,
            external: &[],
            buffers,
            state,
            dt,
            contacts: None,
            helper_thread: false,
        }
    }
}

impl<'a, H: ContactHook> StepInput<'a, H> {
    /// External forces, one per particle (N).
    pub fn with_external(mut self, forces: &'a [Vec3]) -> Self {
        self.external = forces;
        self
    }

    /// Contacts resolved by `hook` (none when `None`).
    pub fn with_contacts<C: ContactHook>(self, hook: Option<&'a mut C>) -> StepInput<'a, C> {
        StepInput {
            particles: self.particles,
            connections: self.connections,
            settings: self.settings,
            external: self.external,
            buffers: self.buffers,
            state: self.state,
            dt: self.dt,
            contacts: hook,
            helper_thread: self.helper_thread,
        }
    }

    /// Lets a large cloth measure its strain on the helper thread.
    pub fn with_helper_thread(mut self, on: bool) -> Self {
        self.helper_thread = on;
        self
    }
}

/// `external` (N) if every force is finite; else a copy in `cleaned` with
/// the non-finite ones zeroed, and the input divergence to report.
pub(super) fn finite_external<'a>(
    external: &'a [Vec3],
    cleaned: &'a mut Vec<Vec3>,
) -> (&'a [Vec3], Option<Divergence>) {
    if external.iter().all(|f| f.is_finite()) {
        return (external, None);
    }
    // A bug in game code, not a step to make fast: a copy will do.
    cleaned.extend(
        external
            .iter()
            .map(|f| if f.is_finite() { *f } else { Vec3::ZERO }),
    );
    (cleaned, Some(Divergence::NonFiniteInput))
}

/// Puts every particle whose position or velocity is not finite back at
/// its `good` position (the start of the last step) at rest, or at the
/// mean of the finite particles when there is no such position.
pub(super) fn repair(particles: &mut Particles, good: &[Vec3]) {
    let finite: Vec<Vec3> = particles
        .positions
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    let centre = if finite.is_empty() {
        Vec3::ZERO
    } else {
        finite.iter().sum::<Vec3>() / finite.len() as f32
    };
    for (p, (x, v)) in particles
        .positions
        .iter_mut()
        .zip(&mut particles.velocities)
        .enumerate()
    {
        if !(x.is_finite() && v.is_finite()) {
            *x = good
                .get(p)
                .copied()
                .filter(|g| g.is_finite())
                .unwrap_or(centre);
            *v = Vec3::ZERO;
        }
    }
}
