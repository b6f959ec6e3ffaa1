//! The implicit operator's product gathered per particle: sixteen (AVX-512),
//! eight (AVX2 with FMA) or four (wasm32's simd128) particles at a time sum
//! the terms of every stream of blocks in registers and write once, where a
//! portable product forms each stream's products and scatters them to both
//! ends.
//!
//! For particles `p` in a range,
//! `out_p = m_p d_p + Σ_δ C_δ[p](d_p − d_{p+δ}) + C_δ[p−δ](d_p − d_{p−δ})`,
//! zero where `free_p = 0`, with each block `C = t I + s u uᵀ` stored at
//! `pad + p` of its stream and `d` stored `pad` values into its arrays.

use std::ops::Range;

use super::Level;

/// The particles of one AVX-512 vector: the zeros a [`Product`]'s arrays
/// hold after their last value.
pub const LANES: usize = 16;

/// One stream of blocks `C = t I + s u uᵀ` (kg), of the pairs `(p, p + δ)`.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(
    not(any(
        test,
        target_arch = "x86_64",
        all(target_arch = "wasm32", target_feature = "simd128")
    )),
    expect(dead_code, reason = "read by the SIMD kernels alone")
)]
pub struct Blocks<'a> {
    /// `δ`, the index step of the pairs (particles, ≤ the product's `pad`).
    pub delta: usize,
    /// The isotropic part `t` of each block, at `pad + p`.
    pub t: &'a [f32],
    /// The part `s` along `u`, at `pad + p`.
    pub s: &'a [f32],
    /// The unit direction `u`, by component, at `pad + p`.
    pub u: [&'a [f32]; 3],
    /// Whether any `t` is not 0 (else the kernels skip the `t` terms).
    pub transverse: bool,
}

/// The operator of a product, as [`gather`] reads it.
#[derive(Clone, Copy, Debug)]
pub struct Product<'a> {
    /// `M(1 + αc)` of each particle (kg); `n` values.
    pub mass: &'a [f32],
    /// 1 for a free particle, 0 for a pinned one (its row is zero).
    pub free: &'a [f32],
    /// The zeros before every stream's and `d`'s values (≥ every `δ`).
    pub pad: usize,
}

impl Product<'_> {
    /// Particles.
    pub fn len(&self) -> usize {
        self.mass.len()
    }

    /// Panics unless the kernels' loads stay inside the arrays: `free` as
    /// long as `mass`; every `δ ≤ pad`; every stream array at least
    /// `pad + n + LANES` long and `d` at least `n + 2·pad + LANES`.
    fn check<'a>(
        &self,
        streams: impl Iterator<Item = Blocks<'a>>,
        d: &[&[f32]; 3],
        range: &Range<usize>,
    ) {
        let (n, pad) = (self.len(), self.pad);
        assert_eq!(self.free.len(), n, "free and mass differ in length");
        assert!(
            range.start <= range.end && range.end <= n,
            "range {range:?} of {n}"
        );
        for b in streams {
            assert!(b.delta <= pad, "δ {} beyond the pad {pad}", b.delta);
            for c in [b.t, b.s].into_iter().chain(b.u) {
                assert!(c.len() >= pad + n + LANES, "a stream array is short");
            }
        }
        for c in d {
            assert!(c.len() >= n + 2 * pad + LANES, "d is short");
        }
    }
}

/// Rows `range` of the product of `d` (padded: its particle `p` at
/// `pad + p`) into `out` (`out[c][i]` is row `range.start + i`), with the
/// gathered kernel of `level`. Returns `false`, writing nothing, at a level
/// without one ([`Level::Scalar`]): the portable product scatters instead
/// (see [`reference()`] for what every kernel computes). Panics if the
/// arrays are shorter than [`Product`] says.
pub fn gather<'a>(
    level: Level,
    product: &Product,
    streams: impl Iterator<Item = Blocks<'a>> + Clone,
    d: [&[f32]; 3],
    out: [&mut [f32]; 3],
    range: Range<usize>,
) -> bool {
    let level = level.min(Level::detected());
    if level == Level::Scalar {
        return false;
    }
    product.check(streams.clone(), &d, &range);
    assert!(
        out.iter().all(|o| o.len() == range.len()),
        "out is not the range"
    );
    let out = out.map(|o| o.as_mut_ptr());
    match level {
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 => {
            // SAFETY: `check` bounded every load by the arrays' lengths,
            // `out` holds the range, and the CPU has AVX-512F (`detected`).
            unsafe { x86::avx512(product, streams, d, out, range) };
            true
        }
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 => {
            // SAFETY: as above, with AVX2 and FMA.
            unsafe { x86::avx2(product, streams, d, out, range) };
            true
        }
        #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
        Level::Simd128 => {
            // SAFETY: `check` bounded every load by the arrays' lengths,
            // and `out` holds the range.
            unsafe { wasm::simd128(product, streams, d, out, range) };
            true
        }
        // A level this build has no kernel for.
        _ => {
            let _ = (streams, out, range);
            false
        }
    }
}

