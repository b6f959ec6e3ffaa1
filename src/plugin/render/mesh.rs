//! The live mesh: every cloth gets a [`Mesh3d`] whose positions and smooth
//! normals follow the particles after each frame's fixed steps. A grid
//! cloth's mesh has one vertex per particle and UVs along its columns and
//! rows; a mesh cloth's has the source mesh's vertices, UVs and triangles,
//! with the welded vertices of a seam sharing their particle's position and
//! normal.
//!
//! - Runs in `PostUpdate` ([`ClothMeshSystems`]), before the asset events, so
//!   Bevy's bounds system sees the changed mesh in the same frame and keeps
//!   the `Aabb` right for culling and picking (no `NoFrustumCulling`, no
//!   `NoAutoAabb` needed).
//! - Writes go through `Mesh::try_attribute_mut`; a mesh that was taken by
//!   the render world, lost an attribute or changed size is rebuilt, never a
//!   panic.
//! - Vertex positions are the particles' world positions brought into the
//!   cloth entity's local space, so any cloth `Transform` renders correctly.
//! - **Interpolation** ([`ClothMeshSettings::interpolate`], on by default):
//!   the mesh shows the cloth between its last two fixed steps, at the
//!   fraction of a step that `Time<Fixed>` has accumulated
//!   (`overstep_fraction`), so a 144 Hz display does not show a 60 Hz cloth
//!   stepping. The mesh is one fixed step behind the simulation, as with
//!   any interpolation. The positions at the start of each step are kept in
//!   a component of the plugin's own.
//! - Only cloths that moved are written: a paused or resting cloth costs
//!   nothing here. A cloth whose state is not finite keeps its last good
//!   mesh, so a blow-up never reaches the renderer or picking.
//! - With no `Assets<Mesh>` (a headless app without asset plugins), none of
//!   this runs.

use bevy::asset::{AssetEventSystems, Assets, RenderAssetUsages};
use bevy::ecs::schedule::SystemSet;
use bevy::math::{Affine3A, Vec3};
use bevy::mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::{
    Commands, Component, DetectChanges, Entity, GlobalTransform, Local, Query, Ref, Reflect,
    ReflectResource, Res, ResMut, Resource, Time, Without,
};
use bevy::time::Fixed;

use crate::plugin::step::components::Cloth;
use crate::plugin::step::components::ClothParticles;
use crate::sim::grid::Faces;

/// How cloth meshes are drawn.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// # let mut app = App::new();
/// // Show each fixed step as it is, without interpolation.
/// app.insert_resource(ClothMeshSettings { interpolate: false });
/// ```
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct ClothMeshSettings {
    /// Whether meshes show the cloth interpolated between its last two
    /// fixed steps (module docs); off, they show the last step as it is.
    pub interpolate: bool,
}

impl Default for ClothMeshSettings {
    fn default() -> Self {
        Self { interpolate: true }
    }
}

/// The positions (m, world) of a cloth's particles at the start of its
/// last fixed step, for [`ClothMeshSettings::interpolate`]; written at the
/// start of every step ([`ClothSystems::Prepare`](crate::ClothSystems::Prepare)).
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct ClothPrevious {
    /// Positions in m.
    pub(crate) positions: Vec<Vec3>,
    /// Whether the last step left every particle where it was, so there is
    /// nothing to interpolate.
    pub(crate) still: bool,
}

/// Keeps each cloth's [`ClothPrevious`]: the positions before this step.
pub(crate) fn remember_positions(
    _main: crate::plugin::step::schedule::MainThread,
    mut cloths: Query<(&ClothParticles, &mut ClothPrevious)>,
) {
    for (particles, mut previous) in &mut cloths {
        let previous = &mut *previous;
        previous.still = previous.positions == particles.positions;
        if !previous.still {
            previous.positions.clone_from(&particles.positions);
        }
    }
}

/// The `PostUpdate` sets that keep cloth meshes in step with the simulation.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ClothMeshSystems {
    /// New cloths get a mesh (and, with the `render` feature, a default
    /// double-sided material unless they have one).
    Attach,
    /// Positions and normals are written into the mesh asset.
    Sync,
}

