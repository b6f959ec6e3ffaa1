//! `cargo bench --bench cloths`: what collision between cloths costs. Two
//! scenes, each timed with `ClothToClothCollision` on, off, and off with
//! each cloth's self-collision on instead (the same triangles tested):
//!
//! - **Stack**: two free N × N, 1.2 m cotton sheets dropped over a ball
//!   (r 0.3 m) on a floor, the second (layer 1) onto the first, left 3 s to
//!   settle before the timing.
//! - **Flags**: a 17 × 11 cotton flag and a 13 × 9 silk one (layer 1) on
//!   one pole, 6 cm apart, in a 15 m/s storm with ±50 % gusts, left 1 s.
//!
//! Sleep is off (every cloth steps), in a headless `App` with meshes: one
//! `App::update` is one 1/60 s frame. The Apps are timed in turns of 20
//! frames so that all see the same state of a shared, noisy machine.
//! Printed: the median and range of the ms per frame of each, and the extra
//! cost of collision between cloths over the extra cost of self-collision.
//!
//! `cargo bench --bench cloths -- 20 32` limits the stack's sizes.

mod common;
#[path = "common/race.rs"]
mod race;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::wind::Wind;
use common::headless;
use race::{Runner, race, sizes, summary};

/// The stack's sizes timed unless the command line names others.
const SIZES: [usize; 2] = [20, 32];

/// Frames timed per App.
const FRAMES: usize = 300;

/// How the cloths of a scene meet.
#[derive(Clone, Copy, PartialEq)]
enum Meeting {
    /// `ClothToClothCollision` on every cloth.
    Cloths,
    /// Nothing between cloths.
    Off,
    /// Each cloth's self-collision instead.
    Themselves,
}

struct Scene {
    app: App,
    cloths: Vec<Entity>,
}

impl Scene {
    fn app() -> App {
        let mut settings = ClothSettings::default();
        settings.sleep.enabled = false;
        headless(settings)
    }

    /// Spawns `cloth` in `layer`, meeting the others as `meeting` says.
    fn spawn(&mut self, cloth: ClothBundle, layer: i32, meeting: Meeting) {
        let mut e = self.app.world_mut().spawn(cloth);
        match meeting {
            Meeting::Cloths => {
                e.insert(ClothToClothCollision { layer, ..default() });
            }
            Meeting::Themselves => {
                e.insert(ClothSelfCollision { thickness: 0.01 });
            }
            Meeting::Off => {}
        }
        self.cloths.push(e.id());
    }

    fn stack(n: usize, meeting: Meeting) -> Self {
        let mut scene = Self {
            app: Self::app(),
            cloths: Vec::new(),
        };
        let world = scene.app.world_mut();
        world.spawn((ClothCollider::plane(), Transform::default()));
        world.spawn((
            ClothCollider::sphere(0.3),
            Transform::from_xyz(0.0, 0.3, 0.0),
        ));
        for (layer, (at, turn)) in [
            (Vec3::new(0.0, 0.7, 0.0), 0.0),
            (Vec3::new(0.03, 1.0, 0.02), 0.5),
        ]
        .into_iter()
        .enumerate()
        {
            let sheet = ClothBuilder::new(n as u32, n as u32)
                .size(1.2, 1.2)
                .position(at)
                .rotation(Quat::from_rotation_y(turn))
                .build()
                .expect("a valid sheet");
            scene.spawn(sheet, layer as i32, meeting);
        }
        scene.settle(180);
        scene
    }

    fn flags(meeting: Meeting) -> Self {
        let mut scene = Self {
            app: Self::app(),
            cloths: Vec::new(),
        };
        scene.app.insert_resource(ClothWind(Wind {
            velocity: Vec3::new(15.0, 0.0, -4.0),
            gust_amplitude: 0.5,
            gust_frequency: 1.3,
            ..default()
        }));
        let flag = |columns: u32, rows: u32, z: f32, material: ClothMaterial| {
            let size = Vec2::new((columns - 1) as f32, (rows - 1) as f32) * 0.05;
            ClothBuilder::new(columns, rows)
                .size(size.x, size.y)
                .material(material)
                .position(Vec3::new(size.x / 2.0, 2.0 - size.y / 2.0, z))
                .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
                .pin_edge(GridEdge::Left)
                .build()
                .expect("a valid flag")
        };
        scene.spawn(flag(17, 11, 0.0, ClothMaterial::COTTON), 0, meeting);
        scene.spawn(flag(13, 9, 0.06, ClothMaterial::SILK), 1, meeting);
        scene.settle(60);
        scene
    }

    fn settle(&mut self, frames: usize) {
        for _ in 0..frames {
            self.app.update();
        }
    }
}

impl Runner for Scene {
    fn frame(&mut self) {
        self.app.update();
    }

    fn strain(&self) -> f32 {
        self.cloths
            .iter()
            .filter_map(|&e| self.app.world().get::<ClothStats>(e))
            .map(|s| s.max_strain)
            .fold(0.0, f32::max)
    }
}

/// Times the three variants of a scene and prints a row.
fn row(name: &str, make: impl Fn(Meeting) -> Scene) {
    let mut on = make(Meeting::Cloths);
    let mut off = make(Meeting::Off);
    let mut own = make(Meeting::Themselves);
    let mut times = race(&mut [&mut on, &mut off, &mut own], FRAMES, 20);
    let (a, a_lo, a_hi) = summary(&mut times[0]);
    let (b, b_lo, b_hi) = summary(&mut times[1]);
    let (c, c_lo, c_hi) = summary(&mut times[2]);
    let ratio = (a - b) / (c - b);
    println!(
        "| {name} | {a:.3} ({a_lo:.3}–{a_hi:.3}) | {b:.3} ({b_lo:.3}–{b_hi:.3}) | {c:.3} ({c_lo:.3}–{c_hi:.3}) | {ratio:.2} |"
    );
}

fn main() {
    println!(
        "| scene | between cloths ms (median, range) | off | self-collision instead | extra cost, between cloths over self-collision |"
    );
    println!("|---|---|---|---|---|");
    for n in sizes(&SIZES) {
        row(&format!("stack {n}×{n}"), |m| Scene::stack(n, m));
    }
    row("flags", Scene::flags);
}
