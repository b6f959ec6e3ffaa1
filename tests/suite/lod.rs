//! Level of detail: a cloth no camera sees, or a far one, steps less
//! often, a very far one freezes, and each comes back without a jump; a
//! worn cloth stays on its skeleton at every level.

use crate::common;

use bevy::camera::{Camera, CameraProjection, PerspectiveProjection};
use bevy::prelude::*;
use bevy_cloth::plugin::worn::ClothSkinTargets;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::connections::max_strain;
use common::{app, particles, sheet, wear};

const DT: f32 = 1.0 / 60.0;

/// Points camera `e` from `from` at `at`, its frustum updated at once.
fn look(app: &mut App, e: Entity, from: Vec3, at: Vec3) {
    let transform = Transform::from_translation(from).looking_at(at, Vec3::Y);
    let global = GlobalTransform::from(transform);
    let frustum = PerspectiveProjection::default().compute_frustum(&global);
    app.world_mut()
        .entity_mut(e)
        .insert((transform, global, frustum));
}

/// A camera at `from` looking at `at`.
fn camera(app: &mut App, from: Vec3, at: Vec3) -> Entity {
    let e = app.world_mut().spawn(Camera::default()).id();
    look(app, e, from, at);
    e
}

fn steps(app: &App, e: Entity) -> u64 {
    app.world().get::<ClothStats>(e).unwrap().steps
}

fn detail(app: &App, e: Entity) -> Detail {
    app.world().get::<ClothDetail>(e).unwrap().detail()
}

/// Runs until `cloth` is at `level` (a cloth earns its combined steps by
/// staying calm), at most 300 fixed steps.
fn until(app: &mut App, cloth: Entity, level: Detail) {
    for _ in 0..300 {
        app.update();
        if detail(app, cloth) == level {
            return;
        }
    }
    panic!("{cloth} never reached {level:?}: {:?}", detail(app, cloth));
}

/// Runs until `cloth` has waited `k` fixed steps since its last step, at
/// most 300 fixed steps.
fn until_waited(app: &mut App, cloth: Entity, k: u32) {
    for _ in 0..300 {
        if app
            .world()
            .get::<ClothDetail>(cloth)
            .unwrap()
            .waited_steps()
            == k
        {
            return;
        }
        app.update();
    }
    panic!("{cloth} never waited {k} fixed steps");
}

/// The largest distance a particle moved between `a` and `b`, m.
fn jump(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max)
}

/// The fastest particle, m/s.
fn speed(p: &ClothParticles) -> f32 {
    p.velocities.iter().map(|v| v.length()).fold(0.0, f32::max)
}

/// The hanging sheet's centre, where the cameras look.
const SHEET: Vec3 = Vec3::new(0.5, 2.0, 0.5);

/// A falling, swinging sheet with LOD, and the same sheet with LOD off.
fn two_sheets(app: &mut App) -> (Entity, Entity) {
    let lod = app.world_mut().spawn(sheet(9)).id();
    let off = LodSettings {
        enabled: false,
        ..default()
    };
    let reference = app.world_mut().spawn((sheet(9), ClothLod(off))).id();
    (lod, reference)
}

