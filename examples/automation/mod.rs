//! The automation the rendering check needs, as one plugin an example adds
//! with one line (`.add_plugins(automation::AutomationPlugin)`); delete
//! that line and the example runs the same, by hand.
//!
//! `--frames N` runs N frames and exits; `--screenshot PATH` saves the last
//! frame to PATH (through Bevy's `Screenshot`) before exiting; `--press K:F`
//! (repeatable) presses key K (a letter, a digit or `Space`) at frame F, so
//! a scripted interaction can be checked; `--drag X0,Y0:X1,Y1@F` presses
//! the primary mouse button at window pixel (X0, Y0) at frame F, moves to
//! (X1, Y1) over ten frames and releases: a real pick and pull through
//! Bevy's mesh picking (`--drag-shift` holds Shift meanwhile); `--no-panel`
//! closes the cloth panel. Without arguments the plugin does nothing.

use std::path::PathBuf;

use bevy::input::ButtonState;
use bevy::input::mouse::MouseButtonInput;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured, save_to_disk};
use bevy::window::{CursorMoved, PrimaryWindow, WindowEvent};
use bevy_cloth::plugin::interaction::ClothPointerGrabs;
use bevy_cloth::plugin::tools::panel::ClothPanel;

/// Reads the command line and plays its script.
pub struct AutomationPlugin;

impl Plugin for AutomationPlugin {
    fn build(&self, app: &mut App) {
        let automation = Automation::from_args();
        if !automation.active() {
            return;
        }
        app.insert_resource(automation);
        add_systems(app);
    }
}

/// The systems that play an [`Automation`] resource's script.
pub fn add_systems(app: &mut App) {
    app.add_systems(Startup, close_panel)
        .add_systems(Update, (automate, report_grab))
        .add_systems(PreUpdate, scripted_keys.after(bevy::input::InputSystems))
        .add_systems(First, scripted_drag);
}

/// `--no-panel`: the cloth panel stays closed.
fn close_panel(auto: Res<Automation>, panel: Option<ResMut<ClothPanel>>) {
    if let (true, Some(mut panel)) = (auto.no_panel, panel) {
        panel.open = false;
    }
}

/// Command-line automation (`--frames`, `--screenshot`).
#[derive(Resource, Debug, Default)]
pub struct Automation {
    /// Frames to run before the screenshot and exit.
    pub frames: Option<u32>,
    /// Where to save the screenshot.
    pub screenshot: Option<PathBuf>,
    /// Keys to press, with the frame to press them at.
    pub presses: Vec<(KeyCode, u32)>,
    /// A scripted mouse drag: from, to (window pixels), starting frame.
    pub drag: Option<(Vec2, Vec2, u32)>,
    /// `--no-panel`: leave the egui cloth panel out.
    pub no_panel: bool,
    /// `--drag-shift`: hold Shift through the scripted drag.
    pub drag_shift: bool,
    /// Frames rendered so far.
    pub frame: u32,
    requested: bool,
}

impl Automation {
    /// Reads `--frames N` and `--screenshot PATH` from the command line.
    pub fn from_args() -> Self {
        let mut out = Self::default();
        let mut args = std::env::args().skip(1);
        while let Some(arg) = args.next() {
            match arg.as_str() {
                "--frames" => out.frames = args.next().and_then(|n| n.parse().ok()),
                "--screenshot" => out.screenshot = args.next().map(PathBuf::from),
                "--no-panel" => out.no_panel = true,
                "--drag-shift" => out.drag_shift = true,
                "--drag" => out.drag = args.next().as_deref().and_then(parse_drag),
                "--press" => {
                    if let Some(press) = args.next().as_deref().and_then(parse_press) {
                        out.presses.push(press);
                    }
                }
                _ => {}
            }
        }
        if out.screenshot.is_some() && out.frames.is_none() {
            out.frames = Some(60);
        }
        out
    }

    /// Whether the command line asks for anything.
    pub fn active(&self) -> bool {
        self.frames.is_some() || !self.presses.is_empty() || self.drag.is_some() || self.no_panel
    }
}

/// `X0,Y0:X1,Y1@F` → (from, to, frame).
fn parse_drag(s: &str) -> Option<(Vec2, Vec2, u32)> {
    let (path, frame) = s.split_once('@')?;
    let (from, to) = path.split_once(':')?;
    let point = |p: &str| {
        let (x, y) = p.split_once(',')?;
        Some(Vec2::new(x.parse().ok()?, y.parse().ok()?))
    };
    Some((point(from)?, point(to)?, frame.parse().ok()?))
}

