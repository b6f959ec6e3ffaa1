//! The implicit solver's matrix-free operator `A`, stored by grid offset.
//!
//! `(A d)_a = M_a(1 + αc) d_a + Σ_b C_ab (d_a − d_b)`, with one symmetric
//! block `C = αD_ab + βK_ab` per active connection (its blocks
//! `∂F_a/∂v_b`, `∂F_a/∂x_b`; MODEL.md §6.5) and the rows of pinned
//! particles zeroed (the filter).
//!
//! A grid cloth's connections join particles a fixed index step `δ = b − a`
//! apart: `1, 2` along a row, `columns ± 1`, `columns`, `2·columns ± 2`,
//! `2·columns` across. The blocks of all pairs with the same `δ` form a
//! *stream* indexed by the lower particle, stored component by component
//! (xx, yy, zz, xy, xz, yz), and the vectors are stored the same way
//! ([`Soa`]). A stream's product is then three loops over contiguous
//! arrays with no index lists, which the compiler turns into SIMD: on a
//! 64×64 cloth a product takes about 45 µs where the pair list of 3×3
//! blocks it replaced took about 70. Pairs with any other step (crease springs, hand-made
//! connections) go through a short pair list. Nothing assumes the pairs
//! form a grid: a missing pair is a zero block.

use bevy::math::{Mat3, Vec3};

use super::coarse::Coarse;
use crate::model::jacobian::Block;
pub(super) use crate::soa::Soa;

/// `Σ aᵢ·bᵢ` in f64, summed in eight f32 lanes over runs short enough to
/// keep six significant digits, so that the inner loop vectorises.
#[inline(always)]
pub(super) fn dot(a: &Soa, b: &Soa) -> f64 {
    const LANES: usize = 8;
    const RUN: usize = 32 * LANES;
    let mut total = 0.0f64;
    for (x, y) in a.0.iter().zip(&b.0) {
        for (xs, ys) in x.chunks(RUN).zip(y.chunks(RUN)) {
            let mut lanes = [0.0f32; LANES];
            let (xc, yc) = (xs.chunks_exact(LANES), ys.chunks_exact(LANES));
            let tail: f32 = xc
                .remainder()
                .iter()
                .zip(yc.remainder())
                .map(|(p, q)| p * q)
                .sum();
            for (xl, yl) in xc.zip(yc) {
                for k in 0..LANES {
                    lanes[k] += xl[k] * yl[k];
                }
            }
            total += (lanes.iter().sum::<f32>() + tail) as f64;
        }
    }
    total
}

/// Symmetric 3×3 blocks, component by component: xx, yy, zz, xy, xz, yz.
#[derive(Clone, Debug, Default)]
pub(super) struct SymBlocks(pub [Vec<f32>; 6]);

impl SymBlocks {
    fn reset(&mut self, n: usize) {
        for c in &mut self.0 {
            c.clear();
            c.resize(n, 0.0);
        }
    }

    fn add(&mut self, i: usize, s: &[f32; 6]) {
        for (c, v) in self.0.iter_mut().zip(s) {
            c[i] += v;
        }
    }

    fn get(&self, i: usize) -> [f32; 6] {
        std::array::from_fn(|k| self.0[k][i])
    }
}

/// The six components of a symmetric matrix.
fn sym(m: Mat3) -> [f32; 6] {
    [
        m.x_axis.x, m.y_axis.y, m.z_axis.z, m.y_axis.x, m.z_axis.x, m.z_axis.y,
    ]
}

/// The symmetric matrix whose six components are `s`.
pub(super) fn sym_matrix(s: &[f32; 6]) -> Mat3 {
    let [xx, yy, zz, xy, xz, yz] = *s;
    Mat3::from_cols(
        Vec3::new(xx, xy, xz),
        Vec3::new(xy, yy, yz),
        Vec3::new(xz, yz, zz),
    )
}

/// The inverse of the symmetric matrix `s`, or of its diagonal if it is
/// singular.
fn sym_inverse(s: [f32; 6]) -> [f32; 6] {
    let [xx, yy, zz, ..] = s;
    let m = sym_matrix(&s);
    let det = m.determinant();
    if det.abs() > 1e-30 && det.is_finite() {
        sym(m.inverse())
    } else {
        [1.0 / xx, 1.0 / yy, 1.0 / zz, 0.0, 0.0, 0.0]
    }
}

