//! Mesh cloths in an app: built with `ClothBuilder::from_mesh`, stepped
//! with the defaults and every integrator, rendered with their UVs and
//! smooth normals, blown by wind, kept apart by self-collision, grabbed,
//! pinned and anchored.

use crate::common;

use bevy::ecs::message::Messages;
use bevy::mesh::{MeshBuilder, Meshable, VertexAttributeValues};
use bevy::prelude::*;
use bevy::shape::{Circle, Sphere};
use bevy_cloth::plugin::step::ClothDiverged;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::connections::max_strain;
use common::{app, app_with_meshes, disc_mesh, jittered_disc, particles, triangle_mesh};

/// The Float32x3 attribute `attribute` of cloth `e`'s live mesh.
fn live(app: &App, e: Entity, attribute: bevy::mesh::MeshVertexAttribute) -> Vec<Vec3> {
    let handle = &app.world().get::<Mesh3d>(e).expect("a live mesh").0;
    let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
    match mesh.attribute(attribute) {
        Some(VertexAttributeValues::Float32x3(v)) => {
            v.iter().map(|p| Vec3::from_array(*p)).collect()
        }
        _ => panic!("no {attribute:?}"),
    }
}

fn strain(app: &App, e: Entity) -> f32 {
    let connections = app.world().get::<ClothConnections>(e).unwrap();
    max_strain(connections.type1(), &particles(app, e).positions)
}

#[test]
fn a_disc_pinned_at_its_centre_falls_like_an_umbrella_and_its_mesh_follows() {
    let mut app = app_with_meshes();
    let mesh = disc_mesh(8, 0.5, 0.4);
    let cloth = ClothBuilder::from_mesh(&mesh)
        .position(Vec3::Y)
        .pin_vertex(0)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    for _ in 0..90 {
        app.update();
    }
    let p = particles(&app, e);
    assert!(p.is_finite());
    let rim_mean = p.positions[p.len() - 48..].iter().map(|x| x.y).sum::<f32>() / 48.0;
    assert!(rim_mean < 0.8, "the rim fell to {rim_mean} m");
    assert!(strain(&app, e) < 0.05, "strain {}", strain(&app, e));
    // The live mesh: the source's vertices at their particles' positions,
    // its UVs kept, smooth unit normals, the centre's pointing up.
    let layout = app.world().get::<Cloth>(e).unwrap().layout().clone();
    let shown = live(&app, e, Mesh::ATTRIBUTE_POSITION);
    assert_eq!(shown.len(), mesh.count_vertices());
    for (x, &q) in shown.iter().zip(layout.vertex_particles()) {
        assert_eq!(*x, p.positions[q as usize]);
    }
    let normals = live(&app, e, Mesh::ATTRIBUTE_NORMAL);
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
    assert!(normals[0].y > 0.95, "centre normal {}", normals[0]);
    let handle = &app.world().get::<Mesh3d>(e).unwrap().0;
    let rendered = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
    assert_eq!(
        rendered
            .attribute(Mesh::ATTRIBUTE_UV_0)
            .map(|a| a.get_bytes().to_vec()),
        mesh.attribute(Mesh::ATTRIBUTE_UV_0)
            .map(|a| a.get_bytes().to_vec())
    );
    assert_eq!(
        rendered.indices().unwrap().len(),
        mesh.indices().unwrap().len()
    );
}

