//! Scenes shared by the integration tests.

pub mod torn;

use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::ClothStats;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::integrate::StepBuffers;
use bevy_cloth::sim::step::step_cloth;

/// The paper's scene (MODEL.md §10.2, §11): an `n × n`, 1 m cotton cloth
/// standing in the XY plane, row 0 at y = 2 m, pinned at its two top corners.
pub fn hanging(n: u32) -> ClothBundle {
    bevy_cloth::lab::accuracy::scene(n)
}

/// An app whose every `update()` after the first runs exactly one 60 Hz
/// fixed step (`TimeUpdateStrategy::FixedTimesteps`); the first update is
/// already done.
pub fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, ClothPlugin::default()))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.update(); // the first update runs no fixed step
    app
}

/// Grabs `particles` of `cloth` where they are, kinematically.
pub fn grab_where_they_are(app: &mut App, cloth: Entity, particles: &[u32]) {
    let x = app
        .world()
        .get::<ClothParticles>(cloth)
        .unwrap()
        .positions
        .clone();
    let mut grabs = app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap();
    for &p in particles {
        grabs.grab(p, x[p as usize], GrabMode::Kinematic);
    }
}

/// Moves every grab target of `cloth` by `by` (m).
pub fn move_grabs(app: &mut App, cloth: Entity, by: Vec3) {
    let mut grabs = app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap();
    let targets: Vec<(u32, Vec3)> = grabs
        .grabs()
        .iter()
        .map(|g| (g.particle, g.target))
        .collect();
    for (p, t) in targets {
        grabs.set_target(p, t + by);
    }
}

/// The particles of cloth `e`.
pub fn particles(app: &App, e: Entity) -> &ClothParticles {
    app.world().get::<ClothParticles>(e).unwrap()
}

/// A horizontal `n × n`, 1 m cotton sheet at y = 2 m pinned at two corners
/// of row 0: the rest of it falls and swings down under gravity.
pub fn sheet(n: u32) -> ClothBundle {
    ClothBuilder::new(n, n)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .expect("valid cloth")
}

/// What a run of [`simulate`] saw.
#[derive(Debug, Clone, Copy)]
pub struct Run {
    /// Whether every value stayed finite.
    pub finite: bool,
    /// Largest Type 1 strain at any step.
    pub peak_strain: f32,
    /// Stats after the last step.
    pub last: Option<(f32, f32)>,
    /// Simulated seconds before the run stopped.
    pub seconds: f32,
}

/// Steps `cloth` with `settings` (substeps = 1) at `dt` for `seconds`,
/// stopping early once it is non-finite or stretched past 100%.
pub fn simulate(cloth: &mut ClothBundle, settings: &ClothSettings, dt: f32, seconds: f32) -> Run {
    let mut settings = settings.clone();
    settings.substeps = 1;
    let mut buffers = StepBuffers::new(cloth.particles.len());
    let mut stats = ClothStats::default();
    let mut run = Run {
        finite: true,
        peak_strain: 0.0,
        last: None,
        seconds: 0.0,
    };
    let steps = (seconds / dt).round() as usize;
    for k in 0..steps {
        step_cloth(
            &mut cloth.particles,
            &cloth.connections,
            &settings,
            &[],
            &mut buffers,
            dt,
        );
        stats.measure(&cloth.particles, &cloth.connections);
        run.seconds = (k + 1) as f32 * dt;
        if !stats.finite || stats.max_strain.is_nan() {
            run.finite = false;
            break;
        }
        run.peak_strain = run.peak_strain.max(stats.max_strain);
        if stats.max_strain > 1.0 {
            break;
        }
    }
    run.last = Some((stats.max_strain, stats.kinetic_energy));
    run
}

/// A small deterministic random source (xorshift64*) for abuse tests.
pub struct Rng(u64);

impl Rng {
    /// A generator from a non-zero seed.
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [−1, 1).
    pub fn signed(&mut self) -> f32 {
        2.0 * self.unit() - 1.0
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: u32) -> u32 {
        (self.next() % n as u64) as u32
    }
}

/// [`disc`](bevy_cloth::sim::topology::disc) of `radius` m as positions and
/// indices, every inner vertex moved by up to `jitter` of a spacing so the
/// triangles are irregular (the rim stays round).
pub fn jittered_disc(rings: u32, radius: f32, jitter: f32) -> (Vec<Vec3>, Vec<u32>) {
    let (mut positions, indices) = bevy_cloth::sim::topology::disc(radius, rings);
    let spacing = radius / rings as f32;
    let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
    let rim = positions.len() - 6 * rings as usize;
    for p in positions.iter_mut().take(rim) {
        *p += Vec3::new(rng.signed(), 0.0, rng.signed()) * 0.5 * jitter * spacing;
    }
    (positions, indices)
}

/// A Bevy `Mesh` of a [`jittered_disc`] in the xz plane, its UVs the
/// positions mapped onto `[0, 1]²`.
pub fn disc_mesh(rings: u32, radius: f32, jitter: f32) -> Mesh {
    let (positions, indices) = jittered_disc(rings, radius, jitter);
    triangle_mesh(&positions, indices)
}

