//! Choi–Ko's "immediate buckling" connections (MODEL.md §2–§3).
//!
//! - **Type 1** ([`type1_forces`]): a tension-only spring, `F_a = k(ℓ − L)u`
//!   for `ℓ ≥ L` and 0 otherwise (seed eq. 1).
//! - **Type 2** ([`type2_forces`]): a compressed strip buckles at once into a
//!   circular arc of length `L`; the force is `f_b = (k_b/L²)·g(ℓ/L)` (seed
//!   eq. 2–3 in the normalised form of MODEL.md §3.3), clamped to the linear
//!   pre-buckling ramp `f_b* = max(f_b, c_b(ℓ − L))` (seed eq. 4), zero for
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

/// Number of intervals of the `g(s)` table (`s_k = k/1024`, MODEL.md §3.6a).
pub const TABLE_INTERVALS: usize = 1024;

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

/// The normalised buckling force `g(s)` and its slope `g'(s)` tabulated on
/// `s_k = k/1024`, interpolated linearly (relative error below 10⁻⁵).
///
/// `f_b(ℓ) = (k_b/L²)·g(ℓ/L)` in N and `df_b/dℓ = (k_b/L³)·g'(ℓ/L)` in N/m.
#[derive(Clone, Debug)]
pub struct BucklingTable {
    /// `[g(s_k), g'(s_k)]` for `k = 0..=1024` (dimensionless). Its length
    /// is part of the type, so lookups need no bounds check and the force
    /// streams' loops vectorise.
    entries: Box<[[f32; 2]; TABLE_INTERVALS + 1]>,
    /// `[g(s_k), g(s_{k+1})]` for `k = 0..1024`: the two ends of each
    /// interval side by side, so one 64-bit gather fetches both.
    ends: Box<[[f32; 2]; TABLE_INTERVALS]>,
}

/// The shared table, built on first use (1025 bisections, well under 1 ms).
pub static BUCKLING_TABLE: LazyLock<BucklingTable> = LazyLock::new(BucklingTable::new);

impl BucklingTable {
    /// Builds the table by bisection on `sinc θ = s_k` (MODEL.md §3.6a).
    pub fn new() -> Self {
        let entries = Box::new(std::array::from_fn(|k| {
            let s = k as f64 / TABLE_INTERVALS as f64;
            let (g, dg) = g_of_theta(inverse_sinc(s));
            [g as f32, dg as f32]
        }));
        let ends = Box::new(std::array::from_fn(|k| [entries[k][0], entries[k + 1][0]]));
        Self { entries, ends }
    }

    /// `(g(s), g'(s))` for `s = ℓ/L`, clamped to `[0, 1]`.
    #[inline]
    pub fn sample(&self, s: f32) -> (f32, f32) {
        let x = s.clamp(0.0, 1.0) * TABLE_INTERVALS as f32;
        // Through i32, which converts in SIMD lanes (NaN gives 0).
        let k = (x as i32).min(TABLE_INTERVALS as i32 - 1) as usize;
        let t = x - k as f32;
        let [g0, d0] = self.entries[k];
        let [g1, d1] = self.entries[k + 1];
        (g0 + t * (g1 - g0), d0 + t * (d1 - d0))
    }

    /// Replaces every `s` in `values` by `g(s)`, as [`g`](Self::g) does
    /// (except that NaN gives `g(0)` or `g(1)`), eight at a time with AVX2's
    /// gathers where the CPU has them: the compiler does not vectorise the
    /// lookup. Eight values that are all at least 1 (links that are not
    /// compressed, the common case) skip the gathers.
    pub fn g_in_place(&self, values: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, as checked on the line above.
            return unsafe { self.g_in_place_avx2(values) };
        }
        for s in values {
            *s = self.g(*s);
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn g_in_place_avx2(&self, values: &mut [f32]) {
        use std::arch::x86_64::*;
        let base = self.ends.as_ptr().cast::<f64>();
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let intervals = _mm256_set1_ps(TABLE_INTERVALS as f32);
        let last = _mm256_set1_epi32(TABLE_INTERVALS as i32 - 1);
        let at_one = _mm256_set1_ps(self.g(1.0));
        let mut chunks = values.chunks_exact_mut(8);
        for chunk in &mut chunks {
            // SAFETY: the chunk holds eight f32.
            let s = unsafe { _mm256_loadu_ps(chunk.as_ptr()) };
            // g is constant from s = 1 on (NaN counts as at least 1 here).
            if _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(s, one)) == 0 {
                // SAFETY: as for the load.
                unsafe { _mm256_storeu_ps(chunk.as_mut_ptr(), at_one) };
                continue;
            }
            // `max` returns its second operand for NaN: NaN becomes 0.
            let x = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(s, zero), one), intervals);
            let k = _mm256_min_epi32(_mm256_cvttps_epi32(x), last);
            let t = _mm256_sub_ps(x, _mm256_cvtepi32_ps(k));
            // Lanes 0, 1, 4, 5 in the low half and 2, 3, 6, 7 in the high
            // one, so that the shuffle below puts the values back in order.
            let k = _mm256_permutevar8x32_epi32(k, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7));
            // SAFETY: each gather reads four of the 1024 pairs `ends[k]`,
            // with 0 ≤ k ≤ 1023.
            let (p, q) = unsafe {
                (
                    _mm256_castpd_ps(_mm256_i32gather_pd::<8>(base, _mm256_castsi256_si128(k))),
                    _mm256_castpd_ps(_mm256_i32gather_pd::<8>(
                        base,
                        _mm256_extracti128_si256::<1>(k),
                    )),
                )
            };
            // (g_k, g_k+1) pairs of lanes 0 1 4 5 in p, 2 3 6 7 in q.
            let g0 = _mm256_shuffle_ps::<0b10_00_10_00>(p, q);
            let g1 = _mm256_shuffle_ps::<0b11_01_11_01>(p, q);
            let g = _mm256_add_ps(g0, _mm256_mul_ps(t, _mm256_sub_ps(g1, g0)));
            // SAFETY: as for the load.
            unsafe { _mm256_storeu_ps(chunk.as_mut_ptr(), g) };
        }
        for s in chunks.into_remainder() {
            *s = self.g(*s);
        }
    }

    /// `g(s)` alone (dimensionless).
    #[inline]
    pub fn g(&self, s: f32) -> f32 {
        self.sample(s).0
    }
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
        // 61 values (seven full lanes of eight and a tail) from below 0 to
        // above 1, with the ends and the table's last interval.
        let mut s: Vec<f32> = (0..61).map(|k| -0.25 + k as f32 * 0.025).collect();
        s.extend([0.0, 1.0, 1.0 - 1e-4, 0.5, 2.0]);
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
        assert_eq!(t.g(1.0), -12.0);
        let four_pi2 = (4.0 * PI * PI) as f32;
        assert!((t.g(0.0) + four_pi2).abs() < 1e-4);
        assert!((t.sample(1.0).1 - 7.2).abs() < 1e-5);
        assert!((t.sample(0.0).1 as f64 - 12.0 * PI * PI).abs() < 1e-3);
    }

    #[test]
    fn table_interpolation_is_within_1e_5_of_direct_evaluation() {
        let t = BucklingTable::new();
        for k in 0..997 {
            let s = (k as f64 + 0.37) / 997.0;
            let (g, _) = g_of_theta(inverse_sinc(s));
            assert!(rel(t.g(s as f32) as f64, g) < 1e-5, "s = {s}");
        }
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
