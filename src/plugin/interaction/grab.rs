//! Grabbing particles from game code (no mouse needed): [`ClothGrabs`].
//!
//! A grab holds one particle and pulls it towards a world-space target,
//! either **kinematically** (the particle is pinned and moved to the target
//! over each fixed step, like an anchor) or through a **spring** (a force
//! `k(target − x) − c·v` in [`ClothForces`], MODEL.md §5b, as Lander's
//! mouse does). Pin and unpin live on [`ClothParticles`]; anchors that ride
//! on entities are [`ClothAnchors`](crate::ClothAnchors).
//!
//! ```
//! # use bevy::prelude::*;
//! # use bevy_cloth::prelude::*;
//! /// Drag the particle nearest a hand towards it, every frame.
//! fn pull(mut cloths: Query<(&ClothParticles, &mut ClothGrabs)>, hand: Single<&Transform, With<Camera>>) {
//!     for (particles, mut grabs) in &mut cloths {
//!         if grabs.is_empty() {
//!             grabs.grab_nearest(particles, hand.translation, GrabMode::Kinematic);
//!         }
//!         grabs.set_targets(hand.translation);
//!     }
//! }
//! ```

use bevy::math::Vec3;
use bevy::prelude::{Commands, Component, Entity, Query, Reflect, ReflectComponent, Res, Time};
use bevy::time::Fixed;

use crate::plugin::step::components::ClothForces;
use crate::plugin::step::components::{Cloth, ClothParticles};
use crate::plugin::step::events::{ClothGrabbed, ClothReleased};
use crate::sim::collision::trimesh::closest_point_on_triangle;
use crate::sim::grid::Faces;
use crate::sim::particles::PinOwner;

/// How a grab moves its particle.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum GrabMode {
    /// Pinned and carried to the target each fixed step (exact, infinitely
    /// stiff). On release a free particle keeps the velocity it was moving
    /// at (a flick); one that was pinned before the grab stays pinned, at
    /// rest, where the grab left it.
    Kinematic,
    /// A zero-rest-length spring to the target.
    Spring {
        /// Spring constant in N/m.
        stiffness: f32,
        /// Damping of the particle's velocity in N·s/m.
        damping: f32,
    },
}

/// One held particle.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct Grab {
    /// The held particle.
    pub particle: u32,
    /// Where it is pulled to, world space, m.
    pub target: Vec3,
    /// How.
    pub mode: GrabMode,
    /// Whether the grab has acted (and [`ClothGrabbed`] was triggered).
    held: bool,
}

/// The particles of this cloth held by the game or the player.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothGrabs {
    grabs: Vec<Grab>,
    /// The particles of released grabs that had acted, to let go and
    /// report at the next step.
    #[reflect(ignore)]
    released: Vec<u32>,
}

impl ClothGrabs {
    /// Follows a seam ([`ClothSew`](crate::plugin::tearing::sew::ClothSew)): each
    /// particle `p` becomes `map[p]`; of two grabs that now hold one
    /// particle, the first stays.
    pub(crate) fn remap(&mut self, map: &[u32]) {
        let at = |p: u32| map.get(p as usize).copied().unwrap_or(p);
        let mut seen = Vec::new();
        self.grabs.retain_mut(|g| {
            g.particle = at(g.particle);
            let first = !seen.contains(&g.particle);
            seen.push(g.particle);
            first
        });
        for p in &mut self.released {
            *p = at(*p);
        }
        self.released.sort_unstable();
        self.released.dedup();
    }

    /// Holds `particle` (replacing any grab of it) and pulls it to `target` (m).
    pub fn grab(&mut self, particle: u32, target: Vec3, mode: GrabMode) {
        self.release(particle);
        self.grabs.push(Grab {
            particle,
            target,
            mode,
            held: false,
        });
    }

    /// Holds the particle nearest `point` (m), pulling it to `point`.
    /// Returns its index (`None` for an empty cloth or a non-finite point).
    pub fn grab_nearest(
        &mut self,
        particles: &ClothParticles,
        point: Vec3,
        mode: GrabMode,
    ) -> Option<u32> {
        let p = nearest(particles, point)?;
        self.grab(p, point, mode);
        Some(p)
    }