/// `K:F` → (key K, frame F).
fn parse_press(s: &str) -> Option<(KeyCode, u32)> {
    let (key, frame) = s.split_once(':')?;
    let code = match key {
        "Space" => KeyCode::Space,
        k if k.len() == 1 => {
            let c = k.chars().next()?.to_ascii_uppercase();
            const LETTERS: [KeyCode; 26] = [
                KeyCode::KeyA,
                KeyCode::KeyB,
                KeyCode::KeyC,
                KeyCode::KeyD,
                KeyCode::KeyE,
                KeyCode::KeyF,
                KeyCode::KeyG,
                KeyCode::KeyH,
                KeyCode::KeyI,
                KeyCode::KeyJ,
                KeyCode::KeyK,
                KeyCode::KeyL,
                KeyCode::KeyM,
                KeyCode::KeyN,
                KeyCode::KeyO,
                KeyCode::KeyP,
                KeyCode::KeyQ,
                KeyCode::KeyR,
                KeyCode::KeyS,
                KeyCode::KeyT,
                KeyCode::KeyU,
                KeyCode::KeyV,
                KeyCode::KeyW,
                KeyCode::KeyX,
                KeyCode::KeyY,
                KeyCode::KeyZ,
            ];
            const DIGITS: [KeyCode; 10] = [
                KeyCode::Digit0,
                KeyCode::Digit1,
                KeyCode::Digit2,
                KeyCode::Digit3,
                KeyCode::Digit4,
                KeyCode::Digit5,
                KeyCode::Digit6,
                KeyCode::Digit7,
                KeyCode::Digit8,
                KeyCode::Digit9,
            ];
            match c {
                'A'..='Z' => LETTERS[(c as u8 - b'A') as usize],
                '0'..='9' => DIGITS[(c as u8 - b'0') as usize],
                _ => return None,
            }
        }
        _ => return None,
    };
    Some((code, frame.parse().ok()?))
}

/// Plays the `--drag` script as window events (cursor moves and left
/// button press/release), exactly what winit would deliver, so egui, Bevy's
/// picking and the camera all see the same mouse.
fn scripted_drag(
    auto: Res<Automation>,
    window: Option<Single<Entity, With<PrimaryWindow>>>,
    mut events: MessageWriter<WindowEvent>,
    mut buttons: MessageWriter<MouseButtonInput>,
) {
    let (Some((from, to, start)), Some(window)) = (auto.drag, window) else {
        return;
    };
    let window = *window;
    let step = auto.frame as i64 - start as i64;
    let along = |k: i64| from.lerp(to, k as f32 / 10.0);
    let cursor = |position: Vec2| {
        WindowEvent::CursorMoved(CursorMoved {
            window,
            position,
            delta: None,
        })
    };
    let button = |state: ButtonState| {
        WindowEvent::MouseButtonInput(MouseButtonInput {
            button: MouseButton::Left,
            state,
            window,
        })
    };
    match step {
        // The cursor arrives a few frames before the press, as a hand's
        // would, so whatever is under it (egui, the cloth) knows first.
        -5 => {
            events.write(cursor(from));
        }
        0 => {
            events.write(button(ButtonState::Pressed));
            // winit also sends the button as its own message (what
            // `ButtonInput<MouseButton>` reads).
            if let WindowEvent::MouseButtonInput(b) = button(ButtonState::Pressed) {
                buttons.write(b);
            }
        }
        1..=10 => {
            events.write(cursor(along(step)));
        }
        11 => {
            events.write(button(ButtonState::Released));
            if let WindowEvent::MouseButtonInput(b) = button(ButtonState::Released) {
                buttons.write(b);
            }
        }
        _ => {}
    }
}

/// Logs once when the pointer first holds a particle (the rendering check
/// looks for this line).
fn report_grab(held: Res<ClothPointerGrabs>, mut said: Local<bool>) {
    if !*said && let Some((_, grab)) = held.iter().next() {
        info!(
            "pointer holds particle {} of cloth {}",
            grab.particle, grab.cloth
        );
        *said = true;
    }
}

/// Presses the `--press` keys at their frames (held for one frame), and
/// holds Shift through a `--drag-shift` drag.
fn scripted_keys(auto: Res<Automation>, mut keys: ResMut<ButtonInput<KeyCode>>) {
    if let (true, Some((_, _, start))) = (auto.drag_shift, auto.drag) {
        let step = auto.frame as i64 - start as i64;
        if step == -5 {
            keys.press(KeyCode::ShiftLeft);
        } else if step == 13 {
            keys.release(KeyCode::ShiftLeft);
        }
    }
    for &(key, frame) in &auto.presses {
        if auto.frame == frame {
            keys.press(key);
        } else if auto.frame == frame + 1 {
            keys.release(key);
        }
    }
}

/// Counts frames; at `--frames` takes the screenshot (if asked) and exits
/// once it is on disk.
fn automate(
    mut commands: Commands,
    mut auto: ResMut<Automation>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(frames) = auto.frames else {
        return;
    };
    auto.frame += 1;
    if auto.frame < frames || auto.requested {
        return;
    }
    auto.requested = true;
    match auto.screenshot.clone() {
        Some(path) => {
            commands
                .spawn(Screenshot::primary_window())
                .observe(save_to_disk(path))
                .observe(
                    |_: On<ScreenshotCaptured>, mut exit: MessageWriter<AppExit>| {
                        exit.write(AppExit::Success);
                    },
                );
        }
        None => {
            exit.write(AppExit::Success);
        }
    }
}
