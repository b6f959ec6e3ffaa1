//! Force models as plain functions over slices: no ECS types here.
//!
//! - [`choi_ko`]: Type 1 tension-only springs and Type 2 buckling links.
//! - [`lander`]: two-sided damped springs (the seed's baseline).
//! - [`Dynamics::accelerations`]: seed eq. 5, `a = M⁻¹F + g − c·v`, with
//!   pinned particles (inverse mass 0) held at zero acceleration.

pub mod bands;
pub mod choi_ko;
pub mod jacobian;
pub mod kernel;
pub mod lander;

use bevy::math::Vec3;

use crate::connections::{ClothConnections, Link};
use crate::settings::{ClothModel, ClothSettings, SpringParams};
use kernel::{Law, Target};

pub use choi_ko::{BUCKLING_TABLE, BucklingTable};

/// Adds the internal forces (N) of `settings.model` over `connections` to `f`,
/// on one thread, family by family.
///
/// Internal forces are sums of equal and opposite pair forces, so they add
/// up to zero over the cloth.
pub fn internal_forces(
    settings: &ClothSettings,
    connections: &ClothConnections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) {
    let families = [
        &connections.structural[..],
        &connections.shear,
        &connections.bend,
        &connections.bend_diagonal,
    ];
    let mut out = Target { f, base: 0 };
    grid_forces(settings, families, x, v, &mut out);
    extra_forces(settings, connections, x, v, out.f);
}

/// The forces of the four grid families (structural, shear, bend, bend
/// diagonal) into `out`; `false` if a link fell outside its window.
fn grid_forces(
    settings: &ClothSettings,
    [structural, shear, bend, bend_diagonal]: [&[Link]; 4],
    x: &[Vec3],
    v: &[Vec3],
    out: &mut Target,
) -> bool {
    match settings.model {
        ClothModel::ChoiKo => {
            let p = &settings.choi_ko;
            let tension = Law::Tension {
                k: p.stiffness,
                kd: p.pair_damping,
            };
            let buckling = Law::Buckling {
                table: &BUCKLING_TABLE,
                kb: p.bending_rigidity,
                cb: p.buckling_slope,
            };
            let families = [
                (structural, tension),
                (shear, tension),
                (bend, buckling),
                (bend_diagonal, buckling),
            ];
            kernel::pair_forces(&families, x, v, out)
        }
        ClothModel::Lander => {
            let p = &settings.lander;
            let spring = |s: SpringParams| Law::Spring {
                ks: s.stiffness,
                kd: s.damping,
            };
            let families = [
                (structural, spring(p.structural)),
                (shear, spring(p.shear)),
                (bend, spring(p.bend)),
            ];
            kernel::pair_forces(&families, x, v, out)
        }
    }
}

/// The forces of crease springs (Type 1 links of rest length L', MODEL.md
/// §9.1) and fold-direction terms, which may join any two particles.
fn extra_forces(
    settings: &ClothSettings,
    connections: &ClothConnections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) {
    let (k, kd) = match settings.model {
        ClothModel::ChoiKo => (settings.choi_ko.stiffness, settings.choi_ko.pair_damping),
        ClothModel::Lander => {
            let s = settings.lander.structural;
            (s.stiffness, s.damping)
        }
    };
    let mut out = Target { f, base: 0 };
    let tension = Law::Tension { k, kd };
    kernel::pair_forces(&[(&connections.crease, tension)], x, v, &mut out);
    crate::connections::fold_forces(&connections.fold, x, out.f);
}

/// Everything the acceleration of a cloth depends on besides its state.
#[derive(Clone, Copy, Debug)]
pub struct Dynamics<'a> {
    /// Model, constants, gravity and damping.
    pub settings: &'a ClothSettings,
    /// The pairs the internal forces act on.
    pub connections: &'a ClothConnections,
    /// Inverse masses in 1/kg; 0 pins a particle.
    pub inverse_masses: &'a [f32],
    /// External forces in N held constant over the step (wind, grabs); empty
    /// for none, otherwise one per particle.
    pub external: &'a [Vec3],
}