/// A Bevy triangle-list `Mesh` with `positions` (m), `indices` and UVs
/// from the xz coordinates.
pub fn triangle_mesh(positions: &[Vec3], indices: Vec<u32>) -> Mesh {
    let (lo, hi) = positions
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(l, h), p| (l.min(*p), h.max(*p)));
    let span = (hi - lo).max(Vec3::splat(1e-6));
    let uvs: Vec<[f32; 2]> = positions
        .iter()
        .map(|p| [(p.x - lo.x) / span.x, (p.z - lo.z) / span.z])
        .collect();
    Mesh::new(
        bevy::mesh::PrimitiveTopology::TriangleList,
        bevy::asset::RenderAssetUsages::default(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_POSITION,
        positions.iter().map(|p| p.to_array()).collect::<Vec<_>>(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
    .with_inserted_indices(bevy::mesh::Indices::U32(indices))
}

/// An app as [`app`] that also has `Assets<Mesh>`, so cloths get a live
/// mesh; the mesh shows the last step as it is (no interpolation).
pub fn app_with_meshes() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        ClothPlugin::default(),
    ))
    .init_asset::<Mesh>()
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
    .insert_resource(ClothMeshSettings { interpolate: false });
    app.update();
    app
}

/// A 1.4 m × 0.6 m hammock (29 × 13 particles, 5 cm apart) hung slack
/// between two posts 1.2 m apart at y = 1 m, pinned along its short edges:
/// its long sides sag 0.31 m in a circular arc. `dress` sets what it is
/// made of (mass, material).
pub fn hammock(dress: impl FnOnce(ClothBuilder) -> ClothBuilder) -> ClothBundle {
    let builder = ClothBuilder::new(29, 13)
        .size(1.4, 0.6)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin_edge(GridEdge::Left)
        .pin_edge(GridEdge::Right);
    let mut cloth = dress(builder).build().unwrap();
    // Arc length 1.4 m over a chord of 1.2 m: half-angle φ with
    // sin φ / φ = 6/7, radius 0.7 / φ.
    let phi = 0.9474f32;
    let radius = 0.7 / phi;
    for p in &mut cloth.particles.positions {
        let a = p.x / radius;
        *p = Vec3::new(radius * a.sin(), 1.0 - radius * (a.cos() - phi.cos()), p.z);
    }
    cloth
}

/// Columns of the [`ribbon`].
pub const COLS: u32 = 5;
/// Rows of the [`ribbon`].
pub const ROWS: u32 = 9;

/// A 0.4 m × 0.8 m ribbon behind the body from y = 1.6 m down, skinned
/// to an upper bone (joint 1; its top half) blending into the root (joint
/// 0; its bottom half); freedom 0 on the top row, 0.5 on the next four, 1
/// below.
pub fn ribbon() -> Mesh {
    let mut positions = Vec::new();
    let (mut joints, mut weights, mut freedom) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..ROWS {
        for i in 0..COLS {
            positions.push([-0.2 + 0.1 * i as f32, 1.6 - 0.1 * j as f32, -0.1]);
            let t = (j as f32 - 4.0).max(0.0) / 8.0;
            joints.push([1u16, 0, 0, 0]);
            weights.push([1.0 - t, t, 0.0, 0.0]);
            freedom.push(match j {
                0 => 0.0f32,
                1..=4 => 0.5,
                _ => 1.0,
            });
        }
    }
    let mut indices = Vec::new();
    for j in 0..ROWS - 1 {
        for i in 0..COLS - 1 {
            let a = j * COLS + i;
            let (b, c, d) = (a + 1, a + 1 + COLS, a + COLS);
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

/// The skeleton (a root and an upper bone 1.2 m up, its child) and the
/// worn ribbon with max distance `max` m.
pub fn wear(app: &mut App, max: f32) -> (Entity, Entity, Entity) {
    let root = app.world_mut().spawn(Transform::default()).id();
    let upper = app
        .world_mut()
        .spawn((Transform::from_xyz(0.0, 1.2, 0.0), ChildOf(root)))
        .id();
    let mesh = ribbon();
    let cloth = ClothBuilder::from_mesh(&mesh).build().unwrap();
    let binds = [
        Mat4::IDENTITY,
        Mat4::from_translation(Vec3::new(0.0, -1.2, 0.0)),
    ];
    let layout = cloth.cloth.mesh().unwrap().clone();
    let skin = ClothSkin::from_mesh(
        &mesh,
        &layout,
        (vec![root, upper], &binds),
        ATTRIBUTE_FREEDOM.name,
        max,
    )
    .unwrap();
    let e = app.world_mut().spawn((cloth, skin)).id();
    (root, upper, e)
}

/// An app without gravity whose cloths are paper-like (`k_b` = 1e-4 N·m²,
/// stiff enough in bending to keep a crease's flaps flat), stepped with
/// `stepping`.
pub fn paper_app_with(stepping: ClothSettings) -> App {
    let mut app = app();
    let mut settings = SimSettings {
        gravity: Vec3::ZERO,
        ..stepping.0
    };
    settings.choi_ko.bending_rigidity = 1e-4;
    app.insert_resource(ClothSettingsDefaults(settings));
    app
}

/// The smallest distance (m) between the surfaces of cloths `a` and `b`:
/// each one's particles against the other's triangles.
pub fn closest(app: &App, a: Entity, b: Entity) -> f32 {
    let one_way = |p: Entity, t: Entity| {
        let x = &particles(app, p).positions;
        let y = &particles(app, t).positions;
        let faces = app.world().get::<Cloth>(t).unwrap();
        let mut least = f32::MAX;
        for &point in x {
            for tri in bevy_cloth::sim::grid::Faces::faces(faces) {
                let corners = tri.map(|q| y[q as usize]);
                let near =
                    bevy_cloth::sim::collision::trimesh::closest_point_on_triangle(point, corners);
                least = least.min(point.distance(near));
            }
        }
        least
    };
    one_way(a, b).min(one_way(b, a))
}
