//! The multigrid half of the implicit solver's preconditioner.
//!
//! Block-Jacobi alone leaves the smooth modes of a stiff cloth to the
//! conjugate gradient: on a 64×64 cotton cloth at 1/60 s, `h²k` outweighs a
//! particle's mass ~5000 times (and 16 times more at 256×256), and the
//! conjugate gradient needs more iterations the finer the grid. Those modes
//! are what coarser grids see, so the preconditioner is
//!
//! `P⁻¹ r = B⁻¹ r + R₁ V₁(R₁ᵀ r)`,
//!
//! with `B` the 3×3 diagonal blocks of `A`, `R₁` the piecewise-constant
//! prolongation from aggregates of 2 × 2 grid particles (pinned ones
//! excluded, as the filter excludes them from `A`), and `V₁` one V-cycle
//! over a hierarchy of levels ([`level`]), each the Galerkin operator
//! `A_{l+1} = R_lᵀ A_l R_l` of the one below in squares of 2 × 2:
//!
//! 1. a block-Jacobi sweep of weight [`OMEGA`] from zero;
//! 2. the residual restricted to the level above, its V-cycle, and the
//!    correction prolonged back, scaled by [`THETA`]: a piecewise-constant
//!    prolongation makes a smooth correction cost more energy than it
//!    should, so the correction it brings is too small by about that much;
//! 3. another sweep, so that the cycle is symmetric;
//!
//! down to a level of at most [`COARSEST`] aggregates, solved exactly by a
//! banded Cholesky factor in f64 ([`factor`]). Both halves of `P⁻¹` are
//! symmetric positive definite, so `P` is too, as the conjugate gradient
//! needs. In motion the iterations grow by half from 64×64 to 256×256 (16
//! times the particles); a two-level correction over at most 8×8
//! aggregates takes 2.5 times as many at 256×256.
//!
//! `A₁` comes straight from the operator's pair blocks: a block `C`
//! between two aggregates `I ≠ J` adds `C` to `A₁[I][I]` and `A₁[J][J]` and
//! `−C` to `A₁[I][J]`; inside one aggregate it cancels; against a pinned
//! particle it adds `C` to the free side's diagonal; masses add up. A grid
//! link reaches at most 2 particles, so aggregates couple only to their 8
//! neighbours. A block between particles farther apart (a contact between
//! distant parts of the cloth) adds `C` to both diagonals only, which keeps
//! `A₁` positive definite.

use bevy::math::{Mat3A, Vec3, Vec3A};

use super::operator::{Soa, rank_block, sym_matrix, sym_of};
use crate::sim::model::jacobian::Block;
use crate::sim::model::streams::StreamBlocks;
use factor::Banded;
use level::{Level, SLOTS};

mod factor;
mod level;
#[cfg(test)]
pub(super) mod tests;

/// Aggregates on the coarsest level at most.
pub const COARSEST: usize = 64;

/// Weight of a block-Jacobi sweep.
const OMEGA: f32 = 0.6;

/// Scale of the correction a level takes from the one above it.
const THETA: f32 = 1.5;

/// Fine particles per aggregate side on the first level.
const SIDE: usize = 2;

/// Marks a pinned particle, which belongs to no aggregate.
const NONE: u32 = u32::MAX;

/// A pair's block `C = t I + s u uᵀ` as `(t, s, u)` (kg; `u` a unit
/// vector).
pub(super) type Rank = (f32, f32, [f32; 3]);

