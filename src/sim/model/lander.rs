//! Lander's spring cloth, the paper's baseline (MODEL.md §7).
//!
//! Every spring is Hookean in both directions and carries its own damping:
//! `F_a = [k_s(ℓ − L) + k_d (v_ab·u)]·u`, `F_b = −F_a`. Structural (±1 axial),
//! shear (±1 diagonal) and bend (±2 axial only; Lander has no (±2,±2)
//! springs) each have their own `k_s` and `k_d`.
//!
//! A compressed Hookean spring has an indefinite Jacobian (its transverse
//! term `k(1 − L/ℓ)` is negative), which is the "buckling instability" that
//! Choi–Ko's tension-only/buckling split removes.

#[cfg(test)]
mod tests {
    use bevy::math::Vec3;

    use crate::sim::connections::Link;
    use crate::sim::model::kernel::{self, Law, Target};

    /// Adds the forces of two-sided damped springs to `f` (N).
    ///
    /// `ks` in N/m, `kd` in N·s/m. Links shorter than 10⁻⁹ m are skipped.
    fn spring_forces(links: &[Link], ks: f32, kd: f32, x: &[Vec3], v: &[Vec3], f: &mut [Vec3]) {
        let mut out = Target { f, base: 0 };
        kernel::pair_forces(&[(links, Law::Spring { ks, kd })], x, v, &mut out);
    }

    #[test]
    fn springs_push_when_compressed_and_pull_when_stretched() {
        let link = [Link {
            a: 0,
            b: 1,
            rest_length: 1.0,
        }];
        let v = [Vec3::ZERO; 2];
        for (len, sign) in [(0.5_f32, -1.0_f32), (1.5, 1.0)] {
            let x = [Vec3::ZERO, Vec3::new(0.0, len, 0.0)];
            let mut f = [Vec3::ZERO; 2];
            spring_forces(&link, 4.0, 0.6, &x, &v, &mut f);
            assert!((f[0].y - sign * 4.0 * 0.5).abs() < 1e-6);
            assert_eq!(f[0], -f[1]);
        }
    }

    #[test]
    fn damping_opposes_relative_axial_velocity_only() {
        let link = [Link {
            a: 0,
            b: 1,
            rest_length: 1.0,
        }];
        let x = [Vec3::ZERO, Vec3::X];
        let mut f = [Vec3::ZERO; 2];
        // Separating along the axis: damping pulls them together.
        spring_forces(&link, 0.0, 0.5, &x, &[Vec3::ZERO, Vec3::X * 2.0], &mut f);
        assert!((f[0].x - 1.0).abs() < 1e-6);
        // Moving across the axis: no damping force.
        let mut f = [Vec3::ZERO; 2];
        spring_forces(&link, 0.0, 0.5, &x, &[Vec3::ZERO, Vec3::Y * 2.0], &mut f);
        assert_eq!(f, [Vec3::ZERO; 2]);
    }
}
