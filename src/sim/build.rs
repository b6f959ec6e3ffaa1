//! The geometry of a new cloth, as the plugin's builders make it and code
//! that builds cloths itself can: a checked grid, the particles' masses
//! (lumped by area, or equal), their places in the world, and the grid's
//! corners and edges to pin.
//!
//! It may import the rest of [`sim`](crate::sim) and [`error`](crate::error).

use bevy::math::{Quat, Vec2, Vec3};

use crate::error::ClothError;
use crate::sim::grid::{Grid, GridCorner, GridEdge, MAX_PARTICLES};
use crate::sim::topology::MeshTopology;

/// How much a new cloth weighs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mass {
    /// Its areal density, kg/m².
    PerArea(f32),
    /// Its whole mass, kg.
    Total(f32),
}

impl Mass {
    /// The number given (kg/m² or kg), when it is finite and positive.
    pub fn checked(self) -> Result<f32, ClothError> {
        let (Mass::PerArea(m) | Mass::Total(m)) = self;
        if m.is_finite() && m > 0.0 {
            Ok(m)
        } else {
            Err(ClothError::InvalidMass(m))
        }
    }
}

/// The rotation of a placement at `position` (m) turned by `rotation`,
/// normalised; an error unless both are finite and the rotation has a
/// length.
pub fn checked_placement(position: Vec3, rotation: Quat) -> Result<Quat, ClothError> {
    let length = rotation.length();
    if position.is_finite() && rotation.is_finite() && length > 1e-6 {
        Ok(rotation / length)
    } else {
        Err(ClothError::InvalidPlacement)
    }
}

/// Rest positions (m) moved to a placement: turned by `rotation`, then
/// moved by `position`.
pub fn placed(rest: impl IntoIterator<Item = Vec3>, position: Vec3, rotation: Quat) -> Vec<Vec3> {
    rest.into_iter().map(|p| position + rotation * p).collect()
}

impl Grid {
    /// A grid of `cols × rows` particles over `size` m (width along the
    /// columns, height along the rows): at least 3 × 3, at most
    /// [`MAX_PARTICLES`], of a finite, positive size.
    pub fn checked(cols: u32, rows: u32, size: Vec2) -> Result<Self, ClothError> {
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
        if !(size.is_finite() && size.x > 0.0 && size.y > 0.0) {
            return Err(ClothError::InvalidSize {
                width: size.x,
                height: size.y,
            });
        }
        Ok(Grid { cols, rows, size })
    }

    /// The particles' masses (kg) for `mass`: lumped by area (a particle on
    /// an edge half an inner one's, a corner a quarter) or, with
    /// `uniform`, all equal.
    pub fn masses(&self, mass: Mass, uniform: bool) -> Vec<f32> {
        let (cols, rows, count) = (self.cols, self.rows, self.len());
        let total = match mass {
            Mass::PerArea(rho) => rho * self.size.x * self.size.y,
            Mass::Total(total) => total,
        };
        (0..count as u32)
            .map(|p| {
                if uniform {
                    return total / count as f32;
                }
                let w = |k: u32, n: u32| if k == 0 || k == n - 1 { 0.5 } else { 1.0 };
                let share = w(p % cols, cols) * w(p / cols, rows);
                total * share / ((cols - 1) * (rows - 1)) as f32
            })
            .collect()
    }

    /// The particles' rest positions (m): the grid laid in the XZ plane,
    /// column `i` along +X and row `j` along +Z, centred on the origin.
    pub fn rest_positions(&self) -> impl Iterator<Item = Vec3> + '_ {
        (0..self.len() as u32).map(|p| {
            let uv = self.rest_uv(p) - 0.5 * self.size;
            Vec3::new(uv.x, 0.0, uv.y)
        })
    }

    /// The particle at `corner`.
    pub fn corner(&self, corner: GridCorner) -> u32 {
        let (c, r) = (self.cols, self.rows);
        match corner {
            GridCorner::TopLeft => self.index(0, 0),
            GridCorner::TopRight => self.index(c - 1, 0),
            GridCorner::BottomLeft => self.index(0, r - 1),
            GridCorner::BottomRight => self.index(c - 1, r - 1),
        }
    }

    /// The particles along `edge`, in order.
    pub fn edge(&self, edge: GridEdge) -> Vec<u32> {
        let (c, r) = (self.cols, self.rows);
        match edge {
            GridEdge::Top => (0..c).map(|i| self.index(i, 0)).collect(),
            GridEdge::Bottom => (0..c).map(|i| self.index(i, r - 1)).collect(),
            GridEdge::Left => (0..r).map(|j| self.index(0, j)).collect(),
            GridEdge::Right => (0..r).map(|j| self.index(c - 1, j)).collect(),
        }
    }
}