/// Visits every pair `(p, q)`, `p < q`, of a step of `n` particles that
/// the operator takes, for a coarse operator to add: the blocks formed by
/// stream, then the Jacobian `blocks` as `C = αD + βK`. `visit` gets the
/// pair and a function that forms its block `C` ([`Rank`]; `None` for a
/// zero block), so that a pair the coarse operator has no use for (the
/// grid's pairs inside one aggregate, most of them, where they cancel)
/// costs no block.
pub(super) fn joining_pairs<'a>(
    n: usize,
    (blocks, streamed): (&[Block], impl Iterator<Item = StreamBlocks<'a>>),
    (alpha, beta): (f32, f32),
    mut visit: impl FnMut(usize, usize, &dyn Fn() -> Option<Rank>),
) {
    for src in streamed {
        // Slots past the last particle hold no link.
        let m = src.t.len().min(n.saturating_sub(src.lo + src.delta));
        for i in 0..m {
            let (p, q) = (src.lo + i, src.lo + i + src.delta);
            visit(p, q, &|| {
                (src.t[i] != 0.0 || src.s[i] != 0.0)
                    .then(|| (src.t[i], src.s[i], src.u.map(|u| u[i])))
            });
        }
    }
    for blk in blocks {
        let (p, q) = (blk.a.min(blk.b) as usize, blk.a.max(blk.b) as usize);
        visit(p, q, &|| rank_block(blk, alpha, beta));
    }
}

/// The vectors of one level's V-cycle.
#[derive(Clone, Debug, Default)]
pub(super) struct LevelWork {
    /// Right-hand side (N·s), restricted from the level below.
    r: Vec<Vec3A>,
    /// Correction (m/s).
    e: Vec<Vec3A>,
    /// Residual.
    t: Vec<Vec3A>,
    /// The coarsest level's unknowns in the factor's order, f64.
    z: Vec<f64>,
}

/// What a preconditioner application writes: lent out to the two threads
/// of a split solve ([`Coarse::take_scratch`]).
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    /// The first level's right-hand side `R₁ᵀ r` (N·s) and its correction
    /// `V₁(R₁ᵀ r)` (m/s), one entry per aggregate.
    pub(super) top: [Vec<Vec3A>; 2],
    /// A fine row's worth of column sums (restriction, N·s) or of
    /// corrections (prolongation, m/s), one per thread.
    pub(super) rows: [Vec<f32>; 2],
    /// The V-cycle's vectors, per level.
    pub(super) work: Vec<LevelWork>,
}

/// The multigrid hierarchy of one step, and its scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct Coarse {
    /// First-level aggregate of each particle, [`NONE`] for pinned ones.
    aggregate: Vec<u32>,
    /// Column of aggregates of each grid column.
    column_aggregate: Vec<u32>,
    /// Particles per grid row.
    fine_columns: usize,
    /// The levels, the first (2 × 2 particles) first; the ones in use this
    /// step are `levels[..used]`, the last solved exactly.
    levels: Vec<Level>,
    /// Levels in use.
    used: usize,
    /// The coarsest level's factor.
    factor: Banded,
    /// Whether the coarsest level's unknowns go column by column (when it
    /// has more columns than rows: a narrower band).
    by_columns: bool,
    scratch: Scratch,
}

crate::simd::multiversion! {
    /// [`Coarse::build`] compiled for a SIMD level.
    fn build_at(this: &mut Coarse) -> bool = Coarse::build;
}

impl Coarse {
    /// Starts the hierarchy of a step for a grid of `columns` particles per
    /// row, with the scaled masses `mass_scale / w` (kg; `w` in 1/kg, 0
    /// pins). Returns `false`, and the correction stays off, unless the
    /// particles form a grid of at least 4×4.
    pub(super) fn begin(
        &mut self,
        columns: usize,
        inverse_masses: &[f32],
        mass_scale: f32,
    ) -> bool {
        let n = inverse_masses.len();
        if columns < 4 || !n.is_multiple_of(columns) || n / columns < 4 {
            return false;
        }
        let rows = n / columns;
        self.fine_columns = columns;
        if self.levels.is_empty() {
            self.levels.push(Level::default());
        }
        let first = &mut self.levels[0];
        first.reset(columns.div_ceil(SIDE), rows.div_ceil(SIDE));
        let up = first.columns;
        // By rows, with the aggregate column of each grid column looked up:
        // a division per particle took ~20 µs a step on a 64×64 cloth.
        self.column_aggregate.clear();
        self.column_aggregate
            .extend((0..columns).map(|i| (i / SIDE) as u32));
        self.aggregate.clear();
        for (j, row) in inverse_masses.chunks_exact(columns).enumerate() {
            let start = ((j / SIDE) * up) as u32;
            let aggregates = row.iter().zip(&self.column_aggregate);
            self.aggregate.extend(aggregates.map(
                |(&w, &i)| {
                    if w == 0.0 { NONE } else { start + i }
                },
            ));
        }
        for (&agg, &w) in self.aggregate.iter().zip(inverse_masses) {
            if agg != NONE {
                let a = agg as usize;
                first.diag[a] += Mat3A::from_diagonal(Vec3::splat(mass_scale / w));
                first.filled[a] = true;
            }
        }
        for row in &mut self.scratch.rows {
            row.resize(columns, 0.0);
        }
        true
    }

