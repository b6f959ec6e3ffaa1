//! The coarse correction of the implicit solver's preconditioner for a
//! cloth that is not a grid (a mesh cloth, [`Connections::columns`] 0).
//!
//! A two-level additive preconditioner, the first level of the grid's
//! multigrid ([`coarse`](super::coarse)) solved exactly,
//! `P⁻¹ r = B⁻¹ r + R A_c⁻¹ Rᵀ r` with
//! `A_c = Rᵀ A R`, on aggregates made from the mesh's connectivity rather
//! than grid squares:
//!
//! - **Aggregates** are grown breadth-first over the Type 1 links, seeds
//!   taken in a breadth-first order of the whole cloth, each to about
//!   `n / `[`AGGREGATES`] particles; a leftover aggregate of less than a
//!   third of that joins a neighbour. They are made once per set of links
//!   and kept while the links stay the same. Pinned particles belong to
//!   none, as the filter leaves them out of `A`.
//! - **`A_c`** (3 unknowns per aggregate) is assembled from the operator's
//!   pair blocks as for the grid, and factored by a Cholesky
//!   factorisation in f64 that skips the zeros before each row's first
//!   coupling (the seeds' breadth-first order keeps coupled aggregates
//!   close in number, so the profile is narrow).

use bevy::math::Vec3;

use super::coarse::joining_pairs;
use super::operator::{Soa, sym_matrix};
use crate::sim::connections::Connections;
use crate::sim::model::jacobian::Block;
use crate::sim::model::streams::StreamBlocks;

/// How many aggregates the particles are grouped into, about.
pub const AGGREGATES: usize = 96;

/// Marks a particle outside every aggregate (pinned).
const NONE: u32 = u32::MAX;

/// The coarse operator of one step of a mesh cloth, factored, and its
/// aggregation.
#[derive(Clone, Debug, Default)]
pub(super) struct MeshCoarse {
    /// What the aggregation was made for: particles, links and a checksum
    /// of the links' ends.
    key: (usize, usize, u64),
    /// Aggregate of each particle, pinned or not.
    grouped: Vec<u32>,
    /// This step's aggregate of each particle, [`NONE`] for pinned ones.
    aggregate: Vec<u32>,
    /// Number of aggregates.
    count: usize,
    /// `A_c` (kg), dense and row-major, then its Cholesky factor `L` in
    /// the lower triangle (√kg).
    matrix: Vec<f64>,
    /// First non-zero column of each row of `A_c`.
    first: Vec<usize>,
    /// Coarse right-hand side, then solution.
    rc: Vec<f64>,
}

impl MeshCoarse {
    /// Starts the coarse operator of a step of the cloth with links
    /// `connections` and scaled masses `mass_scale / w` (kg; `w` in 1/kg,
    /// 0 pins). `false` (no correction) for fewer than 64 particles.
    pub(super) fn begin(
        &mut self,
        connections: &Connections,
        inverse_masses: &[f32],
        mass_scale: f32,
    ) -> bool {
        let n = inverse_masses.len();
        if n < 64 {
            return false;
        }
        let key = key(connections, n);
        if key != self.key {
            self.count = aggregate(connections, n, &mut self.grouped);
            self.key = key;
        }
        self.aggregate.clear();
        self.aggregate.extend(
            self.grouped
                .iter()
                .zip(inverse_masses)
                .map(|(&a, &w)| if w == 0.0 { NONE } else { a }),
        );
        let size = 3 * self.count;
        self.matrix.clear();
        self.matrix.resize(size * size, 0.0);
        self.first.clear();
        self.first.extend((0..size).map(|row| row - row % 3));
        for (&a, &w) in self.aggregate.iter().zip(inverse_masses) {
            if a != NONE {
                let m = (mass_scale / w) as f64;
                for k in 0..3 {
                    self.matrix[(3 * a as usize + k) * (size + 1)] += m;
                }
            }
        }
        // An aggregate of pinned particles only is decoupled: identity.
        for i in 0..self.count {
            for k in 0..3 {
                let d = &mut self.matrix[(3 * i + k) * (size + 1)];
                if *d == 0.0 {
                    *d = 1.0;
                }
            }
        }
        true
    }