#[test]
fn a_sphere_cut_open_keeps_its_seam_closed_as_it_falls() {
    // The upper half of a UV sphere: a dome whose seam's two columns of
    // vertices (with different UVs) weld into one column of particles.
    let sphere = Sphere::new(0.4).mesh().uv(24, 12);
    let Some(VertexAttributeValues::Float32x3(x)) = sphere.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        panic!("positions")
    };
    let x: Vec<Vec3> = x.iter().map(|p| Vec3::from_array(*p)).collect();
    let indices: Vec<u32> = sphere
        .indices()
        .unwrap()
        .iter()
        .map(|i| i as u32)
        .collect::<Vec<_>>()
        .chunks(3)
        .filter(|t| t.iter().all(|&i| x[i as usize].y > -1e-4))
        .flatten()
        .copied()
        .collect();
    let mut dome = sphere.clone();
    dome.insert_indices(bevy::mesh::Indices::U32(indices));
    let mut app = app_with_meshes();
    let cloth = ClothBuilder::from_mesh(&dome)
        .position(Vec3::Y)
        .pin_where(|rest| rest.y > 0.399)
        .build()
        .unwrap();
    let particles_count = cloth.particles.len();
    let e = app.world_mut().spawn(cloth).id();
    let layout = app.world().get::<Cloth>(e).unwrap().layout().clone();
    assert!(
        layout.vertex_particles().len() > particles_count,
        "the seam welded"
    );
    for _ in 0..60 {
        app.update();
    }
    assert!(particles(&app, e).is_finite());
    assert!(strain(&app, e) < 0.05, "strain {}", strain(&app, e));
    // Vertices of one particle (the seam's two sides) show at one place
    // with one normal: no crack, no lighting seam.
    let shown = live(&app, e, Mesh::ATTRIBUTE_POSITION);
    let normals = live(&app, e, Mesh::ATTRIBUTE_NORMAL);
    let mut first = vec![None; particles_count];
    let mut shared = 0;
    for (v, &p) in layout.vertex_particles().iter().enumerate() {
        match first[p as usize] {
            None => first[p as usize] = Some(v),
            Some(w) => {
                assert_eq!(shown[v], shown[w]);
                assert_eq!(normals[v], normals[w]);
                shared += 1;
            }
        }
    }
    assert!(shared >= 6, "{shared} seam vertices");
}

/// Drops an irregular 0.6 m disc on a 0.3 m ball at the origin with the
/// defaults and `integrator`; returns the worst strain after 1 s, the
/// deepest penetration (m) and the middle's height (m) after 3 s.
fn drape(integrator: Integrator) -> (f32, f32, f32) {
    let mut app = app();
    let cloth = ClothBuilder::from_mesh(&disc_mesh(12, 0.6, 0.5))
        .position(Vec3::new(0.0, 0.4, 0.0))
        .build_with(ClothSettings::default().with_integrator(integrator, 1))
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    app.world_mut()
        .spawn((ClothCollider::sphere(0.3), Transform::default()));
    let (mut worst, mut deepest) = (0.0f32, 0.0f32);
    for step in 0..180 {
        app.update();
        let p = particles(&app, e);
        assert!(
            p.is_finite(),
            "{integrator:?} left the finite at step {step}"
        );
        if step >= 60 {
            worst = worst.max(strain(&app, e));
        }
        let inside = p
            .positions
            .iter()
            .map(|x| 0.3 - x.length())
            .fold(0.0, f32::max);
        deepest = deepest.max(inside);
    }
    (worst, deepest, particles(&app, e).positions[0].y)
}

#[test]
fn every_integrator_drapes_an_irregular_disc_on_a_ball_with_the_defaults() {
    for integrator in [
        Integrator::ExplicitEuler,
        Integrator::SymplecticEuler,
        Integrator::Rk4,
        Integrator::BackwardEuler,
        Integrator::Bdf2,
    ] {
        let (worst, deepest, middle) = drape(integrator);
        eprintln!(
            "{integrator:?}: strain after 1 s ≤ {:.2} %, deepest {:.1} mm, middle at {middle:.3} m",
            100.0 * worst,
            1000.0 * deepest
        );
        assert!(worst < 0.05, "{integrator:?}: strain {worst}");
        assert!(
            deepest < 0.01,
            "{integrator:?}: {deepest} m inside the ball"
        );
        assert!(
            (middle - 0.3).abs() < 0.02,
            "{integrator:?}: middle at {middle} m"
        );
    }
}

