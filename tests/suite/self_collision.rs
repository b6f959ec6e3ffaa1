//! Self-collision under fast motion: a fold thrown through the cloth and a
//! cloth flicked over onto itself, every default but the component.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::{app, grab_where_they_are, particles};

/// An `n × n`, 1 m cloth folded in two without gravity: rows up to the
/// middle flat and pinned at y = 0, the rest laid back over them one
/// spacing above and thrown down at `speed` m/s. Returns the lowest height
/// of the upper layer over 1 s and at its end (m), and how many of its
/// particles end below the lower layer.
fn thrown_fold(n: u32, speed: f32, self_collision: bool) -> (f32, f32, usize) {
    let mut app = app();
    let h = 1.0 / (n - 1) as f32;
    let half = (n - 1) / 2;
    let mut cloth = ClothBuilder::new(n, n).size(1.0, 1.0).build().unwrap();
    for j in 0..n {
        for i in 0..n {
            let p = (j * n + i) as usize;
            let x = i as f32 * h - 0.5;
            if j <= half {
                cloth.particles.positions[p] = Vec3::new(x, 0.0, j as f32 * h);
                cloth.particles.pin(p);
            } else {
                cloth.particles.positions[p] = Vec3::new(x, h, (2 * half - j) as f32 * h);
                cloth.particles.velocities[p] = Vec3::new(0.0, -speed, 0.0);
            }
        }
    }
    let settings = ClothSettings(SimSettings {
        gravity: Vec3::ZERO,
        ..default()
    });
    let e = if self_collision {
        let component = ClothSelfCollision::default();
        app.world_mut().spawn((cloth, settings, component)).id()
    } else {
        app.world_mut().spawn((cloth, settings)).id()
    };
    let upper = ((half + 1) * n) as usize..(n * n) as usize;
    let lowest_of = |x: &[Vec3]| upper.clone().map(|p| x[p].y).fold(f32::MAX, f32::min);
    let mut lowest = f32::MAX;
    for _ in 0..60 {
        app.update();
        lowest = lowest.min(lowest_of(&particles(&app, e).positions));
    }
    let x = &particles(&app, e).positions;
    assert!(x.iter().all(|p| p.is_finite()));
    let below = upper.clone().filter(|&p| x[p].y < 0.0).count();
    (lowest, lowest_of(x), below)
}

#[test]
fn a_fold_thrown_down_at_up_to_50_m_s_stays_on_top() {
    for speed in [5.0, 20.0, 50.0] {
        let (lowest, end, below) = thrown_fold(17, speed, true);
        eprintln!("17×17 fold thrown at {speed} m/s: lowest {lowest:.4} m, {end:.4} m after 1 s");
        // Never through the pinned layer at y = 0 (the step may bring it
        // within the 1 cm thickness for a moment).
        assert!(
            lowest > 0.005,
            "at {speed} m/s the upper layer reached {lowest} m"
        );
        assert_eq!(below, 0);
    }
    // Without self-collision it goes through.
    let (lowest, _, below) = thrown_fold(17, 50.0, false);
    eprintln!("without self-collision: lowest {lowest:.4} m, {below} particles below");
    assert!(lowest < -0.05 && below > 0, "{lowest} {below}");
}

#[test]
fn a_fine_fold_thrown_at_50_m_s_stays_on_top() {
    let (lowest, end, below) = thrown_fold(33, 50.0, true);
    eprintln!("33×33 fold thrown at 50 m/s: lowest {lowest:.4} m, {end:.4} m after 1 s");
    assert!(lowest > 0.005 && below == 0, "{lowest} {below}");
}

/// An `n × n`, 1 m cloth lying on a floor, its right edge grabbed and swung
/// over onto its left half along a half circle at `speed` m/s, then let go.
/// Returns the most particles of the flap under the lower half in any
/// frame of the 2 s after, the highest particle (m) and the largest strain
/// in the last second.
fn flick(n: u32, speed: f32) -> (usize, f32, f32) {
    let mut app = app();
    app.world_mut()
        .spawn((ClothCollider::plane(), Transform::default()));
    let cloth = ClothBuilder::new(n, n)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 0.01, 0.0))
        .build()
        .unwrap();
    let e = app
        .world_mut()
        .spawn((cloth, ClothSelfCollision::default()))
        .id();
    for _ in 0..30 {
        app.update();
    }
    let edge: Vec<u32> = (0..n).map(|r| r * n + n - 1).collect();
    grab_where_they_are(&mut app, e, &edge);
    let start = particles(&app, e).positions.clone();
    let (mut angle, turn) = (0.0f32, speed / 0.5 / 60.0);
    while angle < std::f32::consts::PI {
        angle = (angle + turn).min(std::f32::consts::PI);
        let mut grabs = app.world_mut().get_mut::<ClothGrabs>(e).unwrap();
        for &p in &edge {
            let z = start[p as usize].z;
            let at = Vec3::new(0.5 * angle.cos(), 0.03 + 0.5 * angle.sin(), z);
            grabs.set_target(p, at);
        }
        app.update();
    }
    app.update();
    app.world_mut()
        .get_mut::<ClothGrabs>(e)
        .unwrap()
        .release_all();
    // A flap particle is under the lower half when it lies below the
    // nearest particle of that half (in plan, within half a spacing).
    let under = |x: &[Vec3]| {
        let lower: Vec<Vec3> = (0..n * n)
            .filter(|p| p % n < n / 2)
            .map(|p| x[p as usize])
            .collect();
        (0..n * n)
            .filter(|p| p % n > n / 2)
            .filter(|&p| {
                let q = x[p as usize];
                let plan = |a: Vec3| Vec2::new(a.x - q.x, a.z - q.z).length();
                let nearest = lower.iter().min_by(|a, b| plan(**a).total_cmp(&plan(**b)));
                nearest.is_some_and(|a| plan(*a) < 0.5 / n as f32 && q.y < a.y)
            })
            .count()
    };
    let (mut worst, mut top, mut strain) = (0, 0.0f32, 0.0f32);
    for frame in 0..120 {
        app.update();
        let x = &particles(&app, e).positions;
        assert!(x.iter().all(|p| p.is_finite()));
        worst = worst.max(under(x));
        top = top.max(x.iter().map(|p| p.y).fold(0.0, f32::max));
        let now = app.world().get::<ClothStats>(e).unwrap().max_strain;
        if std::env::var("V").is_ok() {
            eprintln!("{frame} {now}");
        }
        if frame >= 60 {
            strain = strain.max(now);
        }
    }
    (worst, top, strain)
}

#[test]
fn a_cloth_flicked_over_onto_itself_at_up_to_50_m_s_lands_on_top_in_one_piece() {
    for (n, speed) in [(16, 20.0), (16, 50.0), (32, 50.0)] {
        let (under, top, strain) = flick(n, speed);
        eprintln!(
            "{n}×{n} flicked at {speed} m/s: {under} flap particles under the lower half, \
             highest {top:.3} m, strain {:.1} %",
            strain * 100.0
        );
        assert_eq!(under, 0, "{n}×{n} at {speed} m/s");
        assert!(top < 0.5, "{n}×{n} at {speed} m/s thrown to {top} m");
        assert!(strain < 0.1, "{n}×{n} at {speed} m/s stretched {strain}");
    }
}
