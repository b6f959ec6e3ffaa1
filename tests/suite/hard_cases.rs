//! Hard cases stay numerically stable, for every integrator at the step it
//! is advertised as safe at: implicit ones at one 1/60 s step, explicit ones
//! at 1/60 s with [`AdaptiveSubsteps`] (the substep follows the stiffest
//! mode). The estimate is not capped here (`max_substeps` is the settings'
//! limit, [`MAX_SUBSTEPS`]): a cap is a budget, below which an integrator is
//! no longer at its safe step. The guard stays on, as in a game. Each case
//! asserts that the cloth stays finite, and that after settling its Type 1
//! strain and its kinetic energy are small.
//!
//! Explicit Euler is the costly one: its bound is a damping rate over `ω²`
//! (MODEL.md §6.1), so it runs 371 substeps per frame on the resting cloth,
//! 6621 on the sharp crease and 37 000 after ×100 stiffness
//! (`explicit_euler_pays_for_its_safe_step_in_substeps`).
//!
//! The suite can fail: `stiffness_x100_without_adaptive_substeps_blows_up`
//! stiffens the cloth without adaptive substeps or the guard, and
//! `explicit_euler_on_the_sharp_crease_needs_the_tension_term` runs explicit
//! Euler without the part of the estimate that reads the cloth's tension;
//! both blow up.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::adaptive::AdaptiveSubsteps;
use bevy_cloth::sim::crease::Crease;
use bevy_cloth::sim::guard::GuardSettings;
use bevy_cloth::sim::settings::MAX_SUBSTEPS;
use common::{app, hanging, particles};

/// The grid of the suite: small enough for explicit Euler's thousands of
/// substeps to stay quick, big enough to fold.
const GRID: u32 = 9;

/// The safe setup of `integrator` (module docs).
fn safe(integrator: Integrator) -> ClothSettings {
    let mut s = ClothSettings::default().with_integrator(integrator, 1);
    if !integrator.is_implicit() {
        s.adaptive = Some(AdaptiveSubsteps {
            max_substeps: MAX_SUBSTEPS,
            ..default()
        });
    }
    s
}

/// Spawns `cloth` with `settings` in a fresh 60 Hz app.
fn spawn(cloth: impl Bundle, settings: ClothSettings) -> (App, Entity) {
    let mut app = app();
    let e = app.world_mut().spawn((cloth, settings)).id();
    (app, e)
}

/// Runs `seconds` of fixed steps, failing at once on a non-finite state.
fn run(app: &mut App, e: Entity, seconds: f32, case: &str) {
    for _ in 0..(seconds * 60.0).round() as usize {
        app.update();
        let p = particles(app, e);
        let finite = p
            .positions
            .iter()
            .chain(&p.velocities)
            .all(|x| x.is_finite());
        assert!(finite, "{case}: non-finite state");
    }
}

/// After settling: finite, Type 1 strain below `max_strain`, kinetic energy
/// below `max_kinetic` J.
fn assert_settled(app: &App, e: Entity, case: &str, max_strain: f32, max_kinetic: f32) {
    let stats = app.world().get::<ClothStats>(e).unwrap();
    assert!(stats.finite, "{case}: not finite");
    assert!(
        stats.max_strain < max_strain,
        "{case}: strain {} after settling",
        stats.max_strain
    );
    assert!(
        stats.kinetic_energy < max_kinetic,
        "{case}: kinetic energy {} J after settling",
        stats.kinetic_energy
    );
}

