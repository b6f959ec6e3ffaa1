//! Analytic collider shapes as exact signed distance functions in the
//! collider's local frame (pure functions, no ECS).
//!
//! [`Shape::distance`] returns the signed distance in m (negative inside)
//! and the outward unit normal of the closest surface point. Every function
//! here is an exact Euclidean distance, so `sweep` can advance along a
//! segment by the distance without skipping the surface (conservative
//! advancement).

use bevy::math::{Vec2, Vec3};
use bevy::reflect::Reflect;

/// An analytic solid in its local frame (metres).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum Shape {
    /// A ball of `radius` m centred on the origin.
    Sphere {
        /// Radius in m.
        radius: f32,
    },
    /// The half-space `y ≤ 0`: a floor whose surface is the local XZ plane
    /// and whose outward normal is +Y.
    Plane,
    /// A box centred on the origin.
    Cuboid {
        /// Half the size along each local axis, m.
        half_extents: Vec3,
    },
    /// A capsule along the local Y axis (as Bevy's `Capsule3d`).
    Capsule {
        /// Radius in m.
        radius: f32,
        /// Half the length of the inner segment, m.
        half_length: f32,
    },
    /// A solid cylinder along the local Y axis (as Bevy's `Cylinder`): a
    /// round table top, a pole.
    Cylinder {
        /// Radius in m.
        radius: f32,
        /// Half the height, m.
        half_height: f32,
    },
    /// A solid cone along local Y: its round base of `radius` m at
    /// `y = −half_height`, its apex at `y = +half_height` (m).
    Cone {
        /// Radius of the base, m.
        radius: f32,
        /// Half the height, m.
        half_height: f32,
    },
}

impl Shape {
    /// Signed distance (m, negative inside) from local point `p` to the
    /// surface, and the outward unit normal there.
    pub fn distance(&self, p: Vec3) -> (f32, Vec3) {
        match *self {
            Shape::Sphere { radius } => {
                let len = p.length();
                let n = if len > 1e-12 { p / len } else { Vec3::Y };
                (len - radius, n)
            }
            Shape::Plane => (p.y, Vec3::Y),
            Shape::Cuboid { half_extents } => box_distance(p, half_extents),
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let axis = Vec3::new(0.0, p.y.clamp(-half_length, half_length), 0.0);
                let d = p - axis;
                let len = d.length();
                let n = if len > 1e-12 { d / len } else { Vec3::X };
                (len - radius, n)
            }
            Shape::Cylinder {
                radius,
                half_height,
            } => cylinder_distance(p, radius, half_height),
            Shape::Cone {
                radius,
                half_height,
            } => cone_distance(p, radius, half_height),
        }
    }

    /// The shape's support along unit direction `u`: the largest `p · u`
    /// (m) over its points (`∞` for the plane, except straight down).
    pub fn support(&self, u: Vec3) -> f32 {
        let across = |u: Vec3| Vec2::new(u.x, u.z).length();
        match *self {
            Shape::Sphere { radius } => radius,
            Shape::Plane => {
                if u.y <= -1.0 + 1e-6 {
                    0.0
                } else {
                    f32::INFINITY
                }
            }
            Shape::Cuboid { half_extents } => u.abs().dot(half_extents),
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length * u.y.abs(),
            Shape::Cylinder {
                radius,
                half_height,
            } => radius * across(u) + half_height * u.y.abs(),
            Shape::Cone {
                radius,
                half_height,
            } => (half_height * u.y).max(radius * across(u) - half_height * u.y),
        }
    }

    /// Radius in m of a ball around the local origin that holds the shape
    /// (`∞` for the plane), for the broad phase.
    pub fn bounding_radius(&self) -> f32 {
        match *self {
            Shape::Sphere { radius } => radius,
            Shape::Plane => f32::INFINITY,
            Shape::Cuboid { half_extents } => half_extents.length(),
            Shape::Capsule {
                radius,
                half_length,
            } => radius + half_length,
            Shape::Cylinder {
                radius,
                half_height,
            } => Vec2::new(radius, half_height).length(),
            Shape::Cone {
                radius,
                half_height,
            } => Vec2::new(radius, half_height).length(),
        }
    }

    /// Whether every dimension is finite and positive.
    pub fn is_valid(&self) -> bool {
        let ok = |v: f32| v.is_finite() && v > 0.0;
        match *self {
            Shape::Sphere { radius } => ok(radius),
            Shape::Plane => true,
            Shape::Cuboid { half_extents } => half_extents.to_array().into_iter().all(ok),
            Shape::Capsule {
                radius,
                half_length,
            } => ok(radius) && half_length.is_finite() && half_length >= 0.0,
            Shape::Cylinder {
                radius,
                half_height,
            } => ok(radius) && ok(half_height),
            Shape::Cone {
                radius,
                half_height,
            } => ok(radius) && ok(half_height),
        }
    }
}

