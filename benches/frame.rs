//! `cargo bench --bench frame`: a whole 1/60 s game frame of a 64×64 cloth
//! draped on a sphere, with mesh sync, per integrator; and a frame of the
//! `tablecloth` example's scene with the defaults.
//!
//! A binary of its own, so that Bevy sizes its task pools as in a game on
//! the machine that runs it (`TaskPoolPlugin`'s defaults: on a 2-core
//! machine one compute thread), rather than as the `step` bench's force
//! evaluation sets them (a compute pool of one thread per core). The
//! implicit solve's helper thread competes with a second compute thread
//! for the cores: with one, the 64×64 backward-Euler frame took 2.6–3.2
//! ms, with two 3.2–4.0 (against 3.5–4.5 without the helper in both).

mod common;

use std::time::Duration;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::headless;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

/// Frames after the drop that the frame bench times: the cloth has landed
/// on the sphere by the first and still drapes it at the last (about 10 s
/// after the drop it slides off and falls for good, which is not the scene).
const DRAPED: std::ops::Range<u32> = 30..330;

/// Drops a fresh 64×64 cloth onto the sphere, replacing the last one; or,
/// `hanging`, drops the same cloth beside the sphere pinned at two corners,
/// so it swings down and hangs free: the same motion without contacts.
fn drop_cloth(app: &mut App, hanging: bool) {
    let old: Vec<Entity> = app
        .world_mut()
        .query_filtered::<Entity, With<ClothParticles>>()
        .iter(app.world())
        .collect();
    for e in old {
        app.world_mut().despawn(e);
    }
    let cloth = if hanging {
        ClothBuilder::new(64, 64)
            .size(1.0, 1.0)
            .position(Vec3::new(2.0, 1.35, 0.0))
            .pin_corner(GridCorner::TopLeft)
            .pin_corner(GridCorner::TopRight)
    } else {
        ClothBuilder::new(64, 64)
            .size(1.0, 1.0)
            .position(Vec3::new(0.0, 1.35, 0.0))
    };
    app.world_mut().spawn(cloth.build().expect("valid"));
}

/// One `App::update` = one 1/60 s fixed step plus mesh sync, for a 64×64
/// cloth draped on a sphere: only frames in [`DRAPED`] are timed, and the
/// cloth is dropped again whenever it gets past them.
fn game_frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame_64x64_sphere_mesh");
    group
        .measurement_time(Duration::from_secs(5))
        .sample_size(20);
    // The same cloth dropped free beside the sphere (pinned at two
    // corners), for what its contacts cost.
    for (integrator, substeps, helper, hanging) in [
        (Integrator::BackwardEuler, 1, true, true),
        (Integrator::BackwardEuler, 1, true, false),
        (Integrator::BackwardEuler, 1, false, false),
        (Integrator::Bdf2, 1, true, false),
        (Integrator::SymplecticEuler, 220, true, false),
    ] {
        let mut settings = ClothSettings::default()
            .with_integrator(integrator, substeps)
            .without_adaptive();
        settings.implicit.helper_thread = helper;
        // Timed stepping: a cloth that comes to rest keeps stepping.
        settings.sleep.enabled = false;
        let mut app = headless(settings);
        app.world_mut().spawn((
            ClothCollider::sphere(0.3),
            Transform::from_xyz(0.0, 1.0, 0.0),
        ));
        let mut frame = DRAPED.end;
        // Named `BE/1` and so on; `BE_one_thread/1` without the helper.
        let name = match (integrator.is_implicit(), helper, hanging) {
            (_, _, true) => format!("{}_hanging", integrator.name()),
            (true, false, _) => format!("{}_one_thread", integrator.name()),
            _ => integrator.name().to_string(),
        };
        group.bench_function(BenchmarkId::new(name, substeps), |b| {
            b.iter_custom(|iters| {
                let mut timed = Duration::ZERO;
                for _ in 0..iters {
                    if frame == DRAPED.end {
                        drop_cloth(&mut app, hanging);
                        for _ in 0..DRAPED.start {
                            app.update();
                        }
                        frame = DRAPED.start;
                    }
                    let start = std::time::Instant::now();
                    app.update();
                    timed += start.elapsed();
                    frame += 1;
                }
                timed
            })
        });
    }
    group.finish();
}

/// One frame of the `tablecloth` example's scene with every default: a
/// 1.5 m, 31 × 31 cotton cloth draped on a round table (a cylinder) over a
/// floor, contacts 1 cm thick. Timed from 1 s to 6 s after the drop.
fn tablecloth_frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame_tablecloth");
    group
        .measurement_time(Duration::from_secs(5))
        .sample_size(20);
    let mut settings = ClothSettings::default();
    settings.sleep.enabled = false;
    let mut app = headless(settings);
    app.world_mut().spawn((
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    app.world_mut().spawn((
        ClothCollider::cylinder(0.56, 0.02).with_friction(0.35),
        Transform::from_xyz(0.0, 0.76, 0.0),
    ));
    let spawn = |app: &mut App| {
        let old: Vec<Entity> = app
            .world_mut()
            .query_filtered::<Entity, With<ClothParticles>>()
            .iter(app.world())
            .collect();
        for e in old {
            app.world_mut().despawn(e);
        }
        let cloth = ClothBuilder::new(31, 31)
            .size(1.5, 1.5)
            .position(Vec3::new(0.0, 0.81, 0.0))
            .build()
            .expect("valid");
        app.world_mut().spawn((
            cloth,
            ClothCollision {
                thickness: 0.01,
                ..default()
            },
        ));
        for _ in 0..60 {
            app.update();
        }
    };
    let mut frame = 360;
    group.bench_function("defaults", |b| {
        b.iter_custom(|iters| {
            let mut timed = Duration::ZERO;
            for _ in 0..iters {
                if frame == 360 {
                    spawn(&mut app);
                    frame = 60;
                }
                let start = std::time::Instant::now();
                app.update();
                timed += start.elapsed();
                frame += 1;
            }
            timed
        })
    });
    group.finish();
}

criterion_group!(benches, game_frame, tablecloth_frame);
criterion_main!(benches);
