//! Cloth of any shape, headless: a disc of particles and links from
//! `sim::topology`, stepped by `sim::guard::step_guarded` with every
//! integrator, and draped on a ball with the implicit solve holding its
//! contacts.

use bevy::math::{Isometry3d, Vec3};
use bevy_cloth::prelude::*;
use bevy_cloth::sim::collision::contact::{Geometry, MovingCollider, collide_particles};
use bevy_cloth::sim::collision::predict::{keep_nearest, predict_contacts, push_out_held};
use bevy_cloth::sim::collision::shapes::Shape;
use bevy_cloth::sim::connections::{Connections, max_strain};
use bevy_cloth::sim::guard::{GuardState, StepInput, step_guarded};
use bevy_cloth::sim::integrate::StepBuffers;
use bevy_cloth::sim::particles::Particles;
use bevy_cloth::sim::step::{ContactHook, NoContacts, Substep, step_cloth_with};
use bevy_cloth::sim::step::{Hold, SolveBody, SolveContact};
use bevy_cloth::sim::topology::{MeshTopology, disc};

const DT: f32 = 1.0 / 60.0;

/// [`disc`] of `radius` m lifted to height `y` m with every inner particle
/// moved by up to `jitter` of a spacing, so the triangles are irregular.
fn jittered_disc(rings: usize, radius: f32, y: f32, jitter: f32) -> (Vec<Vec3>, Vec<u32>) {
    let (mut positions, indices) = disc(radius, rings as u32);
    let spacing = radius / rings as f32;
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    let mut unit = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let rim = positions.len() - 6 * rings;
    for (k, p) in positions.iter_mut().enumerate() {
        if k < rim {
            *p += Vec3::new(unit(), 0.0, unit()) * jitter * spacing;
        }
        p.y += y;
    }
    (positions, indices)
}

/// The particles (cotton, 0.15 kg/m²) and links of a disc.
fn cloth(rings: usize, radius: f32, y: f32, jitter: f32) -> (Particles, Connections) {
    let (positions, indices) = jittered_disc(rings, radius, y, jitter);
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let masses = t.lumped_masses(0.15);
    (Particles::new(t.positions.clone(), masses), t.connections())
}

/// Cotton at the disc's mean spacing `h` (m), stepped with `integrator`.
fn settings(integrator: Integrator, h: f32) -> SimSettings {
    let mut s = SimSettings::default().with_integrator(integrator, 1);
    Fabric::COTTON.apply(&mut s, h);
    s
}

#[test]
fn a_disc_hung_from_its_rim_stays_whole_with_every_integrator() {
    let rings = 10;
    let (particles, links) = cloth(rings, 0.5, 1.0, 0.25);
    // Pin six particles evenly around the rim.
    let rim = particles.len() - 6 * rings;
    for integrator in [
        Integrator::BackwardEuler,
        Integrator::Bdf2,
        Integrator::SymplecticEuler,
        Integrator::Rk4,
        Integrator::ExplicitEuler,
    ] {
        let mut p = particles.clone();
        for k in 0..6 {
            p.pin(rim + k * rings);
        }
        let s = settings(integrator, 0.05);
        let (mut buffers, mut guard) = (StepBuffers::default(), GuardState::default());
        let mut trips = 0;
        for _ in 0..120 {
            let step = step_guarded(StepInput::new(
                &mut p,
                &links,
                &s,
                &mut buffers,
                &mut guard,
                DT,
            ));
            trips += step.report.is_some() as u32;
        }
        let strain = max_strain(links.type1(), &p.positions);
        assert!(p.is_finite(), "{integrator:?}");
        assert_eq!(trips, 0, "{integrator:?}");
        assert!(strain < 0.05, "{integrator:?}: strain {strain}");
        // Its middle sags below the rim (cotton stretches little: a few cm).
        let sag = 1.0 - p.positions[0].y;
        assert!(sag > 0.01 && sag < 0.2, "{integrator:?}: sag {sag} m");
        eprintln!(
            "{integrator:?}: strain {:.2} %, sag {:.1} cm",
            100.0 * strain,
            100.0 * sag
        );
    }
}

/// A static ball as the scene's one collider.
struct Ball {
    collider: MovingCollider<'static>,
    thickness: f32,
}

