//! A cloth worn on a hand-built two-bone skeleton: CPU skinning against
//! Bevy's formula, kinematic particles, and the max distance under a
//! 20 rad/s spin.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::plugin::worn::ClothSkinTargets;
use bevy_cloth::prelude::*;
use common::{COLS, ROWS, app, particles, ribbon, wear};

/// Bevy's skinning of particle `p`: `(Σ wₖ Gₖ Bₖ) rest` with the joints'
/// propagated `GlobalTransform`s.
fn bevy_skinned(app: &App, e: Entity, p: usize) -> Vec3 {
    let skin = app.world().get::<ClothSkin>(e).unwrap();
    let influence = skin.influences[p];
    let mut m = Mat4::ZERO;
    for (&j, &w) in influence.joints.iter().zip(&influence.weights) {
        let joint = skin.joints[j as usize];
        let g = app
            .world()
            .get::<GlobalTransform>(joint)
            .unwrap()
            .to_matrix();
        m += g * Mat4::from(skin.inverse_bindposes[j as usize]) * w;
    }
    m.transform_point3(skin.rest[p])
}

#[test]
fn cpu_skinning_matches_bevys_formula_in_the_same_frame() {
    let mut app = app();
    let (root, upper, e) = wear(&mut app, 0.1);
    for k in 0..5 {
        let a = 0.3 * k as f32;
        *app.world_mut().get_mut::<Transform>(root).unwrap() =
            Transform::from_xyz(1.0, 0.1 * a, 0.0).with_rotation(Quat::from_rotation_y(a));
        app.world_mut()
            .get_mut::<Transform>(upper)
            .unwrap()
            .rotation = Quat::from_rotation_z(0.5 * a);
        app.update();
        let targets = app.world().get::<ClothSkinTargets>(e).unwrap();
        for p in 0..(COLS * ROWS) as usize {
            let want = bevy_skinned(&app, e, p);
            assert!(
                targets.positions[p].distance(want) < 1e-5,
                "frame {k}, particle {p}: {} vs {want}",
                targets.positions[p]
            );
        }
    }
}

#[test]
fn kinematic_particles_follow_the_animation_exactly() {
    let mut app = app();
    let (_, upper, e) = wear(&mut app, 0.1);
    for k in 0..90 {
        let a = 0.6 * (k as f32 * 0.2).sin();
        app.world_mut()
            .get_mut::<Transform>(upper)
            .unwrap()
            .rotation = Quat::from_rotation_x(a);
        app.update();
        let targets = app
            .world()
            .get::<ClothSkinTargets>(e)
            .unwrap()
            .positions
            .clone();
        let p = particles(&app, e);
        assert!(p.is_finite());
        for (i, target) in targets.iter().enumerate().take(COLS as usize) {
            assert_eq!(p.positions[i], *target, "step {k}, particle {i}");
            assert!(p.is_pinned(i));
        }
    }
}

/// The farthest (m) a particle of freedom 0.5 and one of freedom 1 get
/// from their animated positions while the skeleton spins up to 20 rad/s
/// in 0.25 s and spins on for 1.75 s, every simulated particle outside a
/// backstop round the body.
fn spin(max: f32) -> (f32, f32) {
    let mut app = app();
    let (root, _, e) = wear(&mut app, max);
    // A backstop round the body, checked below.
    let skin = app.world_mut().get::<ClothSkin>(e).unwrap().clone();
    let axis = (Vec3::new(0.0, 0.7, 0.0), Vec3::new(0.0, 1.5, 0.0));
    app.world_mut()
        .entity_mut(e)
        .insert(skin.with_backstop(0, axis, 0.08));
    let (mut half, mut free) = (0.0f32, 0.0f32);
    let mut angle = 0.0f32;
    for k in 0..120 {
        angle += 20.0 * (k as f32 / 15.0).min(1.0) / 60.0;
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = Quat::from_rotation_y(angle);
        app.update();
        let targets = app
            .world()
            .get::<ClothSkinTargets>(e)
            .unwrap()
            .positions
            .clone();
        let p = particles(&app, e);
        assert!(p.is_finite(), "step {k}");
        for (i, (x, t)) in p.positions.iter().zip(&targets).enumerate() {
            let body = Vec3::new(0.0, x.y.clamp(0.7, 1.5), 0.0);
            assert!(
                p.is_pinned(i) || x.distance(body) >= 0.08 - 1e-4,
                "step {k}: inside the backstop"
            );
            let row = i as u32 / COLS;
            let d = x.distance(*t);
            if (1..=4).contains(&row) {
                half = half.max(d);
            } else if row > 4 {
                free = free.max(d);
            }
        }
    }
    (half, free)
}

#[test]
fn the_max_distance_and_the_backstop_hold_under_a_20_rad_s_spin() {
    let (held, free) = spin(0.1);
    let (unheld, _) = spin(0.0);
    eprintln!(
        "20 rad/s: freedom-0.5 particles ≤ {:.1} mm from their animated place with a 0.1 m max distance, {:.1} mm without; free ones {:.1} mm",
        1000.0 * held,
        1000.0 * unheld,
        1000.0 * free
    );
    assert!(held <= 0.05 + 1e-4, "{held}");
    assert!(
        unheld > 0.06,
        "without a limit they should fly out: {unheld}"
    );
}

