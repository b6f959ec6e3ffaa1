//! `ClothPlugin` is a plugin group: each member can be left out, and the
//! rest build and run; the concern of the member left out is gone, and
//! nothing else changes.

use bevy::app::PluginGroupBuilder;
use bevy::diagnostic::DiagnosticsStore;
use bevy::ecs::message::Messages;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_cloth::plugin::diagnostics::STEP_TIME;
use bevy_cloth::plugin::lod::ClothDetail;
use bevy_cloth::plugin::{
    ClothCollisionPlugin, ClothCreasePlugin, ClothDiagnosticsPlugin, ClothInteractionPlugin,
    ClothLodPlugin, ClothRenderPlugin, ClothTearingPlugin, ClothWindPlugin, ClothWornPlugin,
};
use bevy_cloth::prelude::*;

/// An app with `group` (and `Assets<Mesh>`), whose every update after the
/// first runs one 60 Hz fixed step.
fn app_with(group: PluginGroupBuilder) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        bevy::diagnostic::DiagnosticsPlugin,
        group,
    ))
    .init_asset::<Mesh>()
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.update();
    app
}

/// The whole group.
fn all() -> PluginGroupBuilder {
    ClothPlugin::default().build()
}

/// A horizontal 12 × 12, 1 m sheet at y = 2 m pinned at two corners.
fn sheet() -> ClothBundle {
    ClothBuilder::new(12, 12)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .unwrap()
}

/// Steps `frames` fixed steps and returns the particles' positions.
fn run(app: &mut App, cloth: Entity, frames: usize) -> Vec<Vec3> {
    for _ in 0..frames {
        app.update();
    }
    let p = app.world().get::<ClothParticles>(cloth).unwrap();
    assert!(p.is_finite());
    p.positions.clone()
}

/// The lowest particle's height, m.
fn lowest(x: &[Vec3]) -> f32 {
    x.iter().map(|p| p.y).fold(f32::INFINITY, f32::min)
}

/// A free sheet that falls 30 fixed steps in `group`: its positions.
fn plain_fall(group: PluginGroupBuilder) -> Vec<Vec3> {
    let mut app = app_with(group);
    let cloth = app.world_mut().spawn(sheet()).id();
    run(&mut app, cloth, 30)
}

#[test]
fn every_member_left_out_leaves_a_plain_cloth_stepping_to_the_same_bits() {
    let full = plain_fall(all());
    assert!(lowest(&full) < 1.9, "the sheet falls");
    let without = [
        ("render", all().disable::<ClothRenderPlugin>()),
        ("interaction", all().disable::<ClothInteractionPlugin>()),
        ("collision", all().disable::<ClothCollisionPlugin>()),
        ("wind", all().disable::<ClothWindPlugin>()),
        ("crease", all().disable::<ClothCreasePlugin>()),
        ("tearing", all().disable::<ClothTearingPlugin>()),
        ("worn", all().disable::<ClothWornPlugin>()),
        ("lod", all().disable::<ClothLodPlugin>()),
        ("diagnostics", all().disable::<ClothDiagnosticsPlugin>()),
    ];
    for (name, group) in without {
        assert!(
            full == plain_fall(group),
            "without {name} the sheet moved otherwise"
        );
    }
}

#[test]
fn without_render_a_cloth_gets_no_mesh() {
    let mut app = app_with(all());
    let drawn = app.world_mut().spawn(sheet()).id();
    app.update();
    assert!(app.world().get::<Mesh3d>(drawn).is_some());
    let mut app = app_with(all().disable::<ClothRenderPlugin>());
    let bare = app.world_mut().spawn(sheet()).id();
    run(&mut app, bare, 3);
    assert!(app.world().get::<Mesh3d>(bare).is_none());
}

#[test]
fn without_interaction_a_cloth_has_no_grabs() {
    let mut app = app_with(all().disable::<ClothInteractionPlugin>());
    let cloth = app.world_mut().spawn(sheet()).id();
    run(&mut app, cloth, 3);
    assert!(app.world().get::<ClothGrabs>(cloth).is_none());
    let mut app = app_with(all());
    let cloth = app.world_mut().spawn(sheet()).id();
    assert!(app.world().get::<ClothGrabs>(cloth).is_some());
}

/// A sheet falling 60 fixed steps onto a ball under its middle.
fn onto_a_ball(group: PluginGroupBuilder) -> Vec<Vec3> {
    let mut app = app_with(group);
    app.world_mut().spawn((
        ClothCollider::sphere(0.3),
        Transform::from_xyz(0.0, 1.4, 0.0),
    ));
    let free = ClothBuilder::new(12, 12)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .build()
        .unwrap();
    let cloth = app.world_mut().spawn(free).id();
    run(&mut app, cloth, 60)
}

#[test]
fn without_collision_a_cloth_falls_through_a_collider() {
    let held = onto_a_ball(all());
    let through = onto_a_ball(all().disable::<ClothCollisionPlugin>());
    let centre = Vec3::new(0.0, 1.4, 0.0);
    let inside = |x: &[Vec3]| x.iter().filter(|p| p.distance(centre) < 0.28).count();
    let highest = |x: &[Vec3]| x.iter().map(|p| p.y).fold(f32::NEG_INFINITY, f32::max);
    // The ball's top is at 1.7 m: the cloth drapes on it, or falls 5 m.
    assert_eq!(inside(&held), 0, "the ball holds the cloth");
    assert!(highest(&held) > 1.6, "{}", highest(&held));
    assert!(highest(&through) < 0.0, "{}", highest(&through));
}

