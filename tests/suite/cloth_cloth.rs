//! Collision between separate cloths ([`ClothToClothCollision`]), with
//! every default: a sheet resting on a sheet, two sheets spawned on top of
//! each other, flags tangling in a storm, collision groups.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::ClothStats;
use bevy_cloth::plugin::collision::ClothCollisionStats;
use bevy_cloth::prelude::*;
use common::{app, closest, particles};

/// A horizontal `n × n` sheet of side `size` m centred at `at`.
fn flat(n: u32, size: f32, at: Vec3) -> ClothBundle {
    ClothBuilder::new(n, n)
        .size(size, size)
        .position(at)
        .build()
        .unwrap()
}

/// Spawns `cloth`, colliding with other cloths in `layer`.
fn spawn_in(app: &mut App, cloth: ClothBundle, layer: i32) -> Entity {
    let contact = ClothToClothCollision { layer, ..default() };
    app.world_mut().spawn((cloth, contact)).id()
}

/// The height of the lowest particle of `e`, m.
fn lowest(app: &App, e: Entity) -> f32 {
    particles(app, e)
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::MAX, f32::min)
}

/// The floor at y = 0.
fn floor(app: &mut App) {
    app.world_mut()
        .spawn((ClothCollider::plane(), Transform::default()));
}

/// The fastest particle of `e`, m/s.
fn fastest(app: &App, e: Entity) -> f32 {
    particles(app, e)
        .velocities
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max)
}

#[test]
fn a_sheet_dropped_on_a_sheet_rests_on_it_for_ten_seconds() {
    let mut app = app();
    floor(&mut app);
    let contact = ClothToClothCollision::default();
    let below = app
        .world_mut()
        .spawn((flat(16, 1.0, Vec3::new(0.0, 0.006, 0.0)), contact.clone()))
        .id();
    // Smaller, turned and off-centre, so its particles meet the lower
    // sheet's triangles everywhere, from 0.3 m up.
    let above = app
        .world_mut()
        .spawn((
            ClothBuilder::new(13, 13)
                .size(0.7, 0.7)
                .position(Vec3::new(0.05, 0.3, -0.03))
                .rotation(Quat::from_rotation_y(0.4))
                .build()
                .unwrap(),
            ClothToClothCollision {
                layer: 1,
                ..default()
            },
        ))
        .id();
    let (mut least, mut late) = (f32::MAX, 0.0f32);
    for step in 0..600 {
        app.update();
        if step % 3 == 0 {
            least = least.min(closest(&app, above, below));
        }
        if step >= 540 {
            late = late.max(fastest(&app, above));
        }
        // Above, never below.
        let lowest = particles(&app, above)
            .positions
            .iter()
            .map(|p| p.y)
            .fold(f32::MAX, f32::min);
        assert!(
            lowest > 0.0,
            "step {step}: the upper sheet is under the lower at {lowest} m"
        );
    }
    println!("a sheet on a sheet: closest {least} m, fastest in the last second {late} m/s");
    assert!(
        least >= contact.thickness / 2.0,
        "the sheets came {least} m close (thickness {} m)",
        contact.thickness
    );
    assert!(late < 0.02, "still moving at {late} m/s in the last second");
    let stats = app.world().resource::<ClothCollisionStats>();
    assert!(stats.cloth_contacts > 0, "{stats:?}");
    for e in [above, below] {
        let s = app.world().get::<ClothStats>(e).unwrap();
        assert!(s.finite && s.max_strain < 0.05, "{s:?}");
    }
}

#[test]
fn two_sheets_spawned_on_top_of_each_other_separate_without_an_explosion() {
    let mut app = app();
    floor(&mut app);
    let contact = ClothToClothCollision::default();
    let sheet = || flat(12, 0.8, Vec3::new(0.0, 0.2, 0.0));
    let a = app.world_mut().spawn((sheet(), contact.clone())).id();
    let b = app.world_mut().spawn((sheet(), contact.clone())).id();
    let mut top = 0.0f32;
    for _ in 0..180 {
        app.update();
        top = top.max(fastest(&app, a)).max(fastest(&app, b));
    }
    // They fell 0.2 m (2 m/s) and lie one on the other; no particle
    // reaches twice the speed of the fall.
    let apart = closest(&app, a, b);
    println!("spawned together: fastest {top} m/s, {apart} m apart");
    assert!(top < 4.0, "a particle reached {top} m/s");
    assert!(apart >= contact.thickness / 2.0, "{apart} m apart");
    for e in [a, b] {
        let s = app.world().get::<ClothStats>(e).unwrap();
        assert!(s.finite && s.max_strain < 0.05, "{s:?}");
    }
}

