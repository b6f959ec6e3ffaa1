//! [`ClothAnchors`]: pinned particles carried by other entities.

use bevy::math::Vec3;
use bevy::prelude::{
    Component, Entity, GlobalTransform, Query, Reflect, ReflectComponent, Res, Time,
};
use bevy::time::Fixed;

use crate::particles::ClothParticles;

/// One particle tied to an entity's [`GlobalTransform`].
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
/// particle is pinned (inverse mass 0) and given, for the duration of every
/// fixed step, the velocity that brings it to its target point by the step's
/// end; it is then placed exactly on that point and its velocity reset to 0.
/// The cloth feels the anchor's motion through its connections.
///
/// Anchors read `GlobalTransform`, which Bevy propagates in `PostUpdate`: a
/// `Transform` written in `Update` reaches the cloth one frame later.
///
/// An anchor whose target has no `GlobalTransform` (or was despawned) is
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
pub struct ClothAnchors(pub Vec<Anchor>);

impl ClothAnchors {
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

    /// Removes the anchor of `particle` (the particle stays pinned; unpin it
    /// with [`ClothParticles::unpin`] to let it fall).
    pub fn detach(&mut self, particle: u32) {
        self.0.retain(|a| a.particle != particle);
    }
}

/// [`ClothSystems::Prepare`](crate::schedule::ClothSystems::Prepare): pins
/// each anchored particle and gives it the velocity that reaches its target
/// point at the end of the fixed step.
pub(crate) fn follow_anchors(
    time: Res<Time<Fixed>>,
    targets: Query<&GlobalTransform>,
    mut cloths: Query<(&mut ClothAnchors, &mut ClothParticles)>,
) {
    let dt = time.timestep().as_secs_f32();
    for (mut anchors, mut particles) in &mut cloths {
        for anchor in &mut anchors.0 {
            anchor.goal = None;
            let p = anchor.particle as usize;
            let Ok(target) = targets.get(anchor.target) else {
                continue;
            };
            if p >= particles.len() {
                continue;
            }
            let offset = match anchor.offset {
                Some(offset) => offset,
                None => {
                    let local = target
                        .affine()
                        .inverse()
                        .transform_point3(particles.positions[p]);
                    if !local.is_finite() {
                        continue;
                    }
                    *anchor.offset.insert(local)
                }
            };
            let goal = target.transform_point(offset);
            if !goal.is_finite() {
                continue;
            }
            particles.inverse_masses[p] = 0.0;
            particles.velocities[p] = (goal - particles.positions[p]) / dt;
            anchor.goal = Some(goal);
        }
    }
}

/// [`ClothSystems::Writeback`](crate::schedule::ClothSystems::Writeback):
/// places anchored particles exactly on their targets, at rest until the
/// next step sets their velocity again (so a detached or orphaned pin stays
/// put instead of drifting).
pub(crate) fn snap_anchors(mut cloths: Query<(&ClothAnchors, &mut ClothParticles)>) {
    for (anchors, mut particles) in &mut cloths {
        for anchor in &anchors.0 {
            let p = anchor.particle as usize;
            if let Some(goal) = anchor.goal
                && p < particles.len()
            {
                particles.positions[p] = goal;
                particles.velocities[p] = Vec3::ZERO;
            }
        }
    }
}
