//! A cloth in motion at any resolution, with every default: the scene of
//! `cargo bench --bench motion` (a 1 m cotton sheet let go horizontal,
//! pinned at two corners, falling and swinging for 3 s), asserting what
//! is deterministic — iteration counts and strain — rather than times.

mod common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::app;

/// Frames of 1/60 s: 3 s.
const FRAMES: usize = 180;

/// What a run of the scene at `n`×`n` left: the solve's iterations in each
/// frame, the iteration cap, and the largest Type 1 strain (dimensionless)
/// seen after any frame.
fn swing(n: u32) -> (Vec<u32>, u32, f32) {
    let mut app = app();
    let cloth = ClothBuilder::new(n, n)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .unwrap();
    let e = app.world_mut().spawn(cloth).id();
    let cap = app
        .world()
        .resource::<ClothDefaults>()
        .0
        .implicit
        .max_iterations;
    let (mut iterations, mut strain) = (Vec::with_capacity(FRAMES), 0.0_f32);
    for frame in 0..FRAMES {
        app.update();
        let stats = app.world().get::<ClothStats>(e).unwrap();
        assert!(stats.finite, "{n}×{n} blew up in frame {frame}");
        iterations.push(stats.solver_iterations);
        strain = strain.max(stats.max_strain);
    }
    (iterations, cap, strain)
}

#[test]
fn a_swinging_sheets_solve_does_not_grow_with_its_resolution() {
    let mean = |k: &[u32]| k.iter().sum::<u32>() as f32 / k.len() as f32;
    let (coarse, cap, coarse_strain) = swing(64);
    let (fine, _, fine_strain) = swing(256);
    let (at_64, at_256) = (mean(&coarse), mean(&fine));
    eprintln!(
        "mean iterations {at_64:.1} at 64×64, {at_256:.1} at 256×256 (most {} and {}); \
         strain {:.2} % and {:.2} %",
        coarse.iter().max().unwrap(),
        fine.iter().max().unwrap(),
        100.0 * coarse_strain,
        100.0 * fine_strain
    );
    assert!(
        at_256 <= 1.5 * at_64,
        "{at_256:.1} iterations a frame at 256×256 against {at_64:.1} at 64×64"
    );
    for (n, run) in [(64, &coarse), (256, &fine)] {
        let capped: Vec<usize> = (0..FRAMES).filter(|&f| run[f] >= cap).collect();
        assert!(capped.is_empty(), "{n}×{n}: frames {capped:?} at the cap");
    }
    // The default strain limit, 5 %, holds at both resolutions.
    for (n, strain) in [(64, coarse_strain), (256, fine_strain)] {
        assert!(strain <= 0.05 + 1e-4, "{n}×{n} strained {strain}");
    }
}
