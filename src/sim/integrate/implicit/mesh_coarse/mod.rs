//! The coarse correction of the implicit solver's preconditioner for a
//! cloth that is not a grid (a mesh cloth, [`Connections::columns`] 0).
//!
//! A multigrid on aggregates made from the mesh's connectivity, whose
//! nodes move rigidly: `P⁻¹ r = B⁻¹ r + R₁ V₁(R₁ᵀ r)`, with `R₁` the
//! prolongation from the rigid motions (a translation and a rotation about
//! the aggregate's centre of mass, [`six`]) of aggregates of about
//! [`FIRST`] linked particles, and `V₁` one V-cycle over levels, each the
//! Galerkin operator `A_{l+1} = R_lᵀ A_l R_l` of the one below on
//! aggregates of about [`SIZE`] of its nodes, again moving rigidly: a
//! block-Jacobi sweep, the residual's correction from the level above
//! scaled by θ, another sweep; down to at most [`COARSEST`] nodes, solved
//! exactly.
//!
//! Rigid nodes, rather than the grid's piecewise-constant ones
//! ([`coarse`](super::coarse)), follow what a mesh cloth does that a grid
//! pinned at its corners rarely does: pieces of it (a torn piece falling
//! free, a flap) turn about one another, which costs no stretch, and which
//! aggregates that can only translate follow in steps that do stretch
//! their links. Six unknowns per node rather than three pay for
//! themselves with three times as many particles per node.
//!
//! - **Aggregates** are grown breadth-first over the Type 1 links, seeds
//!   taken in a breadth-first order of the whole cloth, a
//!   leftover node joining a neighbouring aggregate; each level's graph
//!   joins two aggregates when a link of the level below does. The
//!   hierarchy is made once per set of links and kept while the links stay
//!   the same. Pinned particles belong to none, as the filter leaves them
//!   out of `A`.
//! - **Each level's operator** is a 6×6 diagonal block per node and a
//!   block `A[I][J]` per edge `I < J`. A pair between two aggregates that
//!   share no link (a contact between distant parts of the cloth) adds
//!   to both diagonals only, which keeps the operator positive definite.
//!   A node's rotations keep at least the inertia of a node 1 mm across,
//!   so that a node of one particle, or of particles on a line, has an
//!   invertible block.
//! - **The coarsest level** is factored by a Cholesky factorisation in f64
//!   that skips the zeros before each row's first coupling (the
//!   breadth-first numbering keeps coupled aggregates close in number). A
//!   cloth whose pieces are too many to aggregate that far (a cloth cut
//!   into scraps) takes a block-Jacobi sweep there instead.

use bevy::math::{Mat3A, Vec3, Vec3A};

use super::coarse::{Rank, joining_pairs};
use super::operator::{Soa, sym_matrix};
use crate::sim::connections::{Connections, LinkStamp};
use crate::sim::model::jacobian::Block;
use crate::sim::model::streams::StreamBlocks;
use hierarchy::{hierarchy, key};
use level::Level;
use six::{Block6, Six, cross_matrix};

mod hierarchy;
mod level;
mod six;

/// Particles per aggregate of the first level, about: a rigid node (six
/// unknowns) for twelve particles (36).
pub const FIRST: usize = 12;

/// Nodes per aggregate of the levels above the first, about.
pub const SIZE: usize = 4;

/// Nodes of the coarsest level at most, solved exactly.
pub const COARSEST: usize = 32;

/// Weight of a block-Jacobi sweep.
const OMEGA: f32 = 0.6;

/// Scale of the correction a level takes from the one above it.
const THETA: f32 = 1.5;

/// Marks a particle outside every aggregate (pinned).
const NONE: u32 = u32::MAX;

/// The coarse correction of one step of a mesh cloth: its hierarchy of
/// aggregates and the operator on each level, the coarsest factored.
#[derive(Clone, Debug, Default)]
pub(super) struct MeshCoarse {
    /// What the hierarchy was made for: particles, links and a checksum
    /// of the links' ends.
    key: (usize, usize, u64),
    /// The stamp of the links last found to match `key`.
    stamp: Option<LinkStamp>,
    /// First-level aggregate of each particle, pinned or not.
    grouped: Vec<u32>,
    /// This step's first-level aggregate of each particle, [`NONE`] for
    /// pinned ones.
    aggregate: Vec<u32>,
    /// The positions the operator is linearised at (m).
    positions: Vec<Vec3A>,
    /// Each particle's position less its aggregate's centre (m).
    offset: Vec<Vec3A>,
    /// Each free particle's own block (kg): its mass, its contacts' blocks
    /// and the blocks `C` of its pairs that leave its aggregate, moved onto
    /// the aggregate's diagonal once all are in ([`Self::finish`]).
    own: Vec<Mat3A>,
    /// The levels, first to coarsest.
    levels: Vec<Level>,
    /// Whether the coarsest level is solved exactly (else a sweep).
    exact: bool,
    /// The coarsest level's `A` (kg), dense and row-major, then its
    /// Cholesky factor `L` in the lower triangle (√kg).
    matrix: Vec<f64>,
    /// First non-zero column of each row of the coarsest `A`.
    first: Vec<usize>,
    /// Coarsest right-hand side, then solution.
    rc: Vec<f64>,
}

