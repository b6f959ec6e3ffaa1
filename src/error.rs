//! [`ClothError`]: everything that can be wrong with a cloth's description
//! or settings. It names no other module of the crate, so every layer can
//! return it.

use bevy::math::Vec3;

/// Everything that can be wrong with a cloth's description.
#[derive(thiserror::Error, Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ClothError {
    /// The grid needs at least 3×3 particles (Type 2 links span two spacings).
    #[error("a cloth grid needs at least 3x3 particles, got {cols}x{rows}")]
    GridTooSmall {
        /// Requested columns.
        cols: u32,
        /// Requested rows.
        rows: u32,
    },
    /// The grid has more particles than [`MAX_PARTICLES`](crate::sim::grid::MAX_PARTICLES).
    #[error("a {cols}x{rows} grid exceeds the limit of {max} particles")]
    GridTooLarge {
        /// Requested columns.
        cols: u32,
        /// Requested rows.
        rows: u32,
        /// The limit.
        max: u32,
    },
    /// Width and height (m) must be finite and positive.
    #[error("cloth size must be finite and positive, got {width} m x {height} m")]
    InvalidSize {
        /// Requested width in m.
        width: f32,
        /// Requested height in m.
        height: f32,
    },
    /// Mass (kg, or kg/m² per area) must be finite and positive.
    #[error("cloth mass must be finite and positive, got {0}")]
    InvalidMass(f32),
    /// Position or rotation is not finite, or the rotation has zero length.
    #[error("cloth placement must be finite with a non-zero rotation")]
    InvalidPlacement,
    /// A particle index is not in the grid.
    #[error("particle index {index} is out of range for {count} particles")]
    ParticleOutOfRange {
        /// The offending index.
        index: u32,
        /// Particles in the cloth.
        count: u32,
    },
    /// The particle arrays (positions, velocities, masses) differ in length.
    #[error("the particle arrays of a cloth differ in length")]
    InconsistentParticles,
    /// A stiffness (N/m or N·m²) is not finite and positive.
    #[error("stiffness `{name}` must be finite and positive, got {value}")]
    InvalidStiffness {
        /// Which setting.
        name: &'static str,
        /// Its value.
        value: f32,
    },
    /// A damping coefficient (s⁻¹ or N·s/m) is not finite and non-negative.
    #[error("damping `{name}` must be finite and non-negative, got {value}")]
    InvalidDamping {
        /// Which setting.
        name: &'static str,
        /// Its value.
        value: f32,
    },
    /// Substeps must be between 1 and [`MAX_SUBSTEPS`](crate::sim::settings::MAX_SUBSTEPS).
    #[error("substeps must be between 1 and 100000, got {0}")]
    InvalidSubsteps(u32),
    /// Adaptive substeps need a safety factor in (0, 1] and a cap between 1
    /// and [`MAX_SUBSTEPS`](crate::sim::settings::MAX_SUBSTEPS).
    #[error(
        "adaptive substeps need safety in (0, 1] and max_substeps in 1..=100000, got {safety} and {max_substeps}"
    )]
    InvalidAdaptive {
        /// The safety factor given.
        safety: f32,
        /// The substep cap given.
        max_substeps: u32,
    },
    /// A collider's shape or material is invalid, or its mesh unusable.
    #[error("invalid collider: {0}")]
    InvalidCollider(&'static str),
    /// The implicit solve needs a tolerance in (0, 1), at least one
    /// iteration, at most 8 past solutions, a finite, non-negative Newton
    /// strain and a positive strain limit (infinite turns it off).
    #[error(
        "the implicit solver needs a tolerance in (0, 1), at least one iteration, at most 8 past solutions, a finite, non-negative newton_strain and a strain_limit > 0"
    )]
    InvalidSolver,
    /// A crease is invalid (non-finite, ratio outside (0, 1], angle outside
    /// [0, π), zero length, or missing the cloth).
    #[error("invalid crease: {0}")]
    InvalidCrease(&'static str),
    /// Sleep thresholds must be finite and non-negative, the wake speed at
    /// least the rest speed (m/s), the margin finite (m), and at least one
    /// calm step.
    #[error(
        "invalid sleep settings: rest speed {rest_speed} m/s, wake speed {wake_speed} m/s, {rest_steps} calm steps, margin {margin} m"
    )]
    InvalidSleep {
        /// The rest speed given, m/s.
        rest_speed: f32,
        /// The wake speed given, m/s.
        wake_speed: f32,
        /// The calm steps given.
        rest_steps: u32,
        /// The margin given, m.
        margin: f32,
    },
    /// Level-of-detail distances must be finite and positive with the
    /// freezing distance beyond the near one (m; it may be infinite), and
    /// the rate between 1 and 16 fixed steps.
    #[error(
        "invalid level of detail: near {near} m, freeze {freeze} m, every {max_every} fixed steps at most"
    )]
    InvalidLod {
        /// The near distance given, m.
        near: f32,
        /// The freezing distance given, m.
        freeze: f32,
        /// The largest rate given, fixed steps.
        max_every: u32,
    },
    /// A tearing threshold must be finite and positive: a strain
    /// (dimensionless) or a force (N).
    #[error("invalid tearing threshold {name}: {value}")]
    InvalidTearing {
        /// Which threshold.
        name: &'static str,
        /// The value given.
        value: f32,
    },
    /// Collision between cloths needs a finite, positive thickness (m) and
    /// a finite, non-negative friction coefficient.
    #[error("invalid cloth-to-cloth collision: thickness {thickness} m, friction {friction}")]
    InvalidClothContact {
        /// The thickness given, m.
        thickness: f32,
        /// The friction coefficient given.
        friction: f32,
    },
    /// Gravity (m/s²) must be finite.
    #[error("gravity must be finite, got {0}")]
    InvalidGravity(Vec3),
    /// A cloth mesh has no triangles, or an index list whose length is not
    /// a multiple of 3.
    #[error("a cloth mesh needs triangles: got {indices} indices")]
    NoTriangles {
        /// Indices given (vertices, for a mesh without indices).
        indices: usize,
    },
    /// A cloth mesh's vertex position (m) is NaN or infinite.
    #[error("vertex {vertex} of the cloth mesh is not finite: {position}")]
    NonFiniteVertex {
        /// The vertex.
        vertex: u32,
        /// Its position, m.
        position: Vec3,
    },
    /// Every triangle of a cloth mesh has zero area or a repeated vertex.
    #[error("every one of the {triangles} triangles of the cloth mesh is degenerate")]
    DegenerateMesh {
        /// Triangles given.
        triangles: usize,
    },
    /// A Bevy mesh a cloth cannot be made from (not a triangle list, no
    /// `Float32x3` positions, no vertex colours to read pins from).
    #[error("unsupported cloth mesh: {0}")]
    UnsupportedMesh(&'static str),
    /// A cloth mesh welds to more particles than
    /// [`MAX_PARTICLES`](crate::sim::grid::MAX_PARTICLES).
    #[error("a cloth mesh of {particles} particles exceeds the limit of {max}")]
    MeshTooLarge {
        /// Particles after welding.
        particles: usize,
        /// The limit.
        max: u32,
    },
}
