//! The exact tests of [`ccd`](super): when four points moving on straight
//! lines become coplanar, and whether a particle is then inside a triangle
//! or two edges meet. Double precision throughout; positions in m.

use bevy::math::{DVec3, Vec3};

use super::Crossing;

/// The roots in `[0, 1]` of `k0 + k1 t + k2 t² + k3 t³` where it changes
/// sign by more than `noise` either way, earliest first, at most three.
pub(super) fn sign_changes([k0, k1, k2, k3]: [f64; 4], noise: f64, out: &mut [f64; 3]) -> usize {
    let f = |t: f64| ((k3 * t + k2) * t + k1) * t + k0;
    // Split [0, 1] where the derivative 3 k3 t² + 2 k2 t + k1 vanishes.
    let mut cuts = [0.0, 1.0, 1.0, 1.0];
    let mut n = 1;
    let (a, b, c) = (3.0 * k3, 2.0 * k2, k1);
    let mut critical = |t: f64| {
        if t > 0.0 && t < 1.0 {
            cuts[n] = t;
            n += 1;
        }
    };
    if a.abs() > 1e-300 {
        let disc = b * b - 4.0 * a * c;
        if disc > 0.0 {
            let r = disc.sqrt();
            let q = -0.5 * (b + b.signum() * r);
            let (t0, t1) = (q / a, if q != 0.0 { c / q } else { -b / a });
            let (t0, t1) = (t0.min(t1), t0.max(t1));
            critical(t0);
            critical(t1);
        }
    } else if b.abs() > 1e-300 {
        critical(-c / b);
    }
    cuts[n] = 1.0;
    let mut roots = 0;
    for i in 0..n {
        let (mut lo, mut hi) = (cuts[i], cuts[i + 1]);
        let (flo, fhi) = (f(lo), f(hi));
        if !((flo > noise && fhi < -noise) || (flo < -noise && fhi > noise)) {
            continue;
        }
        let rising = fhi > 0.0;
        for _ in 0..48 {
            let mid = 0.5 * (lo + hi);
            if (f(mid) > 0.0) == rising {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        out[roots] = 0.5 * (lo + hi);
        roots += 1;
    }
    roots
}

/// The coefficients in `t` of `((b - a) × (c - a)) · (d - a)` for points
/// moving at constant velocity from `p0` to `p1` over `t ∈ [0, 1]`.
fn coplanarity(p0: [DVec3; 4], p1: [DVec3; 4]) -> [f64; 4] {
    let (a0, a1) = (p0[1] - p0[0], p1[1] - p1[0]);
    let (b0, b1) = (p0[2] - p0[0], p1[2] - p1[0]);
    let (c0, c1) = (p0[3] - p0[0], p1[3] - p1[0]);
    let (da, db, dc) = (a1 - a0, b1 - b0, c1 - c0);
    let ab = a0.cross(b0);
    let ab1 = a0.cross(db) + da.cross(b0);
    let ab2 = da.cross(db);
    [
        ab.dot(c0),
        ab.dot(dc) + ab1.dot(c0),
        ab1.dot(dc) + ab2.dot(c0),
        ab2.dot(dc),
    ]
}

/// How far from zero the coplanarity product of four points (m³) may be by
/// the rounding of their single-precision positions alone: points that
/// coincide (the two sides of a tear) or lie in one plane are not taken
/// for being on either side.
fn rounding(p0: [DVec3; 4], p1: [DVec3; 4]) -> f64 {
    let reach = p0
        .iter()
        .chain(&p1)
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    let length = |i: usize| (p0[i] - p0[0]).length().max((p1[i] - p1[0]).length());
    let (a, b, c) = (length(1), length(2), length(3));
    let delta = 4.0 * f32::EPSILON as f64 * reach.max(1.0);
    delta * (a * b + b * c + c * a) + 1e-12 * a * b * c
}

pub(super) fn wide(p: Vec3) -> DVec3 {
    p.as_dvec3()
}

/// Barycentric weights of `p` on triangle `[a, b, c]` (double precision).
fn barycentric(p: DVec3, [a, b, c]: [DVec3; 3]) -> Option<[f64; 3]> {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
    let (d20, d21) = (v2.dot(v0), v2.dot(v1));
    let denom = d00 * d11 - d01 * d01;
    if denom.is_nan() || denom.abs() <= 1e-30 {
        return None;
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    Some([1.0 - v - w, v, w])
}

/// Parameters `(s, u)` of the closest points of segments `p0 p1` and
/// `q0 q1`, and their distance (double precision).
fn segments_closest(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> (f64, f64, f64) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.dot(d1), d2.dot(d2), d2.dot(r));
    let (s, u) = if a <= 1e-30 && e <= 1e-30 {
        (0.0, 0.0)
    } else if a <= 1e-30 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= 1e-30 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-30 * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut u = (b * s + f) / e;
            if u < 0.0 {
                u = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if u > 1.0 {
                u = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, u)
        }
    };
    let gap = (p0 + d1 * s) - (q0 + d2 * u);
    (s, u, gap.length())
}

/// The normal of the crossing, turned towards where the separation
/// `weights · x` pointed at the start (or away from where it points at the
/// end, when the features started in one plane).
fn oriented(normal: DVec3, weights: [f64; 4], p0: [DVec3; 4], p1: [DVec3; 4]) -> Option<Vec3> {
    let n = normal.try_normalize()?;
    let sep = |p: [DVec3; 4]| (0..4).map(|i| weights[i] * p[i]).sum::<DVec3>().dot(n);
    let (before, after) = (sep(p0), sep(p1));
    let sign = if before != 0.0 {
        before.signum()
    } else if after != 0.0 {
        -after.signum()
    } else {
        return None;
    };
    Some((n * sign).as_vec3())
}

/// Whether particle `p` passes through triangle `tri` during the step, and
/// how.
pub fn point_triangle(p: u32, tri: [u32; 3], start: &[Vec3], end: &[Vec3]) -> Option<Crossing> {
    let ids = [tri[0], tri[1], tri[2], p];
    let p0 = ids.map(|i| wide(start[i as usize]));
    let p1 = ids.map(|i| wide(end[i as usize]));
    let mut roots = [0.0; 3];
    let found = sign_changes(coplanarity(p0, p1), rounding(p0, p1), &mut roots);
    for &t in &roots[..found] {
        let at = std::array::from_fn::<DVec3, 4, _>(|i| p0[i].lerp(p1[i], t));
        let Some(b) = barycentric(at[3], [at[0], at[1], at[2]]) else {
            continue;
        };
        if b.iter().any(|&b| b < -1e-6) {
            continue;
        }
        let weights = [1.0, -b[0], -b[1], -b[2]];
        let order = [3, 0, 1, 2];
        let (q0, q1) = (order.map(|i| p0[i]), order.map(|i| p1[i]));
        let normal = (at[1] - at[0]).cross(at[2] - at[0]);
        let normal = oriented(normal, weights, q0, q1)?;
        return Some(Crossing {
            particles: [p, tri[0], tri[1], tri[2]],
            weights: weights.map(|w| w as f32),
            normal,
            at: t as f32,
        });
    }
    None
}

/// Whether edges `e` and `f` pass through each other during the step, and
/// how.
pub fn edge_edge(e: [u32; 2], f: [u32; 2], start: &[Vec3], end: &[Vec3]) -> Option<Crossing> {
    let ids = [e[0], e[1], f[0], f[1]];
    let p0 = ids.map(|i| wide(start[i as usize]));
    let p1 = ids.map(|i| wide(end[i as usize]));
    let mut roots = [0.0; 3];
    let found = sign_changes(coplanarity(p0, p1), rounding(p0, p1), &mut roots);
    for &t in &roots[..found] {
        let at = std::array::from_fn::<DVec3, 4, _>(|i| p0[i].lerp(p1[i], t));
        let (s, u, gap) = segments_closest(at[0], at[1], at[2], at[3]);
        let scale = (at[1] - at[0]).length() + (at[3] - at[2]).length();
        if gap.is_nan() || gap > 1e-6 * scale {
            continue;
        }
        let weights = [1.0 - s, s, -(1.0 - u), -u];
        let (d1, d2) = (at[1] - at[0], at[3] - at[2]);
        let mut normal = d1.cross(d2);
        if normal.length_squared() < 1e-4 * d1.length_squared() * d2.length_squared() {
            // Nearly parallel: the edges' plane is ill-defined; part them
            // along where they were apart at the start, off the edge.
            let apart = (0..4).map(|i| weights[i] * p0[i]).sum::<DVec3>();
            normal = apart - d1 * apart.dot(d1) / d1.length_squared().max(1e-30);
        }
        let normal = oriented(normal, weights, p0, p1)?;
        return Some(Crossing {
            particles: ids,
            weights: weights.map(|w| w as f32),
            normal,
            at: t as f32,
        });
    }
    None
}
