//! The coarse-grid half of the implicit solver's preconditioner.
//!
//! Block-Jacobi alone leaves the smooth modes of a stiff cloth to the
//! conjugate gradient: on a 64×64 cotton cloth at 1/60 s, `h²k` outweighs a
//! particle's mass ~5000 times, the condition number is in the thousands
//! and the solve ran into its 100-iteration cap on most frames. Those
//! modes are what a coarse grid sees, so the preconditioner becomes the
//! two-level additive
//!
//! `P⁻¹ r = B⁻¹ r + R A_c⁻¹ Rᵀ r`,  `A_c = Rᵀ A R`,
//!
//! with `B` the 3×3 diagonal blocks of `A`, and `R` the piecewise-constant
//! prolongation from aggregates of `s × s` grid particles (pinned ones
//! excluded, as the filter excludes them from `A`). Both halves are
//! symmetric positive definite, so `P` is too, as the conjugate gradient
//! needs.
//!
//! `A_c` comes straight from the operator's pair blocks: a block `C` between
//! two aggregates `I ≠ J` adds `C` to `A_c[I][I]` and `A_c[J][J]` and `−C` to
//! `A_c[I][J]`; inside one aggregate it cancels; against a pinned particle
//! it adds `C` to the free side's diagonal; masses add up. A grid link
//! reaches at most 2 particles, so for `s ≥ 2` aggregates couple only to
//! their 8 neighbours and `A_c` is banded. It is factored in f64 by
//! banded Cholesky factors of the bands below and above a separator band
//! and a dense one of the separator's Schur complement (`factor.rs`), so
//! that the solve splits between two threads; sized so the aggregates
//! form at most a [`COARSE_SIDE`]² grid, the factorisation is a few tens of
//! µs per step.

use std::ops::Range;

use bevy::math::{Mat3A, Vec3};

use super::operator::{Soa, rank_block, sym_matrix, sym_of};
use crate::sim::model::jacobian::Block;
use crate::sim::model::streams::StreamBlocks;
use factor::{Banded, Dense, MAX_DENSE};

mod factor;

/// Aggregates per side of the coarse grid at most.
pub const COARSE_SIDE: usize = 8;

/// The parts of the coarse unknowns ([`factor`]).
const LOWER: usize = 0;
const UPPER: usize = 1;
const SEPARATOR: usize = 2;

/// Reverses the order of a vector's aggregates (runs of three), keeping
/// each one's three components in order.
fn reverse_aggregates(v: &mut [f64]) {
    let n = v.len() / 3;
    for i in 0..n / 2 {
        let j = n - 1 - i;
        for k in 0..3 {
            v.swap(3 * i + k, 3 * j + k);
        }
    }
}

/// Visits every pair `(p, q)`, `p < q`, of a step of `n` particles that
/// the operator takes, for a coarse operator to add: the blocks formed by
/// stream, then the Jacobian `blocks` as `C = αD + βK`. `visit` gets the
/// pair and a function that forms its block `C` (xx, yy, zz, xy, xz, yz;
/// `None` for a zero block), so that the pairs inside one aggregate, most
/// of them, where they cancel, cost no block.
pub(super) fn joining_pairs<'a>(
    n: usize,
    (blocks, streamed): (&[Block], impl Iterator<Item = StreamBlocks<'a>>),
    (alpha, beta): (f32, f32),
    mut visit: impl FnMut(usize, usize, &dyn Fn() -> Option<[f32; 6]>),
) {
    for src in streamed {
        // Slots past the last particle hold no link.
        let m = src.t.len().min(n.saturating_sub(src.lo + src.delta));
        for i in 0..m {
            let (p, q) = (src.lo + i, src.lo + i + src.delta);
            visit(p, q, &|| {
                (src.t[i] != 0.0 || src.s[i] != 0.0)
                    .then(|| sym_of(src.t[i], src.s[i], src.u.map(|u| u[i])))
            });
        }
    }
    for blk in blocks {
        let (p, q) = (blk.a.min(blk.b) as usize, blk.a.max(blk.b) as usize);
        visit(p, q, &|| {
            rank_block(blk, alpha, beta).map(|(t, s, u)| sym_of(t, s, u))
        });
    }
}

