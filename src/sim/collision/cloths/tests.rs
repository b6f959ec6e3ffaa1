use bevy::math::Vec3;

use super::edge_pass::EDGE_THICKNESS;
use super::*;

/// A flat 1 m square of two triangles at height `y` m, at rest, its
/// particles of 1 kg each, taken for a 1/60 s step.
fn floor_sheet(y: f32) -> ClothObstacle {
    let x = [
        Vec3::new(-0.5, y, -0.5),
        Vec3::new(0.5, y, -0.5),
        Vec3::new(0.5, y, 0.5),
        Vec3::new(-0.5, y, 0.5),
    ];
    let faces = [[0, 1, 2], [0, 2, 3]];
    let mut obstacle = ClothObstacle::default();
    ClothObstacle::take(
        faces.into_iter(),
        (&x, &[Vec3::ZERO; 4], &[1.0; 4]),
        (1.0 / 60.0, 0.01, 1.0),
        &mut obstacle,
    )
    .unwrap();
    obstacle
}

const PAIR: Pair = Pair {
    thickness: 0.01,
    friction: 0.4,
    rank: false,
};

/// The contacts of particles at `x` moving at `v` (inverse masses `w`)
/// with `other`, this cloth having no triangles.
fn contacts(x: &[Vec3], v: &[Vec3], w: &[f32], other: &ClothObstacle) -> Vec<SolveContact> {
    let mut out = Vec::new();
    let mut buffers = ObstacleBuffers::default();
    let dt = 1.0 / 60.0;
    predict_cloth_contacts(
        &[],
        (x, v, w),
        (0.0, dt),
        0.1,
        other,
        PAIR,
        &mut buffers,
        &mut out,
    );
    out
}

#[test]
fn a_particle_falling_onto_another_cloth_is_held_at_the_thickness_off_it() {
    let sheet = floor_sheet(0.0);
    let x = [
        Vec3::new(0.1, 0.015, 0.2),
        Vec3::new(0.1, 0.5, 0.2),
        Vec3::new(-0.2, 0.005, 0.1),
    ];
    let v = [
        Vec3::new(0.0, -1.0, 0.0),
        Vec3::new(0.0, -1.0, 0.0),
        Vec3::ZERO,
    ];
    // The second is far; the third is pinned.
    let got = contacts(&x, &v, &[1.0, 1.0, 0.0], &sheet);
    assert_eq!(got.len(), 1, "{got:?}");
    let c = got[0];
    assert_eq!(c.particle, 0);
    assert!((c.normal - Vec3::Y).length() < 1e-6, "{c:?}");
    assert!((c.gap - 0.005).abs() < 1e-6, "{c:?}");
    assert_eq!(
        (c.velocity, c.friction, c.source),
        (Vec3::ZERO, 0.0, CLOTH_SOURCE)
    );
    // Rising away from it, 5 mm clear: nothing to hold.
    assert!(contacts(&x[..1], &[Vec3::Y], &[1.0], &sheet).is_empty());
}

#[test]
fn a_particle_on_the_other_cloth_s_plane_goes_to_its_rank_s_side() {
    let sheet = floor_sheet(0.0);
    let x = [Vec3::new(0.1, 0.0, 0.2)];
    let got = contacts(&x, &[Vec3::ZERO], &[1.0], &sheet);
    assert_eq!(got.len(), 1);
    assert!((got[0].normal - Vec3::Y).length() < 1e-6, "{got:?}");
    assert!((got[0].gap + 0.01).abs() < 1e-6);
    // The other rank goes below.
    let mut out = Vec::new();
    let below = Pair { rank: true, ..PAIR };
    let mut buffers = ObstacleBuffers::default();
    let (v, w) = ([Vec3::ZERO], [1.0]);
    predict_cloth_contacts(
        &[],
        (&x, &v, &w),
        (0.0, 1.0 / 60.0),
        0.1,
        &sheet,
        below,
        &mut buffers,
        &mut out,
    );
    assert!((out[0].normal + Vec3::Y).length() < 1e-6, "{out:?}");
}

