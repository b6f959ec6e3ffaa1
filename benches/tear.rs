//! `cargo bench --bench tear`: what tearing costs. A frame of a banner
//! whole, with tearing on (the threshold check each step), and cut into 20
//! pieces; and the time of one cut (the topology edit, the links' rebuild
//! and the new render mesh).
//!
//! **Scene.** An N × N, 1 m cotton banner hanging from its top edge at
//! y = 2 m over a floor (`ClothCollider::plane`), in a gusty 6 m/s wind,
//! sleep off (every cloth steps), in a headless `App` with meshes: one
//! `App::update` is one 1/60 s frame with the mesh sync. The torn banner is
//! cut by 3 vertical and 4 horizontal blades into 20 pieces at its first
//! frame (its top row of 4 still hangs, the rest fall to the floor) and
//! left 5 s before the timing. The Apps are timed in turns of 20 frames so
//! that all see the same state of a shared, noisy machine. Printed per size: the median and
//! range of the ms per frame of each, and of the frame in which the banner
//! is cut in 20 pieces (9 fresh banners); and the implicit solve's mean and
//! largest iteration count over the second after the cut, and the frames of
//! it that stopped at the iteration cap.
//!
//! `cargo bench --bench tear -- 32 64` limits the sizes.

mod common;
#[path = "common/race.rs"]
mod race;

use std::time::Instant;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::wind::Wind;
use common::headless;
use race::{Runner, race, sizes, summary};

/// The sizes timed unless the command line names others.
const SIZES: [usize; 2] = [32, 64];

/// Frames timed per App.
const FRAMES: usize = 400;

struct Banner {
    app: App,
    cloth: Entity,
    /// How long the frame of its cut took, ms.
    cut_ms: f64,
    /// The implicit solve's iterations in each frame of the second after
    /// the cut (of the frame's last solve).
    fall: Vec<u32>,
}

impl Banner {
    /// A banner, with tearing on or not, and cut into 20 pieces at its
    /// first frame or not; then left to blow for a second.
    fn new(n: usize, tearing: bool, cut: bool) -> Self {
        let mut settings = ClothSettings::default();
        settings.sleep.enabled = false;
        let mut app = headless(settings);
        app.insert_resource(ClothWind(Wind {
            velocity: Vec3::new(0.0, 0.0, 6.0),
            gust_amplitude: 0.5,
            gust_frequency: 0.7,
            ..default()
        }));
        app.world_mut().spawn((
            ClothCollider::plane().with_friction(0.6),
            Transform::default(),
        ));
        let banner = ClothBuilder::new(n as u32, n as u32)
            .size(1.0, 1.0)
            .position(Vec3::new(0.0, 1.5, 0.0))
            .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
            .pin_edge(GridEdge::Top)
            .build()
            .expect("a valid banner");
        let cloth = app.world_mut().spawn(banner).id();
        if tearing {
            app.world_mut()
                .entity_mut(cloth)
                .insert(ClothTearing::default());
        }
        app.update();
        let mut banner = Self {
            app,
            cloth,
            cut_ms: 0.0,
            fall: Vec::new(),
        };
        if cut {
            banner.cut_ms = 1e3 * banner.cut();
            assert_eq!(banner.pieces(), 20, "the cuts leave 20 pieces");
        }
        for _ in 0..60 {
            banner.frame();
            if cut {
                let stats = banner.app.world().get::<ClothStats>(cloth);
                banner.fall.push(stats.map_or(0, |s| s.solver_iterations));
            }
        }
        banner
    }

    /// Cuts the banner into 20 pieces; returns the seconds the cut took.
    fn cut(&mut self) -> f64 {
        let depth = Vec3::Z * 2.0;
        for x in [-0.25, 0.0, 0.25] {
            self.app.world_mut().write_message(ClothCut::along(
                Some(self.cloth),
                Vec3::new(x, 0.5, 0.0),
                Vec3::new(x, 2.5, 0.0),
                depth,
            ));
        }
        for y in [1.8, 1.6, 1.4, 1.2] {
            self.app.world_mut().write_message(ClothCut::along(
                Some(self.cloth),
                Vec3::new(-1.0, y, 0.0),
                Vec3::new(1.0, y, 0.0),
                depth,
            ));
        }
        let start = Instant::now();
        self.frame();
        start.elapsed().as_secs_f64()
    }

    /// The pieces the banner is in: its particles joined by links.
    fn pieces(&self) -> usize {
        let world = self.app.world();
        let n = world
            .get::<ClothParticles>(self.cloth)
            .expect("a cloth")
            .len();
        let links = world.get::<ClothConnections>(self.cloth).expect("a cloth");
        let pieces = links.pieces(n);
        pieces.iter().max().map_or(0, |&m| m as usize + 1)
    }
}

impl Runner for Banner {
    fn frame(&mut self) {
        self.app.update();
    }

    fn strain(&self) -> f32 {
        self.app
            .world()
            .get::<ClothStats>(self.cloth)
            .map_or(f32::NAN, |s| s.max_strain)
    }
}

fn main() {
    println!(
        "| N×N | whole ms (median, range) | whole, tearing on | cut in 20 pieces | the frame of a cut ms (median, range) | the pieces' first second: mean / most iterations, at the cap |"
    );
    println!("|---|---|---|---|---|---|");
    for n in sizes(&SIZES) {
        let mut whole = Banner::new(n, false, false);
        let mut tearing = Banner::new(n, true, false);
        let mut torn = Banner::new(n, false, true);
        for _ in 0..240 {
            torn.frame();
        }
        // The frame of a cut, on banners that have just been hung.
        let mut cuts: Vec<f64> = (0..9).map(|_| Banner::new(n, false, true).cut_ms).collect();
        let mut times = race(&mut [&mut whole, &mut tearing, &mut torn], FRAMES, 20);
        assert!(
            tearing.pieces() == 1,
            "the banner with tearing on stays whole in the wind"
        );
        let (w, w_lo, w_hi) = summary(&mut times[0]);
        let (t, t_lo, t_hi) = summary(&mut times[1]);
        let (p, p_lo, p_hi) = summary(&mut times[2]);
        let (c, c_lo, c_hi) = summary(&mut cuts);
        let cap = ImplicitSettings::default().max_iterations;
        let mean = torn.fall.iter().sum::<u32>() as f64 / torn.fall.len() as f64;
        let most = torn.fall.iter().max().copied().unwrap_or(0);
        let capped = torn.fall.iter().filter(|&&k| k >= cap).count();
        println!(
            "| {n}×{n} | {w:.3} ({w_lo:.3}–{w_hi:.3}) | {t:.3} ({t_lo:.3}–{t_hi:.3}) | {p:.3} ({p_lo:.3}–{p_hi:.3}) | {c:.2} ({c_lo:.2}–{c_hi:.2}) | {mean:.1} / {most}, {capped} |"
        );
    }
}
