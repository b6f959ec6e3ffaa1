//! Collision between separate cloths ([`ClothToClothCollision`]).
//!
//! At the start of [`ClothSystems::Integrate`](crate::ClothSystems::Integrate)
//! every cloth that has the component is taken as a
//! [`ClothObstacle`]: its surface at the start of the step, its triangles
//! hashed over the step. Each cloth's step then holds its particles off the
//! obstacles near it, inside its own implicit solve
//! ([`sim::collision::cloths`](crate::sim::collision::cloths) has the
//! scheme), so cloths keep stepping independently and in parallel. Nothing
//! runs while no cloth has the component.

use bevy::log::warn_once;
use bevy::math::Vec3;
use bevy::prelude::*;
use bevy::time::Fixed;

use super::ClothContactLayers;
use crate::error::ClothError;
use crate::plugin::step::components::{Cloth, ClothParticles};
use crate::plugin::step::sleep::ClothSleep;
use crate::sim::collision::cloths::{ClothObstacle, Neighbour, NeighbourScratch, Pair};
use crate::sim::grid::Faces;

/// Opts a cloth into collision with the other cloths that have it (grid
/// and mesh cloths alike). Of two cloths that meet, the one of the higher
/// [`layer`](Self::layer) is kept `thickness` m off the other's surface
/// inside its own step (its particles off the other's triangles, its
/// triangles off the other's particles), and the other moves as if it were
/// not there.
///
/// Two cloths meet when their [`groups`](Self::groups) interact; a pair
/// keeps the larger of its two thicknesses and the mean of its frictions.
/// A sleeping cloth wakes when a cloth it is kept off moves near it.
/// Nothing runs while no cloth has the component.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) -> Result<(), ClothError> {
///     let below = ClothToClothCollision::default();
///     commands.spawn((ClothBuilder::new(24, 24).build()?, below));
///     // Falls onto the first and rests on it.
///     let above = ClothToClothCollision {
///         layer: 1,
///         ..default()
///     };
///     commands.spawn((
///         ClothBuilder::new(24, 24).position(Vec3::new(0.0, 0.3, 0.0)).build()?,
///         above,
///     ));
///     // A flag that meets only cloths in group 2.
///     let flag = ClothToClothCollision {
///         groups: ClothContactLayers::new(2, 2),
///         ..default()
///     };
///     commands.spawn((ClothBuilder::new(16, 10).build()?, flag));
///     Ok(())
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
#[require(ClothToClothScratch)]
pub struct ClothToClothCollision {
    /// Smallest distance kept between this cloth's surface and another's,
    /// m (> 0).
    pub thickness: f32,
    /// Coulomb friction coefficient μ against other cloths (≥ 0,
    /// dimensionless).
    pub friction: f32,
    /// Which cloths it meets: two meet when each one's `memberships` share
    /// a bit with the other's `filters`.
    pub groups: ClothContactLayers,
    /// Its place in the stack of cloths (dimensionless): of two cloths that
    /// meet, the one of the higher layer is kept off the other, which moves
    /// as if the first were not there. Layered clothing: a cape (layer 1)
    /// over a skirt (layer 0). Of two in one layer, the one with the larger
    /// [`Entity`] is kept off the other.
    pub layer: i32,
}

impl Default for ClothToClothCollision {
    fn default() -> Self {
        Self {
            thickness: 0.01,
            friction: 0.4,
            groups: ClothContactLayers::ALL,
            layer: 0,
        }
    }
}

impl ClothToClothCollision {
    /// Checks the thickness (finite, > 0 m) and friction (finite, ≥ 0).
    pub fn validate(&self) -> Result<(), ClothError> {
        let thick = self.thickness.is_finite() && self.thickness > 0.0;
        let rough = self.friction.is_finite() && self.friction >= 0.0;
        if thick && rough {
            Ok(())
        } else {
            Err(ClothError::InvalidClothContact {
                thickness: self.thickness,
                friction: self.friction,
            })
        }
    }
}

/// A colliding cloth's scratch: the cloths near it in this step and the
/// contact passes' lists.
#[derive(Component, Clone, Debug, Default, Deref, DerefMut)]
pub(crate) struct ClothToClothScratch(pub(crate) NeighbourScratch);

/// How much farther (m) than its particles' speeds and gravity carry it a
/// cloth looks for other cloths near it.
const NEIGHBOUR_MARGIN: f32 = 0.1;

/// Whose one colliding cloth of the step is, and how it collides.
#[derive(Clone, Debug)]
pub(crate) struct Owner {
    pub(crate) entity: Entity,
    pub(crate) contact: ClothToClothCollision,
    pub(crate) asleep: bool,
}

