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
//! *stream* indexed by the lower particle, each block kept in the form it
//! is made in, `C = t I + s u uᵀ` ([`RankBlocks`]), and the vectors are
//! stored component by component ([`Soa`]). A product then runs over
//! contiguous arrays with no index lists: with AVX-512, sixteen particles
//! at a time gather the terms of every stream in registers
//! (`simd::gather`), with AVX2 and FMA eight at a time;
//! elsewhere each stream's products are formed and scattered to both ends
//! in loops the compiler turns into SIMD. On a 64×64 cloth a product takes
//! about 21 µs (23–24.5 µs in AVX2; 29 µs for the scattered streams of
//! six-component blocks, 70 for the pair list of 3×3 blocks before
//! them). Pairs with any other step (crease springs,
//! hand-made connections) or a second block on one slot go through a short
//! pair list. Nothing assumes the pairs form a grid: a missing pair is a
//! zero block. A cloth that is not a grid takes streams for the steps that
//! a quarter or more of its particles' pairs share ([`common_steps`]), and
//! keeps the rest in the pair list.

use std::ops::Range;

use bevy::math::{DVec3, Mat3, Vec3, Vec3A};

use super::bodies::Coupling;
use crate::sim::model::jacobian::Block;
use crate::sim::soa::Aligned;
pub(super) use crate::sim::soa::Soa;
use crate::simd::gather::{Blocks, Product};
use crate::simd::{self, Level};

/// `Σ aᵢ·bᵢ` in f64, summed in eight f32 lanes over runs short enough to
/// keep six significant digits, so that the inner loop vectorises.
#[inline(always)]
pub(super) fn dot(a: &Soa, b: &Soa) -> f64 {
    dot_parts(
        a.0.each_ref().map(|c| &c[..]),
        b.0.each_ref().map(|c| &c[..]),
    )
}

