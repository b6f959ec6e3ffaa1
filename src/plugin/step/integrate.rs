//! [`ClothSystems::Integrate`](crate::plugin::step::schedule::ClothSystems::Integrate):
//! [`step_cloths`] steps every cloth, in named stages:
//!
//! 1. [`settings_of`]: the cloth's settings (defaults, its override, its
//!    material, tearing) and its checks; an invalid cloth is skipped.
//! 2. Level of detail: a cloth between its steps rides its pins
//!    ([`ride_between_steps`]); one that combines fixed steps takes their
//!    time at a looser tolerance ([`relaxed`]).
//! 3. [`near_cloths`] and [`stays_asleep`]: other cloths within reach, and
//!    the sleep gate (what wakes a sleeping cloth).
//! 4. [`near_colliders`]: the scene's colliders within reach.
//! 5. [`integrate`]: the contact hook, the external forces, the guarded
//!    step ([`step_guarded`]) and the cloth's statistics.
//! 6. [`Totals`]: the contact counts of every cloth, into
//!    [`ClothCollisionStats`], and the impulses on colliders.
//!
//! What it may import: anything of Bevy, [`sim`](crate::sim) and the rest
//! of the plugin layer.

use std::borrow::Cow;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use bevy::ecs::change_detection::Tick;
use bevy::ecs::query::QueryData;
use bevy::ecs::system::SystemChangeTick;
use bevy::log::warn;
use bevy::math::Vec3;
use bevy::platform::time::Instant;
use bevy::prelude::{DetectChanges, Entity, Local, Query, Ref, Res, ResMut, Time};
use bevy::tasks::ComputeTaskPool;
use bevy::time::Fixed;

use crate::plugin::collision::{
    ClothColliderScene, ClothCollision, ClothCollisionStats, ClothContactImpulses,
    ClothContactLayers, ClothObstacles, ClothSelfCollision, ClothToClothScratch, ContactImpulse,
    SelfCollisionScratch,
};
use crate::plugin::lod::ClothDetail;
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::step::components::{
    Cloth, ClothConnections, ClothForces, ClothParticles, ClothSettings, ClothSettingsDefaults,
    ClothStats, check_indices,
};
use crate::plugin::step::pool::compute_pool;
use crate::plugin::step::sleep::{Change, ClothSleep};
use crate::plugin::step::writeback::ClothScratch;
use crate::plugin::tearing::tear::ClothTearing;
use crate::plugin::wind::ClothWind;
use crate::plugin::worn::tether::{ClothTethers, TetherScratch};
use crate::sim::collision::cloths::NeighbourContacts;
use crate::sim::collision::scene::SceneContacts;
use crate::sim::guard::{GuardedStep, StepInput, step_guarded};
use crate::sim::lod::{pin_carry, ride_pins};
use crate::sim::settings::SimSettings;
use crate::sim::team;
use crate::sim::workers::Pool;

/// What the step reads and writes of one cloth.
#[derive(QueryData)]
#[query_data(mutable)]
pub(crate) struct StepQuery {
    entity: Entity,
    cloth: &'static Cloth,
    particles: &'static mut ClothParticles,
    connections: Ref<'static, ClothConnections>,
    settings: Option<Ref<'static, ClothSettings>>,
    material: Option<Ref<'static, ClothMaterial>>,
    forces: Ref<'static, ClothForces>,
    scratch: &'static mut ClothScratch,
    stats: &'static mut ClothStats,
    sleep: &'static mut ClothSleep,
    detail: Option<&'static ClothDetail>,
    collision: Option<Ref<'static, ClothCollision>>,
    layers: Option<Ref<'static, ClothContactLayers>>,
    self_collision: Option<(
        Ref<'static, ClothSelfCollision>,
        &'static mut SelfCollisionScratch,
    )>,
    tethers: Option<(Ref<'static, ClothTethers>, &'static mut TetherScratch)>,
    to_cloth: Option<&'static mut ClothToClothScratch>,
    tearing: bevy::ecs::query::Has<ClothTearing>,
}

