use super::exact::sign_changes;
use super::*;
use crate::plugin::spawn::builder::ClothBuilder;
use crate::sim::grid::Grid;

/// Every crossing from `start` to `end`, by testing every pair.
fn every_crossing(grid: &Grid, start: &[Vec3], end: &[Vec3]) -> Vec<Crossing> {
    let mut edges = Vec::new();
    for [a, b, c] in grid.faces() {
        for (p, q) in [(a, b), (b, c), (c, a)] {
            edges.push([p.min(q), p.max(q)]);
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let mut out = Vec::new();
    for p in 0..start.len() as u32 {
        for tri in grid.faces() {
            if !tri.contains(&p)
                && let Some(c) = point_triangle(p, tri, start, end)
            {
                out.push(c);
            }
        }
    }
    for (i, e) in edges.iter().enumerate() {
        for f in &edges[i + 1..] {
            if !f.contains(&e[0])
                && !f.contains(&e[1])
                && let Some(c) = edge_edge(*e, *f, start, end)
            {
                out.push(c);
            }
        }
    }
    out
}

/// A small generator of numbers in [0, 1), reproducible.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[test]
fn the_cubic_s_sign_changes_are_its_roots_in_order() {
    // (t − 0.25)(t − 0.5)(t − 0.8) = t³ − 1.55 t² + 0.725 t − 0.1
    let mut roots = [0.0; 3];
    let n = sign_changes([-0.1, 0.725, -1.55, 1.0], 0.0, &mut roots);
    assert_eq!(n, 3);
    for (r, want) in roots.iter().zip([0.25, 0.5, 0.8]) {
        assert!((r - want).abs() < 1e-12, "{roots:?}");
    }
    // A double root touches without a sign change; a root outside [0, 1]
    // is not reported.
    let n = sign_changes([0.25, -1.0, 1.0, 0.0], 0.0, &mut roots); // (t − 0.5)²
    assert_eq!(n, 0);
    let n = sign_changes([-2.0, 1.0, 0.0, 0.0], 0.0, &mut roots); // t − 2
    assert_eq!(n, 0);
    // Linear: t − 0.3.
    let n = sign_changes([-0.3, 1.0, 0.0, 0.0], 0.0, &mut roots);
    assert_eq!(n, 1);
    assert!((roots[0] - 0.3).abs() < 1e-12);
}

#[test]
fn a_particle_through_a_triangle_s_inside_crosses_it_and_one_beside_it_does_not() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Z];
    let mut start = vec![tri[0], tri[1], tri[2], Vec3::new(0.2, 0.3, 0.2)];
    let mut end = start.clone();
    end[3].y = -0.1;
    let c = point_triangle(3, [0, 1, 2], &start, &end).expect("crosses");
    assert!((c.at - 0.75).abs() < 1e-6, "{c:?}");
    assert!((c.normal - Vec3::Y).length() < 1e-6, "{c:?}");
    assert_eq!(c.particles, [3, 0, 1, 2]);
    // Beside the triangle (x + z > 1): through the plane, outside it.
    start[3] = Vec3::new(0.8, 0.3, 0.8);
    end[3] = Vec3::new(0.8, -0.1, 0.8);
    assert_eq!(point_triangle(3, [0, 1, 2], &start, &end), None);
    // Down to the plane without going through, and along it.
    start[3] = Vec3::new(0.2, 0.3, 0.2);
    end[3] = Vec3::new(0.2, 0.0, 0.2);
    assert_eq!(point_triangle(3, [0, 1, 2], &start, &end), None);
    start[3] = Vec3::new(0.2, 0.0, 0.2);
    end[3] = Vec3::new(0.3, 0.0, 0.1);
    assert_eq!(point_triangle(3, [0, 1, 2], &start, &end), None);
    // The triangle goes up through a resting particle: the normal points
    // to where the particle was, above it.
    start[3] = Vec3::new(0.2, 0.1, 0.2);
    end[3] = start[3];
    for i in 0..3 {
        end[i] = tri[i] + 0.4 * Vec3::Y;
    }
    let c = point_triangle(3, [0, 1, 2], &start, &end).expect("crosses");
    assert!((c.at - 0.25).abs() < 1e-6, "{c:?}");
    assert!((c.normal - Vec3::Y).length() < 1e-6, "{c:?}");
}

