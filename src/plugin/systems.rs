//! The thin ECS layer of the step: gather a cloth's components, call
//! [`step_guarded`], write back.

use bevy::ecs::change_detection::Tick;
use bevy::ecs::system::SystemChangeTick;
use bevy::log::warn;
use bevy::math::Vec3;
use bevy::prelude::{
    Commands, Component, DetectChanges, Entity, Local, MessageWriter, Query, Ref, Res, ResMut, Time,
};
use bevy::tasks::ComputeTaskPool;
use std::sync::{Arc, Mutex, PoisonError};

use crate::sim::team;
use crate::sim::workers::{Pool, Workers};
use bevy::time::Fixed;

use crate::plugin::components::ClothConnections;
use crate::plugin::components::ClothParticles;
use crate::plugin::components::{ClothDefaults, ClothSettings};
use bevy::platform::time::Instant;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use bevy::ecs::query::QueryData;

use crate::plugin::collision::{
    ClothCollision, ClothCollisionStats, ClothContactImpulses, ClothContacts, ClothObstacles,
    ClothSelfCollision, ClothToClothScratch, ColliderScene, ContactLayers, Feedback, SceneContacts,
    SelfCollisionScratch, SleepWatch, bounds,
};
use crate::plugin::components::Cloth;
pub use crate::plugin::components::check_cloth;
use crate::plugin::components::check_indices;
use crate::plugin::components::{ClothForces, ClothStats};
use crate::plugin::events::ClothDiverged;
use crate::plugin::interaction::ClothGrabs;
use crate::plugin::lod::ClothDetail;
use crate::plugin::sleep::{Change, ClothSleep};
use crate::plugin::tether::{ClothTethers, TetherScratch};
use crate::plugin::wind::ClothWind;
use crate::sim::guard::{StepInput, step_guarded};
use crate::sim::lod::{Detail, pin_carry, ride_pins};
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
    strain: Option<(Tick, f32)>,
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
    fn links(&mut self, connections: &Ref<ClothConnections>, now: Tick) -> (Option<u32>, u64) {
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

/// Preallocated integrator scratch for one cloth (not reflected).
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct ClothScratch {
    /// Stage buffers of the integrators.
    pub buffers: crate::sim::integrate::StepBuffers,
    /// Indices of the scene colliders near this cloth in the current step.
    pub(crate) near: Vec<usize>,
    /// Whether the cloth was skipped for invalid settings, so the warning is
    /// logged once.
    pub(crate) warned_invalid: bool,
    /// The divergence guard's state.
    pub(crate) guard: crate::sim::guard::GuardState,
    /// A divergence to report at the end of the step.
    pub(crate) pending: Option<crate::sim::guard::GuardReport>,
    /// Whether a divergence of this cloth was logged already.
    pub(crate) warned_diverged: bool,
    /// What the step measured that its writeback reuses.
    pub(crate) measured: Measured,
    /// The contact pass's masked inverse masses.
    pub(crate) masked: Vec<f32>,
    /// The edge contacts' scratch.
    pub(crate) edge_points: Vec<(Vec3, f32, Vec3, f32)>,
    /// The impulses this step gave colliders with feedback.
    pub(crate) feedback: Feedback,
    /// Whether the cloth is at rest, and for how long it has been calm.
    pub(crate) rest: RestTracker,
    /// What a sleeping cloth watches.
    pub(crate) sleep: SleepWatch,
    /// The mean of the forces over a combined step (level of detail), N.
    pub(crate) mean_forces: Vec<Vec3>,
}

/// What the step reads and writes of one cloth.
#[derive(QueryData)]
#[query_data(mutable)]
pub(crate) struct StepQuery {
    entity: Entity,
    cloth: &'static Cloth,
    particles: &'static mut ClothParticles,
    connections: Ref<'static, ClothConnections>,
    settings: Option<Ref<'static, ClothSettings>>,
    material: Option<Ref<'static, crate::plugin::material::ClothMaterial>>,
    forces: Ref<'static, ClothForces>,
    scratch: &'static mut ClothScratch,
    stats: &'static mut ClothStats,
    sleep: &'static mut ClothSleep,
    detail: Option<&'static ClothDetail>,
    collision: Option<Ref<'static, ClothCollision>>,
    layers: Option<Ref<'static, ContactLayers>>,
    self_collision: Option<(
        Ref<'static, ClothSelfCollision>,
        &'static mut SelfCollisionScratch,
    )>,
    tethers: Option<(Ref<'static, ClothTethers>, &'static mut TetherScratch)>,
    to_cloth: Option<&'static mut ClothToClothScratch>,
    tearing: bevy::ecs::query::Has<crate::plugin::tear::ClothTearing>,
}

impl StepQueryItem<'_, '_> {
    /// Whether anything that could move this sleeping cloth changed since it
    /// fell asleep or was last looked at ([`sleep`](crate::plugin::sleep)
    /// module docs; the colliders, the wind and the defaults are the
    /// caller's).
    fn disturbed(&self) -> bool {
        let changed = |c: Option<bool>| c.unwrap_or(false);
        self.scratch.sleep.tick != Some(self.particles.last_changed())
            || self.connections.is_changed()
            || changed(self.settings.as_ref().map(DetectChanges::is_changed))
            || changed(self.material.as_ref().map(DetectChanges::is_changed))
            || changed(self.collision.as_ref().map(DetectChanges::is_changed))
            || changed(self.layers.as_ref().map(DetectChanges::is_changed))
            || changed(self.self_collision.as_ref().map(|s| s.0.is_changed()))
            || changed(self.tethers.as_ref().map(|t| t.0.is_changed()))
            || (self.forces.is_changed() && self.forces.0.iter().any(|f| *f != Vec3::ZERO))
    }
}

/// Bevy's compute task pool as the [`Workers`] a step spreads its force
/// bands over: what the plugin passes to every step, and what a headless
/// caller of [`step_guarded`] can give its buffers with
/// [`StepBuffers::with_workers`](crate::sim::integrate::StepBuffers::with_workers).
#[derive(Clone, Copy, Debug)]
pub struct ComputePool(pub &'static ComputeTaskPool);

impl Workers for ComputePool {
    fn threads(&self) -> usize {
        self.0.thread_num()
    }

    fn run_all<'a>(&self, jobs: Vec<Box<dyn FnOnce() -> bool + Send + 'a>>) -> bool {
        self.0
            .scope(|s| {
                for job in jobs {
                    s.spawn(async move { job() });
                }
            })
            .into_iter()
            .all(|ok| ok)
    }
}

/// Runs `step` on every cloth of `cloths`, in parallel on Bevy's compute
/// pool. Bevy's parallel iteration runs one item after another when the
/// pool has a single thread, as on a 2-core machine (where Bevy gives the
/// other core to its I/O and async pools); there the calling thread and the
/// pool's thread take the cloths in turns from a shared counter, so two
/// cores step cloths whenever the pool's thread is free. Each cloth's step
/// is the same whichever thread runs it.
fn for_each_cloth<'w, 's>(
    cloths: &mut Query<'w, 's, StepQuery>,
    step: impl Fn(StepQueryItem<'_, '_>) + Send + Sync + Clone,
) {
    let pool = ComputeTaskPool::try_get().filter(|p| p.thread_num() == 1 && team::THREADS);
    let Some(pool) = pool else {
        cloths.par_iter_mut().for_each(step);
        return;
    };
    let items: Vec<Mutex<Option<StepQueryItem<'_, '_>>>> = cloths
        .iter_mut()
        .map(|item| Mutex::new(Some(item)))
        .collect();
    let next = AtomicUsize::new(0);
    let work = || {
        while let Some(slot) = items.get(next.fetch_add(1, Ordering::Relaxed)) {
            let item = slot.lock().unwrap_or_else(PoisonError::into_inner).take();
            if let Some(item) = item {
                step(item);
            }
        }
    };
    if items.len() < 2 {
        work();
        return;
    }
    pool.scope(|s| {
        s.spawn(async { work() });
        work();
    });
}

/// The compute pool, once Bevy has made one, as a step's [`Pool`].
fn compute_pool(pool: &mut Pool) -> &Pool {
    if pool.0.is_none()
        && let Some(compute) = ComputeTaskPool::try_get()
    {
        *pool = Pool::new(Arc::new(ComputePool(compute)));
    }
    pool
}

/// [`ClothSystems::Integrate`](crate::plugin::schedule::ClothSystems::Integrate):
/// steps every cloth over the fixed timestep (never the frame delta),
/// resolving contacts with nearby colliders and with itself after every
/// substep when there are any.
///
/// A cloth whose settings or arrays are invalid is skipped, with one warning
/// until it is fixed.
#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: each parameter is one resource or query"
)]
pub(crate) fn step_cloths(
    _main: crate::plugin::schedule::MainThread,
    time: Res<Time<Fixed>>,
    defaults: Res<ClothDefaults>,
    scene: Option<Res<ColliderScene>>,
    stats: Option<ResMut<ClothCollisionStats>>,
    impulses: Option<ResMut<ClothContactImpulses>>,
    mut cloths: Query<StepQuery>,
    ticks: SystemChangeTick,
    mut pool: Local<Pool>,
    wind: Option<Res<ClothWind>>,
    mut blew: Local<bool>,
    obstacles: Option<Res<ClothObstacles>>,
    nothing: Local<(ColliderScene, ClothObstacles)>,
) {
    // Without the collision plugin the step meets an empty scene.
    let scene = scene.as_deref().unwrap_or(&nothing.0);
    let obstacles = obstacles.as_deref().unwrap_or(&nothing.1);
    let pool = compute_pool(&mut pool);
    let now = ticks.this_run();
    let dt = time.timestep().as_secs_f32();
    // What wakes every sleeping cloth: new defaults, the wind stopping (its
    // start and change reach them as forces).
    let blows = wind.is_some_and(|w| w.blows());
    let stopped = std::mem::replace(&mut *blew, blows) && !blows;
    let everything = defaults.is_changed() || stopped;
    let totals: [AtomicU64; 6] = Default::default();
    let feedback = Mutex::new(Vec::new());
    for_each_cloth(&mut cloths, |mut item| {
        let base = item.settings.as_deref().map_or(&defaults.0, |own| &own.0);
        let material = item.material.as_deref().copied().unwrap_or_default();
        let mut settings = material.settings(base, item.cloth.spacing());
        if item.tearing {
            // A strain limit would hold every thread short of its tear
            // strain: a tearing cloth's threads stretch as its forces say.
            settings.to_mut().implicit.strain_limit = f32::INFINITY;
        }
        let settings = &*settings;
        let connections: &ClothConnections = &item.connections;
        let (max_index, generation) = item.scratch.measured.links(&item.connections, now);
        item.scratch.measured.strain = None;
        let checked = material
            .validate()
            .and_then(|()| settings.validate())
            .and_then(|()| check_indices(&item.particles, max_index));
        if let Err(error) = checked {
            if !item.scratch.warned_invalid {
                warn!("cloth {} is not simulated: {error}", item.entity);
                item.scratch.warned_invalid = true;
            }
            return;
        }
        item.scratch.warned_invalid = false;
        // Level of detail: between its steps the cloth rides its pins; on
        // its step it takes the time of the fixed steps it combines.
        let steps = item.detail.map_or(1, ClothDetail::steps_now);
        if steps == 0 {
            let p = &item.particles;
            if let Some(carry) = pin_carry(&p.positions, &p.velocities, &p.inverse_masses, dt) {
                let p = &mut item.particles.0;
                let w = &p.inverse_masses;
                ride_pins(&carry, &mut p.positions, &mut p.velocities, w, dt);
                let history = &mut item.scratch.buffers.implicit;
                history.carry_history(&carry, |i| w[i] > 0.0);
            }
            return;
        }
        let dt = dt * steps as f32;
        // A combined step of `k` fixed steps is solved to a relative
        // tolerance `k` times looser: a reduced cloth is `k/2` to `k` times
        // farther than `near`, or out of view.
        let relaxed;
        let settings = if steps > 1 {
            let mut own = settings.clone();
            own.implicit.tolerance = (own.implicit.tolerance * steps as f32).min(0.1);
            relaxed = own;
            &relaxed
        } else {
            settings
        };
        item.scratch.sleep.settings = settings.sleep;
        // Other cloths it may reach this step: one moving near it wakes it.
        // The fastest particle (m/s), scanned once, when first asked for.
        let mut speed = None;
        let mut fastest = || {
            *speed.get_or_insert_with(|| {
                let v = &item.particles.velocities;
                v.iter().map(|v| v.length()).fold(0.0, f32::max)
            })
        };
        let reach = |speed: f32| 2.0 * speed * dt + settings.gravity.length() * dt * dt + 0.01;
        let mut cloth_moving = false;
        if let Some(to_cloth) = item.to_cloth.as_deref_mut() {
            let x = &item.particles.positions;
            let (rest, entity) = (settings.sleep.rest_speed, item.entity);
            cloth_moving = obstacles.near(entity, x, reach(fastest()), rest, to_cloth);
        }
        // Sleep: a sleeping cloth stays as it is unless something could
        // move it; a woken one continues from where it slept.
        let asked = item.sleep.wake_requested();
        if asked {
            item.sleep.take_wake();
        }
        let was_asleep = item.sleep.is_asleep();
        if was_asleep {
            let tolerance = settings.sleep.rest_speed * dt;
            let layers = item.layers.as_deref().copied().unwrap_or_default();
            if !(asked
                || everything
                || item.disturbed()
                || cloth_moving
                || item.scratch.sleep.scene_changed(scene, layers, tolerance))
            {
                return;
            }
            item.sleep.set_asleep(false);
            item.scratch.sleep.tick = None;
        }
        if asked || was_asleep {
            if item.scratch.rest.resting() {
                item.scratch.sleep.event = Some(Change::Woke);
            }
            item.scratch.rest.wake();
        }
        let scratch = &mut *item.scratch;
        if scratch.buffers.workers.0.is_none() {
            scratch.buffers.workers = pool.clone();
        }
        scratch.buffers.set_links_generation(Some(generation));
        // Colliders the cloth may reach this step: its box grown by the
        // thickness and twice the distance its fastest particle or gravity
        // could carry it.
        let thickness = item
            .collision
            .map_or(ClothCollision::default().thickness, |c| c.thickness);
        scratch.near.clear();
        if !scene.colliders.is_empty() && thickness.is_finite() && thickness >= 0.0 {
            let (lo, hi) = bounds(&item.particles.positions, thickness + reach(fastest()));
            let layers = item.layers.as_deref().copied().unwrap_or_default();
            scratch.near.extend(
                scene
                    .overlapping(lo, hi)
                    .filter(|&c| scene.colliders[c].layers.interacts(layers)),
            );
        }
        let self_collision = item
            .self_collision
            .as_mut()
            .filter(|(s, _)| s.thickness.is_finite() && s.thickness > 0.0)
            .map(|(s, buffers)| (item.cloth, s.thickness, &mut buffers.0));
        let tethers = item
            .tethers
            .as_mut()
            .filter(|(t, _)| t.slack.is_finite() && t.slack >= 1.0)
            .map(|(t, made)| {
                let t = &**t;
                let w = &item.particles.inverse_masses;
                made.0.update_tracked(connections, Some(generation), w);
                (&made.0, t.slack)
            });
        let helper = settings.implicit.helper_thread;
        let cloths = item
            .to_cloth
            .as_deref_mut()
            .filter(|c| !c.near.1.is_empty())
            .map(|scratch| ClothContacts {
                obstacles,
                scratch,
                contacts: 0,
                gravity: settings.gravity,
            });
        let contacts = !scratch.near.is_empty() || self_collision.is_some() || cloths.is_some();
        let mut hook = (contacts || tethers.is_some()).then(|| SceneContacts {
            scene,
            near: &scratch.near,
            thickness,
            helper,
            in_solve: item.collision.as_ref().is_none_or(|c| c.in_solve),
            self_collision,
            tethers,
            links: [&connections.structural, &connections.shear],
            masked: &mut scratch.masked,
            edge_points: &mut scratch.edge_points,
            feedback: &mut scratch.feedback,
            counts: Default::default(),
            cloths,
        });
        let mut external = &item.forces.0[..];
        if steps > 1 {
            // Over a combined step the pins move as far as over one fixed
            // step, and the forces of its fixed steps act as their mean.
            let p = &mut item.particles.0;
            for (v, _) in p
                .velocities
                .iter_mut()
                .zip(&p.inverse_masses)
                .filter(|(_, w)| **w == 0.0)
            {
                *v /= steps as f32;
            }
            if external.iter().any(|f| *f != Vec3::ZERO) {
                scratch.mean_forces.clear();
                let share = 1.0 / steps as f32;
                scratch
                    .mean_forces
                    .extend(external.iter().map(|f| *f * share));
                external = &scratch.mean_forces;
            }
        }
        let started = Instant::now();
        let step = step_guarded(
            StepInput::new(
                &mut item.particles,
                connections,
                settings,
                &mut scratch.buffers,
                &mut scratch.guard,
                dt,
            )
            .with_external(external)
            .with_contacts(hook.as_mut())
            .with_helper_thread(helper),
        );
        if let Some(hook) = hook {
            if let Some(c) = &hook.cloths {
                totals[4].fetch_add(1, Ordering::Relaxed);
                totals[5].fetch_add(c.contacts as u64, Ordering::Relaxed);
            }
            let (against, itself) = hook.counts;
            for (total, n) in totals.iter().zip([
                against.tests,
                against.contacts,
                itself.tests,
                itself.contacts,
            ]) {
                total.fetch_add(n as u64, Ordering::Relaxed);
            }
        }
        if !scratch.feedback.impulses.is_empty() {
            feedback
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .append(&mut scratch.feedback.impulses);
        }
        scratch.measured.strain = step.strain.map(|s| (now, s));
        scratch.pending = step.report;
        let effective = step;
        item.stats.substeps = effective.substeps;
        item.stats.integrator = effective.integrator;
        item.stats.step_micros = started.elapsed().as_secs_f32() * 1e6;
        item.stats.solver_iterations = if effective.integrator.is_implicit() {
            scratch.buffers.implicit.last_iterations
        } else {
            0
        };
    });
    let feedback = feedback
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    if let Some(mut impulses) = impulses {
        for (c, impulse) in feedback {
            if let Some(collider) = scene.colliders.get(c) {
                *impulses.map.entry(collider.entity).or_default() += impulse;
            }
        }
    }
    let Some(mut stats) = stats else {
        return;
    };
    if !scene.colliders.is_empty() {
        stats.collider_passes += 1;
    }
    let [ct, cc, st, sc, cp, ck] = totals.map(AtomicU64::into_inner);
    stats.cloth_passes += cp.min(1);
    stats.cloth_contacts += ck;
    if ct + st > 0 {
        stats.collider_tests += ct;
        stats.collider_contacts += cc;
        stats.self_tests += st;
        stats.self_contacts += sc;
    }
    if cloths.iter().any(|c| c.self_collision.is_some()) {
        stats.self_passes += 1;
    }
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
    layers: Option<&'static ContactLayers>,
}