fn box_distance(p: Vec3, h: Vec3) -> (f32, Vec3) {
    let q = p.abs() - h;
    let outside = q.max(Vec3::ZERO);
    if outside != Vec3::ZERO {
        let len = outside.length();
        return (len, (outside * p.signum()) / len);
    }
    // Inside: the nearest face is the one with the largest q.
    let (d, axis) = if q.x >= q.y && q.x >= q.z {
        (q.x, Vec3::X * p.x.signum())
    } else if q.y >= q.z {
        (q.y, Vec3::Y * p.y.signum())
    } else {
        (q.z, Vec3::Z * p.z.signum())
    };
    (d, axis)
}

/// Signed distance (m) and outward normal of a cone (see [`Shape::Cone`]),
/// worked in the half-plane of the axis and the point: the boundary is the
/// slant from the apex to the rim and the base from the rim to the axis.
fn cone_distance(p: Vec3, radius: f32, half_height: f32) -> (f32, Vec3) {
    let r = Vec2::new(p.x, p.z);
    let rl = r.length();
    let radial = if rl > 1e-12 { r / rl } else { Vec2::X };
    let to3 = |n: Vec2| Vec3::new(radial.x * n.x, n.y, radial.y * n.x);
    let q = Vec2::new(rl, p.y);
    let (apex, rim) = (Vec2::new(0.0, half_height), Vec2::new(radius, -half_height));
    let slant = rim - apex;
    let t = ((q - apex).dot(slant) / slant.length_squared()).clamp(0.0, 1.0);
    let on_slant = apex + t * slant;
    let on_base = Vec2::new(rl.min(radius), -half_height);
    let (d_slant, d_base) = (q.distance(on_slant), q.distance(on_base));
    let inside = p.y >= -half_height && rl * 2.0 * half_height <= radius * (half_height - p.y);
    let slant_normal = Vec2::new(2.0 * half_height, radius).normalize();
    if inside {
        return if d_slant <= d_base {
            (-d_slant, to3(slant_normal))
        } else {
            (-d_base, Vec3::NEG_Y)
        };
    }
    let (d, nearest, face) = if d_slant <= d_base {
        (d_slant, on_slant, slant_normal)
    } else {
        (d_base, on_base, Vec2::NEG_Y)
    };
    let n = if d > 1e-9 { (q - nearest) / d } else { face };
    (d, to3(n))
}

fn cylinder_distance(p: Vec3, radius: f32, half_height: f32) -> (f32, Vec3) {
    let r = Vec2::new(p.x, p.z);
    let rl = r.length();
    let radial = if rl > 1e-12 { r / rl } else { Vec2::X };
    let radial3 = Vec3::new(radial.x, 0.0, radial.y);
    let axial3 = Vec3::Y * p.y.signum();
    let q = Vec2::new(rl - radius, p.y.abs() - half_height);
    let outside = q.max(Vec2::ZERO);
    if outside != Vec2::ZERO {
        let len = outside.length();
        let n = (radial3 * outside.x + axial3 * outside.y) / len;
        return (len, n);
    }
    if q.x >= q.y {
        (q.x, radial3)
    } else {
        (q.y, axial3)
    }
}