#[test]
fn a_particle_of_the_other_cloth_over_a_triangle_pushes_its_corners_away() {
    // The other cloth: one particle 4 mm over the centroid of this
    // cloth's triangle, coming down at 1 m/s.
    let mut point = ClothObstacle::default();
    ClothObstacle::take(
        std::iter::empty(),
        (
            &[Vec3::new(0.0, 0.004, -0.4 / 3.0)],
            &[Vec3::new(0.0, -1.0, 0.0)],
            &[1.0],
        ),
        (1.0 / 60.0, 0.01, 1.0),
        &mut point,
    )
    .unwrap();
    let x = [
        Vec3::new(-0.5, 0.0, -0.5),
        Vec3::new(0.5, 0.0, -0.5),
        Vec3::new(0.0, 0.0, 0.6),
    ];
    let (v, w) = ([Vec3::ZERO; 3], [1.0; 3]);
    let mut out = Vec::new();
    let mut buffers = ObstacleBuffers::default();
    let faces = [[0, 1, 2]];
    predict_cloth_contacts(
        &faces,
        (&x, &v, &w),
        (0.0, 1.0 / 60.0),
        1.0,
        &point,
        PAIR,
        &mut buffers,
        &mut out,
    );
    assert_eq!(out.len(), 3, "every corner carries a third: {out:?}");
    for c in &out {
        assert!((c.normal + Vec3::Y).length() < 1e-5, "{c:?}");
        assert!((c.gap + 0.006).abs() < 1e-5, "{c:?}");
        assert_eq!(c.velocity, Vec3::new(0.0, -1.0, 0.0));
    }
}

#[test]
fn a_particle_that_passed_through_the_other_cloth_is_put_back_on_its_side() {
    let sheet = floor_sheet(0.0);
    let start = [Vec3::new(0.1, 0.02, 0.2)];
    let mut x = [Vec3::new(0.1, -0.03, 0.2)];
    let mut v = [Vec3::new(0.5, -3.0, 0.0)];
    let mut buffers = ObstacleBuffers::default();
    let moved = undo_crossings(
        &start,
        &mut x,
        &mut v,
        &[1.0],
        &[],
        (0.0, 1.0 / 60.0),
        &sheet,
        PAIR,
        &mut buffers,
    );
    assert_eq!(moved, 1);
    assert!((x[0].y - 0.01).abs() < 1e-6, "{}", x[0]);
    assert_eq!(
        v[0],
        Vec3::new(0.5, 0.0, 0.0),
        "its approach is taken out, its slide kept"
    );
    // One that stayed clear is left alone; a pinned one too.
    let mut clear = [Vec3::new(0.1, 0.03, 0.2)];
    let moved = undo_crossings(
        &start,
        &mut clear,
        &mut v,
        &[1.0],
        &[],
        (0.0, 1.0 / 60.0),
        &sheet,
        PAIR,
        &mut buffers,
    );
    assert_eq!((moved, clear[0].y), (0, 0.03));
    let mut pinned = [Vec3::new(0.1, -0.03, 0.2)];
    let moved = undo_crossings(
        &start,
        &mut pinned,
        &mut v,
        &[0.0],
        &[],
        (0.0, 1.0 / 60.0),
        &sheet,
        PAIR,
        &mut buffers,
    );
    assert_eq!((moved, pinned[0].y), (0, -0.03));
}

