//! A debug view drawn with Bevy's gizmos (feature `debug`):
//! [`ClothDebugPlugin`].
//!
//! It draws, for every cloth:
//! - the stretch links (Type 1), coloured by strain: green at rest, yellow
//!   at half of [`ClothDebug::strain_scale`], red from it up;
//! - pinned particles (white) and anchored ones (cyan);
//! - grabbed particles (magenta), with a line to their target;
//! - particles in contact with a collider (orange crosses);
//! - and every [`ClothCollider`]'s shape (grey).
//!
//! [`ClothDebug::toggle_key`] (`F3` by default) switches it on and off.
//!
//! ```no_run
//! # use bevy::prelude::*;
//! # use bevy_cloth::prelude::*;
//! App::new()
//!     .add_plugins((DefaultPlugins, ClothPlugin::default(), ClothDebugPlugin))
//!     .insert_resource(ClothDebug { enabled: true, ..default() })
//!     .run();
//! ```

use bevy::color::{Color, LinearRgba, Mix};
use bevy::gizmos::config::GizmoConfigGroup;
use bevy::gizmos::{AppGizmoBuilder, gizmos::Gizmos};
use bevy::input::ButtonInput;
use bevy::input::keyboard::KeyCode;
use bevy::math::{Affine3A, Isometry3d, Vec3};
use bevy::prelude::*;
use bevy::shape::{Capsule3d, Cone, Cylinder, Plane3d, Sphere};

use crate::plugin::collision::{ClothCollider, ClothCollision, ColliderShape, Shape};
use crate::plugin::interaction::grab::ClothGrabs;
use crate::plugin::step::components::ClothConnections;
use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::pose::WorldPose;
use crate::plugin::worn::anchor::ClothAnchors;

/// Adds the gizmo debug view; see [`ClothDebug`] for what it draws.
pub struct ClothDebugPlugin;

/// The gizmo group of the debug view (its line width and depth bias are set
/// through Bevy's `GizmoConfigStore`).
#[derive(Clone, Default, Reflect, GizmoConfigGroup)]
pub struct ClothGizmos;

/// What the debug view draws, and whether it is on.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct ClothDebug {
    /// Whether anything is drawn.
    pub enabled: bool,
    /// The key that toggles [`ClothDebug::enabled`] (`None`: no key).
    #[reflect(ignore)]
    pub toggle_key: Option<KeyCode>,
    /// Type 1 links coloured by strain.
    pub links: bool,
    /// The strain drawn fully red (dimensionless, > 0): 0.1 is 10 %.
    pub strain_scale: f32,
    /// Pinned and anchored particles.
    pub pins: bool,
    /// Grabbed particles and their targets.
    pub grabs: bool,
    /// Particles within twice the cloth's thickness of a collider.
    pub contacts: bool,
    /// Collider shapes.
    pub colliders: bool,
}

impl Default for ClothDebug {
    fn default() -> Self {
        Self {
            enabled: false,
            toggle_key: Some(KeyCode::F3),
            links: true,
            strain_scale: 0.1,
            pins: true,
            grabs: true,
            contacts: true,
            colliders: true,
        }
    }
}

/// How many gizmo primitives (lines, spheres, crosses, shapes) the debug
/// view drew in the last frame: 0 while it is off.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClothDebugDrawn(pub usize);

impl Plugin for ClothDebugPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ClothDebug>()
            .init_resource::<ClothDebugDrawn>()
            .register_type::<ClothDebug>()
            .init_gizmo_group::<ClothGizmos>()
            .add_systems(
                PostUpdate,
                (
                    toggle.run_if(resource_exists::<ButtonInput<KeyCode>>),
                    draw.run_if(|debug: Res<ClothDebug>| debug.enabled),
                    forget.run_if(|debug: Res<ClothDebug>| !debug.enabled),
                )
                    .chain(),
            );
    }
}

fn toggle(keys: Res<ButtonInput<KeyCode>>, mut debug: ResMut<ClothDebug>) {
    if debug.toggle_key.is_some_and(|key| keys.just_pressed(key)) {
        debug.enabled = !debug.enabled;
    }
}

fn forget(mut drawn: ResMut<ClothDebugDrawn>) {
    if drawn.0 != 0 {
        drawn.0 = 0;
    }
}