/// Marks a pinned particle, which belongs to no aggregate.
const NONE: u32 = u32::MAX;

/// The coarse operator of one step, factored, and its scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct Coarse {
    /// Aggregate of each particle, [`NONE`] for pinned ones.
    aggregate: Vec<u32>,
    /// Column of aggregates of each grid column.
    column_aggregate: Vec<u32>,
    /// Particles per grid row.
    fine_columns: usize,
    /// Particles per aggregate side.
    side: usize,
    /// Aggregates per coarse row.
    columns: usize,
    /// Number of aggregates.
    count: usize,
    /// Diagonal blocks of `A_c` (N/m·s² like `A`, i.e. kg).
    diag: Vec<Mat3A>,
    /// Sums of the blocks `C` from each aggregate to its neighbours at
    /// coarse offsets (1,0), (−1,1), (0,1), (1,1); `A_c[I][J] = −C`.
    off: Vec<[Mat3A; 4]>,
    /// The factor `L_L` of the bands below the separator band
    /// ([`factor`]'s layout).
    lower: Banded,
    /// The factor `L_U` of the bands above it, in reverse.
    upper: Banded,
    /// The separator's Schur complement, factored (`L_S`).
    separator: Dense,
    /// `X_L` and `X_U` (√kg): of each side, the rows of its band next to
    /// the separator by the separator's columns, row-major.
    cross: [Vec<f64>; 2],
    /// A column of `X`, while it is formed.
    column: Vec<f64>,
    /// Coarse right-hand side, then solution, and after them the
    /// separator's share of the lower bands' forward substitution
    /// (`X_Lᵀ z_L`).
    rc: Vec<f64>,
    /// A fine row's worth of column sums (restriction, N·s) or of
    /// corrections (prolongation, m/s).
    row: Vec<f32>,
    /// The same for a second thread ([`halves`](super::halves)).
    second_row: Vec<f32>,
    /// Whether a block coupled aggregates that are not neighbours.
    unusable: bool,
}

crate::simd::multiversion! {
    /// [`Coarse::factor`] compiled for a SIMD level.
    fn factor_at(this: &mut Coarse) -> bool = Coarse::factor;
}