impl Dynamics<'_> {
    /// Overwrites `out` with the external forces (N), or zeros if there are none.
    fn external_forces(&self, out: &mut [Vec3]) {
        if self.external.len() == out.len() {
            out.copy_from_slice(self.external);
        } else {
            out.fill(Vec3::ZERO);
        }
    }

    /// Writes the accelerations (m/s²) at state `(x, v)` into `out`:
    /// `a_i = w_i (F_int + F_ext)_i + g − c·v_i` for free particles, 0 for
    /// pinned ones (`w_i = 0`), so a pin keeps whatever velocity it was given.
    pub fn accelerations(&self, x: &[Vec3], v: &[Vec3], out: &mut [Vec3]) {
        self.external_forces(out);
        let banded = self.settings.parallel.banded(out.len());
        if !(banded && bands::internal_forces_banded(self.settings, self.connections, x, v, out)) {
            if banded {
                // Not a layout the bands can split: start over on one thread.
                self.external_forces(out);
            }
            internal_forces(self.settings, self.connections, x, v, out);
        }
        let g = self.settings.gravity;
        let c = self.settings.damping;
        for ((a, &w), &vi) in out.iter_mut().zip(self.inverse_masses).zip(v) {
            *a = if w == 0.0 {
                Vec3::ZERO
            } else {
                w * *a + g - c * vi
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny deterministic generator (xorshift) so the tests need no crate.
    struct Rng(u64);
    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        }
        fn vec(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.unit(), self.unit(), self.unit()) * scale
        }
    }

    #[test]
    fn internal_forces_sum_to_zero_on_a_random_deformed_grid() {
        let (n, h) = (9u32, 0.1f32);
        let rest: Vec<Vec3> = (0..n * n)
            .map(|p| Vec3::new((p % n) as f32 * h, 0.0, (p / n) as f32 * h))
            .collect();
        let conn = ClothConnections::grid(n, n, &rest);
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        // Perturb by up to half a spacing so links are both stretched and compressed.
        let x: Vec<Vec3> = rest.iter().map(|&p| p + rng.vec(0.5 * h)).collect();
        let v: Vec<Vec3> = rest.iter().map(|_| rng.vec(1.0)).collect();
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let mut s = ClothSettings::default().with_model(model);
            // Make the Type 2 links matter as much as Type 1 ones.
            s.choi_ko.bending_rigidity = 1.0;
            let mut f = vec![Vec3::ZERO; x.len()];
            internal_forces(&s, &conn, &x, &v, &mut f);
            let total: Vec3 = f.iter().sum();
            let scale: f32 = f.iter().map(|v| v.length()).sum();
            assert!(scale > 1.0, "{model:?}: forces too small to test ({scale})");
            assert!(
                total.length() < 1e-5 * scale,
                "{model:?}: net {total} of {scale}"
            );
        }
    }

    #[test]
    fn pinned_particles_get_no_acceleration_and_free_ones_gravity() {
        let rest = [Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0)];
        let conn = ClothConnections::default();
        let settings = ClothSettings::default();
        let d = Dynamics {
            settings: &settings,
            connections: &conn,
            inverse_masses: &[0.0, 1.0, 2.0],
            external: &[Vec3::ZERO, Vec3::ZERO, Vec3::X],
        };
        let v = [Vec3::ONE, Vec3::ZERO, Vec3::Y];
        let mut a = [Vec3::NAN; 3];
        d.accelerations(&rest, &v, &mut a);
        assert_eq!(a[0], Vec3::ZERO);
        assert_eq!(a[1], settings.gravity);
        let want = Vec3::X * 2.0 + settings.gravity - settings.damping * Vec3::Y;
        assert!((a[2] - want).length() < 1e-6);
    }
}