impl MeshTopology {
    /// The particles' masses (kg) for `mass`: lumped by the area of their
    /// triangles or, with `uniform`, all equal.
    pub fn masses(&self, mass: Mass, uniform: bool) -> Vec<f32> {
        let mut masses = match mass {
            Mass::PerArea(rho) => self.lumped_masses(rho),
            Mass::Total(total) => {
                let mut masses = self.lumped_masses(1.0);
                let sum: f32 = masses.iter().sum();
                masses.iter_mut().for_each(|m| *m *= total / sum);
                masses
            }
        };
        if uniform {
            let total: f32 = masses.iter().sum();
            masses.fill(total / self.len() as f32);
        }
        masses
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grids_lumped_masses_add_up_and_split_by_quarters() {
        let grid = Grid::checked(5, 4, Vec2::new(2.0, 1.5)).unwrap();
        let masses = grid.masses(Mass::PerArea(0.2), false);
        let total: f32 = masses.iter().sum();
        assert!((total - 0.2 * 3.0).abs() < 1e-6, "{total}");
        let inner = masses[grid.index(1, 1) as usize];
        assert_eq!(
            masses[grid.corner(GridCorner::TopLeft) as usize],
            inner / 4.0
        );
        assert_eq!(masses[grid.index(2, 0) as usize], inner / 2.0);
        let uniform = grid.masses(Mass::Total(2.0), true);
        assert!(uniform.iter().all(|&m| m == 0.1));
    }

    #[test]
    fn corners_and_edges_name_the_grids_particles() {
        let grid = Grid::checked(4, 3, Vec2::ONE).unwrap();
        let corners = [
            GridCorner::TopLeft,
            GridCorner::TopRight,
            GridCorner::BottomLeft,
            GridCorner::BottomRight,
        ];
        assert_eq!(corners.map(|c| grid.corner(c)), [0, 3, 8, 11]);
        assert_eq!(grid.edge(GridEdge::Top), [0, 1, 2, 3]);
        assert_eq!(grid.edge(GridEdge::Bottom), [8, 9, 10, 11]);
        assert_eq!(grid.edge(GridEdge::Left), [0, 4, 8]);
        assert_eq!(grid.edge(GridEdge::Right), [3, 7, 11]);
    }

    #[test]
    fn bad_grids_masses_and_placements_are_errors() {
        assert!(matches!(
            Grid::checked(2, 9, Vec2::ONE),
            Err(ClothError::GridTooSmall { .. })
        ));
        assert!(matches!(
            Grid::checked(2000, 2000, Vec2::ONE),
            Err(ClothError::GridTooLarge { .. })
        ));
        assert!(matches!(
            Grid::checked(3, 3, Vec2::new(1.0, f32::NAN)),
            Err(ClothError::InvalidSize { .. })
        ));
        assert!(matches!(
            Mass::Total(-1.0).checked(),
            Err(ClothError::InvalidMass(_))
        ));
        assert!(matches!(
            Mass::PerArea(f32::INFINITY).checked(),
            Err(ClothError::InvalidMass(_))
        ));
        let zero = Quat::from_xyzw(0.0, 0.0, 0.0, 0.0);
        assert!(checked_placement(Vec3::ZERO, zero).is_err());
        assert!(checked_placement(Vec3::NAN, Quat::IDENTITY).is_err());
        let half = Quat::from_xyzw(0.0, 0.0, 0.0, 0.5);
        assert_eq!(checked_placement(Vec3::ONE, half).unwrap(), Quat::IDENTITY);
    }

    #[test]
    fn a_placed_grid_is_centred_and_turned() {
        let grid = Grid::checked(3, 3, Vec2::new(2.0, 1.0)).unwrap();
        let turn = Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let at = placed(grid.rest_positions(), Vec3::Y, turn);
        assert!(at[4].abs_diff_eq(Vec3::Y, 1e-6), "{}", at[4]);
        // Row 0 (z = -0.5) turned about X goes up to y = 1.5.
        assert!(
            at[0].abs_diff_eq(Vec3::new(-1.0, 1.5, 0.0), 1e-6),
            "{}",
            at[0]
        );
    }
}
