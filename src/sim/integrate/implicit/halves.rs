//! The conjugate gradient of a large grid cloth on two threads.
//!
//! The particles are cut in two at [`Halves::at`]; the calling thread runs
//! every pass of an iteration on the lower half and the helper thread
//! ([`team`](super::team)) on the upper:
//!
//! 1. `q = A d` (the gathered product reads `d` across the cut) and
//!    `dᵀq`, summed over both halves at a barrier;
//! 2. `Δv += αd`, `r −= αq`, `y = B⁻¹r`, and `R₁ᵀr` of the half's bands
//!    of first-level aggregates (the cut lies between two bands); a
//!    barrier, the V-cycle over the coarser levels on the helper, a
//!    barrier, then `y += R₁e` over the half's bands;
//! 3. `rᵀy`, summed at a barrier (with, when the directions are deflated
//!    by the past solutions, their products with `y`, after which each
//!    thread deflates its half of `y`); `d = y + βd`; a barrier.
//!
//! Every value is formed by the same operations as on one thread, and the
//! single-thread loop sums its dot products in the same two halves
//! ([`Halves::dot`]), so a solve gives the same bits whether or not it got
//! the helper.

use std::ops::Range;

use bevy::math::Vec3A;

use super::coarse::{Coarse, LevelWork};
use super::operator::{Operator, Soa, dot_parts};
use super::past::Past;
use crate::sim::settings::MAX_PAST_SOLUTIONS;
use crate::sim::team::{Claim, SUM_SLOTS, Team};
use crate::simd::{self, Level};

/// Particles from which a grid cloth's solve is split between two threads.
pub(super) const MIN_PARTICLES: usize = crate::sim::team::SPLIT_PARTICLES;

/// One solve in this many takes the other way than the faster one, so that
/// a change of conditions (another thread taking the helper's core) is seen.
const EXPLORE: u32 = 30;

/// One solve in this many explores when the faster way is faster by
/// [`WIDE`] or more: a 64×64 cloth's solve alone takes ~1 ms longer, so
/// exploring one frame in 30 cost ~35 µs a frame on average.
const EXPLORE_WIDE: u32 = 240;

/// The ratio of the two ways' costs from which exploring is rarer.
const WIDE: f32 = 1.25;

/// Chooses, per cloth, between the solve on one thread and the solve shared
/// with the helper by their measured time per iteration (µs, a moving
/// average). Sharing is usually the faster; it is not when the two threads
/// end up on one core's hyperthreads, or compete with another busy thread
/// of the app for the cores (a second compute-pool thread on a 2-core
/// machine): the halves wait for each other at every barrier, and a 64×64
/// step then took 1.7 ms shared against 1.45 alone (1.1 when shared goes
/// well). Either way gives the same bits, so switching changes nothing but
/// the time.
#[derive(Clone, Debug, Default)]
pub(super) struct Choice {
    /// µs per iteration alone and shared, once measured.
    cost: [Option<f32>; 2],
    solves: u32,
}

impl Choice {
    /// Whether the next solve should share its iterations: yes until
    /// sharing has been timed, then no until solving alone has, then the
    /// faster, except one solve in [`EXPLORE`] ([`EXPLORE_WIDE`] if the
    /// faster is faster by [`WIDE`]).
    pub(super) fn share(&mut self) -> bool {
        self.solves = self.solves.wrapping_add(1);
        match self.cost {
            [_, None] => true,
            [None, _] => false,
            [Some(alone), Some(shared)] => {
                let wide = alone.max(shared) >= WIDE * alone.min(shared);
                let period = if wide { EXPLORE_WIDE } else { EXPLORE };
                (shared < alone) != self.solves.is_multiple_of(period)
            }
        }
    }

    /// Records a solve of `iterations` that took `time` on `threads` (1 or
    /// 2) threads. A solve of fewer than 4 iterations says too little.
    pub(super) fn record(&mut self, threads: u32, time: std::time::Duration, iterations: u32) {
        if iterations < 4 || !(1..=2).contains(&threads) {
            return;
        }
        let per = time.as_secs_f32() * 1e6 / iterations as f32;
        let cost = &mut self.cost[threads as usize - 1];
        *cost = Some(cost.map_or(per, |old| old + 0.25 * (per - old)));
    }
}

// `rᵀy` and a deflation's products are summed at one barrier.
const _: () = assert!((MAX_PAST_SOLUTIONS as usize) < SUM_SLOTS);

/// Where a solve's vectors are cut in two.
#[derive(Clone, Copy, Debug)]
pub(super) struct Halves {
    /// The first particle of the upper half.
    at: usize,
    /// The first band of aggregates of the upper half (with a coarse grid).
    band: usize,
    /// The SIMD level of the gathered product (not scalar).
    kernel: Level,
}

