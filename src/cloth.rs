//! The [`Cloth`] component, its validated [`ClothBuilder`] and [`ClothError`].

use bevy::math::{Quat, Vec2, Vec3};
use bevy::prelude::{Bundle, Component, Reflect, ReflectComponent, Transform};

use crate::connections::ClothConnections;
use crate::interaction::ClothGrabs;
use crate::material::ClothMaterial;
use crate::particles::ClothParticles;
use crate::settings::ClothSettings;
use crate::step::{ClothForces, ClothScratch, ClothStats};

/// Everything that can be wrong with a cloth's description.
#[derive(thiserror::Error, Clone, Debug, PartialEq)]
pub enum ClothError {
    /// The grid needs at least 3×3 particles (Type 2 links span two spacings).
    #[error("a cloth grid needs at least 3x3 particles, got {cols}x{rows}")]
    GridTooSmall {
        /// Requested columns.
        cols: u32,
        /// Requested rows.
        rows: u32,
    },
    /// The grid has more particles than [`MAX_PARTICLES`].
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
    /// Substeps must be between 1 and [`MAX_SUBSTEPS`](crate::settings::MAX_SUBSTEPS).
    #[error("substeps must be between 1 and 100000, got {0}")]
    InvalidSubsteps(u32),
    /// Adaptive substeps need a safety factor in (0, 1] and a cap between 1
    /// and [`MAX_SUBSTEPS`](crate::settings::MAX_SUBSTEPS).
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
    /// iteration and a finite, non-negative Newton strain.
    #[error(
        "the implicit solver needs a tolerance in (0, 1), at least one iteration and a finite, non-negative newton_strain"
    )]
    InvalidSolver,
    /// A crease is invalid (non-finite, ratio outside (0, 1], angle outside
    /// [0, π), zero length, or missing the cloth).
    #[error("invalid crease: {0}")]
    InvalidCrease(&'static str),
    /// Gravity (m/s²) must be finite.
    #[error("gravity must be finite, got {0}")]
    InvalidGravity(Vec3),
}

/// Most particles one cloth may have (a 1024×1024 grid).
pub const MAX_PARTICLES: u32 = 1 << 20;

/// A rectangular cloth: one entity whose particles and connections are
/// [`ClothParticles`] and [`ClothConnections`]. Make it with [`ClothBuilder`].
///
/// Particle `(i, j)` (column `i`, row `j`) has index `p = j·cols + i` and rest
/// coordinates `(u, v) = (i·w/(cols−1), j·h/(rows−1))` in metres.
///
/// Particles are simulated in world space; keep the entity's `Transform` at
/// identity unless you want the rendered mesh offset from the simulation.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(
    Transform,
    ClothForces,
    ClothScratch,
    ClothStats,
    ClothGrabs,
    ClothMaterial,
    crate::mesh::ClothPrevious
)]
pub struct Cloth {
    /// Particles per row.
    pub cols: u32,
    /// Particles per column.
    pub rows: u32,
    /// Rest width (along columns) and height (along rows) in m.
    pub size: Vec2,
}

impl Cloth {
    /// Number of particles.
    pub fn len(&self) -> usize {
        (self.cols * self.rows) as usize
    }

    /// Whether the grid is empty (never for a built cloth).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Particle index of column `i`, row `j`.
    pub fn index(&self, i: u32, j: u32) -> u32 {
        j * self.cols + i
    }

    /// Rest coordinates `(u, v)` in m of particle `p`.
    pub fn rest_uv(&self, p: u32) -> Vec2 {
        let (i, j) = (p % self.cols, p / self.cols);
        Vec2::new(
            i as f32 * self.size.x / (self.cols - 1) as f32,
            j as f32 * self.size.y / (self.rows - 1) as f32,
        )
    }

    /// Number of triangles, `2(cols−1)(rows−1)`.
    pub fn triangle_count(&self) -> usize {
        2 * ((self.cols - 1) * (self.rows - 1)) as usize
    }

