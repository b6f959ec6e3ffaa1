//! The integration tests, one binary: a module per suite, each an
//! app-level or end-to-end check of one concern (`cargo test --test suite --
//! wind::` runs one). Scenes the suites share are in [`common`].
//!
//! One binary links Bevy once: a new suite is a module here, not a file
//! of its own in `tests/` (which cargo would build as another binary).

mod abuse;
mod accuracy;
mod allocation;
mod app;
mod architecture;
#[cfg(feature = "avian")]
mod avian;
mod cloth_cloth;
mod cloth_edges;
mod collision;
mod common;
mod compare;
mod contact;
mod crease;
mod debug;
mod edit;
mod events;
mod examples;
mod frame;
mod fuzz;
mod gltf;
mod guard;
mod hard_cases;
mod interaction;
mod layers;
mod lod;
mod many;
mod material;
mod mesh_app;
mod mesh_cloth;
mod mesh_crease;
mod motion;
mod picking;
mod pins;
mod plugins;
#[cfg(feature = "rapier")]
mod rapier;
mod rim;
mod self_collision;
mod skin;
mod sleep;
mod stability;
mod tear;
mod tether;
mod wind;