#[test]
fn off_screen_a_cloth_steps_every_16th_step_and_catches_up_in_view_without_a_jump() {
    let mut app = app();
    let (cloth, reference) = two_sheets(&mut app);
    // 5 m away, looking away from it.
    let eye = camera(&mut app, SHEET + Vec3::Z * 5.0, SHEET + Vec3::Z * 10.0);
    until(&mut app, cloth, Detail::Every(16));
    assert_eq!(detail(&app, reference), Detail::Full);
    let (before, full) = (steps(&app, cloth), steps(&app, reference));
    let mut taken = Vec::new();
    for _ in 0..80 {
        app.update();
        taken.push(app.world().get::<ClothDetail>(cloth).unwrap().steps_now());
    }
    assert_eq!(steps(&app, reference) - full, 80);
    assert_eq!(steps(&app, cloth) - before, 5, "every 16th fixed step");
    let combined: Vec<u32> = taken.into_iter().filter(|&k| k > 0).collect();
    assert!(combined[1..].iter().all(|&k| k == 16), "{combined:?}");
    // Some more fixed steps off-screen, then the player turns to it: it
    // takes the time it owes in one step, which moves it no farther than
    // the reference cloth moves in that time.
    let mut history = vec![particles(&app, reference).positions.clone()];
    while app.world().get::<ClothDetail>(cloth).unwrap().steps_now() != 0 || history.len() < 20 {
        app.update();
        history.push(particles(&app, reference).positions.clone());
    }
    let owed = 1 + app
        .world()
        .get::<ClothDetail>(cloth)
        .unwrap()
        .waited_steps();
    let start = particles(&app, cloth).positions.clone();
    look(&mut app, eye, SHEET + Vec3::Z * 5.0, SHEET);
    app.update();
    history.push(particles(&app, reference).positions.clone());
    assert_eq!(detail(&app, cloth), Detail::Full);
    assert_eq!(
        app.world().get::<ClothDetail>(cloth).unwrap().steps_now(),
        owed
    );
    let end = particles(&app, cloth);
    let moved = jump(&start, &end.positions);
    let span = history.len() - 1 - owed as usize;
    let reference_moved = jump(&history[span], history.last().unwrap());
    eprintln!("catch-up of {owed} steps: jump {moved:.4} m, reference {reference_moved:.4} m");
    assert!(
        moved <= 1.5 * reference_moved + 0.005,
        "{moved} vs {reference_moved}"
    );
    assert!(moved <= speed(end) * owed as f32 * DT * 1.01 + 1e-4);
    // From then on, every fixed step.
    let count = steps(&app, cloth);
    for _ in 0..10 {
        app.update();
    }
    assert_eq!(steps(&app, cloth) - count, 10);
}

#[test]
fn in_view_a_distant_cloth_steps_less_often_as_the_distance_doubles() {
    let mut app = app();
    let cloth = app.world_mut().spawn(sheet(9)).id();
    let eye = camera(&mut app, SHEET + Vec3::Z * 30.0, SHEET);
    for (distance, every) in [(30.0, 2), (50.0, 4), (10.0, 1)] {
        look(&mut app, eye, SHEET + Vec3::Z * distance, SHEET);
        let level = match every {
            1 => Detail::Full,
            k => Detail::Every(k),
        };
        until(&mut app, cloth, level);
        let before = steps(&app, cloth);
        for _ in 0..40 {
            app.update();
        }
        assert_eq!(
            steps(&app, cloth) - before,
            40 / u64::from(every),
            "at {distance} m"
        );
        let d = app.world().get::<ClothDetail>(cloth).unwrap().distance();
        assert!(d.is_some_and(|d| (d - distance).abs() < 1.0), "{d:?}");
    }
}

#[test]
fn beyond_the_freezing_distance_a_cloth_stands_still_and_resumes_where_it_froze() {
    let mut app = app();
    let cloth = app.world_mut().spawn(sheet(9)).id();
    let eye = camera(&mut app, SHEET + Vec3::Z * 5.0, SHEET);
    for _ in 0..20 {
        app.update();
    }
    look(&mut app, eye, SHEET + Vec3::Z * 150.0, SHEET);
    app.update();
    assert_eq!(detail(&app, cloth), Detail::Frozen);
    let frozen = particles(&app, cloth).clone();
    let count = steps(&app, cloth);
    for _ in 0..60 {
        // A force written to a frozen cloth is dropped, not saved up.
        let mut forces = app.world_mut().get_mut::<ClothForces>(cloth).unwrap();
        forces.0.fill(Vec3::new(0.0, 0.0, 5.0));
        app.update();
        let forces = app.world().get::<ClothForces>(cloth).unwrap();
        assert!(forces.0.iter().all(|f| *f == Vec3::ZERO));
    }
    assert_eq!(particles(&app, cloth).positions, frozen.positions);
    assert_eq!(particles(&app, cloth).velocities, frozen.velocities);
    assert_eq!(steps(&app, cloth), count);
    // Back near: it continues from its frozen state, one fixed step at a
    // time.
    look(&mut app, eye, SHEET + Vec3::Z * 5.0, SHEET);
    app.update();
    assert_eq!(steps(&app, cloth), count + 1);
    let after = particles(&app, cloth);
    let moved = jump(&frozen.positions, &after.positions);
    assert!(moved <= speed(after) * DT * 1.01 + 1e-5, "{moved}");
}

