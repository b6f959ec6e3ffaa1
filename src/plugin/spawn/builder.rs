//! The validated [`ClothBuilder`] and the [`ClothBundle`] it makes. The
//! [`Cloth`] grid and [`ClothError`] live in [`grid`](crate::sim::grid) and
//! [`error`](crate::error) and are re-exported here.

use bevy::math::{Quat, Vec2, Vec3};
use bevy::prelude::Bundle;

use crate::error::ClothError;
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::step::components::Cloth;
use crate::plugin::step::components::ClothConnections;
use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::components::ClothSettings;
use crate::sim::build::{Mass, checked_placement, placed};
use crate::sim::grid::{Grid, GridCorner, GridEdge};
use crate::sim::particles::PinOwner;

/// What both builders share: the material, the mass and the placement.
#[derive(Clone, Debug)]
pub(crate) struct Common {
    pub(crate) material: ClothMaterial,
    pub(crate) mass: Option<Mass>,
    pub(crate) uniform_mass: bool,
    pub(crate) position: Vec3,
    pub(crate) rotation: Quat,
}

impl Default for Common {
    fn default() -> Self {
        Self {
            material: ClothMaterial::COTTON,
            mass: None,
            uniform_mass: false,
            position: Vec3::ZERO,
            rotation: Quat::IDENTITY,
        }
    }
}

impl Common {
    /// The checks both builders make of what they share: the material, the
    /// mass (the material's density unless given; finite and positive) and
    /// the placement (finite, a rotation of non-zero length). Returns the
    /// mass, its number (kg/m² or kg) and the normalised rotation.
    pub(crate) fn check(&self) -> Result<(Mass, f32, Quat), ClothError> {
        self.material.validate()?;
        let fabric_density = self.material.fabric().map_or(0.15, |f| f.density);
        let mass = self.mass.unwrap_or(Mass::PerArea(fabric_density));
        let m = mass.checked()?;
        Ok((mass, m, checked_placement(self.position, self.rotation)?))
    }

    /// The bundle both builders make: checks the particles' `masses` (kg;
    /// `m`, the mass the builder was given, names an invalid one), pins
    /// the particles `resolve` gives for each of `pins`, and puts the
    /// components together.
    #[expect(
        clippy::too_many_arguments,
        reason = "the parts of a cloth, each made by its builder"
    )]
    pub(crate) fn bundle<P>(
        &self,
        m: f32,
        cloth: Cloth,
        positions: Vec<Vec3>,
        masses: Vec<f32>,
        connections: ClothConnections,
        pins: &[P],
        resolve: impl Fn(&P) -> Result<Vec<u32>, ClothError>,
    ) -> Result<ClothBundle, ClothError> {
        if masses.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
            return Err(ClothError::InvalidMass(m));
        }
        let mut particles = ClothParticles::new(positions, masses);
        for pin in pins {
            for p in resolve(pin)? {
                particles.pin_by(p as usize, PinOwner::Builder);
            }
        }
        Ok(ClothBundle {
            cloth,
            particles,
            connections,
            material: self.material,
        })
    }

    /// The shared fields, for a builder's `Debug`.
    pub(crate) fn debug_fields(&self, d: &mut std::fmt::DebugStruct<'_, '_>) {
        d.field("material", &self.material)
            .field("mass", &self.mass)
            .field("uniform_mass", &self.uniform_mass)
            .field("position", &self.position)
            .field("rotation", &self.rotation);
    }
}

