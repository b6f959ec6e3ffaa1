//! The grid families' pair forces by index step, as SIMD loops.
//!
//! A grid cloth's links join particles a fixed index step `δ = b − a`
//! apart: `1` and `columns` for the structural family, `columns ± 1` for
//! shear, twice those for the Type 2 families. [`ForceStreams`] sorts each
//! family into *streams*, one per common step, holding the rest length of
//! the link `(a, a + δ)` at index `a` (NaN where there is none). A stream's
//! forces are then plain loops over contiguous arrays of positions and
//! velocities stored component by component (`Soa`), with no index lists,
//! no branches and no scalar tails (streams are padded to a multiple of
//! sixteen slots), which the compiler turns into sixteen- or eight-lane
//! SIMD; links with any other step go through the pair kernel ([`kernel`]).
//!
//! The streams are a cache of the link lists: [`ForceStreams::pair_forces`]
//! first compares each family with the copy the streams were built from
//! (one `memcmp`, cheap next to the forces; the integrators do it once per
//! fixed step) and rebuilds them in place if anything changed, so a crease
//! that shortens rest lengths in place is seen at once. Nothing assumes the
//! links form a grid; a family whose steps are all different simply goes
//! through the pair kernel.
//!
//! The forces are the pair kernel's, evaluated with the same operations
//! except that `ℓ/L` is a product with a stored `1/L`; only the order in
//! which they are summed into each particle differs. The Type 2 streams
//! (module `buckling`) run in one AVX-512 pass where the CPU has it, with the
//! same operations as their portable loops.

use std::ops::Range;

use bevy::math::Vec3;

mod buckling;
mod linearise;

use buckling::{Buckling, buckling_pairs};
pub(crate) use linearise::{Linearisation, StreamBlocks};

use super::choi_ko::MIN_LENGTH;
use super::kernel::{self, Law, Target};
use crate::sim::connections::{Link, LinkStamp};
use crate::sim::soa::{Aligned, Soa};

/// At most this many streams per family (a grid family has two steps).
const MAX_STREAMS: usize = 4;

/// A step gets a stream only if at least this many links share it.
const MIN_STREAM_LINKS: usize = 8;

/// Every loop over a stream runs a multiple of this many slots (the widest
/// SIMD vector, AVX-512's sixteen `f32`), so none needs a scalar tail: the
/// streams are padded with empty slots, the component arrays with zeros.
const LANES: usize = 16;

/// Per-cloth cache and scratch of the streamed force evaluation
/// ([`pair_forces`](Self::pair_forces)). Holds about three and a half times the
/// memory of the link lists it was built from.
#[derive(Clone, Debug, Default)]
pub struct ForceStreams {
    /// One entry per family, in the order the families were passed.
    families: Vec<FamilyStreams>,
    /// Positions (m), velocities (m/s) and forces (N), by component.
    x: Soa,
    v: Soa,
    f: Soa,
    /// `g(ℓ/L)` (dimensionless) and `ℓ` (m) of each pair of one Type 2 stream.
    g: Vec<f32>,
    len: Vec<f32>,
    /// For the implicit integrators' linearisation: the vector `K`
    /// multiplies (m), `K w` (N) and `g′(ℓ/L)` of one Type 2 stream.
    w: Soa,
    kw: Soa,
    dg: Vec<f32>,
    /// `g`, `g′` and `ℓ` again, for the calling thread while the helper
    /// thread uses the first (a linearisation split between them).
    second: [Vec<f32>; 3],
    /// The generation of the links the families are passed, if the owner
    /// keeps one ([`ForceStreams::set_links_generation`]).
    generation: Option<u64>,
}

/// The streams of one family and the copy of the links they came from.
#[derive(Clone, Debug, Default)]
struct FamilyStreams {
    /// The links at the last rebuild.
    source: Vec<Link>,
    /// The stamp of the links last found equal to `source`.
    stamp: Option<LinkStamp>,
    /// Number of particles at the last rebuild.
    particles: usize,
    streams: Vec<Stream>,
    /// Links that fit no stream (other steps, a repeated pair).
    others: Vec<Link>,
}

