//! Choi–Ko's "immediate buckling" connections (MODEL.md §2–§3).
//!
//! - **Type 1** ([`type1_forces`]): a tension-only spring, `F_a = k(ℓ − L)u`
//!   for `ℓ ≥ L` and 0 otherwise (paper eq. 1).
//! - **Type 2** ([`type2_forces`]): a compressed strip buckles at once into a
//!   circular arc of length `L`; the force is `f_b = (k_b/L²)·g(ℓ/L)` (paper
//!   eq. 2–3 in the normalised form of MODEL.md §3.3), clamped to the linear
//!   pre-buckling ramp `f_b* = max(f_b, c_b(ℓ − L))` (paper eq. 4), zero for
//!   `ℓ ≥ L` and skipped for `ℓ < 10⁻⁹` m where the direction is undefined.
//!
//! One table of `g(s)` and `g'(s)` on `s ∈ [0, 1]` ([`BucklingTable`])
//! serves every rest length and every `k_b`.

use std::sync::LazyLock;

use bevy::math::Vec3;

use super::kernel::{self, Law, Target};
use crate::connections::Link;

/// Connections shorter than this (m) are skipped: their direction is undefined.
pub const MIN_LENGTH: f32 = 1e-9;

/// Number of pieces of the `g(s)` polynomial table on `[0, 1]`
/// ([`BucklingTable`]).
pub const TABLE_INTERVALS: usize = 32;

/// Degree of each piece of the table.
const DEGREE: usize = 4;

