//! Pins with owners in an app: a grab, an anchor, the builder and the game
//! each let go of their own pin only.

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::{app, hanging, particles};

fn grabs(app: &mut App, e: Entity) -> Mut<'_, ClothGrabs> {
    app.world_mut().get_mut::<ClothGrabs>(e).unwrap()
}

fn particles_mut(app: &mut App, e: Entity) -> Mut<'_, ClothParticles> {
    app.world_mut().get_mut::<ClothParticles>(e).unwrap()
}

fn run(app: &mut App, frames: usize) {
    for _ in 0..frames {
        app.update();
    }
}

/// The free bottom-right corner of the hanging cloth; particle 0 is its
/// top-left corner, pinned by the builder.
const CORNER: usize = 224;
const PINNED: usize = 0;

#[test]
fn a_released_grab_leaves_the_game_s_pin_in_place() {
    let mut app = app();
    let cloth = app.world_mut().spawn(hanging(15)).id();
    run(&mut app, 30);
    let start = particles(&app, cloth).positions[CORNER];
    grabs(&mut app, cloth).grab(CORNER as u32, start, GrabMode::Kinematic);
    for k in 1..=10 {
        let target = start + Vec3::Z * 0.02 * k as f32;
        grabs(&mut app, cloth).set_target(CORNER as u32, target);
        app.update();
    }
    // While the player holds it, the game nails it where it is.
    assert!(particles_mut(&mut app, cloth).pin(CORNER));
    grabs(&mut app, cloth).release(CORNER as u32);
    app.update();
    let here = particles(&app, cloth).positions[CORNER];
    run(&mut app, 30);
    let p = particles(&app, cloth);
    assert!(p.is_pinned_by(CORNER, PinOwner::Game));
    assert!(!p.is_pinned_by(CORNER, PinOwner::Grab));
    assert_eq!(p.positions[CORNER], here, "the game's pin holds");
    assert_eq!(p.velocities[CORNER], Vec3::ZERO);
}

#[test]
fn a_builder_pin_grabbed_and_released_stays_pinned_at_rest_where_it_was_left() {
    let mut app = app();
    let cloth = app.world_mut().spawn(hanging(15)).id();
    run(&mut app, 10);
    let start = particles(&app, cloth).positions[PINNED];
    grabs(&mut app, cloth).grab(PINNED as u32, start, GrabMode::Kinematic);
    let goal = start + Vec3::new(0.0, 0.0, 0.2);
    for k in 1..=12 {
        grabs(&mut app, cloth).set_target(PINNED as u32, start.lerp(goal, k as f32 / 12.0));
        app.update();
    }
    grabs(&mut app, cloth).release(PINNED as u32);
    run(&mut app, 30);
    let p = particles(&app, cloth);
    assert!(p.is_pinned_by(PINNED, PinOwner::Builder));
    assert!(
        p.positions[PINNED].distance(goal) < 1e-5,
        "{}",
        p.positions[PINNED]
    );
    assert_eq!(p.velocities[PINNED], Vec3::ZERO);
}

/// The hanging cloth with its free corner and its builder-pinned corner
/// anchored to a hand that moves 0.3 m/s along +Z for 0.5 s; then the
/// anchors are let go, by `detach` or by removing the component.
fn anchored_then_let_go(remove: bool) -> (ClothParticles, Vec3) {
    let mut app = app();
    let cloth = app.world_mut().spawn(hanging(15)).id();
    run(&mut app, 30);
    let hand = app.world_mut().spawn(Transform::default()).id();
    let anchors = ClothAnchors::default()
        .with(CORNER as u32, hand)
        .with(PINNED as u32, hand);
    app.world_mut().entity_mut(cloth).insert(anchors);
    for _ in 0..30 {
        app.world_mut()
            .get_mut::<Transform>(hand)
            .unwrap()
            .translation
            .z += 0.3 / 60.0;
        app.update();
    }
    let held = particles(&app, cloth).positions[CORNER];
    if remove {
        app.world_mut().entity_mut(cloth).remove::<ClothAnchors>();
    } else {
        let mut anchors = app.world_mut().get_mut::<ClothAnchors>(cloth).unwrap();
        anchors.detach(CORNER as u32);
        anchors.detach(PINNED as u32);
    }
    run(&mut app, 30);
    (particles(&app, cloth).clone(), held)
}

#[test]
fn an_anchor_let_go_frees_its_particle_and_leaves_the_builder_s_pin() {
    for remove in [false, true] {
        let (p, held) = anchored_then_let_go(remove);
        // Free, the corner swings back under the cloth's top edge.
        assert!(!p.is_pinned(CORNER), "removed {remove}");
        assert!(
            p.positions[CORNER].distance(held) > 0.05,
            "removed {remove}: {} from {held}",
            p.positions[CORNER]
        );
        assert!(
            p.is_pinned_by(PINNED, PinOwner::Builder),
            "removed {remove}"
        );
        assert!(
            !p.is_pinned_by(PINNED, PinOwner::Anchor),
            "removed {remove}"
        );
        assert_eq!(p.velocities[PINNED], Vec3::ZERO, "removed {remove}");
        assert!(p.is_finite());
    }
}

/// A small deterministic generator (xorshift), so the churn is the same
/// every run.
struct Dice(u64);

impl Dice {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n as u64) as usize
    }
}

#[test]
fn a_thousand_grabs_releases_pins_and_unpins_leave_each_owner_s_pin() {
    let mut app = app();
    let cloth = app.world_mut().spawn(hanging(15)).id();
    run(&mut app, 10);
    // The particles played with: both builder-pinned top corners, the
    // free bottom corners and two in the middle.
    let played = [0, 14, 210, 224, 112, 97];
    let builder = |i: usize| i == 0 || i == 14;
    let mut game = [false; 6];
    let mut held = [false; 6];
    let mut dice = Dice(0x9e37_79b9_7f4a_7c15);
    for turn in 0..1000 {
        let k = dice.below(played.len());
        let i = played[k];
        match dice.below(5) {
            0 | 1 => {
                let at = particles(&app, cloth).positions[i] + Vec3::Z * 0.01;
                grabs(&mut app, cloth).grab(i as u32, at, GrabMode::Kinematic);
                held[k] = true;
            }
            2 => {
                grabs(&mut app, cloth).release(i as u32);
                held[k] = false;
            }
            3 => {
                particles_mut(&mut app, cloth).pin(i);
                game[k] = true;
            }
            _ => {
                // A game's unpin frees the particle from every owner, but a
                // grab that still holds it pins it again at its next step.
                particles_mut(&mut app, cloth).unpin(i);
                game[k] = false;
            }
        }
        app.update();
        let p = particles(&app, cloth);
        assert!(p.is_finite(), "turn {turn}");
        for (k, &i) in played.iter().enumerate() {
            let expected =
                game[k] || held[k] || (builder(i) && p.is_pinned_by(i, PinOwner::Builder));
            assert_eq!(p.is_pinned(i), expected, "turn {turn}: particle {i}");
            assert_eq!(
                p.is_pinned_by(i, PinOwner::Grab),
                held[k],
                "turn {turn}: particle {i}"
            );
            if !p.is_pinned(i) {
                assert_eq!(p.inverse_masses[i], 1.0 / p.masses[i], "turn {turn}");
            }
        }
    }
}