impl Coarse {
    /// Starts the coarse operator of a step for a grid of `columns`
    /// particles per row, with the scaled masses `mass_scale / w` (kg;
    /// `w` in 1/kg, 0 pins). Returns `false`, and the correction stays off,
    /// unless the particles form a grid of at least 4×4.
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
        let side = columns.max(rows).div_ceil(COARSE_SIDE).max(4);
        self.columns = columns.div_ceil(side);
        self.count = self.columns * rows.div_ceil(side);
        self.fine_columns = columns;
        self.side = side;
        self.unusable = false;
        // By rows, with the aggregate column of each grid column looked up:
        // a division per particle took ~20 µs a step on a 64×64 cloth.
        self.column_aggregate.clear();
        self.column_aggregate
            .extend((0..columns).map(|i| (i / side) as u32));
        self.aggregate.clear();
        for (j, row) in inverse_masses.chunks_exact(columns).enumerate() {
            let first = ((j / side) * self.columns) as u32;
            let aggregates = row.iter().zip(&self.column_aggregate);
            self.aggregate.extend(aggregates.map(
                |(&w, &i)| {
                    if w == 0.0 { NONE } else { first + i }
                },
            ));
        }
        // The aggregates' masses, summed in `rc` (no allocation per step).
        let masses = &mut self.rc;
        masses.clear();
        masses.resize(self.count, 0.0);
        for (&agg, &w) in self.aggregate.iter().zip(inverse_masses) {
            if agg != NONE {
                masses[agg as usize] += (mass_scale / w) as f64;
            }
        }
        self.diag.clear();
        // An aggregate of pinned particles only is decoupled: identity.
        self.diag.extend(
            masses
                .iter()
                .map(|&m| Mat3A::from_diagonal(Vec3::splat(if m > 0.0 { m as f32 } else { 1.0 }))),
        );
        self.off.clear();
        self.off.resize(self.count, [Mat3A::ZERO; 4]);
        self.row.resize(columns, 0.0);
        self.second_row.resize(columns, 0.0);
        true
    }

    /// Whether a pair `(a, b)` adds to `A_c`: its particles lie in different
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
            self.diag[i as usize] += Mat3A::from(sym_matrix(c));
        }
    }

    /// Adds the block `C` (xx, yy, zz, xy, xz, yz) of the pair `(a, b)`.
    pub(super) fn add_pair(&mut self, a: usize, b: usize, c: &[f32; 6]) {
        let (i, j) = (self.aggregate[a], self.aggregate[b]);
        if i == j {
            return;
        }
        let c = Mat3A::from(sym_matrix(c));
        if i == NONE || j == NONE {
            self.diag[i.min(j) as usize] += c;
            return;
        }
        let columns = self.columns as i64;
        let (lo, hi) = (i.min(j) as i64, i.max(j) as i64);
        let slot = match (hi % columns - lo % columns, hi / columns - lo / columns) {
            (1, 0) => 0,
            (-1, 1) => 1,
            (0, 1) => 2,
            (1, 1) => 3,
            _ => {
                self.unusable = true;
                return;
            }
        };
        self.diag[lo as usize] += c;
        self.diag[hi as usize] += c;
        self.off[lo as usize][slot] += c;
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
                && let Some(c) = block()
            {
                self.add_pair(p, q, &c);
            }
        });
    }

    /// Factors `A_c`; `false` if a block coupled aggregates that are not
    /// neighbours or a pivot was not positive.
    pub(super) fn finish(&mut self) -> bool {
        if self.unusable {
            return false;
        }
        factor_at(crate::simd::level(), self)
    }

    /// Where the unknowns of aggregate `a` go: the bands below the
    /// separator band in order, the separator band, the bands above it in
    /// reverse; as (part, index of the aggregate within it).
    fn place(&self, a: usize) -> (usize, usize) {
        let (band, separator) = (a / self.columns, self.separator_band());
        match band.cmp(&separator) {
            std::cmp::Ordering::Less => (LOWER, a),
            std::cmp::Ordering::Equal => (SEPARATOR, a - separator * self.columns),
            std::cmp::Ordering::Greater => (UPPER, self.count - 1 - a),
        }
    }

    /// The band of aggregates that separates the lower bands from the
    /// upper (the first band of the upper half of a split solve).
    pub(super) fn separator_band(&self) -> usize {
        self.bands() / 2
    }

    /// Unknowns below the separator, in it, and in all (`3 × count`).
    fn sizes(&self) -> (usize, usize, usize) {
        let band = 3 * self.columns;
        (band * self.separator_band(), band, 3 * self.count)
    }

    /// Writes `A_c` into the factors' matrices ([`factor`]) and factors
    /// them; `false` on a pivot that is not positive.
    #[inline(always)]
    fn factor(&mut self) -> bool {
        let columns = self.columns;
        let (below, band, size) = self.sizes();
        let above = size - below - band;
        self.lower.reset(below, 3 * (columns + 1) + 2);
        self.upper.reset(above, 3 * (columns + 1) + 2);
        self.separator.reset(band);
        // `A_·S`, of the rows of each side's band next to the separator.
        for cross in &mut self.cross {
            cross.clear();
            cross.resize(band * band, 0.0);
        }
        // A_c[a][b] = v(p, q) for the blocks of aggregates a ≥ b.
        let deltas = [1, columns - 1, columns, columns + 1];
        for a in 0..self.count {
            let d = self.diag[a];
            let (part, i) = self.place(a);
            for p in 0..3 {
                for q in 0..=p {
                    let (r, c, value) = (3 * i + p, 3 * i + q, d.col(q)[p] as f64);
                    match part {
                        LOWER => self.lower.put(r, c, value),
                        UPPER => self.upper.put(r, c, value),
                        _ => self.separator.add(r, c, value),
                    }
                }
            }
            for (c, &delta) in self.off[a].iter().zip(&deltas) {
                let b = a + delta;
                if b >= self.count || *c == Mat3A::ZERO {
                    continue;
                }
                // A_c[b][a] = −Cᵀ.
                let v = |p: usize, q: usize| -c.col(p)[q] as f64;
                let (low, high) = (self.place(a), self.place(b));
                for p in 0..3 {
                    for q in 0..3 {
                        match (low, high) {
                            ((LOWER, i), (LOWER, j)) => {
                                self.lower.put(3 * j + p, 3 * i + q, v(p, q));
                            }
                            // Reversed: b comes before a.
                            ((UPPER, i), (UPPER, j)) => {
                                self.upper.put(3 * i + q, 3 * j + p, v(p, q));
                            }
                            ((SEPARATOR, i), (SEPARATOR, j)) => {
                                self.separator.add(3 * j + p, 3 * i + q, v(p, q));
                            }
                            ((LOWER, i), (SEPARATOR, j)) => {
                                let row = 3 * i + q - (below - band);
                                self.cross[0][row * band + 3 * j + p] = v(p, q);
                            }
                            ((SEPARATOR, i), (UPPER, j)) => {
                                let row = 3 * j + p - (above - band);
                                self.cross[1][row * band + 3 * i + q] = v(p, q);
                            }
                            _ => return false, // the grid couples only neighbours
                        }
                    }
                }
            }
        }
        if !(self.lower.factor() && self.upper.factor()) {
            return false;
        }
        // X = L⁻¹ A_·S a column at a time: A_·S is 0 above the band next
        // to the separator, and so is X. Then the Schur complement.
        for (factor, cross) in [&self.lower, &self.upper].into_iter().zip(&mut self.cross) {
            let n = factor.size();
            if n == 0 {
                cross.fill(0.0);
                continue;
            }
            for k in 0..band {
                self.column.clear();
                self.column.resize(n, 0.0);
                for m in 0..band {
                    self.column[n - band + m] = cross[m * band + k];
                }
                factor.forward(&mut self.column, n - band);
                for m in 0..band {
                    cross[m * band + k] = self.column[n - band + m];
                }
            }
            for r in 0..band {
                for c in 0..=r {
                    let mut s = 0.0;
                    for m in 0..band {
                        s += cross[m * band + r] * cross[m * band + c];
                    }
                    self.separator.add(r, c, -s);
                }
            }
        }
        if !self.separator.factor() {
            return false;
        }
        self.rc.clear();
        self.rc.resize(size + band, 0.0);
        true
    }

    /// The aggregate of free particle `p` (for tests).
    #[cfg(test)]
    pub(super) fn aggregate_of(&self, p: usize) -> usize {
        self.aggregate[p] as usize
    }

    /// `y += R A_c⁻¹ Rᵀ r` (r in N·s, zero at pins as the filter leaves it;
    /// y in m/s), leaving the particles whose `free` is 0 (pins) alone.
    #[inline(always)]
    pub(super) fn add(&mut self, r: &Soa, y: &mut Soa, free: &[f32]) {
        let mut rc = std::mem::take(&mut self.rc);
        let mut sums = std::mem::take(&mut self.row);
        let n = free.len();
        let (r, mut y) = (r.0.each_ref(), y.0.each_mut());
        let size = 3 * self.count;
        for (j, rc) in rc[..size].chunks_mut(3 * self.columns).enumerate() {
            let r = r.map(|c| &c[self.band_rows(j, n)]);
            self.restrict_band(r, rc, &mut sums);
        }
        self.solve(&mut rc);
        for (j, rc) in rc[..size].chunks(3 * self.columns).enumerate() {
            let rows = self.band_rows(j, n);
            let y = y.each_mut().map(|c| &mut c[rows.clone()]);
            self.prolong_band(rc, y, &free[rows.clone()], &mut sums);
        }
        self.rc = rc;
        self.row = sums;
    }

    /// Bands of aggregates.
    pub(super) fn bands(&self) -> usize {
        self.count / self.columns
    }

    /// The coarse right-hand side, lent out with a scratch row for each of
    /// two threads (for a correction split between them); see
    /// [`Coarse::put_scratch`].
    pub(super) fn take_scratch(&mut self) -> (Vec<f64>, [Vec<f32>; 2]) {
        let rows = [&mut self.row, &mut self.second_row].map(std::mem::take);
        (std::mem::take(&mut self.rc), rows)
    }

    /// Takes back what [`Coarse::take_scratch`] lent.
    pub(super) fn put_scratch(&mut self, (rc, [row, second]): (Vec<f64>, [Vec<f32>; 2])) {
        (self.rc, self.row, self.second_row) = (rc, row, second);
    }

    /// `Rᵀ r` of one band of aggregates into its `3 × columns` entries of
    /// the coarse right-hand side `rc` (N·s): the columns of the band's
    /// `side` rows summed, then their runs of `side`, one aggregate each.
    /// `r` holds the band's particles; `sums` is a row of scratch.
    #[inline(always)]
    pub(super) fn restrict_band(&self, r: [&[f32]; 3], rc: &mut [f64], sums: &mut [f32]) {
        let (cols, side) = (self.fine_columns, self.side);
        for (k, band) in r.into_iter().enumerate() {
            // `begin` checked that the rows are whole.
            sums.copy_from_slice(&band[..cols]);
            for row in band[cols..].chunks_exact(cols) {
                for (s, &x) in sums.iter_mut().zip(row) {
                    *s += x;
                }
            }
            for (i, run) in sums.chunks(side).enumerate() {
                rc[3 * i + k] = run.iter().sum::<f32>() as f64;
            }
        }
    }

    /// `rc = A_c⁻¹ rc` (N·s in, m/s out; `rc` in its
    /// [`Coarse::pieces`]), the passes of both threads of a split solve in turn.
    #[inline(always)]
    pub(super) fn solve(&self, rc: &mut [f64]) {
        let [lower, separator, upper, tail] = self.split(rc);
        self.forward_lower(lower, tail);
        self.forward_upper(upper, separator);
        self.solve_separator(separator, tail);
        self.backward_lower(lower, separator);
        self.backward_upper(upper, separator);
    }

    /// Where the coarse right-hand side (see [`Coarse::take_scratch`])
    /// holds its lower bands, separator band, upper bands and the scratch
    /// after them.
    pub(super) fn pieces(&self) -> [Range<usize>; 4] {
        let (below, band, size) = self.sizes();
        [
            0..below,
            below..below + band,
            below + band..size,
            size..size + band,
        ]
    }

    /// `rc` cut into its [`Coarse::pieces`].
    fn split<'a>(&self, rc: &'a mut [f64]) -> [&'a mut [f64]; 4] {
        let [lower, separator, upper, _] = self.pieces();
        let (lower, rest) = rc.split_at_mut(lower.end);
        let (separator, rest) = rest.split_at_mut(separator.len());
        let (upper, tail) = rest.split_at_mut(upper.len());
        [lower, separator, upper, tail]
    }

    /// `z_L = L_L⁻¹ r_L`, and `X_Lᵀ z_L` into `tail` (thread 0 of a split
    /// solve).
    #[inline(always)]
    pub(super) fn forward_lower(&self, lower: &mut [f64], tail: &mut [f64]) {
        self.lower.forward(lower, 0);
        self.cross_times(0, lower, tail);
    }

    /// `z_U = L_U⁻¹ r_U` (the bands reversed in place), then `r_S −= X_Uᵀ
    /// z_U` (thread 1).
    #[inline(always)]
    pub(super) fn forward_upper(&self, upper: &mut [f64], separator: &mut [f64]) {
        reverse_aggregates(upper);
        self.upper.forward(upper, 0);
        let mut t = [0.0; MAX_DENSE];
        let t = &mut t[..separator.len()];
        self.cross_times(1, upper, t);
        for (s, t) in separator.iter_mut().zip(t) {
            *s -= *t;
        }
    }

    /// `e_S = L_S⁻ᵀ L_S⁻¹ (r_S − X_Uᵀ z_U − X_Lᵀ z_L)`, the last term from
    /// `tail` (thread 1, between two barriers).
    #[inline(always)]
    pub(super) fn solve_separator(&self, separator: &mut [f64], tail: &[f64]) {
        for (s, t) in separator.iter_mut().zip(tail) {
            *s -= t;
        }
        self.separator.solve(separator);
    }

    /// `e_L = L_L⁻ᵀ (z_L − X_L e_S)` (thread 0).
    #[inline(always)]
    pub(super) fn backward_lower(&self, lower: &mut [f64], separator: &[f64]) {
        self.cross_back(0, lower, separator);
        self.lower.backward(lower);
    }

    /// `e_U = L_U⁻ᵀ (z_U − X_U e_S)`, the bands put back in order (thread 1).
    #[inline(always)]
    pub(super) fn backward_upper(&self, upper: &mut [f64], separator: &[f64]) {
        self.cross_back(1, upper, separator);
        self.upper.backward(upper);
        reverse_aggregates(upper);
    }

    /// `out = Xᵀ z` of side `k` (`z`'s last band of rows against `X`).
    #[inline(always)]
    fn cross_times(&self, k: usize, z: &[f64], out: &mut [f64]) {
        let band = out.len();
        out.fill(0.0);
        if z.is_empty() {
            return;
        }
        let rows = &z[z.len() - band..];
        for (row, &zm) in self.cross[k].chunks_exact(band).zip(rows) {
            for (o, &x) in out.iter_mut().zip(row) {
                *o += x * zm;
            }
        }
    }

    /// `z −= X e_S` of side `k` (on `z`'s last band of rows).
    #[inline(always)]
    fn cross_back(&self, k: usize, z: &mut [f64], separator: &[f64]) {
        let band = separator.len();
        if z.is_empty() {
            return;
        }
        let rows = z.len() - band..;
        for (row, zm) in self.cross[k].chunks_exact(band).zip(&mut z[rows]) {
            let s: f64 = row.iter().zip(separator).map(|(x, e)| x * e).sum();
            *zm -= s;
        }
    }
    /// `y += R e` over one band of aggregates, pins left alone: `rc` holds
    /// the band's `3 × columns` entries of `e` (m/s), `y` and `free` the
    /// band's particles; a row of corrections is formed in `sums`, then
    /// added to each of the band's rows.
    #[inline(always)]
    pub(super) fn prolong_band(
        &self,
        rc: &[f64],
        y: [&mut [f32]; 3],
        free: &[f32],
        sums: &mut [f32],
    ) {
        let (cols, side) = (self.fine_columns, self.side);
        for (k, band) in y.into_iter().enumerate() {
            for (i, run) in sums.chunks_mut(side).enumerate() {
                run.fill(rc[3 * i + k] as f32);
            }
            let rows = band.chunks_exact_mut(cols).zip(free.chunks_exact(cols));
            for (row, free) in rows {
                for ((yi, &f), &e) in row.iter_mut().zip(free).zip(sums.iter()) {
                    *yi += e * f;
                }
            }
        }
    }

    /// The particles of band `j` (`side` whole grid rows), of `n` in all.
    pub(super) fn band_rows(&self, j: usize, n: usize) -> std::ops::Range<usize> {
        let length = self.fine_columns * self.side;
        j * length..((j + 1) * length).min(n)
    }
}