#[test]
fn forces_written_between_the_steps_of_a_reduced_cloth_act_on_its_next_step() {
    // Without gravity, damping or pins, a cloth's momentum is what the forces gave
    // it: one impulse written on a skipped fixed step, and a steady force.
    let mut app = app();
    let settings = SimSettings {
        gravity: Vec3::ZERO,
        ..default()
    };
    let cloths = [true, false].map(|enabled| {
        let free = ClothBuilder::new(5, 5)
            .position(Vec3::new(0.0, 2.0, 0.0))
            .build()
            .unwrap();
        let lod = LodSettings {
            enabled,
            ..default()
        };
        let calm = ClothMaterial::Fabric(Fabric {
            damping: 0.0,
            ..Fabric::COTTON
        });
        let own = (ClothSettings(settings.clone()), ClothLod(lod));
        let e = app.world_mut().spawn((free, own)).id();
        app.world_mut().entity_mut(e).insert(calm);
        e
    });
    camera(
        &mut app,
        Vec3::new(0.5, 2.0, 5.0),
        Vec3::new(0.5, 2.0, 10.0),
    );
    app.update();
    let momentum = |app: &App, e: Entity| -> Vec3 {
        let p = particles(app, e);
        p.velocities
            .iter()
            .zip(&p.inverse_masses)
            .map(|(v, w)| *v / *w)
            .sum()
    };
    let push = |app: &mut App, f: Vec3| {
        for &e in &cloths {
            let mut forces = app.world_mut().get_mut::<ClothForces>(e).unwrap();
            let n = forces.0.len().max(25);
            forces.0.resize(n, Vec3::ZERO);
            forces.0.iter_mut().for_each(|x| *x += f);
        }
    };
    // An impulse of 25 × 2 N over one fixed step.
    until_waited(&mut app, cloths[0], 1);
    push(&mut app, Vec3::X * 2.0);
    for _ in 0..8 {
        app.update();
    }
    let given = 25.0 * 2.0 * DT;
    let p = cloths.map(|e| momentum(&app, e));
    eprintln!("impulse {given}: momentum {p:?}");
    assert!(
        (p[0].x - given).abs() < 0.02 * given,
        "{p:?} against {given}"
    );
    // A steady 0.5 N a particle for 40 fixed steps.
    for _ in 0..40 {
        push(&mut app, Vec3::Y * 0.5);
        app.update();
    }
    until_waited(&mut app, cloths[0], 0);
    let given = 25.0 * 0.5 * 40.0 * DT;
    let p = cloths.map(|e| momentum(&app, e));
    eprintln!("steady {given}: momentum {p:?}");
    assert!(
        (p[0].y - given).abs() < 0.03 * given,
        "{p:?} against {given}"
    );
}

#[test]
fn bad_lod_settings_are_errors_and_the_cloth_keeps_stepping() {
    let mut app = app();
    camera(&mut app, SHEET + Vec3::Z * 5.0, SHEET + Vec3::Z * 10.0);
    let good = LodSettings::default();
    let bad = [
        LodSettings { near: 0.0, ..good },
        LodSettings { near: -3.0, ..good },
        LodSettings {
            near: f32::NAN,
            ..good
        },
        LodSettings {
            freeze: f32::NAN,
            ..good
        },
        LodSettings {
            freeze: -1.0,
            ..good
        },
        LodSettings {
            max_every: 0,
            ..good
        },
    ];
    let cloths: Vec<Entity> = bad
        .iter()
        .map(|lod| {
            assert!(matches!(lod.validate(), Err(ClothError::InvalidLod { .. })));
            app.world_mut().spawn((sheet(5), ClothLod(*lod))).id()
        })
        .collect();
    // The global defaults too.
    app.world_mut().resource_mut::<ClothLodDefaults>().0.near = f32::NAN;
    let global = app.world_mut().spawn(sheet(5)).id();
    for _ in 0..10 {
        app.update();
    }
    for e in cloths.into_iter().chain([global]) {
        assert_eq!(steps(&app, e), 10, "{e}");
        assert!(particles(&app, e).is_finite());
    }
}

