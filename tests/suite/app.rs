//! Headless app tests: `MinimalPlugins` + `ClothPlugin`, `FixedUpdate`
//! stepped an exact number of times (`TimeUpdateStrategy::FixedTimesteps`).

use crate::common;

use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::mesh::{Mesh, Mesh3d, VertexAttributeValues};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::prelude::*;
use common::{app, particles, sheet as hanging};

#[test]
fn hanging_cloth_keeps_pins_exact_and_hangs_below_them() {
    let mut app = app();
    let cloth = app.world_mut().spawn(hanging(15)).id();
    let start = particles(&app, cloth).positions.clone();
    for _ in 0..120 {
        app.update();
    }
    let p = particles(&app, cloth);
    assert_eq!(app.world().get::<ClothStats>(cloth).unwrap().steps, 120);
    // Pins: exactly where they started, bit for bit.
    for pin in [0, 14] {
        assert!(p.is_pinned(pin));
        assert_eq!(p.positions[pin], start[pin]);
    }
    // Everything finite; every free particle at or below the pins.
    assert!(p.is_finite());
    let top = start[0].y;
    assert!(p.positions.iter().all(|x| x.y <= top + 1e-4));
    // The free far corners have swung down well below the pins.
    assert!(p.positions[224].y < top - 0.5, "{}", p.positions[224]);
    let stats = app.world().get::<ClothStats>(cloth).unwrap();
    assert!(stats.finite && stats.max_strain < 0.05, "{stats:?}");
}

#[test]
fn a_moving_anchor_carries_its_particles_exactly() {
    let mut app = app();
    let pole = app.world_mut().spawn(Transform::default()).id();
    let cloth = app
        .world_mut()
        .spawn((
            hanging(15),
            ClothAnchors::default().with(0, pole).with(14, pole),
        ))
        .id();
    let start = particles(&app, cloth).positions.clone();
    app.update(); // let the anchors take their offsets
    // Move the pole 0.5 m/s along +X and up 0.25 m/s, one step at a time.
    for k in 1..=120 {
        let t = k as f32 / 60.0;
        app.world_mut()
            .get_mut::<Transform>(pole)
            .unwrap()
            .translation = Vec3::new(0.5 * t, 0.25 * t, 0.0);
        app.update();
    }
    // Anchored particles sit exactly on the pole at its latest position: a
    // root entity is read from its `Transform`, with no frame of lag.
    let p = particles(&app, cloth);
    let moved = Vec3::new(1.0, 0.5, 0.0);
    for pin in [0, 14] {
        assert!(
            (p.positions[pin] - (start[pin] + moved)).length() < 1e-5,
            "{}",
            p.positions[pin]
        );
    }
    assert!(p.is_finite());
    // The cloth came along: its centre moved most of the way.
    let centre = p.positions[7 * 15 + 7];
    assert!(centre.x > start[7 * 15 + 7].x + 0.8, "{centre}");
    // A despawned anchor leaves the particle pinned where it is, no panic.
    app.world_mut().despawn(pole);
    let here = particles(&app, cloth).positions[0];
    app.update();
    assert_eq!(particles(&app, cloth).positions[0], here);
}

#[test]
fn per_cloth_settings_override_the_defaults() {
    let mut app = app();
    let falls = app.world_mut().spawn(hanging(5)).id();
    let floats = app
        .world_mut()
        .spawn((
            hanging(5),
            ClothSettings(SimSettings {
                gravity: Vec3::ZERO,
                ..default()
            }),
        ))
        .id();
    let start = particles(&app, floats).positions.clone();
    for _ in 0..30 {
        app.update();
    }
    assert_eq!(particles(&app, floats).positions, start);
    assert!(particles(&app, falls).positions[24].y < start[24].y - 0.01);
    // Changing the global defaults reaches the cloth without an override:
    // gravity upwards lifts it.
    app.world_mut()
        .resource_mut::<ClothSettingsDefaults>()
        .gravity = Vec3::Y * 9.81;
    let y = particles(&app, falls).positions[24].y;
    for _ in 0..60 {
        app.update();
    }
    assert!(particles(&app, falls).positions[24].y > y + 0.5);
}