impl MeshCoarse {
    /// Sets the positions (m) the next steps' operators are linearised at.
    pub(super) fn place(&mut self, x: &[Vec3]) {
        self.positions.clear();
        self.positions.extend(x.iter().map(|&p| Vec3A::from(p)));
    }

    /// Starts the coarse operator of a step of the cloth with links
    /// `connections` and scaled masses `mass_scale / w` (kg; `w` in 1/kg,
    /// 0 pins) at the positions last [placed](Self::place), whose links
    /// have generation `generation` if their owner keeps one (see
    /// [`LinkStamp`]). `false` (no correction) for fewer than 64 particles
    /// or positions of another cloth.
    pub(super) fn begin(
        &mut self,
        connections: &Connections,
        generation: Option<u64>,
        inverse_masses: &[f32],
        mass_scale: f32,
    ) -> bool {
        let n = inverse_masses.len();
        if n < 64 || self.positions.len() != n {
            return false;
        }
        let stamp = connections.stamp(generation);
        if self.key.0 != n || !LinkStamp::unchanged(self.stamp, stamp) {
            let key = key(connections, n);
            if key != self.key {
                self.levels = hierarchy(connections, n, &mut self.grouped);
                self.key = key;
            }
        }
        self.stamp = stamp;
        self.aggregate.clear();
        self.aggregate.extend(
            self.grouped
                .iter()
                .zip(inverse_masses)
                .map(|(&a, &w)| if w == 0.0 { NONE } else { a }),
        );
        let first = &mut self.levels[0];
        first.reset();
        for ((&a, &w), &x) in self
            .aggregate
            .iter()
            .zip(inverse_masses)
            .zip(&self.positions)
        {
            if a != NONE {
                let m = mass_scale / w;
                first.mass[a as usize] += m;
                first.centre[a as usize] += m * x;
                first.filled[a as usize] = true;
            }
        }
        first.centre_on_mass();
        self.offset.clear();
        self.offset
            .extend(self.aggregate.iter().zip(&self.positions).map(|(&a, &x)| {
                if a == NONE {
                    Vec3A::ZERO
                } else {
                    x - first.centre[a as usize]
                }
            }));
        self.own.clear();
        self.own.extend(inverse_masses.iter().map(|&w| {
            if w == 0.0 {
                Mat3A::ZERO
            } else {
                Mat3A::from_diagonal(Vec3::splat(mass_scale / w))
            }
        }));
        true
    }

    /// Adds the symmetric block `c` (xx, yy, zz, xy, xz, yz; kg) to
    /// particle `a`'s diagonal (a contact the solve holds): to its own
    /// block, unless it is pinned.
    pub(super) fn add_diagonal(&mut self, a: usize, c: &[f32; 6]) {
        if let Some(&i) = self.aggregate.get(a)
            && i != NONE
        {
            self.own[a] += Mat3A::from(sym_matrix(c));
        }
    }

    /// Adds the block `C = t I + s u uᵀ` of the pair `(a, b)`: `Qₐᵀ C Qₐ`
    /// and `Q_bᵀ C Q_b` to their aggregates' diagonals, `−Qₐᵀ C Q_b`
    /// between them (`Q` a particle's motion under its aggregate's rigid
    /// motion). With `[d]×` the cross-product matrix of an offset `d`,
    /// `[a]×[b]× = b aᵀ − (a·b) I` and `[d]× u = d × u` write the products
    /// out.
    fn add_pair(&mut self, a: usize, b: usize, (t, s, u): Rank) {
        let (i, j) = (self.aggregate[a], self.aggregate[b]);
        let u = Vec3A::from_array(u);
        let (da, db) = (self.offset[a], self.offset[b]);
        let outer = |x: Vec3A, y: Vec3A| Mat3A::from_cols(x * y.x, x * y.y, x * y.z);
        let first = &mut self.levels[0];
        if i == j {
            // Both in one aggregate: only its rotations stretch the pair,
            // by `(xₐ − x_b) × ω`: `−[d]× C [d]×`.
            if i != NONE {
                let d = da - db;
                let w = d.cross(u);
                first.diag[i as usize].rr +=
                    Mat3A::from_diagonal(Vec3::splat(t * d.length_squared())) - t * outer(d, d)
                        + s * outer(w, w);
            }
            return;
        }
        let c = Mat3A::from_diagonal(Vec3::splat(t)) + s * outer(u, u);
        for (k, p) in [(i, a), (j, b)] {
            if k != NONE {
                self.own[p] += c;
            }
        }
        if i != NONE && j != NONE {
            let (wa, wb) = (da.cross(u), db.cross(u));
            let block = Block6 {
                tt: -c,
                tr: t * cross_matrix(db) - s * outer(u, wb),
                rt: -t * cross_matrix(da) - s * outer(wa, u),
                rr: t * (outer(db, da) - Mat3A::from_diagonal(Vec3::splat(da.dot(db))))
                    - s * outer(wa, wb),
            };
            self.levels[0].add_off(i as usize, j as usize, block);
        }
    }