    /// Triangle `t`: quad `q = t/2` (row-major) split into `(a, d, c)` and
    /// `(a, c, b)` with `a = (i, j)`, `b = (i+1, j)`, `c = (i+1, j+1)`,
    /// `d = (i, j+1)`; counter-clockwise about `+v × +u`.
    pub fn triangle(&self, t: u32) -> [u32; 3] {
        let q = t / 2;
        let (i, j) = (q % (self.cols - 1), q / (self.cols - 1));
        let (a, b) = (self.index(i, j), self.index(i + 1, j));
        let (c, d) = (self.index(i + 1, j + 1), self.index(i, j + 1));
        if t.is_multiple_of(2) {
            [a, d, c]
        } else {
            [a, c, b]
        }
    }

    /// Every triangle, without allocating.
    pub fn triangle_iter(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        (0..self.triangle_count() as u32).map(|t| self.triangle(t))
    }

    /// Every triangle as a vector (see [`triangle`](Self::triangle)).
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        self.triangle_iter().collect()
    }

    /// The rest spacing of the particles in m: the geometric mean of the
    /// spacing along the columns and along the rows.
    pub fn spacing(&self) -> f32 {
        let along = |len: f32, n: u32| len / (n.max(2) - 1) as f32;
        (along(self.size.x, self.cols) * along(self.size.y, self.rows)).sqrt()
    }

    /// The rest area in m².
    pub fn area(&self) -> f32 {
        self.size.x * self.size.y
    }
}

/// A corner of the grid: top = row 0, left = column 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Reflect)]
pub enum GridCorner {
    /// Column 0, row 0.
    TopLeft,
    /// Last column, row 0.
    TopRight,
    /// Column 0, last row.
    BottomLeft,
    /// Last column, last row.
    BottomRight,
}

/// An edge of the grid: top = row 0, left = column 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Reflect)]
pub enum GridEdge {
    /// Row 0.
    Top,
    /// The last row.
    Bottom,
    /// Column 0.
    Left,
    /// The last column.
    Right,
}

/// How the cloth's mass is given.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Mass {
    PerArea(f32),
    Total(f32),
}

/// A pin request, resolved when the grid is known.
enum Pin {
    Index(u32),
    Corner(GridCorner),
    Edge(GridEdge),
    Where(Box<dyn Fn(u32, u32, Vec2) -> bool + Send + Sync>),
}

/// The entity a [`ClothBuilder`] makes: spawn it with `commands.spawn(bundle)`.
#[derive(Bundle, Clone, Debug)]
pub struct ClothBundle {
    /// The grid description.
    pub cloth: Cloth,
    /// Particle state.
    pub particles: ClothParticles,
    /// Type 1 / Type 2 (or Lander) connections.
    pub connections: ClothConnections,
    /// What it is made of.
    pub material: ClothMaterial,
}

/// Builds a validated rectangular cloth.
///
/// The grid lies in the builder's local XZ plane, centred on the origin:
/// column `i` runs along +X, row `j` along +Z, so particle `(i, j)` sits at
/// `(u − w/2, 0, v − h/2)` before [`rotation`](Self::rotation) and
/// [`position`](Self::position) place it in the world. A horizontal sheet
/// needs neither; `rotation(Quat::from_rotation_x(FRAC_PI_2))` stands it up
/// with row 0 on top (a curtain).
///
/// The material defaults to [`ClothMaterial::COTTON`]; the mass to the
/// material's density (0.15 kg/m² for cotton and for raw constants), lumped
/// by area: corner, edge and interior particles get ¼, ½ and 1 share
/// (MODEL.md §1).
///
/// ```
/// use bevy_cloth::prelude::*;
/// let cloth = ClothBuilder::new(15, 15)
///     .size(1.0, 1.0)
///     .pin_corner(GridCorner::TopLeft)
///     .pin_corner(GridCorner::TopRight)
///     .build()
///     .unwrap();
/// assert_eq!(cloth.connections.type1_count(), 812);
/// ```
pub struct ClothBuilder {
    cols: u32,
    rows: u32,
    size: Vec2,
    mass: Option<Mass>,
    material: ClothMaterial,
    uniform_mass: bool,
    position: Vec3,
    rotation: Quat,
    pins: Vec<Pin>,
}

impl std::fmt::Debug for ClothBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ClothBuilder")
            .field("cols", &self.cols)
            .field("rows", &self.rows)
            .field("size", &self.size)
            .field("mass", &self.mass)
            .field("material", &self.material)
            .field("uniform_mass", &self.uniform_mass)
            .field("position", &self.position)
            .field("rotation", &self.rotation)
            .field("pins", &self.pins.len())
            .finish()
    }
}

