//! Cloth on a moving frame: a cape on a body that teleports or spins at
//! 20 rad/s, with `TeleportCloth`, `ClothInertia` and `ClothTethers`.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::connections::max_strain;
use common::{app, particles};

/// A 0.5 m × 0.8 m cotton cape hanging from a collar 0.15 m behind the
/// axis of a body at the origin, its top edge anchored to the body.
fn wear(app: &mut App, extras: impl Bundle) -> (Entity, Entity) {
    let body = app.world_mut().spawn(Transform::default()).id();
    let cape = ClothBuilder::new(10, 16)
        .size(0.5, 0.8)
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .position(Vec3::new(0.0, 1.1, -0.15))
        .build()
        .unwrap();
    let mut anchors = ClothAnchors::default();
    for i in 0..10 {
        anchors = anchors.with(i, body);
    }
    let cape = app.world_mut().spawn((cape, anchors, extras)).id();
    (body, cape)
}

fn strain(app: &App, e: Entity) -> f32 {
    let links = app.world().get::<ClothConnections>(e).unwrap();
    max_strain(links.type1(), &particles(app, e).positions)
}

/// Worst strain of a cape over the 1 s after its body teleports 10 m and
/// turns a quarter, with or without the cape teleported along.
fn teleported(along: bool) -> f32 {
    let mut app = app();
    let (body, cape) = wear(&mut app, ());
    for _ in 0..60 {
        app.update();
    }
    let old = Isometry3d::IDENTITY;
    let new = Isometry3d::new(Vec3::new(10.0, 0.0, 0.0), Quat::from_rotation_y(1.57));
    let by = new * old.inverse();
    *app.world_mut().get_mut::<Transform>(body).unwrap() =
        Transform::from_translation(Vec3::from(new.translation)).with_rotation(new.rotation);
    if along {
        app.world_mut()
            .commands()
            .entity(cape)
            .queue(TeleportCloth(by));
    }
    let mut worst = 0.0f32;
    for _ in 0..60 {
        app.update();
        assert!(particles(&app, cape).is_finite());
        worst = worst.max(strain(&app, cape));
    }
    worst
}

#[test]
fn a_teleported_cape_arrives_unstretched() {
    let along = teleported(true);
    let left = teleported(false);
    eprintln!(
        "body teleported 10 m and turned 90°: cape strain ≤ {:.2} % teleported along, {:.0} % left behind",
        100.0 * along,
        100.0 * left
    );
    assert!(along < 0.02, "{along}");
    assert!(left > 0.5, "{left}");
}

/// Worst strain of a cape while its body spins up to 20 rad/s in 0.25 s
/// and spins on for 2 s; `inertia` gives the cape a frame (the body) with
/// these linear and angular scales.
fn spun(inertia: Option<(f32, f32)>, tethers: bool, integrator: Integrator) -> f32 {
    let mut app = app();
    let settings = ClothSettings::default().with_integrator(integrator, 1);
    let (body, cape) = wear(&mut app, settings);
    if let Some((linear, angular)) = inertia {
        app.world_mut()
            .entity_mut(cape)
            .insert(ClothInertia::new(body, linear, angular));
    }
    if tethers {
        app.world_mut()
            .entity_mut(cape)
            .insert(ClothTethers::default());
    }
    for _ in 0..30 {
        app.update();
    }
    let mut angle = 0.0f32;
    let mut worst = 0.0f32;
    for k in 0..135 {
        let rate = 20.0 * (k as f32 / 15.0).min(1.0);
        angle += rate / 60.0;
        app.world_mut().get_mut::<Transform>(body).unwrap().rotation = Quat::from_rotation_y(angle);
        app.update();
        assert!(particles(&app, cape).is_finite());
        worst = worst.max(strain(&app, cape));
    }
    worst
}

#[test]
fn a_cape_on_a_body_spinning_at_20_rad_s_stays_within_10_percent() {
    for integrator in [Integrator::BackwardEuler, Integrator::Bdf2] {
        let world = spun(None, false, integrator);
        let tethered = spun(None, true, integrator);
        let felt = spun(Some((0.3, 0.2)), true, integrator);
        let welded = spun(Some((0.0, 0.0)), false, integrator);
        eprintln!(
            "{integrator:?}, 20 rad/s: strain {:.1} % in the world, {:.1} % with tethers, {:.1} % feeling 0.3/0.2 of the frame, {:.2} % feeling none",
            100.0 * world,
            100.0 * tethered,
            100.0 * felt,
            100.0 * welded
        );
        // Simulated in the world, the spin stretches the cape: its Newton
        // corrections and quiet substeps hold it to a few per cent, and
        // feeling the frame takes most of that away.
        assert!(
            world > 0.03 && world > 2.5 * felt,
            "{integrator:?}: the spin should stretch it: {world} against {felt} feeling the frame"
        );
        assert!(felt < 0.1, "{integrator:?}: {felt}");
        assert!(welded < 0.005, "{integrator:?}: {welded}");
    }
}

/// The deepest (m) any cape particle gets inside a 0.2 m body capsule
/// (axis vertical, 1.2 m long) over 1 s of the body backing into its cape at
/// `speed` m/s, with or without the capsule as a collider.
fn backed_into(speed: f32, collider: bool) -> f32 {
    let mut app = app();
    let body = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 1.0, 0.0))
        .id();
    // The collar 0.25 m behind the axis, just outside the capsule.
    let cape = ClothBuilder::new(10, 16)
        .size(0.5, 0.8)
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .position(Vec3::new(0.0, 1.1, -0.25))
        .build()
        .unwrap();
    let mut anchors = ClothAnchors::default();
    for i in 0..10 {
        anchors = anchors.with(i, body);
    }
    let cape = app.world_mut().spawn((cape, anchors)).id();
    if collider {
        app.world_mut()
            .entity_mut(body)
            .insert(ClothCollider::capsule(0.2, 0.4));
    }
    for _ in 0..30 {
        app.update();
    }
    let mut deepest = 0.0f32;
    for k in 0..60 {
        let z = -speed * (k + 1) as f32 / 60.0;
        app.world_mut()
            .get_mut::<Transform>(body)
            .unwrap()
            .translation = Vec3::new(0.0, 1.0, z);
        app.update();
        let p = particles(&app, cape);
        assert!(p.is_finite());
        for x in &p.positions {
            // Distance from the capsule's axis segment (y from 0.6 to 1.4).
            let axis = Vec3::new(0.0, x.y.clamp(0.6, 1.4), z);
            deepest = deepest.max(0.2 - x.distance(axis));
        }
    }
    deepest
}

#[test]
fn a_body_capsule_keeps_the_cape_outside_at_10_m_s() {
    let kept = backed_into(10.0, true);
    let through = backed_into(10.0, false);
    eprintln!(
        "body backing into its cape at 10 m/s: deepest {:.1} mm inside the capsule with it as a collider, {:.0} mm without",
        1000.0 * kept,
        1000.0 * through
    );
    assert!(kept < 0.01, "{kept} m inside");
    assert!(through > 0.05, "{through}");
}