    /// Adds every pair of a step of `n` particles ([`joining_pairs`]).
    pub(super) fn add_pairs<'a>(
        &mut self,
        n: usize,
        pairs: (&[Block], impl Iterator<Item = StreamBlocks<'a>>),
        scales: (f32, f32),
    ) {
        joining_pairs(n, pairs, scales, |p, q, block| {
            if (self.aggregate[p] != NONE || self.aggregate[q] != NONE)
                && let Some(c) = block()
            {
                self.add_pair(p, q, c);
            }
        });
    }

    /// Forms the levels above the first and factors the coarsest; `false`
    /// on an operator that is not positive definite.
    pub(super) fn finish(&mut self) -> bool {
        let first = &mut self.levels[0];
        for ((&a, c), &d) in self.aggregate.iter().zip(&self.own).zip(&self.offset) {
            if a != NONE {
                // `Qᵀ C Q` of a symmetric `C`, written out.
                let s = cross_matrix(d);
                let tr = -(*c * s);
                let block = &mut first.diag[a as usize];
                block.tt += *c;
                block.tr += tr;
                block.rt += tr.transpose();
                block.rr -= tr.transpose() * s;
            }
        }
        for l in 1..self.levels.len() {
            let (below, above) = self.levels.split_at_mut(l);
            below[l - 1].coarsen(&mut above[0]);
        }
        for level in &mut self.levels {
            level.regularise();
            level.transpose_off();
        }
        let last = self.levels.len() - 1;
        if !self.levels[..last].iter_mut().all(Level::invert) {
            return false;
        }
        self.exact = self.levels[last].count() <= COARSEST;
        if !self.exact {
            return self.levels[last].invert();
        }
        self.fill_coarsest();
        self.factor()
    }

    /// Writes the coarsest level's operator into the dense matrix, an
    /// empty node's diagonal the identity.
    fn fill_coarsest(&mut self) {
        let level = &self.levels[self.levels.len() - 1];
        let size = 6 * level.count();
        self.matrix.clear();
        self.matrix.resize(size * size, 0.0);
        self.first.clear();
        self.first.extend((0..size).map(|row| row - row % 6));
        let mut put = |(i, j): (usize, usize), b: &Block6| {
            for (k, m) in [b.tt, b.tr, b.rt, b.rr].iter().enumerate() {
                let (r0, c0) = (6 * i + 3 * (k / 2), 6 * j + 3 * (k % 2));
                for c in 0..3 {
                    for r in 0..3 {
                        self.matrix[(r0 + r) * size + c0 + c] = m.col(c)[r] as f64;
                    }
                }
            }
        };
        let identity = Block6 {
            tt: Mat3A::IDENTITY,
            rr: Mat3A::IDENTITY,
            ..Block6::ZERO
        };
        for i in 0..level.count() {
            put(
                (i, i),
                if level.filled[i] {
                    &level.diag[i]
                } else {
                    &identity
                },
            );
            for k in level.start[i] as usize..level.start[i + 1] as usize {
                let j = level.above[k] as usize;
                put((i, j), &level.off[k]);
                put((j, i), &level.off[k].transpose());
                for r in 0..6 {
                    let row = 6 * j + r;
                    self.first[row] = self.first[row].min(6 * i);
                }
            }
        }
    }