impl ContactHook for Ball {
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        held: &[Hold],
    ) {
        let masked: Vec<f32> = if held.len() == w.len() {
            w.iter()
                .zip(held)
                .map(|(&w, &h)| if h == Hold::Free { w } else { 0.0 })
                .collect()
        } else {
            w.to_vec()
        };
        collide_particles(&self.collider, start, x, v, &masked, self.thickness, sub.dt);
        if held.len() == x.len() {
            push_out_held(&self.collider, held, (start, x, v), self.thickness, sub.dt);
        }
    }

    fn predict(
        &mut self,
        sub: Substep,
        x: &[Vec3],
        v: &[Vec3],
        w: &[f32],
        out: &mut Vec<SolveContact>,
        _bodies: &mut Vec<SolveBody>,
    ) {
        let reach = (self.thickness, sub.dt);
        predict_contacts(&self.collider, (x, v, w), reach, false, out);
        keep_nearest(out, |_| 0);
    }
}

#[test]
fn an_irregular_disc_drapes_on_a_ball_and_stays() {
    // A 1.2 m disc dropped from 0.1 m above a 0.3 m ball centred at 1 m.
    let (particles, links) = cloth(16, 0.6, 1.4, 0.3);
    for integrator in [Integrator::BackwardEuler, Integrator::Bdf2] {
        let mut p = particles.clone();
        let s = settings(integrator, 0.6 / 16.0);
        let mut ball = Ball {
            collider: MovingCollider {
                geometry: Geometry::Shape(Shape::Sphere { radius: 0.3 }),
                start: Isometry3d::from_translation(Vec3::Y),
                end: Isometry3d::from_translation(Vec3::Y),
                friction: 0.5,
                restitution: 0.0,
            },
            thickness: 0.005,
        };
        let (mut buffers, mut guard) = (StepBuffers::default(), GuardState::default());
        let mut worst = 0.0f32;
        for step in 0..300 {
            step_guarded(
                StepInput::new(&mut p, &links, &s, &mut buffers, &mut guard, DT)
                    .with_contacts(Some(&mut ball)),
            );
            if step >= 60 {
                worst = worst.max(max_strain(links.type1(), &p.positions));
            }
        }
        assert!(p.is_finite(), "{integrator:?}");
        assert!(worst < 0.05, "{integrator:?}: strain {worst}");
        // The middle rests on top of the ball (1.3 m plus the thickness).
        let top = p.positions[0].y;
        assert!(
            (top - 1.305).abs() < 0.01,
            "{integrator:?}: middle at {top} m"
        );
        // No particle is inside the ball.
        let inside = p
            .positions
            .iter()
            .map(|x| x.distance(Vec3::Y))
            .fold(f32::INFINITY, f32::min);
        assert!(inside > 0.29, "{integrator:?}: {inside}");
        eprintln!(
            "{integrator:?}: strain after 1 s {:.2} %, middle {top:.4} m",
            100.0 * worst
        );
    }
}

/// Conjugate-gradient iterations per backward Euler step of an irregular
/// disc of `rings` rings (36: 3,997 particles) held at six rim particles,
/// over 30 steps from rest, with the coarse correction on or off.
fn iterations(rings: usize, coarse: bool) -> (u32, f32) {
    let (mut p, links) = cloth(rings, 1.0, 1.0, 0.25);
    let rim = p.len() - 6 * rings;
    for k in 0..6 {
        p.pin(rim + k * rings);
    }
    let mut s = settings(Integrator::BackwardEuler, 1.0 / rings as f32);
    s.implicit.coarse_grid = coarse;
    let mut buffers = StepBuffers::default();
    let mut total = 0;
    for _ in 0..30 {
        step_cloth_with(
            &mut p,
            &links,
            &s,
            &[],
            &mut buffers,
            DT,
            None::<&mut NoContacts>,
        );
        total += buffers.solver_iterations();
    }
    assert!(p.is_finite());
    (total, max_strain(links.type1(), &p.positions))
}

#[test]
fn the_coarse_correction_cuts_a_mesh_cloths_iterations() {
    let (with, strain_with) = iterations(36, true);
    let (without, strain_without) = iterations(36, false);
    eprintln!(
        "3,997-particle disc, 30 steps: {with} iterations with the coarse correction, {without} without; strain {:.2} % / {:.2} %",
        100.0 * strain_with,
        100.0 * strain_without
    );
    assert!(5 * with < 3 * without, "{with} vs {without}");
    assert!((strain_with - strain_without).abs() < 0.01);
}

#[test]
fn a_mesh_cloths_iterations_grow_little_as_it_grows_finer() {
    // The coarse correction's levels follow the resolution: 4 times the
    // particles take at most 1.5 times the iterations, 16 times at most
    // 1.8 times.
    let counts: Vec<u32> = [18, 36, 72].map(|rings| iterations(rings, true).0).into();
    eprintln!("discs of 18, 36 and 72 rings, 30 steps: {counts:?} iterations");
    assert!(2 * counts[1] <= 3 * counts[0], "{counts:?}");
    assert!(5 * counts[2] <= 9 * counts[0], "{counts:?}");
}
