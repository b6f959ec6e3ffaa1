//! Separate cloths meeting edge to edge, where no particle of either comes
//! near a triangle of the other: a ribbon dropped or thrown across a
//! ribbon, every default but the components.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::{app, particles};

/// A ribbon of 3 × `length` particles, 4 cm wide and 10 cm between rows.
fn ribbon(length: u32) -> ClothBuilder {
    ClothBuilder::new(3, length).size(0.04, 0.1 * (length - 1) as f32)
}

/// The closest points' distance of segments `p0 p1` and `q0 q1`, m.
fn segment_distance((p0, p1): (Vec3, Vec3), (q0, q1): (Vec3, Vec3)) -> f32 {
    // Sampled finely enough for a test: 1 mm steps on 10 cm edges.
    let mut least = f32::MAX;
    for i in 0..=100 {
        let p = p0.lerp(p1, i as f32 / 100.0);
        let (d, e) = (q1 - q0, p - q0);
        let u = (e.dot(d) / d.length_squared().max(1e-12)).clamp(0.0, 1.0);
        least = least.min(p.distance(q0 + d * u));
    }
    least
}

/// The edges of `e`'s triangles, each once.
fn edges(app: &App, e: Entity) -> Vec<[u32; 2]> {
    let cloth = app.world().get::<Cloth>(e).unwrap();
    let mut out: Vec<[u32; 2]> = bevy_cloth::sim::grid::Faces::faces(cloth)
        .flat_map(|[a, b, c]| [[a, b], [b, c], [c, a]])
        .map(|[a, b]| [a.min(b), a.max(b)])
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// The smallest distance (m) between an edge `ea` of cloth `a` and an edge
/// `eb` of cloth `b` that start within 0.5 m of each other; asserts every
/// particle of both is finite.
fn closest_edges(app: &App, (a, ea): (Entity, &[[u32; 2]]), (b, eb): (Entity, &[[u32; 2]])) -> f32 {
    let (xa, xb) = (&particles(app, a).positions, &particles(app, b).positions);
    assert!(xa.iter().chain(xb).all(|p| p.is_finite()));
    let mut least = f32::MAX;
    for &[p, q] in ea {
        let s = (xa[p as usize], xa[q as usize]);
        for &[r, t] in eb {
            let u = (xb[r as usize], xb[t as usize]);
            if s.0.distance(u.0) < 0.5 {
                least = least.min(segment_distance(s, u));
            }
        }
    }
    least
}

/// A ribbon along z pinned at both ends at y = 1 m, and a ribbon along x
/// pinned at both ends 2 cm above it and thrown down at `speed` m/s; their
/// particles lie 5 cm either side of the other ribbon, so they meet edge to
/// edge only. Returns, over 2 s, the smallest distance between their edges
/// (m) and the lowest height of the upper ribbon's middle over the lower's
/// (m).
fn ribbon_thrown_across(speed: f32, collide: bool) -> (f32, f32) {
    let mut app = app();
    let ends = |_: u32, row: u32, _: Vec2| row == 0 || row == 9;
    let lower = ribbon(10)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin_where(ends)
        .build()
        .unwrap();
    let mut upper = ribbon(10)
        .position(Vec3::new(0.0, 1.02, 0.0))
        .rotation(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2))
        .pin_where(ends)
        .build()
        .unwrap();
    for v in &mut upper.particles.velocities[3..27] {
        *v = Vec3::new(0.0, -speed, 0.0);
    }
    let contact = |layer| ClothToClothCollision { layer, ..default() };
    let (a, b) = if collide {
        let a = app.world_mut().spawn((lower, contact(0))).id();
        (a, app.world_mut().spawn((upper, contact(1))).id())
    } else {
        let a = app.world_mut().spawn(lower).id();
        (a, app.world_mut().spawn(upper).id())
    };
    let (ea, eb) = (edges(&app, a), edges(&app, b));
    // Midway between the particles either side of the crossing in each
    // ribbon's middle column.
    let middle = |app: &App, e: Entity| {
        let x = &particles(app, e).positions;
        x[4 * 3 + 1].lerp(x[5 * 3 + 1], 0.5)
    };
    let (mut least, mut lowest) = (f32::MAX, f32::MAX);
    for _ in 0..120 {
        app.update();
        least = least.min(closest_edges(&app, (a, &ea), (b, &eb)));
        lowest = lowest.min(middle(&app, b).y - middle(&app, a).y);
    }
    (least, lowest)
}

