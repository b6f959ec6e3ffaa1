//! The rapier bridge in an app with bevy_rapier's plugin stepping in
//! `FixedUpdate`: every shape drapes, collision groups and sensors are
//! respected, bad input is skipped, kinematic bodies carry the cloth, and
//! dynamic bodies feel it (bounce, momentum).

use crate::common;

use std::f32::consts::FRAC_PI_2;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::plugin::bridges::rapier::ClothRapierPlugin;
use bevy_cloth::plugin::collision::{ClothColliderScene, ClothContactImpulses, ClothContactLayers};
use bevy_cloth::prelude::*;
use bevy_cloth::sim::material::Fabric;
use bevy_rapier3d::prelude::*;

/// An app with rapier (in `FixedUpdate`, one 1/60 s step per fixed step)
/// and the bridge; every `update()` after the first runs one fixed step.
fn app() -> App {
    app_with(|_| {})
}

/// [`app`], with `add` adding more plugins before it is finished.
fn app_with(add: impl FnOnce(&mut App)) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        bevy::asset::AssetPlugin::default(),
        RapierPhysicsPlugin::<NoUserData>::default().in_fixed_schedule(),
        ClothPlugin::default(),
        ClothRapierPlugin::default(),
    ))
    .insert_resource(TimestepMode::Fixed {
        dt: 1.0 / 60.0,
        substeps: 1,
    })
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    add(&mut app);
    app.finish();
    app.update();
    app
}

fn run(app: &mut App, frames: usize, cloth: Entity) -> f32 {
    let mut worst = 0.0f32;
    for k in 0..frames {
        app.update();
        let stats = app.world().get::<ClothStats>(cloth).unwrap();
        assert!(stats.finite, "non-finite at frame {k}");
        if k >= 30 {
            worst = worst.max(stats.max_strain);
        }
    }
    worst
}

fn positions(app: &App, cloth: Entity) -> Vec<Vec3> {
    app.world()
        .get::<ClothParticles>(cloth)
        .unwrap()
        .positions
        .clone()
}

/// A 1.2 m, 21 × 21 sheet at height `y`, its middle particle's index.
fn sheet(app: &mut App, y: f32) -> (Entity, usize) {
    let n = 21;
    let cloth = ClothBuilder::new(n, n)
        .size(1.2, 1.2)
        .position(Vec3::new(0.0, y, 0.0))
        .build()
        .unwrap();
    (app.world_mut().spawn(cloth).id(), (n * n / 2) as usize)
}

fn floor(app: &mut App) {
    app.world_mut()
        .spawn((RigidBody::Fixed, Collider::halfspace(Vec3::Y).unwrap()));
}

/// The shapes, each with its top at y = 1 m, and whether `contains_point`
/// means "inside a solid" for it.
fn shapes() -> Vec<(&'static str, Collider, Vec3, Quat, bool)> {
    let cube = bevy_rapier3d::parry::shape::Cuboid::new(Vec3::new(0.3, 0.2, 0.3));
    let (vertices, indices) = cube.to_trimesh();
    let heights: Vec<f32> = (0..81)
        .map(|k| {
            let (x, z) = ((k / 9) as f32 / 4.0 - 1.0, (k % 9) as f32 / 4.0 - 1.0);
            0.2 * (1.0 - x * x) * (1.0 - z * z)
        })
        .collect();
    vec![
        (
            "ball",
            Collider::ball(0.3),
            Vec3::Y * 0.7,
            Quat::IDENTITY,
            true,
        ),
        (
            "cuboid",
            Collider::cuboid(0.3, 0.2, 0.3),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            true,
        ),
        (
            "capsule",
            Collider::capsule_x(0.3, 0.2),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            true,
        ),
        (
            "cylinder",
            Collider::cylinder(0.2, 0.3),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            true,
        ),
        (
            "cone",
            Collider::cone(0.3, 0.3),
            Vec3::Y * 0.7,
            Quat::from_rotation_x(std::f32::consts::PI),
            true,
        ),
        (
            "convex hull",
            Collider::convex_hull(&[
                Vec3::new(-0.3, -0.2, -0.3),
                Vec3::new(0.3, -0.2, -0.3),
                Vec3::new(-0.3, -0.2, 0.3),
                Vec3::new(0.3, -0.2, 0.3),
                Vec3::new(-0.3, 0.2, -0.3),
                Vec3::new(0.3, 0.2, -0.3),
                Vec3::new(-0.3, 0.2, 0.3),
                Vec3::new(0.3, 0.2, 0.3),
            ])
            .unwrap(),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            true,
        ),
        (
            "triangle mesh",
            Collider::trimesh(vertices, indices).unwrap(),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            false,
        ),
        (
            "compound",
            Collider::compound(vec![
                (
                    Vec3::new(-0.2, 0.0, 0.0),
                    Quat::IDENTITY,
                    Collider::ball(0.2),
                ),
                (
                    Vec3::new(0.2, 0.0, 0.0),
                    Quat::IDENTITY,
                    Collider::cuboid(0.15, 0.2, 0.2),
                ),
            ]),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            true,
        ),
        (
            "height field",
            Collider::heightfield(heights, 9, 9, Vec3::new(2.0, 1.0, 2.0)),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            false,
        ),
        (
            "round cuboid",
            Collider::round_cuboid(0.25, 0.15, 0.25, 0.05),
            Vec3::Y * 0.8,
            Quat::IDENTITY,
            true,
        ),
    ]
}

