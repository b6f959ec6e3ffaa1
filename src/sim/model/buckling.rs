//! Choi–Ko's buckling law (MODEL.md §3): the curve `g(s)` of a strip
//! compressed to `s = ℓ/L` of its rest length, its table, and the Type 2
//! force magnitude [`type2_magnitude`] that the forces
//! ([`choi_ko`](super::choi_ko), [`kernel`](super::kernel)), the Jacobians
//! and the stiffness estimate read. It names no other module of the crate.

use std::sync::LazyLock;

/// Connections shorter than this (m) are skipped: their direction is undefined.
pub(crate) const MIN_LENGTH: f32 = 1e-9;

/// Number of pieces of the `g(s)` polynomial table on `[0, 1]`
/// ([`BucklingTable`]).
pub(crate) const TABLE_INTERVALS: usize = crate::simd::table::PIECES;

/// Degree of each piece of the table.
const DEGREE: usize = crate::simd::table::DEGREE;

/// Solves `sinc θ = s` for `θ ∈ [0, π]` by bisection (f64; MODEL.md §3.6a).
///
/// `sinc` falls strictly from 1 at θ = 0 to 0 at θ = π; `s` is clamped to
/// `[0, 1]`.
pub(crate) fn inverse_sinc(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    let (mut lo, mut hi) = (0.0_f64, std::f64::consts::PI);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        let sinc = if mid == 0.0 { 1.0 } else { mid.sin() / mid };
        if sinc > s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `g` and `dg/ds` as functions of the half turning angle θ (MODEL.md §3.3, §3.7).
///
/// `g(θ) = 4θ²/D`, `g' = 4θ²(3D + θ sin θ)/D³` with `D = cos θ − sin θ/θ`.
/// Below θ = 10⁻² the series of `D` and of `3D + θ sin θ` avoid cancellation
/// (MODEL.md §3.4), so `g(0) = −12` and `g'(0) = 36/5` come out exactly.
pub fn g_of_theta(theta: f64) -> (f64, f64) {
    let t2 = theta * theta;
    if theta < 1e-2 {
        // D/θ² and (3D + θ sin θ)/θ⁴ as series.
        let d = -1.0 / 3.0 + t2 / 30.0 - t2 * t2 / 840.0;
        let n = -1.0 / 15.0 + t2 / 210.0;
        (4.0 / d, 4.0 * n / (d * d * d))
    } else {
        let d = theta.cos() - theta.sin() / theta;
        let n = 3.0 * d + theta * theta.sin();
        (4.0 * t2 / d, 4.0 * t2 * n / (d * d * d))
    }
}

/// The normalised buckling force `g(s)` and its slope `g'(s)` (both
/// dimensionless) as 32 pieces of quartic on `s ∈ [0, 1]`.
///
/// `f_b(ℓ) = (k_b/L²)·g(ℓ/L)` in N and `df_b/dℓ = (k_b/L³)·g'(ℓ/L)` in N/m.
///
/// Piece `k` covers `s ∈ [k/32, (k+1)/32]` and takes the exact `g` and
/// `g'` (bisection on `sinc θ = s` in f64, MODEL.md §3.6a) at both ends
/// and the exact `g` at the middle; `g'` between the ends is the piece's
/// derivative. Against the exact values the relative error of `g` is
/// below 3·10⁻⁷ and that of `g'` below 1.5·10⁻⁵. MODEL.md §3.6a suggests a
/// linear table on `s_k = k/1024` (errors 2.6·10⁻⁶ and 10⁻⁵); the pieces
/// are as accurate and fill ten AVX-512 vectors, so the force streams look
/// `g` up with five permutes of whole vectors instead of gathers
/// (gathers take about a tenth of a 15×15 RK4 step on a 2-core x86-64
/// with AVX-512).
#[derive(Clone, Debug)]
pub struct BucklingTable {
    /// `coefficients[j][k]`: the coefficient of `t^j` of piece `k`, with
    /// `t = 32·s − k ∈ [0, 1]`. Stored by power so that one permute
    /// picks a power's coefficient for sixteen lanes.
    coefficients: [[f32; TABLE_INTERVALS]; DEGREE + 1],
    /// `slopes[j][k]`: the coefficient of `t^j` of `g'` on piece `k`
    /// (`32·(j + 1)·c_{j+1}`).
    slopes: [[f32; TABLE_INTERVALS]; DEGREE],
}

/// The shared table, built on first use (160 bisections, well under 1 ms).
pub(crate) static BUCKLING_TABLE: LazyLock<BucklingTable> = LazyLock::new(BucklingTable::new);

impl BucklingTable {
    /// Fits every piece to the exact `g` (MODEL.md §3.3, §3.6a).
    pub fn new() -> Self {
        let mut coefficients = [[0.0; TABLE_INTERVALS]; DEGREE + 1];
        let mut slopes = [[0.0; TABLE_INTERVALS]; DEGREE];
        let n = TABLE_INTERVALS as f64;
        let exact = |s: f64| g_of_theta(inverse_sinc(s));
        for k in 0..TABLE_INTERVALS {
            let s = k as f64 / n;
            let ((g0, d0), (g1, d1)) = (exact(s), exact(s + 1.0 / n));
            let half = exact(s + 0.5 / n).0;
            // Slopes per unit of t = 32 s − k.
            let c = quartic(g0, half, g1, d0 / n, d1 / n);
            for j in 0..=DEGREE {
                coefficients[j][k] = c[j] as f32;
            }
            for j in 0..DEGREE {
                slopes[j][k] = (TABLE_INTERVALS as f64 * (j + 1) as f64 * c[j + 1]) as f32;
            }
        }
        Self {
            coefficients,
            slopes,
        }
    }

    /// `(g(s), g'(s))` for `s = ℓ/L`, clamped to `[0, 1]` (NaN is taken
    /// as 0).
    #[inline]
    pub fn sample(&self, s: f32) -> (f32, f32) {
        let (k, t) = crate::simd::table::locate(s);
        let c = &self.coefficients;
        let g = (((c[4][k] * t + c[3][k]) * t + c[2][k]) * t + c[1][k]) * t + c[0][k];
        let d = &self.slopes;
        let dg = ((d[3][k] * t + d[2][k]) * t + d[1][k]) * t + d[0][k];
        (g, dg)
    }

    /// `g(s)` alone (dimensionless).
    #[cfg(test)]
    #[inline]
    pub fn g(&self, s: f32) -> f32 {
        self.sample(s).0
    }

    /// Replaces every `s` in `values` by `g(s)`, as [`g`](Self::g) gives
    /// it bit for bit, eight at a time with AVX2's gathers
    /// where the CPU has them (`simd::table`).
    pub fn g_in_place(&self, values: &mut [f32]) {
        crate::simd::table::g_in_place(&self.coefficients, values);
    }

    /// The pieces' coefficients, as `simd::table`
    /// reads them.
    pub fn pieces(&self) -> &crate::simd::table::Pieces {
        &self.coefficients
    }
}

/// The coefficients `c_0 … c_4` (of `t^0 … t^4`, `t ∈ [0, 1]`) of the
/// quartic with the values `(g_0, g_½, g_1)` at `t = 0, ½, 1` and the slopes
/// `(m_0, m_1)` (per unit of `t`) at both ends.
fn quartic(g0: f64, half: f64, g1: f64, m0: f64, m1: f64) -> [f64; 5] {
    // With c0 = g0 and c1 = m0, the rest solve
    // c2 + c3 + c4 = a, 2c2 + 3c3 + 4c4 = b, c2/4 + c3/8 + c4/16 = c.
    let a = g1 - g0 - m0;
    let b = m1 - m0;
    let c = half - g0 - 0.5 * m0;
    let c4 = 2.0 * b + 16.0 * c - 8.0 * a;
    let c3 = b - 2.0 * a - 2.0 * c4;
    [g0, m0, a - c3 - c4, c3, c4]
}

impl Default for BucklingTable {
    fn default() -> Self {
        Self::new()
    }
}

/// The clamped Type 2 force magnitude `f_b*(ℓ)` in N and its slope `df_b*/dℓ`
/// in N/m for a connection of rest length `rest` (m) at length `len` (m).
///
/// Positive pulls the ends together; this is never positive: 0 for
/// `ℓ ≥ L`, otherwise `max((k_b/L²)g(ℓ/L), c_b(ℓ − L))`. `k_b` in N·m²,
/// `c_b` in N/m.
#[inline]
pub(crate) fn type2_magnitude(
    table: &BucklingTable,
    len: f32,
    rest: f32,
    kb: f32,
    cb: f32,
) -> (f32, f32) {
    if len >= rest {
        return (0.0, 0.0);
    }
    let (g, dg) = table.sample(len / rest);
    let inv_l2 = 1.0 / (rest * rest);
    let fb = kb * inv_l2 * g;
    let linear = cb * (len - rest);
    if linear > fb {
        (linear, cb)
    } else {
        (fb, kb * inv_l2 / rest * dg)
    }
}
