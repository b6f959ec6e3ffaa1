//! One level of a mesh cloth's multigrid hierarchy: a graph of aggregates
//! and the Galerkin operator on their rigid motions ([`six`](super::six)).

use bevy::math::{Mat3A, Vec3A};

use super::six::{Block6, Six};
use super::{NONE, OMEGA};

/// The least rotational inertia a node keeps, over its mass (m²): a node
/// narrower than 1 mm has no rotation worth solving for.
const NARROWEST: f32 = 1e-6;

/// One level: a graph of nodes (fixed while the links stay the same) and
/// this step's operator on it.
#[derive(Clone, Debug, Default)]
pub(super) struct Level {
    /// Each node's edges to higher-numbered nodes: `above[start[i]..start[i + 1]]`,
    /// sorted.
    pub(super) start: Vec<u32>,
    pub(super) above: Vec<u32>,
    /// Each node's aggregate on the level above (empty on the coarsest).
    pub(super) parent: Vec<u32>,
    /// Each edge's edge on the level above, or [`NONE`] for an edge inside
    /// one aggregate.
    pub(super) lift: Vec<u32>,
    /// Each node's mass (kg, scaled as the operator's) and centre (m, the
    /// mass-weighted mean of its particles).
    pub(super) mass: Vec<f32>,
    pub(super) centre: Vec<Vec3A>,
    /// Each node's centre less its parent's (m).
    pub(super) offset: Vec<Vec3A>,
    /// Diagonal blocks.
    pub(super) diag: Vec<Block6>,
    /// Inverses of the diagonal blocks, zero at empty nodes.
    pub(super) inverse: Vec<Block6>,
    /// The block `A[i][j]` of each edge `i < j` (`A[j][i]` is its
    /// transpose).
    pub(super) off: Vec<Block6>,
    /// The transposes of `off`: `A[j][i]`.
    pub(super) off_t: Vec<Block6>,
    /// Whether a free particle lies under the node.
    pub(super) filled: Vec<bool>,
    /// Scratch: right-hand side, correction and residual.
    pub(super) r: Vec<Six>,
    pub(super) e: Vec<Six>,
    pub(super) t: Vec<Six>,
}

impl Level {
    /// A level on the graph `neighbours` (each row sorted, no node its own
    /// neighbour).
    pub(super) fn new(neighbours: &[Vec<u32>]) -> Self {
        let mut start = Vec::with_capacity(neighbours.len() + 1);
        let mut above = Vec::new();
        start.push(0);
        for (i, row) in neighbours.iter().enumerate() {
            above.extend(row.iter().filter(|&&j| j as usize > i));
            start.push(above.len() as u32);
        }
        Self {
            start,
            above,
            ..Self::default()
        }
    }

    pub(super) fn count(&self) -> usize {
        self.start.len() - 1
    }

    /// The edge between nodes `i < j`, if they are neighbours.
    pub(super) fn edge(&self, i: usize, j: usize) -> Option<usize> {
        let from = self.start[i] as usize;
        let row = &self.above[from..self.start[i + 1] as usize];
        row.binary_search(&(j as u32)).ok().map(|k| from + k)
    }

    /// Zeroes this step's operator, masses and centres.
    pub(super) fn reset(&mut self) {
        let (count, edges) = (self.count(), self.above.len());
        for (v, len) in [(&mut self.diag, count), (&mut self.off, edges)] {
            v.clear();
            v.resize(len, Block6::ZERO);
        }
        self.filled.clear();
        self.filled.resize(count, false);
        self.mass.clear();
        self.mass.resize(count, 0.0);
        for v in [&mut self.centre, &mut self.offset] {
            v.clear();
            v.resize(count, Vec3A::ZERO);
        }
        for v in [&mut self.r, &mut self.e, &mut self.t] {
            v.clear();
            v.resize(count, Six::ZERO);
        }
    }

    /// Divides the mass-weighted sums of positions in `centre` by the
    /// masses.
    pub(super) fn centre_on_mass(&mut self) {
        for (c, &m) in self.centre.iter_mut().zip(&self.mass) {
            if m > 0.0 {
                *c /= m;
            }
        }
    }