#[test]
fn edges_that_pass_through_each_other_cross_and_those_that_pass_by_do_not() {
    // Edge 0–1 along x at y = 0.2 comes down through edge 2–3 along z.
    let start = vec![
        Vec3::new(-1.0, 0.2, 0.0),
        Vec3::new(1.0, 0.2, 0.0),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(0.0, 0.0, 1.0),
    ];
    let mut end = start.clone();
    end[0].y = -0.2;
    end[1].y = -0.2;
    let c = edge_edge([0, 1], [2, 3], &start, &end).expect("crosses");
    assert!((c.at - 0.5).abs() < 1e-6, "{c:?}");
    assert!((c.normal - Vec3::Y).length() < 1e-6, "{c:?}");
    for (got, want) in c.weights.iter().zip([0.5, 0.5, -0.5, -0.5]) {
        assert!((got - want).abs() < 1e-5, "{c:?}");
    }
    // Shifted past the other edge's end: they pass by.
    let shift = Vec3::new(0.0, 0.0, 1.5);
    let (s2, e2): (Vec<Vec3>, Vec<Vec3>) = (0..4)
        .map(|i| {
            if i < 2 {
                (start[i] + shift, end[i] + shift)
            } else {
                (start[i], end[i])
            }
        })
        .unzip();
    assert_eq!(edge_edge([0, 1], [2, 3], &s2, &e2), None);
    // Sliding along each other in one plane: no crossing.
    let flat: Vec<Vec3> = start.iter().map(|p| Vec3::new(p.x, 0.0, p.z)).collect();
    let moved: Vec<Vec3> = flat
        .iter()
        .enumerate()
        .map(|(i, p)| if i < 2 { *p + Vec3::Z * 0.3 } else { *p })
        .collect();
    assert_eq!(edge_edge([0, 1], [2, 3], &flat, &moved), None);
}

/// A 9×9 cloth folded in two, its upper half 4 cm over the pinned lower
/// half, the upper half's step carrying it `drop` m down.
fn folded(drop: f32) -> (Grid, Vec<Vec3>, Vec<Vec3>, Vec<f32>) {
    let cloth = ClothBuilder::new(9, 9).size(1.0, 1.0).build().unwrap();
    let grid = cloth.cloth.grid().cloned().expect("a grid cloth");
    let h = 1.0 / 8.0;
    let mut start = vec![Vec3::ZERO; 81];
    let mut w = vec![1.0; 81];
    for j in 0..9usize {
        for i in 0..9usize {
            let p = j * 9 + i;
            let x = i as f32 * h - 0.5;
            if j <= 4 {
                start[p] = Vec3::new(x, 0.0, j as f32 * h);
                w[p] = 0.0;
            } else {
                // Laid back over rows 3..0, rising from the fold.
                let z = (8 - j) as f32 * h;
                start[p] = Vec3::new(x, 0.04 * (j - 4) as f32, z);
            }
        }
    }
    let mut end = start.clone();
    for p in &mut end[45..] {
        p.y -= drop;
    }
    (grid, start, end, w)
}