    /// Factors the coarsest operator in place; `false` on a pivot that is
    /// not positive.
    fn factor(&mut self) -> bool {
        let size = self.first.len();
        let a = &mut self.matrix;
        // A row's first coupling bounds its columns' too (the profile).
        for i in 0..size {
            for j in self.first[i]..=i {
                let lo = self.first[i].max(self.first[j]);
                let (row_i, row_j) = (i * size, j * size);
                let s = a[row_i + j] - dot(&a[row_i + lo..row_i + j], &a[row_j + lo..row_j + j]);
                if i == j {
                    if !(s > 0.0 && s.is_finite()) {
                        return false;
                    }
                    a[row_i + i] = s.sqrt();
                } else {
                    a[row_i + j] = s / a[row_j + j];
                }
            }
        }
        true
    }

    /// `y += R₁ V₁(R₁ᵀ r)` over the free particles (`free` is 1 or 0; r
    /// in N·s, zero at pins as the filter leaves it; y in m/s).
    pub(super) fn add(&mut self, r: &Soa, y: &mut Soa, free: &[f32]) {
        let first = &mut self.levels[0];
        first.r.fill(Six::ZERO);
        let [rx, ry, rz] = r.0.each_ref().map(|c| &c[..self.aggregate.len()]);
        for (p, (&a, &d)) in self.aggregate.iter().zip(&self.offset).enumerate() {
            if a != NONE {
                let f = Six {
                    t: Vec3A::new(rx[p], ry[p], rz[p]),
                    r: Vec3A::ZERO,
                };
                first.r[a as usize] += f.lifted(d);
            }
        }
        self.cycle_from(0);
        let e = &self.levels[0].e;
        let n = self.aggregate.len();
        let [yx, yy, yz] = y.0.each_mut().map(|c| &mut c[..n]);
        for (p, ((&a, &f), &d)) in self
            .aggregate
            .iter()
            .zip(&free[..n])
            .zip(&self.offset)
            .enumerate()
        {
            if a != NONE {
                let c = f * e[a as usize].moved(d).t;
                yx[p] += c.x;
                yy[p] += c.y;
                yz[p] += c.z;
            }
        }
    }

    /// The V-cycle from level `l`: its `e` from its `r`.
    fn cycle_from(&mut self, l: usize) {
        if l + 1 == self.levels.len() {
            self.solve_coarsest();
            return;
        }
        let (below, above) = self.levels.split_at_mut(l + 1);
        let (level, up) = (&mut below[l], &mut above[0]);
        level.e.fill(Six::ZERO);
        level.jacobi(false);
        level.residual();
        up.r.fill(Six::ZERO);
        for (i, &t) in level.t.iter().enumerate() {
            up.r[level.parent[i] as usize] += t.lifted(level.offset[i]);
        }
        self.cycle_from(l + 1);
        let (below, above) = self.levels.split_at_mut(l + 1);
        let (level, up) = (&mut below[l], &above[0]);
        for (i, e) in level.e.iter_mut().enumerate() {
            if level.filled[i] {
                *e += THETA * up.e[level.parent[i] as usize].moved(level.offset[i]);
            }
        }
        level.residual();
        level.jacobi(true);
    }

    /// `e = A⁻¹ r` on the coarsest level (or one sweep when it is not
    /// solved exactly).
    fn solve_coarsest(&mut self) {
        let level = self.levels.last_mut().expect("a level");
        if !self.exact {
            level.e.fill(Six::ZERO);
            level.jacobi(false);
            return;
        }
        let size = self.first.len();
        let rc = &mut self.rc;
        rc.clear();
        rc.extend(level.r.iter().flat_map(|r| {
            r.t.to_array()
                .into_iter()
                .chain(r.r.to_array())
                .map(f64::from)
        }));
        let l = &self.matrix;
        for i in 0..size {
            let row = &l[i * size..];
            let from = self.first[i];
            rc[i] = (rc[i] - dot(&row[from..i], &rc[from..i])) / row[i];
        }
        for i in (0..size).rev() {
            let row = &l[i * size..];
            let x = rc[i] / row[i];
            rc[i] = x;
            for k in self.first[i]..i {
                rc[k] -= row[k] * x;
            }
        }
        for (i, e) in level.e.iter_mut().enumerate() {
            let at = |k: usize| Vec3A::new(rc[k] as f32, rc[k + 1] as f32, rc[k + 2] as f32);
            *e = if level.filled[i] {
                Six {
                    t: at(6 * i),
                    r: at(6 * i + 3),
                }
            } else {
                Six::ZERO
            };
        }
    }
}

/// `Σ aᵢbᵢ` in four independent sums, so that it runs at the adds'
/// throughput rather than their latency.
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let (ac, bc) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ac
        .remainder()
        .iter()
        .zip(bc.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut sums = [0.0; 4];
    for (x, y) in ac.zip(bc) {
        for k in 0..4 {
            sums[k] += x[k] * y[k];
        }
    }
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

#[cfg(test)]
mod tests;
