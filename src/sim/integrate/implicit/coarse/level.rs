//! One level of the multigrid hierarchy: a grid of aggregates and the
//! Galerkin operator on it, stored as a sum of pair blocks.
//!
//! Every level's operator has the form of the fine one: a diagonal block
//! per node (its mass and every block `C` joining it to another node) and,
//! for each pair of neighbouring nodes, a block `C` with
//! `A[I][J] = A[J][I] = −C`. Piecewise-constant aggregation keeps that
//! form: summing a level's nodes in squares of 2 × 2 gives the next
//! level's, where a block inside a square cancels and a block between two
//! squares joins them (`Rᵀ A R` in a pass over the blocks).

use bevy::math::{Mat3A, Vec3A};

/// Offsets (columns, rows) of the neighbours a node stores its blocks to:
/// the other four of its 8 neighbours store theirs to it.
pub(super) const SLOTS: [(isize, isize); 4] = [(1, 0), (-1, 1), (0, 1), (1, 1)];

/// A level's grid of nodes and its operator (kg: N/m·s² like the fine
/// operator `A`).
#[derive(Clone, Debug, Default)]
pub(super) struct Level {
    /// Nodes per row.
    pub(super) columns: usize,
    /// Rows of nodes.
    pub(super) rows: usize,
    /// Diagonal blocks.
    pub(super) diag: Vec<Mat3A>,
    /// Inverses of the diagonal blocks (1/kg), zero at empty nodes.
    pub(super) inverse: Vec<Mat3A>,
    /// The blocks `C` to the neighbours at [`SLOTS`] (zero where none).
    pub(super) off: Vec<[Mat3A; 4]>,
    /// Whether a free particle lies under the node.
    pub(super) filled: Vec<bool>,
}

impl Level {
    /// Starts an empty operator on a grid of `columns × rows` nodes.
    pub(super) fn reset(&mut self, columns: usize, rows: usize) {
        (self.columns, self.rows) = (columns, rows);
        let count = columns * rows;
        self.diag.clear();
        self.diag.resize(count, Mat3A::ZERO);
        self.off.clear();
        self.off.resize(count, [Mat3A::ZERO; 4]);
        self.filled.clear();
        self.filled.resize(count, false);
    }

    /// Nodes.
    pub(super) fn count(&self) -> usize {
        self.columns * self.rows
    }

    /// Adds the block `c` joining nodes `a ≠ b` (off-diagonal only: the
    /// diagonals already hold it). Between nodes that are not neighbours
    /// the coupling is dropped (`false`), which keeps the operator
    /// symmetric positive definite.
    pub(super) fn add_link(&mut self, a: usize, b: usize, c: Mat3A) -> bool {
        let columns = self.columns;
        let (lo, hi) = (a.min(b), a.max(b));
        let across = (hi % columns) as isize - (lo % columns) as isize;
        let down = (hi / columns - lo / columns) as isize;
        match SLOTS.iter().position(|&s| s == (across, down)) {
            Some(slot) => {
                self.off[lo][slot] += c;
                true
            }
            None => false,
        }
    }

    /// The neighbour of node `i` at slot `slot`, if there is one.
    #[inline(always)]
    fn neighbour(&self, i: usize, slot: usize) -> Option<usize> {
        let (column, row) = (i % self.columns, i / self.columns);
        let (across, down) = SLOTS[slot];
        let c = column.checked_add_signed(across)?;
        let r = row.checked_add_signed(down)?;
        (c < self.columns && r < self.rows).then_some(r * self.columns + c)
    }

