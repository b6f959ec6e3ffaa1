//! Tools for looking at and steering cloths while a game runs: the egui
//! panel (feature `egui`, [`ClothPanelPlugin`](panel::ClothPanelPlugin)) and
//! the gizmo debug view (feature `debug`,
//! [`ClothDebugPlugin`](debug::ClothDebugPlugin)).
//!
//! What it may import: anything of Bevy, bevy_egui, and the rest of the
//! plugin layer.

#[cfg(feature = "debug")]
pub mod debug;
#[cfg(feature = "egui")]
pub mod panel;