#[test]
fn a_teleporting_camera_and_a_despawned_one_cause_no_pop() {
    let mut app = app();
    let cloth = app.world_mut().spawn(sheet(9)).id();
    let eye = camera(&mut app, SHEET + Vec3::Z * 5.0, SHEET);
    let spots = [
        (SHEET + Vec3::Z * 5.0, SHEET),
        (SHEET + Vec3::Z * 5.0, SHEET + Vec3::Z * 10.0),
        (SHEET + Vec3::X * 45.0, SHEET),
        (SHEET - Vec3::Y * 150.0, SHEET),
        (SHEET + Vec3::splat(f32::NAN), SHEET),
    ];
    let mut seed = 7u32;
    let mut worst = 0.0f32;
    for _ in 0..400 {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let (from, at) = spots[(seed >> 16) as usize % spots.len()];
        look(&mut app, eye, from, at);
        let before = particles(&app, cloth).positions.clone();
        app.update();
        let now = particles(&app, cloth);
        let taken = app.world().get::<ClothDetail>(cloth).unwrap().steps_now();
        assert!(now.is_finite());
        let moved = jump(&before, &now.positions);
        assert!(
            moved <= speed(now) * taken.max(1) as f32 * DT * 1.01 + 1e-4,
            "a jump of {moved} m over {taken} steps"
        );
        let links = app.world().get::<ClothConnections>(cloth).unwrap();
        worst = worst.max(max_strain(links.type1(), &now.positions));
    }
    assert!(worst < 0.1, "strain {worst}");
    // The camera goes: the cloth catches up and then steps every fixed step.
    app.world_mut().entity_mut(eye).despawn();
    app.update();
    assert_eq!(detail(&app, cloth), Detail::Full);
    let count = steps(&app, cloth);
    for _ in 0..5 {
        app.update();
    }
    assert_eq!(steps(&app, cloth), count + 5);
}

#[test]
fn a_held_cloth_steps_every_fixed_step_off_screen() {
    let mut app = app();
    let cloth = app.world_mut().spawn(sheet(9)).id();
    camera(&mut app, SHEET + Vec3::Z * 5.0, SHEET + Vec3::Z * 10.0);
    app.world_mut().get_mut::<ClothGrabs>(cloth).unwrap().grab(
        40,
        SHEET + Vec3::Y,
        GrabMode::Kinematic,
    );
    app.update();
    let count = steps(&app, cloth);
    for _ in 0..8 {
        app.update();
    }
    assert_eq!(steps(&app, cloth), count + 8);
    app.world_mut()
        .get_mut::<ClothGrabs>(cloth)
        .unwrap()
        .release_all();
    until(&mut app, cloth, Detail::Every(16));
}

/// The worst strain, and the worst distance of a kinematic particle from
/// its animated position, of the worn ribbon while its skeleton walks at
/// 3 m/s and turns at 1 rad/s for 1 s, seen from a camera `far` m away
/// (looking at it, or away).
fn walked(far: f32, seen: bool, level: Detail) -> (f32, f32, Detail) {
    let mut app = app();
    let (root, _, e) = wear(&mut app, 0.1);
    let at = Vec3::new(0.0, 1.2, 0.0);
    let eye = camera(&mut app, at, at);
    let looking = |app: &mut App, body: Vec3| {
        let look_at = if seen {
            body + at
        } else {
            body + at + Vec3::Z * 100.0
        };
        look(app, eye, body + at + Vec3::Z * far, look_at);
    };
    // It stands until it has earned its level.
    looking(&mut app, Vec3::ZERO);
    for _ in 0..300 {
        app.update();
        if detail(&app, e) == level {
            break;
        }
    }
    let (mut strain, mut off) = (0.0f32, 0.0f32);
    let mut level = Detail::Full;
    for k in 0..60 {
        let t = (k + 1) as f32 * DT;
        let body = Vec3::new(3.0 * t, 0.0, 0.0);
        let mut transform = app.world_mut().get_mut::<Transform>(root).unwrap();
        transform.translation = body;
        transform.rotation = Quat::from_rotation_y(t);
        looking(&mut app, body);
        app.update();
        level = detail(&app, e);
        let links = app.world().get::<ClothConnections>(e).unwrap();
        let p = particles(&app, e);
        assert!(p.is_finite());
        strain = strain.max(max_strain(links.type1(), &p.positions));
        let targets = app.world().get::<ClothSkinTargets>(e).unwrap();
        let skin = app.world().get::<ClothSkin>(e).unwrap();
        for (i, &f) in skin.freedom.iter().enumerate() {
            if f <= 0.0 {
                off = off.max(p.positions[i].distance(targets.positions[i]));
            }
        }
    }
    (strain, off, level)
}

