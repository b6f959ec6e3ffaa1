//! The grid a cloth is made of: [`Grid`] (columns, rows and rest size), its
//! indexing and triangles, and the corners and edges that name its pins. It
//! names no other module of the crate.

use bevy::math::Vec2;
use bevy::reflect::Reflect;

/// Most particles one cloth may have (a 1024×1024 grid).
pub const MAX_PARTICLES: u32 = 1 << 20;

/// A rectangular cloth's grid, whose particles and connections are
/// [`Particles`](crate::sim::particles::Particles) and
/// [`Connections`](crate::sim::connections::Connections). In an app, the
/// `Cloth` component wraps it.
///
/// Particle `(i, j)` (column `i`, row `j`) has index `p = j·cols + i` and rest
/// coordinates `(u, v) = (i·w/(cols−1), j·h/(rows−1))` in metres.
///
/// Particles are simulated in world space; keep the entity's `Transform` at
/// identity unless you want the rendered mesh offset from the simulation.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct Grid {
    /// Particles per row.
    pub cols: u32,
    /// Particles per column.
    pub rows: u32,
    /// Rest width (along columns) and height (along rows) in m.
    pub size: Vec2,
}

impl Grid {
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
        2 * (self.cols.saturating_sub(1) * self.rows.saturating_sub(1)) as usize
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

/// The triangles of a cloth, a grid's or a mesh's: what wind and
/// self-collision act on.
pub trait Faces {
    /// Number of triangles.
    fn face_count(&self) -> usize;

    /// Triangle `t` (`t < face_count()`), as three particle indices.
    fn face(&self, t: u32) -> [u32; 3];

    /// The side (m) of self-collision's spatial hash cells, of the order of
    /// the longest rest edge, so that a triangle spans few cells.
    fn cell_size(&self) -> f32;

    /// Every triangle, in order.
    fn faces(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        (0..self.face_count() as u32).map(|t| self.face(t))
    }

    /// A number that names these triangles: equal generations mean equal
    /// triangles, so caches built from them need not compare them again
    /// (`None`, the default: no such number; caches compare the triangles).
    fn generation(&self) -> Option<u64> {
        None
    }
}

impl Faces for Grid {
    fn face_count(&self) -> usize {
        self.triangle_count()
    }

    fn face(&self, t: u32) -> [u32; 3] {
        self.triangle(t)
    }

    /// The larger of the spacings along the columns and along the rows, m.
    fn cell_size(&self) -> f32 {
        (self.size.x / (self.cols - 1) as f32).max(self.size.y / (self.rows - 1) as f32)
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