#[test]
fn friction_slows_a_held_sliding_particle_by_its_load_and_never_turns_it() {
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let dt = 1.0 / 60.0;
    let held_on = |velocity| {
        (
            SolveContact {
                particle: 0,
                normal: Vec3::Y,
                gap: 0.0,
                velocity,
                friction: 0.0,
                source: CLOTH_SOURCE,
                body: NO_BODY,
                edge: false,
            },
            0.5,
        )
    };
    // Sliding at 1 m/s over a cloth at rest: loses μ g dt.
    let mut v = [Vec3::new(1.0, 0.0, 0.0)];
    assert_eq!(
        rub(
            &[held_on(Vec3::ZERO)],
            &mut v,
            &[Hold::Slide],
            (gravity, dt)
        ),
        1
    );
    assert!((v[0].x - (1.0 - 0.5 * 9.81 * dt)).abs() < 1e-6, "{}", v[0]);
    // Slower than that: stops relative to the cloth (moving at 0.2 m/s),
    // not past it.
    let mut v = [Vec3::new(0.25, 0.0, 0.0)];
    rub(
        &[held_on(Vec3::new(0.2, 0.0, 0.0))],
        &mut v,
        &[Hold::Stick],
        (gravity, dt),
    );
    assert!((v[0].x - 0.2).abs() < 1e-6, "{}", v[0]);
    // Not held, or under the cloth (gravity pulling it off): untouched.
    let mut v = [Vec3::new(1.0, 0.0, 0.0)];
    assert_eq!(
        rub(&[held_on(Vec3::ZERO)], &mut v, &[Hold::Free], (gravity, dt)),
        0
    );
    assert_eq!(
        rub(
            &[held_on(Vec3::ZERO)],
            &mut v,
            &[Hold::Slide],
            (-gravity, dt)
        ),
        0
    );
    assert_eq!(v[0].x, 1.0);
}

/// A strip 2 cm wide along z at height 0, at rest, taken for a 1/60 s step.
fn strip() -> ClothObstacle {
    let x = [
        Vec3::new(-0.01, 0.0, -0.5),
        Vec3::new(0.01, 0.0, -0.5),
        Vec3::new(0.01, 0.0, 0.5),
        Vec3::new(-0.01, 0.0, 0.5),
    ];
    let mut obstacle = ClothObstacle::default();
    ClothObstacle::take(
        [[0, 1, 2], [0, 2, 3]].into_iter(),
        (&x, &[Vec3::ZERO; 4], &[1.0; 4]),
        (1.0 / 60.0, 0.01, 1.0),
        &mut obstacle,
    )
    .unwrap();
    obstacle
}