#[test]
fn invalid_user_data_skips_the_cloth_instead_of_panicking() {
    let mut app = app();
    let bad_settings = app
        .world_mut()
        .spawn((
            hanging(5),
            ClothSettings(SimSettings {
                substeps: 0,
                ..default()
            }),
        ))
        .id();
    let mut broken = hanging(5);
    broken.connections.bend[0].b = 999;
    let bad_links = app.world_mut().spawn(broken).id();
    let mut short = hanging(5);
    short.particles.velocities.pop();
    let bad_arrays = app.world_mut().spawn(short).id();
    let good = app.world_mut().spawn(hanging(5)).id();
    let before: Vec<Vec<Vec3>> = [bad_settings, bad_links, bad_arrays]
        .iter()
        .map(|&e| particles(&app, e).positions.clone())
        .collect();
    for _ in 0..10 {
        app.update();
    }
    for (e, b) in [bad_settings, bad_links, bad_arrays].iter().zip(before) {
        assert_eq!(particles(&app, *e).positions, b, "an invalid cloth moved");
    }
    assert!(particles(&app, good).positions[24].y < hanging(5).particles.positions[24].y);
}

#[test]
fn the_mesh_follows_the_particles() {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        ClothPlugin::default(),
    ))
    .init_asset::<Mesh>()
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )))
    // The mesh shows the last step as it is (no interpolation).
    .insert_resource(ClothMeshSettings { interpolate: false });
    let cloth = app.world_mut().spawn(hanging(7)).id();
    for _ in 0..20 {
        app.update();
    }
    let handle = app
        .world()
        .get::<Mesh3d>(cloth)
        .expect("a mesh was attached")
        .0
        .clone();
    let meshes = app.world().resource::<Assets<Mesh>>();
    let mesh = meshes.get(&handle).unwrap();
    let Some(VertexAttributeValues::Float32x3(pos)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        panic!("no positions")
    };
    let p = particles(&app, cloth);
    assert_eq!(pos.len(), 49);
    for (m, x) in pos.iter().zip(&p.positions) {
        assert_eq!(Vec3::from_array(*m), *x);
    }
    // The cloth did move, so the mesh was rewritten, not just created.
    assert_ne!(p.positions[48], hanging(7).particles.positions[48]);
    assert_eq!(mesh.indices().unwrap().len(), 2 * 6 * 6 * 3);
}

/// The mesh vertex positions (m) of `cloth`.
fn mesh_positions(app: &App, cloth: Entity) -> Vec<Vec3> {
    let handle = &app.world().get::<Mesh3d>(cloth).expect("a mesh").0;
    let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
    match mesh.attribute(Mesh::ATTRIBUTE_POSITION) {
        Some(VertexAttributeValues::Float32x3(p)) => {
            p.iter().map(|p| Vec3::from_array(*p)).collect()
        }
        _ => panic!("no positions"),
    }
}

/// The free bottom corner's mesh height (m) on each of 36 frames at
/// 60 Hz while the cloth steps at 10 Hz, with interpolation on or off.
fn frames_at_10_hz(interpolate: bool) -> Vec<f32> {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        ClothPlugin::default(),
    ))
    .init_asset::<Mesh>()
    .insert_resource(Time::<Fixed>::from_hz(10.0))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )))
    .insert_resource(ClothMeshSettings { interpolate });
    let cloth = app.world_mut().spawn(common::sheet(7)).id();
    (0..36)
        .map(|_| {
            app.update();
            mesh_positions(&app, cloth)[48].y
        })
        .collect()
}

#[test]
fn the_mesh_is_interpolated_between_fixed_steps() {
    // The corner of the falling sheet moves all the time. Stepped at 10 Hz
    // and drawn at 60 Hz, the interpolated mesh moves on nearly every frame;
    // without interpolation it holds still for five frames in six.
    let moves = |heights: &[f32]| heights.windows(2).filter(|w| w[1] != w[0]).count();
    let smooth = frames_at_10_hz(true);
    let stepped = frames_at_10_hz(false);
    eprintln!(
        "frames the corner moved on: {} of 35 interpolated, {} of 35 stepped",
        moves(&smooth),
        moves(&stepped)
    );
    assert!(moves(&smooth) >= 28, "{smooth:?}");
    assert!(moves(&stepped) <= 7, "{stepped:?}");
    // Each interpolated frame lies between the steps around it.
    let (lo, hi) = stepped
        .iter()
        .fold((f32::MAX, f32::MIN), |(l, h), &y| (l.min(y), h.max(y)));
    assert!(smooth.iter().all(|&y| y >= lo - 1e-4 && y <= hi + 1e-4));
}

