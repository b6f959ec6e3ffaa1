//! The windowed examples are templates: each reads on its own, and the
//! automation the rendering check needs is one plugin, added by one line,
//! that does nothing without command-line arguments.

#[path = "../../examples/automation/mod.rs"]
mod automation;

use std::fs;
use std::path::Path;

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use bevy_cloth::prelude::*;

const WINDOWED: [&str; 12] = [
    "hanging",
    "tablecloth",
    "sphere",
    "lander_vs_choi",
    "crease",
    "round_tablecloth",
    "flag",
    "cape",
    "two_sheets",
    "hammock",
    "tablecloth_trick",
    "tear",
];

fn source(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/{name}.rs"));
    fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn automation_is_one_line_in_each_windowed_example() {
    for name in WINDOWED {
        let text = source(name);
        let mentions: Vec<&str> = text
            .lines()
            .filter(|l| l.contains("automation") || l.contains("Automation"))
            .filter(|l| !l.trim_start().starts_with("//"))
            .collect();
        assert_eq!(
            mentions,
            [
                "mod automation;",
                "        .add_plugins(automation::AutomationPlugin)"
            ],
            "{name}: the automation must be its module and one plugin line"
        );
    }
}

#[test]
fn each_windowed_example_sets_up_its_own_camera_light_and_plugins() {
    for name in WINDOWED {
        let text = source(name);
        for needed in [
            "DefaultPlugins",
            "MeshPickingPlugin",
            "ClothPlugin::default()",
            "ClothPanelPlugin",
            "PanOrbitCameraPlugin",
            "Camera3d",
            "DirectionalLight",
        ] {
            assert!(text.contains(needed), "{name} does not show {needed}");
        }
        assert!(!text.contains("mod common"), "{name} uses a shared module");
    }
}

/// What an app is made of: its resources and the systems of the schedules
/// the automation would add to.
fn shape(app: &mut App) -> (usize, Vec<usize>) {
    let resources = app.world().iter_resources().count();
    let systems = [
        Startup.intern(),
        First.intern(),
        PreUpdate.intern(),
        Update.intern(),
    ]
    .into_iter()
    .map(|label| app.get_schedule(label).map_or(0, |s| s.systems_len()))
    .collect();
    (resources, systems)
}

#[test]
fn the_automation_plugin_changes_nothing_without_arguments() {
    // The test binary's own arguments are none of the automation's.
    let plain = || {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, ClothPlugin::default()));
        app
    };
    let mut without = plain();
    let mut with = plain();
    with.add_plugins(automation::AutomationPlugin);
    assert_eq!(shape(&mut with), shape(&mut without));
    // With arguments it does add its systems (so the comparison can fail).
    let mut scripted = plain();
    let mut script = automation::Automation::default();
    script.frames = Some(3);
    scripted.insert_resource(script);
    automation::add_systems(&mut scripted);
    assert_ne!(shape(&mut scripted), shape(&mut without));
}