    /// Moves the target of the grab of `particle`; `false` if it is not held.
    pub fn set_target(&mut self, particle: u32, target: Vec3) -> bool {
        match self.grabs.iter_mut().find(|g| g.particle == particle) {
            Some(g) => {
                g.target = target;
                true
            }
            None => false,
        }
    }

    /// Moves the target of every grab.
    pub fn set_targets(&mut self, target: Vec3) {
        for g in &mut self.grabs {
            g.target = target;
        }
    }

    /// Lets go of `particle`: at the next step a kinematic grab lets go of
    /// its pin ([`PinOwner::Grab`]), and the particle gets its mass back
    /// unless another owner (the builder, an anchor, the game) pins it too.
    pub fn release(&mut self, particle: u32) {
        let mut released = Vec::new();
        self.grabs.retain(|g| {
            if g.particle == particle {
                if g.held {
                    released.push(g.particle);
                }
                false
            } else {
                true
            }
        });
        self.released.extend(released);
    }

    /// Lets go of everything.
    pub fn release_all(&mut self) {
        for g in std::mem::take(&mut self.grabs) {
            if g.held {
                self.released.push(g.particle);
            }
        }
    }

    /// The current grabs.
    pub fn grabs(&self) -> &[Grab] {
        &self.grabs
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.grabs.is_empty()
    }
}

/// Index of the particle nearest `point` (m) among the corners of the
/// cloth's triangle nearest it: the particle a pointer hit on the surface
/// means. Where a tear has left a particle and its copy at one place, this
/// is the one of the piece that was hit, which [`nearest`] cannot tell.
/// A cloth with no triangle with finite corners falls back to [`nearest`].
pub fn nearest_on_surface(cloth: &Cloth, particles: &ClothParticles, point: Vec3) -> Option<u32> {
    if !point.is_finite() {
        return None;
    }
    let x = &particles.positions;
    let corners = |t: [u32; 3]| {
        let c = t.map(|p| x.get(p as usize).copied().unwrap_or(Vec3::NAN));
        c.iter().all(|p| p.is_finite()).then_some(c)
    };
    let hit = cloth
        .faces()
        .filter_map(|t| corners(t).map(|c| (t, c)))
        .map(|(t, c)| {
            (
                t,
                c,
                closest_point_on_triangle(point, c).distance_squared(point),
            )
        })
        .min_by(|a, b| a.2.total_cmp(&b.2));
    match hit {
        Some((t, c, _)) => (0..3)
            .min_by(|&i, &j| {
                c[i].distance_squared(point)
                    .total_cmp(&c[j].distance_squared(point))
            })
            .map(|i| t[i]),
        None => nearest(particles, point),
    }
}

/// Index of the particle nearest `point` (m).
pub fn nearest(particles: &ClothParticles, point: Vec3) -> Option<u32> {
    if !point.is_finite() {
        return None;
    }
    particles
        .positions
        .iter()
        .enumerate()
        .map(|(i, x)| (i, x.distance_squared(point)))
        .filter(|(_, d)| d.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i as u32)
}

/// Run condition of the grab systems: some cloth holds or has just let go
/// of a particle.
pub(crate) fn grabs_active(cloths: Query<&ClothGrabs>) -> bool {
    cloths
        .iter()
        .any(|g| !g.grabs.is_empty() || !g.released.is_empty())
}