impl ClothBuilder {
    /// A `cols × rows` grid of cotton, 1 m × 1 m, at the origin.
    pub fn new(cols: u32, rows: u32) -> Self {
        Self {
            cols,
            rows,
            size: Vec2::ONE,
            mass: None,
            material: ClothMaterial::COTTON,
            uniform_mass: false,
            position: Vec3::ZERO,
            rotation: Quat::IDENTITY,
            pins: Vec::new(),
        }
    }

    /// Width along the columns and height along the rows, in m.
    pub fn size(mut self, width: f32, height: f32) -> Self {
        self.size = Vec2::new(width, height);
        self
    }

    /// What the cloth is made of ([`ClothMaterial`]); its density gives
    /// the masses unless [`mass_per_area`](Self::mass_per_area) or
    /// [`total_mass`](Self::total_mass) says otherwise.
    pub fn material(mut self, material: ClothMaterial) -> Self {
        self.material = material;
        self
    }

    /// Areal density in kg/m² (instead of the material's).
    pub fn mass_per_area(mut self, kg_per_m2: f32) -> Self {
        self.mass = Some(Mass::PerArea(kg_per_m2));
        self
    }

    /// Total mass in kg (instead of the material's density).
    pub fn total_mass(mut self, kg: f32) -> Self {
        self.mass = Some(Mass::Total(kg));
        self
    }

    /// Gives every particle the same mass instead of lumping it by area.
    pub fn uniform_mass(mut self) -> Self {
        self.uniform_mass = true;
        self
    }

    /// World position of the grid's centre in m.
    pub fn position(mut self, position: Vec3) -> Self {
        self.position = position;
        self
    }

    /// World orientation of the grid (normalised when built).
    pub fn rotation(mut self, rotation: Quat) -> Self {
        self.rotation = rotation;
        self
    }

    /// Pins particle `index` (`p = row·cols + column`).
    pub fn pin(mut self, index: u32) -> Self {
        self.pins.push(Pin::Index(index));
        self
    }

    /// Pins a corner.
    pub fn pin_corner(mut self, corner: GridCorner) -> Self {
        self.pins.push(Pin::Corner(corner));
        self
    }

    /// Pins a whole edge.
    pub fn pin_edge(mut self, edge: GridEdge) -> Self {
        self.pins.push(Pin::Edge(edge));
        self
    }

    /// Pins every particle for which `predicate(column, row, rest_uv)` is
    /// true, with `rest_uv` in metres.
    pub fn pin_where(
        mut self,
        predicate: impl Fn(u32, u32, Vec2) -> bool + Send + Sync + 'static,
    ) -> Self {
        self.pins.push(Pin::Where(Box::new(predicate)));
        self
    }