/// [`dot`] of vectors given as their three component arrays.
#[inline(always)]
pub(super) fn dot_parts(a: [&[f32]; 3], b: [&[f32]; 3]) -> f64 {
    const LANES: usize = 8;
    const RUN: usize = 32 * LANES;
    let mut total = 0.0f64;
    for (x, y) in a.into_iter().zip(b) {
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
pub(super) struct SymBlocks(pub [Aligned; 6]);

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

/// The blocks of one stream in the form they are made in,
/// `C = t I + s u uᵀ` (MODEL.md §2: a link's `αD + βK` acts along its
/// direction `u` and equally across it): `t` and `s` in kg, `u` a unit
/// vector. Five numbers rather than six, and a product of 13 operations
/// rather than 15. A slot whose `t` and `s` are both 0 holds no block.
#[derive(Clone, Debug, Default)]
pub(super) struct RankBlocks {
    t: Aligned,
    s: Aligned,
    u: [Aligned; 3],
    /// Whether any `t` is not 0 (Type 2 streams have none by default),
    /// else the product skips it.
    transverse: bool,
}

impl RankBlocks {
    /// Sizes the arrays to `n` slots, keeping what they held.
    fn resize(&mut self, n: usize) {
        for c in [&mut self.t, &mut self.s].into_iter().chain(&mut self.u) {
            c.resize(n, 0.0);
        }
    }

    /// Zeroes every slot outside `keep`.
    fn zero_outside(&mut self, keep: Range<usize>) {
        for c in [&mut self.t, &mut self.s].into_iter().chain(&mut self.u) {
            let end = c.len();
            c[..keep.start.min(end)].fill(0.0);
            c[keep.end.min(end)..].fill(0.0);
        }
    }

    fn is_free(&self, i: usize) -> bool {
        self.t[i] == 0.0 && self.s[i] == 0.0
    }

    fn set(&mut self, i: usize, t: f32, s: f32, u: [f32; 3]) {
        (self.t[i], self.s[i]) = (t, s);
        for (c, u) in self.u.iter_mut().zip(u) {
            c[i] = u;
        }
    }

    /// The six components of the block at `i`.
    #[cfg(test)]
    fn sym(&self, i: usize) -> [f32; 6] {
        sym_of(self.t[i], self.s[i], std::array::from_fn(|k| self.u[k][i]))
    }
}

/// Adds the block `c` of the pair `(p, q)` to the pair list and to both
/// ends' diagonal blocks.
fn push_other(
    others: &mut Vec<([u32; 2], [f32; 6])>,
    diag: &mut SymBlocks,
    (p, q): (usize, usize),
    c: [f32; 6],
) {
    others.push(([p as u32, q as u32], c));
    diag.add(p, &c);
    diag.add(q, &c);
}

/// The block `C = αD + βK = t I + s u uᵀ` of a Jacobian block as `(t, s,
/// u)`, or `None` if it is zero (a dropped slack link, or an undamped,
/// unstiff one, adds nothing).
#[inline(always)]
pub(super) fn rank_block(blk: &Block, alpha: f32, beta: f32) -> Option<(f32, f32, [f32; 3])> {
    let t = beta * blk.transverse;
    let s = beta * blk.axial + alpha * blk.damping - t;
    (t != 0.0 || s != 0.0).then(|| (t, s, blk.u.to_array()))
}

/// The components (xx, yy, zz, xy, xz, yz) of `t I + s u uᵀ`.
#[inline(always)]
pub(super) fn sym_of(t: f32, s: f32, u: [f32; 3]) -> [f32; 6] {
    let su = [s * u[0], s * u[1], s * u[2]];
    [
        t + su[0] * u[0],
        t + su[1] * u[1],
        t + su[2] * u[2],
        su[0] * u[1],
        su[0] * u[2],
        su[1] * u[2],
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
/// singular: the cofactors of its columns `x`, `y`, `z` over the
/// determinant `z · (x × y)`. A particle's block is its mass (kg) plus its
/// links' stiffness times `h²` (kg), and the links of a flat cloth lie in
/// its plane, so across it the block holds the mass alone: for a light
/// particle with stiff links (a copy a tear splits off takes a share of
/// the particle's mass, by area, that may be small) its eigenvalues differ
/// by five orders of magnitude or more, and cofactors in f32 can lose the
/// mass to rounding and give the inverse of a positive definite block a
/// negative eigenvalue, which stops the conjugate gradient with a negative
/// `rᵀP⁻¹r`. An inverse that comes out so is formed again in f64. Written
/// out rather than left to the math library, whose formula may change
/// between versions: the preconditioner, and with it every implicit step,
/// keeps the same bits.
pub(super) fn sym_inverse(s: [f32; 6]) -> [f32; 6] {
    let m = sym_matrix(&s);
    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
    let (yz, zx, xy) = (y.cross(z), z.cross(x), x.cross(y));
    let det = z.dot(xy);
    if det.abs() > 1e-30 && det.is_finite() {
        let inv = det.recip();
        // The inverse is symmetric: its columns are the cofactors' rows.
        let [a, b, c] = [yz * inv, zx * inv, xy * inv];
        let inverse = [a.x, b.y, c.z, a.y, a.z, b.z];
        if positive_definite(inverse.map(f64::from)) {
            return inverse;
        }
        if let Some(inverse) = sym_inverse_f64(s) {
            return inverse;
        }
    }
    [1.0 / s[0], 1.0 / s[1], 1.0 / s[2], 0.0, 0.0, 0.0]
}

/// [`sym_inverse`] in f64, rounded to f32; `None` if `s` is singular.
fn sym_inverse_f64(s: [f32; 6]) -> Option<[f32; 6]> {
    let [xx, yy, zz, xy, xz, yz] = s.map(f64::from);
    let (x, y, z) = (
        DVec3::new(xx, xy, xz),
        DVec3::new(xy, yy, yz),
        DVec3::new(xz, yz, zz),
    );
    let (yz, zx, xy) = (y.cross(z), z.cross(x), x.cross(y));
    let det = z.dot(xy);
    (det.abs() > 1e-30 && det.is_finite()).then(|| {
        let inv = det.recip();
        let [a, b, c] = [yz * inv, zx * inv, xy * inv];
        [a.x, b.y, c.z, a.y, a.z, b.z].map(|v| v as f32)
    })
}

/// Whether the symmetric matrix with components `s` (xx, yy, zz, xy, xz,
/// yz) is positive definite: its leading minors are positive.
fn positive_definite(s: [f64; 6]) -> bool {
    let [xx, yy, zz, xy, xz, yz] = s;
    let minor = xx * yy - xy * xy;
    let det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz);
    xx > 0.0 && minor > 0.0 && det > 0.0
}

/// The operator of one step, its block-Jacobi preconditioner and scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct Operator {
    /// Index steps of the streams.
    deltas: Vec<usize>,
    /// Per stream, the block of pair `(p, p + δ)` at `pad + p` (zero where
    /// there is none, in the `pad` entries before the first and in the
    /// [`LANES`] after the last).
    streams: Vec<RankBlocks>,
    /// The largest `δ` rounded up to [`LANES`] (particles, so that the
    /// gathered product's loads of a particle's own values line up with
    /// the arrays' starts): the zeros before every stream and on both
    /// sides of `padded`, so that the gathered products read `p ± δ` of
    /// any particle within the arrays.
    pad: usize,
    /// The vector being multiplied, with `pad` zeros before it and
    /// `pad + LANES` after (AVX-512 product only).
    padded: Soa,
    /// Pairs outside the streams, with their blocks.
    others: Vec<([u32; 2], [f32; 6])>,
    /// Blocks added to single particles' diagonal blocks (contacts held by
    /// the solve), sorted by particle; set before [`Operator::build_with`].
    pub(super) extra: Vec<(u32, [f32; 6])>,
    /// The free bodies behind held contacts, moved within the solve; set
    /// with [`extra`](Self::extra).
    pub(super) coupling: Coupling,
    /// `M(1 + αc)` of free particles, 0 for pinned ones (kg).
    mass: Aligned,
    /// 1 for a free particle, 0 for a pinned one.
    pub free: Aligned,
    /// Inverses of `A`'s 3×3 diagonal blocks (identity for pins).
    precond: SymBlocks,
    /// Products of one stream.
    tmp: Soa,
    /// The vector being multiplied, particle by particle, and the pair
    /// list's sums, for the pairs outside the streams.
    gathered: Vec<Vec3A>,
    sums: Vec<Vec3A>,
    /// The streams of a cloth that is not a grid ([`common_steps`]), and
    /// the counts of particles and of force streams they were chosen for.
    common: ((usize, usize), Vec<usize>),
    /// Keeps every pair of a cloth that is not a grid in the pair list
    /// (the tests compare the two forms).
    pub(super) list_only: bool,
}

impl Operator {
    /// `out = A d` (filtered: pinned rows zero).
    pub fn apply(&mut self, d: &Soa, out: &mut Soa) {
        self.apply_at(simd::level(), d, out);
    }

    /// [`Operator::apply`] with the kernels of `level`: gathered per
    /// particle with AVX-512 (on a 64×64 cloth about 15 µs a product) or
    /// AVX2 and FMA (23–24.5 µs), else scattered by stream (29–31 µs, on a
    /// 2-core x86-64).
    pub(super) fn apply_at(&mut self, level: Level, d: &Soa, out: &mut Soa) {
        if level > Level::Scalar {
            self.fill_padded(d);
            let n = self.mass.len();
            let padded = self.padded.0.each_ref().map(|c| &c[..]);
            let rows = out.0.each_mut().map(|c| &mut c[..n]);
            let (product, blocks) = (self.product(), self.blocks());
            if simd::gather::gather(level, &product, blocks, padded, rows, 0..n) {
                self.apply_others(d, out);
                return;
            }
        }
        self.apply_portable(d, out);
    }

    /// The masses, filter and pad, as the gathered product reads them.
    pub(super) fn product(&self) -> Product<'_> {
        Product {
            mass: &self.mass,
            free: &self.free,
            pad: self.pad,
        }
    }

    /// The streams, as the gathered product reads them.
    pub(super) fn blocks(&self) -> impl Iterator<Item = Blocks<'_>> + Clone {
        self.deltas
            .iter()
            .zip(&self.streams)
            .map(|(&delta, c)| Blocks {
                delta,
                t: &c.t,
                s: &c.s,
                u: c.u.each_ref().map(|u| &u[..]),
                transverse: c.transverse,
            })
    }

    /// [`Operator::apply`] by streams scattered to both ends, in the SIMD
    /// width of its caller: the product on CPUs without AVX2 and FMA.
    #[inline(always)]
    pub(super) fn apply_portable(&mut self, d: &Soa, out: &mut Soa) {
        let n = self.mass.len();
        for (o, x) in out.0.iter_mut().zip(&d.0) {
            for ((o, &x), &m) in o.iter_mut().zip(x).zip(&self.mass) {
                *o = m * x;
            }
        }
        for (&delta, blocks) in self.deltas.iter().zip(&self.streams) {
            let m = n - delta;
            stream_product(blocks, self.pad, d, delta, m, &mut self.tmp);
            // t_p = C(d_p − d_{p+δ}): out_p += t_p, out_{p+δ} −= t_p.
            out.add_pairs(0, delta, &self.tmp, m);
        }
        out.filter(&self.free);
        self.apply_others(d, out);
    }

    /// Adds the pairs outside the streams and the [`extra`](Self::extra)
    /// diagonal blocks to `out = A d`, filtered. The pairs (most of a
    /// mesh cloth's) run over the vector copied particle by particle, so
    /// each end is one load and one store rather than three.
    fn apply_others(&mut self, d: &Soa, out: &mut Soa) {
        if !self.others.is_empty() {
            let n = self.mass.len();
            let [dx, dy, dz] = &d.0;
            self.gathered.clear();
            self.gathered
                .extend((0..n).map(|i| Vec3A::new(dx[i], dy[i], dz[i])));
            self.sums.clear();
            self.sums.resize(n, Vec3A::ZERO);
            let (x, sums) = (&self.gathered, &mut self.sums);
            for &([p, q], c) in &self.others {
                let (p, q) = (p as usize, q as usize);
                let t = sym_times_a(&c, x[q] - x[p]);
                sums[p] -= t;
                sums[q] += t;
            }
            let [ox, oy, oz] = &mut out.0;
            for (i, (t, &f)) in self.sums.iter().zip(&self.free).enumerate() {
                ox[i] += f * t.x;
                oy[i] += f * t.y;
                oz[i] += f * t.z;
            }
        }
        for &(i, c) in &self.extra {
            let i = i as usize;
            out.set(i, out.get(i) + self.free[i] * sym_times(&c, d.get(i)));
        }
        self.coupling.apply(d, out, &self.free);
    }

    /// Adds the [`extra`](Self::extra) diagonal blocks of the particles
    /// `first..first + d[0].len()` to `out = A d` there (the slices start at
    /// `first`), filtered.
    pub(super) fn add_extra_part(&self, d: [&[f32]; 3], out: [&mut [f32]; 3], first: usize) {
        let end = first + d[0].len();
        let start = self.extra.partition_point(|&(i, _)| (i as usize) < first);
        let [ox, oy, oz] = out;
        for &(i, c) in self.extra[start..]
            .iter()
            .take_while(|(i, _)| (*i as usize) < end)
        {
            let k = i as usize - first;
            let t = self.free[i as usize] * sym_times(&c, Vec3::new(d[0][k], d[1][k], d[2][k]));
            ox[k] += t.x;
            oy[k] += t.y;
            oz[k] += t.z;
        }
    }

    /// Copies `d` into [`Operator::padded`](Self) (the gathered product
    /// checks the lengths it relies on).
    pub(super) fn fill_padded(&mut self, d: &Soa) {
        let (n, pad) = (self.mass.len(), self.pad);
        for (p, x) in self.padded.0.iter_mut().zip(&d.0) {
            p[pad..pad + n].copy_from_slice(&x[..n]);
        }
    }

    /// Asserts what the gathered products' loads rely on: every stream
    /// holds `pad + n + LANES` values and `padded` `n + 2·pad + LANES`.
    pub(super) fn check_padded(&self, padded: &Soa) {
        let (n, pad) = (self.mass.len(), self.pad);
        let streams_fit = self
            .streams
            .iter()
            .flat_map(|s| [&s.t, &s.s].into_iter().chain(&s.u));
        assert!(streams_fit.into_iter().all(|c| c.len() >= pad + n + LANES));
        assert!(padded.0.iter().all(|c| c.len() >= n + 2 * pad + LANES));
        assert!(self.free.len() == n);
    }

    /// The zeros before a padded vector's values (particles).
    pub(super) fn pad(&self) -> usize {
        self.pad
    }

    /// Lends out the padded vector (for a product split between threads).
    pub(super) fn take_padded(&mut self) -> Soa {
        std::mem::take(&mut self.padded)
    }

    /// Takes back what [`Operator::take_padded`] lent.
    pub(super) fn put_padded(&mut self, padded: Soa) {
        self.padded = padded;
    }

    /// `Σ M(1 + αc)` over the free particles, kg.
    pub(super) fn total_mass(&self) -> f64 {
        self.mass.iter().map(|&m| m as f64).sum()
    }

    /// Whether the gathered product (`simd::gather`) alone is the
    /// product: every pair is in a stream, and no free body is coupled.
    pub(super) fn streams_only(&self) -> bool {
        self.others.is_empty() && self.coupling.is_empty()
    }

    /// `y = B⁻¹ r` for the block-Jacobi preconditioner `B`.
    #[inline(always)]
    pub fn precondition(&self, r: &Soa, y: &mut Soa) {
        let [rx, ry, rz] = &r.0;
        let [yx, yy, yz] = &mut y.0;
        self.precondition_part([rx, ry, rz], [yx, yy, yz], 0);
    }

    /// [`Operator::precondition`] of the particles from `first` on, as many
    /// as `r` holds.
    #[inline(always)]
    pub(super) fn precondition_part(
        &self,
        [rx, ry, rz]: [&[f32]; 3],
        [yx, yy_, yz_]: [&mut [f32]; 3],
        first: usize,
    ) {
        let n = rx.len();
        let [xx, yy, zz, xy, xz, yz] = self.precond.0.each_ref().map(|c| &c[first..first + n]);
        let (ry, rz) = (&ry[..n], &rz[..n]);
        let (yx, yy_, yz_) = (&mut yx[..n], &mut yy_[..n], &mut yz_[..n]);
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
                let c = s.sym(self.pad + p);
                if c != [0.0; 6] {
                    out.push((p, p + delta, c));
                }
            }
        }
        out
    }

    /// The index steps of the streams (for tests).
    #[cfg(test)]
    pub fn steps(&self) -> &[usize] {
        &self.deltas
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

/// `C v` for a symmetric `C`, on aligned vectors.
#[inline(always)]
fn sym_times_a(c: &[f32; 6], v: Vec3A) -> Vec3A {
    let [xx, yy, zz, xy, xz, yz] = *c;
    Vec3A::new(xx, xy, xz) * v.x + Vec3A::new(xy, yy, yz) * v.y + Vec3A::new(xz, yz, zz) * v.z
}

/// Particles of one AVX-512 vector, and the zeros after every stream.
const LANES: usize = simd::gather::LANES;

/// `t_p = C_p (d_p − d_{p+δ})` for `p < m`, into `t`, with `C_p` at
/// `pad + p` of the stream `c`.
#[inline(always)]
fn stream_product(c: &RankBlocks, pad: usize, d: &Soa, delta: usize, m: usize, t: &mut Soa) {
    let (ct, cs) = (&c.t[pad..pad + m], &c.s[pad..pad + m]);
    let [ux, uy, uz] = c.u.each_ref().map(|u| &u[pad..pad + m]);
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
        let k = cs[p] * (ux[p] * ex + uy[p] * ey + uz[p] * ez);
        tx[p] = ct[p] * ex + k * ux[p];
        ty[p] = ct[p] * ey + k * uy[p];
        tz[p] = ct[p] * ez + k * uz[p];
    }
}

mod build;

#[cfg(test)]
mod tests {
    use super::*;

    /// The written-out inverse inverts (to rounding), and falls back to
    /// the diagonal's inverse for a singular block.
    #[test]
    fn sym_inverse_inverts_a_block_and_survives_a_singular_one() {
        for s in [
            [4.0, 5.0, 6.0, 1.0, 0.5, -0.25],
            [1e-3, 2e-3, 3e-3, 1e-4, 0.0, 2e-4],
            [1e4, 1.0, 1.0, 0.0, 0.0, 0.0],
        ] {
            let product = sym_matrix(&sym_inverse(s)) * sym_matrix(&s);
            assert!(
                product.abs_diff_eq(Mat3::IDENTITY, 1e-5),
                "{s:?}: {product}"
            );
        }
        // Rank one: the determinant is 0.
        let singular = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        assert_eq!(sym_inverse(singular), [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]);
    }
}
