//! Timing cloths against each other: the runner trait, this crate's
//! cloth in the two comparison scenes (hanging at rest, and falling and
//! swinging), an empty app, the turns, the summary and the strain the
//! comparison benches print.

#![allow(dead_code, reason = "each comparison bench uses the part it needs")]

use std::time::Instant;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cloth::prelude::*;

/// One cloth being stepped frame by frame.
pub trait Runner {
    /// One 1/60 s frame.
    fn frame(&mut self);
    /// Largest structural strain now.
    fn strain(&self) -> f32;
}

/// The largest `ℓ/L − 1` over the links along an `n × n` grid of spacing
/// `h` m (particles in rows or columns of `n`, at `x(p)`).
pub fn structural_strain(n: usize, h: f32, x: impl Fn(usize) -> Vec3) -> f32 {
    let mut worst = 0.0f32;
    for j in 0..n {
        for i in 0..n {
            let p = j * n + i;
            if i + 1 < n {
                worst = worst.max(x(p).distance(x(p + 1)) / h - 1.0);
            }
            if j + 1 < n {
                worst = worst.max(x(p).distance(x(p + n)) / h - 1.0);
            }
        }
    }
    worst
}

/// The comparison scenes of a 1 m N × N cloth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scene {
    /// Standing in a vertical plane, pinned at its two top corners, let go
    /// flat at rest: it hangs still (the easy case).
    Hanging,
    /// Laid horizontal at 1 m, pinned at the two corners of one edge, let
    /// go: it falls and swings (the case a player sees).
    Motion,
}

/// A headless App with no cloth and no cloth plugin: what a frame costs
/// before any cloth work.
pub struct Empty(App);

impl Empty {
    pub fn new() -> Self {
        let mut app = App::new();
        app.add_plugins(MinimalPlugins)
            .insert_resource(Time::<Fixed>::from_hz(60.0))
            .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
        app.update();
        Self(app)
    }
}

impl Runner for Empty {
    fn frame(&mut self) {
        self.0.update();
    }

    fn strain(&self) -> f32 {
        0.0
    }
}

/// This crate, with its defaults but sleep, in a headless App.
pub struct Ours {
    app: App,
    cloth: Entity,
    n: usize,
}

impl Ours {
    pub fn new(n: usize) -> Self {
        // Sleep off: the cloth steps every frame, as the engines it is
        // compared with do, even once it hangs at rest.
        let mut settings = SimSettings::default();
        settings.sleep.enabled = false;
        Self::with_settings(n, settings)
    }

    /// The same cloth with `settings` as the defaults.
    pub fn with_settings(n: usize, settings: SimSettings) -> Self {
        Self::in_scene(n, Scene::Hanging, settings)
    }

    /// A headless app (`MinimalPlugins`, `ClothPlugin`) that steps at
    /// 60 Hz, one fixed step a frame, with `settings` as the defaults.
    pub fn app(settings: SimSettings) -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, ClothPlugin::default()))
            .insert_resource(Time::<Fixed>::from_hz(60.0))
            .insert_resource(TimeUpdateStrategy::FixedTimesteps(1))
            .insert_resource(ClothSettingsDefaults(settings));
        app
    }

    /// The cloth of `scene` with `settings` as the defaults.
    pub fn in_scene(n: usize, scene: Scene, settings: SimSettings) -> Self {
        let mut app = Self::app(settings);
        let builder = ClothBuilder::new(n as u32, n as u32).size(1.0, 1.0);
        let cloth = match scene {
            Scene::Hanging => builder
                .position(Vec3::new(0.0, 1.5, 0.0))
                .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
                .pin_corner(GridCorner::TopLeft)
                .pin_corner(GridCorner::TopRight),
            Scene::Motion => builder
                .position(Vec3::new(0.0, 1.0, 0.0))
                .pin(0)
                .pin(n as u32 - 1),
        };
        let cloth = app.world_mut().spawn(cloth.build().expect("valid")).id();
        app.update();
        Self { app, cloth, n }
    }

    /// The cloth `cloth` of `n × n` particles already spawned in `app`,
    /// stepped once.
    pub fn in_app(mut app: App, cloth: Entity, n: usize) -> Self {
        app.update();
        Self { app, cloth, n }
    }

    /// The implicit solve's iterations in the last step.
    pub fn iterations(&self) -> u32 {
        let stats = self.app.world().get::<ClothStats>(self.cloth);
        stats.map_or(0, |s| s.solver_iterations)
    }
}

impl Runner for Ours {
    fn frame(&mut self) {
        self.app.update();
    }

    fn strain(&self) -> f32 {
        let x = &self
            .app
            .world()
            .get::<ClothParticles>(self.cloth)
            .unwrap()
            .positions;
        structural_strain(self.n, 1.0 / (self.n - 1) as f32, |p| x[p])
    }
}

/// Median, least and largest of `ms`.
pub fn summary(ms: &mut [f64]) -> (f64, f64, f64) {
    ms.sort_by(f64::total_cmp);
    (ms[ms.len() / 2], ms[0], ms[ms.len() - 1])
}

/// Times `frames` frames of each runner, in turns of `block` frames.
pub fn race(runners: &mut [&mut dyn Runner], frames: usize, block: usize) -> Vec<Vec<f64>> {
    let mut times = vec![Vec::with_capacity(frames); runners.len()];
    while times[0].len() < frames {
        for (r, t) in runners.iter_mut().zip(&mut times) {
            for _ in 0..block {
                let start = Instant::now();
                r.frame();
                t.push(start.elapsed().as_secs_f64() * 1e3);
            }
        }
    }
    times
}

/// The sizes named on the command line (at least 3), or `default`.
pub fn sizes(default: &[usize]) -> Vec<usize> {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .filter(|&n| n >= 3)
        .collect();
    if sizes.is_empty() {
        default.to_vec()
    } else {
        sizes
    }
}