/// A pennant: a triangle 1.2 m long and 0.6 m high at its hoist, in the
/// xy plane, as an irregular triangle mesh.
fn pennant() -> Mesh {
    let (cols, rows) = (16u32, 9u32);
    let mut positions = Vec::new();
    let mut index = vec![vec![0u32; rows as usize]; cols as usize];
    for i in 0..cols {
        let x = 1.2 * i as f32 / (cols - 1) as f32;
        let half = 0.3 * (1.0 - x / 1.2) + 0.002;
        for j in 0..rows {
            index[i as usize][j as usize] = positions.len() as u32;
            let y = half * (2.0 * j as f32 / (rows - 1) as f32 - 1.0);
            positions.push(Vec3::new(x, y, 0.0));
        }
    }
    let mut indices = Vec::new();
    for i in 0..cols as usize - 1 {
        for j in 0..rows as usize - 1 {
            let (a, b) = (index[i][j], index[i + 1][j]);
            let (c, d) = (index[i + 1][j + 1], index[i][j + 1]);
            // Alternate the diagonal, as a modeller's triangulation might.
            if (i + j) % 2 == 0 {
                indices.extend([a, b, c, a, c, d]);
            } else {
                indices.extend([a, b, d, b, c, d]);
            }
        }
    }
    triangle_mesh(&positions, indices)
}

/// How far (m, along the wind) the pennant's fly end moves in 2 s of
/// 8 m/s wind from `direction`.
fn pennant_blown(direction: Vec3) -> f32 {
    let mut app = app();
    app.insert_resource(ClothWind(Wind {
        velocity: direction * 8.0,
        ..default()
    }));
    let cloth = ClothBuilder::from_mesh(&pennant())
        .position(Vec3::new(0.0, 2.0, 0.0))
        .pin_where(|rest| rest.x < 1e-3)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    let tip = particles(&app, e)
        .positions
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.x.total_cmp(&b.1.x))
        .unwrap()
        .0;
    let start = particles(&app, e).positions[tip];
    for _ in 0..120 {
        app.update();
    }
    assert!(particles(&app, e).is_finite());
    (particles(&app, e).positions[tip] - start).dot(direction)
}

#[test]
fn wind_acts_per_face_on_a_mesh_pennant() {
    let face_on = pennant_blown(Vec3::Z);
    let edge_on = pennant_blown(Vec3::Y.cross(Vec3::Z));
    eprintln!("pennant, 8 m/s for 2 s: face-on {face_on:.3} m, along its length {edge_on:.4} m");
    assert!(face_on > 0.2, "face-on moved {face_on} m");
    assert!(edge_on.abs() < 0.5 * face_on, "edge-on moved {edge_on} m");
}

/// One mesh of two irregular discs, the upper `shift` m from the lower:
/// the lower pinned flat at y = 0, the upper thrown down at 2 m/s without
/// gravity. Returns the upper disc's lowest height over 0.5 s.
fn layers(self_collision: bool, shift: Vec3) -> f32 {
    let (lower, indices) = jittered_disc(6, 0.4, 0.5);
    let n = lower.len() as u32;
    let mut positions = lower.clone();
    positions.extend(lower.iter().map(|p| *p + shift));
    let mut all = indices.clone();
    all.extend(indices.iter().map(|i| i + n));
    let mut cloth = ClothBuilder::from_mesh(&triangle_mesh(&positions, all))
        .pin_where(|rest| rest.y < 0.05)
        .build()
        .unwrap();
    for v in &mut cloth.particles.velocities[n as usize..] {
        *v = Vec3::new(0.0, -2.0, 0.0);
    }
    let settings = ClothSettings(SimSettings {
        gravity: Vec3::ZERO,
        ..default()
    });
    let mut app = app();
    let mut entity = app.world_mut().spawn((cloth, settings));
    if self_collision {
        entity.insert(ClothSelfCollision { thickness: 0.02 });
    }
    let e = entity.id();
    let mut lowest = f32::MAX;
    for _ in 0..30 {
        app.update();
        let x = &particles(&app, e).positions;
        lowest = x[n as usize..].iter().map(|p| p.y).fold(lowest, f32::min);
    }
    lowest
}

#[test]
fn self_collision_keeps_the_layers_of_a_mesh_cloth_apart() {
    // Shifted sideways, and exactly above (every upper particle lands on a
    // lower one, in the plane of its triangles, after three steps).
    for shift in [Vec3::new(0.013, 0.1, 0.021), Vec3::new(0.0, 0.1, 0.0)] {
        let with = layers(true, shift);
        let without = layers(false, shift);
        eprintln!(
            "upper layer at {shift} m: lowest {with:.4} m with self-collision, {without:.4} m without"
        );
        assert!(with > 0.01, "with self-collision it reached {with} m");
        assert!(
            without < -0.05,
            "without it should pass through, got {without} m"
        );
    }
}

