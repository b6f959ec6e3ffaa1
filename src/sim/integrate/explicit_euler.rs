use bevy::math::Vec3;

/// The paper's explicit Euler (paper eq. 6, MODEL.md §6.1), exactly as written:
///
/// `v⁺ = v + a(x, v)·dt`, `x⁺ = x + v·dt` with the **old** velocity.
///
/// This is also Lander's `EulerIntegrate`. Its local error is `O(dt²)` and
/// its global error `O(dt)` (the paper's "O(dt²)" is the local one). For a
/// damped mode `ẍ = −ω²x − cẋ` it is stable only while `dt ≤ c/ω²`, and for
/// `c = 0` never: that bound, not accuracy, is why the paper measured a 64×
/// smaller step for Euler than for RK4. Use [`symplectic_euler`](super::symplectic_euler)
/// for the same cost without the bound.
///
/// `x` in m, `v` in m/s, `dt` in s; `accel` writes m/s² into its third
/// argument; `a` is scratch of one `Vec3` per particle.
#[inline(always)]
pub fn explicit_euler(
    x: &mut [Vec3],
    v: &mut [Vec3],
    dt: f32,
    a: &mut [Vec3],
    mut accel: impl FnMut(&[Vec3], &[Vec3], &mut [Vec3]),
) {
    accel(x, v, a);
    let (x, v, a) = (super::flat_mut(x), super::flat_mut(v), super::flat(a));
    for ((xi, vi), ai) in x.iter_mut().zip(v.iter_mut()).zip(a) {
        *xi += *vi * dt;
        *vi += *ai * dt;
    }
}