impl Halves {
    /// The cut for a solve with `op` (and `coarse`, if its correction is
    /// on), or `None` if it is solved on one thread: fewer than
    /// [`MIN_PARTICLES`] particles, pairs outside the streams, a coarse grid
    /// of one band, or a CPU without AVX2 and FMA.
    pub(super) fn plan(op: &Operator, coarse: Option<&Coarse>) -> Option<Self> {
        let n = op.free.len();
        if n < MIN_PARTICLES || !op.streams_only() {
            return None;
        }
        let kernel = kernel()?;
        let (at, band) = match coarse {
            Some(c) if c.bands() >= 2 => {
                let band = c.bands() / 2;
                (c.band_rows(band, n).start, band)
            }
            Some(_) => return None,
            None => ((n / 2).next_multiple_of(16), 0),
        };
        (at > 0 && at < n).then_some(Self { at, band, kernel })
    }

    /// `aᵀb`, as the lower half's sum plus the upper half's.
    #[inline(always)]
    pub(super) fn dot(&self, a: &Soa, b: &Soa) -> f64 {
        fn lower(v: &Soa, at: usize) -> [&[f32]; 3] {
            v.0.each_ref().map(|c| &c[..at])
        }
        fn upper(v: &Soa, at: usize) -> [&[f32]; 3] {
            v.0.each_ref().map(|c| &c[at..])
        }
        let at = self.at;
        dot_parts(lower(a, at), lower(b, at)) + dot_parts(upper(a, at), upper(b, at))
    }
}

/// The level of the gathered product on a range, if the kernels have one.
fn kernel() -> Option<Level> {
    let level = simd::level();
    (level > Level::Scalar).then_some(level)
}

/// The vectors of one solve, shared by both threads. Each pass writes only
/// its own half of a vector (of `rc`, its own bands), and reads the other
/// half only after a barrier that follows the other thread's writes.
struct Shared<'a> {
    op: &'a Operator,
    coarse: Option<&'a Coarse>,
    /// The past solutions that deflate the directions, if they do.
    past: Option<&'a Past>,
    halves: Halves,
    n: usize,
    dv: [*mut f32; 3],
    r: [*mut f32; 3],
    y: [*mut f32; 3],
    q: [*mut f32; 3],
    /// `d`, padded for the product: `pad` zeros before its first value.
    padded: [*mut f32; 3],
    /// The first level's right-hand side and correction
    /// ([`Scratch::top`](super::coarse::Scratch::top)).
    rc: [(*mut Vec3A, usize); 2],
    rows: [(*mut f32, usize); 2],
    /// The V-cycle's vectors ([`Scratch::work`](super::coarse::Scratch::work)), the helper's alone.
    work: (*mut LevelWork, usize),
    /// `δ` of the start, `δ₀`, `ε²` and the iteration cap.
    start: (f64, f64, f64, u32),
}

// SAFETY: the pointers are only used as `Shared` documents.
unsafe impl Sync for Shared<'_> {}

/// Runs the iterations of [`pcg`](super::pcg) from its first direction
/// `d = y` on both threads, deflating each direction by `past` if given
/// ([`Past::deflate`]); `delta` is `rᵀy`. Returns the iterations and the
/// last `rᵀy`.
#[allow(clippy::too_many_arguments)]
pub(super) fn iterate(
    claim: &Claim,
    halves: Halves,
    op: &mut Operator,
    mut coarse: Option<&mut Coarse>,
    past: Option<&Past>,
    [dv, r, y, q]: [&mut Soa; 4],
    (delta, delta0, tol2, max_iterations): (f64, f64, f64, u32),
) -> (u32, f64) {
    let n = op.free.len();
    let pad = op.pad();
    let mut padded = op.take_padded();
    for (p, y) in padded.0.iter_mut().zip(&y.0) {
        p[pad..pad + n].copy_from_slice(&y[..n]);
    }
    op.check_padded(&padded);
    for v in [&*dv, &*r, &*y, &*q] {
        assert!(v.0.iter().all(|c| c.len() == n));
    }
    let mut scratch = coarse.as_deref_mut().map(Coarse::take_scratch);
    let (rc, rows, work) = match &mut scratch {
        Some(s) => (
            s.top.each_mut().map(|v| (v.as_mut_ptr(), v.len())),
            s.rows.each_mut().map(|r| (r.as_mut_ptr(), r.len())),
            (s.work.as_mut_ptr(), s.work.len()),
        ),
        None => (
            [(std::ptr::null_mut(), 0); 2],
            [(std::ptr::null_mut(), 0); 2],
            (std::ptr::null_mut(), 0),
        ),
    };
    let ptrs = |v: &mut Soa| v.0.each_mut().map(|c| c.as_mut_ptr());
    let shared = Shared {
        op,
        coarse: coarse.as_deref(),
        past,
        halves,
        n,
        dv: ptrs(dv),
        r: ptrs(r),
        y: ptrs(y),
        q: ptrs(q),
        // SAFETY: `check_padded` asserted `pad + n` values and more.
        padded: padded
            .0
            .each_mut()
            .map(|c| unsafe { c.as_mut_ptr().add(pad) }),
        rc,
        rows,
        work,
        start: (delta, delta0, tol2, max_iterations),
    };
    let result = claim.run(|team, part| {
        // Compiled for the product's level. SAFETY: `Shared` holds what
        // `body` needs.
        unsafe { body_at(halves.kernel, &shared, team, part) }
    });
    op.put_padded(padded);
    if let (Some(c), Some(s)) = (coarse, scratch) {
        c.put_scratch(s);
    }
    result
}

