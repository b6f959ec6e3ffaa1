//! The pair-force kernel shared by both models.
//!
//! A pair force is `F_a = f(ℓ)·u`, `F_b = −F_a` with `u = (x_b − x_a)/ℓ`,
//! from the link family's force [`Law`]. [`pair_forces`] adds them link by
//! link into a [`Target`]: the whole force array, or one band's window of it
//! ([`bands`](super::bands)).
//!
//! Profiled on 15×15 (4 ns per link): the cost is the data-dependent
//! branch between slack and taut links and the square root and division of
//! the taut ones. A branch-free version, a blocked structure-of-arrays
//! version (packed `sqrtps`/`divps`) and a version summing each particle's
//! links in a register were all 15–40% slower, so the loop stays plain.

use bevy::math::Vec3;

use super::buckling::{BucklingTable, MIN_LENGTH, type2_magnitude};
use crate::sim::connections::Link;

/// The force law of a family of links.
#[derive(Clone, Copy, Debug)]
pub enum Law<'a> {
    /// Choi–Ko Type 1, tension only: `[k(ℓ − L) + k_d (v_ab·u)]·u` while
    /// `ℓ ≥ L`, else 0. `k` in N/m, `k_d` in N·s/m.
    Tension {
        /// Stiffness `k` (N/m).
        k: f32,
        /// Axial pair damping `k_d` (N·s/m).
        kd: f32,
    },
    /// Choi–Ko Type 2, compression only: `f_b*(ℓ)·u` for `ℓ < L`
    /// ([`type2_magnitude`]).
    Buckling {
        /// The `g(s)` table.
        table: &'a BucklingTable,
        /// Bending rigidity `k_b` (N·m²).
        kb: f32,
        /// Pre-buckling slope `c_b` (N/m).
        cb: f32,
    },
    /// Lander's two-sided damped spring: `[k_s(ℓ − L) + k_d (v_ab·u)]·u`.
    Spring {
        /// Stiffness `k_s` (N/m).
        ks: f32,
        /// Damping `k_d` (N·s/m).
        kd: f32,
    },
}

/// The force (N) on `a` of a Type 1 link `a → b` of rest length `rest`
/// (m), `d = x_b − x_a` (m); `None` while slack.
#[inline(always)]
fn tension(d: Vec3, rest: f32, k: f32, kd: f32, dv: impl Fn() -> Vec3) -> Option<Vec3> {
    // Slack links (most of a hanging cloth's) leave before the sqrt.
    let len2 = d.length_squared();
    if len2 < rest * rest || len2 < MIN_LENGTH * MIN_LENGTH {
        return None;
    }
    let len = len2.sqrt();
    let inv = 1.0 / len;
    let mut mag = k * (len - rest);
    if kd != 0.0 {
        mag += kd * dv().dot(d) * inv;
    }
    Some(d * (mag * inv))
}

/// The force (N) on `a` of a Type 2 link; `None` at or beyond rest length.
#[inline(always)]
fn buckling(d: Vec3, rest: f32, table: &BucklingTable, kb: f32, cb: f32) -> Option<Vec3> {
    // Links at or beyond rest length (most of them) leave before the sqrt.
    let len2 = d.length_squared();
    if len2 >= rest * rest || len2 < MIN_LENGTH * MIN_LENGTH {
        return None;
    }
    let len = len2.sqrt();
    let (mag, _) = type2_magnitude(table, len, rest, kb, cb);
    Some(d * (mag / len))
}

/// The force (N) on `a` of one of Lander's springs.
#[inline(always)]
fn spring(d: Vec3, rest: f32, ks: f32, kd: f32, dv: impl Fn() -> Vec3) -> Option<Vec3> {
    let len = d.length();
    if len < MIN_LENGTH {
        return None;
    }
    let inv = 1.0 / len;
    let mag = ks * (len - rest) + kd * dv().dot(d) * inv;
    Some(d * (mag * inv))
}

/// Where the kernel adds its forces: `f[p − base]` for particle `p`.
#[derive(Debug)]
pub struct Target<'a> {
    /// Forces (N) of a window of particles.
    pub f: &'a mut [Vec3],
    /// Index of the window's first particle.
    pub base: usize,
}

/// Adds the forces of every `(links, law)` family to `out`, family by
/// family in link order.
///
/// Positions `x` in m, velocities `v` in m/s (read only by damped laws).
/// Returns `false`, skipping the link, if a link's end fell outside the
/// target window (the parallel bands check their windows with this).
pub fn pair_forces(families: &[(&[Link], Law)], x: &[Vec3], v: &[Vec3], out: &mut Target) -> bool {
    let mut inside = true;
    for &(links, law) in families {
        inside &= match law {
            Law::Tension { k, kd } => each(links, x, out, |d, rest, a, b| {
                tension(d, rest, k, kd, || v[b] - v[a])
            }),
            Law::Buckling { table, kb, cb } => each(links, x, out, |d, rest, _, _| {
                buckling(d, rest, table, kb, cb)
            }),
            Law::Spring { ks, kd } => each(links, x, out, |d, rest, a, b| {
                spring(d, rest, ks, kd, || v[b] - v[a])
            }),
        };
    }
    inside
}

/// One family's loop, specialised for its law: `force(d, L, a, b)`.
#[inline(always)]
fn each(
    links: &[Link],
    x: &[Vec3],
    out: &mut Target,
    force: impl Fn(Vec3, f32, usize, usize) -> Option<Vec3>,
) -> bool {
    let mut inside = true;
    for l in links {
        let (a, b) = (l.a as usize, l.b as usize);
        let Some(force) = force(x[b] - x[a], l.rest_length, a, b) else {
            continue;
        };
        let (wa, wb) = (a.wrapping_sub(out.base), b.wrapping_sub(out.base));
        if wa < out.f.len() && wb < out.f.len() {
            out.f[wa] += force;
            out.f[wb] -= force;
        } else {
            inside = false;
        }
    }
    inside
}
