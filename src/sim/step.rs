//! One fixed step of one cloth, as a plain function ([`step_cloth`]), and
//! the contact hook it calls between substeps.

use bevy::math::Vec3;

use crate::sim::connections::Connections;
pub use crate::sim::integrate::implicit::{ContactBuffers, Hold, SolveBody, SolveContact};
use crate::sim::integrate::{self, StepBuffers};
use crate::sim::model::Dynamics;
use crate::sim::particles::Particles;
use crate::sim::settings::SimSettings;

/// One substep, as a contact hook sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Substep {
    /// Start of the substep as a fraction of the fixed step, in [0, 1).
    pub from: f32,
    /// End of the substep as a fraction of the fixed step, in (0, 1].
    pub to: f32,
    /// Length of the substep in s.
    pub dt: f32,
}

/// Contacts with the world over a step: what the implicit solve should
/// hold, and what is left to resolve after each substep.
///
/// A closure `|substep, start, x, v, w| …` is a hook that only resolves
/// after each substep.
pub trait ContactHook {
    /// After each substep: the substep, positions at its start (m), and
    /// the particles' positions (m), velocities (m/s) and inverse masses
    /// (1/kg) at its end, which it may correct. `held` says which particles
    /// the implicit solve held on a surface this substep (empty when none);
    /// their contacts are resolved already.
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        held: &[Hold],
    );

    /// Before an implicit substep: the contacts its solve is to hold
    /// (positions m, velocities m/s, inverse masses 1/kg at the substep's
    /// start) into `out`, and the free bodies behind them
    /// ([`SolveContact::body`]) into `bodies`. None by default.
    fn predict(
        &mut self,
        _sub: Substep,
        _x: &[Vec3],
        _v: &[Vec3],
        _w: &[f32],
        _out: &mut Vec<SolveContact>,
        _bodies: &mut Vec<SolveBody>,
    ) {
    }

    /// After an implicit substep, before [`resolve`](Self::resolve): the
    /// contacts its solve held, whose `impulses`
    /// say what each gave its particle (N·s), with the particles'
    /// positions (m) and velocities (m/s) at the substep's end. Nothing by
    /// default.
    fn solved(&mut self, _x: &[Vec3], _v: &[Vec3], _contacts: &ContactBuffers) {}

    /// The step's attempt so far was undone and is taken again (the
    /// [`guard`](crate::sim::guard)'s retry): forget what it measured.
    /// Nothing by default.
    fn undo(&mut self) {}
}

impl<F: FnMut(Substep, &[Vec3], &mut [Vec3], &mut [Vec3], &[f32])> ContactHook for F {
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        _held: &[Hold],
    ) {
        self(sub, start, x, v, w)
    }
}

/// The hook of a step without contacts.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoContacts;

impl ContactHook for NoContacts {
    fn resolve(
        &mut self,
        _: Substep,
        _: &[Vec3],
        _: &mut [Vec3],
        _: &mut [Vec3],
        _: &[f32],
        _: &[Hold],
    ) {
    }
}

/// Advances one cloth by `dt` seconds in `settings.substeps` equal substeps.
///
/// `external` holds one force per particle in N, or is empty. `buffers` are
/// resized if the particle count changed (the only allocation). Settings are
/// assumed valid ([`SimSettings::validate`]); the ECS layer checks them.
/// Returns the substeps run: `settings.substeps`, or more with
/// [`SimSettings::adaptive`](crate::sim::adaptive::AdaptiveSubsteps).
pub fn step_cloth(
    particles: &mut Particles,
    connections: &Connections,
    settings: &SimSettings,
    external: &[Vec3],
    buffers: &mut StepBuffers,
    dt: f32,
) -> u32 {
    step_cloth_with(
        particles,
        connections,
        settings,
        external,
        buffers,
        dt,
        None::<&mut NoContacts>,
    )
}

