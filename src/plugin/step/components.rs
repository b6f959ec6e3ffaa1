//! The components of a cloth entity that hold the simulation's state: thin
//! newtypes over the [`sim`](crate::sim) types, which they dereference to,
//! so `particles.positions` reads the same on a component as on the plain
//! type; and the per-cloth forces and statistics of a fixed step.

use std::sync::atomic::{AtomicU64, Ordering};

use bevy::math::Vec3;
use bevy::prelude::{
    Component, Deref, DerefMut, Reflect, ReflectComponent, ReflectDefault, ReflectResource,
    Resource,
};

use crate::error::ClothError;
use crate::plugin::spawn::mesh_cloth::MeshLayout;
use crate::sim::connections::{Connections, max_strain};
use crate::sim::grid::{Faces, Grid};
use crate::sim::particles::Particles;
use crate::sim::settings::{ClothModel, Integrator, SimSettings};

/// A cloth: one entity whose particles and connections are
/// [`ClothParticles`] and [`ClothConnections`], over one triangle-mesh
/// topology ([`MeshLayout`]). Make it with [`ClothBuilder`](crate::ClothBuilder)
/// (a rectangular [`Grid`]) or
/// [`ClothBuilder::from_mesh`](crate::ClothBuilder::from_mesh) (any triangle
/// mesh); [`ClothPlugin`](crate::ClothPlugin) makes it require the step's
/// other components (forces, stats, grabs, material, scratch, the previous
/// positions and a `Transform`).
///
/// The layout is the cloth's topology whichever way it was built: a grid
/// cloth's is [`MeshLayout::from_grid`]. A grid cloth also keeps its
/// [`Grid`] ([`Cloth::grid`]) as long as its topology is that grid's, and
/// the step, the coarse correction and the render mesh take the grid's fast
/// paths from it; a topology edit ([`Cloth::set_layout`], which tearing
/// and cutting use) drops it, and the cloth goes on as a mesh cloth with the
/// same particles.
///
/// Particles are simulated in world space; keep the entity's `Transform` at
/// identity unless you want the rendered mesh offset from the simulation.
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(opaque, Component, Clone, Debug, PartialEq)]
pub struct Cloth {
    /// The particles and triangles: the topology every system reads.
    layout: MeshLayout,
    /// The grid `layout` was built as, while it still is that grid.
    grid: Option<Grid>,
    /// A number no other topology of any cloth has had
    /// ([`Cloth::generation`]).
    generation: u64,
}

/// A number not handed out before.
fn fresh_generation() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// Equal layouts and grids, whatever their generations.
impl PartialEq for Cloth {
    fn eq(&self, other: &Self) -> bool {
        self.layout == other.layout && self.grid == other.grid
    }
}

impl From<Grid> for Cloth {
    fn from(grid: Grid) -> Self {
        Self {
            layout: MeshLayout::from_grid(&grid),
            grid: Some(grid),
            generation: fresh_generation(),
        }
    }
}

impl From<MeshLayout> for Cloth {
    fn from(layout: MeshLayout) -> Self {
        Self {
            layout,
            grid: None,
            generation: fresh_generation(),
        }
    }
}

impl Cloth {
    /// The grid of a cloth built as a rectangular grid whose topology is
    /// still that grid's (`None` for a mesh cloth and for a torn grid).
    pub fn grid(&self) -> Option<&Grid> {
        self.grid.as_ref()
    }

    /// The cloth's topology and render layout, for every cloth.
    pub fn layout(&self) -> &MeshLayout {
        &self.layout
    }

    /// The layout of a cloth that is not a grid (`None` while
    /// [`Cloth::grid`] is `Some`): where the step takes the general mesh
    /// paths.
    pub fn mesh(&self) -> Option<&MeshLayout> {
        self.grid.is_none().then_some(&self.layout)
    }

    /// Replaces the cloth's topology with `layout`, which has the same
    /// number of particles as the cloth's [`ClothParticles`] after the edit
    /// (the caller resizes those and rewrites [`ClothConnections`]). The
    /// grid fast path is dropped unless `layout` is the grid's own.
    pub fn set_layout(&mut self, layout: MeshLayout) {
        if self.grid.as_ref().is_some_and(|grid| {
            layout.topology() != &crate::sim::topology::MeshTopology::from_grid(grid)
        }) {
            self.grid = None;
        }
        self.layout = layout;
        self.generation = fresh_generation();
    }