#[test]
fn edges_that_passed_through_the_other_cloth_s_edges_are_put_back_on_their_side() {
    let other = strip();
    // A triangle whose corners all lie off the strip, two of its edges
    // across it, falling 5 cm through it in one step.
    let faces = [[0, 1, 2]];
    let start = [
        Vec3::new(-0.3, 0.02, 0.0),
        Vec3::new(0.3, 0.02, 0.0),
        Vec3::new(0.3, 0.02, 0.3),
    ];
    let end = start.map(|p| p - Vec3::new(0.0, 0.05, 0.0));
    let dt = 1.0 / 60.0;
    let (mut x, mut v) = (end, [Vec3::new(0.2, -3.0, 0.0); 3]);
    let mut buffers = ObstacleBuffers::default();
    let w = [1.0; 3];
    let points = undo_crossings(
        &start,
        &mut x,
        &mut v,
        &w,
        &[],
        (0.0, dt),
        &other,
        PAIR,
        &mut buffers,
    );
    assert_eq!(points, 0, "no particle came near the strip");
    assert_eq!(x, end);
    let edges = undo_edge_crossings(
        &faces,
        &start,
        &mut x,
        &mut v,
        &w,
        (&[], &[]),
        (0.0, dt),
        &other,
        PAIR,
        &mut buffers,
    );
    assert_eq!(edges, 2, "{x:?}");
    // Where each edge crosses x = 0 it lies above the strip, at least the
    // thickness up, and no longer falls.
    for (a, b) in [(0, 1), (0, 2)] {
        let f = (0.0 - x[a].x) / (x[b].x - x[a].x);
        let (at, speed) = (x[a].lerp(x[b], f), v[a].lerp(v[b], f));
        assert!(at.y >= PAIR.thickness - 1e-5, "edge {a}–{b} at {at}");
        // Stopped where it met the strip's edge, 1 cm off x = 0.
        assert!(speed.y >= -0.1, "edge {a}–{b} still falls at {speed}");
    }
    assert!(x[1].y >= PAIR.thickness - 1e-5 && x[1].y < 0.02, "{x:?}");
    // Edge 0–1 met the strip level: its slide along x is kept.
    assert!((v[1].x - 0.2).abs() < 1e-6, "{v:?}");
    // The same fall, stopped short of the strip, or with every particle
    // pinned, or with a NaN: nothing moves.
    for (scale, w, nan) in [(0.3, 1.0, false), (1.0, 0.0, false), (1.0, 1.0, true)] {
        let mut x = start.map(|p| p - Vec3::new(0.0, 0.05 * scale, 0.0));
        if nan {
            x[2].y = f32::NAN;
        }
        let before = x;
        let moved = undo_edge_crossings(
            &faces,
            &start,
            &mut x,
            &mut [Vec3::ZERO; 3],
            &[w; 3],
            (&[], &[]),
            (0.0, dt),
            &other,
            PAIR,
            &mut buffers,
        );
        let same = x
            .iter()
            .zip(&before)
            .all(|(a, b)| a == b || a.is_nan() && b.is_nan());
        // With a NaN corner the edge 0–1 still crosses and is put back.
        let expected = if nan { 1 } else { 0 };
        assert_eq!(moved, expected, "{scale} {w} {nan}: {x:?}");
        assert!(same || nan, "{x:?}");
        assert!(x[0].is_finite() && x[1].is_finite(), "{x:?}");
    }
    // With its corners held against a ceiling (the collider's normal
    // down), the triangle is not pushed up into it; lying on a floor, it is
    // pushed up off it.
    let mut held_x = end;
    let moved = undo_edge_crossings(
        &faces,
        &start,
        &mut held_x,
        &mut [Vec3::ZERO; 3],
        &w,
        (&[Hold::Stick; 3], &[Vec3::NEG_Y; 3]),
        (0.0, dt),
        &other,
        PAIR,
        &mut buffers,
    );
    assert_eq!((moved, held_x), (0, end));
    let moved = undo_edge_crossings(
        &faces,
        &start,
        &mut held_x,
        &mut [Vec3::ZERO; 3],
        &w,
        (&[Hold::Slide; 3], &[Vec3::Y; 3]),
        (0.0, dt),
        &other,
        PAIR,
        &mut buffers,
    );
    assert_eq!(moved, 2);
    // Mismatched slices do nothing.
    let moved = undo_edge_crossings(
        &faces,
        &start[..2],
        &mut x,
        &mut v,
        &w,
        (&[], &[]),
        (0.0, dt),
        &other,
        PAIR,
        &mut buffers,
    );
    assert_eq!(moved, 0);
}

/// The edge contacts of the triangle `[0, 1, 2]` at `x` (velocities `v`,
/// inverse masses `w`) with [`strip`].
fn edge_contacts(x: &[Vec3; 3], v: &[Vec3; 3], w: &[f32; 3]) -> Vec<SolveContact> {
    let mut out = Vec::new();
    let mut buffers = ObstacleBuffers::default();
    let dt = 1.0 / 60.0;
    let faces = [[0, 1, 2]];
    let other = strip();
    predict_edge_contacts(
        &faces,
        (x, v, w),
        (0.0, dt),
        &other,
        PAIR,
        &mut buffers,
        &mut out,
    );
    out
}

