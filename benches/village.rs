//! `cargo bench --bench village`: a village of 100 banners in the wind,
//! with level of detail and sleep (the defaults) and without, against the
//! 10 banners the player is near.
//!
//! **Scene.** 100 banners of 24 × 24 particles (1 m, cotton, pinned along
//! their top edge) in a gusty 8 m/s wind, in a headless `App` with meshes
//! and one camera at the origin looking down −z (Bevy's default
//! perspective, aspect 1): 10 banners 5–14 m in front of it, 45 farther in
//! view (30–96 m), 45 behind it (out of view, 5–50 m). One `App::update`
//! is one 1/60 s frame. Three Apps are timed in turns of 20 frames after
//! 300 frames of warm-up: the village with every default, the village
//! with level of detail and sleep off, and the 10 near banners alone
//! (every default). Printed: the median and range of the ms per frame of
//! each, and the village's median over the near banners'.

mod common;
#[path = "common/race.rs"]
mod race;

use bevy::camera::{Camera, CameraProjection, PerspectiveProjection};
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::headless;
use race::{Runner, race, summary};

/// Frames timed per App.
const FRAMES: usize = 600;

/// Frames before the timing: the banners unfurl, and the far ones earn
/// their longest combined steps.
const WARM_UP: usize = 300;

/// Where the banners stand: (near, far in view, behind the camera).
fn spots() -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec3>) {
    let near = (0..10)
        .map(|k| Vec3::new(if k % 2 == 0 { -1.2 } else { 0.2 }, 0.5, -5.0 - k as f32))
        .collect();
    let far = (0..45)
        .map(|k| Vec3::new((k % 3) as f32 * 4.0 - 4.0, 0.5, -30.0 - 1.5 * k as f32))
        .collect();
    let behind = (0..45)
        .map(|k| Vec3::new((k % 3) as f32 * 2.0 - 2.0, 0.5, 5.0 + k as f32))
        .collect();
    (near, far, behind)
}

/// A village of banners at `at`, with level of detail and sleep `on`.
struct Village {
    app: App,
    banners: Vec<Entity>,
}

impl Village {
    fn new(at: &[Vec3], on: bool) -> Self {
        let mut settings = ClothSettings::default();
        settings.sleep.enabled = on;
        let mut app = headless(settings);
        app.world_mut().resource_mut::<ClothLodDefaults>().0.enabled = on;
        app.insert_resource(ClothWind(Wind {
            velocity: Vec3::new(8.0, 0.0, 1.0),
            gust_amplitude: 0.4,
            gust_frequency: 0.7,
            ..default()
        }));
        let eye = Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(0.0, 1.0, -1.0), Vec3::Y);
        let global = GlobalTransform::from(eye);
        let frustum = PerspectiveProjection::default().compute_frustum(&global);
        app.world_mut()
            .spawn((Camera::default(), eye, global, frustum));
        let banners = at
            .iter()
            .map(|&x| {
                let banner = ClothBuilder::new(24, 24)
                    .size(1.0, 1.0)
                    .position(x + Vec3::Y)
                    .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
                    .pin_edge(GridEdge::Top)
                    .build()
                    .expect("valid");
                app.world_mut().spawn(banner).id()
            })
            .collect();
        let mut village = Self { app, banners };
        for _ in 0..WARM_UP {
            village.frame();
        }
        village
    }

    /// Banners at each level now: full, reduced, frozen.
    fn levels(&self) -> [usize; 3] {
        let mut count = [0; 3];
        for &e in &self.banners {
            let detail = self.app.world().get::<ClothDetail>(e).expect("a banner");
            count[match detail.detail() {
                Detail::Full => 0,
                Detail::Every(_) => 1,
                Detail::Frozen => 2,
            }] += 1;
        }
        count
    }
}

impl Runner for Village {
    fn frame(&mut self) {
        self.app.update();
    }

    fn strain(&self) -> f32 {
        self.banners
            .iter()
            .filter_map(|&e| self.app.world().get::<ClothStats>(e))
            .map(|s| s.max_strain)
            .fold(0.0, f32::max)
    }
}

fn main() {
    let (near, far, behind) = spots();
    let all: Vec<Vec3> = [&near[..], &far, &behind].concat();
    let mut village = Village::new(&all, true);
    let mut off = Village::new(&all, false);
    let mut alone = Village::new(&near, true);
    let [full, reduced, frozen] = village.levels();
    println!("Banners with level of detail: {full} full, {reduced} reduced, {frozen} frozen.");
    let mut times = race(&mut [&mut village, &mut off, &mut alone], FRAMES, 20);
    let strains = [village.strain(), off.strain(), alone.strain()];
    let (v, v_lo, v_hi) = summary(&mut times[0]);
    let (o, o_lo, o_hi) = summary(&mut times[1]);
    let (a, a_lo, a_hi) = summary(&mut times[2]);
    println!("| scene | ms per frame (median, range) | largest strain |");
    println!("|---|---|---|");
    println!(
        "| 100 banners, LOD and sleep | {v:.2} ({v_lo:.2}–{v_hi:.2}) | {:.1} % |",
        100.0 * strains[0]
    );
    println!(
        "| 100 banners, LOD and sleep off | {o:.2} ({o_lo:.2}–{o_hi:.2}) | {:.1} % |",
        100.0 * strains[1]
    );
    println!(
        "| the 10 near banners alone | {a:.2} ({a_lo:.2}–{a_hi:.2}) | {:.1} % |",
        100.0 * strains[2]
    );
    println!(
        "Village with LOD and sleep / 10 near banners: {:.2}×; without: {:.2}×.",
        v / a,
        o / a
    );
}
