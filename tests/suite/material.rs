//! Materials, not spring constants: the same fabric hangs the same at any
//! resolution, and a fabric's density and stiffness reach a live cloth.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::{app, particles};

/// A horizontal 1 m `n × n` sheet of `material` at y = 2 m, pinned at the
/// two corners of row 0: it falls, swings down and hangs. Returns its
/// bottom edge (the last row) after `seconds`, as a function of the rest
/// coordinate `u ∈ [0, 1]` along it.
fn bottom_edge(n: u32, material: ClothMaterial, seconds: f32) -> impl Fn(f32) -> Vec3 {
    bottom_edge_with(n, material, ClothSettings::default(), seconds)
}

/// [`bottom_edge`] with `settings` on the cloth.
fn bottom_edge_with(
    n: u32,
    material: ClothMaterial,
    settings: ClothSettings,
    seconds: f32,
) -> impl Fn(f32) -> Vec3 + use<> {
    let mut app = app();
    let cloth = ClothBuilder::new(n, n)
        .material(material)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .unwrap();
    let e = app.world_mut().spawn((cloth, settings)).id();
    for _ in 0..(seconds * 60.0) as usize {
        app.update();
    }
    let p = particles(&app, e);
    assert!(p.is_finite());
    let row: Vec<Vec3> = p.positions[((n - 1) * n) as usize..].to_vec();
    move |u: f32| {
        let s = u * (n - 1) as f32;
        let i = (s.floor() as usize).min(n as usize - 2);
        row[i].lerp(row[i + 1], s - i as f32)
    }
}

/// The largest distance (m) between the bottom edges of a 15×15 and a
/// 61×61 cloth of `material`, over 29 points along the edge.
fn disagreement(material: ClothMaterial) -> f32 {
    apart(
        bottom_edge(15, material, 6.0),
        bottom_edge(61, material, 6.0),
    )
}

/// The largest distance (m) between two edges over 29 points along them.
fn apart(coarse: impl Fn(f32) -> Vec3, fine: impl Fn(f32) -> Vec3) -> f32 {
    (0..=28)
        .map(|k| {
            let u = k as f32 / 28.0;
            coarse(u).distance(fine(u))
        })
        .fold(0.0, f32::max)
}

#[test]
fn a_fabric_hangs_the_same_at_15x15_and_61x61() {
    for (name, material) in [
        ("cotton", ClothMaterial::COTTON),
        ("silk", ClothMaterial::SILK),
        ("leather", ClothMaterial::LEATHER),
    ] {
        let worst = disagreement(material);
        eprintln!(
            "{name}: bottom edges of 15×15 and 61×61 within {:.1} mm",
            1e3 * worst
        );
        assert!(worst < 0.02, "{name}: {worst} m");
    }
}

#[test]
fn a_fabric_changed_on_a_live_cloth_changes_its_weight_and_stiffness() {
    let mut app = app();
    let cloth = ClothBuilder::new(9, 9)
        .material(ClothMaterial::SILK)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    app.update();
    let total = |app: &App| particles(app, e).masses.iter().sum::<f32>();
    assert!((total(&app) - 0.06).abs() < 1e-5);
    *app.world_mut().get_mut::<ClothMaterial>(e).unwrap() = ClothMaterial::DENIM;
    app.update();
    assert!((total(&app) - 0.4).abs() < 1e-5, "{}", total(&app));
    let p = particles(&app, e);
    assert!(
        p.masses
            .iter()
            .zip(&p.inverse_masses)
            .all(|(m, w)| (m * w - 1.0).abs() < 1e-5)
    );
}

#[test]
fn an_invalid_fabric_is_an_error_and_the_cloth_is_skipped() {
    let bad = ClothMaterial::Fabric(Fabric {
        bending: f32::NAN,
        ..Fabric::COTTON
    });
    assert!(ClothBuilder::new(5, 5).material(bad).build().is_err());
    // Set on a live cloth, it stops that cloth without a panic.
    let mut app = app();
    let e = app
        .world_mut()
        .spawn(ClothBuilder::new(5, 5).build().unwrap())
        .id();
    *app.world_mut().get_mut::<ClothMaterial>(e).unwrap() = bad;
    let before = particles(&app, e).positions.clone();
    for _ in 0..5 {
        app.update();
    }
    assert_eq!(particles(&app, e).positions, before);
}