    /// Whether a pair `(a, b)` adds to `A₁`: its particles lie in different
    /// aggregates (or one is pinned).
    #[inline]
    pub(super) fn joins(&self, a: usize, b: usize) -> bool {
        self.aggregate[a] != self.aggregate[b]
    }

    /// Adds the symmetric block `c` to particle `a`'s diagonal (a contact
    /// the solve holds): to its aggregate's, unless it is pinned.
    pub(super) fn add_diagonal(&mut self, a: usize, c: &[f32; 6]) {
        if let Some(&i) = self.aggregate.get(a)
            && i != NONE
        {
            self.levels[0].diag[i as usize] += Mat3A::from(sym_matrix(c));
        }
    }

    /// Adds the block `C` (xx, yy, zz, xy, xz, yz) of the pair `(a, b)`.
    pub(super) fn add_pair(&mut self, a: usize, b: usize, c: &[f32; 6]) {
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
        let (i, j) = (i as usize, j as usize);
        first.diag[i] += c;
        first.diag[j] += c;
        // Between aggregates that are not neighbours the coupling is
        // dropped: `C` stays on both diagonals.
        first.add_link(i, j, c);
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
            if self.joins(p, q)
                && let Some((t, s, u)) = block()
            {
                self.add_pair(p, q, &sym_of(t, s, u));
            }
        });
    }

    /// Forms the levels above the first and factors the coarsest; `false`
    /// if a level's operator is not positive definite.
    pub(super) fn finish(&mut self) -> bool {
        build_at(crate::simd::level(), self)
    }

    /// The body of [`Coarse::finish`].
    #[inline(always)]
    fn build(&mut self) -> bool {
        let mut used = 1;
        while self.levels[used - 1].count() > COARSEST {
            if self.levels.len() == used {
                self.levels.push(Level::default());
            }
            let (below, above) = self.levels.split_at_mut(used);
            above[0].coarsen(&below[used - 1]);
            used += 1;
        }
        self.used = used;
        if !self.levels[..used - 1].iter_mut().all(Level::invert) {
            return false;
        }
        let work = &mut self.scratch.work;
        work.resize_with(used, LevelWork::default);
        for (w, level) in work.iter_mut().zip(&self.levels) {
            for v in [&mut w.r, &mut w.e, &mut w.t] {
                v.clear();
                v.resize(level.count(), Vec3A::ZERO);
            }
        }
        for v in &mut self.scratch.top {
            v.clear();
            v.resize(self.levels[0].count(), Vec3A::ZERO);
        }
        self.factor_coarsest()
    }

    /// Writes the coarsest level's operator into the banded factor, its
    /// nodes row by row or column by column, whichever gives the narrower
    /// band, and factors it.
    fn factor_coarsest(&mut self) -> bool {
        let level = &self.levels[self.used - 1];
        let (columns, rows) = (level.columns, level.rows);
        self.by_columns = columns > rows;
        let index = order(self.by_columns, columns, rows);
        let size = 3 * level.count();
        self.factor.reset(size, 3 * (columns.min(rows) + 1) + 2);
        for a in 0..level.count() {
            let ia = index(a);
            // An aggregate of pinned particles only is decoupled: identity.
            let d = if level.filled[a] {
                level.diag[a]
            } else {
                Mat3A::IDENTITY
            };
            for p in 0..3 {
                for q in 0..=p {
                    self.factor.put(3 * ia + p, 3 * ia + q, d.col(q)[p] as f64);
                }
            }
            for (slot, &(across, down)) in SLOTS.iter().enumerate() {
                let c = level.off[a][slot];
                let (column, row) = ((a % columns) as isize + across, a / columns + down as usize);
                if c == Mat3A::ZERO || column < 0 || column as usize >= columns || row >= rows {
                    continue;
                }
                let ib = index(row * columns + column as usize);
                let (hi, lo) = (ia.max(ib), ia.min(ib));
                for p in 0..3 {
                    for q in 0..3 {
                        // −C is symmetric: A[hi][lo] = −C.
                        self.factor.put(3 * hi + p, 3 * lo + q, -c.col(q)[p] as f64);
                    }
                }
            }
        }
        let z = &mut self.scratch.work[self.used - 1].z;
        z.clear();
        z.resize(size, 0.0);
        self.factor.factor()
    }

    /// The first-level aggregate of free particle `p` (for tests).
    #[cfg(test)]
    pub(super) fn aggregate_of(&self, p: usize) -> usize {
        self.aggregate[p] as usize
    }

    /// The levels in use (for tests).
    #[cfg(test)]
    fn levels(&self) -> &[Level] {
        &self.levels[..self.used]
    }

    /// `y += R₁ V₁(R₁ᵀ r)` (r in N·s, zero at pins as the filter leaves
    /// it; y in m/s), leaving the particles whose `free` is 0 (pins) alone.
    #[inline(always)]
    pub(super) fn add(&mut self, r: &Soa, y: &mut Soa, free: &[f32]) {
        let mut s = self.take_scratch();
        let n = free.len();
        let (r, mut y) = (r.0.each_ref(), y.0.each_mut());
        let per_band = self.levels[0].columns;
        let [top, correction] = &mut s.top;
        for (j, rc) in top.chunks_mut(per_band).enumerate() {
            let r = r.map(|c| &c[self.band_rows(j, n)]);
            self.restrict_band(r, rc, &mut s.rows[0]);
        }
        self.cycle(top, correction, &mut s.work);
        for (j, e) in correction.chunks(per_band).enumerate() {
            let rows = self.band_rows(j, n);
            let y = y.each_mut().map(|c| &mut c[rows.clone()]);
            self.prolong_band(e, y, &free[rows.clone()], &mut s.rows[0]);
        }
        self.put_scratch(s);
    }

    /// Bands of aggregates (rows of the first level).
    pub(super) fn bands(&self) -> usize {
        self.levels[0].rows
    }

    /// Aggregates per band.
    pub(super) fn per_band(&self) -> usize {
        self.levels[0].columns
    }

    /// The scratch of a preconditioner application, lent out (for a
    /// correction split between two threads); see [`Coarse::put_scratch`].
    pub(super) fn take_scratch(&mut self) -> Scratch {
        std::mem::take(&mut self.scratch)
    }

    /// Takes back what [`Coarse::take_scratch`] lent.
    pub(super) fn put_scratch(&mut self, scratch: Scratch) {
        self.scratch = scratch;
    }

    /// `R₁ᵀ r` of one band of aggregates into its entries `rc` of the
    /// first level's right-hand side (N·s): the columns of the band's rows
    /// summed, then their pairs, one aggregate each. `r` holds the band's
    /// particles; `sums` is a row of scratch.
    #[inline(always)]
    pub(super) fn restrict_band(&self, r: [&[f32]; 3], rc: &mut [Vec3A], sums: &mut [f32]) {
        let cols = self.fine_columns;
        for (k, band) in r.into_iter().enumerate() {
            // `begin` checked that the rows are whole.
            sums.copy_from_slice(&band[..cols]);
            for row in band[cols..].chunks_exact(cols) {
                for (s, &x) in sums.iter_mut().zip(row) {
                    *s += x;
                }
            }
            for (rc, run) in rc.iter_mut().zip(sums.chunks(SIDE)) {
                rc[k] = run.iter().sum::<f32>();
            }
        }
    }

    /// `y += R₁ e` over one band of aggregates, pins left alone: `e` holds
    /// the band's corrections (m/s), `y` and `free` the band's particles; a
    /// row of corrections is formed in `sums`, then added to each of the
    /// band's rows.
    #[inline(always)]
    pub(super) fn prolong_band(
        &self,
        e: &[Vec3A],
        y: [&mut [f32]; 3],
        free: &[f32],
        sums: &mut [f32],
    ) {
        let cols = self.fine_columns;
        for (k, band) in y.into_iter().enumerate() {
            for (run, e) in sums.chunks_mut(SIDE).zip(e) {
                run.fill(e[k]);
            }
            let rows = band.chunks_exact_mut(cols).zip(free.chunks_exact(cols));
            for (row, free) in rows {
                for ((yi, &f), &e) in row.iter_mut().zip(free).zip(sums.iter()) {
                    *yi += e * f;
                }
            }
        }
    }

    /// The particles of band `j` (`SIDE` whole grid rows), of `n` in all.
    pub(super) fn band_rows(&self, j: usize, n: usize) -> std::ops::Range<usize> {
        let length = self.fine_columns * SIDE;
        j * length..((j + 1) * length).min(n)
    }

    /// `e = V₁(r)`: the V-cycle from the first level (r in N·s, e in m/s).
    #[inline(always)]
    pub(super) fn cycle(&self, r: &[Vec3A], e: &mut [Vec3A], work: &mut [LevelWork]) {
        self.cycle_from(0, r, e, work);
    }

    /// The V-cycle from level `l` (`work[l..]` its vectors and those of the
    /// levels above).
    fn cycle_from(&self, l: usize, r: &[Vec3A], e: &mut [Vec3A], work: &mut [LevelWork]) {
        let level = &self.levels[l];
        if l + 1 == self.used {
            self.solve_coarsest(r, e, &mut work[l].z);
            return;
        }
        let (mine, above) = work[l..].split_at_mut(1);
        let t = &mut mine[0].t;
        e.fill(Vec3A::ZERO);
        level.jacobi(OMEGA, r, e);
        level.residual(r, e, t);
        let next = &mut above[0];
        let (mut rn, mut en) = (std::mem::take(&mut next.r), std::mem::take(&mut next.e));
        level.restrict(t, &mut rn);
        self.cycle_from(l + 1, &rn, &mut en, work);
        level.prolong(THETA, &en, e);
        (work[l + 1].r, work[l + 1].e) = (rn, en);
        let t = &mut work[l].t;
        level.residual(r, e, t);
        level.jacobi(OMEGA, t, e);
    }

    /// `e = A⁻¹ r` on the coarsest level, through `z` in the factor's
    /// order.
    fn solve_coarsest(&self, r: &[Vec3A], e: &mut [Vec3A], z: &mut [f64]) {
        let level = &self.levels[self.used - 1];
        let index = order(self.by_columns, level.columns, level.rows);
        for (a, r) in r.iter().enumerate() {
            let i = 3 * index(a);
            z[i..i + 3].copy_from_slice(&[r.x as f64, r.y as f64, r.z as f64]);
        }
        self.factor.forward(z, 0);
        self.factor.backward(z);
        for (a, e) in e.iter_mut().enumerate() {
            let i = 3 * index(a);
            *e = if level.filled[a] {
                Vec3A::new(z[i] as f32, z[i + 1] as f32, z[i + 2] as f32)
            } else {
                Vec3A::ZERO
            };
        }
    }
}

/// The factor's index of node `a` of a grid of `columns × rows` nodes:
/// row by row, or column by column if `by_columns`.
fn order(by_columns: bool, columns: usize, rows: usize) -> impl Fn(usize) -> usize {
    move |a| {
        if by_columns {
            (a % columns) * rows + a / columns
        } else {
            a
        }
    }
}