#[test]
fn every_rapier_shape_drapes_a_cloth() {
    for (name, collider, at, turn, solid) in shapes() {
        let mut app = app();
        floor(&mut app);
        app.world_mut().spawn((
            RigidBody::Fixed,
            collider.clone(),
            Transform::from_translation(at).with_rotation(turn),
        ));
        let (cloth, middle) = sheet(&mut app, 1.2);
        let worst = run(&mut app, 150, cloth);
        let x = positions(&app, cloth);
        let inside = if solid {
            x.iter()
                .filter(|&&p| collider.contains_point(at, turn, p))
                .count()
        } else {
            0
        };
        eprintln!(
            "{name}: middle at {:.3} m, worst strain {:.2} %, {inside} inside",
            x[middle].y,
            100.0 * worst
        );
        assert!(
            x[middle].y > 0.99,
            "{name}: fell through, middle at {}",
            x[middle].y
        );
        assert!(x[middle].y < 1.03, "{name}: hovers at {}", x[middle].y);
        assert_eq!(inside, 0, "{name}: particles inside");
        assert!(worst <= 0.05, "{name}: strain {worst}");
    }
}

/// Where the middle of a sheet dropped onto a 0.3 m ball ends up, with the
/// given cloth layers and ball setup.
fn drop_on_ball(cloth_layers: Option<ClothContactLayers>, ball: impl Bundle) -> f32 {
    let mut app = app();
    floor(&mut app);
    app.world_mut().spawn((
        RigidBody::Fixed,
        Collider::ball(0.3),
        Transform::from_xyz(0.0, 0.7, 0.0),
        ball,
    ));
    let (cloth, middle) = sheet(&mut app, 1.2);
    if let Some(layers) = cloth_layers {
        app.world_mut().entity_mut(cloth).insert(layers);
    }
    run(&mut app, 90, cloth);
    positions(&app, cloth)[middle].y
}

#[test]
fn collision_groups_and_sensors_are_respected() {
    let on = drop_on_ball(None, ());
    assert!(on > 0.99, "on the ball: {on}");
    let shared = drop_on_ball(
        Some(ClothContactLayers::new(0b10, 0b11)),
        CollisionGroups::new(Group::GROUP_1, Group::GROUP_2),
    );
    assert!(shared > 0.99, "shared groups: {shared}");
    let apart = drop_on_ball(
        Some(ClothContactLayers::new(0b10, 0b10)),
        CollisionGroups::new(Group::GROUP_1, Group::GROUP_1),
    );
    assert!(apart < 0.1, "no shared group: fell to {apart}");
    let sensor = drop_on_ball(None, Sensor);
    assert!(sensor < 0.1, "sensor: fell to {sensor}");
    let disabled = drop_on_ball(None, ColliderDisabled);
    assert!(disabled < 0.1, "disabled: fell to {disabled}");
}

