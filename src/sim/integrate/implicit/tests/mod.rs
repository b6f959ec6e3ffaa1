//! Unit tests of the implicit integrators: the solver against a dense
//! solve, pins, the operator's block order, and the orders of accuracy.

use super::operator::dot;
use super::*;
use crate::plugin::spawn::builder::ClothBuilder;
use crate::sim::connections::{Connections, Link};
use crate::sim::model::jacobian::assemble;
use crate::sim::settings::{ClothModel, SimSettings};
use bevy::math::DVec3;

/// Dense `A` (3n × 3n, f64) from the operator's pairs, pinned rows and
/// columns replaced by the identity.
#[expect(
    clippy::needless_range_loop,
    reason = "dense matrix indices read best as indices"
)]
fn dense(op: &Operator) -> Vec<Vec<f64>> {
    let mass = op.mass();
    let n = mass.len();
    let mut a = vec![vec![0.0f64; 3 * n]; 3 * n];
    for i in 0..n {
        for k in 0..3 {
            a[3 * i + k][3 * i + k] = mass[i] as f64;
        }
    }
    for (p, q, c) in op.pairs() {
        let c = operator::sym_matrix(&c);
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
    for i in (0..n).filter(|&i| op.free[i] == 0.0) {
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

/// A deformed, moving `n × n` cloth pinned at two corners and the
/// Jacobian blocks at its state.
pub(super) fn deformed(
    n: u32,
) -> (
    crate::plugin::spawn::builder::ClothBundle,
    Vec<Vec3>,
    Vec<Block>,
) {
    let mut cloth = ClothBuilder::new(n, n).pin(0).pin(n - 1).build().unwrap();
    // Deform: stretch some links, compress others.
    for (i, x) in cloth.particles.positions.iter_mut().enumerate() {
        let s = i as f32;
        *x += 0.3 / n as f32 * Vec3::new((s * 1.3).sin(), (s * 0.7).cos(), (s * 2.1).sin());
    }
    let v: Vec<Vec3> = (0..n * n)
        .map(|i| Vec3::splat((i as f32 * 0.4).cos()))
        .collect();
    let mut blocks = Vec::new();
    let mut f = vec![Vec3::ZERO; v.len()];
    let settings = SimSettings::default();
    let x = &cloth.particles.positions;
    assemble(
        &settings,
        &cloth.connections,
        true,
        x,
        &v,
        &mut f,
        &mut blocks,
    );
    (cloth, v, blocks)
}

/// `n` vectors `f(i)`, stored component by component.
pub(super) fn soa(n: usize, f: impl Fn(usize) -> Vec3) -> Soa {
    let mut s = Soa::default();
    s.resize(n);
    for i in 0..n {
        s.set(i, f(i));
    }
    s
}

/// A smooth but irregular test vector for particle `i` (dimensionless).
fn wiggle(i: usize) -> Vec3 {
    let s = i as f32;
    Vec3::new(s.sin(), (0.3 * s).cos(), 1.0 - 0.01 * s)
}

/// A crease-like pair of a 9×9 grid that the streams do not hold, with
/// transverse stiffness `k` (N/m), three times that along its direction.
fn stray_block(k: f32) -> Block {
    Block {
        a: 3,
        b: 50,
        u: Vec3::new(0.6, 0.0, 0.8),
        axial: 3.0 * k,
        transverse: k,
        damping: 0.5,
    }
}

#[test]
fn the_streams_give_the_product_of_the_pair_list() {
    let (cloth, _, mut blocks) = deformed(9);
    blocks.push(stray_block(1.0));
    let w = &cloth.particles.inverse_masses;
    let h = 1.0 / 60.0;
    let (mut grid, mut list) = (Operator::default(), Operator::default());
    list.list_only = true;
    grid.build(9, w, 1.1, &blocks, h, h * h, None);
    list.build(0, w, 1.1, &blocks, h, h * h, None);
    assert!(list.steps().is_empty());
    let pairs = grid.pairs().len();
    assert!(pairs > 250 && list.pairs().len() == pairs, "{pairs} pairs");
    let mut d = soa(81, wiggle);
    d.filter(&grid.free);
    let (mut a, mut b) = (soa(81, |_| Vec3::ZERO), soa(81, |_| Vec3::ZERO));
    grid.apply(&d, &mut a);
    list.apply(&d, &mut b);
    for i in 0..81 {
        let (p, q) = (a.get(i), b.get(i));
        assert!(
            (p - q).length() <= 1e-5 * (1.0 + q.length()),
            "{i}: {p} vs {q}"
        );
    }
    assert_eq!(a.get(0), Vec3::ZERO, "a pinned row is filtered");
}

/// A cloth that is not a grid but numbered row by row (a torn grid, a
/// subdivided plane) has its own streams, found from its pairs; one
/// numbered at random has none. Either way the product is the pair list's.
#[test]
fn a_mesh_numbered_row_by_row_finds_the_grids_streams() {
    let (cloth, _, blocks) = deformed(9);
    let w = &cloth.particles.inverse_masses;
    let h = 1.0 / 60.0;
    // The particles renumbered by a fixed shuffle: no step is common.
    let mut order: Vec<u32> = (0..81).collect();
    let mut state = 12345u32;
    for i in (1..81).rev() {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        order.swap(i, (state >> 8) as usize % (i + 1));
    }
    let shuffle = |i: u32| order[i as usize];
    let mut shuffled_w = vec![0.0; 81];
    for (i, &wi) in w.iter().enumerate() {
        shuffled_w[shuffle(i as u32) as usize] = wi;
    }
    let shuffled: Vec<Block> = blocks
        .iter()
        .map(|b| Block {
            a: shuffle(b.a),
            b: shuffle(b.b),
            ..*b
        })
        .collect();
    let mut list = Operator::default();
    list.list_only = true;
    list.build(0, w, 1.1, &blocks, h, h * h, None);
    let (mut found, mut none) = (Operator::default(), Operator::default());
    found.build(0, w, 1.1, &blocks, h, h * h, None);
    none.build(0, &shuffled_w, 1.1, &shuffled, h, h * h, None);
    // The Type 1 steps, and only the grid's (a Type 2 link has a block
    // only while it buckles).
    let steps = found.steps();
    let grid = [1, 2, 8, 9, 10, 16, 18, 20];
    assert!(steps.iter().all(|d| grid.contains(d)), "{steps:?}");
    assert!([1, 8, 9, 10].iter().all(|d| steps.contains(d)), "{steps:?}");
    assert!(none.steps().is_empty(), "{:?}", none.steps());
    let mut d = soa(81, wiggle);
    d.filter(&list.free);
    let (mut a, mut b) = (soa(81, |_| Vec3::ZERO), soa(81, |_| Vec3::ZERO));
    list.apply(&d, &mut a);
    found.apply(&d, &mut b);
    let mut e = soa(81, |_| Vec3::ZERO);
    let mut ds = soa(81, |_| Vec3::ZERO);
    for i in 0..81 {
        ds.set(shuffle(i as u32) as usize, d.get(i));
    }
    none.apply(&ds, &mut e);
    for i in 0..81 {
        let q = a.get(i);
        for p in [b.get(i), e.get(shuffle(i as u32) as usize)] {
            assert!(
                (p - q).length() <= 1e-5 * (1.0 + q.length()),
                "{i}: {p} vs {q}"
            );
        }
    }
}

#[test]
fn block_jacobi_inverts_the_diagonal_blocks() {
    let (cloth, _, mut blocks) = deformed(9);
    blocks.push(stray_block(1.0e4));
    let w = &cloth.particles.inverse_masses;
    let h = 1.0 / 60.0;
    let mut op = Operator::default();
    op.build(9, w, 1.1, &blocks, h, h * h, None);
    let a = dense(&op);
    // For r = A's diagonal block of each free particle times a unit
    // vector (zero elsewhere), B⁻¹r must give that unit vector back.
    let mut checked = 0;
    for i in (0..81).filter(|&i| op.free[i] != 0.0) {
        for k in 0..3 {
            let mut r = Soa::default();
            r.resize(81);
            let column = |row: usize| a[3 * i + row][3 * i + k] as f32;
            r.set(i, Vec3::new(column(0), column(1), column(2)));
            let mut y = Soa::default();
            y.resize(81);
            op.precondition(&r, &mut y);
            let mut unit = Vec3::ZERO;
            unit[k] = 1.0;
            let err = (y.get(i) - unit).length();
            assert!(err < 1e-4, "particle {i}, axis {k}: {}", y.get(i));
            checked += 1;
        }
    }
    assert_eq!(checked, 3 * 79);
}

/// A light particle of a flat cloth with stiff links (a copy a tear
/// split off): its block is its mass across the cloth and five to six
/// orders of magnitude more along it. Its inverse stays positive definite
/// (500 such blocks, and three met at a 96×96 banner's cuts).
#[test]
fn a_light_particles_block_inverts_to_a_positive_definite_one() {
    let positive_definite = |s: [f32; 6]| {
        let [xx, yy, zz, xy, xz, yz] = operator::sym_inverse(s).map(f64::from);
        let inverse = bevy::math::DMat3::from_cols(
            DVec3::new(xx, xy, xz),
            DVec3::new(xy, yy, yz),
            DVec3::new(xz, yz, zz),
        );
        let minors = [xx, xx * yy - xy * xy, inverse.determinant()];
        assert!(minors.iter().all(|&m| m > 0.0), "{s:?}: {minors:?}");
    };
    let mass = 2.8e-6_f64;
    for case in 0..500 {
        // One to three links in a tilted plane, stiffness × h² of 0.05 to
        // 1 kg.
        let tilt = case as f64 * 0.0123;
        let normal = DVec3::new(tilt.sin() * 0.3, tilt.cos(), tilt.sin() * 0.7).normalize();
        let along = normal.any_orthonormal_vector();
        let across = normal.cross(along);
        let mut block = [[0.0_f64; 3]; 3];
        for (i, row) in block.iter_mut().enumerate() {
            row[i] = mass;
        }
        for link in 0..1 + case % 3 {
            let angle = 0.37 * case as f64 + 2.1 * link as f64;
            let u = angle.cos() * along + angle.sin() * across;
            let k = 0.05 + 0.95 * ((case * 7 + link * 3) % 10) as f64 / 9.0;
            for (r, row) in block.iter_mut().enumerate() {
                for (c, value) in row.iter_mut().enumerate() {
                    *value += k * u[r] * u[c];
                }
            }
        }
        let [[xx, xy, xz], [_, yy, yz], [.., zz]] = block;
        positive_definite([xx, yy, zz, xy, xz, yz].map(|v| v as f32));
    }
    for s in [
        [
            1.3314066,
            0.00138299,
            0.056126203,
            -0.0428665,
            0.2733548,
            -0.008801058,
        ],
        [
            0.47441107, 0.8492203, 0.06529719, 0.63471043, 0.17599897, 0.23547553,
        ],
        [
            1.2543999,
            0.1254169,
            0.009099217,
            -0.39663374,
            0.10681972,
            -0.03377592,
        ],
    ] {
        positive_definite(s);
    }
}

/// The dynamics of `cloth` (no external forces) and buffers holding the
/// backward-Euler operator at its state with velocities `v` (m/s) for a
/// step of `h` seconds.
fn linearised<'a>(
    settings: &'a SimSettings,
    cloth: &'a crate::plugin::spawn::builder::ClothBundle,
    v: &[Vec3],
    h: f32,
) -> (Dynamics<'a>, ImplicitBuffers) {
    let dynamics = Dynamics {
        settings,
        connections: &cloth.connections,
        inverse_masses: &cloth.particles.inverse_masses,
        external: &[],
        workers: crate::sim::workers::Pool::none(),
    };
    let mut buffers = ImplicitBuffers::default();
    buffers.resize(v.len());
    let x = &cloth.particles.positions;
    linearise(&dynamics, (x, v, v), h, h * h, &mut buffers);
    (dynamics, buffers)
}

/// The buffers after a cold backward-Euler solve at 1/60 s of `cloth`
/// moving at `v` (m/s), its right-hand side `h·f`; asserts the solve reached
/// its tolerance.
fn solved_cold(
    settings: &SimSettings,
    cloth: &crate::plugin::spawn::builder::ClothBundle,
    v: &[Vec3],
) -> ImplicitBuffers {
    let h = 1.0 / 60.0;
    let (dynamics, mut buffers) = linearised(settings, cloth, v, h);
    for i in 0..v.len() {
        buffers.rhs.set(i, h * buffers.force[i]);
    }
    buffers.rhs.filter(&buffers.op.free);
    solve(&dynamics, &mut buffers);
    assert!(buffers.last_residual <= settings.implicit.tolerance);
    buffers
}

#[test]
fn the_coarse_grid_cuts_the_iterations_of_a_stiff_cloth() {
    let (cloth, v, _) = deformed(32);
    let solve_with = |coarse_grid| {
        let mut settings = SimSettings::default();
        settings.implicit.coarse_grid = coarse_grid;
        settings.implicit.max_iterations = 1000;
        settings.implicit.tolerance = 1e-6;
        settings.implicit.velocity_tolerance = 0.0;
        let buffers = solved_cold(&settings, &cloth, &v);
        let dv: Vec<Vec3> = (0..v.len()).map(|i| buffers.dv.get(i)).collect();
        (buffers.last_iterations, buffers.coarse_active, dv)
    };
    let (plain, off, dv_plain) = solve_with(false);
    let (two_level, on, dv_two) = solve_with(true);
    assert!(!off && on);
    assert!(
        (two_level as f32) < 0.7 * plain as f32,
        "{two_level} iterations with the coarse grid, {plain} without"
    );
    // Both reach the same Δv.
    let norm = dv_plain
        .iter()
        .map(|d| d.length_squared())
        .sum::<f32>()
        .sqrt();
    let diff = dv_plain
        .iter()
        .zip(&dv_two)
        .map(|(a, b)| (*a - *b).length_squared())
        .sum::<f32>()
        .sqrt();
    assert!(diff < 1e-2 * norm, "{diff} of {norm}");
}

#[test]
fn the_iterations_stay_nearly_flat_from_16_to_128() {
    // Deformed, moving cotton sheets of 16² to 128² (64 times the
    // particles) at 1/60 s, solved cold to the default relative tolerance.
    let iterations: Vec<u32> = [16, 32, 64, 128]
        .into_iter()
        .map(|n| {
            let (cloth, v, _) = deformed(n);
            let mut settings = SimSettings::default();
            settings.implicit.velocity_tolerance = 0.0;
            settings.implicit.max_iterations = 1000;
            let buffers = solved_cold(&settings, &cloth, &v);
            assert!(buffers.coarse_active);
            buffers.last_iterations
        })
        .collect();
    eprintln!("iterations at 16², 32², 64², 128²: {iterations:?}");
    let (coarsest, finest) = (iterations[0].max(iterations[1]), iterations[3]);
    assert!(
        finest as f32 <= 1.6 * coarsest as f32,
        "{iterations:?}: the iterations grow with the resolution"
    );
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
    // 6×6: streams, a coarse grid of 3×3 aggregates and pins at 0 and 5.
    let (cloth, v, _) = deformed(6);
    let n = v.len();
    let mut settings = SimSettings::default();
    settings.implicit.coarse_grid = true;
    settings.implicit.tolerance = 1e-6;
    settings.implicit.velocity_tolerance = 0.0;
    settings.implicit.max_iterations = 500;
    let (dynamics, mut buffers) = linearised(&settings, &cloth, &v, 1.0 / 30.0);
    assert!(buffers.coarse_active);
    for i in 0..n {
        buffers
            .rhs
            .set(i, Vec3::new(1.0, -2.0, 0.5) * (i as f32 * 0.3).sin() * 1e-3);
    }
    buffers.rhs.filter(&buffers.op.free);
    solve(&dynamics, &mut buffers);
    let a = dense(&buffers.op);
    let rhs: Vec<Vec3> = (0..n).map(|i| buffers.rhs.get(i)).collect();
    let b: Vec<f64> = rhs
        .iter()
        .flat_map(|r| r.to_array().map(|c| c as f64))
        .collect();
    let exact = gauss(a, b);
    let norm: f64 = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
    let dv: Vec<Vec3> = (0..n).map(|i| buffers.dv.get(i)).collect();
    let err: f64 = dv
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
    assert_eq!(buffers.dv.get(0), Vec3::ZERO);
    assert_eq!(buffers.dv.get(5), Vec3::ZERO);

    // Warm start: the same system again starts at its solution and
    // needs (almost) no iterations; a slightly changed one needs fewer
    // than from zero and meets the same tolerance.
    let cold = buffers.last_iterations;
    let first = dv;
    solve(&dynamics, &mut buffers);
    assert!(buffers.last_iterations <= 1, "{}", buffers.last_iterations);
    for c in &mut buffers.rhs.0 {
        for r in c {
            *r *= 1.01;
        }
    }
    solve(&dynamics, &mut buffers);
    let warm = buffers.last_iterations;
    assert!(warm < cold, "warm {warm} vs cold {cold} iterations");
    assert!(buffers.last_residual <= 1e-6);
    let scaled = first
        .iter()
        .enumerate()
        .map(|(i, a)| (*a * 1.01 - buffers.dv.get(i)).length());
    assert!(scaled.fold(0.0, f32::max) < 1e-3 * norm as f32);
    // A forgotten history starts cold again.
    buffers.reset_history();
    solve(&dynamics, &mut buffers);
    assert_eq!(buffers.last_iterations, cold);
}

#[test]
fn pinned_particles_keep_their_prescribed_velocity_exactly() {
    let mut cloth = ClothBuilder::new(5, 5).pin(0).pin(4).build().unwrap();
    cloth.particles.velocities[4] = Vec3::new(0.3, 0.0, -0.1); // a moving anchor
    let settings = SimSettings::default();
    for integrator in [backward_euler, bdf2] {
        let mut x = cloth.particles.positions.clone();
        let mut v = cloth.particles.velocities.clone();
        let w = cloth.particles.inverse_masses.clone();
        let dynamics = Dynamics {
            settings: &settings,
            connections: &cloth.connections,
            inverse_masses: &w,
            external: &[],
            workers: crate::sim::workers::Pool::none(),
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
    let mut settings = SimSettings::default().with_model(ClothModel::Lander);
    settings.gravity = Vec3::ZERO;
    settings.damping = c;
    settings.lander.structural.stiffness = k;
    settings.lander.structural.damping = 0.0;
    settings.implicit.tolerance = 1e-7;
    settings.implicit.velocity_tolerance = 0.0;
    let connections = Connections {
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
        workers: crate::sim::workers::Pool::none(),
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

mod contacts;
mod streamed;
mod two_threads;

#[test]
fn a_solve_stopped_at_its_tolerance_leaves_no_net_force() {
    // Stopped early, the solve's residual `r = b − AΔv` is force (times the
    // step) the cloth did not get right; its sum would be momentum made
    // from nothing, which moves a cloth as a whole, step after step. The
    // residual is left with no sum over the free particles.
    let (cloth, v, _) = deformed(32);
    let mut settings = SimSettings::default();
    settings.implicit.tolerance = 0.1;
    settings.implicit.velocity_tolerance = 0.0;
    let mut buffers = solved_cold(&settings, &cloth, &v);
    let mut q = Soa::default();
    q.resize(v.len());
    buffers.op.apply(&buffers.dv, &mut q);
    let (mut net, mut size) = (DVec3::ZERO, 0.0f64);
    for i in 0..v.len() {
        let r = (buffers.rhs.get(i) - q.get(i)) * buffers.op.free[i];
        net += r.as_dvec3();
        size += r.length() as f64;
    }
    assert!(size > 0.0, "the solve stopped early");
    assert!(
        net.length() <= 1e-5 * size,
        "net residual {net} N·s against {size} N·s in all"
    );
}

#[test]
fn the_past_solutions_guess_is_the_solution_when_they_span_it() {
    let (cloth, v, _) = deformed(16);
    let settings = SimSettings::default();
    let (_, mut buffers) = linearised(&settings, &cloth, &v, 1.0 / 60.0);
    let n = v.len();
    let op = &mut buffers.op;
    let mut w1 = soa(n, |i| 0.05 * wiggle(i));
    let mut w2 = soa(n, |i| Vec3::new(0.0, -0.16, 0.01 * (i % 7) as f32));
    w1.filter(&op.free);
    w2.filter(&op.free);
    // b = A x with x = 0.5 w1 − 3 w2: the guess from {w1, w2, w1} is x.
    let x = soa(n, |i| 0.5 * w1.get(i) - 3.0 * w2.get(i));
    let (mut b, mut dv) = (soa(n, |_| Vec3::ZERO), soa(n, wiggle));
    op.apply(&x, &mut b);
    let mut past = past::Past::default();
    for w in [&w1, &w2, &w1] {
        past.remember(w, 4, (100, 100));
    }
    assert!(past.wanted());
    assert!(past.guess(op, &b, &mut dv, false));
    let size = (0..n).map(|i| x.get(i).length()).fold(0.0, f32::max);
    for i in 0..n {
        let error = (dv.get(i) - x.get(i)).length();
        assert!(error <= 1e-4 * size, "particle {i}: {error} m/s off");
    }
    // A direction deflated by them is A-orthogonal to both.
    let mut y = soa(n, |i| 0.05 * wiggle(3 * i) + Vec3::Y);
    y.filter(&op.free);
    // The cosine of the angle between y and w in A's energy norm.
    let along = |op: &mut Operator, y: &Soa, w: &Soa| {
        let (mut aw, mut ay) = (soa(n, |_| Vec3::ZERO), soa(n, |_| Vec3::ZERO));
        op.apply(w, &mut aw);
        op.apply(y, &mut ay);
        dot(&aw, y) / (dot(&aw, w) * dot(&ay, y)).sqrt()
    };
    assert!(
        along(op, &y, &w2).abs() > 0.1,
        "the test direction has a part along w2"
    );
    past.deflate(&mut y, dot);
    for w in [&w1, &w2] {
        let cosine = along(op, &y, w);
        assert!(cosine.abs() <= 1e-4, "{cosine}");
    }
    // It is wanted from a solve of four fifths of the cap until 30 in a
    // row of less than a quarter; none when nothing is kept.
    let mut run = vec![(24, false), (79, false), (80, true), (25, true)];
    run.extend([(24, true); 29]);
    run.extend([(30, true), (24, true), (24, true)]);
    run.extend([(24, true); 27]);
    run.push((24, false));
    let mut gate = past::Past::default();
    for (k, (iterations, wanted)) in run.into_iter().enumerate() {
        gate.remember(&w1, 4, (iterations, 100));
        assert_eq!(
            gate.wanted(),
            wanted,
            "solve {k}, after {iterations} of 100"
        );
    }
    // A solution of a step that blew up is left out, not spread.
    let mut past = past::Past::default();
    let broken = soa(n, |i| if i == 7 { Vec3::NAN } else { wiggle(i) });
    for w in [&broken, &w1, &w2] {
        past.remember(w, 4, (100, 100));
    }
    assert!(past.guess(op, &b, &mut dv, false));
    for i in 0..n {
        let error = (dv.get(i) - x.get(i)).length();
        assert!(error <= 1e-4 * size, "particle {i}: {error} m/s off");
    }
    past.remember(&w1, 0, (100, 100));
    assert!(!past.wanted());
    assert!(!past.guess(op, &b, &mut dv, false));
}

/// A cloth cut in two between its 8th and 9th columns, whose solution is
/// a different combination of the past solutions on each piece: the
/// guess piece by piece finds it, one combination of the whole cloth does
/// not; a direction deflated piece by piece is `A`-orthogonal to each
/// piece's part of each solution.
#[test]
fn a_cloth_in_pieces_takes_a_combination_on_each() {
    let (mut cloth, v, _) = deformed(16);
    let left = |i: u32| i % 16 < 8;
    let c = &mut cloth.connections.0;
    for list in [
        &mut c.structural,
        &mut c.shear,
        &mut c.bend,
        &mut c.bend_diagonal,
    ] {
        list.retain(|l| left(l.a) == left(l.b));
    }
    let settings = SimSettings::default();
    let (dynamics, mut buffers) = linearised(&settings, &cloth, &v, 1.0 / 60.0);
    let n = v.len();
    let side = |i: usize, a: f32, b: f32| if left(i as u32) { a } else { b };
    let op = &mut buffers.op;
    let mut w1 = soa(n, |i| 0.05 * wiggle(i));
    let mut w2 = soa(n, |i| Vec3::new(0.0, -0.16, 0.01 * (i % 7) as f32));
    w1.filter(&op.free);
    w2.filter(&op.free);
    let x = soa(n, |i| {
        side(i, 0.5, -2.0) * w1.get(i) + side(i, -3.0, 1.0) * w2.get(i)
    });
    let (mut b, mut dv) = (soa(n, |_| Vec3::ZERO), soa(n, |_| Vec3::ZERO));
    op.apply(&x, &mut b);
    let mut past = past::Past::default();
    for w in [&w1, &w2] {
        past.remember(w, 4, (100, 100));
    }
    let links = coupled(dynamics.connections, &[]);
    past.find_pieces(links, n, None);
    let size = (0..n).map(|i| x.get(i).length()).fold(0.0, f32::max);
    let worst = |dv: &Soa| {
        (0..n)
            .map(|i| (dv.get(i) - x.get(i)).length())
            .fold(0.0, f32::max)
    };
    assert!(past.guess(op, &b, &mut dv, false));
    assert!(
        worst(&dv) > 0.1 * size,
        "one combination fits: {}",
        worst(&dv)
    );
    assert!(past.guess(op, &b, &mut dv, true));
    assert!(worst(&dv) <= 1e-4 * size, "{} m/s off", worst(&dv));
    // Deflated piece by piece: A-orthogonal to each piece's part of w1, w2.
    let mut y = soa(n, |i| 0.05 * wiggle(3 * i) + Vec3::Y);
    y.filter(&op.free);
    past.deflate(&mut y, dot);
    let (mut ay, mut aw) = (soa(n, |_| Vec3::ZERO), soa(n, |_| Vec3::ZERO));
    op.apply(&y, &mut ay);
    for w in [&w1, &w2] {
        for on_left in [true, false] {
            let part = soa(n, |i| {
                if left(i as u32) == on_left {
                    w.get(i)
                } else {
                    Vec3::ZERO
                }
            });
            op.apply(&part, &mut aw);
            let cosine = dot(&aw, &y) / (dot(&aw, &part) * dot(&ay, &y)).sqrt();
            assert!(cosine.abs() <= 1e-4, "{cosine}");
        }
    }
}
