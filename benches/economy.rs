//! `cargo bench --bench economy`: what `ClothPlugin` costs a frame where a
//! scene calls for little of it: no cloth at all, one cloth asleep, and a
//! cloth in motion with each member of the plugin group that the scene
//! does not use left in or left out.
//!
//! **Runners**, each a headless `App` (`MinimalPlugins`, one fixed step
//! of 1/60 s per `App::update`):
//! - **empty app**: `MinimalPlugins` alone;
//! - **no cloth**: with `ClothPlugin`;
//! - **asleep**: with `ClothPlugin` and a 32 × 32 sheet resting on a floor
//!   (`ClothCollider::plane`), asleep (the default sleep);
//! - **awake**: with `ClothPlugin` and the comparison bench's 15 × 15
//!   sheet (let go horizontal, pinned at two corners of an edge), sleep
//!   off, so that it steps every frame; no wind, tear, crease, anchor,
//!   skin, tether, inertia, grab, camera, collider or other cloth;
//! - **awake without X**: the same, with the member X disabled
//!   (`ClothPlugin::default().build().disable::<X>()`).
//!
//! After 60 frames of warm-up (the asleep runner first runs until its sheet
//! sleeps), the runners are timed in turns of 10 frames for 3000 frames
//! each. Printed: the median and range of the ms per frame, and the median
//! over the runner it is compared with (the empty app, no cloth, or the
//! awake cloth with every member): a member the scene does not use costs
//! nothing, so leaving it out saves nothing.

#[path = "common/race.rs"]
mod race;

use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cloth::plugin::{
    ClothCollisionPlugin, ClothCreasePlugin, ClothDiagnosticsPlugin, ClothInteractionPlugin,
    ClothLodPlugin, ClothTearingPlugin, ClothWindPlugin, ClothWornPlugin,
};
use bevy_cloth::prelude::*;
use race::{Empty, Runner, race, summary};

/// Frames timed per runner.
const FRAMES: usize = 3000;

/// A headless App, stepped a frame at a time.
struct Frames(App);

impl Runner for Frames {
    fn frame(&mut self) {
        self.0.update();
    }

    fn strain(&self) -> f32 {
        0.0
    }
}

/// A headless App with `plugins` and one fixed step per update.
fn app(plugins: PluginGroupBuilder) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, plugins))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app
}

/// The 15 × 15 sheet, sleep off, with `plugins`.
fn awake(plugins: PluginGroupBuilder) -> Frames {
    let mut app = app(plugins);
    let mut settings = SimSettings::default();
    settings.sleep.enabled = false;
    app.insert_resource(ClothSettingsDefaults(settings));
    let cloth = ClothBuilder::new(15, 15)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin(0)
        .pin(14)
        .build()
        .expect("valid");
    app.world_mut().spawn(cloth);
    Frames(app)
}

/// A 32 × 32 sheet asleep on a floor.
fn asleep() -> Frames {
    let mut app = app(ClothPlugin::default().build());
    app.world_mut().spawn((
        ClothCollider::plane().with_friction(0.8),
        Transform::default(),
    ));
    let cloth = ClothBuilder::new(32, 32)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 0.01, 0.0))
        .build()
        .expect("valid");
    let cloth = app.world_mut().spawn(cloth).id();
    for _ in 0..1200 {
        app.update();
        if app
            .world()
            .get::<ClothSleep>(cloth)
            .is_some_and(|s| s.is_asleep())
        {
            return Frames(app);
        }
    }
    panic!("the sheet did not fall asleep in 20 s");
}

fn main() {
    let every = || ClothPlugin::default().build();
    let mut runners: Vec<(String, Box<dyn Runner>, usize)> = vec![
        ("empty app".into(), Box::new(Empty::new()), 0),
        ("no cloth".into(), Box::new(Frames(app(every()))), 0),
        ("one 32×32 cloth asleep".into(), Box::new(asleep()), 1),
        ("one 15×15 cloth awake".into(), Box::new(awake(every())), 0),
    ];
    let base = runners.len() - 1;
    let without: [(&str, PluginGroupBuilder); 8] = [
        ("collision", every().disable::<ClothCollisionPlugin>()),
        ("wind", every().disable::<ClothWindPlugin>()),
        ("creases", every().disable::<ClothCreasePlugin>()),
        (
            "tearing and sewing",
            every().disable::<ClothTearingPlugin>(),
        ),
        ("worn cloth", every().disable::<ClothWornPlugin>()),
        ("level of detail", every().disable::<ClothLodPlugin>()),
        ("interaction", every().disable::<ClothInteractionPlugin>()),
        ("diagnostics", every().disable::<ClothDiagnosticsPlugin>()),
    ];
    for (name, plugins) in without {
        runners.push((format!("… without {name}"), Box::new(awake(plugins)), base));
    }
    for (_, r, _) in &mut runners {
        for _ in 0..60 {
            r.frame();
        }
    }
    let mut times = vec![Vec::with_capacity(FRAMES); runners.len()];
    while times[0].len() < FRAMES {
        let mut turn: Vec<&mut dyn Runner> = runners
            .iter_mut()
            .map(|(_, r, _)| -> &mut dyn Runner { r.as_mut() })
            .collect();
        for (all, t) in times.iter_mut().zip(race(&mut turn, 10, 10)) {
            all.extend(t);
        }
    }
    let medians: Vec<(f64, f64, f64)> = times.iter_mut().map(|t| summary(t)).collect();
    println!("| runner | ms/frame (range) | over |");
    println!("|---|---|---|");
    for (k, (name, _, against)) in runners.iter().enumerate() {
        let (m, lo, hi) = medians[k];
        let over = if k == 0 {
            "–".to_string()
        } else {
            let against = if k == *against { 0 } else { *against };
            format!("{:+.3} ms ({})", m - medians[against].0, runners[against].0)
        };
        println!("| {name} | {m:.3} ({lo:.3}–{hi:.3}) | {over} |");
    }
}
