//! What strain each material reaches in wind, with the defaults:
//! `cargo test --release --test wind -- --nocapture` prints the table the
//! README gives.
//!
//! A 1 m × 0.6 m flag (21 × 13 particles) pinned along its hoist, in gusty
//! wind (gusts ±50 % at 1.3 Hz) blowing at 17° to its plane, for 10 s. The
//! strain is the largest Type 1 strain, its peak over the run and its
//! median over the last 5 s.

mod common;

use bevy::ecs::message::Messages;
use bevy::prelude::*;
use bevy_cloth::plugin::events::ClothDiverged;
use bevy_cloth::prelude::*;
use common::app;

/// Peak and late median strain, and the guard's trips, of a flag of
/// `material` in wind of mean speed `speed` m/s.
fn flag(material: ClothMaterial, speed: f32) -> (f32, f32, usize) {
    let mut app = app();
    let cloth = ClothBuilder::new(21, 13)
        .size(1.0, 0.6)
        .material(material)
        .position(Vec3::new(0.5, 2.0, 0.0))
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .pin_edge(GridEdge::Left)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(speed, 0.0, 0.3 * speed),
        gust_amplitude: 0.5,
        gust_frequency: 1.3,
        ..default()
    }));
    let (mut peak, mut late, mut trips) = (0.0f32, Vec::new(), 0);
    for k in 0..600 {
        app.update();
        trips += app
            .world()
            .resource::<Messages<ClothDiverged>>()
            .iter_current_update_messages()
            .count();
        let s = app.world().get::<ClothStats>(e).unwrap();
        assert!(s.finite, "non-finite at {speed} m/s");
        peak = peak.max(s.max_strain);
        if k >= 300 {
            late.push(s.max_strain);
        }
    }
    late.sort_by(f32::total_cmp);
    (peak, late[late.len() / 2], trips)
}

#[test]
fn every_material_stays_within_the_guard_bound_up_to_30_m_s() {
    let speeds = [5.0, 10.0, 15.0, 20.0, 30.0];
    println!("peak (median over the last 5 s) Type 1 strain of a flag in gusty wind:");
    println!(
        "| material | {} |",
        speeds.map(|s| format!("{s} m/s")).join(" | ")
    );
    println!("|---|{}", "---|".repeat(speeds.len()));
    for (name, fabric) in Fabric::PRESETS {
        let mut row = format!("| {name} |");
        for speed in speeds {
            let (peak, median, trips) = flag(ClothMaterial::Fabric(fabric), speed);
            row += &format!(" {:.1} % ({:.1} %) |", 100.0 * peak, 100.0 * median);
            assert!(peak < 3.0, "{name} at {speed} m/s: {peak}");
            assert_eq!(trips, 0, "{name} at {speed} m/s tripped the guard");
        }
        println!("{row}");
    }
}
