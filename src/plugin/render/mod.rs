//! What a cloth looks like: its live mesh ([`ClothMeshSettings`],
//! [`cloth_mesh`]), smooth normals ([`grid_normals`], [`face_normals`]) and,
//! with the render feature, a default double-sided material for a cloth
//! that has none.
//!
//! What it may import: the simulation and the rest of the plugin layer.

pub(crate) mod mesh;

pub use mesh::*;

#[cfg(feature = "render")]
pub(crate) use default_material::attach_default_material;

#[cfg(feature = "render")]
mod default_material {
    use bevy::asset::{Assets, Handle};
    use bevy::color::Color;
    use bevy::pbr::{MeshMaterial3d, StandardMaterial};
    use bevy::prelude::{Commands, Entity, Local, Query, ResMut, With, Without};

    use crate::plugin::step::Cloth;

    /// Gives cloths without a material a double-sided, unculled one, so the
    /// back of the cloth is lit and visible.
    pub(crate) fn attach_default_material(
        mut commands: Commands,
        materials: Option<ResMut<Assets<StandardMaterial>>>,
        mut handle: Local<Option<Handle<StandardMaterial>>>,
        cloths: Query<Entity, (With<Cloth>, Without<MeshMaterial3d<StandardMaterial>>)>,
    ) {
        let Some(mut materials) = materials else {
            return;
        };
        for entity in &cloths {
            let material = handle.get_or_insert_with(|| {
                materials.add(StandardMaterial {
                    base_color: Color::srgb(0.75, 0.2, 0.2),
                    perceptual_roughness: 0.9,
                    double_sided: true,
                    cull_mode: None,
                    ..Default::default()
                })
            });
            commands
                .entity(entity)
                .try_insert(MeshMaterial3d(material.clone()));
        }
    }
}
