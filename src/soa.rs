//! Vectors stored component by component, so that loops over them run as
//! SIMD: the implicit solver's vectors and the force streams' positions,
//! velocities and forces.

use bevy::math::Vec3;

/// `n` vectors stored as three arrays of components (x, y, z).
#[derive(Clone, Debug, Default)]
pub(crate) struct Soa(pub [Vec<f32>; 3]);

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