/// [`ClothSystems::Forces`](crate::ClothSystems::Forces): kinematic grabs
/// take the velocity that reaches their target by the step's end; spring
/// grabs add their force. Triggers [`ClothGrabbed`] and [`ClothReleased`].
pub(crate) fn apply_grabs(
    _main: crate::plugin::step::schedule::MainThread,
    mut commands: Commands,
    time: Res<Time<Fixed>>,
    mut cloths: Query<(
        Entity,
        &mut ClothGrabs,
        &mut ClothParticles,
        &mut ClothForces,
    )>,
) {
    let dt = time.timestep().as_secs_f32();
    for (entity, mut grabs, mut particles, mut forces) in &mut cloths {
        // Nothing held or let go: no work, and nothing marked changed.
        if grabs.grabs.is_empty() && grabs.released.is_empty() {
            continue;
        }
        let n = particles.len();
        let ClothGrabs { grabs, released } = &mut *grabs;
        for p in released.drain(..) {
            // Free, it flies on with the grab's velocity; a pin another
            // owner holds stays where the grab left it, at rest.
            let i = p as usize;
            if particles.is_pinned_by(i, PinOwner::Grab) && particles.release_pin(i, PinOwner::Grab)
            {
                particles.velocities[i] = Vec3::ZERO;
            }
            commands.trigger(ClothReleased {
                entity,
                particle: p,
            });
        }
        for g in grabs.iter_mut() {
            let p = g.particle as usize;
            if p >= n || !g.target.is_finite() {
                continue;
            }
            if !g.held {
                g.held = true;
                commands.trigger(ClothGrabbed {
                    entity,
                    particle: g.particle,
                });
            }
            match g.mode {
                GrabMode::Kinematic => {
                    particles.pin_by(p, PinOwner::Grab);
                    particles.velocities[p] = (g.target - particles.positions[p]) / dt;
                }
                GrabMode::Spring { stiffness, damping } => {
                    let f = stiffness * (g.target - particles.positions[p])
                        - damping * particles.velocities[p];
                    if f.is_finite() {
                        forces.add(p, f, n);
                    }
                }
            }
        }
    }
}

/// [`ClothSystems::Writeback`](crate::ClothSystems::Writeback): kinematic
/// grabs sit exactly on their targets.
pub(crate) fn snap_grabs(
    _main: crate::plugin::step::schedule::MainThread,
    mut cloths: Query<(&ClothGrabs, &mut ClothParticles)>,
) {
    for (grabs, mut particles) in &mut cloths {
        for g in &grabs.grabs {
            let p = g.particle as usize;
            if g.mode == GrabMode::Kinematic && p < particles.len() && g.target.is_finite() {
                particles.positions[p] = g.target;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seam_moves_grabs_and_keeps_one_per_particle() {
        let mut grabs = ClothGrabs::default();
        grabs.grab(4, Vec3::X, GrabMode::Kinematic);
        grabs.grab(3, Vec3::Y, GrabMode::Kinematic);
        grabs.grab(0, Vec3::Z, GrabMode::Kinematic);
        // 3 is sewn onto 1 and 4 moves down to 3.
        grabs.remap(&[0, 1, 2, 1, 3]);
        let held: Vec<(u32, Vec3)> = grabs
            .grabs()
            .iter()
            .map(|g| (g.particle, g.target))
            .collect();
        assert_eq!(held, vec![(3, Vec3::X), (1, Vec3::Y), (0, Vec3::Z)]);
        // 1 sewn onto 0: of the two grabs now on 0, the first stays.
        grabs.remap(&[0, 0, 1, 2]);
        let held: Vec<(u32, Vec3)> = grabs
            .grabs()
            .iter()
            .map(|g| (g.particle, g.target))
            .collect();
        assert_eq!(held, vec![(2, Vec3::X), (0, Vec3::Y)]);
    }

    #[test]
    fn grab_release_and_nearest() {
        let particles = ClothParticles::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![1.0; 3]);
        let mut grabs = ClothGrabs::default();
        assert_eq!(
            grabs.grab_nearest(&particles, Vec3::new(0.9, 0.1, 0.0), GrabMode::Kinematic),
            Some(1)
        );
        assert_eq!(
            grabs.grab_nearest(&particles, Vec3::NAN, GrabMode::Kinematic),
            None
        );
        assert!(grabs.set_target(1, Vec3::ONE) && !grabs.set_target(2, Vec3::ONE));
        grabs.grab(1, Vec3::ZERO, GrabMode::Kinematic);
        assert_eq!(grabs.grabs().len(), 1);
        grabs.release(1);
        assert!(grabs.is_empty());
    }
}
