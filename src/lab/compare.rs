//! The paper's §6.2 comparison, measured: the same scripted pull and release
//! on Choi–Ko's and Lander's cloth at the same step, and how much each
//! still moves afterwards (MODEL.md §10.3: "Lander's cloth oscillates more
//! under mouse dragging … and keeps unnatural wrinkles").
//!
//! **Script**: the paper's scene (15×15 cotton, MODEL.md §11, hanging from
//! two corners) settles for 1 s; its free bottom-left corner is grabbed and
//! carried 0.4 m out of the cloth's plane over 0.5 s, held 0.5 s, and let go.
//! Both models use RK4 at 5·10⁻⁴ s (inside both stable steps) and the same
//! stretch stiffness, damping and masses.
//!
//! **Measures** after the release: kinetic energy (J) and mean particle
//! speed (m/s) at 1, 2 and 5 s, and a **wrinkle measure** at 5 s: the mean
//! angle (rad) between the normals of adjacent triangles across interior
//! mesh edges (0 for a flat or smoothly curved sheet at this resolution,
//! larger the more the surface creases).

use bevy::math::Vec3;

use crate::lab::accuracy::scene;
use crate::sim::grid::Grid;
use crate::sim::integrate::StepBuffers;
use crate::sim::settings::{ClothModel, Integrator, SimSettings};
use crate::sim::step::step_cloth;

/// The step both models are integrated at, s.
pub const STEP: f32 = 5e-4;

/// What the scripted pull left behind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual {
    /// Kinetic energy at 1, 2 and 5 s after release, J.
    pub kinetic: [f32; 3],
    /// Mean particle speed at 1, 2 and 5 s after release, m/s.
    pub speed: [f32; 3],
    /// Mean angle between adjacent triangle normals at 5 s, rad.
    pub wrinkle: f32,
    /// Largest Type 1 strain during the whole script.
    pub peak_strain: f32,
    /// Whether everything stayed finite.
    pub finite: bool,
}

/// Mean angle (rad) between the normals of the two triangles of every
/// interior edge of the grid (diagonals and shared quad edges).
pub fn wrinkle_measure(cloth: &Grid, x: &[Vec3]) -> f32 {
    let normal = |t: u32| {
        let [a, b, c] = cloth.triangle(t).map(|p| x[p as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    };
    let quads_per_row = cloth.cols - 1;
    let (mut sum, mut count) = (0.0f32, 0u32);
    let mut add = |t1: u32, t2: u32| {
        let d = normal(t1).dot(normal(t2)).clamp(-1.0, 1.0);
        sum += d.acos();
        count += 1;
    };
    for q in 0..(cloth.cols - 1) * (cloth.rows - 1) {
        let (i, j) = (q % quads_per_row, q / quads_per_row);
        // The quad's diagonal.
        add(2 * q, 2 * q + 1);
        // Its right neighbour: (a, c, b) of this quad meets (a, d, c) of the next.
        if i + 1 < quads_per_row {
            add(2 * q + 1, 2 * (q + 1));
        }
        // Its lower neighbour: (a, d, c) of this quad meets (a, c, b) below.
        if j + 1 < cloth.rows - 1 {
            add(2 * q, 2 * (q + quads_per_row) + 1);
        }
    }
    if count == 0 { 0.0 } else { sum / count as f32 }
}

/// Runs the script (module docs) on `model` with the cotton settings.
pub fn pull_and_release(model: ClothModel) -> Residual {
    let settings = SimSettings::default()
        .with_model(model)
        .with_integrator(Integrator::Rk4, 1)
        .without_adaptive();
    let mut cloth = scene(15);
    // The free bottom-left corner (column 0, last row).
    let grid = cloth.cloth.grid().expect("the scene is a grid").clone();
    let corner = grid.index(0, grid.rows - 1) as usize;
    let mut buffers = StepBuffers::new(cloth.particles.len());
    let mut out = Residual {
        kinetic: [0.0; 3],
        speed: [0.0; 3],
        wrinkle: 0.0,
        peak_strain: 0.0,
        finite: true,
    };
    let steps = |s: f32| (s / STEP).round() as usize;
    let mut step = |cloth: &mut crate::plugin::spawn::builder::ClothBundle,
                    target: Option<Vec3>| {
        let p = &mut cloth.particles;
        if let Some(t) = target {
            p.pin_by(corner, crate::sim::particles::PinOwner::Game);
            p.velocities[corner] = (t - p.positions[corner]) / STEP;
        }
        step_cloth(p, &cloth.connections, &settings, &[], &mut buffers, STEP);
        if let Some(t) = target {
            p.positions[corner] = t;
        }
        let strain = crate::sim::connections::max_strain(cloth.connections.type1(), &p.positions);
        out.peak_strain = out.peak_strain.max(strain);
        out.finite &= p.is_finite();
    };
    for _ in 0..steps(1.0) {
        step(&mut cloth, None);
    }
    let start = cloth.particles.positions[corner];
    let goal = start + Vec3::new(0.0, 0.0, 0.4);
    let pull = steps(0.5);
    for k in 1..=pull {
        step(&mut cloth, Some(start.lerp(goal, k as f32 / pull as f32)));
    }
    for _ in 0..steps(0.5) {
        step(&mut cloth, Some(goal));
    }
    // Release: the corner gets its mass back and keeps its (zero) velocity.
    cloth.particles.unpin(corner);
    let marks = [steps(1.0), steps(2.0), steps(5.0)];
    for k in 1..=marks[2] {
        step(&mut cloth, None);
        if let Some(m) = marks.iter().position(|&m| m == k) {
            let p = &cloth.particles;
            out.kinetic[m] = p.kinetic_energy();
            out.speed[m] = p.velocities.iter().map(|v| v.length()).sum::<f32>() / p.len() as f32;
        }
    }
    out.wrinkle = wrinkle_measure(&grid, &cloth.particles.positions);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plugin::spawn::builder::ClothBuilder;

    #[test]
    fn a_flat_sheet_has_no_wrinkles_and_a_fold_has_some() {
        let b = ClothBuilder::new(5, 5).build().unwrap();
        let mut x = b.particles.positions.clone();
        assert!(wrinkle_measure(b.cloth.grid().unwrap(), &x) < 1e-6);
        // Fold the last two columns up by 90° about column 2.
        for j in 0..5 {
            for i in 3..5 {
                let p = j * 5 + i;
                x[p] = Vec3::new(x[j * 5 + 2].x, (i - 2) as f32 * 0.25, x[p].z);
            }
        }
        let folded = wrinkle_measure(b.cloth.grid().unwrap(), &x);
        // 4 of the 40 interior edges bend by 90°.
        assert!(
            (folded - 4.0 * std::f32::consts::FRAC_PI_2 / 40.0).abs() < 1e-3,
            "{folded}"
        );
    }
}