#[test]
fn a_worn_cloth_stays_on_its_walking_skeleton_at_every_level() {
    let full = walked(3.0, true, Detail::Full);
    assert_eq!(full.2, Detail::Full);
    for (far, seen, level) in [
        (3.0, false, Detail::Every(16)),
        (30.0, true, Detail::Every(2)),
        (150.0, true, Detail::Frozen),
    ] {
        let (strain, off, at) = walked(far, seen, level);
        eprintln!(
            "{at:?}: strain {:.2} % (full {:.2} %), kinematic particles {off:.2e} m off",
            100.0 * strain,
            100.0 * full.0
        );
        assert!(
            matches!((at, level), (Detail::Every(_), Detail::Every(_))) || at == level,
            "{at:?} for {level:?}"
        );
        assert!(off < 1e-4, "{level:?}: {off} m off its skeleton");
        assert!(
            strain <= full.0.max(0.02) * 1.5,
            "{level:?}: strain {strain} against {}",
            full.0
        );
    }
}

#[test]
fn unseen_cloths_in_a_storm_flicked_or_large_stay_sound() {
    let mut app = app();
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(0.0, 0.0, 15.0),
        gust_amplitude: 0.6,
        gust_frequency: 1.3,
        ..default()
    }));
    let off = ClothLod(LodSettings {
        enabled: false,
        ..default()
    });
    let [large, small, flicked, large_full, small_full, flicked_full] =
        [48, 3, 16, 48, 3, 16].map(|n| app.world_mut().spawn(sheet(n)).id());
    for e in [large_full, small_full, flicked_full] {
        app.world_mut().entity_mut(e).insert(off);
    }
    let eye = camera(&mut app, SHEET + Vec3::Z * 5.0, SHEET + Vec3::Z * 10.0);
    app.update();
    // Flicked at 50 m/s while unseen, once it steps every 16th step.
    until(&mut app, flicked, Detail::Every(16));
    for e in [flicked, flicked_full] {
        let mut p = app.world_mut().get_mut::<ClothParticles>(e).unwrap();
        let p = &mut p.0;
        for (v, w) in p.velocities.iter_mut().zip(&p.inverse_masses) {
            if *w > 0.0 {
                *v = Vec3::new(0.0, 50.0, 0.0);
            }
        }
    }
    let mut worst = [0.0f32; 6];
    let all = [large, small, flicked, large_full, small_full, flicked_full];
    for _ in 0..240 {
        app.update();
        for (w, &e) in worst.iter_mut().zip(&all) {
            assert!(particles(&app, e).is_finite(), "{e}");
            let links = app.world().get::<ClothConnections>(e).unwrap();
            *w = w.max(max_strain(links.type1(), &particles(&app, e).positions));
        }
    }
    let percent = worst.map(|s| format!("{:.1} %", 100.0 * s));
    eprintln!(
        "strain in the storm, unseen (48×48, 3×3, flicked 16×16; then at full rate): {percent:?}"
    );
    // A combined step after a flick or a gust stretches an unseen cloth
    // more than a fixed step would, and then it combines fewer.
    assert!(worst.iter().all(|&s| s < 0.3), "{worst:?}");
    // Back in view, it is as sound as the ones that stepped every fixed
    // step.
    look(&mut app, eye, SHEET + Vec3::Z * 5.0, SHEET);
    let mut seen = [0.0f32; 6];
    for _ in 0..30 {
        app.update();
        for (w, &e) in seen.iter_mut().zip(&all) {
            let links = app.world().get::<ClothConnections>(e).unwrap();
            *w = w.max(max_strain(links.type1(), &particles(&app, e).positions));
        }
    }
    eprintln!(
        "back in view: {:?}",
        seen.map(|s| format!("{:.1} %", 100.0 * s))
    );
    for (lod, full) in seen[..3].iter().zip(&seen[3..]) {
        assert!(*lod <= 1.5 * full + 0.02, "{seen:?}");
    }
}
