//! Type 2 (buckling) pair forces in one AVX-512 pass: lengths, the `g`
//! table and forces of sixteen links at a time, skipping the square root,
//! the table and the division for sixteen links none of which is
//! compressed (a flat or taut region of cloth).
//!
//! For link `i` with ends `a`, `b`, rest length `L` and `1/L`:
//! `d = b − a`, `ℓ = |d|`, and while `ℓ_min ≤ ℓ < L`
//! `out = d · max((k_b/L²)·g(ℓ/L), c_b(ℓ − L)) / ℓ`, else 0.

use super::Level;
use super::table::Pieces;

/// The Type 2 law's constants.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(
    not(any(test, target_arch = "x86_64")),
    expect(dead_code, reason = "read by the x86-64 kernels alone")
)]
pub struct Law<'a> {
    /// The `g` table's pieces.
    pub pieces: &'a Pieces,
    /// Bending rigidity `k_b`, N·m².
    pub kb: f32,
    /// Slope `c_b` of the pre-buckling ramp, N/m.
    pub cb: f32,
    /// Links shorter than this (m) get no force: no direction.
    pub min_length: f32,
}

/// A run of links: their ends' coordinates (m) by component, rest lengths
/// (m; NaN for an empty slot, which gets no force) and their inverses.
#[derive(Clone, Copy, Debug)]
pub struct Links<'a> {
    /// First ends, `[x, y, z]`.
    pub a: [&'a [f32]; 3],
    /// Second ends.
    pub b: [&'a [f32]; 3],
    /// Rest lengths `L`, m.
    pub rest: &'a [f32],
    /// `1/L`, 1/m.
    pub inv_rest: &'a [f32],
}

impl Links<'_> {
    /// Links in the run; panics unless every array holds as many.
    fn len(&self) -> usize {
        let m = self.rest.len();
        let all = self.a.iter().chain(&self.b).chain([&self.inv_rest]);
        assert!(
            all.into_iter().all(|c| c.len() == m),
            "link arrays differ in length"
        );
        m
    }
}

/// The pair forces (N) of `links` into `out`, in one pass of the AVX-512
/// kernel. Returns `false`, writing nothing, below [`Level::Avx512`] or
/// when the run is not a whole number of sixteen links: the caller then
/// forms them in portable loops ([`reference()`] is what both compute, to
/// the sign of zeros).
pub fn pairs(level: Level, law: Law, links: Links, out: [&mut [f32]; 3]) -> bool {
    let m = links.len();
    assert!(out.iter().all(|o| o.len() == m), "out differs in length");
    if level.min(Level::detected()) < Level::Avx512 || !m.is_multiple_of(16) {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: the CPU has AVX-512F (`detected`); every array holds `m`,
        // a multiple of sixteen.
        unsafe { x86::pairs_avx512(law, links, out) };
        true
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (law, out);
        false
    }
}