    /// Forms this level from the level below it (`fine`): nodes in squares
    /// of 2 × 2.
    pub(super) fn coarsen(&mut self, fine: &Level) {
        self.reset(fine.columns.div_ceil(2), fine.rows.div_ceil(2));
        let up = self.columns;
        let parent = |i: usize| (i / fine.columns / 2) * up + (i % fine.columns) / 2;
        for i in 0..fine.count() {
            let p = parent(i);
            self.diag[p] += fine.diag[i];
            self.filled[p] |= fine.filled[i];
        }
        for i in 0..fine.count() {
            for slot in 0..SLOTS.len() {
                let c = fine.off[i][slot];
                let Some(j) = fine.neighbour(i, slot) else {
                    continue;
                };
                if c == Mat3A::ZERO {
                    continue;
                }
                let (p, q) = (parent(i), parent(j));
                if p == q {
                    // A[I][J] + A[J][I] = −2C inside one square.
                    self.diag[p] -= c + c;
                } else {
                    // Neighbours' parents are neighbours.
                    let joined = self.add_link(p, q, c);
                    debug_assert!(joined);
                }
            }
        }
    }

    /// Inverts the diagonal blocks of the filled nodes; `false` if one is
    /// not invertible (a coarse operator that is not positive definite).
    pub(super) fn invert(&mut self) -> bool {
        invert_diagonal(&self.diag, &self.filled, &mut self.inverse)
    }

    /// `t = r − A e`.
    #[inline(always)]
    pub(super) fn residual(&self, r: &[Vec3A], e: &[Vec3A], t: &mut [Vec3A]) {
        for ((t, &r), (d, &e)) in t.iter_mut().zip(r).zip(self.diag.iter().zip(e)) {
            *t = r - *d * e;
        }
        let (columns, count) = (self.columns, self.count());
        // Slot deltas in node index: a block to a node past the end of a
        // row is zero, so only the end of the grid needs a bound.
        let deltas = [1, columns - 1, columns, columns + 1];
        for i in 0..count {
            for (slot, &delta) in deltas.iter().enumerate() {
                let j = i + delta;
                if j >= count {
                    break;
                }
                let c = self.off[i][slot];
                t[i] += c * e[j];
                t[j] += c * e[i];
            }
        }
    }

    /// `e += ω D⁻¹ t`.
    #[inline(always)]
    pub(super) fn jacobi(&self, omega: f32, t: &[Vec3A], e: &mut [Vec3A]) {
        for ((e, &t), d) in e.iter_mut().zip(t).zip(&self.inverse) {
            *e += omega * (*d * t);
        }
    }

    /// `coarse[parent(i)] += t[i]`, `coarse` of the level above (2 × 2
    /// squares), zeroed first.
    #[inline(always)]
    pub(super) fn restrict(&self, t: &[Vec3A], coarse: &mut [Vec3A]) {
        coarse.fill(Vec3A::ZERO);
        let up = self.columns.div_ceil(2);
        for (row, t) in t.chunks_exact(self.columns).enumerate() {
            let out = &mut coarse[(row / 2) * up..][..up];
            for (pair, o) in t.chunks(2).zip(out.iter_mut()) {
                *o += pair.iter().copied().sum::<Vec3A>();
            }
        }
    }

    /// `e[i] += θ coarse[parent(i)]` at filled nodes.
    #[inline(always)]
    pub(super) fn prolong(&self, theta: f32, coarse: &[Vec3A], e: &mut [Vec3A]) {
        let up = self.columns.div_ceil(2);
        let rows = e
            .chunks_exact_mut(self.columns)
            .zip(self.filled.chunks_exact(self.columns));
        for (row, (e, filled)) in rows.enumerate() {
            let from = &coarse[(row / 2) * up..][..up];
            for (i, (e, &filled)) in e.iter_mut().zip(filled).enumerate() {
                if filled {
                    *e += theta * from[i / 2];
                }
            }
        }
    }
}

/// Writes into `inverse` the inverses of the `diag` blocks of the filled
/// nodes (zero at the others); `false` if one is not invertible (a coarse
/// operator that is not positive definite).
fn invert_diagonal(diag: &[Mat3A], filled: &[bool], inverse: &mut Vec<Mat3A>) -> bool {
    inverse.clear();
    let mut ok = true;
    inverse.extend(diag.iter().zip(filled).map(|(d, &filled)| {
        if !filled {
            return Mat3A::ZERO;
        }
        let det = d.determinant();
        ok &= det > 0.0 && det.is_finite() && d.x_axis.x > 0.0;
        if ok { d.inverse() } else { Mat3A::ZERO }
    }));
    ok
}