#[test]
fn without_wind_the_wind_resource_blows_nothing() {
    let windy = |group: PluginGroupBuilder| {
        let mut app = app_with(group);
        app.insert_resource(ClothWind(Wind {
            velocity: Vec3::new(0.0, 0.0, 8.0),
            ..default()
        }));
        let cloth = app.world_mut().spawn(sheet()).id();
        run(&mut app, cloth, 30)
    };
    let calm = plain_fall(all());
    assert!(windy(all()) != calm, "the wind blows");
    assert!(windy(all().disable::<ClothWindPlugin>()) == calm);
}

#[test]
fn without_creases_a_crease_component_does_nothing() {
    let creased = |group: PluginGroupBuilder| {
        let mut app = app_with(group);
        let crease = Crease::new(Vec2::new(0.5, 0.0), Vec2::new(0.5, 1.0));
        let cloth = app
            .world_mut()
            .spawn((sheet(), ClothCreases(vec![crease])))
            .id();
        run(&mut app, cloth, 30)
    };
    let flat = plain_fall(all());
    assert!(creased(all()) != flat, "the crease folds the sheet");
    assert!(creased(all().disable::<ClothCreasePlugin>()) == flat);
}

#[test]
fn without_tearing_a_cloth_keeps_its_topology_and_no_cut_is_registered() {
    let mut app = app_with(all().disable::<ClothTearingPlugin>());
    let cloth = app
        .world_mut()
        .spawn((sheet(), ClothTearing::default().with_strain(0.01).unwrap()))
        .id();
    assert_eq!(run(&mut app, cloth, 30).len(), 144);
    assert!(!app.world().contains_resource::<Messages<ClothCut>>());
    // With it, a cut splits a particle of the same sheet.
    let mut app = app_with(all());
    let cloth = app.world_mut().spawn(sheet()).id();
    run(&mut app, cloth, 2);
    app.world_mut()
        .write_message(ClothCut::split(cloth, 66, Vec3::X));
    assert!(run(&mut app, cloth, 2).len() > 144);
}

#[test]
fn without_worn_cloth_an_anchor_does_not_carry_its_particle() {
    let carried = |group: PluginGroupBuilder| {
        let mut app = app_with(group);
        let pole = app
            .world_mut()
            .spawn(Transform::from_xyz(0.0, 2.0, 0.0))
            .id();
        let cloth = app
            .world_mut()
            .spawn((sheet(), ClothAnchors::default().with(0, pole)))
            .id();
        let start = run(&mut app, cloth, 2)[0];
        app.world_mut()
            .get_mut::<Transform>(pole)
            .unwrap()
            .translation = Vec3::new(0.5, 2.5, 0.0);
        run(&mut app, cloth, 5)[0] - start
    };
    let by = Vec3::new(0.5, 0.5, 0.0);
    assert!(carried(all()).distance(by) < 1e-4, "{}", carried(all()));
    // Particle 0 is a pin: without its anchor it stays where it is.
    assert!(carried(all().disable::<ClothWornPlugin>()).length() < 1e-6);
}

#[test]
fn without_lod_a_cloth_has_no_detail_and_steps_every_fixed_step() {
    let mut app = app_with(all().disable::<ClothLodPlugin>());
    let cloth = app.world_mut().spawn(sheet()).id();
    run(&mut app, cloth, 10);
    assert!(app.world().get::<ClothDetail>(cloth).is_none());
    assert_eq!(app.world().get::<ClothStats>(cloth).unwrap().steps, 10);
}

#[test]
fn without_diagnostics_the_store_has_no_cloth_paths() {
    let mut app = app_with(all());
    let cloth = app.world_mut().spawn(sheet()).id();
    run(&mut app, cloth, 3);
    let store = app.world().resource::<DiagnosticsStore>();
    assert!(store.get(&STEP_TIME).is_some());
    let mut app = app_with(all().disable::<ClothDiagnosticsPlugin>());
    let cloth = app.world_mut().spawn(sheet()).id();
    run(&mut app, cloth, 3);
    let store = app.world().resource::<DiagnosticsStore>();
    assert!(store.get(&STEP_TIME).is_none());
}

/// Counts its runs.
#[derive(Resource, Default)]
struct Runs(u32);

#[test]
fn a_world_without_a_cloth_runs_none_of_the_steps_systems() {
    // A system in each of the step's sets stands for the members' systems
    // there: it runs while a cloth exists, and not before or after.
    let mut app = app_with(all());
    app.init_resource::<Runs>();
    for set in [
        ClothSystems::Prepare,
        ClothSystems::Crease,
        ClothSystems::Forces,
        ClothSystems::Integrate,
        ClothSystems::Collide,
        ClothSystems::Writeback,
    ] {
        app.add_systems(FixedUpdate, (|mut r: ResMut<Runs>| r.0 += 1).in_set(set));
    }
    let runs = |app: &mut App, frames: u32| {
        app.world_mut().resource_mut::<Runs>().0 = 0;
        for _ in 0..frames {
            app.update();
        }
        app.world().resource::<Runs>().0
    };
    assert_eq!(runs(&mut app, 10), 0, "no cloth yet");
    let cloth = ClothBuilder::new(8, 8).build().unwrap();
    let cloth = app.world_mut().spawn(cloth).id();
    assert_eq!(runs(&mut app, 10), 60, "one cloth: every set, every step");
    // Gone: one more step clears what it left, then nothing runs.
    app.world_mut().despawn(cloth);
    assert_eq!(runs(&mut app, 10), 6, "the step after the cloth despawned");
    assert_eq!(runs(&mut app, 10), 0, "no cloth since");
}
