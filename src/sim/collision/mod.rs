//! The narrow phase: particles against moving shapes and triangle meshes
//! over a step, the contacts the implicit solve holds, and the cloth
//! against itself. Plain functions over slices of positions (m) and
//! velocities (m/s).
//!
//! It may import the rest of [`sim`](crate::sim) and [`error`](crate::error);
//! the components that place colliders in a scene live in
//! [`plugin::collision`](crate::plugin::collision).

use bevy::math::Vec3;

pub(crate) mod ccd;
mod cells;
pub(crate) mod cloths;
pub mod contact;
pub(crate) mod edges;
pub(crate) mod narrow;
pub mod predict;
pub mod scene;
pub(crate) mod self_collision;
pub mod shapes;
pub mod trimesh;

pub use contact::Counts;
pub(crate) use self_collision::SelfCollisionBuffers;
pub use shapes::Shape;
pub use trimesh::TriMesh;

/// The box around `x` (m) grown by `pad` m.
pub fn bounds(x: &[Vec3], pad: f32) -> (Vec3, Vec3) {
    let (lo, hi) = x.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &p| {
        (lo.min(p), hi.max(p))
    });
    (lo - pad, hi + pad)
}
