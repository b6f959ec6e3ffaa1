//! [`ClothAnchors`]: pinned particles carried by other entities.

use bevy::math::Vec3;
use bevy::prelude::{Component, Entity, On, Query, Reflect, ReflectComponent, Remove, Res, Time};
use bevy::time::Fixed;

use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::pose::WorldPose;
use crate::plugin::step::sleep::ClothSleep;
use crate::sim::particles::PinOwner;

/// One particle tied to another entity's transform.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct Anchor {
    /// The carried particle's index.
    pub particle: u32,
    /// The entity that carries it (a pole, a hand, a table).
    pub target: Entity,
    /// The particle's position in the target's local space, in the target's
    /// units (m when unscaled). `None`: taken from where the particle is at
    /// the first step the target is seen.
    pub offset: Option<Vec3>,
    /// Where the particle must be at the end of this step (world, m).
    #[reflect(ignore)]
    goal: Option<Vec3>,
}

/// Particles of this cloth that follow other entities. Each anchored
/// particle is pinned (inverse mass 0) and given, every fixed step, the
/// velocity (m/s) that brings it to its target point by the step's end,
/// where it is then placed exactly. The cloth feels the anchor's motion
/// through its connections; detach a particle while its anchor moves and
/// it flies off with the anchor's velocity (a yank).
///
/// An anchor holds its particle's pin as [`PinOwner::Anchor`]. When it is
/// [`detach`](Self::detach)ed, or the component is removed, it lets go of
/// that pin: the particle flies on with the anchor's last velocity, or
/// stops (velocity 0) where another owner (the builder, a grab, the game)
/// still pins it. A particle whose target disappears stops, still pinned.
///
/// Targets are read where the cloth systems see them: a root entity's own
/// `Transform` (current even when moved in `FixedUpdate`), a child's
/// `GlobalTransform`.
///
/// An anchor whose target has no transform (or was despawned) is
/// skipped: its particle stays pinned where it is.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn hang_from(mut commands: Commands, pole: Entity) {
///     let cloth = ClothBuilder::new(15, 15).build().unwrap();
///     commands.spawn((cloth, ClothAnchors::default().with(0, pole).with(14, pole)));
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothAnchors(pub Vec<Anchor>, #[reflect(ignore)] Vec<u32>);

impl ClothAnchors {
    /// Follows a seam ([`ClothSew`](crate::plugin::tearing::sew::ClothSew)): each
    /// particle `p` becomes `map[p]`; of two anchors that now carry one
    /// particle, the first stays.
    pub(crate) fn remap(&mut self, map: &[u32]) {
        let at = |p: u32| map.get(p as usize).copied().unwrap_or(p);
        let mut seen = Vec::new();
        self.0.retain_mut(|a| {
            a.particle = at(a.particle);
            let first = !seen.contains(&a.particle);
            seen.push(a.particle);
            first
        });
        for p in &mut self.1 {
            *p = at(*p);
        }
        self.1.sort_unstable();
        self.1.dedup();
    }

    /// Adds particle `particle` carried by `target`, keeping its current
    /// offset from the target.
    pub fn with(mut self, particle: u32, target: Entity) -> Self {
        self.attach(particle, target, None);
        self
    }

    /// Adds particle `particle` carried by `target` at `offset` in the
    /// target's local space.
    pub fn with_offset(mut self, particle: u32, target: Entity, offset: Vec3) -> Self {
        self.attach(particle, target, Some(offset));
        self
    }

    /// Adds or replaces the anchor of `particle`.
    pub fn attach(&mut self, particle: u32, target: Entity, offset: Option<Vec3>) {
        self.detach(particle);
        self.0.push(Anchor {
            particle,
            target,
            offset,
            goal: None,
        });
    }

    /// Removes the anchor of `particle`. At the next step the anchor lets go
    /// of its pin: the particle flies on with the anchor's last velocity
    /// (m/s), or stops if another owner still pins it.
    pub fn detach(&mut self, particle: u32) {
        let before = self.0.len();
        self.0.retain(|a| a.particle != particle);
        if self.0.len() != before {
            self.1.push(particle);
        }
    }

    /// The anchors.
    pub fn anchors(&self) -> &[Anchor] {
        &self.0
    }
}

/// [`ClothSystems::Prepare`](crate::plugin::step::schedule::ClothSystems::Prepare): pins
/// each anchored particle and gives it the velocity that reaches its target
/// point at the end of the fixed step.
pub(crate) fn follow_anchors(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    targets: Query<WorldPose>,
    mut cloths: Query<(&mut ClothAnchors, &mut ClothParticles, &ClothSleep)>,
) {
    let dt = time.timestep().as_secs_f32();
    for (mut anchors, mut particles, sleep) in &mut cloths {
        // A sleeping cloth whose anchors are where it left them is left
        // alone (and asleep).
        if sleep.is_asleep() && anchors_still(&anchors, &particles, &targets) {
            continue;
        }
        let ClothAnchors(anchors, detached) = &mut *anchors;
        for p in detached.drain(..) {
            let_go(&mut particles, p);
        }
        for anchor in anchors.iter_mut() {
            anchor.goal = None;
            let p = anchor.particle as usize;
            if p >= particles.len() {
                continue;
            }
            let Some(target) = targets.get(anchor.target).ok().and_then(|t| t.affine()) else {
                stop_if_pinned(&mut particles, anchor.particle);
                continue;
            };
            let offset = match anchor.offset {
                Some(offset) => offset,
                None => {
                    let local = target.inverse().transform_point3(particles.positions[p]);
                    if !local.is_finite() {
                        continue;
                    }
                    *anchor.offset.insert(local)
                }
            };
            let goal = target.transform_point3(offset);
            if !goal.is_finite() {
                continue;
            }
            particles.pin_by(p, PinOwner::Anchor);
            particles.velocities[p] = (goal - particles.positions[p]) / dt;
            anchor.goal = Some(goal);
        }
    }
}

/// Whether every anchor of a cloth has its target and sits on it, with
/// nothing detached: the anchors would not move the cloth.
fn anchors_still(
    anchors: &ClothAnchors,
    particles: &ClothParticles,
    targets: &Query<WorldPose>,
) -> bool {
    anchors.1.is_empty()
        && anchors.0.iter().all(|anchor| {
            let p = anchor.particle as usize;
            let target = targets.get(anchor.target).ok().and_then(|t| t.affine());
            match (target, anchor.offset, particles.positions.get(p)) {
                (Some(target), Some(offset), Some(&x)) => target.transform_point3(offset) == x,
                // Out of range: the anchor does nothing.
                (_, _, None) => true,
                // Its target is gone: it only stops its pin.
                (None, _, Some(_)) => {
                    !particles.is_pinned(p) || particles.velocities[p] == Vec3::ZERO
                }
                (Some(_), None, Some(_)) => false,
            }
        })
}

/// [`ClothSystems::Writeback`](crate::plugin::step::schedule::ClothSystems::Writeback):
/// places anchored particles exactly on their targets (they keep the
/// anchor's velocity). Sleeping cloths are left alone.
pub(crate) fn snap_anchors(
    _main: crate::plugin::step::schedule::MainThread,
    mut cloths: Query<(&ClothAnchors, &mut ClothParticles, &ClothSleep)>,
) {
    for (anchors, mut particles, _) in cloths.iter_mut().filter(|c| !c.2.is_asleep()) {
        for anchor in &anchors.0 {
            if let (Some(goal), Some(x)) = (
                anchor.goal,
                particles.positions.get_mut(anchor.particle as usize),
            ) {
                *x = goal;
            }
        }
    }
}

/// Stops particle `p` if it is pinned (a pin left without its anchor).
fn stop_if_pinned(particles: &mut ClothParticles, p: u32) {
    if particles.is_pinned(p as usize) {
        particles.velocities[p as usize] = Vec3::ZERO;
    }
}

/// Lets go of the anchor's pin of particle `p`: free, it flies on with the
/// anchor's last velocity; still pinned by another owner, it stops.
fn let_go(particles: &mut ClothParticles, p: u32) {
    particles.release_pin(p as usize, PinOwner::Anchor);
    stop_if_pinned(particles, p);
}

/// When `ClothAnchors` is removed, its particles are let go as
/// [`ClothAnchors::detach`] lets one go.
pub(crate) fn stop_on_remove(
    trigger: On<Remove<ClothAnchors>>,
    mut cloths: Query<(&ClothAnchors, &mut ClothParticles)>,
) {
    if let Ok((anchors, mut particles)) = cloths.get_mut(trigger.entity) {
        for anchor in &anchors.0 {
            let_go(&mut particles, anchor.particle);
        }
    }
}
