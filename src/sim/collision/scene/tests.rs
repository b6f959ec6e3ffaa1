//! The contact hook's tests.

use bevy::math::{Isometry3d, Vec3};

use super::hook::{SPLIT_PARTICLES, resolve_substep};
use super::{ColliderKey, ColliderScene, ColliderShape, SceneCollider};
use crate::sim::collision::{SelfCollisionBuffers, Shape};
use crate::sim::grid::Grid;
use crate::sim::step::Substep;

/// A 64×64 cloth's contacts with a sphere, resolved in one pass and in two
/// halves on two threads: the same positions, velocities and counts.
#[test]
fn a_large_cloths_contacts_are_the_same_in_two_halves() {
    let pose = Isometry3d::from_translation(Vec3::new(0.0, 1.0, 0.0));
    let scene = ColliderScene {
        colliders: vec![SceneCollider::new(
            ColliderKey(0),
            ColliderShape::Analytic(Shape::Sphere { radius: 0.3 }),
            pose,
            pose,
        )],
    };
    let n = 64usize;
    assert!(n * n >= SPLIT_PARTICLES);
    // A sheet 1 cm above the sphere's top moving 3 cm down in the substep:
    // its middle ends inside, its edges stay clear.
    let start: Vec<Vec3> = (0..n * n)
        .map(|i| {
            let (u, w) = ((i % n) as f32 / 63.0 - 0.5, (i / n) as f32 / 63.0 - 0.5);
            Vec3::new(u, 1.31, w)
        })
        .collect();
    let end: Vec<Vec3> = start
        .iter()
        .map(|p| *p - Vec3::new(0.0, 0.03, 0.0))
        .collect();
    let inverse_masses = vec![1.0; n * n];
    let sub = Substep {
        from: 0.0,
        to: 1.0,
        dt: 1.0 / 60.0,
    };
    let run = |helper: bool| {
        let (mut x, mut v) = (end.clone(), vec![Vec3::new(0.0, -1.8, 0.0); n * n]);
        let (counts, _) = resolve_substep(
            &scene,
            &[0],
            (0.005, helper),
            None::<(&Grid, f32, &mut SelfCollisionBuffers)>,
            sub,
            &start,
            &mut x,
            &mut v,
            &inverse_masses,
        );
        (x, v, counts)
    };
    let (x1, v1, one) = run(false);
    let (x2, v2, two) = run(true);
    assert!(
        one.contacts > 100 && one.contacts < (n * n) as u32 / 2,
        "{one:?}"
    );
    assert_eq!((one.tests, one.contacts), (two.tests, two.contacts));
    let bits = |p: &[Vec3]| {
        p.iter()
            .flat_map(|q| q.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&x1), bits(&x2));
    assert_eq!(bits(&v1), bits(&v2));
}