/// The links `(a, a + delta)` of one family for `a` in `lo..lo + rest.len()`
/// (a multiple of [`LANES`] slots).
#[derive(Clone, Debug)]
struct Stream {
    delta: usize,
    lo: usize,
    /// Rest length (m) of the link at `lo + i`, NaN where there is none.
    rest: Aligned,
    /// `1/L` (1/m) of each rest length (NaN where there is none).
    inv_rest: Aligned,
    /// The force (N) on the lower particle of each pair at the last
    /// evaluation, slot `i` at `delta + i`, with zeros before (`delta` of
    /// them, never written) and after the slots (up to `delta` +
    /// [`padded_span`](Self::padded_span), never written either).
    pair: Soa,
    /// `(K w)` on the lower particle of each pair at the last
    /// linearisation (N), laid out like `pair`.
    pair_kw: Soa,
    /// The blocks `C = t I + s u uᵀ` of each slot at the last
    /// linearisation: `t`, `s` (kg), `u` by component.
    blocks: [Aligned; 5],
}

impl FamilyStreams {
    /// Rebuilds the streams unless `links` and `n` are what they were built
    /// from, reusing their memory (a crease that changes every step
    /// rebuilds every step without allocating, once the streams have grown).
    fn sync(&mut self, links: &[Link], n: usize, generation: Option<u64>) {
        let stamp = LinkStamp::of_list(generation, links);
        if self.particles == n
            && (LinkStamp::unchanged(self.stamp, stamp) || same_links(&self.source, links))
        {
            self.stamp = stamp;
            return;
        }
        self.stamp = stamp;
        self.particles = n;
        self.source.clear();
        self.source.extend_from_slice(links);
        self.others.clear();

        // The most common steps, with the range of lower ends of each:
        // (δ, count, lo, hi).
        let mut steps = [(0, 0, 0, 0); 4 * MAX_STREAMS];
        let mut found = 0;
        for l in links {
            let (a, b) = ordered(l);
            if b >= n || a == b {
                continue;
            }
            let delta = b - a;
            if let Some(s) = steps[..found].iter_mut().find(|s| s.0 == delta) {
                s.1 += 1;
                s.2 = s.2.min(a);
                s.3 = s.3.max(a + 1);
            } else if found < steps.len() {
                // Steps beyond the first few are rare; they go to `others`.
                steps[found] = (delta, 1, a, a + 1);
                found += 1;
            }
        }
        let steps = &mut steps[..found];
        steps.sort_unstable_by(|p, q| q.1.cmp(&p.1).then(p.0.cmp(&q.0)));
        let chosen = steps
            .iter()
            .take(MAX_STREAMS)
            .filter(|s| s.1 >= MIN_STREAM_LINKS);
        let mut count = 0;
        for (k, &(delta, _, lo, hi)) in chosen.enumerate() {
            if k == self.streams.len() {
                self.streams.push(Stream {
                    delta,
                    lo,
                    rest: Aligned::default(),
                    inv_rest: Aligned::default(),
                    pair: Soa::default(),
                    pair_kw: Soa::default(),
                    blocks: Default::default(),
                });
            }
            let s = &mut self.streams[k];
            (s.delta, s.lo) = (delta, lo);
            s.rest.clear();
            s.rest.resize((hi - lo).next_multiple_of(LANES), f32::NAN);
            let len = delta + s.padded_span();
            for c in s.pair.0.iter_mut().chain(&mut s.pair_kw.0) {
                c.clear();
                c.resize(len, 0.0);
            }
            count = k + 1;
        }
        self.streams.truncate(count);

        for l in links {
            let (a, b) = ordered(l);
            let slot = self
                .streams
                .iter_mut()
                .find(|s| b < n && b > a && s.delta == b - a)
                .map(|s| &mut s.rest[a - s.lo])
                .filter(|r| r.is_nan() && !l.rest_length.is_nan());
            match slot {
                Some(r) => *r = l.rest_length,
                None => self.others.push(*l),
            }
        }
        for s in &mut self.streams {
            s.inv_rest.resize(s.rest.len(), 0.0);
            for (inv, r) in s.inv_rest.iter_mut().zip(&s.rest) {
                *inv = 1.0 / r;
            }
        }
    }
}