impl StepQueryItem<'_, '_> {
    /// Whether anything that could move this sleeping cloth changed since it
    /// fell asleep or was last looked at ([`sleep`](crate::plugin::step::sleep)
    /// module docs; the colliders, the wind and the defaults are the
    /// caller's).
    fn disturbed(&self) -> bool {
        let changed = |c: Option<bool>| c.unwrap_or(false);
        self.scratch.rest.watch.tick != Some(self.particles.last_changed())
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

/// The contact counts of every cloth's step, added up across threads:
/// tests and contacts against colliders, tests and contacts with itself,
/// cloths with other cloths near, and their contacts.
#[derive(Default)]
struct Totals([AtomicU64; 6]);

impl Totals {
    /// Adds what one cloth's contact hook counted.
    fn add(&self, hook: &SceneContacts<Cloth>) {
        let totals = &self.0;
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

    /// Adds the totals of this fixed step to `stats`: `colliders` whether
    /// the scene had any, `itself` whether a cloth collides with itself.
    fn into_stats(self, stats: &mut ClothCollisionStats, colliders: bool, itself: bool) {
        if colliders {
            stats.collider_passes += 1;
        }
        let [ct, cc, st, sc, cp, ck] = self.0.map(AtomicU64::into_inner);
        stats.cloth_passes += cp.min(1);
        stats.cloth_contacts += ck;
        if ct + st > 0 {
            stats.collider_tests += ct;
            stats.collider_contacts += cc;
            stats.self_tests += st;
            stats.self_contacts += sc;
        }
        if itself {
            stats.self_passes += 1;
        }
    }
}

/// What every cloth's step shares in one run of [`step_cloths`].
struct Shared<'a> {
    /// The global defaults.
    defaults: &'a SimSettings,
    /// The colliders of this fixed step (empty without collision).
    scene: &'a ClothColliderScene,
    /// The colliding cloths of this fixed step.
    obstacles: &'a ClothObstacles,
    /// The workers a step spreads its force bands over.
    pool: &'a Pool,
    /// The fixed step, s.
    dt: f32,
    /// This run's change tick.
    now: Tick,
    /// Whether every sleeping cloth wakes: new defaults, or the wind stopped.
    wake_all: bool,
    /// The contact counts, added up.
    totals: Totals,
    /// The impulses the cloths gave colliders with feedback.
    feedback: Mutex<Vec<(usize, ContactImpulse)>>,
}

/// How far a cloth may move in a step of `dt` s: twice what its fastest
/// particle (m/s, scanned once, when first asked for) or gravity (m/s²)
/// could carry it, plus 1 cm.
struct Reach {
    speed: Option<f32>,
    dt: f32,
    gravity: f32,
}

impl Reach {
    /// The reach of a cloth whose particles move at `v` (m/s), m.
    fn get(&mut self, v: &[Vec3]) -> f32 {
        let speed = *self
            .speed
            .get_or_insert_with(|| v.iter().map(|v| v.length()).fold(0.0, f32::max));
        2.0 * speed * self.dt + self.gravity * self.dt * self.dt + 0.01
    }
}

/// [`ClothSystems::Integrate`](crate::plugin::step::schedule::ClothSystems::Integrate):
/// steps every cloth over the fixed timestep (never the frame delta),
/// resolving contacts with nearby colliders and with itself after every
/// substep when there are any. Without the collision plugin the step meets
/// an empty scene.
///
/// A cloth whose settings or arrays are invalid is skipped, with one warning
/// until it is fixed.
#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: each parameter is one resource or query"
)]
pub(crate) fn step_cloths(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    defaults: Res<ClothSettingsDefaults>,
    scene: Option<Res<ClothColliderScene>>,
    stats: Option<ResMut<ClothCollisionStats>>,
    impulses: Option<ResMut<ClothContactImpulses>>,
    mut cloths: Query<StepQuery>,
    ticks: SystemChangeTick,
    mut pool: Local<Pool>,
    wind: Option<Res<ClothWind>>,
    mut blew: Local<bool>,
    obstacles: Option<Res<ClothObstacles>>,
    nothing: Local<(ClothColliderScene, ClothObstacles)>,
) {
    // What wakes every sleeping cloth: new defaults, the wind stopping (its
    // start and change reach them as forces).
    let blows = wind.is_some_and(|w| w.blows());
    let stopped = std::mem::replace(&mut *blew, blows) && !blows;
    let shared = Shared {
        defaults: &defaults.0,
        scene: scene.as_deref().unwrap_or(&nothing.0),
        obstacles: obstacles.as_deref().unwrap_or(&nothing.1),
        pool: compute_pool(&mut pool),
        dt: time.timestep().as_secs_f32(),
        now: ticks.this_run(),
        wake_all: defaults.is_changed() || stopped,
        totals: Totals::default(),
        feedback: Mutex::new(Vec::new()),
    };
    for_each_cloth(&mut cloths, |item| step_one(&shared, item));
    let Shared {
        scene,
        totals,
        feedback,
        ..
    } = shared;
    let feedback = feedback
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    if let Some(mut impulses) = impulses {
        for (c, impulse) in feedback {
            if let Some(entity) = scene.colliders.get(c).and_then(|c| c.key.entity()) {
                *impulses.map.entry(entity).or_default() += impulse;
            }
        }
    }
    if let Some(mut stats) = stats {
        let itself = cloths.iter().any(|c| c.self_collision.is_some());
        totals.into_stats(&mut stats, !scene.colliders.is_empty(), itself);
    }
}