#[test]
fn a_fold_thrown_through_the_lower_layer_in_one_step_ends_above_it() {
    let (grid, start, mut x, w) = folded(0.6);
    assert!(!every_crossing(&grid, &start, &x).is_empty());
    let mut v = vec![Vec3::ZERO; 81];
    v[45..].fill(Vec3::new(0.0, -36.0, 0.0));
    let mut buffers = CrossingBuffers::default();
    let counts = prevent_crossings(&grid, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
    assert!(counts.crossings > 0, "{counts:?}");
    assert_eq!(every_crossing(&grid, &start, &x), vec![]);
    // The upper layer is above the lower one, and no faster than it came.
    for p in 45..81 {
        assert!(x[p].y > 0.0, "particle {p} at {}", x[p]);
        assert!(v[p].length() <= 36.0 + 1e-3, "particle {p} at {} m/s", v[p]);
    }
    // The pinned layer has not moved.
    assert_eq!(&x[..45], &start[..45]);
}

#[test]
fn pushes_between_free_particles_keep_the_momentum() {
    let (grid, start, mut x, mut w) = folded(0.3);
    w.fill(1.0);
    let mut v = vec![Vec3::ZERO; 81];
    v[45..].fill(Vec3::new(0.0, -18.0, 0.0));
    let momentum = |v: &[Vec3]| v.iter().sum::<Vec3>();
    let before = momentum(&v);
    let mut buffers = CrossingBuffers::default();
    let counts = prevent_crossings(&grid, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
    assert!(counts.crossings > 0, "{counts:?}");
    assert_eq!(every_crossing(&grid, &start, &x), vec![]);
    assert!((momentum(&v) - before).length() < 1e-3 * before.length());
}

#[test]
fn impact_zones_undo_what_pushes_leave_crossed() {
    let (grid, start, mut x, w) = folded(0.6);
    let mut v = vec![Vec3::ZERO; 81];
    let mut buffers = CrossingBuffers::default();
    buffers
        .edges
        .update(|| grid.faces(), grid.face_count(), None);
    let mut tests = 0;
    let stopped = stop_zones(
        &grid,
        (&start, &mut x, &mut v),
        &w,
        0.01,
        &mut tests,
        &mut buffers,
    );
    assert!(stopped > 0 && tests > 0);
    assert_eq!(every_crossing(&grid, &start, &x), vec![]);
    // Held particles (the lower layer) are not moved; the zones hold one,
    // so they stop with it.
    assert_eq!(&x[..45], &start[..45]);
    for p in 45..81 {
        if x[p] == start[p] {
            assert_eq!(v[p], Vec3::ZERO);
        }
    }
}

#[test]
fn random_steps_of_a_crumpled_cloth_end_without_a_crossing() {
    let mut rng = Lcg(7);
    let cloth = ClothBuilder::new(7, 7).size(0.6, 0.6).build().unwrap();
    let grid = cloth.cloth.grid().cloned().expect("a grid cloth");
    let mut buffers = CrossingBuffers::default();
    let mut x = cloth.particles.positions.clone();
    let w = vec![1.0; x.len()];
    let mut v = vec![Vec3::ZERO; x.len()];
    let mut crossed = 0;
    for step in 0..300 {
        let start = x.clone();
        // Each particle jumps up to 15 cm (twice the spacing) at random.
        for p in x.iter_mut() {
            *p += 0.3 * Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5);
        }
        let counts = prevent_crossings(&grid, &start, &mut x, &mut v, &w, 0.005, &mut buffers);
        crossed += counts.crossings;
        let left = every_crossing(&grid, &start, &x);
        assert!(left.is_empty(), "step {step}: {counts:?}, left {left:?}");
        assert!(x.iter().all(|p| p.is_finite()));
    }
    assert!(crossed > 100, "the steps should cross often: {crossed}");
}

#[test]
fn a_non_finite_particle_is_left_to_the_guard() {
    let (grid, start, mut x, w) = folded(0.6);
    x[50] = Vec3::NAN;
    let mut v = vec![Vec3::ZERO; 81];
    let mut buffers = CrossingBuffers::default();
    let counts = prevent_crossings(&grid, &start, &mut x, &mut v, &w, 0.01, &mut buffers);
    assert_eq!(counts.crossings, 0);
    let counts = prevent_crossings(&grid, &start, &mut x, &mut v, &w, f32::NAN, &mut buffers);
    assert_eq!(counts, CrossingCounts::default());
    // Slices that do not match the cloth or each other: nothing done.
    let (grid, start, mut x, w) = folded(0.6);
    let (short, mut fewer) = (&start[..40], x[..40].to_vec());
    let mut v = vec![Vec3::ZERO; 40];
    let counts = prevent_crossings(
        &grid,
        short,
        &mut fewer,
        &mut v,
        &w[..40],
        0.01,
        &mut buffers,
    );
    assert_eq!(counts, CrossingCounts::default());
    let mut v = vec![Vec3::ZERO; 81];
    let counts = prevent_crossings(&grid, &start, &mut x, &mut v, &w[..3], 0.01, &mut buffers);
    assert_eq!(counts, CrossingCounts::default());
}

#[test]
fn features_that_start_in_one_place_or_one_plane_do_not_cross() {
    // The two sides of a tear: copies of an edge, in one place, parting.
    let a = Vec3::new(0.3, 1.2, -0.7);
    let b = Vec3::new(0.34, 1.21, -0.66);
    let start = vec![a, b, a, b];
    let end = vec![
        a + Vec3::X * 0.01,
        b + Vec3::X * 0.01,
        a - Vec3::Y * 0.01,
        b - Vec3::Y * 0.01,
    ];
    assert_eq!(edge_edge([0, 1], [2, 3], &start, &end), None);
    // A particle copied from a triangle's corner, parting from it.
    let c = Vec3::new(0.31, 1.25, -0.69);
    let start = vec![a, b, c, a];
    let end = vec![a, b, c, a + Vec3::new(0.01, -0.02, 0.005)];
    assert_eq!(point_triangle(3, [0, 1, 2], &start, &end), None);
    // A flat cloth in a tilted plane, far from the origin, sliding along
    // the plane: its single-precision positions are off the plane by
    // rounding only.
    let cloth = ClothBuilder::new(6, 6).size(0.3, 0.3).build().unwrap();
    let grid = cloth.cloth.grid().cloned().expect("a grid cloth");
    let tilt = bevy::math::Quat::from_rotation_x(0.7) * bevy::math::Quat::from_rotation_z(0.3);
    let far = Vec3::new(120.0, 35.0, -80.0);
    let start: Vec<Vec3> = cloth
        .particles
        .positions
        .iter()
        .map(|p| far + tilt * *p)
        .collect();
    let slide = tilt * Vec3::new(0.02, 0.0, 0.013);
    let end: Vec<Vec3> = start.iter().map(|p| *p + slide).collect();
    assert_eq!(every_crossing(&grid, &start, &end), vec![]);
    // Torn copies of random triangles' corners, parting along the plane.
    let mut rng = Lcg(11);
    let mut random = || Vec3::new(rng.next(), rng.next(), rng.next()) - 0.5;
    for _ in 0..2000 {
        let at = far * random();
        let (a, b) = (at + 0.05 * random(), at + 0.05 * random());
        let c = at + 0.05 * random();
        let along = 0.02 * (b - a) + 0.01 * (c - a);
        let start = vec![a, b, c, a];
        let end = vec![a, b, c, a + along];
        assert_eq!(point_triangle(3, [0, 1, 2], &start, &end), None);
        let end = vec![a - along, b, c, a + along];
        assert_eq!(edge_edge([0, 1], [3, 2], &start, &end), None);
        // A particle sliding in the triangle's plane onto it.
        let start = vec![a, b, c, a + 1.5 * (a - b)];
        let end = vec![a, b, c, (a + b + c) / 3.0];
        assert_eq!(point_triangle(3, [0, 1, 2], &start, &end), None);
    }
}