/// `(min, max)` of a link's ends: a pair force is the same either way round.
fn ordered(l: &Link) -> (usize, usize) {
    let (a, b) = (l.a as usize, l.b as usize);
    (a.min(b), a.max(b))
}

/// Whether two link lists are identical, bit for bit (a `memcmp`).
fn same_links(p: &[Link], q: &[Link]) -> bool {
    bytemuck::cast_slice::<Link, u8>(p) == bytemuck::cast_slice::<Link, u8>(q)
}

crate::simd::multiversion! {
    /// [`ForceStreams::streamed`] compiled for a SIMD level.
    fn streamed_at(this: &mut ForceStreams, e: Eval, out: &mut [Vec3]) = ForceStreams::streamed;
}

impl ForceStreams {
    /// Adds the forces (N) of every `(links, law)` family to `out`, like
    /// `kernel::pair_forces` over the whole array.
    ///
    /// Positions `x` in m, velocities `v` in m/s (read only by damped laws);
    /// every link's ends must be indices into `x`.
    pub fn pair_forces(
        &mut self,
        families: &[(&[Link], Law)],
        x: &[Vec3],
        v: &[Vec3],
        out: &mut [Vec3],
    ) {
        self.sync(families.iter().map(|f| f.0), x.len());
        self.pair_forces_synced(families, x, v, out);
    }