/// Every colliding cloth of the current step, as the others see it.
#[derive(Resource, Default)]
pub struct ClothObstacles {
    /// The cloths' surfaces over the step.
    pub(crate) neighbours: Vec<Neighbour>,
    /// Whose each one is.
    owners: Vec<Owner>,
    /// Surfaces kept for their allocations.
    spare: Vec<Neighbour>,
}

impl ClothObstacles {
    /// How many cloths take part in this step.
    pub fn len(&self) -> usize {
        self.neighbours.len()
    }

    /// Whether none does.
    pub fn is_empty(&self) -> bool {
        self.neighbours.is_empty()
    }

    /// Fills `scratch` for the cloth `entity` whose particles (at `x`, m)
    /// may move `reach` m this step: its own entry and the entries of the
    /// cloths it meets whose boxes come within it. Returns whether one of
    /// them is awake and moving faster than `rest_speed` m/s (it wakes a
    /// sleeping cloth).
    pub(crate) fn near(
        &self,
        entity: Entity,
        x: &[Vec3],
        reach: f32,
        rest_speed: f32,
        scratch: &mut ClothToClothScratch,
    ) -> bool {
        let (own, near) = &mut scratch.near;
        near.clear();
        *own = self.owners.iter().position(|o| o.entity == entity);
        let Some(me) = own.map(|i| &self.owners[i]) else {
            return false;
        };
        let mine = &me.contact;
        // Grown by a margin for what forces the step does not know of yet
        // may carry it (a gust on a light flag): a particle that ends the
        // step within the thickness of a neighbour is pushed out then.
        let (lo, hi) = super::bounds(x, reach + mine.thickness + NEIGHBOUR_MARGIN);
        let mut moving = false;
        for (k, (other, surface)) in self.owners.iter().zip(&self.neighbours).enumerate() {
            let theirs = &other.contact;
            let below = (theirs.layer, other.entity) < (mine.layer, entity);
            if !below
                || other.entity == entity
                || !mine.groups.interacts(theirs.groups)
                || !surface.obstacle.overlaps(lo, hi)
            {
                continue;
            }
            moving |= !other.asleep && surface.obstacle.speed > rest_speed;
            near.push((
                k,
                Pair {
                    thickness: mine.thickness.max(theirs.thickness),
                    friction: 0.5 * (mine.friction + theirs.friction),
                    rank: false,
                },
            ));
        }
        moving
    }
}

/// What the snapshot reads of a colliding cloth.
type ObstacleQuery = (
    Entity,
    &'static Cloth,
    &'static ClothParticles,
    &'static ClothToClothCollision,
    &'static ClothSleep,
);

/// Whether the snapshot has work: a cloth has the component, or last
/// step's entries are to be cleared.
pub(crate) fn obstacles_in_use(
    cloths: Query<(), With<ClothToClothCollision>>,
    obstacles: Res<ClothObstacles>,
) -> bool {
    !cloths.is_empty() || !obstacles.is_empty()
}

/// At the start of [`ClothSystems::Integrate`](crate::ClothSystems::Integrate):
/// every colliding cloth's surface at the start of the step. A cloth with a
/// non-finite position or velocity, or an invalid component (warned once),
/// is left out. A sleeping cloth's particles do not give way.
pub(crate) fn take_obstacles(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    cloths: Query<ObstacleQuery>,
    mut obstacles: ResMut<ClothObstacles>,
) {
    let dt = time.timestep().as_secs_f32();
    let ClothObstacles {
        neighbours,
        owners,
        spare,
    } = &mut *obstacles;
    spare.append(neighbours);
    owners.clear();
    let pad = cloths
        .iter()
        .map(|c| c.3.thickness)
        .filter(|t| t.is_finite())
        .fold(0.0, f32::max);
    let mut still = Vec::new();
    for (entity, cloth, particles, contact, sleep) in &cloths {
        if let Err(error) = contact.validate() {
            warn_once!("cloth {entity} does not collide with other cloths: {error}");
            continue;
        }
        let mut entry = spare.pop().unwrap_or_default();
        let asleep = sleep.is_asleep();
        let w = if asleep {
            still.clear();
            still.resize(particles.len(), 0.0);
            &still[..]
        } else {
            &particles.inverse_masses[..]
        };
        let p = (&particles.positions[..], &particles.velocities[..], w);
        let cell = cloth.cell_size();
        if ClothObstacle::take(cloth.faces(), p, (dt, pad, cell), &mut entry.obstacle).is_none() {
            spare.push(entry);
            continue;
        }
        entry
            .obstacle
            .set_generation(crate::sim::grid::Faces::generation(cloth));
        entry.cell = cell;
        neighbours.push(entry);
        owners.push(Owner {
            entity,
            contact: contact.clone(),
            asleep,
        });
    }
}