#[test]
fn two_flags_in_a_storm_tangle_without_passing_through() {
    let mut app = app();
    let contact = ClothToClothCollision::default();
    // A cotton flag and a smaller silk one on one pole, 6 cm apart, in
    // gusts blowing the lighter silk onto the cotton.
    let flag = |columns: u32, rows: u32, z: f32, material: ClothMaterial| {
        let size = Vec2::new((columns - 1) as f32, (rows - 1) as f32) * 0.05;
        ClothBuilder::new(columns, rows)
            .size(size.x, size.y)
            .material(material)
            .position(Vec3::new(size.x / 2.0, 2.0 - size.y / 2.0, z))
            .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
            .pin_edge(GridEdge::Left)
            .build()
            .unwrap()
    };
    let a = app
        .world_mut()
        .spawn((flag(17, 11, 0.0, ClothMaterial::COTTON), contact.clone()))
        .id();
    let b = app
        .world_mut()
        .spawn((
            flag(13, 9, 0.06, ClothMaterial::SILK),
            ClothToClothCollision {
                layer: 1,
                ..default()
            },
        ))
        .id();
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(15.0, 0.0, -4.0),
        gust_amplitude: 0.5,
        gust_frequency: 1.3,
        ..default()
    }));
    let mut least = f32::MAX;
    for step in 0..300 {
        app.update();
        if step % 2 == 0 {
            least = least.min(closest(&app, a, b));
        }
    }
    let stats = app.world().resource::<ClothCollisionStats>();
    println!(
        "flags: closest {least} m, {} contacts",
        stats.cloth_contacts
    );
    assert!(
        least >= contact.thickness / 2.0,
        "the flags came {least} m close (thickness {} m)",
        contact.thickness
    );
    let stats = app.world().resource::<ClothCollisionStats>();
    assert!(stats.cloth_contacts > 0, "they never met: {stats:?}");
    for e in [a, b] {
        let s = app.world().get::<ClothStats>(e).unwrap();
        assert!(s.finite, "{s:?}");
    }
}

#[test]
fn cloths_whose_groups_do_not_meet_and_cloths_without_it_pass_through() {
    for groups in [Some((1, 1)), None] {
        let mut app = app();
        floor(&mut app);
        let mut spawn = |at: f32, layers: u32| {
            let mut e = app
                .world_mut()
                .spawn(flat(10, 0.6, Vec3::new(0.0, at, 0.0)));
            if let Some((m, f)) = groups {
                e.insert(ClothToClothCollision {
                    groups: ClothContactLayers::new(m * layers, f * layers),
                    ..default()
                });
            }
            e.id()
        };
        let below = spawn(0.006, 1);
        let above = spawn(0.2, 2);
        for _ in 0..120 {
            app.update();
        }
        // Both lie on the floor, one in the other.
        let apart = closest(&app, above, below);
        assert!(apart < 0.003, "{groups:?}: {apart} m apart");
        let stats = app.world().resource::<ClothCollisionStats>();
        assert_eq!(
            (stats.cloth_passes, stats.cloth_contacts),
            (0, 0),
            "{groups:?}"
        );
    }
}

#[test]
fn a_bad_thickness_or_friction_turns_the_pass_off_without_a_panic() {
    for (thickness, friction) in [(0.0, 0.4), (-1.0, 0.4), (f32::NAN, 0.4), (0.01, -1.0)] {
        let bad = ClothToClothCollision {
            thickness,
            friction,
            ..default()
        };
        assert!(matches!(
            bad.validate(),
            Err(ClothError::InvalidClothContact { .. })
        ));
        let mut app = app();
        floor(&mut app);
        let a = app
            .world_mut()
            .spawn((flat(8, 0.5, Vec3::new(0.0, 0.006, 0.0)), bad.clone()))
            .id();
        let b = app
            .world_mut()
            .spawn((flat(8, 0.5, Vec3::new(0.0, 0.1, 0.0)), bad))
            .id();
        for _ in 0..60 {
            app.update();
        }
        for e in [a, b] {
            assert!(app.world().get::<ClothStats>(e).unwrap().finite);
        }
        assert_eq!(
            app.world().resource::<ClothCollisionStats>().cloth_passes,
            0
        );
    }
}