    /// Rebuilds the streams of every family of links that changed since
    /// the last call, for `n` particles.
    pub(crate) fn sync<'a>(
        &mut self,
        families: impl ExactSizeIterator<Item = &'a [Link]>,
        n: usize,
    ) {
        if self.families.len() < families.len() {
            self.families.resize_with(families.len(), Default::default);
        }
        for (cache, links) in self.families.iter_mut().zip(families) {
            cache.sync(links, n, self.generation);
        }
    }

    /// Names the links passed from now on by `generation`, a number their
    /// owner changes whenever they change (`None`: compare them on every
    /// call, the default). With it, a call whose lists are the ones last
    /// seen at the same generation skips comparing them.
    pub(crate) fn set_links_generation(&mut self, generation: Option<u64>) {
        self.generation = generation;
    }

    /// [`pair_forces`](Self::pair_forces) without comparing the links: the
    /// caller has [`sync`](Self::sync)ed them since they last changed.
    pub(crate) fn pair_forces_synced(
        &mut self,
        families: &[(&[Link], Law)],
        x: &[Vec3],
        v: &[Vec3],
        out: &mut [Vec3],
    ) {
        self.evaluate(
            Eval {
                families,
                x,
                v,
                accel: None,
                from_zero: false,
            },
            out,
        );
    }

    /// Turns the forces (N) in `out` into accelerations (m/s²) after adding
    /// every family's forces, as [`Dynamics::accelerations`] does:
    /// `a_i = w_i (out_i + F_i) + g − c·v_i`, 0 where `w_i = 0`, formed in
    /// the component arrays, so it vectorises.
    ///
    /// [`Dynamics::accelerations`]: super::Dynamics::accelerations
    pub(crate) fn accelerations_synced(
        &mut self,
        families: &[(&[Link], Law)],
        x: &[Vec3],
        v: &[Vec3],
        accel: &Accel,
        out: &mut [Vec3],
    ) {
        let accel = Some(accel);
        self.evaluate(
            Eval {
                families,
                x,
                v,
                accel,
                from_zero: accel.is_some_and(|a| a.from_zero),
            },
            out,
        );
    }

    /// The links that fit no stream through the pair kernel, then the
    /// streams in the widest SIMD the CPU has.
    fn evaluate(&mut self, mut e: Eval, out: &mut [Vec3]) {
        if e.from_zero && self.families.iter().any(|c| !c.others.is_empty()) {
            // The pair kernel adds to `out`.
            out.fill(Vec3::ZERO);
            e.from_zero = false;
        }
        let mut target = Target { f: out, base: 0 };
        for (cache, &(_, law)) in self.families.iter().zip(e.families) {
            if !cache.others.is_empty() {
                kernel::pair_forces(&[(&cache.others, law)], e.x, e.v, &mut target);
            }
        }
        // Compiled for the CPU's vectors: AVX-512 takes 12 % off the
        // forces of a 15×15 cloth over AVX2 on a 2-core x86-64.
        streamed_at(crate::simd::level(), self, e, out);
    }

    /// The streams' forces, added to `out`, which then becomes the
    /// accelerations if `e.accel` is given.
    #[inline(always)]
    fn streamed(&mut self, e: Eval, out: &mut [Vec3]) {
        let Eval {
            families,
            x,
            v,
            accel,
            from_zero,
        } = e;
        let damped = damped(families);
        let n = x.len();
        let span = self.span(n);
        let Self {
            families: caches,
            x: xs,
            v: vs,
            f,
            g,
            len,
            ..
        } = self;
        let longest = caches.iter().flat_map(|c| &c.streams).map(|s| s.rest.len());
        let longest = longest.max().unwrap_or(0);
        for s in [&mut *xs, &mut *vs, &mut *f] {
            s.resize(span);
        }
        g.resize(longest, 0.0);
        len.resize(longest, 0.0);
        scatter(x, xs);
        // Velocities are read by damped laws and by the accelerations.
        let read_v = damped || accel.is_some();
        if read_v {
            scatter(v, vs);
        }
        if from_zero {
            f.zero();
        } else {
            // The forces start from what `out` holds; padding particles at 0.
            scatter(out, f);
            for c in &mut f.0 {
                c[n..].fill(0.0);
            }
        }
        // Undamped laws never read velocities: hand them the positions.
        let vs = if read_v { &*vs } else { &*xs };
        for (cache, &(_, law)) in caches.iter_mut().zip(families) {
            for stream in &mut cache.streams {
                // Taken out so that the loops may write it while reading
                // the rest of the stream.
                let mut pair = std::mem::take(&mut stream.pair);
                let (s, pair) = (&*stream, &mut pair);
                let r = &s.rest[..s.slots()];
                match law {
                    // Undamped laws get loops of their own that read no
                    // velocities (undamped seed preset, RK4: Choi–Ko 9.3 →
                    // 8.8 µs, Lander 7.5 → 6.6 µs per step).
                    Law::Tension { k, kd: 0.0 } => pairs(s, xs, vs, pair, [r; 3], |d, _, r, _| {
                        tension(d, [0.0; 3], r, k, 0.0)
                    }),
                    Law::Tension { k, kd } => pairs(s, xs, vs, pair, [r; 3], |d, dv, r, _| {
                        tension(d, dv, r, k, kd)
                    }),
                    Law::Buckling { table, kb, cb } => {
                        let law = Buckling { table, kb, cb };
                        buckling_pairs(s, xs, pair, law, g, len)
                    }
                    Law::Spring { ks, kd: 0.0 } => pairs(s, xs, vs, pair, [r; 3], |d, _, r, _| {
                        spring(d, [0.0; 3], r, ks, 0.0)
                    }),
                    Law::Spring { ks, kd } => pairs(s, xs, vs, pair, [r; 3], |d, dv, r, _| {
                        spring(d, dv, r, ks, kd)
                    }),
                }
                accumulate(s, pair, f);
                stream.pair = std::mem::take(pair);
            }
        }
        if let Some(&Accel {
            inverse_masses,
            gravity,
            damping,
            ..
        }) = accel
        {
            // Component by component, in SIMD.
            let w = &inverse_masses[..n];
            for ((fc, vc), g) in f.0.iter_mut().zip(&vs.0).zip(gravity.to_array()) {
                for ((a, &v), &w) in fc[..n].iter_mut().zip(&vc[..n]).zip(w) {
                    *a = if w == 0.0 {
                        0.0
                    } else {
                        w * *a + g - damping * v
                    };
                }
            }
        }
        gather(f, out);
    }
}