#[test]
fn explicit_euler_pays_for_its_safe_step_in_substeps() {
    // Its bound (MODEL.md §6.1) is a damping rate over ω²: for the pair-
    // damped stiffness the ratio k_d/k (adaptive module docs). It shrinks
    // with k, not √k: ×100 stiffness asks ×100 substeps where symplectic
    // Euler asks ×10.
    let cloth = hanging(GRID);
    let unlimited = AdaptiveSubsteps {
        max_substeps: u32::MAX,
        ..default()
    };
    let substeps = |i: Integrator, scale: f32| {
        let mut s = safe(i);
        s.choi_ko.stiffness *= scale;
        s.choi_ko.shear_stiffness *= scale;
        s.choi_ko.buckling_slope *= scale;
        let mode = bevy_cloth::sim::adaptive::stiffest_mode(
            &s,
            &cloth.connections,
            &cloth.particles.positions,
            &cloth.particles.inverse_masses,
            &mut Vec::new(),
        );
        unlimited.substeps(1, 1.0 / 60.0, i, mode) as f32
    };
    let euler = substeps(Integrator::ExplicitEuler, 1.0);
    let symplectic = substeps(Integrator::SymplecticEuler, 1.0);
    assert!(euler > 5.0 * symplectic, "{euler} vs {symplectic}");
    let ratio = substeps(Integrator::ExplicitEuler, 100.0) / euler;
    assert!(
        ratio > 90.0 && ratio < 110.0,
        "×100 stiffness: ×{ratio} substeps"
    );
    let ratio = substeps(Integrator::SymplecticEuler, 100.0) / symplectic;
    assert!(
        ratio > 8.0 && ratio < 12.0,
        "×100 stiffness: ×{ratio} substeps"
    );
}

/// The integrators of the suite (module docs).
const SAFE: [Integrator; 5] = [
    Integrator::ExplicitEuler,
    Integrator::SymplecticEuler,
    Integrator::Rk4,
    Integrator::BackwardEuler,
    Integrator::Bdf2,
];

/// Every integrator of the suite through `case`, which must settle to a
/// Type 1 strain below `max_strain`.
fn each_integrator(max_strain: f32, case: impl Fn(Integrator) -> (App, Entity, String)) {
    for integrator in SAFE {
        let (app, e, name) = case(integrator);
        let stats = app.world().get::<ClothStats>(e).unwrap();
        let (strain, kinetic) = (stats.max_strain, stats.kinetic_energy);
        eprintln!(
            "{name}: strain {strain:.4}, kinetic {kinetic:.2e} J, {} substeps",
            stats.substeps
        );
        assert_settled(&app, e, &name, max_strain, 0.02);
    }
}

#[test]
fn extreme_pull_a_corner_dragged_3_m_at_20_m_per_s_and_released() {
    each_integrator(0.1, |i| {
        let (mut app, e) = spawn(hanging(GRID), safe(i));
        run(&mut app, e, 0.5, "pull: settle");
        // The bottom corner, held kinematically, moves 3 m in 0.15 s.
        let corner = (GRID * GRID - 1) as usize;
        {
            let mut p = app.world_mut().get_mut::<ClothParticles>(e).unwrap();
            p.pin(corner);
            p.velocities[corner] = Vec3::new(20.0, 0.0, 0.0);
        }
        run(&mut app, e, 0.15, "pull: drag");
        let dragged = particles(&app, e).positions[corner];
        let start = hanging(GRID).particles.positions[corner];
        assert!(
            dragged.x - start.x > 2.5,
            "{i:?}: corner from {start} to {dragged}"
        );
        app.world_mut()
            .get_mut::<ClothParticles>(e)
            .unwrap()
            .unpin(corner);
        run(&mut app, e, 4.0, "pull: release");
        (app, e, format!("extreme pull, {i:?}"))
    });
}

#[test]
fn crumple_every_particle_within_1_cm_of_one_point() {
    each_integrator(0.1, |i| {
        let mut cloth = hanging(GRID);
        let centre = Vec3::new(0.5, 1.0, 0.0);
        for (k, x) in cloth.particles.positions.iter_mut().enumerate() {
            // A deterministic scatter inside a 1 cm ball.
            let t = k as f32;
            *x = centre + 0.009 * Vec3::new((t * 1.7).sin(), (t * 2.3).cos(), (t * 0.7).sin());
        }
        let (mut app, e) = spawn(cloth, safe(i));
        run(&mut app, e, 3.0, "crumple");
        (app, e, format!("crumple, {i:?}"))
    });
}

