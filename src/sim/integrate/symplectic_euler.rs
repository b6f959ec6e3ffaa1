use bevy::math::Vec3;

/// Symplectic (semi-implicit) Euler (MODEL.md §6.2):
///
/// `v⁺ = v + a(x, v)·dt`, `x⁺ = x + v⁺·dt` with the **new** velocity.
///
/// One force evaluation, like the paper's explicit Euler, but stable for
/// `dt ≤ (√(c² + 4ω²) − c)/ω² ≈ 2/ω_max` instead of `c/ω²`. First order.
///
/// `x` in m, `v` in m/s, `dt` in s; `a` is scratch of one `Vec3` per particle.
#[inline(always)]
pub fn symplectic_euler(
    x: &mut [Vec3],
    v: &mut [Vec3],
    dt: f32,
    a: &mut [Vec3],
    mut accel: impl FnMut(&[Vec3], &[Vec3], &mut [Vec3]),
) {
    accel(x, v, a);
    let (x, v, a) = (super::flat_mut(x), super::flat_mut(v), super::flat(a));
    for ((xi, vi), ai) in x.iter_mut().zip(v.iter_mut()).zip(a) {
        *vi += *ai * dt;
        *xi += *vi * dt;
    }
}