#[test]
fn an_edge_resting_across_the_other_cloth_s_edges_is_held_through_its_ends() {
    // Two edges of the triangle lie across the strip's long edges, their
    // corners 29 cm off it; the third lies beside it.
    let at = |y: f32| {
        [
            Vec3::new(-0.3, y, 0.0),
            Vec3::new(0.3, y, 0.0),
            Vec3::new(0.3, y, 0.3),
        ]
    };
    let h = EDGE_THICKNESS * PAIR.thickness;
    let still = [Vec3::ZERO; 3];
    let list = edge_contacts(&at(h), &still, &[1.0; 3]);
    let mut ends: Vec<u32> = list.iter().map(|c| c.particle).collect();
    ends.sort_unstable();
    assert_eq!(ends, [0, 0, 1, 2], "{list:?}");
    for c in &list {
        assert!(c.edge && c.source == CLOTH_SOURCE, "{c:?}");
        assert!(c.normal.distance(Vec3::Y) < 1e-5, "{c:?}");
        assert!(c.gap.abs() < 1e-5 && c.velocity == Vec3::ZERO, "{c:?}");
        assert_eq!(c.friction, 0.0);
    }
    // Lying the full thickness over it, as a sheet lying on a sheet: none.
    assert!(edge_contacts(&at(PAIR.thickness), &still, &[1.0; 3]).is_empty());
    // The same, falling onto it at 1 m/s (1.7 cm in the step): held, its
    // gap the 2.5 mm to go.
    let falling = [Vec3::new(0.0, -1.0, 0.0); 3];
    let list = edge_contacts(&at(PAIR.thickness), &falling, &[1.0; 3]);
    assert_eq!(list.len(), 4, "{list:?}");
    assert!(
        list.iter()
            .all(|c| (c.gap - (PAIR.thickness - h)).abs() < 1e-5)
    );
    // Below it, rising: held on its own side, below.
    let rising = [Vec3::new(0.0, 1.0, 0.0); 3];
    let list = edge_contacts(&at(-PAIR.thickness), &rising, &[1.0; 3]);
    assert_eq!(list.len(), 4, "{list:?}");
    assert!(list.iter().all(|c| c.normal.distance(-Vec3::Y) < 1e-5));
    // Far above it, falling: none yet.
    assert!(edge_contacts(&at(0.5), &falling, &[1.0; 3]).is_empty());
    // A pinned corner takes none; a pinned edge lists nothing.
    let list = edge_contacts(&at(h), &still, &[0.0, 1.0, 1.0]);
    assert!(
        list.iter().all(|c| c.particle != 0) && list.len() == 2,
        "{list:?}"
    );
    assert!(edge_contacts(&at(h), &still, &[0.0, 0.0, 1.0]).len() == 1);
    // A NaN corner: its edges list nothing, and nothing panics.
    let mut x = at(h);
    x[0].y = f32::NAN;
    assert!(edge_contacts(&x, &still, &[1.0; 3]).is_empty());
    // Mismatched slices: nothing.
    let mut out = Vec::new();
    let (faces, other) = ([[0, 1, 2]], strip());
    let mut buffers = ObstacleBuffers::default();
    let x = at(h);
    let pair = (&x[..], &still[..2], &[1.0; 3][..]);
    predict_edge_contacts(
        &faces,
        pair,
        (0.0, 0.01),
        &other,
        PAIR,
        &mut buffers,
        &mut out,
    );
    assert!(out.is_empty());
}

#[test]
fn an_edge_whose_nearest_point_is_a_corner_lists_no_edge_contact() {
    // The triangle stands on its corner 0 over the strip's middle: the
    // particle–triangle contacts hold that corner, not its edges.
    let h = EDGE_THICKNESS * PAIR.thickness;
    let x = [
        Vec3::new(0.0, h, 0.0),
        Vec3::new(0.0, h + 0.3, 0.0),
        Vec3::new(0.0, h + 0.3, 0.3),
    ];
    assert!(edge_contacts(&x, &[Vec3::ZERO; 3], &[1.0; 3]).is_empty());
}

/// The triangles of a square grid of `columns` × `columns` particles, row
/// by row, two a square.
fn grid_faces(columns: u32) -> impl Iterator<Item = [u32; 3]> {
    (0..(columns - 1) * (columns - 1)).flat_map(move |s| {
        let (i, j) = (s % (columns - 1), s / (columns - 1));
        let a = j * columns + i;
        [
            [a, a + 1, a + columns + 1],
            [a, a + columns + 1, a + columns],
        ]
    })
}

