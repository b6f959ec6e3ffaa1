//! Vectors stored component by component, so that loops over them run as
//! SIMD: the implicit solver's vectors and the force streams' positions,
//! velocities and forces; each component in an [`Aligned`] array.
//!
//! Aligning the solver's and the streams' arrays to cache lines took the
//! 64×64 frame on a sphere from 2.0–2.1 to 1.8–1.9 ms (probe means); a
//! 64×64 product alone from 19.8 to 18.7 µs.

use bevy::math::Vec3;

/// `n` vectors stored as three arrays of components (x, y, z).
#[derive(Clone, Debug, Default)]
pub(crate) struct Soa(pub [Aligned; 3]);

impl Soa {
    /// Makes room for `n` vectors (zeros when growing).
    pub fn resize(&mut self, n: usize) {
        for c in &mut self.0 {
            c.resize(n, 0.0);
        }
    }

    /// Vector `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.0[0][i], self.0[1][i], self.0[2][i])
    }

    /// Sets vector `i`.
    #[inline]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.0[0][i] = v.x;
        self.0[1][i] = v.y;
        self.0[2][i] = v.z;
    }

    /// Sets every vector to zero.
    pub fn zero(&mut self) {
        for c in &mut self.0 {
            c.fill(0.0);
        }
    }

    /// Copies `other` (of the same length).
    pub fn copy_from(&mut self, other: &Soa) {
        for (c, o) in self.0.iter_mut().zip(&other.0) {
            c.copy_from_slice(o);
        }
    }

    /// Adds a stream of pair values to both ends of each pair: `p_i` to
    /// vector `start + i` and `−p_i` to vector `start + i + δ`, for
    /// `i < m`. One pass over the vectors the pairs touch, each getting
    /// `p_j − p_{j−δ}` (a term only where its index is below `m`).
    /// Inlined so that it runs in its caller's SIMD width.
    #[inline(always)]
    pub fn add_pairs(&mut self, start: usize, delta: usize, p: &Soa, m: usize) {
        let (head, tail) = (delta.min(m), delta.max(m));
        for (c, p) in self.0.iter_mut().zip(&p.0) {
            let (c, p) = (&mut c[start..start + m + delta], &p[..m]);
            for (c, &p) in c[..head].iter_mut().zip(p) {
                *c += p;
            }
            if delta < m {
                let (c, now, before) = (&mut c[delta..m], &p[delta..], &p[..m - delta]);
                for ((c, &p), &q) in c.iter_mut().zip(now).zip(before) {
                    *c += p - q;
                }
            }
            for (c, &q) in c[tail..].iter_mut().zip(&p[tail - delta..]) {
                *c -= q;
            }
        }
    }

    /// Zeroes the vectors of pinned particles (`free[i] == 0`).
    pub fn filter(&mut self, free: &[f32]) {
        for c in &mut self.0 {
            for (x, &f) in c.iter_mut().zip(free) {
                *x = if f == 0.0 { 0.0 } else { *x };
            }
        }
    }
}

/// One 64-byte cache line of `f32`s, the unit of an [`Aligned`] buffer.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct Line([f32; 16]);

/// A growable array of `f32` whose first value starts a cache line, so
/// that SIMD loads and stores of sixteen values at multiples of sixteen
/// never straddle two lines. With `Vec<f32>`'s 16-byte alignment three
/// arrays in four started mid-line, and every 64-byte load from them
/// touched two lines.
#[derive(Clone, Default)]
pub(crate) struct Aligned {
    lines: Vec<Line>,
    len: usize,
}

impl Aligned {
    /// Resizes to `n` values, new ones `value`.
    pub fn resize(&mut self, n: usize, value: f32) {
        let old = self.len;
        self.lines.resize(n.div_ceil(16), Line::default());
        self.len = n;
        if n > old {
            self[old..].fill(value);
        }
    }

    /// Empties the array (keeping its memory).
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl std::fmt::Debug for Aligned {
    /// The values, not the unused rest of the last line.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl std::ops::Deref for Aligned {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        // SAFETY: `lines` holds at least `len` initialised `f32`s, in order
        // (`Line` is `repr(C)` of an array, with no padding).
        unsafe { std::slice::from_raw_parts(self.lines.as_ptr().cast(), self.len) }
    }
}

impl std::ops::DerefMut for Aligned {
    fn deref_mut(&mut self) -> &mut [f32] {
        // SAFETY: as for `deref`, uniquely borrowed.
        unsafe { std::slice::from_raw_parts_mut(self.lines.as_mut_ptr().cast(), self.len) }
    }
}

impl<'a> IntoIterator for &'a Aligned {
    type Item = &'a f32;
    type IntoIter = std::slice::Iter<'a, f32>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a> IntoIterator for &'a mut Aligned {
    type Item = &'a mut f32;
    type IntoIter = std::slice::IterMut<'a, f32>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aligned_arrays_start_a_cache_line_and_resize_like_vectors() {
        let mut a = Aligned::default();
        for n in [1, 15, 16, 17, 100, 3] {
            let old: Vec<f32> = a.to_vec();
            a.resize(n, 7.0);
            assert_eq!(a.len(), n);
            assert_eq!(a.as_ptr() as usize % 64, 0, "{n}");
            // Kept values below the old length, the new value above it.
            for (i, &v) in a.iter().enumerate() {
                assert_eq!(v, if i < old.len() { old[i] } else { 7.0 }, "{n}: {i}");
            }
            for (i, v) in a.iter_mut().enumerate() {
                *v = i as f32;
            }
        }
        a.clear();
        assert!(a.is_empty());
        a.resize(4, 1.0);
        assert_eq!(&a[..], &[1.0; 4]);
    }
}