/// The first point of the segment `p0 → p1` (local, m) that comes within
/// `margin` m of `shape`, as the fraction `t ∈ [0, 1]` along the segment;
/// `Some(0.0)` if `p0` already is, `None` if the segment stays clear.
///
/// Spheres and planes are solved in closed form; the other shapes by
/// conservative advancement (`advance`).
pub(crate) fn sweep(shape: &Shape, p0: Vec3, p1: Vec3, margin: f32) -> Option<f32> {
    // Contact within this much of the margin (m), as `advance` stops.
    let reach = margin + SWEEP_TOLERANCE;
    match *shape {
        Shape::Sphere { radius } => {
            // |p0 + t·δ|² = r²: a t² + 2 b t + c = 0.
            let r = radius + reach;
            let c = p0.length_squared() - r * r;
            if c <= 0.0 {
                return Some(0.0);
            }
            let delta = p1 - p0;
            let (a, b) = (delta.length_squared(), p0.dot(delta));
            let disc = b * b - a * c;
            if b >= 0.0 || disc < 0.0 {
                return None; // moving away, or passing by
            }
            // The nearer root, written so that it does not cancel.
            let t = c / (-b + disc.sqrt());
            (t <= 1.0).then_some(t)
        }
        Shape::Plane => {
            if p0.y <= reach {
                Some(0.0)
            } else if p1.y > reach {
                None
            } else {
                Some(((p0.y - reach) / (p0.y - p1.y)).min(1.0))
            }
        }
        _ => advance(shape, p0, p1, margin),
    }
}

/// How close (m) to `margin` a sweep counts as contact.
const SWEEP_TOLERANCE: f32 = 1e-6;