/// What [`gather`] computes, one particle and one term at a time (the x86
/// kernels fuse multiplies and adds and the simd128 one sums in its own
/// order, so they agree to rounding).
#[cfg(test)]
pub fn reference<'a>(
    product: &Product,
    streams: impl Iterator<Item = Blocks<'a>> + Clone,
    d: [&[f32]; 3],
    out: [&mut [f32]; 3],
    range: Range<usize>,
) {
    product.check(streams.clone(), &d, &range);
    let pad = product.pad;
    let [ox, oy, oz] = out;
    for (i, p) in range.enumerate() {
        let here = pad + p;
        let a = [d[0][here], d[1][here], d[2][here]];
        let m = product.mass[p];
        let mut sum = [m * a[0], m * a[1], m * a[2]];
        for b in streams.clone() {
            for (block, other) in [(here, here + b.delta), (here - b.delta, here - b.delta)] {
                let e: [f32; 3] = std::array::from_fn(|c| a[c] - d[c][other]);
                let u: [f32; 3] = std::array::from_fn(|c| b.u[c][block]);
                let k = b.s[block] * (u[0] * e[0] + u[1] * e[1] + u[2] * e[2]);
                for c in 0..3 {
                    sum[c] += b.t[block] * e[c] + k * u[c];
                }
            }
        }
        let keep = product.free[p] != 0.0;
        for (o, s) in [&mut ox[i], &mut oy[i], &mut oz[i]].into_iter().zip(sum) {
            *o = if keep { s } else { 0.0 };
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;
    use std::ops::Range;

    use super::{Blocks, LANES, Product};

    /// [`gather`](super::gather) in AVX-512, sixteen particles at a time.
    ///
    /// # Safety
    /// The CPU has AVX-512F; [`Product::check`] held; `out` points to three
    /// arrays of `range.len()` values no one else reads or writes meanwhile.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn avx512<'a>(
        product: &Product,
        streams: impl Iterator<Item = Blocks<'a>> + Clone,
        [dx, dy, dz]: [&[f32]; 3],
        out: [*mut f32; 3],
        range: Range<usize>,
    ) {
        let (first, end, pad) = (range.start, range.end, product.pad);
        let (dx, dy, dz) = (dx.as_ptr(), dy.as_ptr(), dz.as_ptr());
        for start in range.step_by(LANES) {
            // The lanes of particles up to the last.
            let mask: __mmask16 = if end - start >= LANES {
                !0
            } else {
                (1 << (end - start)) - 1
            };
            // SAFETY: indices within the lengths `check` bounded (the
            // masked loads and stores touch lanes below `end` only).
            unsafe {
                let at = |c: *const f32, i: usize| _mm512_loadu_ps(c.add(i));
                let here = pad + start;
                let (ax, ay, az) = (at(dx, here), at(dy, here), at(dz, here));
                let mass = _mm512_maskz_loadu_ps(mask, product.mass.as_ptr().add(start));
                let mut sx = _mm512_mul_ps(mass, ax);
                let mut sy = _mm512_mul_ps(mass, ay);
                let mut sz = _mm512_mul_ps(mass, az);
                for c in streams.clone() {
                    let (t, s) = (c.t.as_ptr(), c.s.as_ptr());
                    let [ux, uy, uz] = c.u.map(|c| c.as_ptr());
                    // C_δ[p] (pair p, p + δ) with e = d_p − d_{p+δ}, then
                    // C_δ[p − δ] (pair p − δ, p) with e = d_p − d_{p−δ}:
                    // C e = t e + s (u·e) u.
                    let delta = c.delta;
                    for (block, other) in [(here, here + delta), (here - delta, here - delta)] {
                        let ex = _mm512_sub_ps(ax, at(dx, other));
                        let ey = _mm512_sub_ps(ay, at(dy, other));
                        let ez = _mm512_sub_ps(az, at(dz, other));
                        let (bx, by, bz) = (at(ux, block), at(uy, block), at(uz, block));
                        let along = _mm512_mul_ps(bx, ex);
                        let along = _mm512_fmadd_ps(by, ey, along);
                        let along = _mm512_fmadd_ps(bz, ez, along);
                        let k = _mm512_mul_ps(at(s, block), along);
                        if c.transverse {
                            let tb = at(t, block);
                            sx = _mm512_fmadd_ps(tb, ex, sx);
                            sy = _mm512_fmadd_ps(tb, ey, sy);
                            sz = _mm512_fmadd_ps(tb, ez, sz);
                        }
                        sx = _mm512_fmadd_ps(k, bx, sx);
                        sy = _mm512_fmadd_ps(k, by, sy);
                        sz = _mm512_fmadd_ps(k, bz, sz);
                    }
                }
                // The filter: pinned rows (free = 0) are zero.
                let free = _mm512_maskz_loadu_ps(mask, product.free.as_ptr().add(start));
                let keep = _mm512_mask_cmp_ps_mask::<_CMP_NEQ_UQ>(mask, free, _mm512_setzero_ps());
                for (o, s) in out.into_iter().zip([sx, sy, sz]) {
                    _mm512_mask_storeu_ps(o.add(start - first), mask, _mm512_maskz_mov_ps(keep, s));
                }
            }
        }
    }

    /// [`avx512`] in AVX2 and FMA, eight particles at a time.
    ///
    /// # Safety
    /// As for [`avx512`], with AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn avx2<'a>(
        product: &Product,
        streams: impl Iterator<Item = Blocks<'a>> + Clone,
        [dx, dy, dz]: [&[f32]; 3],
        out: [*mut f32; 3],
        range: Range<usize>,
    ) {
        const WIDTH: usize = 8;
        let (first, end, pad) = (range.start, range.end, product.pad);
        let (dx, dy, dz) = (dx.as_ptr(), dy.as_ptr(), dz.as_ptr());
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        for start in range.step_by(WIDTH) {
            // All ones in the lanes of particles up to the last.
            let mask = _mm256_cmpgt_epi32(_mm256_set1_epi32((end - start) as i32), lane);
            // SAFETY: as in `avx512`.
            unsafe {
                let at = |c: *const f32, i: usize| _mm256_loadu_ps(c.add(i));
                let here = pad + start;
                let (ax, ay, az) = (at(dx, here), at(dy, here), at(dz, here));
                let mass = _mm256_maskload_ps(product.mass.as_ptr().add(start), mask);
                let mut sx = _mm256_mul_ps(mass, ax);
                let mut sy = _mm256_mul_ps(mass, ay);
                let mut sz = _mm256_mul_ps(mass, az);
                for c in streams.clone() {
                    let (t, s) = (c.t.as_ptr(), c.s.as_ptr());
                    let [ux, uy, uz] = c.u.map(|c| c.as_ptr());
                    let delta = c.delta;
                    for (block, other) in [(here, here + delta), (here - delta, here - delta)] {
                        let ex = _mm256_sub_ps(ax, at(dx, other));
                        let ey = _mm256_sub_ps(ay, at(dy, other));
                        let ez = _mm256_sub_ps(az, at(dz, other));
                        let (bx, by, bz) = (at(ux, block), at(uy, block), at(uz, block));
                        let along = _mm256_mul_ps(bx, ex);
                        let along = _mm256_fmadd_ps(by, ey, along);
                        let along = _mm256_fmadd_ps(bz, ez, along);
                        let k = _mm256_mul_ps(at(s, block), along);
                        if c.transverse {
                            let tb = at(t, block);
                            sx = _mm256_fmadd_ps(tb, ex, sx);
                            sy = _mm256_fmadd_ps(tb, ey, sy);
                            sz = _mm256_fmadd_ps(tb, ez, sz);
                        }
                        sx = _mm256_fmadd_ps(k, bx, sx);
                        sy = _mm256_fmadd_ps(k, by, sy);
                        sz = _mm256_fmadd_ps(k, bz, sz);
                    }
                }
                // The filter: pinned rows (free = 0) are zero.
                let free = _mm256_maskload_ps(product.free.as_ptr().add(start), mask);
                let keep = _mm256_cmp_ps::<_CMP_NEQ_UQ>(free, _mm256_setzero_ps());
                for (o, s) in out.into_iter().zip([sx, sy, sz]) {
                    _mm256_maskstore_ps(o.add(start - first), mask, _mm256_and_ps(s, keep));
                }
            }
        }
    }
}

