//! The banded Cholesky factor that solves the coarsest level of the
//! multigrid hierarchy exactly, in f64.

/// A banded Cholesky factor `L` (`A = L Lᵀ`) in f64 of a matrix with a
/// multiple of 3 rows and a half-bandwidth of at least 2 (scalar rows).
#[derive(Clone, Debug, Default)]
pub(super) struct Banded {
    size: usize,
    /// Half-bandwidth in scalar rows.
    bandwidth: usize,
    /// `A`, then `L`, row by row: `L[i][j]` at
    /// `i·(bandwidth + 1) + j + bandwidth − i` for `i − bandwidth ≤ j ≤ i`.
    band: Vec<f64>,
    /// `1 / L[i][i]` (1/√kg: `A = L Lᵀ` is in kg).
    inverse_diagonal: Vec<f64>,
    /// `L` below the diagonal column by column (√kg): `L[i + 1 + k][i]` at
    /// `i·bandwidth + k`, so that the forward solve reads it in order.
    columns_below: Vec<f64>,
    /// A column of `L`, while factoring.
    column: Vec<f64>,
}

impl Banded {
    /// Starts a zero matrix of `size` rows and half-bandwidth `bandwidth`.
    pub(super) fn reset(&mut self, size: usize, bandwidth: usize) {
        debug_assert!(size.is_multiple_of(3) && bandwidth >= 2);
        (self.size, self.bandwidth) = (size, bandwidth);
        self.band.clear();
        self.band.resize(size * (bandwidth + 1), 0.0);
    }

    /// Sets `A[r][c]` for `r ≥ c`, `r − c ≤ bandwidth`.
    #[inline(always)]
    pub(super) fn put(&mut self, r: usize, c: usize, value: f64) {
        let bw = self.bandwidth;
        self.band[r * (bw + 1) + c + bw - r] = value;
    }

    /// Factors the matrix in place; `false` on a pivot that is not positive.
    ///
    /// Right-looking: column k of L, then its outer product off the rows
    /// below, each row's update one contiguous run (no chain of dependent
    /// sums, so it runs as SIMD).
    #[inline(always)]
    pub(super) fn factor(&mut self) -> bool {
        let (size, bw) = (self.size, self.bandwidth);
        let width = bw + 1;
        let band = &mut self.band;
        let column = &mut self.column;
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
        true
    }

    /// `z = L⁻¹ z`, for a `z` whose entries before `start` (a multiple of
    /// 3) are 0, as they stay.
    ///
    /// Both substitutions go an aggregate (three rows) at a time: its
    /// three unknowns in scalars, then their columns off the rows beyond
    /// as vector loops. Row by row, each row's scalar load followed the
    /// vector store that had just updated it, a store-forwarding stall
    /// per row.
    #[inline(always)]
    pub(super) fn forward(&self, rc: &mut [f64], start: usize) {
        let (bw, inverse, below) = (self.bandwidth, &self.inverse_diagonal, &self.columns_below);
        let size = self.size;
        debug_assert_eq!(rc.len(), size);
        // `below[i·bw + k]` is L[i + 1 + k][i].
        for i in (start..size).step_by(3) {
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
    }

    /// `e = L⁻ᵀ e`.
    #[inline(always)]
    pub(super) fn backward(&self, rc: &mut [f64]) {
        let (bw, band, inverse) = (self.bandwidth, &self.band, &self.inverse_diagonal);
        let size = self.size;
        debug_assert_eq!(rc.len(), size);
        // Row i of L holds L[i][j] at `band[i·width + j + bw − i]`.
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
}
