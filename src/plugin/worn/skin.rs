//! [`ClothSkin`]: a mesh cloth worn on an animated skeleton. Each particle's
//! animated position comes from the skeleton's joints on the CPU, at the
//! fixed step (`crate::sim::skin`); particles painted 0 follow it
//! exactly, particles painted 1 are simulated, and those in between are
//! simulated within a maximum distance of it, scaled by their paint.

use bevy::asset::Assets;
use bevy::math::{Affine3A, Mat4, Vec3};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Mesh, MeshVertexAttribute, VertexAttributeValues, VertexFormat};
use bevy::prelude::{ChildOf, Component, Entity, Query, Res, Time, Transform};
use bevy::time::Fixed;

use crate::error::ClothError;
use crate::plugin::spawn::mesh_cloth::{MeshLayout, float_attribute};
use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::sleep::ClothSleep;
use crate::plugin::worn::tether::ClothTethers;
use crate::sim::particles::PinOwner;
pub use crate::sim::skin::{Backstop, Influence};
use crate::sim::skin::{limit_distance, push_out_of_capsule, skin};

/// A `Float32` vertex attribute named `"Cloth_Freedom"` for
/// [`ClothSkin::from_mesh`]: 0 follows the animation, 1 is simulated
/// freely, in between is simulated within that share of the maximum
/// distance.
pub const ATTRIBUTE_FREEDOM: MeshVertexAttribute = MeshVertexAttribute::new(
    "Cloth_Freedom",
    0x0c10_7b11_f4ee_2026,
    VertexFormat::Float32,
);

/// A cloth worn on a skinned mesh's skeleton: put it on a cloth made with
/// [`ClothBuilder::from_mesh`](crate::ClothBuilder::from_mesh) from the same
/// mesh.
///
/// Every fixed step, before the cloth is stepped, each particle's animated
/// position is skinned from the joints' transforms as Bevy's renderer
/// skins the mesh (`Σ wₖ Jₖ Bₖ`), with the joints' world transforms
/// composed from their `Transform`s up the hierarchy, so the cloth sees
/// this step's pose, not last frame's. Then:
///
/// - a particle of freedom 0 is pinned and carried to its animated
///   position, where it ends the step exactly;
/// - a particle of freedom `f` in `(0, 1)` is simulated and kept within
///   `f × max_distance` m of its animated position (as Unity's and Jolt's
///   max distance);
/// - a particle of freedom 1 is simulated freely.
///
/// On its first step every particle is placed at its animated position.
/// Worn cloth has tethers to its kinematic particles by default (a
/// [`ClothTethers`] is added with the skin unless the entity has one).
#[derive(Component, Clone, Debug, PartialEq)]
#[require(ClothSkinTargets, ClothTethers)]
pub struct ClothSkin {
    /// The skeleton's joint entities (a `SkinnedMesh`'s `joints`).
    pub joints: Vec<Entity>,
    /// Their inverse bind poses (a `SkinnedMeshInverseBindposes`).
    pub inverse_bindposes: Vec<Affine3A>,
    /// Each particle's position in the mesh's bind space, m.
    pub rest: Vec<Vec3>,
    /// Each particle's joints and weights.
    pub influences: Vec<Influence>,
    /// Each particle's freedom, in `[0, 1]` (see above).
    pub freedom: Vec<f32>,
    /// The distance (m) a particle of freedom 1 would be allowed; a
    /// particle of freedom `f < 1` is kept within `f` times it (0: no
    /// limit).
    pub max_distance: f32,
    /// Capsules around the bones that the simulated particles are kept
    /// outside of, posed at this step ([`with_backstop`](Self::with_backstop)).
    pub backstops: Vec<Backstop>,
}