/// One cloth's fixed step, stage by stage (the module docs).
fn step_one(shared: &Shared, mut item: StepQueryItem) {
    let Some((settings, generation)) = settings_of(&mut item, shared) else {
        return;
    };
    let steps = item.detail.map_or(1, ClothDetail::steps_now);
    if steps == 0 {
        ride_between_steps(&mut item, shared.dt);
        return;
    }
    let dt = shared.dt * steps as f32;
    let settings = relaxed(settings, steps);
    item.scratch.rest.watch.settings = settings.sleep;
    let mut reach = Reach {
        speed: None,
        dt,
        gravity: settings.gravity.length(),
    };
    let cloth_moving = near_cloths(&mut item, shared, &settings, &mut reach);
    if stays_asleep(&mut item, shared, &settings, dt, cloth_moving) {
        return;
    }
    let scratch = &mut *item.scratch;
    if scratch.buffers.workers.0.is_none() {
        scratch.buffers.workers = shared.pool.clone();
    }
    scratch.buffers.set_links_generation(Some(generation));
    let thickness = near_colliders(&mut item, shared.scene, &mut reach);
    integrate(
        &mut item, shared, &settings, dt, steps, thickness, generation,
    );
}

/// Stage 1: the cloth's settings (the defaults or its own, its material,
/// no strain limit while it may tear) and its links' generation, or `None`
/// (warned once) when its material, settings or arrays are invalid.
fn settings_of<'s>(
    item: &mut StepQueryItem,
    shared: &Shared<'s>,
) -> Option<(Cow<'s, SimSettings>, u64)> {
    let material = item.material.as_deref().copied().unwrap_or_default();
    let spacing = item.cloth.spacing();
    let mut settings = match item.settings.as_deref() {
        None => material.settings(shared.defaults, spacing),
        Some(own) => Cow::Owned(material.settings(&own.0, spacing).into_owned()),
    };
    if item.tearing {
        // A strain limit would hold every thread short of its tear
        // strain: a tearing cloth's threads stretch as its forces say.
        settings.to_mut().implicit.strain_limit = f32::INFINITY;
    }
    let (max_index, generation) = item.scratch.measured.links(&item.connections, shared.now);
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
        return None;
    }
    item.scratch.warned_invalid = false;
    Some((settings, generation))
}