simd::multiversion! {
    /// [`body`] compiled for a SIMD level.
    ///
    /// # Safety
    /// As for [`body`].
    unsafe fn body_at(s: &Shared, team: &Team, part: usize) -> (u32, f64) = body;
}

/// Three component arrays' `range`, as slices.
///
/// # Safety
/// The arrays hold `range`, and no one else writes it while the slices live.
#[inline(always)]
unsafe fn slices<'a>(v: [*mut f32; 3], range: &Range<usize>) -> [&'a [f32]; 3] {
    // SAFETY: the caller's.
    v.map(|p| unsafe { std::slice::from_raw_parts(p.add(range.start), range.len()) })
}

/// [`slices`], mutable.
///
/// # Safety
/// The arrays hold `range`, and no one else reads or writes it while the
/// slices live.
#[inline(always)]
unsafe fn slices_mut<'a>(v: [*mut f32; 3], range: &Range<usize>) -> [&'a mut [f32]; 3] {
    // SAFETY: the caller's.
    v.map(|p| unsafe { std::slice::from_raw_parts_mut(p.add(range.start), range.len()) })
}

/// One thread's half of the iterations (`part` 0 below the cut, 1 above).
///
/// # Safety
/// `s` points to vectors of `n` particles (`rc` and the rows as their
/// lengths say), the CPU has `s.halves.kernel`'s features, and the other
/// thread runs this with the other `part`.
#[inline(always)]
unsafe fn body(s: &Shared, team: &Team, part: usize) -> (u32, f64) {
    let Halves { at, band, kernel } = s.halves;
    let own = if part == 0 { 0..at } else { at..s.n };
    let (mut delta, delta0, tol2, max_iterations) = s.start;
    // The padded arrays themselves, for the product: `padded` starts
    // `pad` values into them.
    // SAFETY: `iterate` offset the arrays' starts by `pad`.
    let d_at = s.padded.map(|p| unsafe { p.sub(s.op.pad()) });
    // What `check_padded` asserted the padded arrays hold.
    let padded_len = s.n + 2 * s.op.pad() + simd::gather::LANES;
    let product = s.op.product();
    let mut iterations = 0;
    while iterations < max_iterations && delta > tol2 * delta0 {
        // 1. q = A d over this half; every d is settled (barrier 3 below).
        let ran = {
            // SAFETY: `check_padded` held for the padded arrays, which no
            // one writes in this pass; `q`'s half is this thread's. The
            // slices end with this block.
            let (d_all, q_own) = unsafe { (slices(d_at, &(0..padded_len)), slices_mut(s.q, &own)) };
            simd::gather::gather(kernel, &product, s.op.blocks(), d_all, q_own, own.clone())
        };
        debug_assert!(ran, "`Halves::plan` gives a level with a gathered product");
        // The contacts' diagonal blocks of this half.
        // SAFETY: this half of `q`, this thread's alone in this pass.
        unsafe {
            s.op.add_extra_part(slices(s.padded, &own), slices_mut(s.q, &own), own.start)
        };
        // SAFETY: this half, written by this thread only.
        let (d, q) = unsafe { (slices(s.padded, &own), slices(s.q, &own)) };
        let dq = team.sum(part, 0, dot_parts(d, q));
        if !(dq > 0.0 && dq.is_finite()) {
            break; // both threads see the same sum and stop together
        }
        let alpha = (delta / dq) as f32;
        // 2. Δv, r, y over this half.
        // SAFETY: this half of each, this thread's alone in this pass.
        let (dv, r) = unsafe { (slices_mut(s.dv, &own), slices_mut(s.r, &own)) };
        for ((dv, r), (d, q)) in dv.into_iter().zip(r).zip(d.into_iter().zip(q)) {
            for ((dvi, ri), (&di, &qi)) in dv.iter_mut().zip(r.iter_mut()).zip(d.iter().zip(q)) {
                *dvi += alpha * di;
                *ri -= alpha * qi;
            }
        }
        // SAFETY: as above; `r` is only read from here on.
        let (r, y) = unsafe { (slices(s.r, &own), slices_mut(s.y, &own)) };
        s.op.precondition_part(r, y, own.start);
        if let Some(c) = s.coarse {
            // SAFETY: this half of `r` is settled; `body`'s contract.
            unsafe { coarse_half(s, c, team, part, band) };
        }
        let next = match s.past {
            // SAFETY: this half of `y`, settled by this thread.
            None => team.sum(part, 1, dot_parts(r, unsafe { slices(s.y, &own) })),
            // SAFETY: as above; `y` is then this thread's alone to deflate.
            Some(past) => unsafe { deflated(past, r, s.y, &own, team, part) },
        };
        // SAFETY: this half of `y`, settled by this thread.
        let y = unsafe { slices(s.y, &own) };
        // 3. d = y + βd over this half, then wait for the other's.
        let beta = (next / delta) as f32;
        // SAFETY: this half of `d`, this thread's alone until the barrier.
        let d = unsafe { slices_mut(s.padded, &own) };
        for (d, y) in d.into_iter().zip(y) {
            for (di, &yi) in d.iter_mut().zip(y) {
                *di = yi + beta * *di;
            }
        }
        team.barrier(part);
        delta = next;
        iterations += 1;
    }
    (iterations, delta)
}