/// [`ClothSystems::Writeback`](crate::plugin::schedule::ClothSystems::Writeback):
/// clears the external forces, measures [`ClothStats`] (with the strain the
/// step's guard measured, if the particles have not changed since:
/// [`Measured`]), reports the step's divergences ([`report_divergence`]),
/// triggers [`ClothAtRest`](crate::plugin::events::ClothAtRest) and
/// [`ClothWoke`](crate::plugin::events::ClothWoke), and puts cloths at rest
/// to sleep, in one system. A cloth whose grabs move a particle is not at
/// rest, whatever its free particles do; a held cloth does not sleep.
pub(crate) fn finish_step(
    _main: crate::plugin::schedule::MainThread,
    mut commands: Commands,
    mut cloths: Query<WritebackQuery>,
    mut out: MessageWriter<ClothDiverged>,
    ticks: SystemChangeTick,
    scene: Option<Res<ColliderScene>>,
    nothing: Local<ColliderScene>,
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
        if let Some(change) = scratch.sleep.event.take() {
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
        let settings = scratch.sleep.settings;
        let change = match scratch.rest.step(speed, &settings) {
            Some(RestChange::CameToRest) => Some(Change::Rested),
            Some(RestChange::Woke) => Some(Change::Woke),
            None => None,
        };
        if let Some(change) = change {
            change.trigger(entity, &mut commands);
        }
        stats.resting = scratch.rest.resting();
        let held = grabs.is_some_and(|g| !g.grabs().is_empty());
        if settings.enabled && stats.resting && !held && stats.finite {
            let thickness = collision.map_or(ClothCollision::default().thickness, |c| c.thickness);
            let pad = thickness.max(0.0) + settings.margin;
            let layers = layers.copied().unwrap_or_default();
            let around = bounds(&particles.positions, pad);
            if around.0.is_finite()
                && around.1.is_finite()
                && scratch
                    .sleep
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
    }) = scratch.pending.take()
    else {
        return;
    };
    if !scratch.warned_diverged {
        warn!(
            "cloth {entity} diverged ({reason:?}); now {substeps} substeps of {integrator:?}{}",
            if recovered {
                ""
            } else {
                ", not recovered: speeds clamped or held for this step"
            }
        );
        scratch.warned_diverged = true;
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