#[test]
fn bounds_follow_the_moving_cloth_in_the_same_frame() {
    use bevy::camera::primitives::Aabb;
    use bevy::camera::visibility::VisibilityPlugin;
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        VisibilityPlugin,
        ClothPlugin::default(),
    ))
    .init_asset::<Mesh>()
    .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>()
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    let cloth = app.world_mut().spawn(hanging(9)).id();
    let mut checked = 0;
    for _ in 0..60 {
        app.update();
        let Some(aabb) = app.world().get::<Aabb>(cloth) else {
            continue;
        };
        // The box Bevy culls and picks with equals the drawn cloth's bounds
        // now (the mesh, interpolated between the last two steps).
        let x = &mesh_positions(&app, cloth);
        let min = x.iter().fold(Vec3::MAX, |a, &b| a.min(b));
        let max = x.iter().fold(Vec3::MIN, |a, &b| a.max(b));
        assert!(
            (Vec3::from(aabb.min()) - min).length() < 1e-5,
            "{aabb:?} vs {min}..{max}"
        );
        assert!(
            (Vec3::from(aabb.max()) - max).length() < 1e-5,
            "{aabb:?} vs {min}..{max}"
        );
        checked += 1;
    }
    assert!(checked > 50, "the Aabb was checked {checked} times");
    // The cloth swung down, so the box did move.
    let aabb = app.world().get::<Aabb>(cloth).unwrap();
    assert!(aabb.min().y < 1.5, "{aabb:?}");
}

#[test]
fn live_figures_are_bevy_diagnostics() {
    use bevy::diagnostic::DiagnosticsStore;
    use bevy_cloth::plugin::diagnostics::{
        KINETIC_ENERGY, MAX_STRAIN, STEP_TIME, SUBSTEPS, step_time_path,
    };
    let mut app = app();
    app.world_mut().spawn(hanging(9));
    for _ in 0..10 {
        app.update();
    }
    let store = app.world().resource::<DiagnosticsStore>();
    let value = |path: &bevy::diagnostic::DiagnosticPath| {
        store.get(path).and_then(|d| d.value()).unwrap_or(f64::NAN)
    };
    assert!(value(&STEP_TIME) > 0.0);
    assert!(value(step_time_path(Integrator::BackwardEuler)) > 0.0);
    assert!(
        store
            .get(step_time_path(Integrator::Rk4))
            .unwrap()
            .value()
            .is_none()
    );
    assert_eq!(value(&SUBSTEPS), 1.0);
    assert!(value(&MAX_STRAIN) > 0.0 && value(&KINETIC_ENERGY) > 0.0);
}

/// Moves particle 0 of every cloth 0.5 m along x (after the integration,
/// before the writeback measures the statistics).
fn shove(mut cloths: Query<&mut ClothParticles>, mut shoves: Local<u32>) {
    *shoves += 1;
    if *shoves == 3 {
        for mut p in &mut cloths {
            p.positions[0].x += 0.5;
        }
    }
}

#[test]
fn statistics_measure_the_state_whatever_changed_it_after_the_step() {
    // 48×48 with backward Euler: the divergence guard measures the strain
    // in two halves (one on the helper thread), and the writeback reuses
    // its figure unless the particles changed since.
    let mut app = app();
    app.insert_resource(ClothSettingsDefaults(
        SimSettings::default().with_integrator(Integrator::BackwardEuler, 1),
    ))
    .add_systems(FixedUpdate, shove.in_set(ClothSystems::Collide));
    let cloth = app.world_mut().spawn(hanging(48)).id();
    for step in 1..=5 {
        app.update();
        let p = particles(&app, cloth);
        let links = app.world().get::<ClothConnections>(cloth).unwrap();
        let fresh = bevy_cloth::sim::connections::max_strain(links.type1(), &p.positions);
        let stats = app.world().get::<ClothStats>(cloth).unwrap();
        assert_eq!(stats.max_strain.to_bits(), fresh.to_bits(), "step {step}");
        if step == 3 {
            // The shoved particle's links are stretched far past the rest.
            assert!(stats.max_strain > 10.0, "{stats:?}");
        }
    }
}

#[test]
fn links_edited_between_steps_are_checked_again() {
    let mut app = app();
    let cloth = app.world_mut().spawn(hanging(5)).id();
    for _ in 0..3 {
        app.update();
    }
    app.world_mut()
        .get_mut::<ClothConnections>(cloth)
        .unwrap()
        .bend[0]
        .b = 999;
    let before = particles(&app, cloth).positions.clone();
    for _ in 0..3 {
        app.update();
    }
    assert_eq!(
        particles(&app, cloth).positions,
        before,
        "a cloth with a bad link moved"
    );
}
