//! Another cloth as one cloth's step sees it ([`ClothObstacle`]): its
//! triangles and particles at the start of the fixed step, moving on at
//! their velocities, hashed over the step; and a pair's contact
//! ([`Pair`]).

use std::sync::atomic::{AtomicU64, Ordering};

use bevy::math::Vec3;

use super::super::cells::{CellTable, cell_of, key};
use super::{MAX_QUERY_CELLS, MAX_SPAN, SLACK, single_cell};

/// Another cloth as one cloth's step sees it: its surface at the start of
/// the fixed step, moving on at its velocities.
#[derive(Clone, Debug, Default)]
pub struct ClothObstacle {
    /// Its triangles, as indices into its particles.
    pub faces: Vec<[u32; 3]>,
    /// Positions at the start of the fixed step, m.
    pub x: Vec<Vec3>,
    /// Velocities, m/s.
    pub v: Vec<Vec3>,
    /// Inverse masses, 1/kg (0: pinned, does not give way).
    pub w: Vec<f32>,
    /// The fixed step, s.
    pub dt: f32,
    /// Smallest corner and largest corner of its box over the step, grown
    /// by [`pad`](Self::pad), m.
    pub lo: Vec3,
    /// See [`lo`](Self::lo).
    pub hi: Vec3,
    /// How far (m) its box and hash cells are grown around its triangles.
    pub pad: f32,
    /// Its fastest particle, m/s.
    pub speed: f32,
    /// Side of the hash cells, m.
    cell: f32,
    /// Its triangles by cell.
    entries: CellTable,
    /// Triangles whose sweep spans more than [`MAX_SPAN`] cells a side.
    big: Vec<u32>,
    /// A number no other take of any obstacle has (0: never taken): what
    /// was listed against this take can be used again while it holds.
    pub(super) stamp: u64,
    /// The generation of its triangles ([`Faces::generation`](crate::sim::grid::Faces::generation)), if known.
    generation: Option<u64>,
}

/// A colliding pair as one of its cloths sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// Smallest distance kept between the two surfaces, m (> 0).
    pub thickness: f32,
    /// Coulomb friction coefficient μ (≥ 0, dimensionless).
    pub friction: f32,
    /// Whether this cloth goes below the other where the two lie on one
    /// plane (above when `false`).
    pub rank: bool,
}

/// Every cell key of the box `lo..hi` (m), at most [`MAX_SPAN`] a side.
pub(super) fn cells(lo: Vec3, hi: Vec3, inv_cell: f32, mut each: impl FnMut(u64)) {
    let (lo, hi) = (cell_of(lo, inv_cell), cell_of(hi, inv_cell));
    let last = |a: usize| hi[a].min(lo[a].saturating_add(MAX_SPAN - 1));
    for i in lo[0]..=last(0) {
        for j in lo[1]..=last(1) {
            for k in lo[2]..=last(2) {
                each(key([i, j, k]));
            }
        }
    }
}

/// The box (m) of `points`, if every one is finite.
pub fn finite_box(points: &[Vec3]) -> Option<(Vec3, Vec3)> {
    let (lo, hi) = points.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &p| {
        (lo.min(p), hi.max(p))
    });
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

impl ClothObstacle {
    /// Names the triangles of this take by the generation their cloth
    /// gave them ([`Faces::generation`](crate::sim::grid::Faces::generation)), so that the edges listed from
    /// them are listed again only when it changes.
    pub(crate) fn set_generation(&mut self, generation: Option<u64>) {
        self.generation = generation;
    }

    /// See [`set_generation`](Self::set_generation).
    pub(crate) fn generation(&self) -> Option<u64> {
        self.generation
    }

    /// Takes a cloth's surface at the start of a fixed step of `dt` s:
    /// `faces`, positions `x` (m), velocities `v` (m/s) and inverse masses
    /// `w` (1/kg); its triangles are hashed over the step grown by `pad` m
    /// (the largest thickness it meets), in cells of about `cell` m (its
    /// longest rest edge). Returns `None` for a cloth with a non-finite
    /// position or velocity (it is left out of collision).
    pub fn take(
        faces: impl Iterator<Item = [u32; 3]>,
        (x, v, w): (&[Vec3], &[Vec3], &[f32]),
        (dt, pad, cell): (f32, f32, f32),
        reuse: &mut Self,
    ) -> Option<()> {
        let n = x.len();
        if v.len() != n || w.len() != n || !(dt.is_finite() && dt > 0.0) {
            return None;
        }
        let (lo0, hi0) = finite_box(x)?;
        let speed = v.iter().map(|v| v.length()).fold(0.0, f32::max);
        if !speed.is_finite() {
            return None;
        }
        let this = reuse;
        static TAKES: AtomicU64 = AtomicU64::new(1);
        this.stamp = TAKES.fetch_add(1, Ordering::Relaxed);
        this.generation = None;
        this.faces.clear();
        this.faces
            .extend(faces.filter(|t| t.iter().all(|&q| (q as usize) < n)));
        this.x.clear();
        this.x.extend_from_slice(x);
        this.v.clear();
        this.v.extend_from_slice(v);
        this.w.clear();
        this.w.extend_from_slice(w);
        this.dt = dt;
        let pad = pad + SLACK;
        this.pad = pad;
        this.speed = speed;
        let travel = Vec3::splat(speed * dt + pad);
        (this.lo, this.hi) = (lo0 - travel, hi0 + travel);
        this.cell = cell.max(2.0 * pad).max(1e-4);
        let inv_cell = 1.0 / this.cell;
        this.entries.clear();
        this.big.clear();
        for (t, tri) in this.faces.iter().enumerate() {
            let (mut lo, mut hi) = (Vec3::MAX, Vec3::MIN);
            for &q in tri {
                let (s, e) = (x[q as usize], x[q as usize] + v[q as usize] * dt);
                lo = lo.min(s).min(e);
                hi = hi.max(s).max(e);
            }
            let (a, b) = (cell_of(lo - pad, inv_cell), cell_of(hi + pad, inv_cell));
            if (0..3).any(|i| b[i].saturating_sub(a[i]) >= MAX_SPAN) {
                this.big.push(t as u32);
                continue;
            }
            let entries = &mut this.entries;
            cells(lo - pad, hi + pad, inv_cell, |k| entries.enter(k, t as u32));
        }
        this.entries.finish();
        Some(())
    }