#[test]
fn a_sheet_dropped_on_a_sleeping_sheet_rests_on_it_and_leaves_it_asleep() {
    let mut app = app();
    floor(&mut app);
    let contact = ClothToClothCollision::default();
    let below = app
        .world_mut()
        .spawn((flat(12, 0.8, Vec3::new(0.0, 0.006, 0.0)), contact.clone()))
        .id();
    // Until the lower sheet sleeps.
    let mut slept = false;
    for _ in 0..600 {
        app.update();
        if app.world().get::<ClothSleep>(below).unwrap().is_asleep() {
            slept = true;
            break;
        }
    }
    assert!(slept, "the lower sheet never fell asleep");
    let above = spawn_in(&mut app, flat(10, 0.6, Vec3::new(0.0, 0.4, 0.0)), 1);
    for _ in 0..240 {
        app.update();
        // The lower layer does not feel the upper one: it sleeps on.
        assert!(app.world().get::<ClothSleep>(below).unwrap().is_asleep());
    }
    let apart = closest(&app, above, below);
    println!("on a sleeping sheet: {apart} m apart");
    assert!(apart >= 0.35 * contact.thickness, "{apart} m apart");
    let lowest = lowest(&app, above);
    assert!(
        lowest > 0.006,
        "the upper sheet is under the lower at {lowest} m"
    );
}

#[test]
fn tiny_huge_and_broken_cloths_churning_among_colliding_ones_never_panic() {
    let mut app = app();
    floor(&mut app);
    let contact = ClothToClothCollision::default();
    let keep = app
        .world_mut()
        .spawn((flat(12, 0.8, Vec3::new(0.0, 0.006, 0.0)), contact.clone()))
        .id();
    // A cloth with a NaN particle, one thrown far away at 50 m/s, and a
    // 3×3 one, all over the kept sheet.
    let mut broken = flat(6, 0.3, Vec3::new(0.0, 0.1, 0.0));
    broken.particles.positions[7] = Vec3::NAN;
    app.world_mut().spawn((broken, contact.clone()));
    let mut thrown = flat(6, 0.3, Vec3::new(0.0, 0.2, 0.0));
    thrown.particles.velocities.fill(Vec3::new(50.0, 5.0, 0.0));
    app.world_mut().spawn((thrown, contact.clone()));
    app.world_mut()
        .spawn((flat(3, 0.1, Vec3::new(0.1, 0.05, 0.0)), contact.clone()));
    let mut churn = Vec::new();
    for step in 0..120u32 {
        // Spawned and despawned every few steps, some right on the sheet.
        if step % 3 == 0 {
            let y = 0.006 + 0.02 * (step % 4) as f32;
            churn.push(
                app.world_mut()
                    .spawn((flat(5, 0.2, Vec3::new(0.0, y, 0.0)), contact.clone()))
                    .id(),
            );
        }
        if step % 5 == 0 && !churn.is_empty() {
            let e = churn.remove(0);
            app.world_mut().despawn(e);
        }
        app.update();
    }
    // Struck by cloths spawned into it every few steps, it stays whole.
    let s = app.world().get::<ClothStats>(keep).unwrap();
    println!("churn: the kept sheet's strain {}", s.max_strain);
    assert!(s.finite && s.max_strain < 0.25, "{s:?}");
}

#[test]
fn a_sheet_dropped_over_a_ball_onto_a_draped_sheet_stays_outside_it() {
    let mut app = app();
    floor(&mut app);
    app.world_mut().spawn((
        ClothCollider::sphere(0.3),
        Transform::from_xyz(0.0, 0.3, 0.0),
    ));
    let contact = ClothToClothCollision::default();
    // Both free: the lower one drapes over the ball, the upper one falls
    // onto it a moment later, turned, and drapes over both.
    let below = app
        .world_mut()
        .spawn((flat(20, 1.2, Vec3::new(0.0, 0.7, 0.0)), contact.clone()))
        .id();
    let above = app
        .world_mut()
        .spawn((
            ClothBuilder::new(20, 20)
                .size(1.2, 1.2)
                .position(Vec3::new(0.03, 1.0, 0.02))
                .rotation(Quat::from_rotation_y(0.5))
                .build()
                .unwrap(),
            ClothToClothCollision {
                layer: 1,
                ..default()
            },
        ))
        .id();
    // The closest the surfaces come while the upper sheet lands (its first
    // second) and after.
    let (mut landing, mut least, mut strain) = (f32::MAX, f32::MAX, 0.0f32);
    for step in 0..300 {
        app.update();
        if step % 3 == 0 {
            let apart = closest(&app, above, below);
            if step < 60 {
                landing = landing.min(apart);
            } else {
                least = least.min(apart);
            }
        }
        if step >= 60 {
            for e in [above, below] {
                let s = app.world().get::<ClothStats>(e).unwrap();
                assert!(s.finite, "step {step}: {s:?}");
                strain = strain.max(s.max_strain);
            }
        }
    }
    // The upper sheet's top, over the ball, is above the lower one's.
    let top = |e: Entity| {
        particles(&app, e)
            .positions
            .iter()
            .map(|p| p.y)
            .fold(f32::MIN, f32::max)
    };
    println!(
        "over a ball: closest {landing} m landing, {least} m after, strain after 1 s {strain}, tops {} m and {} m",
        top(above),
        top(below)
    );
    assert!(top(above) > top(below), "the upper sheet went under");
    assert!(
        landing >= 0.1 * contact.thickness,
        "the sheets came {landing} m close landing (thickness {} m)",
        contact.thickness
    );
    assert!(
        least >= contact.thickness / 2.0,
        "the sheets came {least} m close (thickness {} m)",
        contact.thickness
    );
    assert!(strain < 0.05, "strain {strain}");
}

