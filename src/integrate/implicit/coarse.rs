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
//! their 8 neighbours and `A_c` is banded. It is factored by a banded
//! Cholesky in f64, sized so the aggregates form at most a
//! [`COARSE_SIDE`]² grid: the factorisation is a few tens of µs per step.

use bevy::math::{Mat3A, Vec3};

use super::operator::{Soa, rank_block, sym_matrix, sym_of};
use crate::model::jacobian::Block;
use crate::model::streams::StreamBlocks;

/// Aggregates per side of the coarse grid at most.
pub const COARSE_SIDE: usize = 8;

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
    /// Half-bandwidth of `A_c` in scalar rows.
    bandwidth: usize,
    /// The Cholesky factor `L`, row by row: `L[i][j]` at
    /// `i·(bandwidth + 1) + j + bandwidth − i` for `i − bandwidth ≤ j ≤ i`.
    band: Vec<f64>,
    /// `1 / L[i][i]` (1/√kg: `A_c = L Lᵀ` is in kg).
    inverse_diagonal: Vec<f64>,
    /// `L` below the diagonal column by column (√kg): `L[i + 1 + k][i]` at
    /// `i·bandwidth + k`, so that the forward solve reads it in order.
    columns_below: Vec<f64>,
    /// Coarse right-hand side, then solution.
    rc: Vec<f64>,
    /// A fine row's worth of column sums (restriction, N·s) or of
    /// corrections (prolongation, m/s).
    row: Vec<f32>,
    /// The same for a second thread ([`halves`](super::halves)).
    second_row: Vec<f32>,
    /// Whether a block coupled aggregates that are not neighbours.
    unusable: bool,
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
    /// aggregates: the blocks `C` formed by stream, then the Jacobian
    /// `blocks` as `C = αD + βK`, as the operator takes them.
    pub(super) fn add_pairs<'a>(
        &mut self,
        n: usize,
        (blocks, streamed): (&[Block], impl Iterator<Item = StreamBlocks<'a>>),
        (alpha, beta): (f32, f32),
    ) {
        for src in streamed {
            // Slots past the last particle hold no link.
            let m = src.t.len().min(n.saturating_sub(src.lo + src.delta));
            // Most pairs lie inside one aggregate, where they cancel.
            for i in 0..m {
                let (p, q) = (src.lo + i, src.lo + i + src.delta);
                if self.joins(p, q) && (src.t[i] != 0.0 || src.s[i] != 0.0) {
                    let c = sym_of(src.t[i], src.s[i], src.u.map(|u| u[i]));
                    self.add_pair(p, q, &c);
                }
            }
        }
        for blk in blocks {
            if let Some((t, s, u)) = rank_block(blk, alpha, beta) {
                let (p, q) = (blk.a.min(blk.b) as usize, blk.a.max(blk.b) as usize);
                self.add_pair(p, q, &sym_of(t, s, u));
            }
        }
    }

    /// Factors `A_c`; `false` if a block coupled aggregates that are not
    /// neighbours or a pivot was not positive.
    pub(super) fn finish(&mut self) -> bool {
        if self.unusable {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, as checked on the line above.
            return unsafe { self.factor_avx512() };
        } else if std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has AVX2 and FMA, as checked just above.
            return unsafe { self.factor_avx2() };
        }
        self.factor()
    }

    /// [`Coarse::factor`] compiled for AVX-512.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn factor_avx512(&mut self) -> bool {
        self.factor()
    }

    /// [`Coarse::factor`] compiled for AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn factor_avx2(&mut self) -> bool {
        self.factor()
    }

    /// Writes `A_c` into the band and factors it in place; `false` on a
    /// pivot that is not positive.
    #[inline(always)]
    fn factor(&mut self) -> bool {
        let columns = self.columns;
        let bw = 3 * (columns + 1) + 2;
        let width = bw + 1;
        let size = 3 * self.count;
        self.bandwidth = bw;
        self.band.clear();
        self.band.resize(size * width, 0.0);
        let band = &mut self.band;
        // A[r][c] for r ≥ c.
        let mut put = |r: usize, c: usize, value: f32| band[r * width + c + bw - r] = value as f64;
        let deltas = [1, columns - 1, columns, columns + 1];
        for (i, (d, off)) in self.diag.iter().zip(&self.off).enumerate() {
            for p in 0..3 {
                for q in 0..=p {
                    put(3 * i + p, 3 * i + q, d.col(q)[p]);
                }
            }
            for (c, &delta) in off.iter().zip(&deltas) {
                let j = i + delta;
                if j >= self.count || *c == Mat3A::ZERO {
                    continue;
                }
                // A_c[j][i] = −Cᵀ.
                for p in 0..3 {
                    for q in 0..3 {
                        put(3 * j + p, 3 * i + q, -c.col(p)[q]);
                    }
                }
            }
        }
        // Right-looking: column k of L, then its outer product off the
        // rows below, each row's update one contiguous run (no chain of
        // dependent sums, so it runs as SIMD).
        let column = &mut self.rc;
        column.clear();
        column.resize(bw, 0.0);
        for k in 0..size {
            let pivot = band[k * width + bw];
            if pivot.is_nan() || pivot <= 0.0 {
                return false;
            }
            let pivot = pivot.sqrt();
            band[k * width + bw] = pivot;
            let below = (size - 1 - k).min(bw);
            for (m, c) in column[..below].iter_mut().enumerate() {
                let i = k + 1 + m;
                let at = i * width + k + bw - i;
                band[at] /= pivot;
                *c = band[at];
            }
            for m in 0..below {
                let i = k + 1 + m;
                let lik = column[m];
                // A[i][k+1..=i] −= L[i][k]·L[k+1..=i][k].
                let row = &mut band[i * width + k + 1 + bw - i..i * width + bw + 1];
                for (a, &l) in row.iter_mut().zip(&column[..=m]) {
                    *a -= lik * l;
                }
            }
        }
        self.inverse_diagonal.clear();
        self.inverse_diagonal
            .extend((0..size).map(|i| 1.0 / band[i * width + bw]));
        self.columns_below.clear();
        self.columns_below.resize(size * bw, 0.0);
        for i in 0..size {
            for (k, r) in (i + 1..size.min(i + 1 + bw)).enumerate() {
                self.columns_below[i * bw + k] = band[r * width + i + bw - r];
            }
        }
        self.rc.clear();
        self.rc.resize(size, 0.0);
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
        for (j, rc) in rc.chunks_mut(3 * self.columns).enumerate() {
            let r = r.map(|c| &c[self.band_rows(j, n)]);
            self.restrict_band(r, rc, &mut sums);
        }
        self.solve(&mut rc);
        for (j, rc) in rc.chunks(3 * self.columns).enumerate() {
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

    /// `rc = A_c⁻¹ rc` (N·s in, m/s out) by the Cholesky factor.
    ///
    /// Both substitutions go an aggregate (three rows) at a time: its
    /// three unknowns in scalars, then their columns off the rows beyond
    /// as vector loops. Row by row, each row's scalar load followed the
    /// vector store that had just updated it, a store-forwarding stall
    /// per row: 3.3 µs a solve on a 64×64 cloth, one of the solver's few
    /// passes that cannot be split between threads.
    #[inline(always)]
    pub(super) fn solve(&self, rc: &mut [f64]) {
        let (bw, band, inverse) = (self.bandwidth, &self.band, &self.inverse_diagonal);
        let below = &self.columns_below;
        let size = rc.len();
        debug_assert!(size.is_multiple_of(3) && bw >= 2);
        // L z = Rᵀ r. `below[i·bw + k]` is L[i + 1 + k][i].
        for i in (0..size).step_by(3) {
            let z0 = rc[i] * inverse[i];
            let z1 = (rc[i + 1] - below[i * bw] * z0) * inverse[i + 1];
            let z2 =
                (rc[i + 2] - below[i * bw + 1] * z0 - below[(i + 1) * bw] * z1) * inverse[i + 2];
            (rc[i], rc[i + 1], rc[i + 2]) = (z0, z1, z2);
            // Columns i, i + 1, i + 2 of L off rows i + 3 on: all three
            // reach row i + bw, the last two one and two rows further.
            let rows = (size - (i + 3)).min(bw - 2);
            let c0 = &below[i * bw + 2..i * bw + 2 + rows];
            let c1 = &below[(i + 1) * bw + 1..(i + 1) * bw + 1 + rows];
            let c2 = &below[(i + 2) * bw..(i + 2) * bw + rows];
            let target = &mut rc[i + 3..i + 3 + rows];
            for (r, ((&l0, &l1), &l2)) in target.iter_mut().zip(c0.iter().zip(c1).zip(c2)) {
                *r = *r - l0 * z0 - l1 * z1 - l2 * z2;
            }
            let row = i + 3 + rows;
            if row < size {
                rc[row] =
                    rc[row] - below[(i + 1) * bw + bw - 1] * z1 - below[(i + 2) * bw + bw - 2] * z2;
            }
            if row + 1 < size {
                rc[row + 1] -= below[(i + 2) * bw + bw - 1] * z2;
            }
        }
        // Lᵀ e = z. Row i of L holds L[i][j] at `band[i·width + j + bw − i]`.
        let width = bw + 1;
        let at = |i: usize, j: usize| band[i * width + j + bw - i];
        for i in (0..size).step_by(3).rev() {
            let e2 = rc[i + 2] * inverse[i + 2];
            let e1 = (rc[i + 1] - at(i + 2, i + 1) * e2) * inverse[i + 1];
            let e0 = (rc[i] - at(i + 2, i) * e2 - at(i + 1, i) * e1) * inverse[i];
            (rc[i], rc[i + 1], rc[i + 2]) = (e0, e1, e2);
            // Rows i + 2, i + 1, i of L off rows up to i − 1: all three
            // reach back to row i + 2 − bw, the last two one and two
            // rows further.
            let first = (i + 2).saturating_sub(bw);
            let rows = i - first;
            let r2 = &band[(i + 2) * width + first + bw - (i + 2)..][..rows];
            let r1 = &band[(i + 1) * width + first + bw - (i + 1)..][..rows];
            let r0 = &band[i * width + first + bw - i..][..rows];
            let target = &mut rc[first..i];
            for (z, ((&l2, &l1), &l0)) in target.iter_mut().zip(r2.iter().zip(r1).zip(r0)) {
                *z = *z - l2 * e2 - l1 * e1 - l0 * e0;
            }
            if first >= 1 {
                let j = first - 1;
                rc[j] = rc[j] - at(i + 1, j) * e1 - at(i, j) * e0;
            }
            if first >= 2 {
                let j = first - 2;
                rc[j] -= at(i, j) * e0;
            }
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
