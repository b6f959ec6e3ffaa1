//! The buckling curve `g(s)` looked up in its table of 32 quartic pieces
//! on `s ∈ [0, 1]` (built by `sim::model::buckling::BucklingTable`), one value
//! at a time ([`g`], the reference) or a slice at a time with AVX2's
//! gathers ([`g_in_place`]): the compiler does not vectorise the lookup.

use super::Level;

/// Pieces of the table on `[0, 1]`.
pub const PIECES: usize = 32;

/// Degree of each piece.
pub const DEGREE: usize = 4;

/// `pieces[j][k]`: the coefficient of `t^j` of piece `k`, `t = 32·s − k`.
/// Stored by power so that one vector instruction picks a power's
/// coefficient for every lane.
pub type Pieces = [[f32; PIECES]; DEGREE + 1];

/// The piece `k` and the position `t ∈ [0, 1]` in it of `s`, clamped to
/// `[0, 1]` (NaN gives piece 0 at `t = 0`, as the vector kernels do).
#[inline]
pub fn locate(s: f32) -> (usize, f32) {
    // `max` returns its other operand for NaN (`clamp` would keep NaN).
    #[allow(clippy::manual_clamp)]
    let x = s.max(0.0).min(1.0) * PIECES as f32;
    // Through i32, which converts in SIMD lanes (NaN gives 0).
    let k = (x as i32).min(PIECES as i32 - 1) as usize;
    (k, x - k as f32)
}

/// `g(s)` (dimensionless) from `pieces`, by Horner's rule (NaN gives
/// `g(0)`).
#[inline]
pub fn g(pieces: &Pieces, s: f32) -> f32 {
    let (k, t) = locate(s);
    let c = pieces;
    (((c[4][k] * t + c[3][k]) * t + c[2][k]) * t + c[1][k]) * t + c[0][k]
}

/// Replaces every `s` in `values` by [`g`]`(s)`, bit for bit (NaN gives
/// `g(0)`), at [`level`](super::level).
pub fn g_in_place(pieces: &Pieces, values: &mut [f32]) {
    g_in_place_at(super::level(), pieces, values);
}

/// [`g_in_place`] at `level`: eight values at a time with AVX2's gathers
/// at [`Level::Avx2`] and above, one at a time otherwise.
pub fn g_in_place_at(level: Level, pieces: &Pieces, values: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if level.min(Level::detected()) >= Level::Avx2 {
        // SAFETY: the CPU has AVX2 (`detected`).
        return unsafe { x86::g_in_place_avx2(pieces, values) };
    }
    let _ = level;
    for s in values {
        *s = g(pieces, *s);
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) mod x86 {
    use std::arch::x86_64::*;

    use super::{DEGREE, PIECES, Pieces};

    /// [`g_in_place`](super::g_in_place) with AVX2's gathers.
    #[target_feature(enable = "avx2,fma")]
    pub(in crate::simd) fn g_in_place_avx2(c: &Pieces, values: &mut [f32]) {
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let pieces = _mm256_set1_ps(PIECES as f32);
        let last = _mm256_set1_epi32(PIECES as i32 - 1);
        let mut chunks = values.chunks_exact_mut(8);
        for chunk in &mut chunks {
            // SAFETY: the chunk holds eight f32.
            let s = unsafe { _mm256_loadu_ps(chunk.as_ptr()) };
            // `max` returns its second operand for NaN: NaN becomes 0.
            let x = _mm256_mul_ps(_mm256_min_ps(_mm256_max_ps(s, zero), one), pieces);
            let k = _mm256_min_epi32(_mm256_cvttps_epi32(x), last);
            let t = _mm256_sub_ps(x, _mm256_cvtepi32_ps(k));
            // SAFETY: every row holds 32 coefficients and 0 ≤ k ≤ 31.
            let pick = |c: &[f32; PIECES]| unsafe { _mm256_i32gather_ps::<4>(c.as_ptr(), k) };
            let mut g = pick(&c[DEGREE]);
            for c in c[..DEGREE].iter().rev() {
                g = _mm256_add_ps(_mm256_mul_ps(g, t), pick(c));
            }
            // SAFETY: as for the load.
            unsafe { _mm256_storeu_ps(chunk.as_mut_ptr(), g) };
        }
        for s in chunks.into_remainder() {
            *s = super::g(c, *s);
        }
    }

    /// `g` of sixteen values at once, as [`g`](super::g) gives it bit for
    /// bit (NaN gives `g(0)`): each power's coefficients of the 32 pieces
    /// fill two registers, from which one permute picks every lane's.
    #[target_feature(enable = "avx512f")]
    pub(in crate::simd) fn g_avx512(c: &Pieces, s: __m512) -> __m512 {
        // `max` returns its second operand for NaN: NaN becomes 0.
        let clamped = _mm512_min_ps(_mm512_max_ps(s, _mm512_setzero_ps()), _mm512_set1_ps(1.0));
        let x = _mm512_mul_ps(clamped, _mm512_set1_ps(PIECES as f32));
        let last = _mm512_set1_epi32(PIECES as i32 - 1);
        let k = _mm512_min_epi32(_mm512_cvttps_epi32(x), last);
        let t = _mm512_sub_ps(x, _mm512_cvtepi32_ps(k));
        let pick = |c: &[f32; PIECES]| {
            // SAFETY: `c` holds 32 f32, two registers' worth.
            let (lo, hi) = unsafe {
                (
                    _mm512_loadu_ps(c.as_ptr()),
                    _mm512_loadu_ps(c[16..].as_ptr()),
                )
            };
            _mm512_permutex2var_ps(lo, k, hi)
        };
        let mut g = pick(&c[DEGREE]);
        for c in c[..DEGREE].iter().rev() {
            g = _mm512_add_ps(_mm512_mul_ps(g, t), pick(c));
        }
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table of made-up coefficients (the lookup does not care).
    fn pieces() -> Pieces {
        std::array::from_fn(|j| std::array::from_fn(|k| ((j * 7 + k * 3) as f32 * 0.37).sin()))
    }

    fn inputs() -> Vec<f32> {
        let mut s: Vec<f32> = (0..203).map(|i| i as f32 / 200.0 - 0.005).collect();
        s.extend([f32::NAN, -1.0, 2.0, 1.0, 0.0, 31.5 / 32.0, f32::INFINITY]);
        s
    }

    #[test]
    fn every_level_looks_up_g_bit_for_bit() {
        let c = pieces();
        let want: Vec<f32> = inputs().iter().map(|&s| g(&c, s)).collect();
        assert_eq!(want[203], g(&c, 0.0), "NaN gives g(0)");
        for level in Level::available() {
            let mut got = inputs();
            g_in_place_at(level, &c, &mut got);
            for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "{level:?} value {i}");
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx512_lookup_is_g_bit_for_bit() {
        if Level::detected() < Level::Avx512 {
            return;
        }
        use std::arch::x86_64::*;
        let c = pieces();
        for chunk in inputs().chunks_exact(16) {
            let mut got = [0.0f32; 16];
            // SAFETY: the CPU has AVX-512F (checked above); 16 values.
            unsafe {
                let s = _mm512_loadu_ps(chunk.as_ptr());
                _mm512_storeu_ps(got.as_mut_ptr(), x86::g_avx512(&c, s));
            }
            for (a, s) in got.iter().zip(chunk) {
                assert_eq!(a.to_bits(), g(&c, *s).to_bits(), "s = {s}");
            }
        }
    }
}
