//! The implicit integrators' linearisation of the grid families, by
//! stream: forces, `K w` and the blocks `C = αD + βK` of every slot in one
//! SIMD pass per stream, where [`assemble`](crate::sim::model::jacobian::assemble)
//! builds a list of [`Block`](crate::sim::model::jacobian::Block)s link by link
//! and the solver's operator then sorts them into its own streams.
//!
//! The blocks are those of [`model::jacobian`](crate::sim::model::jacobian),
//! formed with the same choices (slack Type 1 axial term, dropped or full
//! Type 2 transverse term, Lander's clamp); a slot without a link, or with
//! an inactive one, has a zero block.

use std::ops::Range;

use bevy::math::Vec3;

use super::{
    FamilyStreams, ForceStreams, LANES, Soa, Stream, accumulate, gather, length_squared, scatter,
    window,
};
use crate::sim::connections::Link;
use crate::sim::model::choi_ko::{BucklingTable, MIN_LENGTH};
use crate::sim::model::kernel::Law;

/// How the blocks are formed: `C = αD + βK` and the choices of
/// [`model::jacobian`](crate::sim::model::jacobian).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Linearisation {
    /// `α`, the factor of `D = ∂F/∂v` (s).
    pub alpha: f32,
    /// `β`, the factor of `K = ∂F/∂x` (s²).
    pub beta: f32,
    /// Whether a slack Type 1 link keeps its axial stiffness.
    pub keep_slack: bool,
    /// Whether the negative transverse terms are kept (Type 2's, Lander's
    /// compressed springs').
    pub full: bool,
    /// Whether half of the families' slot values may be formed on the
    /// helper thread ([`crate::sim::team`]); the result is the same either way.
    pub split: bool,
}

/// The blocks of one stream: the pair `(lo + i, lo + i + delta)` has the
/// block `C = t[i] I + s[i] u uᵀ` with `u = (u[0][i], u[1][i], u[2][i])`
/// (`t`, `s` in kg like the operator), zero (`t = s = 0`) where the slot
/// holds no active link.
pub(crate) struct StreamBlocks<'a> {
    /// Index step of the stream.
    pub delta: usize,
    /// Lower particle of slot 0.
    pub lo: usize,
    /// `t` of each slot.
    pub t: &'a [f32],
    /// `s` of each slot.
    pub s: &'a [f32],
    /// The link's unit vector, by component.
    pub u: [&'a [f32]; 3],
}

/// The inputs of [`ForceStreams::linearise_synced`].
#[derive(Clone, Copy)]
struct Input<'a> {
    families: &'a [(&'a [Link], Law<'a>)],
    x: &'a [Vec3],
    v: &'a [Vec3],
    w: &'a [Vec3],
    lin: Linearisation,
}

