//! Rigid motions of a node of the mesh hierarchy and the 6×6 blocks that
//! act on them.
//!
//! A node's unknowns are a translation `t` (m/s) and a rotation `ω`
//! (rad/s) about its centre `c`: a point at `x` under it moves at
//! `t + ω × (x − c)`. Its loads are the dual pair, a force (N·s) and a
//! torque about `c` (N·m·s). A node moved to a centre `c'` by `d = c − c'`
//! maps through `T = [[I, −[d]×], [0, I]]` (`[d]×` the cross-product
//! matrix, `[d]× v = d × v`): its motion is `T` times the motion about
//! `c'`, and its load about `c'` is `Tᵀ` times its load about `c`.

use std::ops::{Add, AddAssign, Mul, Sub};

use bevy::math::{Mat3A, Vec3A};

/// A rigid motion (m/s, rad/s) or a load (N·s, N·m·s) of a node.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Six {
    /// Translation, or force.
    pub(super) t: Vec3A,
    /// Rotation, or torque.
    pub(super) r: Vec3A,
}

impl Six {
    pub(super) const ZERO: Self = Self {
        t: Vec3A::ZERO,
        r: Vec3A::ZERO,
    };

    /// The motion about a centre `d` (m) below this one's (`T v`).
    #[inline]
    pub(super) fn moved(self, d: Vec3A) -> Self {
        Self {
            t: self.t + self.r.cross(d),
            r: self.r,
        }
    }

    /// The load about a centre `d` (m) above this one's (`Tᵀ f`).
    #[inline]
    pub(super) fn lifted(self, d: Vec3A) -> Self {
        Self {
            t: self.t,
            r: self.r + d.cross(self.t),
        }
    }
}

impl Add for Six {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self {
            t: self.t + o.t,
            r: self.r + o.r,
        }
    }
}

impl Sub for Six {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self {
            t: self.t - o.t,
            r: self.r - o.r,
        }
    }
}

impl AddAssign for Six {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl Mul<Six> for f32 {
    type Output = Six;
    #[inline]
    fn mul(self, v: Six) -> Six {
        Six {
            t: self * v.t,
            r: self * v.r,
        }
    }
}

/// A 6×6 block `[[tt, tr], [rt, rr]]` over two nodes' motions (kg, kg·m,
/// kg·m²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Block6 {
    pub(super) tt: Mat3A,
    pub(super) tr: Mat3A,
    pub(super) rt: Mat3A,
    pub(super) rr: Mat3A,
}

impl Default for Block6 {
    fn default() -> Self {
        Self::ZERO
    }
}

/// `[d]×`: the matrix of `v ↦ d × v`.
#[inline]
pub(super) fn cross_matrix(d: Vec3A) -> Mat3A {
    Mat3A::from_cols(
        Vec3A::new(0.0, d.z, -d.y),
        Vec3A::new(-d.z, 0.0, d.x),
        Vec3A::new(d.y, -d.x, 0.0),
    )
}

impl Block6 {
    pub(super) const ZERO: Self = Self {
        tt: Mat3A::ZERO,
        tr: Mat3A::ZERO,
        rt: Mat3A::ZERO,
        rr: Mat3A::ZERO,
    };

    /// The block of `c` acting on translations alone.
    #[cfg(test)]
    pub(super) fn translation(c: Mat3A) -> Self {
        Self {
            tt: c,
            ..Self::ZERO
        }
    }

    /// `Tᵢᵀ B Tⱼ`: this block between two nodes, each moved to a centre
    /// `dᵢ`, `dⱼ` (m) above its own (module docs).
    pub(super) fn moved(&self, di: Vec3A, dj: Vec3A) -> Self {
        let (si, sj) = (cross_matrix(di), cross_matrix(dj));
        let rt = si * self.tt + self.rt;
        Self {
            tt: self.tt,
            tr: self.tr - self.tt * sj,
            rt,
            rr: self.rr + si * self.tr - rt * sj,
        }
    }

    pub(super) fn transpose(&self) -> Self {
        Self {
            tt: self.tt.transpose(),
            tr: self.rt.transpose(),
            rt: self.tr.transpose(),
            rr: self.rr.transpose(),
        }
    }

    #[inline]
    pub(super) fn mul(&self, v: Six) -> Six {
        Six {
            t: self.tt * v.t + self.tr * v.r,
            r: self.rt * v.t + self.rr * v.r,
        }
    }

    /// The inverse of a symmetric positive definite block, by its Schur
    /// complement; `None` when a pivot block is not invertible.
    pub(super) fn inverse(&self) -> Option<Self> {
        let p = invert(self.tt)?;
        let pq = p * self.tr;
        let s = invert(self.rr - self.rt * pq)?;
        let tr = -(pq * s);
        Some(Self {
            tt: p - tr * (self.rt * p),
            tr,
            rt: tr.transpose(),
            rr: s,
        })
    }
}

impl Add for Block6 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            tt: self.tt + o.tt,
            tr: self.tr + o.tr,
            rt: self.rt + o.rt,
            rr: self.rr + o.rr,
        }
    }
}

