//! The operator's product in AVX-512 and in AVX2 with FMA: each particle
//! gathers the terms of every stream with its sums in registers
//! (see [`Operator::apply`]).

use std::ops::Range;

use super::{LANES, Operator, Soa};

/// A product kernel over a range of particles
/// ([`Operator::gather_range_avx512`], [`Operator::gather_range_avx2`]).
#[cfg(target_arch = "x86_64")]
type RangeKernel = unsafe fn(&Operator, [*const f32; 3], [*mut f32; 3], Range<usize>);

#[cfg(target_arch = "x86_64")]
impl Operator {
    /// [`Operator::apply`] in AVX-512, sixteen particles at a time: each
    /// gathers `M(1 + αc) d_p + Σ_δ C_δ[p](d_p − d_{p+δ}) + C_δ[p−δ](d_p −
    /// d_{p−δ})` over the streams with its sums in registers, and writes
    /// them once. Where [`apply_portable`](Self::apply_portable) forms each
    /// stream's products and scatters them to both ends, this loads about
    /// half as much and stores an eighth: on a 64×64 cloth about 15 µs a
    /// product rather than 29.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    pub(super) fn gather_avx512(&mut self, d: &Soa, out: &mut Soa) {
        // SAFETY: this function's own target feature is the kernel's.
        unsafe { self.gather_whole(d, out, Self::gather_range_avx512) }
    }

    /// `out = A d` by a range kernel over all particles, then the pairs
    /// outside the streams.
    ///
    /// # Safety
    /// The CPU has the features `kernel` is compiled for.
    #[inline(always)]
    unsafe fn gather_whole(&mut self, d: &Soa, out: &mut Soa, kernel: RangeKernel) {
        self.fill_padded(d);
        let n = self.mass.len();
        assert!(out.0.iter().all(|c| c.len() >= n));
        let padded = self.padded.0.each_ref().map(|c| c.as_ptr());
        let outs = out.0.each_mut().map(|c| c.as_mut_ptr());
        // SAFETY: `fill_padded` checked the lengths, `out` is ours, and the
        // caller vouches for the CPU.
        unsafe { kernel(self, padded, outs, 0..n) };
        self.apply_others(d, out);
    }

    /// Rows `range` of the product (streams only) of the padded vector at
    /// `d` (laid out as `padded`), written to `out`.
    ///
    /// # Safety
    /// The CPU has AVX-512F; [`Operator::check_padded`] holds for `d`;
    /// `out` points to three arrays of at least `n` values whose `range`
    /// no one else reads or writes meanwhile, and no one writes `d`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    pub(in crate::integrate::implicit) unsafe fn gather_range_avx512(
        &self,
        [dx, dy, dz]: [*const f32; 3],
        out: [*mut f32; 3],
        range: Range<usize>,
    ) {
        use std::arch::x86_64::*;
        let (end, pad) = (range.end, self.pad);
        for start in range.step_by(LANES) {
            // The lanes of particles up to the last.
            let mask: __mmask16 = if end - start >= LANES {
                !0
            } else {
                (1 << (end - start)) - 1
            };
            // SAFETY: indices within the lengths the caller vouches for
            // (the masked loads and stores touch lanes below `end` only).
            unsafe {
                let at = |c: *const f32, i: usize| _mm512_loadu_ps(c.add(i));
                let here = pad + start;
                let (ax, ay, az) = (at(dx, here), at(dy, here), at(dz, here));
                let mass = _mm512_maskz_loadu_ps(mask, self.mass.as_ptr().add(start));
                let mut sx = _mm512_mul_ps(mass, ax);
                let mut sy = _mm512_mul_ps(mass, ay);
                let mut sz = _mm512_mul_ps(mass, az);
                for (&delta, c) in self.deltas.iter().zip(&self.streams) {
                    let (t, s) = (c.t.as_ptr(), c.s.as_ptr());
                    let [ux, uy, uz] = c.u.each_ref().map(|c| c.as_ptr());
                    // C_δ[p] (pair p, p + δ) with e = d_p − d_{p+δ}, then
                    // C_δ[p − δ] (pair p − δ, p) with e = d_p − d_{p−δ}:
                    // C e = t e + s (u·e) u.
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
                let free = _mm512_maskz_loadu_ps(mask, self.free.as_ptr().add(start));
                let keep = _mm512_mask_cmp_ps_mask::<_CMP_NEQ_UQ>(mask, free, _mm512_setzero_ps());
                for (o, s) in out.into_iter().zip([sx, sy, sz]) {
                    _mm512_mask_storeu_ps(o.add(start), mask, _mm512_maskz_mov_ps(keep, s));
                }
            }
        }
    }

    /// [`Operator::gather_avx512`] in AVX2 and FMA, eight particles at a
    /// time, for the many CPUs without AVX-512: on a 2-core x86-64
    /// 23–24.5 µs per 64×64 product against 30.4–31.2 µs for the scattered
    /// streams compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(in crate::integrate::implicit) fn gather_avx2(&mut self, d: &Soa, out: &mut Soa) {
        // SAFETY: this function's own target features are the kernel's.
        unsafe { self.gather_whole(d, out, Self::gather_range_avx2) }
    }

    /// [`Operator::gather_range_avx512`] in AVX2 and FMA.
    ///
    /// # Safety
    /// As for [`Operator::gather_range_avx512`], with AVX2 and FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(in crate::integrate::implicit) unsafe fn gather_range_avx2(
        &self,
        [dx, dy, dz]: [*const f32; 3],
        out: [*mut f32; 3],
        range: Range<usize>,
    ) {
        use std::arch::x86_64::*;
        const WIDTH: usize = 8;
        let (end, pad) = (range.end, self.pad);
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        for start in range.step_by(WIDTH) {
            // All ones in the lanes of particles up to the last.
            let mask = _mm256_cmpgt_epi32(_mm256_set1_epi32((end - start) as i32), lane);
            // SAFETY: indices within the lengths the caller vouches for
            // (the masked loads and stores touch lanes below `end` only).
            unsafe {
                let at = |c: *const f32, i: usize| _mm256_loadu_ps(c.add(i));
                let here = pad + start;
                let (ax, ay, az) = (at(dx, here), at(dy, here), at(dz, here));
                let mass = _mm256_maskload_ps(self.mass.as_ptr().add(start), mask);
                let mut sx = _mm256_mul_ps(mass, ax);
                let mut sy = _mm256_mul_ps(mass, ay);
                let mut sz = _mm256_mul_ps(mass, az);
                for (&delta, c) in self.deltas.iter().zip(&self.streams) {
                    let (t, s) = (c.t.as_ptr(), c.s.as_ptr());
                    let [ux, uy, uz] = c.u.each_ref().map(|c| c.as_ptr());
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
                let free = _mm256_maskload_ps(self.free.as_ptr().add(start), mask);
                let keep = _mm256_cmp_ps::<_CMP_NEQ_UQ>(free, _mm256_setzero_ps());
                for (o, s) in out.into_iter().zip([sx, sy, sz]) {
                    _mm256_maskstore_ps(o.add(start), mask, _mm256_and_ps(s, keep));
                }
            }
        }
    }
}