/// A sheet come to rest on a fixed rapier box (top at y = 1 m) above a
/// floor: the app, the box, the cloth and its middle particle.
fn resting_on_box() -> (App, Entity, Entity, usize) {
    let mut app = app();
    floor(&mut app);
    let body = app
        .world_mut()
        .spawn((
            RigidBody::Fixed,
            Collider::cuboid(0.5, 0.2, 0.5),
            Transform::from_xyz(0.0, 0.8, 0.0),
        ))
        .id();
    let (cloth, middle) = sheet(&mut app, 1.1);
    run(&mut app, 60, cloth);
    (app, body, cloth, middle)
}

#[test]
fn a_collider_whose_groups_change_lets_the_cloth_go() {
    let (mut app, box_, cloth, middle) = resting_on_box();
    assert!(positions(&app, cloth)[middle].y > 0.99);
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothContactLayers::new(0b10, 0b10));
    app.world_mut()
        .entity_mut(box_)
        .insert(CollisionGroups::new(Group::GROUP_1, Group::GROUP_1));
    run(&mut app, 60, cloth);
    let y = positions(&app, cloth)[middle].y;
    assert!(y < 0.1, "the box's new groups let it fall: {y}");
}

#[test]
fn a_cloth_whose_body_is_despawned_falls_on() {
    let (mut app, body, cloth, middle) = resting_on_box();
    app.world_mut().despawn(body);
    run(&mut app, 90, cloth);
    let y = positions(&app, cloth)[middle].y;
    assert!(y < 0.1, "fell to the floor: {y}");
}

#[test]
fn a_cloth_collider_and_a_rapier_collider_on_one_entity_collide_once() {
    let mut app = app();
    app.world_mut().spawn((
        RigidBody::Fixed,
        Collider::ball(0.3),
        ClothCollider::sphere(0.3),
        Transform::from_xyz(0.0, 0.7, 0.0),
    ));
    let (cloth, _) = sheet(&mut app, 1.2);
    run(&mut app, 2, cloth);
    assert_eq!(
        app.world().resource::<ClothColliderScene>().colliders.len(),
        1
    );
}

#[test]
fn a_collider_on_a_child_moves_with_its_body() {
    // A box collider on a child entity, offset 0.5 m from a kinematic body:
    // the cloth rests on it where rapier puts it.
    let mut app = app();
    floor(&mut app);
    app.world_mut()
        .spawn((RigidBody::Fixed, Transform::from_xyz(-0.5, 0.0, 0.0)))
        .with_child((
            Collider::cuboid(0.5, 0.2, 0.5),
            Transform::from_xyz(0.5, 0.8, 0.0),
        ));
    let (cloth, middle) = sheet(&mut app, 1.1);
    run(&mut app, 60, cloth);
    let y = positions(&app, cloth)[middle].y;
    assert!((0.99..1.03).contains(&y), "on the child's box: {y}");
}

#[derive(Component)]
struct Poisoned;

/// Writes non-finite velocities into rapier's own body set for the
/// cloth's step (rapier would quarantine the body in its own).
fn poison(mut sets: Query<&mut RapierRigidBodySet>, poisoned: Query<Entity, With<Poisoned>>) {
    for mut set in &mut sets {
        for entity in &poisoned {
            let Some(&handle) = set.entity2body().get(&entity) else {
                continue;
            };
            if let Some(body) = set.bodies.get_mut(handle) {
                body.set_linvel(Vec3::new(f32::NAN, 0.0, 0.0), false);
                body.set_angvel(Vec3::INFINITY, false);
            }
        }
    }
}

fn heal(mut sets: Query<&mut RapierRigidBodySet>, poisoned: Query<Entity, With<Poisoned>>) {
    for mut set in &mut sets {
        for entity in &poisoned {
            let Some(&handle) = set.entity2body().get(&entity) else {
                continue;
            };
            if let Some(body) = set.bodies.get_mut(handle) {
                body.set_linvel(Vec3::ZERO, false);
                body.set_angvel(Vec3::ZERO, false);
            }
        }
    }
}

