use super::*;
use bevy::math::Isometry3d;
use bevy::mesh::{MeshBuilder, Meshable};

const THICKNESS: f32 = 0.005;
const DT: f32 = 1.0 / 60.0;

/// A table top 1.2 m square and 4 cm thick, its top at y = 0.
fn table(geometry: Geometry<'_>) -> MovingCollider<'_> {
    MovingCollider {
        geometry,
        start: Isometry3d::from_translation(Vec3::new(0.0, -0.02, 0.0)),
        end: Isometry3d::from_translation(Vec3::new(0.0, -0.02, 0.0)),
        friction: 0.5,
        restitution: 0.0,
    }
}

fn top() -> Shape {
    Shape::Cuboid {
        half_extents: Vec3::new(0.6, 0.02, 0.6),
    }
}

fn top_mesh() -> TriMesh {
    let mesh = bevy::shape::Cuboid::new(1.2, 0.04, 1.2).mesh().build();
    TriMesh::from_mesh(&mesh).unwrap()
}

/// The edge contacts of two linked particles at rest.
fn edge_contacts(collider: &MovingCollider, x: [Vec3; 2], w: [f32; 2]) -> Vec<SolveContact> {
    edge_contacts_moving(collider, x, [Vec3::ZERO; 2], w)
}

/// The edge contacts of two linked particles moving at `v` (m/s).
fn edge_contacts_moving(
    collider: &MovingCollider,
    x: [Vec3; 2],
    v: [Vec3; 2],
    w: [f32; 2],
) -> Vec<SolveContact> {
    let link = [Link {
        a: 0,
        b: 1,
        rest_length: x[0].distance(x[1]),
    }];
    let mut out = Vec::new();
    predict_edge_contacts(
        collider,
        &[&link],
        (&x, &v, &w),
        (THICKNESS, DT),
        link_extent(&[&link], &x, &v),
        &mut Vec::new(),
        &mut out,
    );
    out
}

/// A collider that stays where it is.
fn still(geometry: Geometry<'_>) -> MovingCollider<'_> {
    MovingCollider {
        geometry,
        start: Isometry3d::IDENTITY,
        end: Isometry3d::IDENTITY,
        friction: 0.5,
        restitution: 0.0,
    }
}

/// A link from the table top, 2.5 cm in from the rim, to 5 cm out and
/// 4 cm below it: both particles outside, the link through the corner.
fn across_the_rim() -> [Vec3; 2] {
    [
        Vec3::new(0.575, THICKNESS, 0.0),
        Vec3::new(0.61, -0.04, 0.0),
    ]
}

/// The link's distance (m) from the rim's corner, at x = 0.6, y = 0.
fn from_corner([a, b]: [Vec3; 2]) -> f32 {
    let corner = Vec3::new(0.6, 0.0, 0.0);
    let (_, q, _) = segments_nearest((a, b), (corner - Vec3::Z, corner + Vec3::Z));
    let d = q - corner;
    if d.x > 0.0 || d.y > 0.0 {
        d.length()
    } else {
        -d.length()
    }
}

#[test]
fn a_link_through_a_tables_corner_is_listed_on_both_ends_with_the_corners_normal() {
    let x = across_the_rim();
    let depth = from_corner(x);
    assert!(depth < 0.0, "{depth}");
    for (name, mesh) in [("shape", None), ("mesh", Some(top_mesh()))] {
        let geometry = match &mesh {
            Some(m) => Geometry::Mesh(m),
            None => Geometry::Shape(top()),
        };
        let out = edge_contacts(&table(geometry), x, [1.0, 1.0]);
        assert_eq!(out.len(), 2, "{name}: {out:?}");
        assert_eq!((out[0].particle, out[1].particle), (0, 1));
        for c in &out {
            assert!(c.edge);
            // Out of the corner: up and outwards.
            assert!(c.normal.x > 0.3 && c.normal.y > 0.3, "{name}: {}", c.normal);
            // Out by at least the link's depth in the corner, and the
            // edge thickness.
            assert!(
                c.gap < depth - 0.9 * EDGE_THICKNESS * THICKNESS,
                "{name}: {} {depth}",
                c.gap
            );
            assert!(c.gap > -0.05, "{name}: {}", c.gap);
        }
    }
}

#[test]
fn moving_both_ends_out_by_the_gap_clears_the_corner_by_the_edge_thickness() {
    let x = across_the_rim();
    let c = edge_contacts(&table(Geometry::Shape(top())), x, [1.0, 1.0])[0];
    let moved = x.map(|p| p - c.gap * c.normal);
    let clear = from_corner(moved);
    let want = EDGE_THICKNESS * THICKNESS;
    assert!((clear - want).abs() < 2e-4, "{clear} against {want}");
}

#[test]
fn a_pinned_end_leaves_the_free_end_to_carry_the_link() {
    let x = across_the_rim();
    let both = edge_contacts(&table(Geometry::Shape(top())), x, [1.0, 1.0]);
    let one = edge_contacts(&table(Geometry::Shape(top())), x, [0.0, 1.0]);
    assert_eq!(one.len(), 1);
    assert_eq!(one[0].particle, 1);
    // It carries only its share of the point's motion: it moves further.
    assert!(one[0].gap < both[1].gap, "{} {}", one[0].gap, both[1].gap);
    // The link turns about the pin as it comes out, so its nearest point
    // moves along it: out of the corner within the step, and to the edge
    // thickness within the next.
    let mut moved = [x[0], x[1] - one[0].gap * one[0].normal];
    assert!(from_corner(moved) > 0.0, "{}", from_corner(moved));
    for c in edge_contacts(&table(Geometry::Shape(top())), moved, [0.0, 1.0]) {
        moved[1] -= c.gap * c.normal;
    }
    let want = EDGE_THICKNESS * THICKNESS;
    assert!(from_corner(moved) > 0.9 * want, "{}", from_corner(moved));
}

#[test]
fn links_on_a_surface_or_clear_of_corners_list_nothing() {
    let mesh = top_mesh();
    for geometry in [Geometry::Shape(top()), Geometry::Mesh(&mesh)] {
        let table = table(geometry);
        // Lying on the top; hanging beside the side; above the rim.
        for x in [
            [
                Vec3::new(0.0, THICKNESS, 0.0),
                Vec3::new(0.05, THICKNESS, 0.0),
            ],
            [
                Vec3::new(0.6 + THICKNESS, -0.01, 0.0),
                Vec3::new(0.6 + THICKNESS, -0.06, 0.0),
            ],
            [Vec3::new(0.58, 0.03, 0.0), Vec3::new(0.63, 0.03, 0.0)],
        ] {
            assert_eq!(edge_contacts(&table, x, [1.0, 1.0]), [], "{x:?}");
        }
    }
    // A 5 cm link resting over a 0.5 m ball sags 0.6 mm into the
    // thickness: less than a quarter of it.
    let ball = still(Geometry::Shape(Shape::Sphere { radius: 0.5 }));
    let r = 0.5 + THICKNESS;
    let half = 0.025 / r;
    let x = [
        Vec3::new(-half.sin(), half.cos(), 0.0) * r,
        Vec3::new(half.sin(), half.cos(), 0.0) * r,
    ];
    assert_eq!(edge_contacts(&ball, x, [1.0, 1.0]), []);
    // Over a 5 cm ball it cuts into it, and is held.
    let small = MovingCollider {
        geometry: Geometry::Shape(Shape::Sphere { radius: 0.05 }),
        ..ball
    };
    let r = 0.05 + THICKNESS;
    let half = 0.025 / r;
    let x = [
        Vec3::new(-half.sin(), half.cos(), 0.0) * r,
        Vec3::new(half.sin(), half.cos(), 0.0) * r,
    ];
    let out = edge_contacts(&small, x, [1.0, 1.0]);
    assert_eq!(out.len(), 2);
    assert!(out[0].normal.y > 0.999, "{}", out[0].normal);
}

#[test]
fn a_link_arriving_at_a_corner_within_the_step_is_listed() {
    // Above the rim and falling onto it at 2 m/s: it reaches the corner
    // within the step.
    let table = table(Geometry::Shape(top()));
    let v = [Vec3::new(0.0, -2.0, 0.0); 2];
    // Its ends are level: the nearest point is the whole middle of the
    // link over the top, not nearer than the inner end. Tilt the outer end
    // down and it is.
    let level = [Vec3::new(0.575, 0.02, 0.0), Vec3::new(0.625, 0.02, 0.0)];
    assert_eq!(edge_contacts_moving(&table, level, v, [1.0, 1.0]), []);
    let tilted = [Vec3::new(0.575, 0.02, 0.0), Vec3::new(0.62, -0.005, 0.0)];
    let out = edge_contacts_moving(&table, tilted, v, [1.0, 1.0]);
    assert_eq!(out.len(), 2, "{out:?}");
    assert!(out.iter().all(|c| c.gap > 0.0));
}

#[test]
fn nearest_points_of_two_segments() {
    let (t, p, q) = segments_nearest(
        (Vec3::new(-1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)),
        (Vec3::new(0.5, 0.0, -1.0), Vec3::new(0.5, 0.0, 1.0)),
    );
    assert!((t - 0.75).abs() < 1e-6);
    assert!(p.distance(Vec3::new(0.5, 1.0, 0.0)) < 1e-6);
    assert!(q.distance(Vec3::new(0.5, 0.0, 0.0)) < 1e-6);
    // Parallel, and a point.
    let (_, p, q) = segments_nearest((Vec3::ZERO, Vec3::X), (Vec3::Y, Vec3::Y + Vec3::X));
    assert!((p.distance(q) - 1.0).abs() < 1e-6);
    let (_, p, q) = segments_nearest((Vec3::ZERO, Vec3::ZERO), (Vec3::Y, Vec3::Y + Vec3::X));
    assert_eq!((p, q), (Vec3::ZERO, Vec3::Y));
}

#[test]
fn a_link_through_a_table_top_comes_out_over_the_nearest_rim() {
    // A round top (r 0.5 m, 4 cm thick, its middle at y = 0): one end
    // under it, one over it, 8 cm in from the rim. Out through a face, one
    // end would go through the top; over the rim, neither does.
    let top = still(Geometry::Shape(Shape::Cylinder {
        radius: 0.5,
        half_height: 0.02,
    }));
    let x = [Vec3::new(0.0, -0.025, -0.42), Vec3::new(0.0, 0.025, -0.42)];
    let out = edge_contacts(&top, x, [1.0, 1.0]);
    assert_eq!(out.len(), 2, "{out:?}");
    for c in &out {
        assert!(c.normal.distance(Vec3::NEG_Z) < 1e-3, "{}", c.normal);
        let want = -(0.08 + EDGE_THICKNESS * THICKNESS);
        assert!((c.gap - want).abs() < 1e-3, "{} against {want}", c.gap);
    }
}

#[test]
fn the_lower_bound_holds_for_a_convex_distance_and_tightens_with_the_middle() {
    // f(t) = (t − 0.3)² over [0, 1]: its ends' slopes (in t) and middle.
    let f = |t: f32| (t - 0.3) * (t - 0.3);
    let (a, b) = ((f(0.0), -0.6), (f(1.0), -1.4));
    let loose = lower_bound(a, b, None);
    let tight = lower_bound(a, b, Some(f(0.5)));
    // Below the least, 0 at t = 0.3, and tighter with the middle.
    assert!(loose < tight - 0.05 && tight <= 1e-6, "{loose} {tight}");
    // A symmetric chord, (t − 0.5)²: a quarter below its ends, bounded at a
    // third (at half without the middle).
    let f = |t: f32| (t - 0.5) * (t - 0.5);
    let (a, b) = ((f(0.0), -1.0), (f(1.0), -1.0));
    assert!((lower_bound(a, b, None) + 0.25).abs() < 1e-6);
    assert!((lower_bound(a, b, Some(0.0)) + 0.25 / 3.0).abs() < 1e-6);
}

#[test]
fn a_link_whose_pinned_end_is_dragged_into_a_table_is_not_held() {
    // A grab dragged 3 cm down into the table top, 30 cm in from its rim;
    // its link runs up to a free particle lying on the top. No move of
    // the free end takes the link out: the grab holds it in.
    let x = [Vec3::new(0.3, -0.03, 0.0), Vec3::new(0.25, THICKNESS, 0.0)];
    let out = edge_contacts(&table(Geometry::Shape(top())), x, [0.0, 1.0]);
    assert_eq!(out, []);
    let out = edge_contacts(&table(Geometry::Shape(top())), [x[1], x[0]], [1.0, 0.0]);
    assert_eq!(out, []);
}

#[test]
fn a_link_farther_inside_a_table_than_twice_its_length_is_not_held() {
    // A 5 cm link through the middle of a table top 40 cm wide, one end
    // above it and one under it: out over the nearest rim is 20 cm, four
    // times its length, and its ends' own contacts bring them out. Near
    // the rim the same link comes out over it.
    let slab = Shape::Cuboid {
        half_extents: Vec3::new(0.2, 0.02, 0.6),
    };
    let through = |x: f32| {
        [
            Vec3::new(x, THICKNESS, 0.0),
            Vec3::new(x + 0.01, -0.045, 0.0),
        ]
    };
    assert_eq!(
        edge_contacts(&table(Geometry::Shape(slab)), through(0.0), [1.0, 1.0]),
        []
    );
    let near = edge_contacts(&table(Geometry::Shape(slab)), through(0.185), [1.0, 1.0]);
    assert_eq!(near.len(), 2, "{near:?}");
    assert!(near.iter().all(|c| c.normal.x > 0.9), "{near:?}");
}