    /// Checks the description and makes the cloth.
    pub fn build(self) -> Result<ClothBundle, ClothError> {
        let (cols, rows) = (self.cols, self.rows);
        if cols < 3 || rows < 3 {
            return Err(ClothError::GridTooSmall { cols, rows });
        }
        if cols as u64 * rows as u64 > MAX_PARTICLES as u64 {
            return Err(ClothError::GridTooLarge {
                cols,
                rows,
                max: MAX_PARTICLES,
            });
        }
        let size = self.size;
        if !(size.is_finite() && size.x > 0.0 && size.y > 0.0) {
            return Err(ClothError::InvalidSize {
                width: size.x,
                height: size.y,
            });
        }
        self.material.validate()?;
        let mass = self.mass.unwrap_or(Mass::PerArea(
            self.material.fabric().map_or(0.15, |f| f.density),
        ));
        let (Mass::PerArea(m) | Mass::Total(m)) = mass;
        if !(m.is_finite() && m > 0.0) {
            return Err(ClothError::InvalidMass(m));
        }
        let rot_len = self.rotation.length();
        if !(self.position.is_finite() && self.rotation.is_finite() && rot_len > 1e-6) {
            return Err(ClothError::InvalidPlacement);
        }
        let rotation = self.rotation / rot_len;

        let cloth = Cloth { cols, rows, size };
        let count = cloth.len();
        let total = match mass {
            Mass::PerArea(rho) => rho * size.x * size.y,
            Mass::Total(total) => total,
        };
        let masses: Vec<f32> = (0..count as u32)
            .map(|p| {
                if self.uniform_mass {
                    return total / count as f32;
                }
                let w = |k: u32, n: u32| if k == 0 || k == n - 1 { 0.5 } else { 1.0 };
                let share = w(p % cols, cols) * w(p / cols, rows);
                total * share / ((cols - 1) * (rows - 1)) as f32
            })
            .collect();
        if masses.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
            return Err(ClothError::InvalidMass(m));
        }
        let positions: Vec<Vec3> = (0..count as u32)
            .map(|p| {
                let uv = cloth.rest_uv(p) - 0.5 * size;
                self.position + rotation * Vec3::new(uv.x, 0.0, uv.y)
            })
            .collect();
        let connections = ClothConnections::grid(cols, rows, &positions);
        let mut particles = ClothParticles::new(positions, masses);
        for pin in &self.pins {
            for p in resolve(&cloth, pin)? {
                particles.pin(p as usize);
            }
        }
        Ok(ClothBundle {
            cloth,
            particles,
            connections,
            material: self.material,
        })
    }

    /// Like [`build`](Self::build), and also validates `settings` for use as
    /// this cloth's override: spawn the pair with `commands.spawn(pair)`.
    pub fn build_with(
        self,
        settings: ClothSettings,
    ) -> Result<(ClothBundle, ClothSettings), ClothError> {
        settings.validate()?;
        Ok((self.build()?, settings))
    }
}