#[test]
fn stiffness_x100_at_runtime() {
    each_integrator(0.1, |i| {
        let (mut app, e) = spawn(hanging(GRID), safe(i));
        run(&mut app, e, 0.2, "stiffen: before");
        {
            let mut s = app.world_mut().get_mut::<ClothSettings>(e).unwrap();
            s.choi_ko.stiffness *= 100.0;
            s.choi_ko.shear_stiffness *= 100.0;
            s.choi_ko.buckling_slope *= 100.0;
        }
        run(&mut app, e, 2.0, "stiffen: after");
        let stats = app.world().get::<ClothStats>(e).unwrap();
        if !i.is_implicit() {
            // The adaptive substeps followed ω_max, which grew tenfold.
            assert!(stats.substeps >= 10, "{i:?}: {} substeps", stats.substeps);
        }
        (app, e, format!("stiffness ×100, {i:?}"))
    });
}

#[test]
fn particles_100_times_lighter_at_runtime() {
    // The same ω_max ×10 as stiffness ×100, through the masses instead.
    each_integrator(0.1, |i| {
        let (mut app, e) = spawn(hanging(GRID), safe(i));
        run(&mut app, e, 0.2, "lighten: before");
        {
            let mut p = app.world_mut().get_mut::<ClothParticles>(e).unwrap();
            let p = &mut p.0;
            for (m, w) in p.masses.iter_mut().zip(&mut p.inverse_masses) {
                *m /= 100.0;
                if *w > 0.0 {
                    *w = 1.0 / *m;
                }
            }
        }
        run(&mut app, e, 2.0, "lighten: after");
        let stats = app.world().get::<ClothStats>(e).unwrap();
        if !i.is_implicit() {
            assert!(stats.substeps >= 200, "{i:?}: {} substeps", stats.substeps);
        }
        (app, e, format!("mass ÷100, {i:?}"))
    });
}

#[test]
fn stiffness_x100_without_adaptive_substeps_blows_up() {
    // Symplectic Euler at a fixed 40 substeps is stable for cotton...
    let s = ClothSettings(SimSettings {
        guard: GuardSettings {
            enabled: false,
            ..default()
        },
        ..default()
    })
    .with_integrator(Integrator::SymplecticEuler, 40)
    .without_adaptive();
    let (mut app, e) = spawn(hanging(GRID), s);
    for _ in 0..12 {
        app.update();
    }
    assert!(app.world().get::<ClothStats>(e).unwrap().max_strain < 0.1);
    // ...but not once k is 100 times larger (ω ×10, the bound ÷10).
    app.world_mut()
        .get_mut::<ClothSettings>(e)
        .unwrap()
        .choi_ko
        .stiffness *= 100.0;
    app.world_mut()
        .get_mut::<ClothSettings>(e)
        .unwrap()
        .choi_ko
        .shear_stiffness *= 100.0;
    for _ in 0..30 {
        app.update();
    }
    let stats = app.world().get::<ClothStats>(e).unwrap();
    assert!(
        !stats.finite || stats.max_strain > 1.0,
        "expected a blow-up: {stats:?}"
    );
}

#[test]
fn explicit_euler_on_the_sharp_crease_needs_the_tension_term() {
    // The crease stretches the hinge's neighbours by 20 %: their tension
    // makes transverse modes only the absolute damping reaches. Explicit
    // Euler at the pair-damped bound alone (371 substeps here, the resting
    // cloth's estimate) blows up to NaN within 3 s; the estimate with the
    // tension term (6621 substeps, `a_sharp_crease_r_0_3`) settles.
    let crease = Crease::new(Vec2::new(0.5, -0.1), Vec2::new(0.5, 1.1)).with_ratio(0.3);
    let resting = ClothSettings::default().with_integrator(Integrator::ExplicitEuler, 1);
    let cloth = hanging(GRID);
    let s = ClothSettings(SimSettings {
        substeps: AdaptiveSubsteps::default().substeps(
            1,
            1.0 / 60.0,
            Integrator::ExplicitEuler,
            bevy_cloth::sim::adaptive::stiffest_mode(
                &resting,
                &cloth.connections,
                &cloth.particles.positions,
                &cloth.particles.inverse_masses,
                &mut Vec::new(),
            ),
        ),
        guard: GuardSettings {
            enabled: false,
            ..default()
        },
        adaptive: None,
        ..resting.0
    });
    assert!(s.substeps < 500, "{}", s.substeps);
    let (mut app, e) = spawn((cloth, ClothCreases(vec![crease])), s);
    for _ in 0..180 {
        app.update();
    }
    let stats = app.world().get::<ClothStats>(e).unwrap();
    assert!(
        !stats.finite || stats.kinetic_energy > 0.1,
        "expected a blow-up: {stats:?}"
    );
}