/// Area-weighted smooth vertex normals of a `cols × rows` grid whose
/// triangles are those of [`Grid::triangles`](crate::sim::grid::Grid::triangles). `x` in any length unit;
/// `out` receives unit vectors (+Y where a vertex has no area around it).
pub fn grid_normals(cols: u32, rows: u32, x: &[Vec3], out: &mut [[f32; 3]]) {
    out.fill([0.0; 3]);
    let mut add = |p: u32, n: Vec3| {
        let o = &mut out[p as usize];
        *o = (Vec3::from_array(*o) + n).to_array();
    };
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            let (a, b) = (j * cols + i, j * cols + i + 1);
            let (c, d) = (b + cols, a + cols);
            let (xa, xb, xc, xd) = (x[a as usize], x[b as usize], x[c as usize], x[d as usize]);
            // Twice the area times the unit normal of (a, d, c) and (a, c, b).
            let n1 = (xd - xa).cross(xc - xa);
            let n2 = (xc - xa).cross(xb - xa);
            for (p, n) in [(a, n1 + n2), (d, n1), (c, n1 + n2), (b, n2)] {
                add(p, n);
            }
        }
    }
    for o in out.iter_mut() {
        *o = Vec3::from_array(*o)
            .try_normalize()
            .unwrap_or(Vec3::Y)
            .to_array();
    }
}

/// Area-weighted smooth normals of the particles of any cloth's triangles
/// `faces`, seen from the side their winding faces. `x` in any length unit;
/// `out` (one per particle) receives unit vectors (+Y where a particle has
/// no area around it).
pub fn face_normals(faces: &impl Faces, x: &[Vec3], out: &mut [[f32; 3]]) {
    out.fill([0.0; 3]);
    for t in faces.faces() {
        let [a, b, c] = t.map(|p| x[p as usize]);
        // Twice the area times the unit normal.
        let n = (b - a).cross(c - a);
        for p in t {
            let o = &mut out[p as usize];
            *o = (Vec3::from_array(*o) + n).to_array();
        }
    }
    for o in out.iter_mut() {
        *o = Vec3::from_array(*o)
            .try_normalize()
            .unwrap_or(Vec3::Y)
            .to_array();
    }
}

/// Number of vertices of `cloth`'s live mesh.
fn render_len(cloth: &Cloth) -> usize {
    match cloth.grid() {
        Some(grid) => grid.len(),
        None => cloth.layout().vertex_particles().len(),
    }
}

/// Whether `cloth` can have a mesh with particles `x`.
fn renderable(cloth: &Cloth, x: &[Vec3]) -> bool {
    x.len() == cloth.len()
        && match cloth.grid() {
            Some(grid) => grid.cols >= 2 && grid.rows >= 2,
            None => !cloth.layout().indices().is_empty(),
        }
}

/// Smooth normals of `cloth`'s rendered vertices for particles at `x` (m,
/// world), brought into local space by `inv`; `scratch` holds a mesh
/// cloth's normals per particle.
fn write_normals(
    cloth: &Cloth,
    x: &[Vec3],
    inv: Option<Affine3A>,
    out: &mut [[f32; 3]],
    scratch: &mut Vec<[f32; 3]>,
) {
    let local = |n: [f32; 3]| match inv {
        Some(inv) => inv
            .transform_vector3(Vec3::from_array(n))
            .try_normalize()
            .unwrap_or(Vec3::Y)
            .to_array(),
        None => n,
    };
    match cloth.grid() {
        Some(grid) => {
            grid_normals(grid.cols, grid.rows, x, out);
            if inv.is_some() {
                out.iter_mut().for_each(|o| *o = local(*o));
            }
        }
        None => {
            let mesh = cloth.layout();
            scratch.resize(x.len(), [0.0; 3]);
            face_normals(mesh.topology(), x, scratch);
            for (o, &p) in out.iter_mut().zip(mesh.vertex_particles()) {
                *o = local(scratch[p as usize]);
            }
        }
    }
}

/// Positions of `cloth`'s rendered vertices for particles at `x` (m,
/// world), brought into local space by `inv`.
fn write_positions(cloth: &Cloth, x: &[Vec3], inv: Option<Affine3A>, out: &mut [[f32; 3]]) {
    let local = |p: Vec3| inv.map_or(p, |inv| inv.transform_point3(p)).to_array();
    match cloth.grid() {
        Some(_) => {
            for (o, &p) in out.iter_mut().zip(x) {
                *o = local(p);
            }
        }
        None => {
            for (o, &p) in out.iter_mut().zip(cloth.layout().vertex_particles()) {
                *o = local(x[p as usize]);
            }
        }
    }
}

