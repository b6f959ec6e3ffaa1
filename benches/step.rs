//! `cargo bench --bench step`: force evaluation and one step per integrator
//! at 15×15, 64×64 and 128×128 (cotton, MODEL.md §11), and whole frames of
//! many cloths, a large one and a cloth on a mesh collider; a disc cloth
//! against a grid of as many particles. The game frame
//! of a 64×64 cloth on a sphere is `cargo bench --bench frame`.

mod common;

use std::hint::black_box;
use std::time::Duration;

use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPool};
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::lab::accuracy::scene;
use bevy_cloth::plugin::ComputePool;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::integrate::StepBuffers;
use bevy_cloth::sim::model::{
    ForceStreams, internal_forces, internal_forces_banded, internal_forces_streamed,
};
use bevy_cloth::sim::particles::Particles;
use bevy_cloth::sim::step::step_cloth;
use bevy_cloth::sim::topology::{MeshTopology, disc};
use bevy_cloth::sim::workers::Workers;
use common::headless;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

const SIZES: [u32; 3] = [15, 64, 128];

/// The paper's scene after 0.2 s of settling, so links are both stretched
/// and slack as in a real run.
fn settled(n: u32) -> ClothBundle {
    let mut cloth = scene(n);
    let settings = ClothSettings::default().with_integrator(Integrator::BackwardEuler, 1);
    let mut buffers = StepBuffers::new(cloth.particles.len());
    for _ in 0..12 {
        step_cloth(
            &mut cloth.particles,
            &cloth.connections,
            &settings,
            &[],
            &mut buffers,
            1.0 / 60.0,
        );
    }
    cloth
}

fn forces(c: &mut Criterion) {
    let pool = ComputePool(ComputeTaskPool::get_or_init(TaskPool::default));
    let mut group = c.benchmark_group("forces");
    for n in SIZES {
        let cloth = settled(n);
        let mut f = vec![Vec3::ZERO; cloth.particles.len()];
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let settings = ClothSettings::default().with_model(model);
            group.bench_function(BenchmarkId::new(format!("{model:?}"), n), |b| {
                b.iter(|| {
                    f.fill(Vec3::ZERO);
                    internal_forces(
                        &settings,
                        &cloth.connections,
                        &cloth.particles.positions,
                        &cloth.particles.velocities,
                        &mut f,
                    );
                    black_box(&f);
                })
            });
        }
        // The same forces by index step, as the explicit integrators run them.
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let settings = ClothSettings::default().with_model(model);
            let mut streams = ForceStreams::default();
            group.bench_function(BenchmarkId::new(format!("{model:?}_streamed"), n), |b| {
                b.iter(|| {
                    f.fill(Vec3::ZERO);
                    internal_forces_streamed(
                        &settings,
                        &cloth.connections,
                        &cloth.particles.positions,
                        &cloth.particles.velocities,
                        &mut f,
                        &mut streams,
                    );
                    black_box(&f);
                })
            });
        }
        // The same Choi–Ko forces in parallel bands on the compute pool.
        let settings = ClothSettings::default();
        let name = format!("ChoiKo_banded_{}threads", pool.threads());
        group.bench_function(BenchmarkId::new(name, n), |b| {
            b.iter(|| {
                f.fill(Vec3::ZERO);
                let banded = internal_forces_banded(
                    Some(&pool),
                    &settings,
                    &cloth.connections,
                    &cloth.particles.positions,
                    &cloth.particles.velocities,
                    &mut f,
                );
                assert!(banded);
                black_box(&f);
            })
        });
    }
    group.finish();
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    group
        .measurement_time(Duration::from_secs(3))
        .sample_size(30);
    for n in SIZES {
        let cloth = settled(n);
        for integrator in Integrator::ALL {
            let settings = ClothSettings::default().with_integrator(integrator, 1);
            // Explicit steps at a step each is stable at for 15×15 cotton;
            // implicit ones at a game's 1/60 s.
            let dt = if integrator.is_implicit() {
                1.0 / 60.0
            } else {
                1e-4
            };
            let mut buffers = StepBuffers::new(cloth.particles.len());
            let mut particles = cloth.particles.clone();
            group.bench_function(BenchmarkId::new(integrator.name(), n), |b| {
                b.iter(|| {
                    // Every iteration starts from the same state, so an
                    // unstable step cannot skew the timing; the copy is
                    // timed too. The state stays in cache, as it does from
                    // one substep to the next in a game (fresh clones per
                    // iteration, as before, fetched it from memory: 15×15
                    // RK4 10.8 against 9.8 µs).
                    particles
                        .positions
                        .copy_from_slice(&cloth.particles.positions);
                    particles
                        .velocities
                        .copy_from_slice(&cloth.particles.velocities);
                    // Every iteration solves from scratch: a warm start
                    // from the identical last step would be free.
                    buffers.reset_history();
                    step_cloth(
                        &mut particles,
                        &cloth.connections,
                        &settings,
                        &[],
                        &mut buffers,
                        dt,
                    )
                })
            });
        }
    }
    group.finish();
}

