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
use crate::sim::collision::cloths::{ClothObstacle, ObstacleBuffers, Pair};
use crate::sim::collision::scene::NearCloths;
use crate::sim::grid::Faces;
use crate::sim::integrate::implicit::SolveContact;

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

/// A colliding cloth's scratch: the obstacles near it in this step and the
/// contact passes' lists.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct ClothToClothScratch {
    /// Index into [`ClothObstacles`] of the cloth itself, and of each
    /// obstacle near it with the pair's contact.
    pub(crate) near: (Option<usize>, Vec<(usize, Pair)>),
    /// The passes' lists.
    pub(crate) buffers: ObstacleBuffers,
    /// The sum of the unit normals of the contacts listed for each particle
    /// in the substep: the colliders', then the other cloths' (the nearest).
    pub(crate) support: Vec<Vec3>,
    /// The contacts with other cloths of the last prediction, one a
    /// particle (the nearest), and the friction coefficient of each.
    pub(crate) held: Vec<(SolveContact, f32)>,
}

/// How much farther (m) than its particles' speeds and gravity carry it a
/// cloth looks for other cloths near it.
const NEIGHBOUR_MARGIN: f32 = 0.1;

/// One colliding cloth of the step.
#[derive(Clone, Debug, Default)]
pub(crate) struct ObstacleEntry {
    pub(crate) entity: Option<Entity>,
    pub(crate) contact: Option<ClothToClothCollision>,
    pub(crate) asleep: bool,
    pub(crate) obstacle: ClothObstacle,
    /// Side of the cloth's hash cells, m.
    pub(crate) cell: f32,
}

/// Every colliding cloth of the current step, as the others see it.
#[derive(Resource, Default)]
pub struct ClothObstacles {
    pub(crate) entries: Vec<ObstacleEntry>,
    /// Entries kept for their allocations.
    spare: Vec<ObstacleEntry>,
}

impl ClothObstacles {
    /// How many cloths take part in this step.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether none does.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
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
        *own = self.entries.iter().position(|e| e.entity == Some(entity));
        let Some(me) = own.map(|i| &self.entries[i]) else {
            return false;
        };
        let Some(mine) = me.contact.as_ref() else {
            return false;
        };
        // Grown by a margin for what forces the step does not know of yet
        // may carry it (a gust on a light flag): a particle that ends the
        // step within the thickness of a neighbour is pushed out then.
        let (lo, hi) = super::bounds(x, reach + mine.thickness + NEIGHBOUR_MARGIN);
        let mut moving = false;
        for (k, other) in self.entries.iter().enumerate() {
            let Some(theirs) = other.contact.as_ref() else {
                continue;
            };
            let below = (theirs.layer, other.entity) < (mine.layer, Some(entity));
            if !below
                || other.entity == Some(entity)
                || !mine.groups.interacts(theirs.groups)
                || !other.obstacle.overlaps(lo, hi)
            {
                continue;
            }
            moving |= !other.asleep && other.obstacle.speed > rest_speed;
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
    let ClothObstacles { entries, spare } = &mut *obstacles;
    spare.append(entries);
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
        entry.entity = Some(entity);
        entry.contact = Some(contact.clone());
        entry.asleep = asleep;
        entry.cell = cell;
        entries.push(entry);
    }
}

/// A cloth's contacts with other cloths during its step, called by the
/// integrators' contact hook
/// ([`SceneContacts`](super::SceneContacts)).
pub(crate) struct ClothContacts<'a> {
    /// Every colliding cloth of the step.
    pub(crate) obstacles: &'a ClothObstacles,
    /// The cloth's own entry and its neighbours ([`ClothToClothScratch`]).
    pub(crate) scratch: &'a mut ClothToClothScratch,
    /// Contacts listed and particles put back so far.
    pub(crate) contacts: u32,
    /// Gravity, m/s².
    pub(crate) gravity: Vec3,
}

impl ClothContacts<'_> {
    /// Seconds into the step at the substep's start and end.
    fn times(sub: crate::sim::step::Substep) -> (f32, f32) {
        let span = sub.to - sub.from;
        if span.is_nan() || span <= 0.0 {
            return (0.0, 0.0);
        }
        // The end as the contacts' prediction reckons it, to the bit.
        let from = sub.from * (sub.dt / span);
        (from, from + sub.dt)
    }
}

