//! The starting guess and the deflation piece by piece, for a cloth in
//! several pieces (torn or cut apart, or made of several).
//!
//! No link joins two pieces, so `A` has no block between them and the
//! energy norm of a combination is the sum of the pieces' own. The best
//! combination with its own coefficients on each piece,
//! `Δv₀ = Σ_p W_p c_p` with `(W_pᵀ A W_p) c_p = W_pᵀ b` (`W_p` the kept
//! solutions on piece `p`, zero elsewhere), then costs the same products
//! with `A` as one combination of the whole cloth, and follows pieces that
//! tumble apart each in its own way, which one set of coefficients for the
//! whole cloth cannot.

use std::ops::Range;

use super::{MOST, add_combination, solve_gram};
use crate::sim::integrate::implicit::operator::dot_parts;
use crate::sim::soa::Soa;

/// The particles `run` of `v`, as its three component slices.
fn part<'a>(v: &'a Soa, run: &Range<usize>) -> [&'a [f32]; 3] {
    v.0.each_ref().map(|c| &c[run.clone()])
}

/// Groups the guess combines apart, at most: pieces past as many share a
/// group (`piece mod MOST_GROUPS`), which is still exact, as no link joins
/// two pieces of a group either.
pub(super) const MOST_GROUPS: usize = 256;

/// Which group each particle is in, and each group's small system.
#[derive(Clone, Debug, Default)]
pub(super) struct Pieces {
    /// Each particle's group.
    of: Vec<u32>,
    /// The union–find forest the groups are found with.
    parent: Vec<u32>,
    /// How many groups there are.
    count: usize,
    /// Runs of consecutive particles of one group, and the group: the sums
    /// and updates go a run at a time (a torn grid's pieces are row
    /// segments).
    runs: Vec<(Range<usize>, usize)>,
    /// The links generation and particle count `of` was made for.
    made_for: Option<(u64, usize)>,
    /// Each group's `WᵀAW` (kg·m²/s²).
    gram: Vec<[[f64; MOST]; MOST]>,
    /// Each group's `Wᵀb` or `(AW)ᵀy` (kg·m²/s²).
    sums: Vec<[f64; MOST]>,
    /// Each group's coefficients (dimensionless).
    coefficients: Vec<[f64; MOST]>,
}

impl Pieces {
    /// Makes room for `n` particles, so that finding the groups later
    /// allocates nothing while the cloth stays in one piece.
    pub fn reserve(&mut self, n: usize) {
        for v in [&mut self.of, &mut self.parent] {
            v.reserve(n.saturating_sub(v.len()));
        }
    }

    /// How many groups the last [`find`](Self::find) made of `n`
    /// particles (0 if it was for another count).
    pub fn count(&self, n: usize) -> usize {
        if self.of.len() == n { self.count } else { 0 }
    }

    /// Groups `n` particles by the pieces `links` (particle pairs) join,
    /// unless it did so last for the same `generation` of the links and
    /// `n` (a cloth without a generation is grouped each time).
    pub fn find(
        &mut self,
        links: impl Iterator<Item = (u32, u32)>,
        n: usize,
        generation: Option<u64>,
    ) {
        let key = generation.map(|g| (g, n));
        if key.is_some() && key == self.made_for && self.of.len() == n {
            return;
        }
        fn root(parent: &mut [u32], mut i: u32) -> u32 {
            while parent[i as usize] != i {
                parent[i as usize] = parent[parent[i as usize] as usize];
                i = parent[i as usize];
            }
            i
        }
        let parent = &mut self.parent;
        parent.clear();
        parent.extend(0..n as u32);
        for (a, b) in links {
            if (a as usize) < n && (b as usize) < n {
                let (a, b) = (root(parent, a), root(parent, b));
                parent[a.max(b) as usize] = a.min(b);
            }
        }
        // Roots numbered in the order of their first particle, then every
        // particle its root's number.
        self.of.clear();
        self.of.resize(n, u32::MAX);
        let mut pieces = 0u32;
        for i in 0..n as u32 {
            let r = root(parent, i) as usize;
            if self.of[r] == u32::MAX {
                self.of[r] = pieces % MOST_GROUPS as u32;
                pieces += 1;
            }
        }
        for i in 0..n as u32 {
            self.of[i as usize] = self.of[root(parent, i) as usize];
        }
        self.count = (pieces as usize).min(MOST_GROUPS);
        self.runs.clear();
        if self.count > 1 {
            let mut start = 0;
            for p in 1..=n {
                if p == n || self.of[p] != self.of[start] {
                    self.runs.push((start..p, self.of[start] as usize));
                    start = p;
                }
            }
            self.gram.resize(self.count, [[0.0; MOST]; MOST]);
            self.sums.resize(self.count, [0.0; MOST]);
            self.coefficients.resize(self.count, [0.0; MOST]);
        }
        self.made_for = key;
    }