#[test]
fn a_mesh_disc_dropped_on_a_grid_sheet_rests_on_it_and_a_sheet_rests_on_the_disc() {
    let mut app = common::app_with_meshes();
    floor(&mut app);
    let sheet = spawn_in(&mut app, flat(16, 1.0, Vec3::new(0.0, 0.006, 0.0)), 0);
    // An irregular mesh disc (r 0.35 m) in layer 1, and a small grid sheet
    // over it in layer 2.
    let disc = ClothBuilder::from_mesh(&common::disc_mesh(8, 0.35, 0.4))
        .position(Vec3::new(0.02, 0.25, 0.0))
        .build()
        .unwrap();
    let disc = app
        .world_mut()
        .spawn((
            disc,
            ClothToClothCollision {
                layer: 1,
                ..default()
            },
        ))
        .id();
    let top = spawn_in(&mut app, flat(9, 0.4, Vec3::new(0.0, 0.45, 0.0)), 2);
    let mut least = [f32::MAX; 2];
    for step in 0..240 {
        app.update();
        if step >= 60 && step % 4 == 0 {
            least[0] = least[0].min(closest(&app, disc, sheet));
            least[1] = least[1].min(closest(&app, top, disc));
        }
    }
    println!("a disc on a sheet, a sheet on the disc: closest {least:?} m");
    for apart in least {
        assert!(apart >= 0.005, "{apart} m apart");
    }
    for e in [sheet, disc, top] {
        let s = app.world().get::<ClothStats>(e).unwrap();
        assert!(s.finite && s.max_strain < 0.05, "{s:?}");
    }
}

#[test]
fn with_an_explicit_integrator_a_sheet_still_rests_on_a_sheet() {
    let mut app = app();
    app.insert_resource(ClothSettingsDefaults(
        SimSettings::default().with_integrator(Integrator::SymplecticEuler, 40),
    ));
    floor(&mut app);
    let below = spawn_in(&mut app, flat(12, 0.8, Vec3::new(0.0, 0.006, 0.0)), 0);
    let above = spawn_in(&mut app, flat(10, 0.6, Vec3::new(0.03, 0.2, 0.0)), 1);
    let mut least = f32::MAX;
    for step in 0..180 {
        app.update();
        if step >= 60 && step % 3 == 0 {
            least = least.min(closest(&app, above, below));
        }
    }
    println!("explicit: closest {least} m");
    assert!(least >= 0.005, "{least} m apart");
    let lowest = lowest(&app, above);
    assert!(lowest > 0.006, "the upper sheet went under, to {lowest} m");
}

#[test]
fn a_sheet_flicked_at_50_m_s_and_a_ball_swept_through_a_stack_leave_it_whole() {
    let mut app = app();
    floor(&mut app);
    let below = spawn_in(&mut app, flat(16, 1.0, Vec3::new(0.0, 0.006, 0.0)), 0);
    let above = spawn_in(&mut app, flat(12, 0.7, Vec3::new(0.0, 0.05, 0.0)), 1);
    for _ in 0..60 {
        app.update();
    }
    // A flick: the upper sheet's particles at 50 m/s down and along.
    {
        let mut p = app.world_mut().get_mut::<ClothParticles>(above).unwrap();
        p.velocities.fill(Vec3::new(30.0, -40.0, 0.0));
    }
    // A ball rolled through the stack, low, at 10 m/s.
    let ball = app
        .world_mut()
        .spawn((
            ClothCollider::sphere(0.1),
            Transform::from_xyz(-1.0, 0.08, 0.0),
        ))
        .id();
    for step in 0..180 {
        if let Some(mut t) = app.world_mut().get_mut::<Transform>(ball) {
            t.translation.x = -1.0 + 10.0 * step as f32 / 60.0;
        }
        app.update();
        for e in [above, below] {
            let s = app.world().get::<ClothStats>(e).unwrap();
            assert!(s.finite, "step {step}: {s:?}");
        }
    }
    for _ in 0..120 {
        app.update();
    }
    let lowest = lowest(&app, above);
    let strain = [above, below].map(|e| app.world().get::<ClothStats>(e).unwrap().max_strain);
    println!("flicked and swept: lowest {lowest} m, strain {strain:?}");
    assert!(lowest >= 0.0, "{lowest}");
    assert!(strain.iter().all(|&s| s < 0.05), "{strain:?}");
}