fn resolve(cloth: &Cloth, pin: &Pin) -> Result<Vec<u32>, ClothError> {
    let (c, r) = (cloth.cols, cloth.rows);
    Ok(match pin {
        Pin::Index(p) => {
            if *p as usize >= cloth.len() {
                return Err(ClothError::ParticleOutOfRange {
                    index: *p,
                    count: cloth.len() as u32,
                });
            }
            vec![*p]
        }
        Pin::Corner(corner) => vec![match corner {
            GridCorner::TopLeft => cloth.index(0, 0),
            GridCorner::TopRight => cloth.index(c - 1, 0),
            GridCorner::BottomLeft => cloth.index(0, r - 1),
            GridCorner::BottomRight => cloth.index(c - 1, r - 1),
        }],
        Pin::Edge(GridEdge::Top) => (0..c).map(|i| cloth.index(i, 0)).collect(),
        Pin::Edge(GridEdge::Bottom) => (0..c).map(|i| cloth.index(i, r - 1)).collect(),
        Pin::Edge(GridEdge::Left) => (0..r).map(|j| cloth.index(0, j)).collect(),
        Pin::Edge(GridEdge::Right) => (0..r).map(|j| cloth.index(c - 1, j)).collect(),
        Pin::Where(f) => (0..cloth.len() as u32)
            .filter(|&p| f(p % c, p / c, cloth.rest_uv(p)))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    #[test]
    fn area_lumped_mass_adds_up_and_splits_by_quarters() {
        let b = ClothBuilder::new(15, 15)
            .mass_per_area(0.15)
            .build()
            .unwrap();
        let m = &b.particles.masses;
        let total: f32 = m.iter().sum();
        assert!((total - 0.15).abs() < 1e-6);
        let interior = 0.15 / 196.0;
        assert!((m[16] - interior).abs() < 1e-9); // MODEL.md §11: 7.65e-4 kg
        assert!((m[1] - interior / 2.0).abs() < 1e-9);
        assert!((m[0] - interior / 4.0).abs() < 1e-9);
        let u = ClothBuilder::new(15, 15)
            .total_mass(0.15)
            .uniform_mass()
            .build()
            .unwrap();
        assert!(
            u.particles
                .masses
                .iter()
                .all(|&x| (x - 0.15 / 225.0).abs() < 1e-9)
        );
    }

    #[test]
    fn placement_and_pins() {
        let b = ClothBuilder::new(5, 4)
            .size(2.0, 3.0)
            .position(Vec3::new(0.0, 2.0, 0.0))
            .rotation(Quat::from_rotation_x(FRAC_PI_2))
            .pin_corner(GridCorner::TopRight)
            .pin_edge(GridEdge::Left)
            .pin_where(|i, j, _| i == 2 && j == 3)
            .pin(6)
            .build()
            .unwrap();
        let x = &b.particles.positions;
        // Standing up: row 0 on top at y = 2 + 1.5, last row at y = 0.5.
        assert!((x[0] - Vec3::new(-1.0, 3.5, 0.0)).length() < 1e-5);
        assert!((x[19] - Vec3::new(1.0, 0.5, 0.0)).length() < 1e-5);
        let pinned: Vec<usize> = (0..20).filter(|&p| b.particles.is_pinned(p)).collect();
        assert_eq!(pinned, vec![0, 4, 5, 6, 10, 15, 17]);
    }

    #[test]
    fn each_invalid_input_returns_its_error() {
        use ClothError::*;
        let err = |b: ClothBuilder| b.build().unwrap_err();
        assert_eq!(
            err(ClothBuilder::new(2, 9)),
            GridTooSmall { cols: 2, rows: 9 }
        );
        assert_eq!(
            err(ClothBuilder::new(9, 0)),
            GridTooSmall { cols: 9, rows: 0 }
        );
        assert!(matches!(
            err(ClothBuilder::new(4096, 4096)),
            GridTooLarge { .. }
        ));
        assert!(matches!(
            err(ClothBuilder::new(u32::MAX, u32::MAX)),
            GridTooLarge { .. }
        ));
        for (w, h) in [
            (0.0, 1.0),
            (1.0, -1.0),
            (f32::NAN, 1.0),
            (1.0, f32::INFINITY),
        ] {
            assert!(matches!(
                err(ClothBuilder::new(3, 3).size(w, h)),
                InvalidSize { .. }
            ));
        }
        for m in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                err(ClothBuilder::new(3, 3).mass_per_area(m)),
                InvalidMass(_)
            ));
            assert!(matches!(
                err(ClothBuilder::new(3, 3).total_mass(m)),
                InvalidMass(_)
            ));
        }
        // Finite inputs whose per-particle mass underflows are still rejected.
        assert!(matches!(
            err(ClothBuilder::new(3, 3).size(1e-30, 1e-30)),
            InvalidMass(_)
        ));
        assert_eq!(
            err(ClothBuilder::new(3, 3).position(Vec3::NAN)),
            InvalidPlacement
        );
        assert_eq!(
            err(ClothBuilder::new(3, 3).rotation(Quat::from_xyzw(0.0, 0.0, 0.0, 0.0))),
            InvalidPlacement
        );
        assert_eq!(
            err(ClothBuilder::new(3, 3).pin(9)),
            ParticleOutOfRange { index: 9, count: 9 }
        );
        let mut bad = ClothSettings::default();
        bad.choi_ko.stiffness = -5.0;
        assert!(matches!(
            ClothBuilder::new(3, 3).build_with(bad).unwrap_err(),
            InvalidStiffness { .. }
        ));
        let bad = ClothSettings {
            damping: f32::NAN,
            ..Default::default()
        };
        assert!(matches!(
            ClothBuilder::new(3, 3).build_with(bad).unwrap_err(),
            InvalidDamping { .. }
        ));
        for (safety, max_substeps) in [(0.0, 10), (f32::NAN, 10), (1.5, 10), (0.5, 0)] {
            let bad = ClothSettings {
                adaptive: Some(crate::adaptive::AdaptiveSubsteps {
                    safety,
                    max_substeps,
                }),
                ..Default::default()
            };
            assert!(matches!(
                ClothBuilder::new(3, 3).build_with(bad).unwrap_err(),
                InvalidAdaptive { .. }
            ));
        }
    }

    #[test]
    fn triangles_cover_the_grid_counter_clockwise() {
        let b = ClothBuilder::new(15, 15).build().unwrap();
        let tris = b.cloth.triangles();
        assert_eq!(tris.len(), 392);
        // Columns along +X and rows along +Z: (a, d, c) turns +Z into +X, so
        // every triangle's normal is +Y for a horizontal sheet.
        let x = &b.particles.positions;
        let n = |t: &[u32; 3]| {
            (x[t[1] as usize] - x[t[0] as usize]).cross(x[t[2] as usize] - x[t[0] as usize])
        };
        assert!(tris.iter().all(|t| n(t).normalize().y > 0.99));
    }
}