/// Stage 2, between the steps of a reduced cloth: it rides its pins over
/// the fixed step of `dt` s.
fn ride_between_steps(item: &mut StepQueryItem, dt: f32) {
    let p = &item.particles;
    if let Some(carry) = pin_carry(&p.positions, &p.velocities, &p.inverse_masses, dt) {
        let p = &mut item.particles.0;
        let w = &p.inverse_masses;
        ride_pins(&carry, &mut p.positions, &mut p.velocities, w, dt);
        let history = &mut item.scratch.buffers.implicit;
        history.carry_history(&carry, |i| w[i] > 0.0);
    }
}

/// Stage 2, a combined step of `steps` fixed steps: solved to a relative
/// tolerance `steps` times looser (at most 0.1), as a reduced cloth is
/// `steps/2` to `steps` times farther than `near`, or out of view.
fn relaxed(settings: Cow<SimSettings>, steps: u32) -> Cow<SimSettings> {
    if steps <= 1 {
        return settings;
    }
    let mut own = settings.into_owned();
    own.implicit.tolerance = (own.implicit.tolerance * steps as f32).min(0.1);
    Cow::Owned(own)
}

/// Stage 3: the other cloths this one may reach this step, kept in its
/// [`ClothToClothScratch`]; whether one moving near it should wake it.
fn near_cloths(
    item: &mut StepQueryItem,
    shared: &Shared,
    settings: &SimSettings,
    reach: &mut Reach,
) -> bool {
    let Some(to_cloth) = item.to_cloth.as_deref_mut() else {
        return false;
    };
    let p = &item.particles;
    let (rest, entity) = (settings.sleep.rest_speed, item.entity);
    let reach = reach.get(&p.velocities);
    shared
        .obstacles
        .near(entity, &p.positions, reach, rest, to_cloth)
}

/// Stage 3, the sleep gate: whether the cloth stays asleep this step. A
/// sleeping cloth stays as it is unless something could move it (a wake
/// asked for, new defaults, a change of its own, a cloth moving near, a
/// collider moving near); a woken one continues from where it slept.
fn stays_asleep(
    item: &mut StepQueryItem,
    shared: &Shared,
    settings: &SimSettings,
    dt: f32,
    cloth_moving: bool,
) -> bool {
    let asked = item.sleep.wake_requested();
    if asked {
        item.sleep.take_wake();
    }
    let was_asleep = item.sleep.is_asleep();
    if was_asleep {
        let tolerance = settings.sleep.rest_speed * dt;
        let layers = item.layers.as_deref().copied().unwrap_or_default();
        if !(asked
            || shared.wake_all
            || item.disturbed()
            || cloth_moving
            || item
                .scratch
                .rest
                .watch
                .scene_changed(shared.scene, layers, tolerance))
        {
            return true;
        }
        item.sleep.set_asleep(false);
        item.scratch.rest.watch.tick = None;
    }
    if asked || was_asleep {
        let rest = &mut item.scratch.rest;
        if rest.tracker.resting() {
            rest.watch.event = Some(Change::Woke);
        }
        rest.tracker.wake();
    }
    false
}

/// Stage 4: the scene's colliders the cloth may reach this step (its box
/// grown by its contact thickness and its reach, on its layers), into its
/// scratch; the contact thickness, m.
fn near_colliders(item: &mut StepQueryItem, scene: &ClothColliderScene, reach: &mut Reach) -> f32 {
    let thickness = item
        .collision
        .as_ref()
        .map_or(ClothCollision::default().thickness, |c| c.thickness);
    let contacts = &mut item.scratch.contacts;
    if !scene.colliders.is_empty() && thickness.is_finite() && thickness >= 0.0 {
        let p = &item.particles;
        let pad = thickness + reach.get(&p.velocities);
        let layers = item.layers.as_deref().copied().unwrap_or_default();
        contacts.select_near(scene, &p.positions, pad, layers);
    } else {
        contacts.clear_near();
    }
    thickness
}

