//! Unit tests of the implicit integrators: the solver against a dense
//! solve, pins, the operator's block order, and the orders of accuracy.

use super::*;
use crate::cloth::ClothBuilder;
use crate::connections::{ClothConnections, Link};
use crate::settings::{ClothModel, ClothSettings};

/// Dense `A` (3n × 3n, f64) from the blocks, pinned rows and columns
/// replaced by the identity.
#[expect(
    clippy::needless_range_loop,
    reason = "dense matrix indices read best as indices"
)]
fn dense(buffers: &ImplicitBuffers, w: &[f32], mass_scale: f32) -> Vec<Vec<f64>> {
    let n = w.len();
    let mut a = vec![vec![0.0f64; 3 * n]; 3 * n];
    for i in 0..n {
        for k in 0..3 {
            a[3 * i + k][3 * i + k] = if w[i] == 0.0 {
                0.0
            } else {
                (mass_scale / w[i]) as f64
            };
        }
    }
    for (&[p, q], c) in buffers.pairs.iter().zip(&buffers.combined) {
        let (p, q, c) = (p as usize, q as usize, bevy::math::Mat3::from(*c));
        for r in 0..3 {
            for s in 0..3 {
                let v = c.col(s)[r] as f64;
                a[3 * p + r][3 * p + s] += v;
                a[3 * q + r][3 * q + s] += v;
                a[3 * p + r][3 * q + s] -= v;
                a[3 * q + r][3 * p + s] -= v;
            }
        }
    }
    for i in (0..n).filter(|&i| w[i] == 0.0) {
        for k in 0..3 {
            for j in 0..3 * n {
                a[3 * i + k][j] = 0.0;
                a[j][3 * i + k] = 0.0;
            }
            a[3 * i + k][3 * i + k] = 1.0;
        }
    }
    a
}

#[test]
fn the_operator_reads_every_block_once_and_neighbours_apart() {
    let cloth = ClothBuilder::new(20, 20).build().unwrap();
    let settings = ClothSettings::default();
    let mut buffers = ImplicitBuffers::default();
    let (x, v) = (&cloth.particles.positions, &cloth.particles.velocities);
    assemble(
        &settings,
        &cloth.connections,
        true,
        x,
        v,
        &mut vec![Vec3::ZERO; 400],
        &mut buffers.blocks,
    );
    let order: Vec<[u32; 2]> = interleaved(&buffers.blocks).map(|b| [b.a, b.b]).collect();
    let mut sorted = order.clone();
    let mut all: Vec<[u32; 2]> = buffers.blocks.iter().map(|b| [b.a, b.b]).collect();
    sorted.sort_unstable();
    all.sort_unstable();
    assert_eq!(sorted, all);
    let shared = order
        .windows(2)
        .filter(|w| w[0].iter().any(|p| w[1].contains(p)))
        .count();
    assert!(shared < order.len() / 100, "{shared} of {}", order.len());
}