impl ClothSkin {
    /// The skin of the cloth made from `mesh` (its `layout`): each particle
    /// takes the bind position, joints and weights of its first vertex
    /// (`ATTRIBUTE_JOINT_INDEX` as `Uint16x4`, `ATTRIBUTE_JOINT_WEIGHT` as
    /// `Float32x4`) and its freedom from the `Float32` attribute named
    /// `freedom` (such as [`ATTRIBUTE_FREEDOM`]). `joints` and
    /// `inverse_bindposes` are the skinned mesh's.
    ///
    /// Errors: [`ClothError::UnsupportedMesh`] for missing or mismatched
    /// attributes or bind poses.
    pub fn from_mesh(
        mesh: &Mesh,
        layout: &MeshLayout,
        (joints, inverse_bindposes): (Vec<Entity>, &[Mat4]),
        freedom: &str,
        max_distance: f32,
    ) -> Result<Self, ClothError> {
        let vertices = layout.topology().particle_of.len();
        let unsupported = ClothError::UnsupportedMesh;
        let Ok(VertexAttributeValues::Float32x3(positions)) =
            mesh.try_attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            return Err(unsupported("no Float32x3 positions"));
        };
        let Ok(VertexAttributeValues::Uint16x4(indices)) =
            mesh.try_attribute(Mesh::ATTRIBUTE_JOINT_INDEX)
        else {
            return Err(unsupported("no Uint16x4 joint indices"));
        };
        let Ok(VertexAttributeValues::Float32x4(weights)) =
            mesh.try_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT)
        else {
            return Err(unsupported("no Float32x4 joint weights"));
        };
        let paint = float_attribute(mesh, freedom)
            .ok_or(unsupported("no Float32 freedom attribute of that name"))?;
        if [positions.len(), indices.len(), weights.len(), paint.len()]
            .iter()
            .any(|&n| n != vertices)
        {
            return Err(unsupported("skin attributes and vertices differ in number"));
        }
        if joints.len() != inverse_bindposes.len()
            || indices
                .iter()
                .flatten()
                .any(|&j| j as usize >= joints.len())
        {
            return Err(unsupported("a joint index past the skin's joints"));
        }
        if !(max_distance.is_finite() && max_distance >= 0.0) {
            return Err(unsupported(
                "the max distance must be finite and not negative",
            ));
        }
        let n = layout.topology().len();
        let mut rest = vec![Vec3::ZERO; n];
        let mut influences = vec![Influence::default(); n];
        let mut free = vec![1.0; n];
        let mut seen = vec![false; n];
        for (v, p) in layout.topology().particle_of.iter().enumerate() {
            let Some(p) = p.map(|p| p as usize) else {
                continue;
            };
            if std::mem::replace(&mut seen[p], true) {
                continue;
            }
            rest[p] = Vec3::from_array(positions[v]);
            influences[p] = Influence {
                joints: indices[v],
                weights: weights[v],
            };
            free[p] = if paint[v].is_finite() {
                paint[v].clamp(0.0, 1.0)
            } else {
                1.0
            };
        }
        Ok(Self {
            joints,
            inverse_bindposes: inverse_bindposes
                .iter()
                .map(|m| Affine3A::from_mat4(*m))
                .collect(),
            rest,
            influences,
            freedom: free,
            max_distance,
            backstops: Vec::new(),
        })
    }

    /// [`from_mesh`](Self::from_mesh) with the joints and inverse bind
    /// poses of `skinned`, the `SkinnedMesh` that renders `mesh`.
    ///
    /// Errors: as `from_mesh`, and [`ClothError::UnsupportedMesh`] when the
    /// inverse bind poses are not in `bindposes` (not loaded yet).
    pub fn from_skinned_mesh(
        mesh: &Mesh,
        layout: &MeshLayout,
        (skinned, bindposes): (&SkinnedMesh, &Assets<SkinnedMeshInverseBindposes>),
        freedom: &str,
        max_distance: f32,
    ) -> Result<Self, ClothError> {
        let binds =
            bindposes
                .get(&skinned.inverse_bindposes)
                .ok_or(ClothError::UnsupportedMesh(
                    "the skin's inverse bind poses are not loaded",
                ))?;
        let joints = (skinned.joints.clone(), &binds[..]);
        Self::from_mesh(mesh, layout, joints, freedom, max_distance)
    }

    /// Adds a backstop: a capsule from `from` to `to` (m, in joint
    /// `joint`'s space; a sphere when they are equal) of radius `radius` m
    /// that the simulated particles stay outside of.
    pub fn with_backstop(mut self, joint: usize, (from, to): (Vec3, Vec3), radius: f32) -> Self {
        self.backstops.push(Backstop {
            joint,
            from,
            to,
            radius,
        });
        self
    }
}

/// This step's animated positions (m) and their velocities (m/s) of a
/// [`ClothSkin`]'s particles.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct ClothSkinTargets {
    /// Animated positions, m.
    pub positions: Vec<Vec3>,
    /// Their velocities over the last step, m/s.
    pub velocities: Vec<Vec3>,
    /// The joints' matrices `Jₖ Bₖ` of this step.
    joint_matrices: Vec<Affine3A>,
    /// The joints' world transforms of this step and of the last.
    joint_worlds: Vec<Affine3A>,
    joints_before: Vec<Affine3A>,
    /// Last step's animated positions.
    before: Vec<Vec3>,
}

/// The world transform of `entity`, composed from the `Transform`s up its
/// hierarchy (current even when they were changed in this fixed step).
fn world_of(
    entity: Entity,
    transforms: &Query<(&Transform, Option<&ChildOf>)>,
) -> Option<Affine3A> {
    let mut affine = Affine3A::IDENTITY;
    let mut at = entity;
    for _ in 0..256 {
        let (t, parent) = transforms.get(at).ok()?;
        affine = t.compute_affine() * affine;
        match parent {
            Some(p) => at = p.parent(),
            None => return Some(affine),
        }
    }
    None
}