/// The setters of [`Common`] and `build_with`, one definition for both
/// builders; `$origin` names the point [`position`](ClothBuilder::position)
/// places.
macro_rules! common_methods {
    ($origin:literal) => {
        /// What the cloth is made of ([`ClothMaterial`]); its density gives
        /// the masses unless [`mass_per_area`](Self::mass_per_area) or
        /// [`total_mass`](Self::total_mass) says otherwise.
        pub fn material(mut self, material: ClothMaterial) -> Self {
            self.common.material = material;
            self
        }

        /// Areal density in kg/m² (instead of the material's).
        pub fn mass_per_area(mut self, kg_per_m2: f32) -> Self {
            self.common.mass = Some($crate::sim::build::Mass::PerArea(kg_per_m2));
            self
        }

        /// Total mass in kg (instead of the material's density).
        pub fn total_mass(mut self, kg: f32) -> Self {
            self.common.mass = Some($crate::sim::build::Mass::Total(kg));
            self
        }

        /// Gives every particle the same mass instead of lumping it by area.
        pub fn uniform_mass(mut self) -> Self {
            self.common.uniform_mass = true;
            self
        }

        #[doc = concat!("World position (m) of ", $origin, ".")]
        pub fn position(mut self, position: Vec3) -> Self {
            self.common.position = position;
            self
        }

        /// World orientation of the cloth (normalised when built).
        pub fn rotation(mut self, rotation: Quat) -> Self {
            self.common.rotation = rotation;
            self
        }

        /// Like [`build`](Self::build), and also validates `settings` for use as
        /// this cloth's override (a [`ClothSettings`] or a
        /// [`SimSettings`](crate::SimSettings)): spawn the pair with
        /// `commands.spawn(pair)`.
        pub fn build_with(
            self,
            settings: impl Into<ClothSettings>,
        ) -> Result<(ClothBundle, ClothSettings), ClothError> {
            let settings = settings.into();
            settings.validate()?;
            Ok((self.build()?, settings))
        }
    };
}
pub(crate) use common_methods;

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
    /// The layout: a grid or a mesh.
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
    common: Common,
    pins: Vec<Pin>,
}

impl std::fmt::Debug for ClothBuilder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut d = f.debug_struct("ClothBuilder");
        d.field("cols", &self.cols)
            .field("rows", &self.rows)
            .field("size", &self.size);
        self.common.debug_fields(&mut d);
        d.field("pins", &self.pins.len()).finish()
    }
}

impl ClothBuilder {
    /// A `cols × rows` grid of cotton, 1 m × 1 m, at the origin.
    pub fn new(cols: u32, rows: u32) -> Self {
        Self {
            cols,
            rows,
            size: Vec2::ONE,
            common: Common::default(),
            pins: Vec::new(),
        }
    }

    /// Width along the columns and height along the rows, in m.
    pub fn size(mut self, width: f32, height: f32) -> Self {
        self.size = Vec2::new(width, height);
        self
    }

    common_methods!("the grid's centre");

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
        let grid = Grid::checked(self.cols, self.rows, self.size)?;
        let (mass, m, rotation) = self.common.check()?;
        let masses = grid.masses(mass, self.common.uniform_mass);
        let positions = placed(grid.rest_positions(), self.common.position, rotation);
        let connections = ClothConnections::grid(grid.cols, grid.rows, &positions);
        let cloth = Cloth::from(grid.clone());
        self.common.bundle(
            m,
            cloth,
            positions,
            masses,
            connections,
            &self.pins,
            |pin| resolve(&grid, pin),
        )
    }
}

fn resolve(cloth: &Grid, pin: &Pin) -> Result<Vec<u32>, ClothError> {
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
        Pin::Corner(corner) => vec![cloth.corner(*corner)],
        Pin::Edge(edge) => cloth.edge(*edge),
        Pin::Where(f) => (0..cloth.len() as u32)
            .filter(|&p| f(p % cloth.cols, p / cloth.cols, cloth.rest_uv(p)))
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
        let bad = crate::SimSettings {
            damping: f32::NAN,
            ..Default::default()
        };
        assert!(matches!(
            ClothBuilder::new(3, 3).build_with(bad).unwrap_err(),
            InvalidDamping { .. }
        ));
        for (safety, max_substeps) in [(0.0, 10), (f32::NAN, 10), (1.5, 10), (0.5, 0)] {
            let bad = crate::SimSettings {
                adaptive: Some(crate::sim::adaptive::AdaptiveSubsteps {
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
        let tris = b.cloth.grid().unwrap().triangles();
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