/// The operator of one step, its block-Jacobi preconditioner and scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct Operator {
    /// Index steps of the streams.
    deltas: Vec<usize>,
    /// Per stream, the block of pair `(p, p + δ)` at `p` (zero where there
    /// is none).
    streams: Vec<SymBlocks>,
    /// Pairs outside the streams, with their blocks.
    others: Vec<([u32; 2], [f32; 6])>,
    /// `M(1 + αc)` of free particles, 0 for pinned ones (kg).
    mass: Vec<f32>,
    /// 1 for a free particle, 0 for a pinned one.
    pub free: Vec<f32>,
    /// Inverses of `A`'s 3×3 diagonal blocks (identity for pins).
    precond: SymBlocks,
    /// Products of one stream.
    tmp: Soa,
}

impl Operator {
    /// Builds `A` from the Jacobian `blocks` as `C = αD + βK`, the mass
    /// scale `1 + αc` and the inverse masses (1/kg, 0 pins); feeds every
    /// pair to `coarse` when given. `columns` is the grid's row length (0
    /// for none).
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        columns: usize,
        inverse_masses: &[f32],
        mass_scale: f32,
        blocks: &[Block],
        alpha: f32,
        beta: f32,
        mut coarse: Option<&mut Coarse>,
    ) {
        let n = inverse_masses.len();
        self.deltas.clear();
        if columns > 0 {
            let c = columns;
            for d in [1, 2, c - 1, c, c + 1, 2 * c - 2, 2 * c, 2 * c + 2] {
                if d > 0 && d < n && !self.deltas.contains(&d) {
                    self.deltas.push(d);
                }
            }
        }
        self.streams
            .resize_with(self.deltas.len(), SymBlocks::default);
        for s in &mut self.streams {
            s.reset(n);
        }
        self.others.clear();
        let mut diag = std::mem::take(&mut self.precond);
        diag.reset(n);
        for blk in blocks {
            // C = αD + βK = t I + s u uᵀ.
            let t = beta * blk.transverse;
            let s = beta * blk.axial + alpha * blk.damping - t;
            if t == 0.0 && s == 0.0 {
                // A dropped slack link (or an undamped, unstiff one) adds nothing.
                continue;
            }
            let u = blk.u;
            let su = s * u;
            let c = [
                t + su.x * u.x,
                t + su.y * u.y,
                t + su.z * u.z,
                su.x * u.y,
                su.x * u.z,
                su.y * u.z,
            ];
            let (p, q) = (blk.a.min(blk.b) as usize, blk.a.max(blk.b) as usize);
            match self.deltas.iter().position(|&d| d == q - p) {
                Some(s) => self.streams[s].add(p, &c),
                None => {
                    self.others.push(([p as u32, q as u32], c));
                    diag.add(p, &c);
                    diag.add(q, &c);
                }
            }
            if let Some(coarse) = coarse.as_deref_mut() {
                coarse.add_pair(p, q, &c);
            }
        }
        // The streams' blocks on the diagonal, both ends, a stream at a time.
        for (&delta, s) in self.deltas.iter().zip(&self.streams) {
            for (diag, s) in diag.0.iter_mut().zip(&s.0) {
                for (d, &c) in diag.iter_mut().zip(s) {
                    *d += c;
                }
                for (d, &c) in diag[delta..].iter_mut().zip(s) {
                    *d += c;
                }
            }
        }
        self.mass.clear();
        self.free.clear();
        for (i, &w) in inverse_masses.iter().enumerate() {
            let free = w != 0.0;
            let m = if free { mass_scale / w } else { 0.0 };
            self.mass.push(m);
            self.free.push(if free { 1.0 } else { 0.0 });
            let mut s = diag.get(i);
            for d in &mut s[..3] {
                *d += m;
            }
            let inv = if free {
                sym_inverse(s)
            } else {
                [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
            };
            for (c, v) in diag.0.iter_mut().zip(inv) {
                c[i] = v;
            }
        }
        self.precond = diag;
        self.tmp.resize(n);
    }

    /// `out = A d` (filtered: pinned rows zero).
    pub fn apply(&mut self, d: &Soa, out: &mut Soa) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, as checked on the line above.
            return unsafe { self.apply_avx512(d, out) };
        } else if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, as checked on the line above.
            return unsafe { self.apply_avx2(d, out) };
        }
        self.apply_portable(d, out);
    }

    /// [`Operator::apply`] compiled for AVX-512's sixteen-lane vectors.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn apply_avx512(&mut self, d: &Soa, out: &mut Soa) {
        self.apply_portable(d, out);
    }

    /// [`Operator::apply`] compiled for AVX2's eight-lane vectors: about
    /// 10% off a 64×64 frame over the baseline's four lanes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn apply_avx2(&mut self, d: &Soa, out: &mut Soa) {
        self.apply_portable(d, out);
    }

    #[inline(always)]
    fn apply_portable(&mut self, d: &Soa, out: &mut Soa) {
        let n = self.mass.len();
        for (o, x) in out.0.iter_mut().zip(&d.0) {
            for ((o, &x), &m) in o.iter_mut().zip(x).zip(&self.mass) {
                *o = m * x;
            }
        }
        for (&delta, blocks) in self.deltas.iter().zip(&self.streams) {
            let m = n - delta;
            stream_product(blocks, d, delta, m, &mut self.tmp);
            // t_p = C(d_p − d_{p+δ}): out_p += t_p, out_{p+δ} −= t_p.
            out.add_pairs(0, delta, &self.tmp, m);
        }
        for &([p, q], c) in &self.others {
            let (p, q) = (p as usize, q as usize);
            let t = sym_times(&c, d.get(q) - d.get(p));
            out.set(p, out.get(p) - t);
            out.set(q, out.get(q) + t);
        }
        out.filter(&self.free);
    }

    /// `y = B⁻¹ r` for the block-Jacobi preconditioner `B`.
    #[inline(always)]
    pub fn precondition(&self, r: &Soa, y: &mut Soa) {
        let [xx, yy, zz, xy, xz, yz] = &self.precond.0;
        let [rx, ry, rz] = &r.0;
        let [yx, yy_, yz_] = &mut y.0;
        let n = self.mass.len();
        for i in 0..n {
            let (a, b, c) = (rx[i], ry[i], rz[i]);
            yx[i] = xx[i] * a + xy[i] * b + xz[i] * c;
            yy_[i] = xy[i] * a + yy[i] * b + yz[i] * c;
            yz_[i] = xz[i] * a + yz[i] * b + zz[i] * c;
        }
    }

    /// Every pair and its block `C` (for tests against a dense matrix).
    #[cfg(test)]
    pub fn pairs(&self) -> Vec<(usize, usize, [f32; 6])> {
        let mut out: Vec<_> = self
            .others
            .iter()
            .map(|&([p, q], c)| (p as usize, q as usize, c))
            .collect();
        for (&delta, s) in self.deltas.iter().zip(&self.streams) {
            for p in 0..self.mass.len() - delta {
                let c = s.get(p);
                if c != [0.0; 6] {
                    out.push((p, p + delta, c));
                }
            }
        }
        out
    }

    /// `M(1 + αc)` per particle (kg), 0 for pins (for tests).
    #[cfg(test)]
    pub fn mass(&self) -> &[f32] {
        &self.mass
    }
}