    /// Writes into `dv` the combination of `solutions` (filtered, their
    /// products with `A` in `images`) closest to the solution of
    /// `A Δv = b` with coefficients of its own on each group (module
    /// docs); keeps each group's `WᵀAW` for [`deflate`](Self::deflate).
    /// False, with `dv` untouched, if no group's combination adds
    /// anything.
    pub fn guess(&mut self, solutions: &[Soa], images: &[Soa], b: &Soa, dv: &mut Soa) -> bool {
        let count = self.count;
        for (gram, sums) in self.gram[..count].iter_mut().zip(&mut self.sums[..count]) {
            *gram = [[0.0; MOST]; MOST];
            *sums = [0.0; MOST];
        }
        let k = solutions.len();
        for (run, group) in &self.runs {
            let (gram, sums) = (&mut self.gram[*group], &mut self.sums[*group]);
            for j in 0..k {
                let aw = part(&images[j], run);
                for (i, w) in solutions.iter().enumerate() {
                    gram[i][j] += dot_parts(part(w, run), aw);
                }
                sums[j] += dot_parts(part(&solutions[j], run), part(b, run));
            }
        }
        if !self.solve(k) {
            return false;
        }
        dv.zero();
        self.add(dv, solutions, 1.0);
        true
    }

    /// [`Past::deflate`](super::Past::deflate) group by group: `y` (m/s)
    /// loses its part along each group's kept solutions in `A`'s energy
    /// norm, with the `A` and solutions of the last [`guess`](Self::guess).
    pub fn deflate(&mut self, solutions: &[Soa], images: &[Soa], y: &mut Soa) {
        let count = self.count;
        for sums in &mut self.sums[..count] {
            *sums = [0.0; MOST];
        }
        for (run, group) in &self.runs {
            let yp = part(y, run);
            for (sum, image) in self.sums[*group].iter_mut().zip(images) {
                *sum += dot_parts(part(image, run), yp);
            }
        }
        if self.solve(solutions.len()) {
            self.add(y, solutions, -1.0);
        }
    }

    /// Each group's coefficients from its `WᵀAW` and sums (zero where none
    /// adds anything); whether any group has any.
    fn solve(&mut self, k: usize) -> bool {
        let mut any = false;
        for ((gram, sums), c) in self.gram.iter().zip(&self.sums).zip(&mut self.coefficients) {
            *c = solve_gram(gram, sums, k).unwrap_or([0.0; MOST]);
            any |= c.iter().any(|&c| c as f32 != 0.0);
        }
        any
    }

    /// `out += sign · Σ_j c_{group, j} w_j`, a run at a time.
    fn add(&self, out: &mut Soa, solutions: &[Soa], sign: f32) {
        for (run, group) in &self.runs {
            let out = out.0.each_mut().map(|c| &mut c[run.clone()]);
            add_combination(out, run.start, solutions, &self.coefficients[*group], sign);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_are_grouped_in_runs_and_kept_for_a_generation() {
        // 0–1–2 and 4–5 joined, 3 and 6 alone: four pieces.
        let links = [(0, 1), (2, 1), (4, 5)];
        let mut pieces = Pieces::default();
        pieces.find(links.into_iter(), 7, Some(1));
        assert_eq!(pieces.count(7), 4);
        assert_eq!(pieces.count(8), 0, "grouped for another count");
        assert_eq!(pieces.of, [0, 0, 0, 1, 2, 2, 3]);
        assert_eq!(pieces.runs, [(0..3, 0), (3..4, 1), (4..6, 2), (6..7, 3)]);
        // The same generation keeps the groups; another, or none, finds
        // them again.
        pieces.find([(0, 6)].into_iter(), 7, Some(1));
        assert_eq!(pieces.of, [0, 0, 0, 1, 2, 2, 3]);
        pieces.find([(0, 6)].into_iter(), 7, Some(2));
        assert_eq!(pieces.of, [0, 1, 2, 3, 4, 5, 0]);
        pieces.find([(0, 6), (3, 4)].into_iter(), 7, None);
        assert_eq!(pieces.of, [0, 1, 2, 3, 3, 4, 0]);
        // One piece: nothing to group; ends out of range are ignored.
        pieces.find((0..6).map(|i| (i, i + 1)).chain([(2, 99)]), 7, None);
        assert_eq!(pieces.count(7), 1);
        assert!(pieces.runs.is_empty());
        // More pieces than groups: they share groups, every particle of a
        // piece in the same one.
        let n = MOST_GROUPS * 2 + 10;
        let pairs = (0..n as u32 / 2).map(|i| (2 * i, 2 * i + 1));
        pieces.find(pairs, n, None);
        assert_eq!(pieces.count(n), MOST_GROUPS);
        for i in (0..n).step_by(2) {
            assert_eq!(pieces.of[i], pieces.of[i + 1]);
            assert_eq!(pieces.of[i] as usize, (i / 2) % MOST_GROUPS);
        }
    }
}