/// One implicit frame (backward Euler, 1/60 s) of a cloth of any shape
/// against a grid of about as many particles: a 4,000-particle disc (36
/// rings, 1.2 m across, every inner particle moved by up to a quarter of a
/// spacing) held at six rim particles, and a flat 64×64 grid of the same
/// area held at six edge particles, both cotton, both sagging for 0.2 s
/// first.
fn mesh_frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh_vs_grid");
    group
        .measurement_time(Duration::from_secs(3))
        .sample_size(30);
    let rings = 36;
    let (mut positions, indices) = disc(0.6, rings);
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let rim = positions.len() - 6 * rings as usize;
    let spacing = 0.6 / rings as f32;
    for (k, p) in positions.iter_mut().enumerate() {
        if k < rim {
            *p += Vec3::new(unit(), 0.0, unit()) * 0.25 * spacing;
        }
        p.y += 1.0;
    }
    let topology = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let mut disc_particles =
        Particles::new(topology.positions.clone(), topology.lumped_masses(0.15));
    for k in 0..6 {
        disc_particles.pin(rim + k * rings as usize);
    }
    // The grid as the disc: flat, 1.06 m across (its area), held at its
    // corners and the middles of two edges, sagging.
    let grid = ClothBuilder::new(64, 64)
        .size(1.06, 1.06)
        .position(Vec3::Y)
        .pin_where(|i, j, _| [0, 32, 63].contains(&i) && [0, 63].contains(&j))
        .build()
        .unwrap();
    let cases = [
        ("disc_3997", disc_particles, topology.connections(), spacing),
        (
            "grid_64x64",
            grid.particles.0.clone(),
            grid.connections.0.clone(),
            grid.cloth.spacing(),
        ),
    ];
    for (name, start, links, h) in cases {
        let mut settings = SimSettings::default();
        Fabric::COTTON.apply(&mut settings, h);
        let mut buffers = StepBuffers::new(start.len());
        let mut settled = start.clone();
        for _ in 0..12 {
            step_cloth(
                &mut settled,
                &links,
                &settings,
                &[],
                &mut buffers,
                1.0 / 60.0,
            );
        }
        let mut particles = settled.clone();
        group.bench_function(name, |b| {
            b.iter(|| {
                particles.positions.copy_from_slice(&settled.positions);
                particles.velocities.copy_from_slice(&settled.velocities);
                buffers.reset_history();
                step_cloth(
                    &mut particles,
                    &links,
                    &settings,
                    &[],
                    &mut buffers,
                    1.0 / 60.0,
                )
            })
        });
    }
    group.finish();
}

/// [`headless`] with `cloths` spawned and five frames run.
fn settled_app(settings: ClothSettings, cloths: impl IntoIterator<Item = ClothBundle>) -> App {
    let mut app = headless(settings);
    for cloth in cloths {
        app.world_mut().spawn(cloth);
    }
    for _ in 0..5 {
        app.update();
    }
    app
}

/// Scale: one 1/60 s frame of 100 cloths of 16×16 (spread over the task
/// pool by the step system) and of one 256×256 cloth.
fn scale(c: &mut Criterion) {
    let mut group = c.benchmark_group("scale");
    group
        .measurement_time(Duration::from_secs(5))
        .sample_size(10);
    let many = || {
        (0..100).map(|k| {
            let mut cloth = scene(16);
            let offset = Vec3::new((k % 10) as f32 * 1.5, 0.0, (k / 10) as f32 * 1.5);
            for x in &mut cloth.particles.positions {
                *x += offset;
            }
            cloth
        })
    };
    for (integrator, substeps) in [(Integrator::SymplecticEuler, 40), (Integrator::Bdf2, 1)] {
        let settings = ClothSettings::default().with_integrator(integrator, substeps);
        let mut app = settled_app(settings, many());
        let name = format!("100_cloths_16x16_{}", integrator.name());
        group.bench_function(BenchmarkId::new(name, substeps), |b| {
            b.iter(|| app.update())
        });
    }
    // The implicit integrators evaluate forces with their Jacobians, on
    // one thread: `parallel` does not apply.
    let settings = ClothSettings::default().with_integrator(Integrator::Bdf2, 1);
    let mut app = settled_app(settings, [scene(256)]);
    group.bench_function(BenchmarkId::new("1_cloth_256x256_BDF2", 1), |b| {
        b.iter(|| app.update())
    });
    group.finish();
}

/// One 1/60 s frame of a 32×32 cloth draped on a mesh sphere of 80 and of
/// about 10 600 triangles: the BVH keeps the cost from following the count.
fn mesh_collider(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame_32x32_on_mesh_sphere");
    group
        .measurement_time(Duration::from_secs(4))
        .sample_size(20);
    for subdivisions in [1u32, 22] {
        let sphere = Sphere::new(0.3)
            .mesh()
            .ico(subdivisions)
            .expect("valid ico sphere");
        let collider = ClothCollider::mesh(&sphere).expect("a triangle mesh");
        let triangles = match &collider.shape {
            bevy_cloth::plugin::collision::ColliderShape::Mesh(m) => m.0.triangles.len(),
            _ => 0,
        };
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, TransformPlugin, ClothPlugin::default()))
            .insert_resource(Time::<Fixed>::from_hz(60.0))
            .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
            .insert_resource(ClothSettingsDefaults(
                SimSettings::default().with_integrator(Integrator::Bdf2, 1),
            ));
        app.world_mut()
            .spawn((collider, Transform::from_xyz(0.0, 1.0, 0.0)));
        app.world_mut().spawn(
            ClothBuilder::new(32, 32)
                .size(1.0, 1.0)
                .position(Vec3::new(0.0, 1.35, 0.0))
                .build()
                .expect("valid"),
        );
        for _ in 0..60 {
            app.update();
        }
        group.bench_function(BenchmarkId::new("triangles", triangles), |b| {
            b.iter(|| app.update())
        });
    }
    group.finish();
}

criterion_group!(benches, forces, steps, mesh_frame, mesh_collider, scale);
criterion_main!(benches);