    /// Whether its box over the step meets the box `lo..hi` (m).
    pub fn overlaps(&self, lo: Vec3, hi: Vec3) -> bool {
        self.lo.cmple(hi).all() && lo.cmple(self.hi).all()
    }

    /// The triangles that may come within `h` m (at most the thickness
    /// it was taken for) of a point moving `motion` m from `p` (m) over the
    /// step, each once, into `out`: the triangles of `p`'s cell when the
    /// motion is within [`SLACK`], else those of the cells of its box.
    pub(super) fn gather_around(&self, p: Vec3, (motion, h): (f32, f32), out: &mut Vec<u32>) {
        if motion > SLACK || h + SLACK > self.pad {
            let reach = Vec3::splat(motion + h);
            return self.gather(p - reach, p + reach, out);
        }
        single_cell(&self.entries, key(cell_of(p, 1.0 / self.cell)), out);
        out.extend_from_slice(&self.big);
    }

    /// The triangles that may reach into the box `lo..hi` (m), each once,
    /// into `out`: those hashed in its cells and the fast ones, or every
    /// triangle for a box of more than [`MAX_QUERY_CELLS`] cells.
    pub(super) fn gather(&self, lo: Vec3, hi: Vec3, out: &mut Vec<u32>) {
        out.clear();
        if self.each_near(lo, hi, |t| out.push(t)) {
            out.sort_unstable();
            out.dedup();
        }
    }

    /// As [`gather`](Self::gather), in no particular order, with `seen`
    /// (an entry per triangle, none of them `query`) marking the triangles
    /// listed in place of a sort.
    pub(super) fn gather_marked(
        &self,
        (lo, hi): (Vec3, Vec3),
        (seen, query): (&mut [u32], u32),
        out: &mut Vec<u32>,
    ) {
        out.clear();
        self.each_near(lo, hi, |t| {
            if let Some(mark) = seen.get_mut(t as usize)
                && *mark != query
            {
                *mark = query;
                out.push(t);
            }
        });
    }

    /// Calls `each` with every triangle hashed in the cells of the box
    /// `lo..hi` (m) and every fast one, some more than once, and returns
    /// true; or, for a box of more than [`MAX_QUERY_CELLS`] cells or not
    /// finite, with every triangle once, and returns false.
    fn each_near(&self, lo: Vec3, hi: Vec3, mut each: impl FnMut(u32)) -> bool {
        let inv_cell = 1.0 / self.cell;
        // A triangle's box meets the box where its box grown by the pad,
        // as it is hashed, meets the box shrunk by the pad (down to its
        // middle).
        let middle = (lo + hi) * 0.5;
        let (lo, hi) = ((lo + self.pad).min(middle), (hi - self.pad).max(middle));
        let (a, b) = (cell_of(lo, inv_cell), cell_of(hi, inv_cell));
        let count = (0..3)
            .map(|i| (b[i] as i64 - a[i] as i64 + 1).max(0))
            .product::<i64>();
        if !(lo.is_finite() && hi.is_finite()) || count > MAX_QUERY_CELLS {
            (0..self.faces.len() as u32).for_each(each);
            return false;
        }
        for i in a[0]..=b[0] {
            for j in a[1]..=b[1] {
                for k in a[2]..=b[2] {
                    self.entries
                        .cell(key([i, j, k]))
                        .iter()
                        .for_each(|&t| each(t));
                }
            }
        }
        self.big.iter().copied().for_each(each);
        true
    }

    /// Its particle `q`'s position at time `t` s into the fixed step, m.
    pub(super) fn at(&self, q: u32, t: f32) -> Vec3 {
        self.x[q as usize] + self.v[q as usize] * t
    }

    /// Triangle `t`'s corners at time `s` s into the fixed step, m.
    pub(super) fn corners(&self, t: u32, s: f32) -> [Vec3; 3] {
        self.faces[t as usize].map(|q| self.at(q, s))
    }
}