#[test]
fn grabs_pins_and_anchors_act_on_a_mesh_cloth() {
    let mut app = app();
    let cloth = ClothBuilder::from_mesh(&disc_mesh(6, 0.5, 0.5))
        .position(Vec3::Y)
        .pin_vertex(0)
        .build()
        .unwrap();
    let rim = cloth.particles.len() as u32 - 1;
    let e = app.world_mut().spawn(cloth).id();
    // A kinematic grab carries a rim particle to its target.
    let target = Vec3::new(0.7, 1.2, 0.0);
    let mut grabs = app.world_mut().get_mut::<ClothGrabs>(e).unwrap();
    grabs.grab(rim, target, GrabMode::Kinematic);
    for _ in 0..30 {
        app.update();
    }
    assert!(particles(&app, e).positions[rim as usize].distance(target) < 1e-4);
    // Released, it falls.
    app.world_mut()
        .get_mut::<ClothGrabs>(e)
        .unwrap()
        .release(rim);
    for _ in 0..30 {
        app.update();
    }
    assert!(particles(&app, e).positions[rim as usize].y < 1.1);
    // Unpinned, the centre falls too.
    app.world_mut()
        .get_mut::<ClothParticles>(e)
        .unwrap()
        .unpin(0);
    for _ in 0..10 {
        app.update();
    }
    assert!(particles(&app, e).positions[0].y < 0.99);
    // Anchored to a moving entity, a particle follows it exactly.
    let holder = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 2.0, 0.0))
        .id();
    app.world_mut()
        .entity_mut(e)
        .insert(ClothAnchors::default().with_offset(0, holder, Vec3::ZERO));
    for k in 0..30 {
        let to = Vec3::new(0.01 * k as f32, 2.0, 0.0);
        app.world_mut()
            .get_mut::<Transform>(holder)
            .unwrap()
            .translation = to;
        app.update();
    }
    let held = particles(&app, e).positions[0];
    assert!(
        held.distance(Vec3::new(0.29, 2.0, 0.0)) < 0.011,
        "anchored at {held}"
    );
    assert!(particles(&app, e).is_finite());
}

#[test]
fn a_4000_vertex_disc_in_a_storm_stays_whole_with_the_defaults() {
    let mut app = app();
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(25.0, 0.0, 8.0),
        gust_amplitude: 0.6,
        gust_frequency: 1.5,
        ..default()
    }));
    let mesh = disc_mesh(36, 1.0, 0.5);
    assert_eq!(mesh.count_vertices(), 3997);
    let cloth = ClothBuilder::from_mesh(&mesh)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .pin_where(|rest| rest.x < -0.8)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    let (mut worst, mut trips) = (0.0f32, 0);
    for _ in 0..180 {
        app.update();
        trips += app
            .world()
            .resource::<Messages<ClothDiverged>>()
            .iter_current_update_messages()
            .count();
        assert!(particles(&app, e).is_finite());
        worst = worst.max(strain(&app, e));
    }
    eprintln!(
        "storm (26 m/s ± 60 %) on a 3,997-particle disc, 3 s: strain ≤ {:.1} %, {trips} trips",
        100.0 * worst
    );
    assert_eq!(trips, 0);
    assert!(worst < 0.3, "strain {worst}");
}