impl NearCloths for ClothContacts<'_> {
    /// Adds the contacts that hold the cloth (positions `x` m, velocities
    /// `v` m/s, inverse masses `w` 1/kg) off its neighbours over `sub`.
    fn predict(
        &mut self,
        sub: crate::sim::step::Substep,
        (x, v, w): (&[Vec3], &[Vec3], &[f32]),
        out: &mut Vec<crate::sim::integrate::implicit::SolveContact>,
    ) {
        let (Some(own), near) = &self.scratch.near else {
            return;
        };
        let me = &self.obstacles.entries[*own];
        if me.obstacle.x.len() != x.len() {
            return;
        }
        let generation = me.obstacle.generation();
        self.scratch.buffers.set_faces_generation(generation);
        let (from, _) = Self::times(sub);
        let before = out.len();
        self.scratch.held.clear();
        // What each particle lies on already (the colliders' contacts).
        let support = &mut self.scratch.support;
        support.clear();
        support.resize(x.len(), Vec3::ZERO);
        for c in &out[..before] {
            if let Some(s) = support.get_mut(c.particle as usize) {
                *s += c.normal;
            }
        }
        for &(k, pair) in near.iter() {
            let from_here = out.len();
            crate::sim::collision::cloths::predict_cloth_contacts(
                &me.obstacle.faces,
                (x, v, w),
                (from, sub.dt),
                me.cell,
                &self.obstacles.entries[k].obstacle,
                pair,
                &mut self.scratch.buffers,
                out,
            );
            crate::sim::collision::cloths::predict_edge_contacts(
                &me.obstacle.faces,
                (x, v, w),
                (from, sub.dt),
                &self.obstacles.entries[k].obstacle,
                pair,
                &mut self.scratch.buffers,
                out,
            );
            // A particle lying on a collider is not pressed into it by
            // another cloth: that cloth rests on this one instead (its own
            // particles are held off this one's triangles in its step).
            let support = &self.scratch.support;
            let mut kept = from_here;
            for i in from_here..out.len() {
                let c = out[i];
                if c.normal.dot(support[c.particle as usize]) >= 0.0 {
                    out[kept] = c;
                    kept += 1;
                }
            }
            out.truncate(kept);
            let held = &mut self.scratch.held;
            held.extend(out[from_here..].iter().map(|&c| (c, pair.friction)));
        }
        // One contact a particle for its friction: the nearest.
        let held = &mut self.scratch.held;
        held.sort_unstable_by(|a, b| {
            (a.0.particle.cmp(&b.0.particle)).then(a.0.gap.total_cmp(&b.0.gap))
        });
        held.dedup_by_key(|c| c.0.particle);
        for (c, _) in held.iter() {
            self.scratch.support[c.particle as usize] += c.normal;
        }
        self.contacts += (out.len() - before) as u32;
    }

    /// After a substep: puts back the particles and edges that passed
    /// through a neighbour (`start` → `x`, m; `v`, m/s; `w`, 1/kg; `held` by
    /// the solve, or empty).
    fn resolve(
        &mut self,
        sub: crate::sim::step::Substep,
        (start, x, v): (&[Vec3], &mut [Vec3], &mut [Vec3]),
        w: &[f32],
        held: &[crate::sim::integrate::implicit::Hold],
    ) {
        let (Some(own), near) = &self.scratch.near else {
            return;
        };
        let held_on = &self.scratch.held;
        crate::sim::collision::cloths::rub(held_on, v, held, (self.gravity, sub.dt));
        let me = &self.obstacles.entries[*own].obstacle;
        self.scratch.buffers.set_faces_generation(me.generation());
        let faces = &me.faces;
        // What each particle lies on: its contacts' normals, colliders' and
        // other cloths' (none without the implicit solve).
        let support = if held.len() == x.len() && self.scratch.support.len() == x.len() {
            &self.scratch.support[..]
        } else {
            &[]
        };
        for &(k, pair) in near.iter() {
            let other = &self.obstacles.entries[k].obstacle;
            self.contacts += crate::sim::collision::cloths::undo_crossings(
                start,
                x,
                v,
                w,
                held,
                Self::times(sub),
                other,
                pair,
                &mut self.scratch.buffers,
            );
            self.contacts += crate::sim::collision::cloths::undo_edge_crossings(
                faces,
                start,
                x,
                v,
                w,
                (held, support),
                Self::times(sub),
                other,
                pair,
                &mut self.scratch.buffers,
            );
        }
    }

    fn contacts(&self) -> u32 {
        self.contacts
    }
}