    /// The topology's generation: a number that changes with every
    /// [`set_layout`](Self::set_layout) and that no other cloth's topology
    /// has (a clone shares it, with the same topology). Caches built from
    /// the triangles (self-collision's edge list, a cloth–cloth contact's)
    /// compare it instead of the triangles.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.layout.topology().len()
    }

    /// Whether there are no particles (never for a built cloth).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The rest spacing of the particles in m (a grid's
    /// [`Grid::spacing`]; a mesh's mean edge length), which scales a
    /// [`ClothMaterial`](crate::ClothMaterial)'s stiffness.
    pub fn spacing(&self) -> f32 {
        match &self.grid {
            Some(grid) => grid.spacing(),
            None => self.layout.spacing(),
        }
    }

    /// The rest area in m².
    pub fn area(&self) -> f32 {
        match &self.grid {
            Some(grid) => grid.area(),
            None => self.layout.area(),
        }
    }
}

impl Faces for Cloth {
    fn face_count(&self) -> usize {
        match &self.grid {
            Some(grid) => grid.face_count(),
            None => self.layout.topology().face_count(),
        }
    }

    fn face(&self, t: u32) -> [u32; 3] {
        match &self.grid {
            Some(grid) => grid.face(t),
            None => self.layout.topology().face(t),
        }
    }

    fn cell_size(&self) -> f32 {
        match &self.grid {
            Some(grid) => grid.cell_size(),
            None => self.layout.cell_size(),
        }
    }

    fn generation(&self) -> Option<u64> {
        Some(self.generation)
    }
}

/// Positions (m), velocities (m/s) and masses (kg) of a cloth's particles:
/// the cloth entity's [`Particles`], which it dereferences to. To borrow two
/// of its arrays mutably at once, go through the field:
/// `let p = &mut particles.0;`.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// /// The height (m) of every cloth's lowest particle.
/// fn lowest(cloths: Query<&ClothParticles>) {
///     for particles in &cloths {
///         let low = particles.positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
///         info!("lowest particle at {low} m");
///     }
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect, Deref, DerefMut)]
#[reflect(Component)]
pub struct ClothParticles(pub Particles);

impl ClothParticles {
    /// Particles at rest at `positions` (m) with masses `masses` (kg, > 0).
    pub fn new(positions: Vec<Vec3>, masses: Vec<f32>) -> Self {
        Self(Particles::new(positions, masses))
    }
}

/// The links a cloth's internal forces act on: the cloth entity's
/// [`Connections`], which it dereferences to.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect, Deref, DerefMut)]
#[reflect(Component)]
pub struct ClothConnections(pub Connections);

impl ClothConnections {
    /// Every connection of a `cols × rows` grid resting at `rest` (m); see
    /// [`Connections::grid`].
    pub fn grid(cols: u32, rows: u32, rest: &[Vec3]) -> Self {
        Self(Connections::grid(cols, rows, rest))
    }
}

/// How one cloth is simulated: on a cloth entity, overrides
/// [`ClothSettingsDefaults`]. Dereferences to its [`SimSettings`].
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) -> Result<(), ClothError> {
///     // RK4 with adaptive substeps and no damping, for this cloth only.
///     let mut settings = ClothSettings::default().with_integrator(Integrator::Rk4, 1);
///     settings.damping = 0.0;
///     commands.spawn((ClothBuilder::new(16, 16).build()?, settings));
///     // Every field at once.
///     let stiff = ClothSettings(SimSettings { substeps: 2, ..default() });
///     commands.spawn((ClothBuilder::new(16, 16).build()?, stiff));
///     Ok(())
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect, Deref, DerefMut)]
#[reflect(Component, Default)]
pub struct ClothSettings(pub SimSettings);

impl ClothSettings {
    /// The same settings with another model ([`SimSettings::with_model`]).
    pub fn with_model(self, model: ClothModel) -> Self {
        Self(self.0.with_model(model))
    }

    /// The same settings with another integrator and least substep count
    /// ([`SimSettings::with_integrator`]).
    pub fn with_integrator(self, integrator: Integrator, substeps: u32) -> Self {
        Self(self.0.with_integrator(integrator, substeps))
    }