#[test]
fn a_crease_on_a_mesh_cloth_folds_it_and_one_that_misses_changes_nothing() {
    let mut app = app();
    let triangle = triangle_mesh(
        &[
            Vec3::ZERO,
            Vec3::new(0.3, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.3),
        ],
        vec![0, 2, 1],
    );
    // From the disc's centre out to its rim, in its rest xz plane; beside
    // it; across a lone triangle, which has no Type 2 link to fold.
    let across = Crease::new(Vec2::new(0.0, 0.0), Vec2::new(0.5, 0.5));
    let beside = Crease::new(Vec2::new(2.0, 2.0), Vec2::new(3.0, 3.0));
    for (mesh, crease, folds) in [
        (disc_mesh(4, 0.5, 0.0), across, true),
        (disc_mesh(4, 0.5, 0.0), beside, false),
        (
            triangle,
            Crease::new(Vec2::new(0.1, -0.1), Vec2::new(0.1, 0.4)),
            false,
        ),
    ] {
        let cloth = ClothBuilder::from_mesh(&mesh).build().unwrap();
        let before = cloth.connections.clone();
        let e = app.world_mut().spawn(cloth).id();
        app.world_mut()
            .entity_mut(e)
            .insert(ClothCreases(vec![crease]));
        app.update();
        let after = app.world().get::<ClothConnections>(e).unwrap();
        assert_eq!(after.structural, before.structural);
        assert_eq!(after.shear, before.shear);
        if folds {
            assert!(!after.crease.is_empty());
            assert_ne!(after.bend, before.bend);
        } else {
            assert_eq!(*after, before);
        }
        assert!(common::particles(&app, e).is_finite());
    }
}

#[test]
fn one_triangle_and_a_fan_of_slivers_are_cloths_too() {
    let mut app = app_with_meshes();
    // One triangle, pinned at a corner; Bevy's circle, a fan of 32 slivers
    // around one centre vertex, pinned at the centre.
    let triangle = triangle_mesh(
        &[
            Vec3::ZERO,
            Vec3::new(0.3, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.3),
        ],
        vec![0, 2, 1],
    );
    let fan = Circle::new(0.4).mesh().resolution(32).build();
    let cloths = [
        ClothBuilder::from_mesh(&triangle)
            .position(Vec3::Y)
            .pin_vertex(0)
            .build()
            .unwrap(),
        ClothBuilder::from_mesh(&fan)
            .rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
            .position(Vec3::Y)
            .pin_where(|rest| rest.length() < 1e-3)
            .build()
            .unwrap(),
    ];
    let entities: Vec<Entity> = cloths.map(|c| app.world_mut().spawn(c).id()).to_vec();
    for _ in 0..120 {
        app.update();
    }
    for e in entities {
        let p = particles(&app, e);
        assert!(p.is_finite());
        assert!(strain(&app, e) < 0.05, "strain {}", strain(&app, e));
        // The free corners hang below the pin.
        let lowest = p.positions.iter().map(|x| x.y).fold(f32::MAX, f32::min);
        assert!(lowest < 0.8, "lowest at {lowest} m");
        assert!(live(&app, e, Mesh::ATTRIBUTE_POSITION).len() >= 3);
    }
}

#[test]
fn a_mesh_cloth_fed_nan_and_flicked_at_50_m_s_recovers() {
    let mut app = app();
    let cloth = ClothBuilder::from_mesh(&disc_mesh(10, 0.5, 0.5))
        .position(Vec3::Y)
        .pin_vertex(0)
        .build()
        .unwrap();
    let pin = cloth.particles.positions[0];
    let e = app.world_mut().spawn(cloth).id();
    for k in 0..120 {
        if k == 10 {
            let mut p = app.world_mut().get_mut::<ClothParticles>(e).unwrap();
            p.positions[40] = Vec3::NAN;
            p.velocities[41] = Vec3::splat(f32::INFINITY);
        }
        if k == 40 {
            let mut p = app.world_mut().get_mut::<ClothParticles>(e).unwrap();
            let n = p.len();
            for v in &mut p.velocities[n - 60..] {
                *v = Vec3::new(50.0, 20.0, 0.0);
            }
        }
        app.update();
        assert!(particles(&app, e).is_finite(), "step {k}");
    }
    assert!(strain(&app, e) < 0.05, "strain {}", strain(&app, e));
    assert_eq!(particles(&app, e).positions[0], pin);
}

/// A disc of 217 particles pinned at its centre, with tethers: its step
/// has force streams, a coarse correction and tethers built from its links.
fn tethered_disc(app: &mut App) -> Entity {
    let cloth = ClothBuilder::from_mesh(&disc_mesh(8, 0.5, 0.3))
        .pin_vertex(0)
        .build()
        .unwrap();
    assert!(cloth.particles.len() >= 200);
    app.world_mut().spawn((cloth, ClothTethers::default())).id()
}

