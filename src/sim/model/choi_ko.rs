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
//! One table of `g(s)` and `g'(s)` on `s ∈ [0, 1]` ([`BucklingTable`], in
//! [`buckling`](super::buckling), re-exported here) serves every rest
//! length and every `k_b`.

pub(crate) use super::buckling::{BUCKLING_TABLE, BucklingTable, MIN_LENGTH, type2_magnitude};

#[cfg(test)]
mod tests {
    use bevy::math::Vec3;

    use super::super::buckling::{g_of_theta, inverse_sinc};
    use super::super::kernel::{self, Law, Target};
    use super::*;
    use crate::sim::connections::Link;

    /// Adds the Type 1 (tension-only) forces of `links` to `f` (N).
    ///
    /// `F_a = [k(ℓ − L) + k_d (v_ab·u)]·u` while `ℓ ≥ L`, else 0; `F_b = −F_a`.
    /// `k` in N/m; `k_d` in N·s/m is the optional axial pair damping of
    /// MODEL.md §4, applied only while the link is taut (a slack Type 1 link
    /// does not exist for the cloth).
    fn type1_forces(links: &[Link], k: f32, kd: f32, x: &[Vec3], v: &[Vec3], f: &mut [Vec3]) {
        let mut out = Target { f, base: 0 };
        kernel::pair_forces(&[(links, Law::Tension { k, kd })], x, v, &mut out);
    }

    /// Adds the Type 2 (buckling) forces of `links` to `f` (N); see
    /// [`type2_magnitude`]. `k_b` in N·m², `c_b` in N/m.
    fn type2_forces(
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