/// A mesh for `cloth` with particles at `x` (m, world) and the world-to-
/// local transform `inv`: positions, smooth normals, UVs and triangles (a
/// grid's UVs run over `[0, 1]²` along its columns and rows and its
/// triangles are [`Grid::triangles`](crate::sim::grid::Grid::triangles); a
/// mesh cloth keeps its source mesh's). Kept in both worlds so the CPU copy
/// can be rewritten and ray-cast for picking.
pub fn cloth_mesh(cloth: &Cloth, x: &[Vec3], inv: Option<Affine3A>) -> Mesh {
    let n = render_len(cloth);
    let mut positions = vec![[0.0; 3]; n];
    write_positions(cloth, x, inv, &mut positions);
    let mut normals = vec![[0.0; 3]; n];
    write_normals(cloth, x, inv, &mut normals, &mut Vec::new());
    let (uvs, indices): (Vec<[f32; 2]>, Vec<u32>) = match cloth.grid() {
        Some(grid) => {
            let (cu, rv) = ((grid.cols - 1) as f32, (grid.rows - 1) as f32);
            let uvs = (0..grid.len() as u32)
                .map(|p| [(p % grid.cols) as f32 / cu, (p / grid.cols) as f32 / rv])
                .collect();
            (uvs, grid.triangles().into_iter().flatten().collect())
        }
        None => {
            let mesh = cloth.layout();
            (mesh.uvs_or_projected(), mesh.indices().to_vec())
        }
    };
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
    .with_inserted_indices(Indices::U32(indices))
}

/// World-to-local transform of a cloth entity, or `None` for the identity.
fn to_local(transform: Option<&GlobalTransform>) -> Option<Affine3A> {
    transform
        .map(|t| t.affine())
        .filter(|a| *a != Affine3A::IDENTITY)
        .map(|a| a.inverse())
}

/// How many vertices `mesh` has (`None` without readable positions), so a
/// resized cloth gets a new mesh.
fn vertex_count(mesh: &Mesh) -> Option<usize> {
    match mesh.try_attribute(Mesh::ATTRIBUTE_POSITION) {
        Ok(VertexAttributeValues::Float32x3(p)) => Some(p.len()),
        _ => None,
    }
}

/// [`ClothMeshSystems::Attach`]: gives each new cloth its mesh.
pub(crate) fn attach_cloth_meshes(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    cloths: Query<(Entity, &Cloth, &ClothParticles, Option<&GlobalTransform>), Without<Mesh3d>>,
) {
    for (entity, cloth, particles, transform) in &cloths {
        if !renderable(cloth, &particles.positions) {
            continue;
        }
        let handle = meshes.add(cloth_mesh(cloth, &particles.positions, to_local(transform)));
        let mut e = commands.entity(entity);
        e.try_insert(Mesh3d(handle));
        // Picked from both sides, and also when the game's mesh picking
        // requires markers.
        #[cfg(feature = "picking")]
        e.try_insert((
            bevy::picking::mesh_picking::ray_cast::RayCastBackfaces,
            bevy::picking::Pickable::default(),
        ));
    }
}

/// What the mesh sync reads of one cloth.
type SyncQuery = (
    Ref<'static, Cloth>,
    Ref<'static, ClothParticles>,
    Option<&'static ClothPrevious>,
    &'static Mesh3d,
    Option<&'static GlobalTransform>,
);

