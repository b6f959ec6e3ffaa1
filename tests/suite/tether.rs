//! Tethers on a banner swung fast from its pole: the stretch along the
//! chain to the pins with and without them.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::tether::Tethers;
use common::{app, particles};

/// A 0.6 m × 1.2 m silk banner hanging from a pole along its top edge,
/// the pole swung sideways 0.5 m either way at `hz` for 3 s; returns the
/// worst stretch of any particle's distance to its pin over its rest
/// distance along the links (dimensionless, 0 = none).
fn swing(tethers: Option<ClothTethers>, hz: f32) -> f32 {
    let mut app = app();
    let banner = ClothBuilder::new(12, 24)
        .size(0.6, 1.2)
        .material(ClothMaterial::SILK)
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .position(Vec3::new(0.0, 1.4, 0.0))
        .build()
        .unwrap();
    let pole = app.world_mut().spawn(Transform::default()).id();
    let mut anchors = ClothAnchors::default();
    for i in 0..12 {
        anchors = anchors.with(i, pole);
    }
    let mut e = app.world_mut().spawn((banner, anchors));
    if let Some(t) = tethers {
        e.insert(t);
    }
    let e = e.id();
    app.update();
    // The reference: the chain lengths to the top edge, as pinned.
    let mut reference = Tethers::default();
    {
        let p = particles(&app, e);
        let links = app.world().get::<ClothConnections>(e).unwrap();
        reference.update(links, &p.inverse_masses);
    }
    let mut worst = 0.0f32;
    for k in 0..180 {
        let t = k as f32 / 60.0;
        let x = 0.5 * (std::f32::consts::TAU * hz * t).sin();
        app.world_mut()
            .get_mut::<Transform>(pole)
            .unwrap()
            .translation
            .x = x;
        app.update();
        let p = particles(&app, e);
        assert!(p.is_finite());
        for i in 0..p.len() {
            if let Some((a, rest)) = reference.anchor_of(i)
                && rest > 0.0
            {
                let d = p.positions[i].distance(p.positions[a as usize]);
                worst = worst.max(d / rest - 1.0);
            }
        }
    }
    worst
}

#[test]
fn tethers_bound_the_stretch_of_a_fast_swung_banner() {
    for (hz, slack) in [
        (2.5, ClothTethers::default().slack),
        (1.0, 1.01),
        (2.5, 1.01),
    ] {
        let with = swing(Some(ClothTethers { slack }), hz);
        let without = swing(None, hz);
        eprintln!(
            "banner swung ±0.5 m at {hz} Hz: stretch to the pins {:.2} % with tethers (slack {slack}), {:.2} % without",
            100.0 * with,
            100.0 * without
        );
        assert!(with <= slack - 1.0 + 1e-4, "{hz} Hz, slack {slack}: {with}");
        assert!(
            without > slack - 1.0 + 0.005,
            "{hz} Hz: only {without} without tethers"
        );
    }
}

#[test]
fn grabbing_and_releasing_every_step_remakes_the_tethers_and_nothing_breaks() {
    let mut app = app();
    let cloth = ClothBuilder::new(16, 16)
        .pin_corner(GridCorner::TopLeft)
        .position(Vec3::Y)
        .build()
        .unwrap();
    let e = app.world_mut().spawn((cloth, ClothTethers::default())).id();
    for k in 0..300u32 {
        let mut grabs = app.world_mut().get_mut::<ClothGrabs>(e).unwrap();
        let p = 1 + (k * 37) % 255;
        if k % 2 == 0 {
            grabs.grab(p, Vec3::new(0.3, 1.5, 0.2), GrabMode::Kinematic);
        } else {
            grabs.release_all();
        }
        app.update();
        assert!(particles(&app, e).is_finite(), "step {k}");
    }
}