/// `rᵀy` over both halves, and this half of `y` deflated by `past`: `rᵀy`
/// and the products `(AW)ᵀy` summed at one barrier, then
/// [`Past::take_along`] on this half (the single-thread solve sums the
/// same halves, [`Halves::dot`], and deflates after `rᵀy` too).
///
/// # Safety
/// `y` holds this half, `own`, settled, and only this thread reads or
/// writes it until the next barrier.
#[inline(always)]
unsafe fn deflated(
    past: &Past,
    r: [&[f32]; 3],
    y: [*mut f32; 3],
    own: &Range<usize>,
    team: &Team,
    part: usize,
) -> f64 {
    let images = past.images();
    let mut sums = [0.0_f64; SUM_SLOTS];
    {
        // SAFETY: the caller's.
        let y = unsafe { slices(y, own) };
        sums[0] = dot_parts(r, y);
        for (sum, image) in sums[1..].iter_mut().zip(images) {
            *sum = dot_parts(image.0.each_ref().map(|c| &c[own.clone()]), y);
        }
    }
    let sums = &mut sums[..1 + images.len()];
    team.sums(part, 1, sums);
    // SAFETY: the caller's; the shared slice above has ended.
    past.take_along(&sums[1..], unsafe { slices_mut(y, own) }, own.start);
    sums[0]
}

/// `y += R₁ V₁(R₁ᵀ r)` with the bands split at `band`: this thread's
/// bands restricted; a barrier, the V-cycle on thread 1, a barrier; this
/// thread's bands prolonged.
///
/// # Safety
/// As for [`body`]; `r` of this half is settled.
#[inline(always)]
unsafe fn coarse_half(s: &Shared, c: &Coarse, team: &Team, part: usize, band: usize) {
    let bands = if part == 0 { 0..band } else { band..c.bands() };
    let [(top, length), (correction, _)] = s.rc;
    let (row, row_length) = s.rows[part];
    // SAFETY: each thread has its own row.
    let sums = unsafe { std::slice::from_raw_parts_mut(row, row_length) };
    let per_band = c.per_band();
    for j in bands.clone() {
        let rows = c.band_rows(j, s.n);
        // SAFETY: band j's particles are in this half; its entries of the
        // right-hand side are this thread's alone in this pass.
        let (r, rc) = unsafe {
            (
                slices(s.r, &rows),
                std::slice::from_raw_parts_mut(top.add(j * per_band), per_band),
            )
        };
        c.restrict_band(r, rc, sums);
    }
    team.barrier(part);
    if part == 1 {
        // SAFETY: both threads wrote their bands of the right-hand side
        // before the barrier and leave it alone until the next iteration's
        // restriction; the correction and the cycle's vectors are this
        // thread's alone until the next barrier.
        unsafe {
            let r = std::slice::from_raw_parts(top, length);
            let e = std::slice::from_raw_parts_mut(correction, length);
            let work = std::slice::from_raw_parts_mut(s.work.0, s.work.1);
            c.cycle(r, e, work);
        }
    }
    team.barrier(part);
    for j in bands {
        let rows = c.band_rows(j, s.n);
        // SAFETY: band j's particles are in this half (this thread writes
        // their `y`); the correction is only read until the next
        // iteration's cycle, two barriers on.
        let (e, y) = unsafe {
            (
                std::slice::from_raw_parts(correction.add(j * per_band), per_band),
                slices_mut(s.y, &rows),
            )
        };
        c.prolong_band(e, y, &s.op.free[rows], sums);
    }
}
