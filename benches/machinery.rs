//! `cargo bench --bench machinery`: what the implicit solve's two pieces
//! of machinery save in the scenes and at the sizes games use: its coarse
//! correction (`ImplicitSettings::coarse_grid`) and its helper thread
//! (`ImplicitSettings::helper_thread`), each measured against the
//! defaults with it off, in the same run.
//!
//! **Scenes** (1 m N × N cloths, every default, one step per 1/60 s frame,
//! a headless `App` with `MinimalPlugins` and `ClothPlugin`):
//! - **motion**: laid horizontal at 1 m, pinned at two corners of one
//!   edge, let go: it falls and swings (the comparison bench's scene);
//! - **hanging**: standing vertical, pinned at its two top corners, let go
//!   at rest; sleep off, so that it steps every frame;
//! - **drape**: let go horizontal 0.3 m above a ball of radius 0.3 m: it
//!   falls onto the ball and drapes over it.
//!
//! After 60 frames of warm-up, the three runners are timed in turns of 10
//! frames for 300 frames (120 at 256 × 256). Printed per scene and size:
//! the median and range of the ms per frame of each, the mean iterations
//! of the solve (the last step's, every 10th frame), and the share of the
//! frame each piece saves where it is on (negative: what it costs).
//!
//! `cargo bench --bench machinery -- motion 32 64` limits the scenes and
//! the sizes of the motion scene (the others run at 64 and 128).

#[path = "common/race.rs"]
mod race;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use race::{Ours, Runner, Scene, race, sizes, summary};

/// Frames before timing starts.
const WARM_UP: usize = 60;

/// Motion sizes timed unless the command line names others.
const SIZES: [usize; 5] = [15, 32, 64, 128, 256];

/// The scenes, as the command line names them.
const SCENES: [&str; 3] = ["motion", "hanging", "drape"];

/// The sizes of the hanging and draped cloths.
const OTHER_SIZES: [usize; 2] = [64, 128];

/// The runners: a name, the coarse correction, the helper thread.
const VARIANTS: [(&str, bool, bool); 3] = [
    ("default", true, true),
    ("coarse correction off", false, true),
    ("helper thread off", true, false),
];

/// The settings of one runner: every default but the coarse correction
/// and the helper thread.
fn settings(coarse: bool, helper: bool, scene: &str) -> SimSettings {
    let mut s = SimSettings::default();
    s.implicit.coarse_grid = coarse;
    s.implicit.helper_thread = helper;
    if scene == "hanging" {
        s.sleep.enabled = false;
    }
    s
}

/// The cloth of `scene` with `settings` as the defaults.
fn runner(scene: &str, n: usize, settings: SimSettings) -> Ours {
    match scene {
        "motion" => Ours::in_scene(n, Scene::Motion, settings),
        "hanging" => Ours::in_scene(n, Scene::Hanging, settings),
        _ => {
            let mut app = Ours::app(settings);
            app.world_mut().spawn((
                ClothCollider::sphere(0.3).with_friction(0.5),
                Transform::from_xyz(0.0, 1.0, 0.0),
            ));
            let cloth = ClothBuilder::new(n as u32, n as u32)
                .size(1.0, 1.0)
                .position(Vec3::new(0.0, 1.6, 0.0))
                .build()
                .expect("valid");
            let cloth = app.world_mut().spawn(cloth).id();
            Ours::in_app(app, cloth, n)
        }
    }
}

fn row(scene: &str, n: usize) {
    let frames = if n >= 256 { 120 } else { 300 };
    let mut runners: Vec<Ours> = VARIANTS
        .iter()
        .map(|&(_, coarse, helper)| runner(scene, n, settings(coarse, helper, scene)))
        .collect();
    for r in &mut runners {
        for _ in 0..WARM_UP {
            r.frame();
        }
    }
    let mut times = vec![Vec::new(); runners.len()];
    let mut iterations = vec![0u64; runners.len()];
    while times[0].len() < frames {
        let mut turn: Vec<&mut dyn Runner> =
            runners.iter_mut().map(|r| r as &mut dyn Runner).collect();
        for (all, t) in times.iter_mut().zip(race(&mut turn, 10, 10)) {
            all.extend(t);
        }
        for (k, r) in runners.iter().enumerate() {
            iterations[k] += u64::from(r.iterations());
        }
    }
    let samples = (frames / 10) as f64;
    let medians: Vec<(f64, f64, f64)> = times.iter_mut().map(|t| summary(t)).collect();
    let mut line = format!("| {scene} | {n} |");
    for (k, &(a, lo, hi)) in medians.iter().enumerate() {
        line += &format!(
            " {a:.3} ({lo:.3}–{hi:.3}) | {:.1} |",
            iterations[k] as f64 / samples
        );
        if k > 0 {
            line += &format!(" {:+.0} % |", 100.0 * (a - medians[0].0) / a);
        }
    }
    println!("{line}");
}

fn main() {
    let mut head = String::from("| scene | N × N | default: ms/frame (range) | iterations |");
    let mut rule = String::from("|---|---|---|---|");
    for (name, ..) in &VARIANTS[1..] {
        head += &format!(" {name}: ms/frame (range) | iterations | saved by the default |");
        rule += "---|---|---|";
    }
    println!("{head}\n{rule}");
    let named: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| SCENES.contains(&a.as_str()))
        .collect();
    let wanted = |scene: &str| named.is_empty() || named.iter().any(|a| a == scene);
    if wanted("motion") {
        for n in sizes(&SIZES) {
            row("motion", n);
        }
    }
    for scene in ["hanging", "drape"].into_iter().filter(|s| wanted(s)) {
        for n in OTHER_SIZES {
            row(scene, n);
        }
    }
}