/// [`sweep`] by conservative advancement: step by the distance to the
/// surface, which can never cross it, so a fast particle cannot tunnel
/// through a thin shape. A particle grazing the surface takes many steps,
/// so the shapes with a closed form do not come here.
fn advance(shape: &Shape, p0: Vec3, p1: Vec3, margin: f32) -> Option<f32> {
    let delta = p1 - p0;
    let len = delta.length();
    let mut t = 0.0_f32;
    for _ in 0..64 {
        let (d, _) = shape.distance(p0 + delta * t);
        let gap = d - margin;
        if gap <= SWEEP_TOLERANCE {
            return Some(t);
        }
        if len < 1e-12 {
            return None;
        }
        t += gap / len;
        if t > 1.0 {
            return None;
        }
    }
    // Grazing the surface for 64 steps: treat it as contact.
    Some(t.min(1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks the distance against brute force: `d` is the exact distance
    /// when outside (to within a point sampled on the surface) and the
    /// normal is the gradient (finite differences).
    fn check_gradient(shape: Shape, p: Vec3) {
        let (d, n) = shape.distance(p);
        let e = 1e-3;
        let g = Vec3::new(
            shape.distance(p + Vec3::X * e).0 - shape.distance(p - Vec3::X * e).0,
            shape.distance(p + Vec3::Y * e).0 - shape.distance(p - Vec3::Y * e).0,
            shape.distance(p + Vec3::Z * e).0 - shape.distance(p - Vec3::Z * e).0,
        ) / (2.0 * e);
        assert!(
            (g - n).length() < 1e-2,
            "{shape:?} at {p}: n {n}, gradient {g}, d {d}"
        );
        assert!((n.length() - 1.0).abs() < 1e-5);
        // The closest surface point is p − d·n and lies on the surface.
        let s = p - d * n;
        assert!(shape.distance(s).0.abs() < 1e-4, "{shape:?} at {p}");
    }

    #[test]
    fn distances_and_normals_of_every_shape() {
        let shapes = [
            Shape::Sphere { radius: 0.5 },
            Shape::Plane,
            Shape::Cuboid {
                half_extents: Vec3::new(0.5, 0.2, 0.3),
            },
            Shape::Capsule {
                radius: 0.2,
                half_length: 0.4,
            },
            Shape::Cylinder {
                radius: 0.6,
                half_height: 0.05,
            },
            Shape::Cone {
                radius: 0.4,
                half_height: 0.3,
            },
        ];
        let points = [
            Vec3::new(1.0, 0.3, -0.2),
            Vec3::new(0.1, 0.05, 0.05),
            Vec3::new(-0.3, -0.9, 0.4),
            Vec3::new(0.0, 0.8, 0.0),
            Vec3::new(0.7, 0.1, 0.4),
        ];
        for shape in shapes {
            for p in points {
                check_gradient(shape, p);
            }
        }
        assert_eq!(
            Shape::Sphere { radius: 1.0 }
                .distance(Vec3::new(0.0, 3.0, 0.0))
                .0,
            2.0
        );
        let table = Shape::Cylinder {
            radius: 0.6,
            half_height: 0.05,
        };
        // Above the top: distance to the top face, normal up.
        assert_eq!(table.distance(Vec3::new(0.3, 0.25, 0.0)), (0.2, Vec3::Y));
        // Beside the rim: radial distance.
        let (d, n) = table.distance(Vec3::new(0.0, 0.0, 1.0));
        assert!((d - 0.4).abs() < 1e-6 && (n - Vec3::Z).length() < 1e-6);
        let floor = Shape::Plane;
        assert_eq!(floor.distance(Vec3::new(3.0, -0.25, 1.0)), (-0.25, Vec3::Y));
    }

    #[test]
    fn sweep_finds_the_entry_of_a_fast_segment_through_a_thin_shape() {
        // A 1 cm slab crossed in one step: sampling the ends would miss it.
        let slab = Shape::Cuboid {
            half_extents: Vec3::new(1.0, 0.005, 1.0),
        };
        let t = sweep(
            &slab,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            0.0,
        )
        .unwrap();
        assert!((t - 0.4975).abs() < 1e-4, "{t}");
        // With a margin it stops earlier.
        let t = sweep(
            &slab,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            0.1,
        )
        .unwrap();
        assert!((t - 0.4475).abs() < 1e-4, "{t}");
        // Passing beside it: no contact; starting inside: contact at 0.
        assert_eq!(
            sweep(
                &slab,
                Vec3::new(2.0, 1.0, 0.0),
                Vec3::new(2.0, -1.0, 0.0),
                0.0
            ),
            None
        );
        assert_eq!(sweep(&slab, Vec3::ZERO, Vec3::Y, 0.0), Some(0.0));
    }

    #[test]
    fn closed_form_sweeps_agree_with_conservative_advancement() {
        // Segments from all around a sphere and a plane, fast and grazing.
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        let (mut hits, mut misses) = (0, 0);
        for shape in [Shape::Sphere { radius: 0.3 }, Shape::Plane] {
            for k in 0..4000 {
                let p0 = Vec3::new(next(), next(), next()) * 0.6;
                // Every other segment short, as a resting particle moves.
                let scale = if k % 2 == 0 { 0.8 } else { 0.004 };
                let p1 = p0 + Vec3::new(next(), next(), next()) * scale;
                let margin = 0.005;
                let (exact, stepped) = (
                    sweep(&shape, p0, p1, margin),
                    advance(&shape, p0, p1, margin),
                );
                match (exact, stepped) {
                    (Some(a), Some(b)) => {
                        hits += 1;
                        let len = p0.distance(p1);
                        let gap = |t: f32| shape.distance(p0.lerp(p1, t)).0 - margin;
                        // The closed form lands on the margin (or starts
                        // inside it); advancement never passes it, and
                        // where it converged rather than ran out of steps
                        // it agrees.
                        assert!(
                            gap(a) < 1e-5 && (a == 0.0 || gap(a) > -1e-5),
                            "{p0} {p1}: {a}"
                        );
                        assert!(
                            b <= a + 1e-5 / len.max(1e-3),
                            "{shape:?} {p0} {p1}: {a} {b}"
                        );
                        if gap(b) <= 2e-6 {
                            assert!((a - b) * len < 1e-5, "{shape:?} {p0} {p1}: {a} {b}");
                        }
                    }
                    (None, None) => misses += 1,
                    // Advancement calls 64 grazing steps contact; the
                    // segment must in fact stay clear.
                    (None, Some(b)) => {
                        let closest = (0..=2000)
                            .map(|s| shape.distance(p0.lerp(p1, s as f32 / 2000.0)).0 - margin)
                            .fold(f32::INFINITY, f32::min);
                        assert!(
                            closest > -1e-5,
                            "{shape:?} {p0} {p1}: advance {b}, {closest}"
                        );
                    }
                    (Some(a), None) => panic!("{shape:?} {p0} {p1}: closed form {a} only"),
                }
            }
        }
        assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
    }

    #[test]
    fn validity() {
        assert!(Shape::Sphere { radius: 1.0 }.is_valid());
        assert!(!Shape::Sphere { radius: 0.0 }.is_valid());
        assert!(
            !Shape::Cylinder {
                radius: 1.0,
                half_height: f32::NAN
            }
            .is_valid()
        );
        assert!(
            Shape::Capsule {
                radius: 1.0,
                half_length: 0.0
            }
            .is_valid()
        );
        assert!(
            !Shape::Cuboid {
                half_extents: Vec3::new(1.0, -1.0, 1.0)
            }
            .is_valid()
        );
    }
}