/// [`step_cloth`] with a contact hook called after every substep, so that
/// contacts are resolved at the time scale of the stiff springs rather than
/// once per fixed step (which lets the cloth gain energy against a collider).
pub fn step_cloth_with(
    particles: &mut Particles,
    connections: &Connections,
    settings: &SimSettings,
    external: &[Vec3],
    buffers: &mut StepBuffers,
    dt: f32,
    mut contacts: Option<&mut impl ContactHook>,
) -> u32 {
    let n = particles.len();
    buffers.resize(n);
    if contacts.is_some() {
        buffers.substep_start.resize(n, Vec3::ZERO);
    }
    let mut substeps = crate::sim::adaptive::substeps_for(
        settings,
        connections,
        particles,
        dt,
        &mut buffers.mode_sums,
    );
    let implicit = settings.integrator.is_implicit();
    let Particles {
        positions,
        velocities,
        inverse_masses,
        ..
    } = particles;
    // The implicit solve's contacts over the whole step, when it holds any:
    // a collider striking the cloth splits the step (`impact_substeps`),
    // and a step that stays whole keeps them for its one substep.
    let mut predicted = false;
    if implicit && let Some(hook) = contacts.as_mut() {
        let contacts = &mut buffers.implicit.contacts;
        contacts.list.clear();
        contacts.bodies.clear();
        let whole = Substep {
            from: 0.0,
            to: 1.0,
            dt,
        };
        let (list, bodies) = (&mut contacts.list, &mut contacts.bodies);
        hook.predict(whole, positions, velocities, inverse_masses, list, bodies);
        let impact = impact_substeps(list, velocities, connections, dt);
        if impact > substeps {
            substeps = impact;
        } else {
            predicted = substeps == 1;
        }
    }
    let h = dt / substeps as f32;
    let workers = buffers.workers.clone();
    let dynamics = Dynamics {
        settings,
        connections,
        inverse_masses,
        external,
        workers: &workers,
    };
    // The connections cannot change during the step: compare them once.
    integrate::sync(settings.integrator, &dynamics, n, buffers);
    for k in 0..substeps {
        let sub = Substep {
            from: k as f32 / substeps as f32,
            to: (k + 1) as f32 / substeps as f32,
            dt: h,
        };
        if !predicted {
            buffers.implicit.contacts.list.clear();
            buffers.implicit.contacts.bodies.clear();
        }
        if let Some(hook) = contacts.as_mut() {
            buffers.substep_start.copy_from_slice(positions);
            if implicit && !predicted {
                hook.predict(
                    sub,
                    positions,
                    velocities,
                    inverse_masses,
                    &mut buffers.implicit.contacts.list,
                    &mut buffers.implicit.contacts.bodies,
                );
            }
        }
        integrate::step_synced(
            settings.integrator,
            &dynamics,
            positions,
            velocities,
            h,
            buffers,
        );
        if let Some(hook) = contacts.as_mut() {
            if implicit && buffers.implicit.contacts.any() {
                hook.solved(positions, velocities, &buffers.implicit.contacts);
            }
            let held = if implicit {
                buffers.implicit.contacts.holds()
            } else {
                &[]
            };
            hook.resolve(
                sub,
                &buffers.substep_start,
                positions,
                velocities,
                inverse_masses,
                held,
            );
        }
    }
    substeps
}

/// How far (as a fraction of the shortest Type 1 rest length) a surface may
/// close in on the cloth in one implicit substep ([`impact_substeps`]).
pub(crate) const IMPACT_REACH: f32 = 0.25;

/// Most substeps [`impact_substeps`] splits a step into.
pub(crate) const MAX_IMPACT_SUBSTEPS: u32 = 8;

/// The substeps an implicit step of `dt` s needs for its predicted
/// `contacts` (particle velocities `v`, m/s): enough that no moving surface
/// closes in on a particle by more than [`IMPACT_REACH`] of the shortest
/// link in one substep, at most [`MAX_IMPACT_SUBSTEPS`]; 1 when none closes
/// in that fast.
///
/// A held contact moves its particle with the surface within the step,
/// while the solve sees its links as they were at the start: a ball
/// striking a sheet at 2.5 m/s moves the particles under it 4 cm in one
/// 1/60 s step, turning the links beside them by as much, and a link turned
/// by an angle `θ` within a linearised step comes out stretched by about
/// `1/cos θ − 1`. In substeps of a quarter link each, the links turn a
/// little at a time and the cloth follows.
pub(crate) fn impact_substeps(
    contacts: &[SolveContact],
    v: &[Vec3],
    connections: &Connections,
    dt: f32,
) -> u32 {
    let approach = contacts
        .iter()
        .filter_map(|c| {
            // The surface's own motion into the particle, less what the
            // particle gives way: a cloth falling onto a still surface
            // needs no split.
            let particle = v.get(c.particle as usize)?;
            let relative = (c.velocity - *particle).dot(c.normal);
            Some(relative.min(c.velocity.dot(c.normal)))
        })
        .fold(0.0f32, f32::max);
    let reach = approach * dt;
    // Nothing closes in by a millimetre: no link turns far.
    if reach.is_nan() || reach <= 1e-3 {
        return 1;
    }
    let shortest = connections
        .type1()
        .map(|l| l.rest_length)
        .fold(f32::INFINITY, f32::min);
    if !(shortest.is_finite() && shortest > 0.0) {
        return 1;
    }
    let needed = (reach / (IMPACT_REACH * shortest)).ceil();
    if needed.is_finite() {
        (needed as u32).clamp(1, MAX_IMPACT_SUBSTEPS)
    } else {
        MAX_IMPACT_SUBSTEPS
    }
}
