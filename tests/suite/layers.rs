//! Layered clothing: a cape worn over a skirt on a walking body, the cape
//! one layer above the skirt (`ClothToClothCollision::layer`), every
//! default.

use crate::common;

use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use bevy_cloth::ClothStats;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::collision::trimesh::closest_point_on_triangle;
use bevy_cloth::sim::grid::Faces;
use common::{app, closest, particles};

/// A skinned sheet of `rows` × `columns` vertices, every vertex on joint 0,
/// placed by `at(row, column)` (m); freedom 0 on row 0 (held to the
/// body), 1 below.
fn worn_mesh(rows: u32, columns: u32, closed: bool, at: impl Fn(u32, u32) -> Vec3) -> Mesh {
    let mut positions = Vec::new();
    let (mut joints, mut weights, mut freedom) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..rows {
        for i in 0..columns {
            positions.push(at(j, i).to_array());
            joints.push([0u16, 0, 0, 0]);
            weights.push([1.0f32, 0.0, 0.0, 0.0]);
            freedom.push(if j == 0 { 0.0f32 } else { 1.0 });
        }
    }
    let mut indices = Vec::new();
    let across = if closed { columns } else { columns - 1 };
    for j in 0..rows - 1 {
        for i in 0..across {
            let next = (i + 1) % columns;
            let (a, b) = (j * columns + i, j * columns + next);
            let (c, d) = (b + columns, a + columns);
            indices.extend([a, d, c, a, c, b]);
        }
    }
    Mesh::new(PrimitiveTopology::TriangleList, default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(
            Mesh::ATTRIBUTE_JOINT_INDEX,
            VertexAttributeValues::Uint16x4(joints),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT, weights)
        .with_inserted_attribute(ATTRIBUTE_FREEDOM, freedom)
        .with_inserted_indices(Indices::U32(indices))
}

/// A skirt: a flared tube of 10 rings of 24, from the waist (r 0.17 m at
/// y = 1 m) to the hem (r 0.34 m at y = 0.5 m).
fn skirt() -> Mesh {
    worn_mesh(10, 24, true, |j, i| {
        let t = j as f32 / 9.0;
        let (r, y) = (0.17 + 0.17 * t, 1.0 - 0.5 * t);
        let a = std::f32::consts::TAU * i as f32 / 24.0;
        Vec3::new(r * a.cos(), y, r * a.sin())
    })
}

/// A cape: 0.6 m wide, 0.9 m from the shoulders (y = 1.45 m, 0.2 m behind
/// the body's axis) down, held out behind the skirt (0.4 m behind the axis
/// at its hem) so that it falls onto the skirt's flare.
fn cape() -> Mesh {
    worn_mesh(13, 11, false, |j, i| {
        let t = j as f32 / 12.0;
        Vec3::new(-0.3 + 0.06 * i as f32, 1.45 - 0.9 * t, -0.2 - 0.2 * t)
    })
}

/// How many particles of the cape lie inside the skirt: nearer than 5 cm
/// to a skirt triangle, on the side of it towards the body's axis (through
/// `axis`, m, along y).
fn inside(app: &App, cape: Entity, skirt: Entity, axis: Vec3) -> usize {
    let x = &particles(app, cape).positions;
    let y = &particles(app, skirt).positions;
    let faces = app.world().get::<Cloth>(skirt).unwrap();
    x.iter()
        .filter(|&&p| {
            let nearest = faces
                .faces()
                .map(|tri| closest_point_on_triangle(p, tri.map(|q| y[q as usize])))
                .min_by(|a, b| a.distance(p).total_cmp(&b.distance(p)));
            nearest.is_some_and(|c| {
                let out = (c - axis) * Vec3::new(1.0, 0.0, 1.0);
                c.distance(p) < 0.05 && (p - c).dot(out) < 0.0
            })
        })
        .count()
}

/// Spawns `mesh` as a cloth worn by `body` (bind pose: identity), with
/// `contact` when given.
fn wear(
    app: &mut App,
    body: Entity,
    mesh: &Mesh,
    contact: Option<ClothToClothCollision>,
) -> Entity {
    let cloth = ClothBuilder::from_mesh(mesh).build().unwrap();
    let layout = cloth.cloth.mesh().unwrap().clone();
    let skin = ClothSkin::from_mesh(
        mesh,
        &layout,
        (vec![body], &[Mat4::IDENTITY]),
        ATTRIBUTE_FREEDOM.name,
        0.6,
    )
    .unwrap();
    let mut e = app.world_mut().spawn((cloth, skin));
    if let Some(contact) = contact {
        e.insert(contact);
    }
    e.id()
}

/// How far the body walks back and forth, m.
const AMPLITUDE: f32 = 0.4;

/// The body walks back and forth along z (up to 1.3 m/s) and turns (up to
/// 0.5 rad) for `seconds`; returns the smallest distance (m) between the
/// cape and the skirt after the first half second, the most cape particles
/// inside the skirt at once, and their largest strain.
fn walk(layered: bool, seconds: f32) -> (f32, usize, f32) {
    let mut app = app();
    app.world_mut()
        .spawn((ClothCollider::plane(), Transform::default()));
    let body = app.world_mut().spawn(Transform::default()).id();
    // The torso, for the cloths to rest against.
    app.world_mut().spawn((
        ClothCollider::capsule(0.15, 0.35),
        Transform::from_xyz(0.0, 1.05, 0.0),
        ChildOf(body),
    ));
    let contact = |layer| layered.then_some(ClothToClothCollision { layer, ..default() });
    let skirt = wear(&mut app, body, &skirt(), contact(0));
    let cape = wear(&mut app, body, &cape(), contact(1));
    let (mut least, mut most, mut strain) = (f32::MAX, 0, 0.0f32);
    let steps = (seconds * 60.0) as u32;
    for step in 0..steps {
        let t = step as f32 / 60.0;
        let phase = std::f32::consts::TAU * t / 2.0;
        if let Some(mut pose) = app.world_mut().get_mut::<Transform>(body) {
            pose.translation.z = AMPLITUDE * phase.sin() * (t / 0.5).min(1.0);
            pose.rotation = Quat::from_rotation_y(0.5 * (phase / 2.0).sin());
        }
        app.update();
        if step >= 30 && step % 3 == 0 {
            least = least.min(closest(&app, cape, skirt));
            let axis = app.world().get::<Transform>(body).unwrap().translation;
            most = most.max(inside(&app, cape, skirt, axis));
            for e in [cape, skirt] {
                let s = app.world().get::<ClothStats>(e).unwrap();
                assert!(s.finite, "step {step}: {s:?}");
                strain = strain.max(s.max_strain);
            }
        }
    }
    (least, most, strain)
}

#[test]
fn a_cape_over_a_skirt_stays_outside_it_while_the_body_walks() {
    let (least, most, strain) = walk(true, 4.0);
    println!("cape over skirt: closest {least} m, {most} cape particles inside, strain {strain}");
    let (bare, into, _) = walk(false, 4.0);
    println!("without: closest {bare} m, {into} cape particles inside");
    assert_eq!(most, 0, "cape particles inside the skirt");
    let thickness = ClothToClothCollision::default().thickness;
    assert!(
        least >= thickness / 2.0,
        "the cape came {least} m close to the skirt"
    );
    assert!(strain < 0.2, "strain {strain}");
    // Without it the cape falls into the skirt's flare.
    assert!(into > 10, "only {into} cape particles went into the skirt");
}