impl AddAssign for Block6 {
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

/// The inverse of a 3×3 block with a finite, positive determinant.
fn invert(m: Mat3A) -> Option<Mat3A> {
    let det = m.determinant();
    (det > 0.0 && det.is_finite()).then(|| m.inverse())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 6×6 matrix of a block, row-major.
    fn dense(b: &Block6) -> [[f32; 6]; 6] {
        let mut out = [[0.0; 6]; 6];
        for (k, m) in [b.tt, b.tr, b.rt, b.rr].iter().enumerate() {
            let (r0, c0) = (3 * (k / 2), 3 * (k % 2));
            for c in 0..3 {
                for r in 0..3 {
                    out[r0 + r][c0 + c] = m.col(c)[r];
                }
            }
        }
        out
    }

    fn block(seed: f32) -> Block6 {
        let m = |s: f32| {
            Mat3A::from_cols(
                Vec3A::new(s.sin(), (2.0 * s).cos(), 0.3 * s),
                Vec3A::new((1.7 * s).cos(), 1.0 + s.sin(), -0.2),
                Vec3A::new(0.4, (0.3 * s).sin(), 2.0 - s.cos()),
            )
        };
        Block6 {
            tt: m(seed),
            tr: m(seed + 1.0),
            rt: m(seed + 2.0),
            rr: m(seed + 3.0),
        }
    }

    /// `T` of a centre `d` as a dense 6×6.
    fn transfer(d: Vec3A) -> [[f32; 6]; 6] {
        dense(&Block6 {
            tt: Mat3A::IDENTITY,
            tr: -cross_matrix(d),
            rt: Mat3A::ZERO,
            rr: Mat3A::IDENTITY,
        })
    }

    fn product(a: &[[f32; 6]; 6], b: &[[f32; 6]; 6]) -> [[f32; 6]; 6] {
        let mut out = [[0.0; 6]; 6];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = (0..6).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        out
    }

    fn transpose(a: &[[f32; 6]; 6]) -> [[f32; 6]; 6] {
        let mut out = [[0.0; 6]; 6];
        for (i, row) in a.iter().enumerate() {
            for (j, &x) in row.iter().enumerate() {
                out[j][i] = x;
            }
        }
        out
    }

    fn close(a: &[[f32; 6]; 6], b: &[[f32; 6]; 6], tol: f32) {
        for i in 0..6 {
            for j in 0..6 {
                assert!((a[i][j] - b[i][j]).abs() <= tol, "{i},{j}: {a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn a_moved_block_is_the_transfers_product() {
        let b = block(0.7);
        let (di, dj) = (Vec3A::new(0.3, -0.2, 0.5), Vec3A::new(-0.1, 0.4, 0.2));
        let want = product(
            &transpose(&transfer(di)),
            &product(&dense(&b), &transfer(dj)),
        );
        close(&dense(&b.moved(di, dj)), &want, 1e-5);
        close(&dense(&b.transpose()), &transpose(&dense(&b)), 0.0);
        // A motion moved and a load lifted are `T v` and `Tᵀ f`.
        let v = Six {
            t: Vec3A::new(1.0, 2.0, -0.5),
            r: Vec3A::new(0.2, -0.7, 0.4),
        };
        let t = Block6 {
            tt: Mat3A::IDENTITY,
            tr: -cross_matrix(di),
            rt: Mat3A::ZERO,
            rr: Mat3A::IDENTITY,
        };
        assert!((t.mul(v).t - v.moved(di).t).length() < 1e-6);
        assert_eq!(t.mul(v).r, v.moved(di).r);
        assert!((t.transpose().mul(v).r - v.lifted(di).r).length() < 1e-6);
        assert_eq!(t.transpose().mul(v).t, v.lifted(di).t);
    }

    #[test]
    fn the_inverse_of_a_rigid_bodys_inertia_inverts_it() {
        // Three particles of 1, 2 and 3 kg about a point off their centre:
        // Σ mᵢ Qᵢᵀ Qᵢ, symmetric positive definite.
        let mut b = Block6::ZERO;
        for (m, x) in [
            (1.0, Vec3A::new(0.2, 0.0, 0.1)),
            (2.0, Vec3A::new(-0.3, 0.4, 0.0)),
            (3.0, Vec3A::new(0.1, -0.2, -0.5)),
        ] {
            b += Block6::translation(Mat3A::from_diagonal(bevy::math::Vec3::splat(m))).moved(x, x);
        }
        let inverse = b.inverse().expect("positive definite");
        let mut identity = [[0.0; 6]; 6];
        for (i, row) in identity.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        close(&product(&dense(&b), &dense(&inverse)), &identity, 1e-4);
        // Two particles have no inertia about the line through them.
        let mut line = Block6::ZERO;
        for x in [Vec3A::X, -Vec3A::X] {
            line += Block6::translation(Mat3A::IDENTITY).moved(x, x);
        }
        assert!(line.inverse().is_none());
    }
}