/// Solves `sinc θ = s` for `θ ∈ [0, π]` by bisection (f64; MODEL.md §3.6a).
///
/// `sinc` falls strictly from 1 at θ = 0 to 0 at θ = π; `s` is clamped to
/// `[0, 1]`.
pub fn inverse_sinc(s: f64) -> f64 {
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
pub static BUCKLING_TABLE: LazyLock<BucklingTable> = LazyLock::new(BucklingTable::new);

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

    /// The piece `k` and the position `t ∈ [0, 1]` in it of `s`, clamped
    /// to `[0, 1]`.
    #[inline]
    fn locate(s: f32) -> (usize, f32) {
        let x = s.clamp(0.0, 1.0) * TABLE_INTERVALS as f32;
        // Through i32, which converts in SIMD lanes (NaN gives 0).
        let k = (x as i32).min(TABLE_INTERVALS as i32 - 1) as usize;
        (k, x - k as f32)
    }

    /// `(g(s), g'(s))` for `s = ℓ/L`, clamped to `[0, 1]`.
    #[inline]
    pub fn sample(&self, s: f32) -> (f32, f32) {
        let (k, t) = Self::locate(s);
        let c = &self.coefficients;
        let g = (((c[4][k] * t + c[3][k]) * t + c[2][k]) * t + c[1][k]) * t + c[0][k];
        let d = &self.slopes;
        let dg = ((d[3][k] * t + d[2][k]) * t + d[1][k]) * t + d[0][k];
        (g, dg)
    }

    /// `g(s)` alone (dimensionless).
    #[inline]
    pub fn g(&self, s: f32) -> f32 {
        self.sample(s).0
    }

    /// Replaces every `s` in `values` by `g(s)`, as [`g`](Self::g) does
    /// (except that NaN gives `g(0)`), eight at a time with AVX2's gathers
    /// where the CPU has them: the compiler does not vectorise the lookup.
    /// (The force streams on AVX-512 use `g_avx512`.)
    pub fn g_in_place(&self, values: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, as checked on the line above.
            return unsafe { self.g_in_place_avx2(values) };
        }
        self.g_in_place_portable(values);
    }

    /// [`g_in_place`](Self::g_in_place) one value at a time.
    fn g_in_place_portable(&self, values: &mut [f32]) {
        for s in values {
            *s = self.g(*s);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn g_in_place_avx2(&self, values: &mut [f32]) {
        use std::arch::x86_64::*;
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let pieces = _mm256_set1_ps(TABLE_INTERVALS as f32);
        let last = _mm256_set1_epi32(TABLE_INTERVALS as i32 - 1);
        let mut chunks = values.chunks_exact_mut(8);
        for chunk in &mut chunks {
            // SAFETY: the chunk holds eight f32.
            let s = unsafe { _mm256_loadu_ps(chunk.as_ptr()) };
            // `max` returns its second operand for NaN: NaN becomes 0.
            let x = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(s, zero), one), pieces);
            let k = _mm256_min_epi32(_mm256_cvttps_epi32(x), last);
            let t = _mm256_sub_ps(x, _mm256_cvtepi32_ps(k));
            // SAFETY: every row holds 32 coefficients and 0 ≤ k ≤ 31.
            let pick =
                |c: &[f32; TABLE_INTERVALS]| unsafe { _mm256_i32gather_ps::<4>(c.as_ptr(), k) };
            let c = &self.coefficients;
            let mut g = pick(&c[DEGREE]);
            for c in c[..DEGREE].iter().rev() {
                g = _mm256_add_ps(_mm256_mul_ps(g, t), pick(c));
            }
            // SAFETY: as for the load.
            unsafe { _mm256_storeu_ps(chunk.as_mut_ptr(), g) };
        }
        self.g_in_place_portable(chunks.into_remainder());
    }

    /// `g` of sixteen values at once, as [`g`](Self::g) gives it bit for
    /// bit (NaN gives `g(0)`): each power's coefficients of the 32 pieces
    /// fill two registers, from which one permute picks every lane's.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    pub(crate) fn g_avx512(&self, s: std::arch::x86_64::__m512) -> std::arch::x86_64::__m512 {
        use std::arch::x86_64::*;
        // `max` returns its second operand for NaN: NaN becomes 0.
        let clamped = _mm512_min_ps(_mm512_max_ps(s, _mm512_setzero_ps()), _mm512_set1_ps(1.0));
        let x = _mm512_mul_ps(clamped, _mm512_set1_ps(TABLE_INTERVALS as f32));
        let last = _mm512_set1_epi32(TABLE_INTERVALS as i32 - 1);
        let k = _mm512_min_epi32(_mm512_cvttps_epi32(x), last);
        let t = _mm512_sub_ps(x, _mm512_cvtepi32_ps(k));
        let pick = |c: &[f32; TABLE_INTERVALS]| {
            // SAFETY: `c` holds 32 f32, two registers' worth.
            let (lo, hi) = unsafe {
                (
                    _mm512_loadu_ps(c.as_ptr()),
                    _mm512_loadu_ps(c[16..].as_ptr()),
                )
            };
            _mm512_permutex2var_ps(lo, k, hi)
        };
        let c = &self.coefficients;
        let mut g = pick(&c[DEGREE]);
        for c in c[..DEGREE].iter().rev() {
            g = _mm512_add_ps(_mm512_mul_ps(g, t), pick(c));
        }
        g
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
pub fn type2_magnitude(table: &BucklingTable, len: f32, rest: f32, kb: f32, cb: f32) -> (f32, f32) {
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

/// Adds the Type 1 (tension-only) forces of `links` to `f` (N).
///
/// `F_a = [k(ℓ − L) + k_d (v_ab·u)]·u` while `ℓ ≥ L`, else 0; `F_b = −F_a`.
/// `k` in N/m; `k_d` in N·s/m is the optional axial pair damping of
/// MODEL.md §4, applied only while the link is taut (a slack Type 1 link
/// does not exist for the cloth).
pub fn type1_forces(links: &[Link], k: f32, kd: f32, x: &[Vec3], v: &[Vec3], f: &mut [Vec3]) {
    let mut out = Target { f, base: 0 };
    kernel::pair_forces(&[(links, Law::Tension { k, kd })], x, v, &mut out);
}

/// Adds the Type 2 (buckling) forces of `links` to `f` (N); see
/// [`type2_magnitude`]. `k_b` in N·m², `c_b` in N/m.
pub fn type2_forces(
    table: &BucklingTable,
    links: &[Link],
    kb: f32,
    cb: f32,
    x: &[Vec3],
    f: &mut [Vec3],
) {
    let mut out = Target { f, base: 0 };
    let law = Law::Buckling { table, kb, cb };
    kernel::pair_forces(&[(links, law)], x, &[], &mut out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn g_in_place_gives_the_lookup_of_g_bit_for_bit() {
        let table = BucklingTable::new();
        // 1001 values (125 full vectors of eight and a tail) from below 0
        // to above 1, with the ends and both sides of a piece boundary.
        let mut s: Vec<f32> = (0..1001).map(|k| -0.25 + k as f32 * 0.0015).collect();
        s.extend([
            0.0,
            1.0,
            1.0 - 1e-4,
            0.5,
            2.0,
            1.0 / 32.0,
            1.0 / 32.0 - 1e-7,
        ]);
        let want: Vec<f32> = s.iter().map(|&s| table.g(s)).collect();
        table.g_in_place(&mut s);
        for (k, (got, want)) in s.iter().zip(&want).enumerate() {
            assert_eq!(got.to_bits(), want.to_bits(), "value {k}: {got} vs {want}");
        }
    }

    /// MODEL.md §3.3 test vectors: (s, θ, g, g').
    const VECTORS: [(f64, f64, f64, f64); 8] = [
        (0.0, PI, -39.4784, 118.435),
        (0.1, 2.85234, -30.7461, 64.816),
        (0.3, 2.35644, -22.0507, 29.470),
        (0.5, 1.89549, -17.5473, 17.281),
        (0.7, 1.41019, -14.7284, 11.523),
        (0.9, 0.78668, -12.7732, 8.306),
        (0.99, 0.24532, -12.0725, 7.300),
        (1.0, 0.0, -12.0, 7.2),
    ];

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-12)
    }

    #[test]
    fn pieces_match_the_exact_g_and_slope() {
        let t = BucklingTable::new();
        let (mut worst_g, mut worst_dg) = (0.0_f64, 0.0_f64);
        for k in 0..=3989 {
            let s = (k as f32 + 0.37) / 3990.0;
            let (g, dg) = g_of_theta(inverse_sinc(s as f64));
            let (tg, tdg) = t.sample(s);
            worst_g = worst_g.max(rel(tg as f64, g));
            worst_dg = worst_dg.max(rel(tdg as f64, dg));
        }
        assert!(worst_g < 3e-7, "g: relative error {worst_g:e}");
        assert!(worst_dg < 1.5e-5, "g': relative error {worst_dg:e}");
    }

    #[test]
    fn inverse_sinc_matches_the_vector() {
        for (s, theta, _, _) in VECTORS {
            assert!((inverse_sinc(s) - theta).abs() < 1e-4, "s = {s}");
        }
    }

    #[test]
    fn table_matches_model_3_3_to_1e_3() {
        let t = BucklingTable::new();
        for (s, _, g, dg) in VECTORS {
            let (tg, tdg) = t.sample(s as f32);
            assert!(rel(tg as f64, g) < 1e-3, "g({s}) = {tg}, want {g}");
            assert!(rel(tdg as f64, dg) < 1e-3, "g'({s}) = {tdg}, want {dg}");
        }
    }

    #[test]
    fn end_values_are_exact() {
        let t = BucklingTable::new();
        assert!((t.g(1.0) + 12.0).abs() < 1e-5);
        let four_pi2 = (4.0 * PI * PI) as f32;
        assert!((t.g(0.0) + four_pi2).abs() < 1e-4);
        assert!((t.sample(1.0).1 - 7.2).abs() < 1e-5);
        assert!((t.sample(0.0).1 as f64 - 12.0 * PI * PI).abs() < 1e-3);
    }

    #[test]
    fn onset_force_is_minus_12_kb_over_l2() {
        let t = BucklingTable::new();
        let (kb, rest) = (5e-7_f32, 2.0 / 14.0);
        // Without the clamp (c_b huge) the force just below L tends to −12 k_b/L².
        let (f, _) = type2_magnitude(&t, rest * (1.0 - 1e-5), rest, kb, 1e12);
        let want = -12.0 * kb / (rest * rest);
        assert!(((f - want) / want).abs() < 1e-3, "{f} vs {want}");
        // At or above L: nothing.
        assert_eq!(type2_magnitude(&t, rest, rest, kb, 1000.0), (0.0, 0.0));
        assert_eq!(
            type2_magnitude(&t, rest * 1.1, rest, kb, 1000.0),
            (0.0, 0.0)
        );
    }

    #[test]
    fn clamp_picks_the_linear_branch_near_rest_length() {
        let t = BucklingTable::new();
        let (kb, cb, rest) = (5e-7_f32, 1000.0_f32, 2.0 / 14.0);
        // Crossing at 1 − s* ≈ 12 k_b/(c_b L³) ≈ 2e-6 (MODEL.md §3.5).
        let len = rest * (1.0 - 5e-7);
        let (f, slope) = type2_magnitude(&t, len, rest, kb, cb);
        assert_eq!(slope, cb);
        assert!((f - cb * (len - rest)).abs() < 1e-9);
        // Well inside the buckled range the curve wins.
        let len = rest * 0.5;
        let (f, slope) = type2_magnitude(&t, len, rest, kb, cb);
        let want = kb / (rest * rest) * t.g(0.5);
        assert!((f - want).abs() < 1e-9 && slope != cb);
    }

    #[test]
    fn type1_is_tension_only_and_type2_compression_only() {
        let t = BucklingTable::new();
        let link = [Link {
            a: 0,
            b: 1,
            rest_length: 1.0,
        }];
        let v = [Vec3::ZERO; 2];
        let mut f = [Vec3::ZERO; 2];
        // Compressed: Type 1 silent, Type 2 pushes apart.
        let x = [Vec3::ZERO, Vec3::new(0.8, 0.0, 0.0)];
        type1_forces(&link, 1000.0, 0.1, &x, &v, &mut f);
        assert_eq!(f, [Vec3::ZERO; 2]);
        type2_forces(&t, &link, 1e-3, 1000.0, &x, &mut f);
        assert!(f[0].x < 0.0 && f[1].x > 0.0);
        // Stretched: Type 2 silent, Type 1 pulls together with k(ℓ − L).
        let x = [Vec3::ZERO, Vec3::new(1.2, 0.0, 0.0)];
        let mut f = [Vec3::ZERO; 2];
        type2_forces(&t, &link, 1e-3, 1000.0, &x, &mut f);
        assert_eq!(f, [Vec3::ZERO; 2]);
        type1_forces(&link, 1000.0, 0.0, &x, &v, &mut f);
        assert!((f[0].x - 200.0).abs() < 1e-3 && (f[1].x + 200.0).abs() < 1e-3);
        // Coincident particles: skipped, no NaN.
        let x = [Vec3::ONE, Vec3::ONE];
        let mut f = [Vec3::ZERO; 2];
        type2_forces(&t, &link, 1e-3, 1000.0, &x, &mut f);
        type1_forces(&link, 1000.0, 0.1, &x, &v, &mut f);
        assert_eq!(f, [Vec3::ZERO; 2]);
    }
}