    /// The same settings with adaptive substeps off
    /// ([`SimSettings::without_adaptive`]).
    pub fn without_adaptive(self) -> Self {
        Self(self.0.without_adaptive())
    }
}

impl From<SimSettings> for ClothSettings {
    fn from(settings: SimSettings) -> Self {
        Self(settings)
    }
}

/// The settings of every cloth that has no [`ClothSettings`] of its own.
#[derive(Resource, Clone, Debug, Default, PartialEq, Reflect, Deref, DerefMut)]
#[reflect(Resource, Default)]
pub struct ClothSettingsDefaults(pub SimSettings);

/// External forces on each particle in N, held constant through one fixed
/// step and cleared after it.
///
/// Systems in [`ClothSystems::Forces`](crate::plugin::step::schedule::ClothSystems::Forces)
/// add to it (wind, a grab spring, a game's explosion); an empty vector
/// means no external force and costs nothing.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothForces(pub Vec<Vec3>);

impl ClothForces {
    /// Adds `force` (N) to particle `p`, sizing the buffer for `count`
    /// particles on first use. Out-of-range indices are ignored.
    pub fn add(&mut self, p: usize, force: Vec3, count: usize) {
        if self.0.len() != count {
            self.0.clear();
            self.0.resize(count, Vec3::ZERO);
        }
        if let Some(f) = self.0.get_mut(p) {
            *f += force;
        }
    }
}

/// What the last fixed step of a cloth looked like.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn report(cloths: Query<(Entity, &ClothStats)>) {
///     for (cloth, stats) in &cloths {
///         if stats.max_strain > 0.1 {
///             info!("cloth {cloth} stretched {:.0} %", 100.0 * stats.max_strain);
///         }
///     }
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
#[non_exhaustive]
pub struct ClothStats {
    /// Fixed steps simulated so far.
    pub steps: u64,
    /// Largest stretch `(ℓ − L)/L` of the stretch links (Type 1 for Choi–Ko,
    /// structural and shear for Lander), dimensionless.
    pub max_strain: f32,
    /// Kinetic energy of the free particles in J.
    pub kinetic_energy: f32,
    /// Whether every position and velocity is finite.
    pub finite: bool,
    /// Conjugate-gradient iterations of the last implicit substep (0 for
    /// the explicit integrators, and while the cloth sleeps).
    pub solver_iterations: u32,
    /// Wall-clock time of the last fixed step's integration, µs (for
    /// display; never asserted on); 0 while the cloth sleeps.
    pub step_micros: f32,
    /// Substeps the last step ran with (more than the settings' after the
    /// divergence guard stepped in).
    pub substeps: u32,
    /// Integrator the last step ran with.
    pub integrator: crate::sim::settings::Integrator,
    /// Speed of the fastest free particle, m/s.
    pub max_speed: f32,
    /// Whether the cloth is at rest (see [`ClothAtRest`](crate::plugin::step::events::ClothAtRest)).
    pub resting: bool,
}

impl ClothStats {
    /// Measures `particles` against `connections`.
    pub fn measure(&mut self, particles: &Particles, connections: &Connections) {
        self.measure_with(
            particles,
            max_strain(connections.type1(), &particles.positions),
        );
    }

    /// [`ClothStats::measure`] given the largest strain, measured already.
    pub(crate) fn measure_with(&mut self, particles: &Particles, max_strain: f32) {
        self.max_strain = max_strain;
        self.kinetic_energy = particles.kinetic_energy();
        self.max_speed = particles.max_speed();
        self.finite = particles.is_finite();
    }
}

/// Checks what the step indexes so that user edits can never make it panic:
/// equal array lengths, and every link inside the particle range.
pub fn check_cloth(
    particles: &ClothParticles,
    connections: &ClothConnections,
) -> Result<(), ClothError> {
    check_indices(particles, connections.max_index())
}

/// [`check_cloth`] given the connections' largest index.
pub(crate) fn check_indices(
    particles: &ClothParticles,
    max_index: Option<u32>,
) -> Result<(), ClothError> {
    let n = particles.len();
    if particles.velocities.len() != n
        || particles.inverse_masses.len() != n
        || particles.masses.len() != n
    {
        return Err(ClothError::InconsistentParticles);
    }
    match max_index {
        Some(index) if index as usize >= n => Err(ClothError::ParticleOutOfRange {
            index,
            count: n as u32,
        }),
        _ => Ok(()),
    }
}
