//! The factored coarse operator `A_c`, ordered so that its solve splits
//! between two threads.
//!
//! The bands of aggregates are cut at a separator band `S`: the bands
//! below it (`L`) couple to the bands above it (`U`) only through `S`.
//! With the unknowns ordered `L`, `U` (bands reversed), `S`,
//!
//! `A_c = [A_LL 0 A_LS; 0 A_UU A_US; A_SL A_SU A_SS] = L Lᵀ`,
//! `L = [L_L 0 0; 0 L_U 0; X_Lᵀ X_Uᵀ L_S]`,
//!
//! with `L_L`, `L_U` banded Cholesky factors, `X = L⁻¹ A_·S` (non-zero only
//! in the rows of the band next to `S`, as `A_·S` is) and `L_S` the dense
//! factor of the Schur complement `A_SS − X_LᵀX_L − X_UᵀX_U`. The solve's
//! substitutions through `L_L` and `L_U` are independent: one thread takes
//! each, and only the small dense one through `L_S` runs alone. `U`'s
//! bands go in reverse so that its band next to `S` comes last in `L_U`,
//! as `L`'s does in `L_L`: each `X` then has as many rows as a band. One
//! band's worth of a 64×64 cloth's coarse grid is 24 unknowns of 192.

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

    /// Rows of the matrix.
    pub(super) fn size(&self) -> usize {
        self.size
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

/// A dense symmetric positive definite matrix in f64 (the separator's
/// Schur complement), factored and then inverted: a product by the
/// inverse is one pass of independent sums, where the two substitutions
/// were a chain of dependent ones (0.6 µs a solve for 24 unknowns).
#[derive(Clone, Debug, Default)]
pub(super) struct Dense {
    size: usize,
    /// `A`, then `L` in its lower triangle.
    a: Vec<f64>,
    /// `A⁻¹`, row-major.
    inverse: Vec<f64>,
}

impl Dense {
    /// Starts a zero matrix of `size` rows.
    pub(super) fn reset(&mut self, size: usize) {
        self.size = size;
        self.a.clear();
        self.a.resize(size * size, 0.0);
    }

    /// Adds `value` to `A[r][c]`, `r ≥ c` (only the lower triangle is read).
    pub(super) fn add(&mut self, r: usize, c: usize, value: f64) {
        self.a[r * self.size + c] += value;
    }

    /// Factors the matrix in place and inverts it; `false` on a pivot that
    /// is not positive.
    pub(super) fn factor(&mut self) -> bool {
        let n = self.size;
        for j in 0..n {
            let mut d = self.a[j * n + j];
            for k in 0..j {
                d -= self.a[j * n + k] * self.a[j * n + k];
            }
            if d.is_nan() || d <= 0.0 {
                return false;
            }
            let d = d.sqrt();
            self.a[j * n + j] = d;
            for i in j + 1..n {
                let mut s = self.a[i * n + j];
                for k in 0..j {
                    s -= self.a[i * n + k] * self.a[j * n + k];
                }
                self.a[i * n + j] = s / d;
            }
        }
        // A⁻¹ = L⁻ᵀ L⁻¹ I, both substitutions a whole row at a time (runs
        // of independent sums, where a column at a time chained them).
        let (l, x) = (&self.a, &mut self.inverse);
        x.clear();
        x.resize(n * n, 0.0);
        for i in 0..n {
            x[i * n + i] = 1.0;
        }
        for k in 0..n {
            let (done, rest) = x.split_at_mut((k + 1) * n);
            let row = &mut done[k * n..];
            let pivot = l[k * n + k];
            row.iter_mut().for_each(|v| *v /= pivot);
            for (i, target) in (k + 1..n).zip(rest.chunks_exact_mut(n)) {
                let lik = l[i * n + k];
                for (t, &r) in target.iter_mut().zip(&*row) {
                    *t -= lik * r;
                }
            }
        }
        for i in (0..n).rev() {
            let (before, from) = x.split_at_mut(i * n);
            let row = &mut from[..n];
            let pivot = l[i * n + i];
            row.iter_mut().for_each(|v| *v /= pivot);
            for (k, target) in before.chunks_exact_mut(n).enumerate() {
                let lik = l[i * n + k];
                for (t, &r) in target.iter_mut().zip(&*row) {
                    *t -= lik * r;
                }
            }
        }
        true
    }

    /// `x = A⁻¹ x` (`x` of at most [`MAX_DENSE`] values).
    #[inline(always)]
    pub(super) fn solve(&self, x: &mut [f64]) {
        let n = self.size;
        let mut y = [0.0; MAX_DENSE];
        for (y, row) in y.iter_mut().zip(self.inverse.chunks_exact(n)) {
            *y = row.iter().zip(&*x).map(|(a, b)| a * b).sum();
        }
        x.copy_from_slice(&y[..n]);
    }
}

/// The most unknowns of a [`Dense`] solve.
pub(super) const MAX_DENSE: usize = 3 * super::COARSE_SIDE;
