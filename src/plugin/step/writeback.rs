//! The writeback of the step: a cloth's scratch, a part per stage of the
//! step, and `finish_step` (statistics, events, rest and sleep, divergence
//! reports) in `ClothSystems::Writeback`. The step itself is the plugin's
//! `integrate` module.

use std::sync::atomic::{AtomicU64, Ordering};

use bevy::ecs::change_detection::Tick;
use bevy::ecs::query::QueryData;
use bevy::ecs::system::SystemChangeTick;
use bevy::log::warn;
use bevy::math::Vec3;
use bevy::prelude::{
    Commands, Component, DetectChanges, Entity, Local, MessageWriter, Query, Ref, Res,
};

use crate::plugin::collision::{ClothColliderScene, ClothCollision, ClothContactLayers, bounds};
use crate::plugin::interaction::grab::ClothGrabs;
use crate::plugin::lod::ClothDetail;
use crate::plugin::step::components::{
    ClothConnections, ClothForces, ClothParticles, ClothStats, check_indices,
};
use crate::plugin::step::events::ClothDiverged;
use crate::plugin::step::sleep::{Change, ClothSleep, SleepWatch};
use crate::sim::collision::scene::SceneContactScratch;
use crate::sim::lod::Detail;
use crate::sim::sleep::{RestChange, RestTracker};

/// What the step measured of a cloth that the writeback reuses while the
/// cloth has not changed since: each scan takes some 20–30 µs on a 64×64
/// cloth, and the writeback would repeat them every fixed step.
#[derive(Clone, Debug, Default)]
pub(crate) struct Measured {
    /// The connections' largest particle index, scanned at this tick, and
    /// the generation they were given then
    /// ([`StepBuffers::set_links_generation`](crate::sim::integrate::StepBuffers::set_links_generation)).
    links: Option<(Tick, Option<u32>, u64)>,
    /// The Type 1 strain of the particles as the step left them at this
    /// tick (measured by the divergence guard).
    pub(crate) strain: Option<(Tick, f32)>,
}

impl Measured {
    /// The connections' largest index: the last scan's if they have not
    /// changed since it, else a new scan at `now`.
    fn max_index(&mut self, connections: &Ref<ClothConnections>, now: Tick) -> Option<u32> {
        self.links(connections, now).0
    }

    /// The connections' largest index and their generation: a number
    /// that changes whenever they change (Bevy's change ticks say when),
    /// and that no other cloth's connections have.
    pub(crate) fn links(
        &mut self,
        connections: &Ref<ClothConnections>,
        now: Tick,
    ) -> (Option<u32>, u64) {
        match self.links {
            Some((at, max, generation)) if !connections.last_changed().is_newer_than(at, now) => {
                (max, generation)
            }
            _ => {
                static NEXT: AtomicU64 = AtomicU64::new(0);
                let max = connections.max_index();
                let generation = NEXT.fetch_add(1, Ordering::Relaxed);
                self.links = Some((now, max, generation));
                (max, generation)
            }
        }
    }

    /// The step's strain of `particles`, if they have not changed since.
    fn strain(&self, particles: &Ref<ClothParticles>, now: Tick) -> Option<f32> {
        self.strain
            .filter(|&(at, _)| !particles.last_changed().is_newer_than(at, now))
            .map(|(_, strain)| strain)
    }
}

/// Preallocated scratch for one cloth's step (not reflected), a part per
/// stage of [`step_cloths`](crate::plugin::step::integrate::step_cloths).
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct ClothScratch {
    /// Stage buffers of the integrators.
    pub buffers: crate::sim::integrate::StepBuffers,
    /// Whether the cloth was skipped for invalid settings, so the warning is
    /// logged once.
    pub(crate) warned_invalid: bool,
    /// What the step measured that its writeback reuses.
    pub(crate) measured: Measured,
    /// The contact stage's.
    pub(crate) contacts: SceneContactScratch,
    /// The divergence guard's.
    pub(crate) guard: GuardScratch,
    /// Rest and sleep.
    pub(crate) rest: RestScratch,
    /// The mean of the forces over a combined step (level of detail), N.
    pub(crate) mean_forces: Vec<Vec3>,
}

/// The divergence guard's state and what it has to report.
#[derive(Clone, Debug, Default)]
pub(crate) struct GuardScratch {
    /// The guard's state.
    pub(crate) state: crate::sim::guard::GuardState,
    /// A divergence to report at the end of the step.
    pub(crate) pending: Option<crate::sim::guard::GuardReport>,
    /// Whether a divergence of this cloth was logged already.
    pub(crate) warned: bool,
}

/// Whether the cloth is at rest, and what a sleeping cloth watches.
#[derive(Clone, Debug, Default)]
pub(crate) struct RestScratch {
    /// Whether the cloth is at rest, and for how long it has been calm.
    pub(crate) tracker: RestTracker,
    /// What a sleeping cloth watches.
    pub(crate) watch: SleepWatch,
}

/// What the writeback reads and writes of one cloth.
#[derive(QueryData)]
#[query_data(mutable)]
pub(crate) struct WritebackQuery {
    entity: Entity,
    particles: Ref<'static, ClothParticles>,
    connections: Ref<'static, ClothConnections>,
    forces: &'static mut ClothForces,
    stats: &'static mut ClothStats,
    scratch: &'static mut ClothScratch,
    sleep: &'static mut ClothSleep,
    detail: Option<&'static mut ClothDetail>,
    grabs: Option<&'static ClothGrabs>,
    collision: Option<&'static ClothCollision>,
    layers: Option<&'static ClothContactLayers>,
}