#[test]
fn bad_bodies_and_shapes_are_skipped_and_the_cloth_stays_finite() {
    let mut app = app();
    floor(&mut app);
    app.world_mut().spawn((
        Poisoned,
        RigidBody::KinematicVelocityBased,
        Collider::ball(0.2),
        Transform::from_xyz(0.3, 0.6, 0.0),
    ));
    app.world_mut().spawn((
        Poisoned,
        RigidBody::Dynamic,
        Collider::ball(0.1),
        Transform::from_xyz(0.0, 0.6, 0.3),
    ));
    app.add_systems(
        FixedUpdate,
        (
            poison.before(bevy_cloth::plugin::collision::ClothColliderSources),
            heal.after(ClothSystems::Writeback)
                .before(PhysicsSet::SyncBackend),
        ),
    );
    app.world_mut().spawn((
        RigidBody::Fixed,
        Collider::ball(0.0),
        Transform::from_xyz(0.0, 0.6, -0.3),
    ));
    app.world_mut().spawn((
        RigidBody::Fixed,
        Collider::segment(Vec3::ZERO, Vec3::X),
        Transform::from_xyz(0.0, 0.6, 0.0),
    ));
    let (cloth, _) = sheet(&mut app, 1.0);
    run(&mut app, 120, cloth);
    assert!(positions(&app, cloth).iter().all(|p| p.is_finite()));
}

#[test]
fn a_kinematic_platform_carries_a_resting_cloth_and_is_not_pushed() {
    let mut app = app();
    let velocity = Vec3::new(0.2, 0.0, 0.0);
    let board = app
        .world_mut()
        .spawn((
            RigidBody::KinematicVelocityBased,
            Collider::cuboid(0.4, 0.02, 0.4),
            Friction::coefficient(0.6),
            Velocity::zero(),
            Transform::from_xyz(0.0, 0.5, 0.0),
        ))
        .id();
    let cloth = ClothBuilder::new(13, 13)
        .size(0.5, 0.5)
        .position(Vec3::new(0.0, 0.526, 0.0))
        .build()
        .unwrap();
    let cloth = app.world_mut().spawn(cloth).id();
    run(&mut app, 30, cloth);
    let at = |app: &App| app.world().get::<Transform>(board).unwrap().translation;
    let on_board = |app: &App| {
        let at = at(app);
        positions(app, cloth)
            .iter()
            .map(|&x| x - at)
            .collect::<Vec<_>>()
    };
    app.world_mut()
        .entity_mut(board)
        .insert(Velocity::linear(velocity));
    // Friction (μ = 0.5) accelerates the cloth at most μ g, so it slips
    // v²/(2 μ g) ≈ 4 mm while catching up with the board: carried is
    // measured from then on.
    run(&mut app, 30, cloth);
    let start = on_board(&app);
    run(&mut app, 300, cloth);
    let end = on_board(&app);
    let drift = start
        .iter()
        .zip(&end)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max);
    let moved = at(&app).x;
    eprintln!(
        "rapier platform: moved {moved:.3} m, cloth drifted {:.2} mm on it",
        1e3 * drift
    );
    assert!(moved > 1.0, "the platform moved {moved} m");
    assert!(drift <= 0.002, "drift {drift} m");
    assert_eq!(app.world().get::<Velocity>(board).unwrap().linear, velocity);
}

/// A dynamic ball of `mass` kg and `radius` m at `at`, moving at
/// `velocity` m/s.
fn ball(app: &mut App, (mass, radius): (f32, f32), at: Vec3, velocity: Vec3) -> Entity {
    app.world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::ball(radius),
            ColliderMassProperties::Mass(mass),
            Velocity::linear(velocity),
            Transform::from_translation(at),
        ))
        .id()
}

#[test]
fn a_light_ball_on_a_heavy_canvas_bounces_no_higher_than_it_fell() {
    let mut app = app();
    let cloth = ClothBuilder::new(21, 21)
        .size(1.0, 1.0)
        .total_mass(3.0)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin_edge(GridEdge::Left)
        .pin_edge(GridEdge::Right)
        .pin_edge(GridEdge::Top)
        .pin_edge(GridEdge::Bottom)
        .build()
        .unwrap();
    let cloth = app.world_mut().spawn(cloth).id();
    run(&mut app, 60, cloth);
    let height = 1.5;
    let ball = ball(&mut app, (0.05, 0.05), Vec3::Y * height, Vec3::ZERO);
    let mut track = Vec::new();
    for _ in 0..240 {
        app.update();
        let p = app.world().get::<Transform>(ball).unwrap().translation;
        let v = app.world().get::<Velocity>(ball).unwrap().linear;
        track.push((p, v));
    }
    let landed = track
        .iter()
        .position(|(_, v)| v.y > 0.0)
        .expect("it comes back up");
    let top = track[landed..]
        .iter()
        .map(|(p, _)| p.y)
        .fold(f32::MIN, f32::max);
    let rest = track.last().unwrap().0.y;
    eprintln!(
        "rapier bounce: dropped from {height} m, came back to {top:.3} m, rests at {rest:.3} m"
    );
    assert!(top <= height, "bounced to {top} m");
    assert!(rest > 0.9, "the canvas holds it: {rest} m");
}