/// Gaussian elimination with partial pivoting.
#[expect(
    clippy::needless_range_loop,
    reason = "dense matrix indices read best as indices"
)]
fn gauss(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap();
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            for k in col..n {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x
}

#[test]
fn pcg_matches_a_dense_solve_and_leaves_pins_alone() {
    let mut cloth = ClothBuilder::new(4, 4).pin(0).pin(3).build().unwrap();
    // Deform: stretch some links, compress others.
    for (i, x) in cloth.particles.positions.iter_mut().enumerate() {
        let s = i as f32;
        *x += 0.08 * Vec3::new((s * 1.3).sin(), (s * 0.7).cos(), (s * 2.1).sin());
    }
    let v: Vec<Vec3> = (0..16)
        .map(|i| Vec3::splat((i as f32 * 0.4).cos()))
        .collect();
    let mut settings = ClothSettings::default();
    settings.implicit.tolerance = 1e-6;
    settings.implicit.max_iterations = 500;
    let w = cloth.particles.inverse_masses.clone();
    let dynamics = Dynamics {
        settings: &settings,
        connections: &cloth.connections,
        inverse_masses: &w,
        external: &[],
    };
    let h = 1.0 / 30.0;
    let mut buffers = ImplicitBuffers::default();
    buffers.resize(16);
    linearise(
        &dynamics,
        &cloth.particles.positions,
        &v,
        h,
        h * h,
        &mut buffers,
    );
    for (i, r) in buffers.rhs.iter_mut().enumerate() {
        *r = Vec3A::new(1.0, -2.0, 0.5) * (i as f32 * 0.3).sin() * 1e-3;
    }
    filter(&w, &mut buffers.rhs);
    solve(&dynamics, h, &mut buffers);
    let a = dense(&buffers, &w, 1.0 + h * settings.damping);
    let b: Vec<f64> = buffers
        .rhs
        .iter()
        .flat_map(|r| r.to_array().map(|c| c as f64))
        .collect();
    let exact = gauss(a, b);
    let norm: f64 = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
    let err: f64 = buffers
        .dv
        .iter()
        .flat_map(|d| d.to_array())
        .zip(&exact)
        .map(|(g, e)| (g as f64 - e).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        err < 1e-3 * norm,
        "PCG error {err} of {norm} after {} iterations",
        buffers.last_iterations
    );
    assert!(buffers.last_residual <= 1e-6);
    // Pins: Δv exactly zero.
    assert_eq!(buffers.dv[0], Vec3A::ZERO);
    assert_eq!(buffers.dv[3], Vec3A::ZERO);

    // Warm start: the same system again starts at its solution and
    // needs (almost) no iterations; a slightly changed one needs fewer
    // than from zero and meets the same tolerance.
    let cold = buffers.last_iterations;
    let first = buffers.dv.clone();
    solve(&dynamics, h, &mut buffers);
    assert!(buffers.last_iterations <= 1, "{}", buffers.last_iterations);
    for r in &mut buffers.rhs {
        *r *= 1.01;
    }
    solve(&dynamics, h, &mut buffers);
    let warm = buffers.last_iterations;
    assert!(warm < cold, "warm {warm} vs cold {cold} iterations");
    assert!(buffers.last_residual <= 1e-6);
    let scaled = first
        .iter()
        .zip(&buffers.dv)
        .map(|(a, b)| (*a * 1.01 - *b).length());
    assert!(scaled.fold(0.0, f32::max) < 1e-3 * norm as f32);
    // A forgotten history starts cold again.
    buffers.reset_history();
    solve(&dynamics, h, &mut buffers);
    assert_eq!(buffers.last_iterations, cold);
}

#[test]
fn pinned_particles_keep_their_prescribed_velocity_exactly() {
    let mut cloth = ClothBuilder::new(5, 5).pin(0).pin(4).build().unwrap();
    cloth.particles.velocities[4] = Vec3::new(0.3, 0.0, -0.1); // a moving anchor
    let settings = ClothSettings::default();
    for integrator in [backward_euler, bdf2] {
        let mut x = cloth.particles.positions.clone();
        let mut v = cloth.particles.velocities.clone();
        let w = cloth.particles.inverse_masses.clone();
        let dynamics = Dynamics {
            settings: &settings,
            connections: &cloth.connections,
            inverse_masses: &w,
            external: &[],
        };
        let mut buffers = ImplicitBuffers::default();
        for _ in 0..30 {
            integrator(&dynamics, &mut x, &mut v, 1.0 / 60.0, &mut buffers);
        }
        assert_eq!(x[0], cloth.particles.positions[0]);
        assert_eq!(v[0], Vec3::ZERO);
        assert_eq!(v[4], Vec3::new(0.3, 0.0, -0.1));
        assert!((x[4] - (cloth.particles.positions[4] + 0.5 * v[4])).length() < 1e-5);
        assert!(x.iter().all(|p| p.is_finite()));
    }
}

/// A mass on a spring to a pin, `ẍ = −ω²x − c ẋ` along the spring.
fn spring_error(
    step: fn(&Dynamics, &mut [Vec3], &mut [Vec3], f32, &mut ImplicitBuffers),
    dt: f32,
) -> f64 {
    let (k, m, c) = (40.0f32, 1.0f32, 0.5f32);
    let mut settings = ClothSettings::default().with_model(ClothModel::Lander);
    settings.gravity = Vec3::ZERO;
    settings.damping = c;
    settings.lander.structural.stiffness = k;
    settings.lander.structural.damping = 0.0;
    settings.implicit.tolerance = 1e-7;
    let connections = ClothConnections {
        structural: vec![Link {
            a: 0,
            b: 1,
            rest_length: 1.0,
        }],
        ..Default::default()
    };
    let w = [0.0, 1.0 / m];
    let dynamics = Dynamics {
        settings: &settings,
        connections: &connections,
        inverse_masses: &w,
        external: &[],
    };
    let mut x = [Vec3::ZERO, Vec3::new(1.1, 0.0, 0.0)];
    let mut v = [Vec3::ZERO; 2];
    let mut buffers = ImplicitBuffers::default();
    // The largest error over 1 s (a single time would depend on phase).
    let steps = (1.0 / dt).round() as usize;
    let (omega2, zw) = ((k / m) as f64, c as f64 / 2.0);
    let wd = (omega2 - zw * zw).sqrt();
    let mut worst = 0.0f64;
    for n in 1..=steps {
        step(&dynamics, &mut x, &mut v, dt, &mut buffers);
        let t = n as f64 * dt as f64;
        let exact = 0.1 * (-zw * t).exp() * ((wd * t).cos() + zw / wd * (wd * t).sin());
        worst = worst.max(((x[1].x - 1.0) as f64 - exact).abs());
    }
    worst
}

#[test]
fn backward_euler_is_first_order_and_bdf2_second_order() {
    // Observed order log₂(e(dt)/e(dt/2)): ~1 for BE (error halves), ~2
    // for BDF2 (error quarters; its first step is BE, so allow 1.7–2.3).
    let order = |s: fn(&Dynamics, &mut [Vec3], &mut [Vec3], f32, &mut ImplicitBuffers)| {
        (spring_error(s, 0.004) / spring_error(s, 0.002)).log2()
    };
    let (be, bdf) = (order(backward_euler), order(bdf2));
    assert!((0.85..1.15).contains(&be), "backward Euler order {be}");
    assert!((1.7..2.3).contains(&bdf), "BDF2 order {bdf}");
}
