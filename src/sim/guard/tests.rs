//! The guard's limits and the relaxing of its boost.

use super::state::{MAX_BACKOFF, RELAX_AFTER, RELAX_AFTER_FIXED};
use super::*;
use crate::sim::connections::Link;

#[test]
fn a_trip_counts_only_beyond_the_start_and_what_pins_in_motion_can_cause() {
    let mut connections = Connections::default();
    connections.structural.push(Link {
        a: 0,
        b: 1,
        rest_length: 0.5,
    });
    let guard = GuardSettings::default();
    let limits = |len: f32, speed: f32, pin_speed: f32| {
        let x = [Vec3::ZERO, Vec3::X * len];
        let v = [Vec3::Z * pin_speed, Vec3::Y * speed];
        Limits::new((&x, &v, &[0.0, 1.0]), &connections, &guard, 0.1)
    };
    // Started within the bounds (strain 10 %, 1 m/s), pins still: every
    // trip counts.
    let calm = limits(0.55, 1.0, 0.0);
    assert!(calm.exceeded(Divergence::Strain(3.1)));
    assert!(calm.exceeded(Divergence::Speed(201.0)));
    assert!(calm.exceeded(Divergence::NonFinite));
    assert!(calm.exceeded(Divergence::NonFiniteInput));
    // Started over-stretched (strain 4) and fast (300 m/s): staying or
    // relaxing is not a divergence, growing 1.5× is.
    let wild = limits(2.5, 300.0, 0.0);
    assert!(!wild.exceeded(Divergence::Strain(4.0)));
    assert!(wild.exceeded(Divergence::Strain(6.5)));
    assert!(!wild.exceeded(Divergence::Speed(350.0)));
    assert!(wild.exceeded(Divergence::Speed(460.0)));
    // A pin carried at 50 m/s moves 5 m in the 0.1 s step: it may
    // stretch the 0.5 m link by 10 more and drag it to 100 m/s.
    let yanked = limits(0.55, 1.0, 50.0);
    assert!((yanked.strain - 13.0).abs() < 1e-4, "{yanked:?}");
    assert!(!yanked.exceeded(Divergence::Strain(12.0)));
    assert!(yanked.exceeded(Divergence::Strain(14.0)));
    assert_eq!(yanked.speed, 200.0);
    let flung = limits(0.55, 1.0, 150.0);
    assert_eq!(flung.speed, 300.0);
}

#[test]
fn an_adaptive_boost_halves_every_few_clean_steps_down_to_the_floor() {
    let se = Integrator::SymplecticEuler;
    let mut state = GuardState {
        boost: Some((64, se)),
        ..GuardState::default()
    };
    let mut seen = Vec::new();
    for _ in 0..5 * RELAX_AFTER {
        state.relax(se, 10, true);
        seen.push(state.boost.map(|(s, _)| s));
    }
    let at = |k: u32| seen[(k * RELAX_AFTER - 1) as usize];
    assert_eq!(seen[0], Some(64));
    assert_eq!([at(1), at(2), at(3)], [Some(32), Some(16), None]);
    // A fallback integrator ends at once after the clean steps.
    state.boost = Some((40, Integrator::BackwardEuler));
    for _ in 0..RELAX_AFTER {
        state.relax(se, 10, true);
    }
    assert_eq!(state.boost, None);
}

#[test]
fn a_fixed_boost_relaxes_later_after_every_trip() {
    let be = Integrator::BackwardEuler;
    // Clean steps until a boost of 4 substeps over a floor of 1 halves.
    let wait = |trips: u32| {
        let mut state = GuardState {
            boost: Some((4, be)),
            trips,
            ..GuardState::default()
        };
        (1..)
            .find(|_| {
                state.relax(be, 1, false);
                state.boost != Some((4, be))
            })
            .unwrap()
    };
    assert_eq!(wait(1), RELAX_AFTER_FIXED);
    assert_eq!(wait(2), 2 * RELAX_AFTER_FIXED);
    assert_eq!(wait(4), 8 * RELAX_AFTER_FIXED);
    assert_eq!(wait(400), RELAX_AFTER_FIXED << MAX_BACKOFF);
}