/// [`ClothMeshSystems::Sync`]: writes positions and normals of every cloth
/// that moved: its particles changed, or it is being interpolated between
/// two different steps; and remakes the whole mesh (triangles, UVs) of a
/// cloth whose topology changed (a tear, [`Cloth::set_layout`]).
pub(crate) fn sync_cloth_meshes(
    mut meshes: ResMut<Assets<Mesh>>,
    settings: Option<Res<ClothMeshSettings>>,
    time: Option<Res<Time<Fixed>>>,
    mut shown: Local<Vec<Vec3>>,
    mut scratch: Local<Vec<[f32; 3]>>,
    cloths: Query<SyncQuery>,
) {
    let interpolate = settings.is_none_or(|s| s.interpolate);
    let alpha = time.map_or(1.0, |t| t.overstep_fraction().clamp(0.0, 1.0));
    for (cloth, particles, previous, mesh3d, transform) in &cloths {
        let n = cloth.len();
        let between =
            previous.filter(|p| interpolate && !p.still && p.positions.len() == n && alpha < 1.0);
        let edited = cloth.is_changed();
        let cloth = &*cloth;
        if !particles.is_changed() && between.is_none() && !edited {
            continue;
        }
        // A non-finite state keeps the last good mesh: NaN vertices would
        // break bounds, culling and picking (Bevy asserts on them).
        if !renderable(cloth, &particles.positions) || !particles.is_finite() {
            continue;
        }
        let x: &[Vec3] = match between {
            Some(previous) => {
                shown.clear();
                shown.extend(
                    previous
                        .positions
                        .iter()
                        .zip(&particles.positions)
                        .map(|(a, b)| a.lerp(*b, alpha)),
                );
                if !shown.iter().all(|x| x.is_finite()) {
                    continue;
                }
                &shown
            }
            None => &particles.positions,
        };
        let Some(mut mesh) = meshes.get_mut(&mesh3d.0) else {
            continue;
        };
        let inv = to_local(transform);
        let vertices = render_len(cloth);
        if edited || vertex_count(&mesh) != Some(vertices) {
            *mesh = cloth_mesh(cloth, x, inv);
            continue;
        }
        if let Ok(VertexAttributeValues::Float32x3(out)) =
            mesh.try_attribute_mut(Mesh::ATTRIBUTE_POSITION)
        {
            write_positions(cloth, x, inv, out);
        }
        match mesh.try_attribute_mut(Mesh::ATTRIBUTE_NORMAL) {
            Ok(VertexAttributeValues::Float32x3(out)) if out.len() == vertices => {
                write_normals(cloth, x, inv, out, &mut scratch);
            }
            _ => *mesh = cloth_mesh(cloth, x, inv),
        }
    }
}

/// Orders the mesh sets in `PostUpdate` before the asset events, so bounds
/// are recomputed in the same frame.
pub(crate) fn configure(
    app: &mut bevy::app::App,
    schedule: bevy::ecs::intern::Interned<dyn bevy::ecs::schedule::ScheduleLabel>,
) {
    use bevy::app::PostUpdate;
    use bevy::ecs::query::With;
    use bevy::ecs::schedule::IntoScheduleConfigs;
    use bevy::ecs::schedule::common_conditions::{
        any_match_filter, any_with_component, resource_exists,
    };
    app.init_resource::<ClothMeshSettings>()
        .register_type::<ClothMeshSettings>()
        .add_systems(
            schedule,
            // Outside the cloth sets, so that it runs while they are paused
            // too: a paused cloth is still, not interpolated.
            remember_positions
                .before(crate::ClothSystems::Prepare)
                .run_if(any_with_component::<Cloth>)
                .run_if(resource_exists::<Assets<Mesh>>)
                .run_if(|s: Res<ClothMeshSettings>| s.interpolate),
        );
    app.configure_sets(
        PostUpdate,
        (ClothMeshSystems::Attach, ClothMeshSystems::Sync)
            .chain()
            .before(AssetEventSystems)
            .run_if(any_with_component::<Cloth>)
            .run_if(resource_exists::<Assets<Mesh>>),
    )
    .add_systems(
        PostUpdate,
        (
            attach_cloth_meshes
                .run_if(any_match_filter::<(With<Cloth>, Without<Mesh3d>)>)
                .in_set(ClothMeshSystems::Attach),
            sync_cloth_meshes.in_set(ClothMeshSystems::Sync),
        ),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_grid_normals_are_up_and_a_fold_tilts_them() {
        let mut x: Vec<Vec3> = (0..9)
            .map(|p| Vec3::new((p % 3) as f32, 0.0, (p / 3) as f32))
            .collect();
        let mut n = vec![[0.0; 3]; 9];
        grid_normals(3, 3, &x, &mut n);
        assert!(
            n.iter()
                .all(|v| (Vec3::from_array(*v) - Vec3::Y).length() < 1e-6)
        );
        // Lift the last column: the normals there lean towards −X.
        for p in [2, 5, 8] {
            x[p].y = 1.0;
        }
        grid_normals(3, 3, &x, &mut n);
        assert!(n[5][0] < -0.1 && (Vec3::from_array(n[5]).length() - 1.0).abs() < 1e-6);
        // Degenerate (all particles at one point): no NaN.
        grid_normals(3, 3, &[Vec3::ONE; 9], &mut n);
        assert!(n.iter().all(|v| *v == [0.0, 1.0, 0.0]));
    }
}