#[test]
fn a_fast_sphere_through_the_cloth() {
    each_integrator(0.1, |i| {
        let (mut app, e) = spawn(hanging(GRID), safe(i));
        run(&mut app, e, 0.5, "sphere: settle");
        // A 15 cm ball at 10 m/s through the hanging cloth's middle.
        let ball = app
            .world_mut()
            .spawn((
                ClothCollider::sphere(0.15),
                Transform::from_xyz(0.5, 1.0, -1.0),
            ))
            .id();
        for _ in 0..12 {
            app.world_mut()
                .get_mut::<Transform>(ball)
                .unwrap()
                .translation
                .z += 10.0 / 60.0;
            run(&mut app, e, 1.0 / 60.0, "sphere: pass");
        }
        app.world_mut().despawn(ball);
        run(&mut app, e, 3.0, "sphere: settle after");
        (app, e, format!("fast sphere, {i:?}"))
    });
}

#[test]
fn a_sharp_crease_r_0_3() {
    // The crease springs pull the hinge column out of the coarse grid's
    // plane, stretching its neighbours: a static strain, not a blow-up.
    each_integrator(0.5, |i| {
        let crease = Crease::new(Vec2::new(0.5, -0.1), Vec2::new(0.5, 1.1)).with_ratio(0.3);
        let (mut app, e) = spawn((hanging(GRID), ClothCreases(vec![crease])), safe(i));
        run(&mut app, e, 3.0, "crease");
        (app, e, format!("sharp crease, {i:?}"))
    });
}

#[test]
fn the_smallest_grid_3x3() {
    each_integrator(0.1, |i| {
        let (mut app, e) = spawn(hanging(3), safe(i));
        run(&mut app, e, 3.0, "3×3");
        (app, e, format!("3×3, {i:?}"))
    });
}

#[test]
fn zero_gravity_with_large_initial_velocities() {
    each_integrator(0.1, |i| {
        let mut cloth = hanging(GRID);
        let p = &mut cloth.particles.0;
        for (k, v) in p.velocities.iter_mut().enumerate() {
            // Pinned particles keep their (zero) prescribed velocity.
            if p.inverse_masses[k] > 0.0 {
                let t = k as f32;
                *v = 10.0 * Vec3::new((t * 1.3).sin(), (t * 0.9).cos(), (t * 2.1).sin());
            }
        }
        let mut s = safe(i);
        s.gravity = Vec3::ZERO;
        let (mut app, e) = spawn(cloth, s);
        run(&mut app, e, 4.0, "zero gravity");
        (app, e, format!("zero gravity, {i:?}"))
    });
}

#[test]
fn coincident_particles() {
    each_integrator(0.1, |i| {
        let mut cloth = hanging(GRID);
        // Row 1 starts exactly on row 0, and the last row on one point.
        let n = GRID as usize;
        let (top, rest) = cloth.particles.positions.split_at_mut(n);
        rest[..n].copy_from_slice(top);
        let last = cloth.particles.positions.len() - n;
        let point = cloth.particles.positions[last];
        cloth.particles.positions[last..].fill(point);
        let (mut app, e) = spawn(cloth, safe(i));
        run(&mut app, e, 3.0, "coincident");
        (app, e, format!("coincident particles, {i:?}"))
    });
}