/// Green at no strain, yellow at half the scale, red from the scale up.
pub fn strain_colour(strain: f32, scale: f32) -> Color {
    let t = if strain.is_finite() && scale > 0.0 {
        (strain / scale).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let (green, yellow, red) = (
        LinearRgba::rgb(0.1, 0.8, 0.2),
        LinearRgba::rgb(0.9, 0.8, 0.1),
        LinearRgba::rgb(0.95, 0.1, 0.1),
    );
    let colour = if t < 0.5 {
        green.mix(&yellow, 2.0 * t)
    } else {
        yellow.mix(&red, 2.0 * t - 1.0)
    };
    colour.into()
}

/// What the debug view reads of one cloth.
type ClothView = (
    &'static ClothParticles,
    &'static ClothConnections,
    Option<&'static ClothAnchors>,
    Option<&'static ClothGrabs>,
    Option<&'static ClothCollision>,
);

fn draw(
    debug: Res<ClothDebug>,
    mut gizmos: Gizmos<ClothGizmos>,
    mut drawn: ResMut<ClothDebugDrawn>,
    cloths: Query<ClothView>,
    colliders: Query<(&ClothCollider, WorldPose)>,
) {
    let mut count = 0;
    let poses: Vec<(&ClothCollider, Affine3A)> = colliders
        .iter()
        .filter_map(|(c, pose)| Some((c, pose.affine()?)))
        .collect();
    for (particles, connections, anchors, grabs, collision) in &cloths {
        let x = &particles.positions;
        let valid = |i: u32| (i as usize) < x.len() && x[i as usize].is_finite();
        let radius = 0.25 * spacing(particles, connections);
        if debug.links {
            for link in connections.type1() {
                if !valid(link.a) || !valid(link.b) {
                    continue;
                }
                let (a, b) = (x[link.a as usize], x[link.b as usize]);
                let strain = (a.distance(b) - link.rest_length) / link.rest_length;
                gizmos.line(a, b, strain_colour(strain, debug.strain_scale));
                count += 1;
            }
        }
        if debug.pins {
            let anchored = |p: usize| {
                anchors.is_some_and(|a| a.anchors().iter().any(|a| a.particle as usize == p))
            };
            for (p, at) in x.iter().enumerate() {
                if particles.is_pinned(p) && at.is_finite() {
                    let colour = if anchored(p) {
                        Color::srgb(0.2, 0.9, 0.95)
                    } else {
                        Color::WHITE
                    };
                    gizmos.sphere(Isometry3d::from_translation(*at), radius, colour);
                    count += 1;
                }
            }
        }
        if debug.grabs
            && let Some(grabs) = grabs
        {
            let magenta = Color::srgb(0.95, 0.2, 0.9);
            for g in grabs.grabs() {
                if valid(g.particle) && g.target.is_finite() {
                    let at = x[g.particle as usize];
                    gizmos.sphere(Isometry3d::from_translation(at), 1.5 * radius, magenta);
                    gizmos.line(at, g.target, magenta);
                    count += 2;
                }
            }
        }
        if debug.contacts && !poses.is_empty() {
            let reach =
                2.0 * collision.map_or(ClothCollision::default().thickness, |c| c.thickness) + 1e-3;
            for at in x.iter().filter(|at| at.is_finite()) {
                if poses.iter().any(|(c, pose)| near(c, pose, *at, reach)) {
                    gizmos.cross(
                        Isometry3d::from_translation(*at),
                        radius,
                        Color::srgb(1.0, 0.55, 0.1),
                    );
                    count += 1;
                }
            }
        }
    }
    if debug.colliders {
        for (collider, pose) in &poses {
            count += draw_collider(&mut gizmos, collider, pose);
        }
    }
    drawn.0 = count;
}

/// A cloth's link rest length, m (a mean, for sizing markers).
fn spacing(particles: &ClothParticles, connections: &ClothConnections) -> f32 {
    let (sum, n) = connections
        .type1()
        .take(64)
        .fold((0.0, 0), |(s, n), l| (s + l.rest_length, n + 1));
    if n == 0 || particles.is_empty() {
        0.01
    } else {
        (sum / n as f32).clamp(1e-3, 1.0)
    }
}

/// Whether `at` (world, m) lies within `reach` (m) of the collider's surface
/// or inside it.
fn near(collider: &ClothCollider, pose: &Affine3A, at: Vec3, reach: f32) -> bool {
    let local = pose.inverse().transform_point3(at);
    match &collider.shape {
        ColliderShape::Analytic(shape) => shape.distance(local).0 < reach,
        ColliderShape::Mesh(mesh) => {
            let mut hit = false;
            let r = Vec3::splat(reach);
            mesh.0.query(local - r, local + r, |t| {
                let q = crate::sim::collision::trimesh::closest_point_on_triangle(
                    local,
                    mesh.0.triangles[t],
                );
                hit |= q.distance(local) < reach;
            });
            hit
        }
    }
}

/// Draws one collider's shape; returns the primitives drawn.
fn draw_collider(
    gizmos: &mut Gizmos<ClothGizmos>,
    collider: &ClothCollider,
    pose: &Affine3A,
) -> usize {
    let grey = Color::srgb(0.6, 0.6, 0.65);
    let (_, rotation, translation) = pose.to_scale_rotation_translation();
    let iso = Isometry3d::new(translation, rotation);
    match &collider.shape {
        ColliderShape::Analytic(shape) => {
            match *shape {
                Shape::Sphere { radius } => {
                    gizmos.primitive_3d(&Sphere::new(radius), iso, grey);
                }
                Shape::Plane => {
                    gizmos.primitive_3d(&Plane3d::default(), iso, grey);
                }
                Shape::Cuboid { half_extents } => {
                    gizmos.cube(
                        Transform::from_translation(translation)
                            .with_rotation(rotation)
                            .with_scale(2.0 * half_extents),
                        grey,
                    );
                }
                Shape::Capsule {
                    radius,
                    half_length,
                } => {
                    gizmos.primitive_3d(&Capsule3d::new(radius, 2.0 * half_length), iso, grey);
                }
                Shape::Cylinder {
                    radius,
                    half_height,
                } => {
                    gizmos.primitive_3d(&Cylinder::new(radius, 2.0 * half_height), iso, grey);
                }
                Shape::Cone {
                    radius,
                    half_height,
                } => {
                    gizmos.primitive_3d(&Cone::new(radius, 2.0 * half_height), iso, grey);
                }
            }
            1
        }
        ColliderShape::Mesh(mesh) => {
            // Edges of the first triangles only: a debug view, not a renderer.
            let mut lines = 0;
            for [a, b, c] in mesh.0.triangles.iter().take(20_000) {
                let [a, b, c] = [a, b, c].map(|v| pose.transform_point3(*v));
                gizmos.linestrip([a, b, c, a], grey);
                lines += 1;
            }
            lines
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strain_colours_run_green_to_red() {
        let at_rest: LinearRgba = strain_colour(0.0, 0.1).into();
        let far: LinearRgba = strain_colour(0.5, 0.1).into();
        assert!(at_rest.green > at_rest.red);
        assert!(far.red > far.green);
        assert_eq!(strain_colour(f32::NAN, 0.1), far.into());
    }
}
