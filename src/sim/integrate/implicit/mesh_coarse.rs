//! The coarse correction of the implicit solver's preconditioner for a
//! cloth that is not a grid (a mesh cloth, [`Connections::columns`] 0).
//!
//! The grid's multigrid ([`coarse`](super::coarse)) on aggregates made from
//! the mesh's connectivity rather than grid squares:
//! `P⁻¹ r = B⁻¹ r + R₁ V₁(R₁ᵀ r)`, with `R₁` the piecewise-constant
//! prolongation from aggregates of about [`SIZE`] linked particles and
//! `V₁` one V-cycle over levels, each the Galerkin operator
//! `A_{l+1} = R_lᵀ A_l R_l` of the one below on aggregates of about
//! [`SIZE`] of its nodes: a block-Jacobi sweep, the residual's correction
//! from the level above scaled by θ, another sweep; down to at most
//! [`COARSEST`] nodes, solved exactly.
//!
//! - **Aggregates** are grown breadth-first over the Type 1 links, seeds
//!   taken in a breadth-first order of the whole cloth, a
//!   leftover node joining a neighbouring aggregate; each level's graph
//!   joins two aggregates when a link of the level below does. The
//!   hierarchy is made once per set of links and kept while the links stay
//!   the same. Pinned particles belong to none, as the filter leaves them
//!   out of `A`.
//! - **Each level's operator** is stored as the grid's: a diagonal block
//!   per node and a block `C` per edge, `A[I][J] = A[J][I] = −C`. A block
//!   between two aggregates that share no link (a contact between distant
//!   parts of the cloth) adds `C` to both diagonals only, which keeps the
//!   operator positive definite.
//! - **The coarsest level** is factored by a Cholesky factorisation in f64
//!   that skips the zeros before each row's first coupling (the
//!   breadth-first numbering keeps coupled aggregates close in number). A
//!   cloth whose pieces are too many to aggregate that far (a cloth cut
//!   into scraps) takes a block-Jacobi sweep there instead.

use bevy::math::{Mat3A, Vec3, Vec3A};

use super::coarse::joining_pairs;
use super::operator::{Soa, sym_matrix};
use crate::sim::connections::{Connections, LinkStamp};
use crate::sim::model::jacobian::Block;
use crate::sim::model::streams::StreamBlocks;
use level::Level;

mod level;

/// Particles (on the first level) or nodes (above) per aggregate, about.
pub const SIZE: usize = 4;