/// Rejoins the first Type 1 link to a particle across the disc, at its
/// rest distance, and halves the next link's rest length.
fn rejoin(connections: &mut ClothConnections, rest: &[Vec3]) {
    let far = rest.len() as u32 - 1;
    let first = &mut connections.structural[0];
    *first = bevy_cloth::sim::connections::Link::from_rest(first.a, far, rest);
    connections.structural[1].rest_length *= 0.5;
}

#[test]
fn links_edited_in_place_reach_every_cache_on_the_next_step() {
    // Two identical disc cloths; one has its links edited in place (same
    // lists, same lengths), the other gets a new component with the same
    // edit. Every cache (force streams, coarse correction, tethers) must
    // see the edit, so both go on identically.
    let (mut edited, mut replaced) = (app(), app());
    let a = tethered_disc(&mut edited);
    let b = tethered_disc(&mut replaced);
    for _ in 0..20 {
        edited.update();
        replaced.update();
    }
    assert!(particles(&edited, a) == particles(&replaced, b));
    let rest = particles(&edited, a).positions.clone();
    let mut links = edited.world_mut().get_mut::<ClothConnections>(a).unwrap();
    rejoin(&mut links, &rest);
    let mut fresh = replaced.world().get::<ClothConnections>(b).unwrap().clone();
    rejoin(&mut fresh, &rest);
    replaced.world_mut().entity_mut(b).insert(fresh);
    for _ in 0..20 {
        edited.update();
        replaced.update();
    }
    let (p, q) = (particles(&edited, a), particles(&replaced, b));
    assert!(p.is_finite());
    assert!(p.positions == q.positions, "a cache missed the edit");
}

#[test]
fn a_new_layout_is_rendered_and_names_a_new_generation() {
    let mut app = app_with_meshes();
    let disc = disc_mesh(3, 0.4, 0.0);
    let e = app
        .world_mut()
        .spawn(ClothBuilder::from_mesh(&disc).build().unwrap())
        .id();
    app.update();
    let rendered = |app: &App| {
        let handle = &app.world().get::<Mesh3d>(e).unwrap().0;
        let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
        mesh.indices().unwrap().iter().collect::<Vec<usize>>()
    };
    let before = rendered(&app);
    // The same particles and vertices, every triangle wound the other way.
    let mut flipped = disc.clone();
    let Some(bevy::mesh::Indices::U32(indices)) = flipped.indices_mut() else {
        panic!("u32 indices")
    };
    indices.chunks_exact_mut(3).for_each(|t| t.swap(1, 2));
    let layout = MeshLayout::from_mesh(&flipped).unwrap();
    let mut cloth = app.world_mut().get_mut::<Cloth>(e).unwrap();
    let generation = cloth.generation();
    cloth.set_layout(layout);
    assert_ne!(cloth.generation(), generation);
    app.update();
    let after = rendered(&app);
    assert_eq!(after.len(), before.len());
    assert_ne!(after, before);
    let wound: Vec<usize> = before
        .chunks_exact(3)
        .flat_map(|t| [t[0], t[2], t[1]])
        .collect();
    assert_eq!(after, wound);
}

#[test]
fn a_grid_cloth_keeps_its_fast_path_until_its_topology_changes() {
    let mut cloth = ClothBuilder::new(4, 3).build().unwrap().cloth;
    assert!(cloth.grid().is_some() && cloth.mesh().is_none());
    assert_eq!(cloth.layout().topology().len(), 12);
    let own = cloth.layout().clone();
    cloth.set_layout(own);
    assert!(cloth.grid().is_some(), "the grid's own topology keeps it");
    let disc = MeshLayout::from_mesh(&disc_mesh(1, 0.4, 0.0)).unwrap();
    cloth.set_layout(disc.clone());
    assert!(cloth.grid().is_none());
    assert_eq!(cloth.mesh(), Some(&disc));
    // Grids with no triangles make a cloth without a panic.
    for (cols, rows) in [(0, 0), (1, 5), (5, 1), (0, 3)] {
        let size = Vec2::ONE;
        let cloth = Cloth::from(bevy_cloth::sim::grid::Grid { cols, rows, size });
        assert_eq!(cloth.len(), (cols * rows) as usize);
        assert!(cloth.layout().topology().triangles.is_empty());
    }
}