/// [`ClothSystems::Writeback`](crate::plugin::step::schedule::ClothSystems::Writeback):
/// clears the external forces, measures [`ClothStats`] (with the strain the
/// step's guard measured, if the particles have not changed since:
/// [`Measured`]), reports the step's divergences ([`report_divergence`]),
/// triggers [`ClothAtRest`](crate::plugin::step::events::ClothAtRest) and
/// [`ClothWoke`](crate::plugin::step::events::ClothWoke), and puts cloths at rest
/// to sleep, in one system. A cloth whose grabs move a particle is not at
/// rest, whatever its free particles do; a held cloth does not sleep.
pub(crate) fn finish_step(
    _main: crate::plugin::step::schedule::MainThread,
    mut commands: Commands,
    mut cloths: Query<WritebackQuery>,
    mut out: MessageWriter<ClothDiverged>,
    ticks: SystemChangeTick,
    scene: Option<Res<ClothColliderScene>>,
    nothing: Local<ClothColliderScene>,
) {
    // Without the collision plugin a cloth falls asleep in an empty scene.
    let scene = scene.as_deref().unwrap_or(&nothing);
    let now = ticks.this_run();
    for item in &mut cloths {
        let WritebackQueryItem {
            entity,
            particles,
            connections,
            mut forces,
            mut stats,
            mut scratch,
            mut sleep,
            mut detail,
            grabs,
            collision,
            layers,
        } = item;
        report_divergence(entity, &mut scratch, &mut out, &mut commands);
        if let Some(change) = scratch.rest.watch.event.take() {
            change.trigger(entity, &mut commands);
        }
        if sleep.is_asleep() {
            continue;
        }
        if let Some(detail) = &detail
            && detail.steps_now() == 0
        {
            // Between the steps of a reduced cloth its forces add up for
            // its next one; a frozen cloth's are dropped.
            if detail.detail() == Detail::Frozen && forces.0.iter().any(|f| *f != Vec3::ZERO) {
                forces.0.fill(Vec3::ZERO);
            }
            continue;
        }
        if forces.0.iter().any(|f| *f != Vec3::ZERO) {
            forces.0.fill(Vec3::ZERO);
        }
        stats.steps += 1;
        let measured = &mut scratch.measured;
        if check_indices(&particles, measured.max_index(&connections, now)).is_ok() {
            match measured.strain(&particles, now) {
                Some(strain) => stats.measure_with(&particles, strain),
                None => stats.measure(&particles, &connections),
            }
        } else {
            stats.finite = particles.is_finite();
            stats.max_speed = f32::NAN;
        }
        if let Some(detail) = &mut detail {
            detail.stepped(stats.max_strain);
        }
        let grabbed = grabs.map_or(0.0, |g| {
            g.grabs()
                .iter()
                .filter_map(|g| particles.velocities.get(g.particle as usize))
                .fold(0.0f32, |m, v| m.max(v.length()))
        });
        // NaN (a non-finite free particle) stays NaN.
        let speed = if stats.max_speed.is_nan() {
            f32::NAN
        } else {
            stats.max_speed.max(grabbed)
        };
        let settings = scratch.rest.watch.settings;
        let change = match scratch.rest.tracker.step(speed, &settings) {
            Some(RestChange::CameToRest) => Some(Change::Rested),
            Some(RestChange::Woke) => Some(Change::Woke),
            None => None,
        };
        if let Some(change) = change {
            change.trigger(entity, &mut commands);
        }
        stats.resting = scratch.rest.tracker.resting();
        let held = grabs.is_some_and(|g| !g.grabs().is_empty());
        if settings.enabled && stats.resting && !held && stats.finite {
            let thickness = collision.map_or(ClothCollision::default().thickness, |c| c.thickness);
            let pad = thickness.max(0.0) + settings.margin;
            let layers = layers.copied().unwrap_or_default();
            let around = bounds(&particles.positions, pad);
            if around.0.is_finite()
                && around.1.is_finite()
                && scratch
                    .rest
                    .watch
                    .fall_asleep(scene, around, layers, particles.last_changed())
            {
                sleep.set_asleep(true);
                // It costs no step while it sleeps.
                stats.step_micros = 0.0;
                stats.solver_iterations = 0;
            }
        }
    }
}

/// Reports the divergence of this step, if any, warning once per cloth.
fn report_divergence(
    entity: Entity,
    scratch: &mut ClothScratch,
    out: &mut MessageWriter<ClothDiverged>,
    commands: &mut Commands,
) {
    let Some(crate::sim::guard::GuardReport {
        reason,
        substeps,
        integrator,
        recovered,
        ..
    }) = scratch.guard.pending.take()
    else {
        return;
    };
    if !scratch.guard.warned {
        warn!(
            "cloth {entity} diverged ({reason:?}); now {substeps} substeps of {integrator:?}{}",
            if recovered {
                ""
            } else {
                ", not recovered: speeds clamped or held for this step"
            }
        );
        scratch.guard.warned = true;
    }
    let diverged = ClothDiverged {
        cloth: entity,
        reason,
        substeps,
        integrator,
        recovered,
    };
    commands.trigger(diverged.clone());
    out.write(diverged);
}