#[test]
fn a_marked_gather_lists_the_triangles_a_sorted_one_does_across_the_marks_wrapping() {
    // A 10 × 10 grid of 0.1 m squares, each two triangles, at rest.
    let x: Vec<Vec3> = (0..121)
        .map(|i| Vec3::new((i % 11) as f32 * 0.1, 0.0, (i / 11) as f32 * 0.1))
        .collect();
    let faces = grid_faces(11);
    let mut obstacle = ClothObstacle::default();
    let (v, w) = (vec![Vec3::ZERO; 121], vec![1.0; 121]);
    ClothObstacle::take(faces, (&x, &v, &w), (1.0 / 60.0, 0.01, 0.1), &mut obstacle).unwrap();
    let mut marks = Marks {
        query: u32::MAX - 3,
        ..Marks::default()
    };
    let (mut sorted, mut marked) = (Vec::new(), Vec::new());
    let mut seed = 7u32;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1 << 24) as f32
    };
    let mut boxes: Vec<(Vec3, Vec3)> = (0..40)
        .map(|_| {
            let c = Vec3::new(next() * 1.2 - 0.1, next() * 0.1 - 0.05, next() * 1.2 - 0.1);
            let r = Vec3::splat(0.01 + 0.2 * next());
            (c - r, c + r)
        })
        .collect();
    boxes.push((Vec3::splat(-50.0), Vec3::splat(50.0)));
    boxes.push((Vec3::splat(f32::NAN), Vec3::ONE));
    for (lo, hi) in boxes {
        obstacle.gather(lo, hi, &mut sorted);
        obstacle.gather_marked((lo, hi), marks.next(obstacle.faces.len()), &mut marked);
        let listed = marked.len();
        marked.sort_unstable();
        marked.dedup();
        assert_eq!(listed, marked.len(), "a triangle listed twice");
        assert_eq!(marked, sorted, "box {lo}..{hi}");
    }
    assert!(marks.query < 100, "the marks wrapped: {}", marks.query);
}

#[test]
fn a_gather_lists_every_triangle_whose_box_meets_the_box_asked() {
    // A 10 × 10 grid of 2.7 cm squares, bent, moving, hashed in cells of
    // 3 cm (a query looks in fewer cells than its box spans: the triangles
    // are hashed grown by the pad).
    let x: Vec<Vec3> = (0..121)
        .map(|i| {
            let (i, j) = ((i % 11) as f32, (i / 11) as f32);
            Vec3::new(0.011 + i * 0.027, 0.01 * (i * j).sin(), 0.004 + j * 0.027)
        })
        .collect();
    let v: Vec<Vec3> = (0..121)
        .map(|i| Vec3::new(0.0, (i % 5) as f32 * 0.1, 0.0))
        .collect();
    let faces = grid_faces(11);
    let mut obstacle = ClothObstacle::default();
    let dt = 1.0 / 60.0;
    ClothObstacle::take(
        faces,
        (&x, &v, &[1.0; 121]),
        (dt, 0.01, 0.03),
        &mut obstacle,
    )
    .unwrap();
    let mut seed = 3u32;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1 << 24) as f32
    };
    let (mut listed, mut met) = (Vec::new(), 0);
    for _ in 0..400 {
        let c = Vec3::new(
            next() * 0.36 - 0.03,
            next() * 0.06 - 0.03,
            next() * 0.36 - 0.03,
        );
        let r = Vec3::new(next(), next(), next()) * 0.06;
        let (lo, hi) = (c - r, c + r);
        obstacle.gather(lo, hi, &mut listed);
        assert!(
            listed.len() < 150,
            "{} of 200 triangles listed",
            listed.len()
        );
        for (t, tri) in obstacle.faces.iter().enumerate() {
            let path: Vec<Vec3> = tri
                .iter()
                .flat_map(|&q| [x[q as usize], x[q as usize] + v[q as usize] * dt])
                .collect();
            let (tlo, thi) = finite_box(&path).unwrap();
            if tlo.cmple(hi).all() && lo.cmple(thi).all() {
                met += 1;
                assert!(listed.contains(&(t as u32)), "{t} meets {lo}..{hi}");
            }
        }
    }
    assert!(met > 400, "only {met} triangles met the boxes");
}

