//! One level of a mesh cloth's multigrid hierarchy: a graph of aggregates
//! and the Galerkin operator on it, stored as a sum of pair blocks.

use bevy::math::{Mat3A, Vec3A};

use super::super::coarse::invert_diagonal;
use super::{NONE, OMEGA};

/// One level: a graph of nodes (fixed while the links stay the same) and
/// this step's operator on it (kg).
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
    /// Diagonal blocks.
    pub(super) diag: Vec<Mat3A>,
    /// Inverses of the diagonal blocks (1/kg), zero at empty nodes.
    pub(super) inverse: Vec<Mat3A>,
    /// The block `C` of each edge.
    pub(super) off: Vec<Mat3A>,
    /// Whether a free particle lies under the node.
    pub(super) filled: Vec<bool>,
    /// Scratch: right-hand side, correction and residual.
    pub(super) r: Vec<Vec3A>,
    pub(super) e: Vec<Vec3A>,
    pub(super) t: Vec<Vec3A>,
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

    /// Zeroes this step's operator.
    pub(super) fn reset(&mut self) {
        let (count, edges) = (self.count(), self.above.len());
        for (v, len) in [(&mut self.diag, count), (&mut self.off, edges)] {
            v.clear();
            v.resize(len, Mat3A::ZERO);
        }
        self.filled.clear();
        self.filled.resize(count, false);
        for v in [&mut self.r, &mut self.e, &mut self.t] {
            v.clear();
            v.resize(count, Vec3A::ZERO);
        }
    }

    /// Adds the block `c` joining nodes `i ≠ j` (both diagonals and the
    /// edge; the diagonals only when they are not neighbours).
    pub(super) fn add_pair(&mut self, i: usize, j: usize, c: Mat3A) {
        self.diag[i] += c;
        self.diag[j] += c;
        if let Some(k) = self.edge(i.min(j), i.max(j)) {
            self.off[k] += c;
        }
    }

    /// `up`'s operator, `Rᵀ A R` over this level's aggregates.
    pub(super) fn coarsen(&self, up: &mut Level) {
        up.reset();
        for i in 0..self.count() {
            let p = self.parent[i] as usize;
            up.diag[p] += self.diag[i];
            up.filled[p] |= self.filled[i];
            for k in self.start[i] as usize..self.start[i + 1] as usize {
                match self.lift[k] {
                    // Inside one aggregate, `A[i][j] + A[j][i] = −2C`.
                    NONE => up.diag[p] -= self.off[k] * 2.0,
                    edge => up.off[edge as usize] += self.off[k],
                }
            }
        }
    }

    /// Inverts the diagonal blocks of the filled nodes; `false` if one is
    /// not invertible (an operator that is not positive definite).
    pub(super) fn invert(&mut self) -> bool {
        invert_diagonal(&self.diag, &self.filled, &mut self.inverse)
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
            ..
        } = self;
        for ((t, &r), (d, &e)) in t.iter_mut().zip(&*r).zip(diag.iter().zip(&*e)) {
            *t = r - *d * e;
        }
        // Row by row: node i's sum kept in a register, its neighbours'
        // entries written as they come.
        for (i, ends) in start.windows(2).enumerate() {
            let edges = ends[0] as usize..ends[1] as usize;
            let ei = e[i];
            let mut sum = Vec3A::ZERO;
            for (&j, c) in above[edges.clone()].iter().zip(&off[edges]) {
                let j = j as usize;
                sum += *c * e[j];
                t[j] += *c * ei;
            }
            t[i] += sum;
        }
    }

    /// `e += ω D⁻¹ x`, `x` the right-hand side or the residual.
    pub(super) fn jacobi(&mut self, residual: bool) {
        let x = if residual { &self.t } else { &self.r };
        for ((e, &x), d) in self.e.iter_mut().zip(x).zip(&self.inverse) {
            *e += OMEGA * (*d * x);
        }
    }
}