/// What [`pairs`] computes, one link at a time.
#[cfg(test)]
pub fn reference(law: Law, links: Links, out: [&mut [f32]; 3]) {
    let m = links.len();
    let [ox, oy, oz] = out;
    for i in 0..m {
        let d: [f32; 3] = std::array::from_fn(|c| links.b[c][i] - links.a[c][i]);
        let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let (rest, inv) = (links.rest[i], links.inv_rest[i]);
        let compressed = len2 < rest * rest && len2 >= law.min_length * law.min_length;
        let scale = if compressed {
            let len = len2.sqrt();
            let g = super::table::g(law.pieces, len * inv);
            let fb = law.kb * (inv * inv) * g;
            let linear = law.cb * (len - rest);
            let mag = if linear > fb { linear } else { fb };
            mag / len
        } else {
            0.0
        };
        ox[i] = d[0] * scale;
        oy[i] = d[1] * scale;
        oz[i] = d[2] * scale;
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use super::{Law, Links};
    use crate::simd::table::x86::g_avx512;

    /// [`pairs`](super::pairs) sixteen links at a time.
    ///
    /// # Safety
    /// The CPU has AVX-512F; every array holds `m` values, a multiple of
    /// sixteen.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn pairs_avx512(law: Law, links: Links, out: [&mut [f32]; 3]) {
        let Links {
            a,
            b,
            rest,
            inv_rest,
        } = links;
        let ([xa, ya, za], [xb, yb, zb]) = (a, b);
        let m = rest.len();
        let (kb, cb) = (_mm512_set1_ps(law.kb), _mm512_set1_ps(law.cb));
        let min2 = _mm512_set1_ps(law.min_length * law.min_length);
        let mut out = out;
        for i in (0..m).step_by(16) {
            // SAFETY: every slice holds `m` values, a multiple of sixteen,
            // and `i + 16 ≤ m`.
            let load = |v: &[f32]| unsafe { _mm512_loadu_ps(v.as_ptr().add(i)) };
            let d = [
                _mm512_sub_ps(load(xb), load(xa)),
                _mm512_sub_ps(load(yb), load(ya)),
                _mm512_sub_ps(load(zb), load(za)),
            ];
            let len2 = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(d[0], d[0]), _mm512_mul_ps(d[1], d[1])),
                _mm512_mul_ps(d[2], d[2]),
            );
            let r = load(rest);
            // An empty slot's NaN rest length fails the first test.
            let compressed = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(len2, _mm512_mul_ps(r, r))
                & _mm512_cmp_ps_mask::<_CMP_GE_OQ>(len2, min2);
            let scale = if compressed == 0 {
                _mm512_setzero_ps()
            } else {
                let len = _mm512_sqrt_ps(len2);
                let inv = load(inv_rest);
                let g = g_avx512(law.pieces, _mm512_mul_ps(len, inv));
                let fb = _mm512_mul_ps(_mm512_mul_ps(kb, _mm512_mul_ps(inv, inv)), g);
                let linear = _mm512_mul_ps(cb, _mm512_sub_ps(len, r));
                let mag =
                    _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(linear, fb), fb, linear);
                _mm512_maskz_div_ps(compressed, mag, len)
            };
            for (out, d) in out.iter_mut().zip(d) {
                // SAFETY: as for the loads.
                unsafe { _mm512_storeu_ps(out.as_mut_ptr().add(i), _mm512_mul_ps(d, scale)) };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_matches_the_reference() {
        let pieces: Pieces =
            std::array::from_fn(|j| std::array::from_fn(|k| -((j + k) as f32 * 0.1).cos()));
        let law = Law {
            pieces: &pieces,
            kb: 1e-3,
            cb: 50.0,
            min_length: 1e-9,
        };
        // 64 links: compressed, taut, empty (NaN) and zero-length ones, in
        // runs of sixteen that hold none compressed and some that hold all.
        let m = 64;
        let mut seed = 7u32;
        let mut next = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let a: [Vec<f32>; 3] = std::array::from_fn(|_| (0..m).map(|_| next()).collect());
        let rest: Vec<f32> = (0..m)
            .map(|i| if i == 40 { f32::NAN } else { 0.1 })
            .collect();
        let b: [Vec<f32>; 3] = std::array::from_fn(|c| {
            (0..m)
                .map(|i| {
                    let along = if c == 0 { 1.0 } else { 0.0 };
                    let stretch = match i / 16 {
                        0 => 1.2,
                        1 => 0.5 + next() * 0.6,
                        _ if i == 50 => 0.0,
                        _ => 0.7 + 0.2 * next(),
                    };
                    a[c][i] + along * 0.1 * stretch
                })
                .collect()
        });
        let inv: Vec<f32> = rest.iter().map(|r| 1.0 / r).collect();
        let links = Links {
            a: a.each_ref().map(|v| &v[..]),
            b: b.each_ref().map(|v| &v[..]),
            rest: &rest,
            inv_rest: &inv,
        };
        let mut want: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; m]);
        let [wx, wy, wz] = &mut want;
        reference(law, links, [wx, wy, wz]);
        assert!(
            want[0][16..32].iter().any(|f| *f != 0.0) && want[0][..16].iter().all(|f| *f == 0.0)
        );
        for level in Level::available() {
            let mut got: [Vec<f32>; 3] = std::array::from_fn(|_| vec![f32::NAN; m]);
            let [gx, gy, gz] = &mut got;
            if !pairs(level, law, links, [gx, gy, gz]) {
                assert!(level < Level::Avx512);
                continue;
            }
            // The same operations: the same values (`==` takes −0 for 0).
            for (c, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    g.iter().zip(w).all(|(g, w)| g == w),
                    "{level:?} component {c}"
                );
            }
        }
    }
}