    /// Adds the symmetric block `c` (xx, yy, zz, xy, xz, yz; kg) at
    /// aggregates `(i, j)` of `A_c`, rows `i`, columns `j`.
    fn put(&mut self, (i, j): (usize, usize), c: &[f32; 6], sign: f64) {
        let size = 3 * self.count;
        let m = sym_matrix(c);
        for r in 0..3 {
            for k in 0..3 {
                self.matrix[(3 * i + r) * size + 3 * j + k] += sign * m.col(k)[r] as f64;
            }
        }
        if i > j {
            for r in 0..3 {
                let row = 3 * i + r;
                self.first[row] = self.first[row].min(3 * j);
            }
        }
    }

    /// Adds the symmetric block `c` to particle `a`'s diagonal (a contact
    /// the solve holds): to its aggregate's, unless it is pinned.
    pub(super) fn add_diagonal(&mut self, a: usize, c: &[f32; 6]) {
        if let Some(&i) = self.aggregate.get(a)
            && i != NONE
        {
            self.put((i as usize, i as usize), c, 1.0);
        }
    }

    /// Adds the block `C` of the pair `(a, b)`.
    fn add_pair(&mut self, a: usize, b: usize, c: &[f32; 6]) {
        let (i, j) = (self.aggregate[a], self.aggregate[b]);
        if i == j {
            return;
        }
        if i == NONE || j == NONE {
            let free = i.min(j) as usize;
            self.put((free, free), c, 1.0);
            return;
        }
        let (i, j) = (i as usize, j as usize);
        self.put((i, i), c, 1.0);
        self.put((j, j), c, 1.0);
        self.put((i, j), c, -1.0);
        self.put((j, i), c, -1.0);
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

    /// Factors `A_c` in place; `false` on a pivot that is not positive.
    pub(super) fn finish(&mut self) -> bool {
        let size = 3 * self.count;
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

    /// `y += R A_c⁻¹ Rᵀ r` over the free particles (`free` is 1 or 0).
    pub(super) fn add(&mut self, r: &Soa, y: &mut Soa, free: &[f32]) {
        let size = 3 * self.count;
        let rc = &mut self.rc;
        rc.clear();
        rc.resize(size, 0.0);
        for (p, &a) in self.aggregate.iter().enumerate() {
            if a != NONE {
                let v = r.get(p);
                for k in 0..3 {
                    rc[3 * a as usize + k] += v[k] as f64;
                }
            }
        }
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
        for (p, &a) in self.aggregate.iter().enumerate() {
            if a != NONE {
                let i = 3 * a as usize;
                let c = Vec3::new(rc[i] as f32, rc[i + 1] as f32, rc[i + 2] as f32);
                y.set(p, y.get(p) + free[p] * c);
            }
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

/// What an aggregation depends on: the particle count, the Type 1 link
/// count and a checksum of their ends.
fn key(connections: &Connections, n: usize) -> (usize, usize, u64) {
    let mut sum = 0u64;
    let mut count = 0;
    for l in connections.type1() {
        sum = sum
            .rotate_left(5)
            .wrapping_add(((l.a as u64) << 32) | l.b as u64);
        count += 1;
    }
    (n, count, sum)
}

/// Groups `n` particles into about [`AGGREGATES`] connected aggregates over
/// the Type 1 links of `connections` (module docs); writes each particle's
/// aggregate into `out` and returns how many there are.
fn aggregate(connections: &Connections, n: usize, out: &mut Vec<u32>) -> usize {
    // Neighbours by particle (compressed rows).
    let mut start = vec![0u32; n + 1];
    for l in connections.type1() {
        start[l.a as usize + 1] += 1;
        start[l.b as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut next = vec![0u32; start[n] as usize];
    for l in connections.type1() {
        for (p, q) in [(l.a, l.b), (l.b, l.a)] {
            next[fill[p as usize] as usize] = q;
            fill[p as usize] += 1;
        }
    }
    let neighbours = |p: usize| &next[start[p] as usize..start[p + 1] as usize];
    // Seeds in breadth-first order of the whole cloth, each piece of it
    // from the particle its first particle's search reaches last (far
    // from the rest: the levels run across the cloth, not around it, and
    // the coupled aggregates stay close in number).
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
            for &q in neighbours(p) {
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
    let target = n.div_ceil(AGGREGATES).max(4);
    out.clear();
    out.resize(n, NONE);
    let mut sizes: Vec<usize> = Vec::new();
    let mut ball = Vec::with_capacity(target);
    for &seed in &order {
        if out[seed as usize] != NONE {
            continue;
        }
        let id = sizes.len() as u32;
        ball.clear();
        ball.push(seed);
        out[seed as usize] = id;
        let mut k = 0;
        while k < ball.len() && ball.len() < target {
            let p = ball[k] as usize;
            k += 1;
            for &q in neighbours(p) {
                if ball.len() < target && out[q as usize] == NONE {
                    out[q as usize] = id;
                    ball.push(q);
                }
            }
        }
        sizes.push(ball.len());
    }
    // Small leftovers join a neighbouring aggregate.
    let mut into: Vec<u32> = (0..sizes.len() as u32).collect();
    for p in 0..n {
        let a = out[p] as usize;
        if sizes[a] * 3 < target
            && into[a] == a as u32
            && let Some(&q) = neighbours(p)
                .iter()
                .find(|&&q| sizes[out[q as usize] as usize] * 3 >= target)
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
mod tests {
    use super::*;
    use crate::sim::topology::{MeshTopology, disc};

    #[test]
    fn a_disc_groups_into_connected_aggregates_of_similar_size() {
        let (positions, indices) = disc(1.0, 20);
        let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
        let links = t.connections();
        let mut out = Vec::new();
        let count = aggregate(&links, t.len(), &mut out);
        assert!(
            (AGGREGATES / 2..=2 * AGGREGATES).contains(&count),
            "{count}"
        );
        let mut sizes = vec![0; count];
        for &a in &out {
            sizes[a as usize] += 1;
        }
        let target = t.len().div_ceil(AGGREGATES);
        assert!(
            sizes.iter().all(|&s| s * 3 >= target && s <= 2 * target),
            "{sizes:?}"
        );
    }

    #[test]
    fn the_profile_factor_solves_the_coarse_system() {
        // A_c of a chain of aggregates: the factor's solve inverts it.
        let (positions, indices) = disc(1.0, 10);
        let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
        let links = t.connections();
        let w = vec![1.0; t.len()];
        let mut c = MeshCoarse::default();
        assert!(c.begin(&links, &w, 1.0));
        for l in links.type1() {
            c.add_pair(l.a as usize, l.b as usize, &[2.0, 2.0, 2.0, 0.5, 0.0, 0.0]);
        }
        let size = 3 * c.count;
        let dense = c.matrix.clone();
        assert!(c.finish());
        // r: one particle's unit force; R A_c⁻¹ Rᵀ r solved, then A_c times
        // the coarse solution gives Rᵀ r back.
        let mut r = Soa::default();
        r.resize(t.len());
        r.set(7, Vec3::new(1.0, -2.0, 0.5));
        let mut y = Soa::default();
        y.resize(t.len());
        c.add(&r, &mut y, &w);
        let x = c.rc.clone();
        for i in 0..size {
            // The dense matrix is symmetric: row i from its lower and upper parts.
            let row: f64 = (0..size).map(|k| dense[i * size + k] * x[k]).sum();
            let a = c.aggregate[7] as usize;
            let want = if i / 3 == a {
                [1.0, -2.0, 0.5][i % 3]
            } else {
                0.0
            };
            assert!((row - want).abs() < 1e-9, "row {i}: {row} vs {want}");
        }
    }
}