/// Nodes of the coarsest level at most, solved exactly.
pub const COARSEST: usize = 64;

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
    /// Starts the coarse operator of a step of the cloth with links
    /// `connections` and scaled masses `mass_scale / w` (kg; `w` in 1/kg,
    /// 0 pins), whose links have generation `generation` if their owner
    /// keeps one (see [`LinkStamp`]). `false` (no correction) for fewer
    /// than 64 particles.
    pub(super) fn begin(
        &mut self,
        connections: &Connections,
        generation: Option<u64>,
        inverse_masses: &[f32],
        mass_scale: f32,
    ) -> bool {
        let n = inverse_masses.len();
        if n < 64 {
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
        for (&a, &w) in self.aggregate.iter().zip(inverse_masses) {
            if a != NONE {
                first.diag[a as usize] += Mat3A::from_diagonal(Vec3::splat(mass_scale / w));
                first.filled[a as usize] = true;
            }
        }
        true
    }

    /// Adds the symmetric block `c` (xx, yy, zz, xy, xz, yz; kg) to
    /// particle `a`'s diagonal (a contact the solve holds): to its
    /// aggregate's, unless it is pinned.
    pub(super) fn add_diagonal(&mut self, a: usize, c: &[f32; 6]) {
        if let Some(&i) = self.aggregate.get(a)
            && i != NONE
        {
            self.levels[0].diag[i as usize] += Mat3A::from(sym_matrix(c));
        }
    }

    /// Adds the block `C` of the pair `(a, b)`.
    fn add_pair(&mut self, a: usize, b: usize, c: &[f32; 6]) {
        let (i, j) = (self.aggregate[a], self.aggregate[b]);
        if i == j {
            return;
        }
        let c = Mat3A::from(sym_matrix(c));
        let first = &mut self.levels[0];
        if i == NONE || j == NONE {
            first.diag[i.min(j) as usize] += c;
            return;
        }
        first.add_pair(i as usize, j as usize, c);
    }

    /// Adds every pair of a step of `n` particles that joins two
    /// aggregates ([`joining_pairs`]).
    pub(super) fn add_pairs<'a>(
        &mut self,
        n: usize,
        pairs: (&[Block], impl Iterator<Item = StreamBlocks<'a>>),
        scales: (f32, f32),
    ) {
        joining_pairs(n, pairs, scales, |p, q, block| {
            if self.aggregate[p] != self.aggregate[q]
                && let Some(c) = block()
            {
                self.add_pair(p, q, &c);
            }
        });
    }

    /// Forms the levels above the first and factors the coarsest; `false`
    /// on an operator that is not positive definite.
    pub(super) fn finish(&mut self) -> bool {
        for l in 1..self.levels.len() {
            let (below, above) = self.levels.split_at_mut(l);
            below[l - 1].coarsen(&mut above[0]);
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
        let size = 3 * level.count();
        self.matrix.clear();
        self.matrix.resize(size * size, 0.0);
        self.first.clear();
        self.first.extend((0..size).map(|row| row - row % 3));
        let mut put = |(i, j): (usize, usize), m: Mat3A, sign: f64| {
            for r in 0..3 {
                for k in 0..3 {
                    self.matrix[(3 * i + r) * size + 3 * j + k] += sign * m.col(k)[r] as f64;
                }
            }
        };
        for i in 0..level.count() {
            let d = if level.filled[i] {
                level.diag[i]
            } else {
                Mat3A::IDENTITY
            };
            put((i, i), d, 1.0);
            for k in level.start[i] as usize..level.start[i + 1] as usize {
                let j = level.above[k] as usize;
                put((i, j), level.off[k], -1.0);
                put((j, i), level.off[k], -1.0);
                for r in 0..3 {
                    let row = 3 * j + r;
                    self.first[row] = self.first[row].min(3 * i);
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
        first.r.fill(Vec3A::ZERO);
        let [rx, ry, rz] = r.0.each_ref().map(|c| &c[..self.aggregate.len()]);
        for (p, &a) in self.aggregate.iter().enumerate() {
            if a != NONE {
                first.r[a as usize] += Vec3A::new(rx[p], ry[p], rz[p]);
            }
        }
        self.cycle_from(0);
        let e = &self.levels[0].e;
        let n = self.aggregate.len();
        let [yx, yy, yz] = y.0.each_mut().map(|c| &mut c[..n]);
        for (p, (&a, &f)) in self.aggregate.iter().zip(&free[..n]).enumerate() {
            if a != NONE {
                let c = f * e[a as usize];
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
        level.e.fill(Vec3A::ZERO);
        level.jacobi(false);
        level.residual();
        up.r.fill(Vec3A::ZERO);
        for (i, &t) in level.t.iter().enumerate() {
            up.r[level.parent[i] as usize] += t;
        }
        self.cycle_from(l + 1);
        let (below, above) = self.levels.split_at_mut(l + 1);
        let (level, up) = (&mut below[l], &above[0]);
        for (i, e) in level.e.iter_mut().enumerate() {
            if level.filled[i] {
                *e += THETA * up.e[level.parent[i] as usize];
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
            level.e.fill(Vec3A::ZERO);
            level.jacobi(false);
            return;
        }
        let size = self.first.len();
        let rc = &mut self.rc;
        rc.clear();
        rc.extend(level.r.iter().flat_map(|r| r.to_array().map(f64::from)));
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
            *e = if level.filled[i] {
                Vec3A::new(rc[3 * i] as f32, rc[3 * i + 1] as f32, rc[3 * i + 2] as f32)
            } else {
                Vec3A::ZERO
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

/// The links the hierarchy is made over: the Type 1 links.
fn links(connections: &Connections) -> impl Iterator<Item = (u32, u32)> + '_ {
    connections.type1().map(|l| (l.a, l.b))
}

/// What a hierarchy depends on: the particle count, the link count and a
/// checksum of their ends.
fn key(connections: &Connections, n: usize) -> (usize, usize, u64) {
    let mut sum = 0u64;
    let mut count = 0;
    for (a, b) in links(connections) {
        sum = sum
            .rotate_left(5)
            .wrapping_add(((a as u64) << 32) | b as u64);
        count += 1;
    }
    (n, count, sum)
}

/// The graph of `n` nodes joined by `edges` (ends out of range ignored):
/// each node's neighbours, sorted, without itself.
fn graph(n: usize, edges: impl Iterator<Item = (u32, u32)>) -> Vec<Vec<u32>> {
    let mut out = vec![Vec::new(); n];
    for (a, b) in edges {
        if a != b && (a as usize) < n && (b as usize) < n {
            out[a as usize].push(b);
            out[b as usize].push(a);
        }
    }
    for row in &mut out {
        row.sort_unstable();
        row.dedup();
    }
    out
}

/// The hierarchy of a cloth of `n` particles over the links of
/// `connections` (module docs): writes each particle's first-level
/// aggregate into `grouped` and returns the levels, their graphs made and
/// their operators empty.
fn hierarchy(connections: &Connections, n: usize, grouped: &mut Vec<u32>) -> Vec<Level> {
    let particles = graph(n, links(connections));
    let count = aggregate(&particles, grouped);
    let mut neighbours = lift(&particles, grouped, count);
    let mut levels = Vec::new();
    loop {
        let mut level = Level::new(&neighbours);
        let count = level.count();
        if count <= COARSEST {
            levels.push(level);
            return levels;
        }
        let up = aggregate(&neighbours, &mut level.parent);
        if 4 * up > 3 * count {
            // Scraps that no longer aggregate: this level is the last.
            level.parent.clear();
            levels.push(level);
            return levels;
        }
        let above = lift(&neighbours, &level.parent, up);
        let next = Level::new(&above);
        level.lift = (0..count)
            .flat_map(|i| {
                let (start, end) = (level.start[i] as usize, level.start[i + 1] as usize);
                let (parent, next) = (&level.parent, &next);
                level.above[start..end].iter().map(move |&j| {
                    let (p, q) = (parent[i] as usize, parent[j as usize] as usize);
                    if p == q {
                        NONE
                    } else {
                        next.edge(p.min(q), p.max(q)).expect("a lifted edge") as u32
                    }
                })
            })
            .collect();
        levels.push(level);
        neighbours = above;
    }
}

/// The graph of `count` aggregates (`parent` of each node of `nodes`):
/// two are neighbours when nodes of theirs are.
fn lift(nodes: &[Vec<u32>], parent: &[u32], count: usize) -> Vec<Vec<u32>> {
    let edges = nodes
        .iter()
        .enumerate()
        .flat_map(|(i, row)| row.iter().map(move |&j| (parent[i], parent[j as usize])));
    graph(count, edges)
}

/// Groups the nodes of the graph `neighbours` into connected aggregates of
/// about [`SIZE`] (module docs); writes each node's aggregate into `out`
/// and returns how many there are.
fn aggregate(neighbours: &[Vec<u32>], out: &mut Vec<u32>) -> usize {
    let n = neighbours.len();
    // Seeds in breadth-first order of the whole graph, each piece of it
    // from the node its first node's search reaches last (far from the
    // rest: the levels run across the cloth, not around it, and the
    // coupled aggregates stay close in number).
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let breadth_first = |root: usize, seen: &mut Vec<bool>, order: &mut Vec<u32>| {
        let from = order.len();
        seen[root] = true;
        order.push(root as u32);
        let mut k = from;
        while k < order.len() {
            let p = order[k] as usize;
            k += 1;
            for &q in &neighbours[p] {
                if !std::mem::replace(&mut seen[q as usize], true) {
                    order.push(q);
                }
            }
        }
        from
    };
    for root in 0..n {
        if seen[root] {
            continue;
        }
        let from = breadth_first(root, &mut seen, &mut order);
        let far = order[order.len() - 1] as usize;
        for &p in &order[from..] {
            seen[p as usize] = false;
        }
        order.truncate(from);
        breadth_first(far, &mut seen, &mut order);
    }
    out.clear();
    out.resize(n, NONE);
    let mut sizes: Vec<usize> = Vec::new();
    let mut ball = Vec::with_capacity(SIZE);
    for &seed in &order {
        if out[seed as usize] != NONE {
            continue;
        }
        let id = sizes.len() as u32;
        ball.clear();
        ball.push(seed);
        out[seed as usize] = id;
        let mut k = 0;
        while k < ball.len() && ball.len() < SIZE {
            let p = ball[k] as usize;
            k += 1;
            for &q in &neighbours[p] {
                if ball.len() < SIZE && out[q as usize] == NONE {
                    out[q as usize] = id;
                    ball.push(q);
                }
            }
        }
        sizes.push(ball.len());
    }
    // A node left alone joins a neighbouring aggregate.
    let mut into: Vec<u32> = (0..sizes.len() as u32).collect();
    for p in 0..n {
        let a = out[p] as usize;
        if sizes[a] == 1
            && let Some(&q) = neighbours[p]
                .iter()
                .find(|&&q| sizes[out[q as usize] as usize] > 1)
        {
            into[a] = out[q as usize];
        }
    }
    // Renumber in order of first appearance.
    let mut number = vec![NONE; sizes.len()];
    let mut count = 0;
    for &p in &order {
        let a = into[out[p as usize] as usize] as usize;
        if number[a] == NONE {
            number[a] = count;
            count += 1;
        }
    }
    for a in out.iter_mut() {
        *a = number[into[*a as usize] as usize];
    }
    count as usize
}

#[cfg(test)]
mod tests;