#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
mod wasm {
    use std::arch::wasm32::*;
    use std::ops::Range;

    use super::{Blocks, Product};

    /// [`gather`](super::gather) in simd128, four particles at a time.
    /// simd128 has no fused multiply-add: each term is a product, then a
    /// sum.
    ///
    /// # Safety
    /// [`Product::check`] held; `out` points to three arrays of
    /// `range.len()` values no one else reads or writes meanwhile.
    pub(super) unsafe fn simd128<'a>(
        product: &Product,
        streams: impl Iterator<Item = Blocks<'a>> + Clone,
        [dx, dy, dz]: [&[f32]; 3],
        out: [*mut f32; 3],
        range: Range<usize>,
    ) {
        const WIDTH: usize = 4;
        let (first, end, pad) = (range.start, range.end, product.pad);
        let (dx, dy, dz) = (dx.as_ptr(), dy.as_ptr(), dz.as_ptr());
        let fma = |a: v128, b: v128, c: v128| f32x4_add(f32x4_mul(a, b), c);
        for start in range.step_by(WIDTH) {
            // Particles in this vector: `mass` and `free` end at the last
            // particle, so a short vector reads and writes them lane by lane.
            let lanes = (end - start).min(WIDTH);
            let short = |v: &[f32]| {
                let mut lane = [0.0f32; WIDTH];
                lane[..lanes].copy_from_slice(&v[start..start + lanes]);
                f32x4(lane[0], lane[1], lane[2], lane[3])
            };
            // SAFETY: indices within the lengths `check` bounded (`d` and
            // the streams hold `LANES` values past the last particle).
            unsafe {
                let at = |c: *const f32, i: usize| v128_load(c.add(i).cast::<v128>());
                let here = pad + start;
                let (ax, ay, az) = (at(dx, here), at(dy, here), at(dz, here));
                let mass = short(product.mass);
                let mut sx = f32x4_mul(mass, ax);
                let mut sy = f32x4_mul(mass, ay);
                let mut sz = f32x4_mul(mass, az);
                for c in streams.clone() {
                    let (t, s) = (c.t.as_ptr(), c.s.as_ptr());
                    let [ux, uy, uz] = c.u.map(|c| c.as_ptr());
                    // C_δ[p] (pair p, p + δ) with e = d_p − d_{p+δ}, then
                    // C_δ[p − δ] (pair p − δ, p) with e = d_p − d_{p−δ}:
                    // C e = t e + s (u·e) u.
                    let delta = c.delta;
                    for (block, other) in [(here, here + delta), (here - delta, here - delta)] {
                        let ex = f32x4_sub(ax, at(dx, other));
                        let ey = f32x4_sub(ay, at(dy, other));
                        let ez = f32x4_sub(az, at(dz, other));
                        let (bx, by, bz) = (at(ux, block), at(uy, block), at(uz, block));
                        let along = f32x4_mul(bx, ex);
                        let along = fma(by, ey, along);
                        let along = fma(bz, ez, along);
                        let k = f32x4_mul(at(s, block), along);
                        if c.transverse {
                            let tb = at(t, block);
                            sx = fma(tb, ex, sx);
                            sy = fma(tb, ey, sy);
                            sz = fma(tb, ez, sz);
                        }
                        sx = fma(k, bx, sx);
                        sy = fma(k, by, sy);
                        sz = fma(k, bz, sz);
                    }
                }
                // The filter: pinned rows (free = 0) are zero.
                let keep = f32x4_ne(short(product.free), f32x4_splat(0.0));
                for (o, s) in out.into_iter().zip([sx, sy, sz]) {
                    let row = o.add(start - first);
                    let s = v128_and(s, keep);
                    if lanes == WIDTH {
                        v128_store(row.cast::<v128>(), s);
                    } else {
                        let mut lane = [0.0f32; WIDTH];
                        v128_store(lane.as_mut_ptr().cast::<v128>(), s);
                        std::ptr::copy_nonoverlapping(lane.as_ptr(), row, lanes);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A product of `n` particles with streams `δ = 1, 5, 6` of made-up
    /// blocks, the middle one without transverse terms; every tenth
    /// particle pinned.
    struct Case {
        mass: Vec<f32>,
        free: Vec<f32>,
        pad: usize,
        arrays: Vec<[Vec<f32>; 5]>,
        deltas: Vec<usize>,
        d: [Vec<f32>; 3],
    }

    fn case(n: usize) -> Case {
        let mut seed = 0x9e37_79b9_u32;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let pad = 16;
        let deltas = vec![1, 5, 6];
        let len = pad + n + LANES;
        let arrays = deltas
            .iter()
            .enumerate()
            .map(|(k, _)| {
                let mut a: [Vec<f32>; 5] = std::array::from_fn(|_| vec![0.0; len]);
                // Slot `i` of all five arrays at once.
                #[allow(clippy::needless_range_loop)]
                for i in pad..pad + n {
                    a[0][i] = if k == 1 { 0.0 } else { next() };
                    a[1][i] = next() + 1.0;
                    let u = [next(), next(), next() + 0.1];
                    let l = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
                    for c in 0..3 {
                        a[2 + c][i] = u[c] / l;
                    }
                }
                a
            })
            .collect();
        let d = std::array::from_fn(|_| {
            let mut v = vec![0.0; n + 2 * pad + LANES];
            for x in &mut v[pad..pad + n] {
                *x = next();
            }
            v
        });
        Case {
            mass: (0..n).map(|_| next() + 2.0).collect(),
            free: (0..n)
                .map(|p| if p % 10 == 3 { 0.0 } else { 1.0 })
                .collect(),
            pad,
            arrays,
            deltas,
            d,
        }
    }

    impl Case {
        fn product(&self) -> Product<'_> {
            Product {
                mass: &self.mass,
                free: &self.free,
                pad: self.pad,
            }
        }

        fn streams(&self) -> Vec<Blocks<'_>> {
            self.arrays
                .iter()
                .zip(&self.deltas)
                .enumerate()
                .map(|(k, (a, &delta))| Blocks {
                    delta,
                    t: &a[0],
                    s: &a[1],
                    u: [&a[2], &a[3], &a[4]],
                    transverse: k != 1,
                })
                .collect()
        }

        fn d(&self) -> [&[f32]; 3] {
            self.d.each_ref().map(|v| &v[..])
        }
    }

    #[test]
    fn every_level_matches_the_reference() {
        // Ranges that start and end off the vectors' widths.
        for (n, range) in [(100, 0..100), (100, 3..77), (37, 16..37), (200, 0..0)] {
            let c = case(n);
            let (product, streams) = (c.product(), c.streams());
            let mut want: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; range.len()]);
            let [wx, wy, wz] = &mut want;
            reference(
                &product,
                streams.iter().copied(),
                c.d(),
                [wx, wy, wz],
                range.clone(),
            );
            for level in Level::available() {
                let mut got: [Vec<f32>; 3] = std::array::from_fn(|_| vec![f32::NAN; range.len()]);
                let [gx, gy, gz] = &mut got;
                let it = streams.iter().copied();
                let ran = gather(level, &product, it, c.d(), [gx, gy, gz], range.clone());
                assert_eq!(ran, level != Level::Scalar, "{level:?}");
                if !ran {
                    continue;
                }
                for (g, w) in got.iter().zip(&want) {
                    for (i, (g, w)) in g.iter().zip(w).enumerate() {
                        assert!(
                            (g - w).abs() <= 1e-5 * (1.0 + w.abs()),
                            "{level:?} {n} {range:?} row {i}: {g} vs {w}"
                        );
                    }
                }
                // Pinned rows are exactly zero.
                for p in range.clone().filter(|p| p % 10 == 3) {
                    assert_eq!(got[0][p - range.start], 0.0);
                }
            }
        }
    }

    #[test]
    #[should_panic(expected = "beyond the pad")]
    fn a_stream_reaching_past_the_pad_is_refused() {
        let c = case(50);
        let mut streams = c.streams();
        streams[0].delta = 17;
        let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; 50]);
        let [x, y, z] = &mut out;
        reference(&c.product(), streams.into_iter(), c.d(), [x, y, z], 0..50);
    }
}