/// [`ClothSystems::Prepare`](crate::ClothSystems::Prepare): skins each
/// cloth's animated positions for this step and carries the particles of
/// freedom 0 to them.
pub(crate) fn follow_skins(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    transforms: Query<(&Transform, Option<&ChildOf>)>,
    mut cloths: Query<(
        &ClothSkin,
        &mut ClothSkinTargets,
        &mut ClothParticles,
        &ClothSleep,
    )>,
) {
    let dt = time.timestep().as_secs_f32();
    for (skin_of, mut targets, mut particles, sleep) in &mut cloths {
        let n = particles.len();
        if skin_of.rest.len() != n || skin_of.influences.len() != n || skin_of.freedom.len() != n {
            continue;
        }
        // A sleeping cloth whose skeleton has not moved is left alone (and
        // asleep).
        if sleep.is_asleep()
            && targets.joint_worlds.len() == skin_of.joints.len()
            && skin_of
                .joints
                .iter()
                .zip(&targets.joint_worlds)
                .all(|(&joint, &was)| {
                    world_of(joint, &transforms).unwrap_or(Affine3A::IDENTITY) == was
                })
        {
            continue;
        }
        let targets = &mut *targets;
        targets.joint_matrices.clear();
        std::mem::swap(&mut targets.joints_before, &mut targets.joint_worlds);
        targets.joint_worlds.clear();
        for (&joint, bind) in skin_of.joints.iter().zip(&skin_of.inverse_bindposes) {
            let world = world_of(joint, &transforms).unwrap_or(Affine3A::IDENTITY);
            targets.joint_worlds.push(world);
            targets.joint_matrices.push(world * *bind);
        }
        std::mem::swap(&mut targets.before, &mut targets.positions);
        skin(
            &skin_of.rest,
            &skin_of.influences,
            &targets.joint_matrices,
            &mut targets.positions,
        );
        if !targets.positions.iter().all(|x| x.is_finite()) {
            targets.positions.clone_from(&targets.before);
            continue;
        }
        let first = targets.before.len() != n;
        targets.velocities.clear();
        if first {
            targets.velocities.resize(n, Vec3::ZERO);
        } else {
            targets.velocities.extend(
                targets
                    .positions
                    .iter()
                    .zip(&targets.before)
                    .map(|(a, b)| (*a - *b) / dt),
            );
        }
        let p = &mut particles.0;
        if first {
            p.positions.clone_from(&targets.positions);
            p.velocities.fill(Vec3::ZERO);
        }
        for i in 0..n {
            if skin_of.freedom[i] <= 0.0 {
                p.pin_by(i, PinOwner::Skin);
                p.velocities[i] = (targets.positions[i] - p.positions[i]) / dt;
            }
        }
    }
}

/// [`ClothSystems::Writeback`](crate::ClothSystems::Writeback): places the
/// particles of freedom 0 exactly on their animated positions, keeps the
/// others within their share of the max distance and outside the
/// backstops.
pub(crate) fn limit_skins(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    mut cloths: Query<(
        &ClothSkin,
        &ClothSkinTargets,
        &mut ClothParticles,
        &ClothSleep,
    )>,
    mut limits: bevy::prelude::Local<Vec<f32>>,
) {
    for (skin_of, targets, mut particles, _) in cloths.iter_mut().filter(|c| !c.3.is_asleep()) {
        let n = particles.len();
        if targets.positions.len() != n || skin_of.freedom.len() != n {
            continue;
        }
        let p = &mut particles.0;
        limits.clear();
        limits.extend(skin_of.freedom.iter().map(|&f| {
            if f > 0.0 && f < 1.0 {
                f * skin_of.max_distance
            } else {
                0.0
            }
        }));
        let target = (&targets.positions[..], &targets.velocities[..]);
        limit_distance(&mut p.positions, &mut p.velocities, target, &limits);
        let dt = time.timestep().as_secs_f32();
        for b in &skin_of.backstops {
            let (Some(now), Some(before)) = (
                targets.joint_worlds.get(b.joint),
                targets
                    .joints_before
                    .get(b.joint)
                    .or(targets.joint_worlds.get(b.joint)),
            ) else {
                continue;
            };
            let (a, c) = (now.transform_point3(b.from), now.transform_point3(b.to));
            let mid = 0.5 * (b.from + b.to);
            let surface_v = (now.transform_point3(mid) - before.transform_point3(mid)) / dt;
            let capsule = (a, c, b.radius);
            push_out_of_capsule(
                &mut p.positions,
                &mut p.velocities,
                &p.inverse_masses,
                capsule,
                surface_v,
            );
        }
        for i in 0..n {
            if skin_of.freedom[i] <= 0.0 {
                p.positions[i] = targets.positions[i];
            }
        }
    }
}
