//! Property tests: any input to the builder and to creases gives `Ok` or a
//! [`ClothError`], never a panic; random sequences of grabs, pins, wind and
//! collider moves leave the cloth finite (with the guard on, as by default).

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::crease::{Crease, RestSurface};
use bevy_cloth::sim::grid::MAX_PARTICLES;
use common::{app, particles};
use proptest::prelude::*;

/// Any `f32`: normal, subnormal, zero, infinite, NaN, of either sign.
fn any_f32() -> impl Strategy<Value = f32> {
    proptest::num::f32::ANY
}

fn any_vec3() -> impl Strategy<Value = Vec3> {
    (any_f32(), any_f32(), any_f32()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Grid sides: small ones that build, and huge ones whose product passes
/// [`MAX_PARTICLES`] and must be refused before anything is allocated.
fn side() -> impl Strategy<Value = u32> {
    prop_oneof![0u32..=24, 1025u32..=u32::MAX, Just(u32::MAX)]
}

fn finite(p: &ClothParticles) -> bool {
    p.positions
        .iter()
        .chain(&p.velocities)
        .all(|x| x.is_finite())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn the_builder_returns_ok_or_an_error_for_any_input(
        cols in side(),
        rows in side(),
        (width, height, density) in (any_f32(), any_f32(), any_f32()),
        position in any_vec3(),
        (qx, qy, qz, qw) in (any_f32(), any_f32(), any_f32(), any_f32()),
        pin in any::<u32>(),
        total in any::<bool>(),
    ) {
        let builder = ClothBuilder::new(cols, rows)
            .size(width, height)
            .position(position)
            .rotation(Quat::from_xyzw(qx, qy, qz, qw))
            .pin(pin)
            .pin_corner(GridCorner::BottomRight);
        let builder = if total { builder.total_mass(density) } else { builder.mass_per_area(density) };
        match builder.build() {
            Ok(cloth) => {
                prop_assert!(finite(&cloth.particles));
                prop_assert!(cloth.particles.masses.iter().all(|m| m.is_finite() && *m > 0.0));
                prop_assert!(cloth.particles.len() as u64 <= MAX_PARTICLES as u64);
            }
            Err(error) => {
                // Every error explains itself.
                prop_assert!(!error.to_string().is_empty());
            }
        }
    }

    #[test]
    fn creases_with_any_input_are_refused_or_stay_finite(
        (fx, fy, tx, ty) in (any_f32(), any_f32(), any_f32(), any_f32()),
        value in any_f32(),
        by_angle in any::<bool>(),
    ) {
        let cloth = common::hanging(7);
        let crease = Crease::new(Vec2::new(fx, fy), Vec2::new(tx, ty));
        let crease = if by_angle { crease.with_angle(value) } else { crease.with_ratio(value) };
        let surface = RestSurface::grid(cloth.cloth.grid().unwrap());
        let valid = crease.validate(&surface, &cloth.connections).is_ok();
        let mut app = app();
        let e = app.world_mut().spawn((cloth, ClothCreases(vec![crease]))).id();
        for _ in 0..3 {
            app.update();
        }
        // Valid or not, nothing panicked and the cloth is finite; an invalid
        // crease changes nothing.
        prop_assert!(finite(particles(&app, e)));
        if !valid {
            let fresh = common::hanging(7);
            let conn = app.world().get::<ClothConnections>(e).unwrap();
            prop_assert_eq!(&conn.bend, &fresh.connections.bend);
        }
    }
}

/// One thing a game might do between fixed steps.
#[derive(Clone, Debug)]
enum Action {
    Grab(u32, Vec3, bool),
    Release(u32),
    Pin(u32),
    Unpin(u32),
    Wind(Vec3),
    MoveBall(Vec3),
    Steps(u8),
}

fn action() -> impl Strategy<Value = Action> {
    let point = (-3.0f32..3.0, -1.0f32..4.0, -3.0f32..3.0).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    let index = 0u32..90; // some beyond the 81 particles
    prop_oneof![
        (index.clone(), point.clone(), any::<bool>()).prop_map(|(i, p, k)| Action::Grab(i, p, k)),
        index.clone().prop_map(Action::Release),
        index.clone().prop_map(Action::Pin),
        index.prop_map(Action::Unpin),
        (-40.0f32..40.0, -40.0f32..40.0, -40.0f32..40.0)
            .prop_map(|(x, y, z)| Action::Wind(Vec3::new(x, y, z))),
        point.prop_map(Action::MoveBall),
        (1u8..6).prop_map(Action::Steps),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn random_grabs_pins_wind_and_collider_moves_stay_finite(
        actions in proptest::collection::vec(action(), 1..24),
        integrator in prop_oneof![
            Just(Integrator::SymplecticEuler),
            Just(Integrator::Rk4),
            Just(Integrator::BackwardEuler),
            Just(Integrator::Bdf2),
        ],
    ) {
        let mut app = app();
        let ball = app.world_mut().spawn((ClothCollider::sphere(0.2), Transform::from_xyz(0.5, 0.5, 0.3))).id();
        let substeps = if integrator.is_implicit() { 1 } else { 40 };
        let settings = ClothSettings::default().with_integrator(integrator, substeps);
        let e = app.world_mut().spawn((common::hanging(9), settings, ClothGrabs::default())).id();
        for a in actions {
            let world = app.world_mut();
            match a {
                Action::Grab(i, p, kinematic) => {
                    let mode = if kinematic { GrabMode::Kinematic } else { GrabMode::Spring { stiffness: 50.0, damping: 0.5 } };
                    world.get_mut::<ClothGrabs>(e).unwrap().grab(i, p, mode);
                }
                Action::Release(i) => world.get_mut::<ClothGrabs>(e).unwrap().release(i),
                Action::Pin(i) => { world.get_mut::<ClothParticles>(e).unwrap().pin(i as usize); }
                Action::Unpin(i) => { world.get_mut::<ClothParticles>(e).unwrap().unpin(i as usize); }
                Action::Wind(v) => { world.insert_resource(ClothWind(Wind { velocity: v, gust_amplitude: 0.3, ..default() })); }
                Action::MoveBall(p) => world.get_mut::<Transform>(ball).unwrap().translation = p,
                Action::Steps(n) => for _ in 0..n { app.update(); },
            }
            app.update();
            prop_assert!(finite(particles(&app, e)));
        }
    }
}