#[test]
fn a_ball_thrown_into_a_free_curtain_gives_it_the_momentum_it_loses() {
    let mut app = app();
    app.world_mut()
        .query::<&mut RapierConfiguration>()
        .single_mut(app.world_mut())
        .unwrap()
        .gravity = Vec3::ZERO;
    app.world_mut()
        .resource_mut::<ClothSettingsDefaults>()
        .0
        .gravity = Vec3::ZERO;
    let undamped = ClothMaterial::Fabric(Fabric {
        damping: 0.0,
        ..Fabric::COTTON
    });
    let cloth = ClothBuilder::new(21, 21)
        .size(1.0, 1.0)
        .total_mass(0.3)
        .material(undamped)
        .rotation(Quat::from_rotation_x(FRAC_PI_2))
        .position(Vec3::new(0.0, 1.0, 0.0))
        .build()
        .unwrap();
    let cloth = app.world_mut().spawn(cloth).id();
    let momentum = |app: &App| -> Vec3 {
        let p = app.world().get::<ClothParticles>(cloth).unwrap();
        p.velocities
            .iter()
            .zip(&p.masses)
            .map(|(v, m)| *v * *m)
            .sum()
    };
    let mass = 0.5;
    let ball = ball(
        &mut app,
        (mass, 0.1),
        Vec3::new(0.0, 1.0, 0.4),
        Vec3::new(0.0, 0.0, -3.0),
    );
    let ball_momentum = |app: &App| mass * app.world().get::<Velocity>(ball).unwrap().linear;
    app.update();
    let (ball0, cloth0) = (ball_momentum(&app), momentum(&app));
    let mut touched = 0;
    for _ in 0..60 {
        app.update();
        let touching = !app.world().resource::<ClothContactImpulses>().is_empty();
        if touching {
            touched += 1;
        } else if touched > 0 {
            break;
        }
    }
    // One more step: rapier applies the last impulse in its next sync.
    app.update();
    let (lost, gained) = (ball0 - ball_momentum(&app), momentum(&app) - cloth0);
    eprintln!(
        "rapier curtain: over {touched} steps of contact the ball lost {lost} N·s, the curtain gained {gained} N·s"
    );
    assert!(touched > 0, "they met");
    assert!(lost.z < -0.3, "the ball was slowed: {lost}");
    assert!(
        (gained - lost).length() <= 0.1 * lost.length(),
        "lost {lost}, gained {gained}"
    );
}

/// A 0.3 kg hammock ([`common::hammock`]) of `material`.
fn hammock(material: ClothMaterial) -> ClothBundle {
    common::hammock(|b| b.total_mass(0.3).material(material))
}

#[test]
fn a_heavy_ball_dropped_into_a_hammock_is_never_thrown_faster_than_it_came() {
    for (material, radius) in [(ClothMaterial::COTTON, 0.12), (ClothMaterial::DENIM, 0.12)] {
        let mut app = app();
        let cloth = app.world_mut().spawn(hammock(material)).id();
        run(&mut app, 60, cloth);
        let ball = ball(&mut app, (5.0, radius), Vec3::Y * 1.1, Vec3::ZERO);
        let mut track = Vec::new();
        for k in 0..120 {
            app.update();
            let stats = app.world().get::<ClothStats>(cloth).unwrap();
            assert!(stats.finite, "non-finite at frame {k}");
            track.push(app.world().get::<Velocity>(ball).unwrap().linear);
        }
        let hit = track
            .iter()
            .position(|v| v.y > -0.1)
            .unwrap_or(track.len() - 1);
        let impact = track[..=hit].iter().map(|v| v.length()).fold(0.0, f32::max);
        let after = track[hit..].iter().map(|v| v.y).fold(f32::MIN, f32::max);
        eprintln!(
            "rapier hammock {radius} m ball: hit at {impact:.2} m/s, fastest up after {after:.2} m/s"
        );
        assert!(
            after <= impact,
            "thrown up at {after} m/s after hitting at {impact} m/s"
        );
    }
}