    /// Adds `b` as the block `A[i][j]` (and its transpose as `A[j][i]`)
    /// of nodes `i ≠ j`; to nothing when they are not neighbours.
    pub(super) fn add_off(&mut self, i: usize, j: usize, b: Block6) {
        if let Some(k) = self.edge(i.min(j), i.max(j)) {
            self.off[k] += if i < j { b } else { b.transpose() };
        }
    }

    /// `up`'s masses, centres and operator, `Tᵀ A T` over this level's
    /// aggregates (each node's offset from its parent set on the way).
    pub(super) fn coarsen(&mut self, up: &mut Level) {
        up.reset();
        for i in 0..self.count() {
            let p = self.parent[i] as usize;
            up.mass[p] += self.mass[i];
            up.centre[p] += self.mass[i] * self.centre[i];
            up.filled[p] |= self.filled[i];
        }
        up.centre_on_mass();
        for i in 0..self.count() {
            self.offset[i] = self.centre[i] - up.centre[self.parent[i] as usize];
        }
        for i in 0..self.count() {
            let (p, di) = (self.parent[i] as usize, self.offset[i]);
            up.diag[p] += self.diag[i].moved(di, di);
            for k in self.start[i] as usize..self.start[i + 1] as usize {
                let j = self.above[k] as usize;
                let b = self.off[k].moved(di, self.offset[j]);
                match self.lift[k] {
                    NONE => up.diag[p] += b + b.transpose(),
                    _ => up.add_off(p, self.parent[j] as usize, b),
                }
            }
        }
    }

    /// Gives each filled node's rotations at least the inertia of a node
    /// [`NARROWEST`] across, so that a node of one particle, or of
    /// particles on a line, stays invertible.
    pub(super) fn regularise(&mut self) {
        for ((d, &m), &filled) in self.diag.iter_mut().zip(&self.mass).zip(&self.filled) {
            if filled {
                let floor = 1e-4 * d.rr.to_cols_array().iter().step_by(4).sum::<f32>() / 3.0;
                d.rr += Mat3A::from_diagonal(bevy::math::Vec3::splat(floor + NARROWEST * m));
            }
        }
    }

    /// Writes `off_t`, the off-diagonal blocks' transposes.
    pub(super) fn transpose_off(&mut self) {
        self.off_t.clear();
        self.off_t.extend(self.off.iter().map(Block6::transpose));
    }

    /// Inverts the diagonal blocks of the filled nodes; `false` if one is
    /// not invertible (an operator that is not positive definite).
    pub(super) fn invert(&mut self) -> bool {
        self.inverse.clear();
        self.inverse.resize(self.count(), Block6::ZERO);
        for ((inv, d), &filled) in self.inverse.iter_mut().zip(&self.diag).zip(&self.filled) {
            if filled {
                match d.inverse() {
                    Some(i) => *inv = i,
                    None => return false,
                }
            }
        }
        true
    }

    /// `t = r − A e`.
    pub(super) fn residual(&mut self) {
        let Self {
            t,
            r,
            e,
            diag,
            start,
            above,
            off,
            off_t,
            ..
        } = self;
        for ((t, &r), (d, &e)) in t.iter_mut().zip(&*r).zip(diag.iter().zip(&*e)) {
            *t = r - d.mul(e);
        }
        for (i, ends) in start.windows(2).enumerate() {
            let edges = ends[0] as usize..ends[1] as usize;
            let ei = e[i];
            let mut sum = Six::ZERO;
            let blocks = off[edges.clone()].iter().zip(&off_t[edges.clone()]);
            for (&j, (b, bt)) in above[edges].iter().zip(blocks) {
                let j = j as usize;
                sum += b.mul(e[j]);
                t[j] = t[j] - bt.mul(ei);
            }
            t[i] = t[i] - sum;
        }
    }

    /// `e += ω D⁻¹ x`, `x` the right-hand side or the residual.
    pub(super) fn jacobi(&mut self, residual: bool) {
        let x = if residual { &self.t } else { &self.r };
        for ((e, &x), d) in self.e.iter_mut().zip(x).zip(&self.inverse) {
            *e += OMEGA * d.mul(x);
        }
    }
}