/// One evaluation's inputs: the families with their laws, positions (m),
/// velocities (m/s), and what turns forces into accelerations, if anything.
#[derive(Clone, Copy)]
struct Eval<'a> {
    families: &'a [(&'a [Link], Law<'a>)],
    x: &'a [Vec3],
    v: &'a [Vec3],
    accel: Option<&'a Accel<'a>>,
    /// Whether the forces start from zero rather than from `out`.
    from_zero: bool,
}

/// What turns forces into accelerations
/// ([`ForceStreams::accelerations_synced`]).
pub(crate) struct Accel<'a> {
    /// Inverse mass of each particle (1/kg), 0 for a pinned one.
    pub inverse_masses: &'a [f32],
    /// Gravity (m/s²).
    pub gravity: Vec3,
    /// Absolute damping rate `c` (1/s).
    pub damping: f32,
    /// Whether the forces start from zero rather than from what `out`
    /// holds (which is then not read).
    pub from_zero: bool,
}

/// Whether any of the laws reads velocities.
fn damped(families: &[(&[Link], Law)]) -> bool {
    families.iter().any(|(_, law)| match *law {
        Law::Tension { kd, .. } | Law::Spring { kd, .. } => kd != 0.0,
        Law::Buckling { .. } => false,
    })
}

impl ForceStreams {
    /// The particles the loops touch for `n` particles: `n`, or beyond it up
    /// to the farthest end of any stream's padded slots.
    fn span(&self, n: usize) -> usize {
        let streams = self.families.iter().flat_map(|c| &c.streams);
        streams.map(|s| s.lo + s.padded_span()).fold(n, usize::max)
    }
}

impl Stream {
    /// The particles at the lower and at the upper ends of the slots.
    fn ends(&self) -> (Range<usize>, Range<usize>) {
        let (lo, m) = (self.lo, self.slots());
        (lo..lo + m, lo + self.delta..lo + self.delta + m)
    }

    /// The number of slots, a multiple of [`LANES`] (so said to the compiler).
    #[inline(always)]
    fn slots(&self) -> usize {
        self.rest.len() / LANES * LANES
    }

    /// How many particles from `lo` on the stream's loops touch: both ends
    /// of every slot, rounded up to [`LANES`].
    fn padded_span(&self) -> usize {
        (self.slots() + self.delta).next_multiple_of(LANES)
    }
}

/// The three component arrays of `x` over `range`.
#[inline(always)]
fn window<'a>(x: &'a Soa, range: &Range<usize>) -> [&'a [f32]; 3] {
    std::array::from_fn(|c| &x.0[c][range.clone()])
}

/// Copies `src` into `dst` component by component.
#[inline(always)]
fn scatter(src: &[Vec3], dst: &mut Soa) {
    let [x, y, z] = &mut dst.0;
    for (((p, x), y), z) in src.iter().zip(x).zip(y).zip(z) {
        (*x, *y, *z) = (p.x, p.y, p.z);
    }
}

/// Copies the first `dst.len()` vectors of `src` into `dst`.
#[inline(always)]
fn gather(src: &Soa, dst: &mut [Vec3]) {
    let [x, y, z] = &src.0;
    for (((p, &x), &y), &z) in dst.iter_mut().zip(x).zip(y).zip(z) {
        *p = Vec3::new(x, y, z);
    }
}