#[test]
fn balls_come_to_rest_in_a_hammock() {
    // As with avian: 5 kg in 0.3 kg of canvas, and lighter and heavier
    // balls in cotton and canvas, each at rest near the middle after 3 s.
    let cases = [
        (ClothMaterial::DENIM, 5.0, 0.12),
        (ClothMaterial::COTTON, 0.1, 0.15),
        (ClothMaterial::COTTON, 1.0, 0.12),
        (ClothMaterial::DENIM, 10.0, 0.15),
    ];
    for (material, mass, radius) in cases {
        let mut app = app();
        let cloth = app.world_mut().spawn(hammock(material)).id();
        run(&mut app, 60, cloth);
        let ball = ball(&mut app, (mass, radius), Vec3::Y * 1.1, Vec3::ZERO);
        run(&mut app, 150, cloth);
        let (mut speed, mut strain) = (0.0f32, 0.0f32);
        for _ in 0..30 {
            app.update();
            let stats = app.world().get::<ClothStats>(cloth).unwrap();
            strain = strain.max(stats.max_strain);
            speed = speed.max(app.world().get::<Velocity>(ball).unwrap().linear.length());
        }
        let at = app.world().get::<Transform>(ball).unwrap().translation;
        eprintln!(
            "rapier {mass} kg ball: at {at}, speed over the last 0.5 s {:.2} cm/s, strain {:.2} %",
            100.0 * speed,
            100.0 * strain
        );
        assert!(at.y > 0.5 && at.y < 1.0, "{mass} kg ball at {at}");
        assert!(
            Vec2::new(at.x, at.z).length() < 0.1,
            "{mass} kg ball at {at}"
        );
        assert!(speed < 0.01, "{mass} kg ball moving at {speed} m/s");
        if mass == 5.0 {
            assert!(strain <= 0.05, "strain {strain}");
        }
    }
}

#[test]
fn a_ball_the_cloth_lets_go_of_falls_freely() {
    // The cloth cancels rapier's gravity on a body it holds up, for the
    // steps it holds it; once it is gone the body falls at g again, and
    // the `ExternalForce` it was given is back to nothing.
    let mut app = app();
    let cloth = app.world_mut().spawn(hammock(ClothMaterial::DENIM)).id();
    run(&mut app, 60, cloth);
    let ball = ball(&mut app, (1.0, 0.12), Vec3::Y * 1.1, Vec3::ZERO);
    run(&mut app, 120, cloth);
    assert!(app.world().get::<ExternalForce>(ball).is_some());
    app.world_mut().despawn(cloth);
    for _ in 0..3 {
        app.update();
    }
    let v0 = app.world().get::<Velocity>(ball).unwrap().linear;
    for _ in 0..6 {
        app.update();
    }
    let v1 = app.world().get::<Velocity>(ball).unwrap().linear;
    let force = app.world().get::<ExternalForce>(ball).unwrap().force;
    assert_eq!(force, Vec3::ZERO, "the cancelling force is taken off");
    let fall = (v1 - v0).y / (6.0 / 60.0);
    assert!((fall + 9.81).abs() < 0.05, "falls at {fall} m/s²");
}

/// With both bridges, an entity carrying an avian and a rapier collider
/// collides once (through avian's).
#[cfg(feature = "avian")]
#[test]
fn an_entity_with_both_engines_colliders_collides_once() {
    let mut app = app_with(|app| {
        app.add_plugins((
            avian3d::prelude::PhysicsPlugins::default(),
            bevy_cloth::plugin::bridges::avian::ClothAvianPlugin::default(),
        ));
    });
    app.world_mut().spawn((
        RigidBody::Fixed,
        Collider::ball(0.3),
        avian3d::prelude::RigidBody::Static,
        avian3d::prelude::Collider::sphere(0.3),
        Transform::from_xyz(0.0, 0.7, 0.0),
    ));
    let (cloth, middle) = sheet(&mut app, 1.2);
    run(&mut app, 2, cloth);
    assert_eq!(
        app.world().resource::<ClothColliderScene>().colliders.len(),
        1
    );
    run(&mut app, 60, cloth);
    let y = positions(&app, cloth)[middle].y;
    assert!((0.99..1.03).contains(&y), "on the ball: {y}");
}