/// `C v` for a symmetric `C`.
#[inline]
fn sym_times(c: &[f32; 6], v: Vec3) -> Vec3 {
    let [xx, yy, zz, xy, xz, yz] = *c;
    Vec3::new(
        xx * v.x + xy * v.y + xz * v.z,
        xy * v.x + yy * v.y + yz * v.z,
        xz * v.x + yz * v.y + zz * v.z,
    )
}

/// `t_p = C_p (d_p − d_{p+δ})` for `p < m`, into `t`.
#[inline(always)]
fn stream_product(c: &SymBlocks, d: &Soa, delta: usize, m: usize, t: &mut Soa) {
    let [cxx, cyy, czz, cxy, cxz, cyz] = &c.0;
    let (cxx, cyy, czz) = (&cxx[..m], &cyy[..m], &czz[..m]);
    let (cxy, cxz, cyz) = (&cxy[..m], &cxz[..m], &cyz[..m]);
    let [dx, dy, dz] = &d.0;
    let (ax, ay, az) = (&dx[..m], &dy[..m], &dz[..m]);
    let (bx, by, bz) = (
        &dx[delta..delta + m],
        &dy[delta..delta + m],
        &dz[delta..delta + m],
    );
    let [tx, ty, tz] = &mut t.0;
    let (tx, ty, tz) = (&mut tx[..m], &mut ty[..m], &mut tz[..m]);
    for p in 0..m {
        let (ex, ey, ez) = (ax[p] - bx[p], ay[p] - by[p], az[p] - bz[p]);
        tx[p] = cxx[p] * ex + cxy[p] * ey + cxz[p] * ez;
        ty[p] = cxy[p] * ex + cyy[p] * ey + cyz[p] * ez;
        tz[p] = cxz[p] * ex + cyz[p] * ey + czz[p] * ez;
    }
}