/// Stage 5: the contact hook (colliders near, itself, tethers, other
/// cloths), the external forces (their mean over a combined step), the
/// guarded step over `dt` s of `steps` fixed steps, and the statistics.
fn integrate(
    item: &mut StepQueryItem,
    shared: &Shared,
    settings: &SimSettings,
    dt: f32,
    steps: u32,
    thickness: f32,
    generation: u64,
) {
    let connections: &ClothConnections = &item.connections;
    let scratch = &mut *item.scratch;
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
        .map(|scratch| NeighbourContacts {
            neighbours: &shared.obstacles.neighbours,
            scratch,
            contacts: 0,
            gravity: settings.gravity,
        });
    let contacts = &mut scratch.contacts;
    let any = !contacts.near().is_empty() || self_collision.is_some() || cloths.is_some();
    let in_solve = item.collision.as_ref().is_none_or(|c| c.in_solve);
    let mut hook = (any || tethers.is_some()).then(|| {
        let mut hook = SceneContacts::new(shared.scene, connections, thickness, contacts)
            .with_helper_thread(helper)
            .with_contacts_in_solve(in_solve)
            .with_self_collision(self_collision);
        hook.tethers = tethers;
        hook.cloths = cloths;
        hook
    });
    let external = mean_external(
        &mut item.particles,
        &item.forces.0,
        steps,
        &mut scratch.mean_forces,
    );
    let started = Instant::now();
    let step = step_guarded(
        StepInput::new(
            &mut item.particles,
            connections,
            settings,
            &mut scratch.buffers,
            &mut scratch.guard.state,
            dt,
        )
        .with_external(external)
        .with_contacts(hook.as_mut())
        .with_helper_thread(helper),
    );
    if let Some(hook) = hook {
        shared.totals.add(&hook);
    }
    let impulses = &mut scratch.contacts.feedback.impulses;
    if !impulses.is_empty() {
        let mut all = shared
            .feedback
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        all.append(impulses);
    }
    record(&mut item.stats, scratch, step, started, shared.now);
}

/// Stage 5, the external forces, N: as they are over one fixed step; over a
/// combined step of `steps`, their mean (in `mean`), with the pins moving
/// as far as over one fixed step (their velocities divided by `steps`).
fn mean_external<'a>(
    particles: &mut ClothParticles,
    external: &'a [Vec3],
    steps: u32,
    mean: &'a mut Vec<Vec3>,
) -> &'a [Vec3] {
    if steps <= 1 {
        return external;
    }
    let p = &mut particles.0;
    for (v, _) in p
        .velocities
        .iter_mut()
        .zip(&p.inverse_masses)
        .filter(|(_, w)| **w == 0.0)
    {
        *v /= steps as f32;
    }
    if !external.iter().any(|f| *f != Vec3::ZERO) {
        return external;
    }
    mean.clear();
    let share = 1.0 / steps as f32;
    mean.extend(external.iter().map(|f| *f * share));
    mean
}

/// Stage 5, what the step reports: its strain for the writeback to reuse,
/// its divergence to report, and the cloth's [`ClothStats`].
fn record(
    stats: &mut ClothStats,
    scratch: &mut ClothScratch,
    step: GuardedStep,
    started: Instant,
    now: Tick,
) {
    scratch.measured.strain = step.strain.map(|s| (now, s));
    scratch.guard.pending = step.report;
    stats.substeps = step.substeps;
    stats.integrator = step.integrator;
    stats.step_micros = started.elapsed().as_secs_f32() * 1e6;
    stats.solver_iterations = if step.integrator.is_implicit() {
        scratch.buffers.implicit.last_iterations
    } else {
        0
    };
}