/// One stream's pair forces: `pair = force(d, dv, L, e)·d` for every slot,
/// with `e` the slot's entries in `per_slot`; [`accumulate`] then adds them
/// to both ends (writing both ends here does not vectorise, as the two
/// writes may overlap). `force` returns the force on `a` (N) per metre of
/// `d = x_b − x_a`, 0 where the slot is empty.
#[inline(always)]
fn pairs(
    s: &Stream,
    x: &Soa,
    v: &Soa,
    pair: &mut Soa,
    per_slot: [&[f32]; 3],
    force: impl Fn([f32; 3], [f32; 3], f32, [f32; 3]) -> f32,
) {
    let m = s.slots();
    let (a, b) = s.ends();
    let rest = &s.rest[..m];
    let [e0, e1, e2] = per_slot.map(|e| &e[..m]);
    let ([xa, ya, za], [xb, yb, zb]) = (window(x, &a), window(x, &b));
    let (va, vb) = (window(v, &a), window(v, &b));
    let [px, py, pz] = &mut pair.0;
    let slots = s.delta..s.delta + m;
    let (px, py, pz) = (
        &mut px[slots.clone()],
        &mut py[slots.clone()],
        &mut pz[slots],
    );
    for i in 0..m {
        let d = [xb[i] - xa[i], yb[i] - ya[i], zb[i] - za[i]];
        let dv = [
            vb[0][i] - va[0][i],
            vb[1][i] - va[1][i],
            vb[2][i] - va[2][i],
        ];
        let scale = force(d, dv, rest[i], [e0[i], e1[i], e2[i]]);
        (px[i], py[i], pz[i]) = (d[0] * scale, d[1] * scale, d[2] * scale);
    }
}

/// `f[lo + j] += p[j] − p[j − δ]` over the particles stream `s` touches,
/// with `p` the pair forces (N) of `s` (`p[j]` at `δ + j` in `pair`, 0
/// outside the slots): one pass adds each pair's force to both of its ends.
#[inline(always)]
fn accumulate(s: &Stream, pair: &Soa, f: &mut Soa) {
    let (delta, width) = (s.delta, s.padded_span());
    for (fc, pc) in f.0.iter_mut().zip(&pair.0) {
        let fc = &mut fc[s.lo..s.lo + width];
        let (now, before) = (&pc[delta..delta + width], &pc[..width]);
        for ((fj, &p), &q) in fc.iter_mut().zip(now).zip(before) {
            *fj += p - q;
        }
    }
}

/// `|d|²`.
#[inline(always)]
fn length_squared(d: [f32; 3]) -> f32 {
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Type 1, per metre of `d`: `[k(ℓ − L) + k_d (v_ab·u)]/ℓ` while `ℓ ≥ L`.
#[inline(always)]
fn tension(d: [f32; 3], dv: [f32; 3], rest: f32, k: f32, kd: f32) -> f32 {
    let len2 = length_squared(d);
    let len = len2.sqrt();
    let inv = 1.0 / len;
    let rate = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
    let damping = kd * rate * inv;
    let mag = k * (len - rest) + damping;
    // An empty slot's NaN rest length fails the first test.
    let taut = len2 >= rest * rest && len2 >= MIN_LENGTH * MIN_LENGTH;
    if taut { mag * inv } else { 0.0 }
}

/// Lander's spring, per metre of `d`: `[k_s(ℓ − L) + k_d (v_ab·u)]/ℓ`.
#[inline(always)]
fn spring(d: [f32; 3], dv: [f32; 3], rest: f32, ks: f32, kd: f32) -> f32 {
    let len2 = length_squared(d);
    let len = len2.sqrt();
    let inv = 1.0 / len;
    let rate = dv[0] * d[0] + dv[1] * d[1] + dv[2] * d[2];
    let damping = kd * rate * inv;
    let mag = ks * (len - rest) + damping;
    let live = !rest.is_nan() && len2 >= MIN_LENGTH * MIN_LENGTH;
    if live { mag * inv } else { 0.0 }
}