/// The deepest (m) a simulated particle gets inside a 0.08 m capsule
/// around the root bone (y from 0.7 to 1.5 m) while an 8 m/s wind from
/// behind blows the ribbon against the body for 1 s, with that capsule as
/// a backstop or without.
fn blown_against(backstop: bool) -> f32 {
    let mut app = app();
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(0.0, 0.0, 8.0),
        ..default()
    }));
    let (_, _, e) = wear(&mut app, 0.1);
    if backstop {
        let skin = app.world_mut().get::<ClothSkin>(e).unwrap().clone();
        let axis = (Vec3::new(0.0, 0.7, 0.0), Vec3::new(0.0, 1.5, 0.0));
        app.world_mut()
            .entity_mut(e)
            .insert(skin.with_backstop(0, axis, 0.08));
    }
    let mut deepest = 0.0f32;
    for _ in 0..60 {
        app.update();
        let p = particles(&app, e);
        assert!(p.is_finite());
        for (i, x) in p.positions.iter().enumerate() {
            if !p.is_pinned(i) {
                let axis = Vec3::new(0.0, x.y.clamp(0.7, 1.5), 0.0);
                deepest = deepest.max(0.08 - x.distance(axis));
            }
        }
    }
    deepest
}

#[test]
fn a_backstop_keeps_the_ribbon_off_the_body_it_is_blown_against() {
    let kept = blown_against(true);
    let through = blown_against(false);
    eprintln!(
        "ribbon blown against the body at 8 m/s: deepest {:.2} mm inside the backstop with it, {:.0} mm without",
        1000.0 * kept,
        1000.0 * through
    );
    assert!(kept < 1e-4, "{kept}");
    assert!(through > 0.02, "{through}");
}

/// The worst strain of the ribbon while its skeleton walks at 3 m/s for
/// 1 s feeling `inertia` of its root's motion.
fn walked(inertia: Option<f32>) -> f32 {
    let mut app = app();
    let (root, _, e) = wear(&mut app, 0.1);
    if let Some(s) = inertia {
        app.world_mut()
            .entity_mut(e)
            .insert(ClothInertia::new(root, s, s));
    }
    app.update();
    let mut worst = 0.0f32;
    for k in 0..60 {
        let x = 3.0 * (k + 1) as f32 / 60.0;
        app.world_mut()
            .get_mut::<Transform>(root)
            .unwrap()
            .translation
            .x = x;
        app.update();
        let links = app.world().get::<ClothConnections>(e).unwrap();
        let p = particles(&app, e);
        assert!(p.is_finite());
        worst = worst.max(bevy_cloth::sim::connections::max_strain(
            links.type1(),
            &p.positions,
        ));
    }
    worst
}

#[test]
fn inertia_scales_carry_a_skins_kinematic_particles_with_the_free_ones() {
    let felt = walked(Some(0.3));
    let world = walked(None);
    eprintln!(
        "skeleton walking at 3 m/s: strain ≤ {:.2} % feeling 0.3 of it, {:.2} % in the world",
        100.0 * felt,
        100.0 * world
    );
    assert!(felt < 0.02, "{felt}");
}

#[test]
fn a_skin_comes_from_a_skinned_mesh_and_its_bind_poses() {
    use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
    let mut app = app();
    let root = app.world_mut().spawn(Transform::default()).id();
    let upper = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 1.2, 0.0))
        .id();
    let binds = vec![
        Mat4::IDENTITY,
        Mat4::from_translation(Vec3::new(0.0, -1.2, 0.0)),
    ];
    let mut assets = Assets::<SkinnedMeshInverseBindposes>::default();
    let skinned = SkinnedMesh {
        inverse_bindposes: assets.add(binds.clone()),
        joints: vec![root, upper],
    };
    let mesh = ribbon();
    let cloth = ClothBuilder::from_mesh(&mesh).build().unwrap();
    let layout = cloth.cloth.mesh().unwrap().clone();
    let name = ATTRIBUTE_FREEDOM.name;
    let skin = ClothSkin::from_skinned_mesh(&mesh, &layout, (&skinned, &assets), name, 0.1);
    let direct = ClothSkin::from_mesh(&mesh, &layout, (vec![root, upper], &binds), name, 0.1);
    assert_eq!(skin.unwrap(), direct.unwrap());
    // Bind poses not loaded: an error, not a panic.
    let empty = Assets::<SkinnedMeshInverseBindposes>::default();
    let missing = ClothSkin::from_skinned_mesh(&mesh, &layout, (&skinned, &empty), name, 0.1);
    assert!(matches!(missing, Err(ClothError::UnsupportedMesh(_))));
}

#[test]
fn a_worn_cloth_sleeps_while_its_skeleton_stands_and_wakes_when_it_moves() {
    let mut app = app();
    let (root, _, e) = wear(&mut app, 0.1);
    let asleep = |app: &App| app.world().get::<ClothSleep>(e).unwrap().is_asleep();
    let mut slept = false;
    for _ in 0..600 {
        app.update();
        if asleep(&app) {
            slept = true;
            break;
        }
    }
    assert!(slept, "{:?}", app.world().get::<ClothStats>(e));
    let before = particles(&app, e).positions.clone();
    for _ in 0..30 {
        app.update();
    }
    assert!(asleep(&app));
    assert_eq!(particles(&app, e).positions, before);
    app.world_mut()
        .get_mut::<Transform>(root)
        .unwrap()
        .translation
        .x += 0.05;
    app.update();
    assert!(!asleep(&app), "the skeleton moved");
    // Its kinematic top row follows the skeleton in that same step.
    let top = particles(&app, e).positions[2];
    assert!(
        (top.x - (before[2].x + 0.05)).abs() < 1e-4,
        "{top} {}",
        before[2]
    );
}