/// One stream's inputs, the particles at the lower (`a`) and upper (`b`)
/// ends of its slots, by component: positions, velocities and `w`.
struct Ends<'a> {
    x: [[&'a [f32]; 3]; 2],
    v: [[&'a [f32]; 3]; 2],
    w: [[&'a [f32]; 3]; 2],
}

/// The first `m` components of `q` at the lower ends `a` and upper ends `b`.
#[inline(always)]
fn ends<'a>(q: &'a Soa, a: &Range<usize>, b: &Range<usize>, m: usize) -> [[&'a [f32]; 3]; 2] {
    [window(q, a), window(q, b)].map(|e| e.map(|c| &c[..m]))
}

/// The inputs of a chunk of slots: the stream's [`Ends`] and `N` arrays of
/// per-slot values over the chunk alone.
struct Chunk<'a, const N: usize> {
    ends: Ends<'a>,
    per_slot: [&'a [f32]; N],
}

impl<'a> Ends<'a> {
    /// The `len` slots from `start`, with `per_slot` values over the whole
    /// stream.
    #[inline(always)]
    fn chunk<const N: usize>(
        &self,
        start: usize,
        len: usize,
        per_slot: [&'a [f32]; N],
    ) -> Chunk<'a, N> {
        let cut = |c: &'a [f32]| &c[start..start + len];
        // Written out: `array::map` here was not inlined, and this runs per
        // chunk of sixteen slots (1.5 % of a 64×64 frame by `perf`).
        let cut_ends = |&[[a0, a1, a2], [b0, b1, b2]]: &[[&'a [f32]; 3]; 2]| {
            [[cut(a0), cut(a1), cut(a2)], [cut(b0), cut(b1), cut(b2)]]
        };
        Chunk {
            ends: Ends {
                x: cut_ends(&self.x),
                v: cut_ends(&self.v),
                w: cut_ends(&self.w),
            },
            per_slot: per_slot.map(cut),
        }
    }
}

/// Slots per chunk of the slot loops: one AVX-512 vector. A stream's
/// slots are a multiple of it, so every chunk is full and its copies out
/// are a few vector moves.
const CHUNK: usize = LANES;

/// Re-slices each named slice to its first `n` values, so that the
/// compiler sees every length and drops the bounds checks of a loop over
/// `0..n` (which then runs as SIMD).
macro_rules! cut {
    ($n:expr; $($s:ident),*) => {
        $(let $s = &$s[..$n];)*
    };
}

/// One stream's outputs for its `m` slots: the pair force on `a` (N) and
/// `(K w)_a` (N), and the block's `t`, `s` and `u`
/// ([`StreamBlocks`]).
struct Out<'a> {
    force: [&'a mut [f32]; 3],
    kw: [&'a mut [f32]; 3],
    c: [&'a mut [f32]; 5],
}

impl ForceStreams {
    /// Writes the forces (N) of the synced families into `f` and `K w` (N)
    /// into `kw`, both from zero, and keeps every stream's blocks for
    /// [`blocks`](Self::blocks). `x` in m, `v` in m/s, `w` in m (any
    /// vector `K` is to multiply). The links of the families that fit no
    /// stream ([`others`](Self::others)) are the caller's.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn linearise_synced(
        &mut self,
        families: &[(&[Link], Law)],
        x: &[Vec3],
        v: &[Vec3],
        w: &[Vec3],
        lin: Linearisation,
        f: &mut [Vec3],
        kw: &mut [Vec3],
    ) {
        let input = Input {
            families,
            x,
            v,
            w,
            lin,
        };
        linearise_at(crate::simd::level(), self, input, f, kw);
    }

    #[inline(always)]
    fn linearise_portable(&mut self, input: Input, f_out: &mut [Vec3], kw_out: &mut [Vec3]) {
        let Input {
            families,
            x,
            v,
            w,
            lin,
        } = input;
        let n = x.len();
        let span = self.span(n);
        let Self {
            families: caches,
            x: xs,
            v: vs,
            f,
            g,
            len,
            w: ws,
            kw,
            dg,
            second,
            ..
        } = self;
        for s in [&mut *xs, &mut *vs, &mut *f, &mut *ws, &mut *kw] {
            s.resize(span);
        }
        scatter(x, xs);
        scatter(v, vs);
        // Backward Euler multiplies `K` by the velocities themselves.
        let w_is_v = std::ptr::eq(w, v);
        if !w_is_v {
            scatter(w, ws);
        }
        let (xs, vs) = (&*xs, &*vs);
        let ws = if w_is_v { vs } else { &*ws };
        let count = caches.len().min(families.len());
        let (caches, families) = (&mut caches[..count], &families[..count]);
        let vectors = (xs, vs, ws);
        // The slot values of each stream are its own: with `split`, the
        // odd families on the helper thread and the even ones here, each
        // thread with its own scratch. Of Choi–Ko's four, each thread then
        // has a Type 1 family and a costlier Type 2 one (by halves, the
        // Type 1 families here took 60–75 µs a 64×64 step and the Type 2
        // ones there 150–170).
        let half = count / 2;
        let scratch_free = |fams: &[(&[Link], Law)]| {
            fams.iter()
                .all(|(_, law)| !matches!(law, Law::Buckling { .. }))
        };
        let one = |cache, family| (std::slice::from_mut(cache), std::slice::from_ref(family));
        if lin.split
            && let ([c0, c1, c2, c3], [f0, f1, f2, f3]) = (&mut *caches, families)
        {
            let [g2, dg2, len2] = second;
            crate::sim::team::both(
                || {
                    for (cache, family) in [one(c0, f0), one(c2, f2)] {
                        let scratch = (&mut *g2, &mut *dg2, &mut *len2);
                        Self::slot_values(cache, family, vectors, lin, Some(scratch));
                    }
                },
                || {
                    for (cache, family) in [one(c1, f1), one(c3, f3)] {
                        let scratch = (&mut *g, &mut *dg, &mut *len);
                        Self::slot_values(cache, family, vectors, lin, Some(scratch));
                    }
                },
            );
        } else if lin.split && half > 0 && scratch_free(&families[..half]) {
            let (first, second) = caches.split_at_mut(half);
            let (laws_first, laws_second) = families.split_at(half);
            let scratch = (g, dg, len);
            crate::sim::team::both(
                || Self::slot_values(first, laws_first, vectors, lin, None),
                || Self::slot_values(second, laws_second, vectors, lin, Some(scratch)),
            );
        } else {
            Self::slot_values(caches, families, vectors, lin, Some((g, dg, len)));
        }
        // Then every stream's pair values to both ends, in stream order:
        // with `split`, the forces here and `K w` on the helper.
        let sum = |out: &mut Soa, pick: fn(&Stream) -> &Soa| {
            out.zero();
            for s in caches.iter().flat_map(|c| &c.streams) {
                accumulate(s, pick(s), out);
            }
        };
        if lin.split {
            crate::sim::team::both(|| sum(f, |s| &s.pair), || sum(kw, |s| &s.pair_kw));
        } else {
            sum(f, |s| &s.pair);
            sum(kw, |s| &s.pair_kw);
        }
        gather(f, f_out);
        gather(kw, kw_out);
    }

    /// Writes every slot's pair force, `(K w)_a` and block into the streams
    /// of `caches` (one per law of `families`), from the component vectors
    /// `(x, v, w)`; `scratch` is for the buckling families' table lookups.
    /// Compiled for the widest SIMD the CPU has, as it may run on the
    /// helper thread.
    fn slot_values(
        caches: &mut [FamilyStreams],
        families: &[(&[Link], Law)],
        vectors: (&Soa, &Soa, &Soa),
        lin: Linearisation,
        scratch: Option<Scratch>,
    ) {
        let slots = Slots {
            caches,
            families,
            vectors,
            lin,
            scratch,
        };
        slot_values_at(crate::simd::level(), slots);
    }

    #[inline(always)]
    fn slot_values_inner(slots: Slots) {
        let Slots {
            caches,
            families,
            vectors: (xs, vs, ws),
            lin,
            mut scratch,
        } = slots;
        for (cache, &(_, law)) in caches.iter_mut().zip(families) {
            for stream in &mut cache.streams {
                let m = stream.slots();
                for c in &mut stream.blocks {
                    c.resize(m, 0.0);
                }
                let mut pair = std::mem::take(&mut stream.pair);
                let mut pair_kw = std::mem::take(&mut stream.pair_kw);
                let mut blocks = std::mem::take(&mut stream.blocks);
                let s = &*stream;
                let (a, b) = s.ends();
                let inputs = Ends {
                    x: ends(xs, &a, &b, m),
                    v: ends(vs, &a, &b, m),
                    w: ends(ws, &a, &b, m),
                };
                let slots = s.delta..s.delta + m;
                let out = Out {
                    force: pair.0.each_mut().map(|c| &mut c[slots.clone()]),
                    kw: pair_kw.0.each_mut().map(|c| &mut c[slots.clone()]),
                    c: blocks.each_mut().map(|c| &mut c[..m]),
                };
                match law {
                    Law::Tension { k, kd } => stretch_slots(s, &inputs, (k, kd, false), lin, out),
                    Law::Spring { ks, kd } => stretch_slots(s, &inputs, (ks, kd, true), lin, out),
                    Law::Buckling { table, kb, cb } => {
                        let Some((g, dg, len)) = scratch.as_mut() else {
                            unreachable!("the caller gives buckling families the scratch");
                        };
                        g.resize(m, 0.0);
                        dg.resize(m, 0.0);
                        len.resize(m, 0.0);
                        let scratch = (&mut g[..m], &mut dg[..m], &mut len[..m]);
                        buckle_slots(s, &inputs, (table, kb, cb), lin, scratch, out);
                    }
                }
                (stream.pair, stream.pair_kw, stream.blocks) = (pair, pair_kw, blocks);
            }
        }
    }

    /// The blocks of every stream at the last
    /// [`linearise_synced`](Self::linearise_synced).
    pub(crate) fn blocks(&self) -> impl Iterator<Item = StreamBlocks<'_>> + Clone {
        self.families.iter().flat_map(|c| &c.streams).map(|s| {
            let [t, sc, ux, uy, uz] = s.blocks.each_ref().map(|c| &c[..]);
            StreamBlocks {
                delta: s.delta,
                lo: s.lo,
                t,
                s: sc,
                u: [ux, uy, uz],
            }
        })
    }

    /// The links of family `k` that fit no stream.
    pub(crate) fn others(&self, k: usize) -> &[Link] {
        self.families.get(k).map_or(&[], |c| &c.others)
    }
}

crate::simd::multiversion! {
    /// [`ForceStreams::linearise_portable`] compiled for a SIMD level.
    fn linearise_at(this: &mut ForceStreams, input: Input, f: &mut [Vec3], kw: &mut [Vec3])
        = ForceStreams::linearise_portable;
}

crate::simd::multiversion! {
    /// [`ForceStreams::slot_values_inner`] compiled for a SIMD level.
    fn slot_values_at(slots: Slots) = ForceStreams::slot_values_inner;
}

impl Out<'_> {
    /// Copies a chunk's values, computed by [`values`] into `local`, to the
    /// slots from `start`: pair forces, `(K w)_a`, blocks.
    #[inline(always)]
    fn put(&mut self, start: usize, len: usize, local: &[[f32; CHUNK]; OUTPUTS]) {
        let outputs = self.force.iter_mut().chain(&mut self.kw).chain(&mut self.c);
        for (dst, src) in outputs.zip(local) {
            dst[start..start + len].copy_from_slice(&src[..len]);
        }
    }
}

/// The buckling families' scratch: `g`, `g′` and lengths per slot.
type Scratch<'a> = (&'a mut Vec<f32>, &'a mut Vec<f32>, &'a mut Vec<f32>);

/// The arguments of [`ForceStreams::slot_values`], in one bundle for its
/// builds for each SIMD width.
struct Slots<'a, 'b> {
    caches: &'a mut [FamilyStreams],
    families: &'a [(&'b [Link], Law<'b>)],
    vectors: (&'a Soa, &'a Soa, &'a Soa),
    lin: Linearisation,
    scratch: Option<Scratch<'a>>,
}

/// Values [`Out`] holds per slot.
const OUTPUTS: usize = 11;

/// What [`Out`] holds for one slot, from the pair force on `a` (N), the
/// link's unit vector `u`, `dw = w_b − w_a` (m) and the Jacobian's `axial`,
/// `transverse` (N/m) and `damping` (N·s/m): the force, `(K w)_a`, and the
/// block `C = αD + βK = t I + s u uᵀ` as `t`, `s`, `u`.
#[inline(always)]
fn values(
    [force, u, dw, [axial, transverse, damping]]: [[f32; 3]; 4],
    lin: Linearisation,
) -> [f32; OUTPUTS] {
    let ue = u[0] * dw[0] + u[1] * dw[1] + u[2] * dw[2];
    let along = (axial - transverse) * ue;
    let t = lin.beta * transverse;
    let s = lin.beta * axial + lin.alpha * damping - t;
    [
        force[0],
        force[1],
        force[2],
        transverse * dw[0] + along * u[0],
        transverse * dw[1] + along * u[1],
        transverse * dw[2] + along * u[2],
        t,
        s,
        u[0],
        u[1],
        u[2],
    ]
}

/// Type 1 (tension only) or, with `two_sided`, Lander's spring: the
/// Jacobian of [`model::jacobian`](crate::sim::model::jacobian)'s `stretch`, slot
/// by slot without a branch, a chunk at a time into a local array that
/// nothing can alias, so that the loop runs as SIMD. `k` in N/m, `kd` in
/// N·s/m.
#[inline(always)]
fn stretch_slots(
    s: &Stream,
    p: &Ends,
    (k, kd, two_sided): (f32, f32, bool),
    lin: Linearisation,
    mut out: Out,
) {
    let m = s.slots();
    let rest = &s.rest[..m];
    let mut local = [[0.0f32; CHUNK]; OUTPUTS];
    for start in (0..m).step_by(CHUNK) {
        let len = CHUNK;
        let c = p.chunk(start, len, [rest]);
        let [[xa, ya, za], [xb, yb, zb]] = c.ends.x;
        let [[va, vya, vza], [vb, vyb, vzb]] = c.ends.v;
        let [[wa, wya, wza], [wb, wyb, wzb]] = c.ends.w;
        let [rest] = c.per_slot;
        cut!(len; xa, ya, za, xb, yb, zb, va, vya, vza, vb, vyb, vzb);
        cut!(len; wa, wya, wza, wb, wyb, wzb, rest);
        for j in 0..len {
            let r = rest[j];
            let d = [xb[j] - xa[j], yb[j] - ya[j], zb[j] - za[j]];
            let len2 = length_squared(d);
            // An empty slot's NaN rest length fails every comparison.
            let valid = len2 >= MIN_LENGTH * MIN_LENGTH && !r.is_nan();
            let taut = valid && (two_sided || len2 >= r * r);
            let len = len2.sqrt();
            let inv = if valid { 1.0 / len } else { 0.0 };
            let u = [d[0] * inv, d[1] * inv, d[2] * inv];
            let dv = [vb[j] - va[j], vyb[j] - vya[j], vzb[j] - vza[j]];
            let rate = dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2];
            let mag = if taut { k * (len - r) + kd * rate } else { 0.0 };
            let mut transverse = if taut { k * (1.0 - r * inv) } else { 0.0 };
            if !lin.full {
                transverse = transverse.max(0.0);
            }
            let axial = if taut || (valid && lin.keep_slack) {
                k
            } else {
                0.0
            };
            let damping = if taut { kd } else { 0.0 };
            let force = [mag * u[0], mag * u[1], mag * u[2]];
            let jacobian = [axial, transverse, damping];
            let dw = [wb[j] - wa[j], wyb[j] - wya[j], wzb[j] - wza[j]];
            let v = values([force, u, dw, jacobian], lin);
            for (l, v) in local.iter_mut().zip(v) {
                l[j] = v;
            }
        }
        out.put(start, len, &local);
    }
}

/// Type 2 (compression only): the Jacobian of
/// [`model::jacobian`](crate::sim::model::jacobian)'s `buckle`, with `ℓ` found
/// first and the table's `g` and `g′` looked up in a scalar loop of their
/// own, then chunks as in [`stretch_slots`]. `k_b` in N·m², `c_b` in N/m.
#[inline(always)]
fn buckle_slots(
    s: &Stream,
    p: &Ends,
    (table, kb, cb): (&BucklingTable, f32, f32),
    lin: Linearisation,
    (g, dg, len): (&mut [f32], &mut [f32], &mut [f32]),
    mut out: Out,
) {
    let m = s.slots();
    let (rest, inv_rest) = (&s.rest[..m], &s.inv_rest[..m]);
    let [[xa, ya, za], [xb, yb, zb]] = p.x;
    for i in 0..m {
        len[i] = length_squared([xb[i] - xa[i], yb[i] - ya[i], zb[i] - za[i]]).sqrt();
    }
    for i in 0..m {
        let (l, r) = (len[i], rest[i]);
        // An empty slot's NaN rest length fails the first test.
        (g[i], dg[i]) = if l < r && l >= MIN_LENGTH {
            table.sample(l * inv_rest[i])
        } else {
            (0.0, 0.0)
        };
    }
    let mut local = [[0.0f32; CHUNK]; OUTPUTS];
    for start in (0..m).step_by(CHUNK) {
        let n = CHUNK;
        let c = p.chunk(start, n, [rest, inv_rest, g, dg]);
        let [[xa, ya, za], [xb, yb, zb]] = c.ends.x;
        let [[wa, wya, wza], [wb, wyb, wzb]] = c.ends.w;
        let [rest, inv_rest, g, dg] = c.per_slot;
        cut!(n; xa, ya, za, xb, yb, zb, wa, wya, wza, wb, wyb, wzb, rest, inv_rest, g, dg);
        for j in 0..n {
            let (r, inv_r) = (rest[j], inv_rest[j]);
            let d = [xb[j] - xa[j], yb[j] - ya[j], zb[j] - za[j]];
            let l = length_squared(d).sqrt();
            let compressed = l < r && l >= MIN_LENGTH;
            let scale = kb * inv_r * inv_r;
            let fb = scale * g[j];
            let linear = cb * (l - r);
            let (mag, slope) = if linear > fb {
                (linear, cb)
            } else {
                (fb, scale * inv_r * dg[j])
            };
            let inv = if compressed { 1.0 / l } else { 0.0 };
            let (mag, slope) = if compressed { (mag, slope) } else { (0.0, 0.0) };
            let u = [d[0] * inv, d[1] * inv, d[2] * inv];
            let force = [mag * u[0], mag * u[1], mag * u[2]];
            let transverse = if lin.full { mag * inv } else { 0.0 };
            let jacobian = [slope, transverse, 0.0];
            let dw = [wb[j] - wa[j], wyb[j] - wya[j], wzb[j] - wza[j]];
            let v = values([force, u, dw, jacobian], lin);
            for (l, v) in local.iter_mut().zip(v) {
                l[j] = v;
            }
        }
        out.put(start, n, &local);
    }
}