#[test]
fn a_ribbon_thrown_across_a_ribbon_stays_above_it() {
    let thickness = ClothToClothCollision::default().thickness;
    for speed in [2.0, 10.0, 50.0] {
        let (least, lowest) = ribbon_thrown_across(speed, true);
        eprintln!(
            "ribbon thrown at {speed} m/s: closest edges {least:.4} m, its middle at least {lowest:.4} m above"
        );
        assert!(
            lowest > 0.0,
            "at {speed} m/s the upper ribbon's middle went {lowest} m below the lower one's"
        );
        assert!(
            least >= thickness / 2.0,
            "at {speed} m/s the ribbons' edges came {least} m close"
        );
    }
    // Without collision between them it goes through: the scene tests what
    // it claims.
    for speed in [2.0, 10.0, 50.0] {
        let (_, lowest) = ribbon_thrown_across(speed, false);
        eprintln!("without collision, at {speed} m/s: its middle at least {lowest:.4} m above");
        assert!(lowest < -0.01, "its middle stayed {lowest} m above");
    }
}

/// The ribbon along x of [`ribbon_thrown_across`], free, dropped from 2 cm
/// across the pinned one: it meets it edge to edge and hangs over it like a
/// towel over a bar. Returns, over `frames` frames, the smallest distance
/// between their edges (m), and at the end the height of its highest
/// particle over the lower ribbon's middle (m) and how far its middle slid
/// along its length (m).
fn ribbon_dropped_across(frames: u32) -> (f32, f32, f32) {
    let mut app = app();
    let ends = |_: u32, row: u32, _: Vec2| row == 0 || row == 9;
    let lower = ribbon(10)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin_where(ends)
        .build()
        .unwrap();
    let upper = ribbon(10)
        .position(Vec3::new(0.0, 1.02, 0.0))
        .rotation(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2))
        .build()
        .unwrap();
    let contact = |layer| ClothToClothCollision { layer, ..default() };
    let a = app.world_mut().spawn((lower, contact(0))).id();
    let b = app.world_mut().spawn((upper, contact(1))).id();
    let (ea, eb) = (edges(&app, a), edges(&app, b));
    let mut least = f32::MAX;
    for _ in 0..frames {
        app.update();
        least = least.min(closest_edges(&app, (a, &ea), (b, &eb)));
    }
    let (xa, xb) = (&particles(&app, a).positions, &particles(&app, b).positions);
    let highest = xb.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    // Midway between the particles either side of the crossing in each
    // ribbon's middle column.
    let middle = |x: &[Vec3]| x[4 * 3 + 1].lerp(x[5 * 3 + 1], 0.5);
    let (ma, mb) = (middle(xa), middle(xb));
    (least, highest - ma.y, mb.x - ma.x)
}

#[test]
fn a_ribbon_dropped_across_a_ribbon_hangs_on_it() {
    let thickness = ClothToClothCollision::default().thickness;
    let (least, highest, slid) = ribbon_dropped_across(600);
    eprintln!(
        "ribbon dropped across: closest edges {least:.4} m; after 10 s its top {highest:.4} m over the other's middle, its middle slid {slid:.4} m"
    );
    assert!(
        least >= thickness / 2.0,
        "the ribbons' edges came {least} m close"
    );
    assert!(
        highest > 0.0,
        "it fell off or through: its top {highest} m over the other"
    );
    assert!(slid.abs() < 0.05, "it slid {slid} m along its length");
}