#[test]
fn edges_put_back_through_the_listed_edges_are_those_a_fresh_look_up_finds() {
    // Two 8 × 8 grids of 4 cm squares, 1.5 cm apart: the other one moving
    // at random, this one falling onto it and through it by random amounts,
    // some within the boxes the prediction listed, some beyond them.
    let faces: Vec<[u32; 3]> = grid_faces(8).collect();
    let mut seed = 11u32;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as f32 / (1 << 24) as f32 - 0.5
    };
    let dt = 1.0 / 60.0;
    let (mut listed_any, mut put_back) = (false, 0);
    for trial in 0..80 {
        let at = |i: u32, y: f32| Vec3::new((i % 8) as f32 * 0.04, y, (i / 8) as f32 * 0.04);
        let theirs: Vec<Vec3> = (0..64).map(|i| at(i, 0.004 * next())).collect();
        let their_v: Vec<Vec3> = (0..64)
            .map(|_| Vec3::new(next(), next(), next()) * 0.6)
            .collect();
        let mut other = ClothObstacle::default();
        ClothObstacle::take(
            faces.iter().copied(),
            (&theirs, &their_v, &[1.0; 64]),
            (dt, 0.01, 0.04),
            &mut other,
        )
        .unwrap();
        // Shifted by a third of a square so that edges cross edges.
        let x: Vec<Vec3> = (0..64)
            .map(|i| at(i, 0.015) + Vec3::new(0.013, 0.003 * next(), 0.007))
            .collect();
        let v: Vec<Vec3> = (0..64)
            .map(|_| Vec3::new(0.3 * next(), -0.9 + 0.3 * next(), 0.3 * next()))
            .collect();
        let w: Vec<f32> = (0..64)
            .map(|i| if i % 17 == 0 { 0.0 } else { 1.0 })
            .collect();
        let mut buffers = ObstacleBuffers::default();
        let mut out = Vec::new();
        predict_edge_contacts(
            &faces,
            (&x, &v, &w),
            (0.0, dt),
            &other,
            PAIR,
            &mut buffers,
            &mut out,
        );
        listed_any |= buffers.pairs.iter().any(|p| !p.theirs.is_empty());
        // Moved by the predicted velocities, then by up to 1 cm (a trial in
        // four: 15 cm, beyond the boxes listed) more at random.
        let scale = if trial % 4 == 0 { 0.3 } else { 0.02 };
        let end: Vec<Vec3> = (0..64)
            .map(|i| x[i] + v[i] * dt + Vec3::new(next(), next() - 0.3, next()) * scale)
            .collect();
        let undo = |buffers: &mut ObstacleBuffers| {
            let (mut xs, mut vs) = (end.clone(), v.clone());
            let moved = undo_edge_crossings(
                &faces,
                &x,
                &mut xs,
                &mut vs,
                &w,
                (&[], &[]),
                (0.0, dt),
                &other,
                PAIR,
                buffers,
            );
            (moved, xs, vs)
        };
        let listed = undo(&mut buffers);
        let fresh = undo(&mut ObstacleBuffers::default());
        // The same edges, put back alike up to rounding (a listed edge may
        // run the other way).
        assert_eq!(listed.0, fresh.0, "trial {trial}");
        for (a, b) in listed
            .1
            .iter()
            .zip(&fresh.1)
            .chain(listed.2.iter().zip(&fresh.2))
        {
            assert!(a.distance(*b) < 1e-5, "trial {trial}: {a} {b}");
        }
        put_back += listed.0;
    }
    assert!(listed_any, "the prediction listed no edge");
    assert!(put_back > 50, "only {put_back} edges put back");
}
