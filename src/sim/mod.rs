//! The simulation: plain data and plain functions, usable without an `App`.
//!
//! What a caller uses: the grid and its links ([`grid`], [`connections`]),
//! the particles' state ([`particles`]), every parameter of a step
//! ([`settings`], [`material`]), the force models ([`model`]), the step's
//! scratch ([`integrate`]), a step as a function ([`step`]), the divergence
//! guard around it ([`guard`]), adaptive substeps ([`adaptive`]), the shapes
//! and contacts of the narrow phase ([`collision`]), creases' geometry
//! ([`crease`]), wind on faces ([`wind`]), the particles and links of a
//! cloth of any shape ([`topology`]), tethers to the pins ([`tether`]), sleep
//! and level of detail ([`sleep`], [`lod`]) and the worker pool that large
//! steps share their work with ([`workers`]). The strain limit, tearing,
//! sewing, moving frames and skinning live here too, as the crate's own
//! plumbing under the [`plugin`](crate::plugin)'s components.
//!
//! What it may import: [`bevy::math`], [`bevy::shape`] (shapes and
//! bounding boxes), [`bevy::reflect`] (the types derive `Reflect` so an
//! inspector can show them), [`bevy::platform`] (a clock that also works in
//! a browser), [`crate::error`] and `crate::simd`. It names no ECS type (no component, resource, query,
//! command, entity, message, task pool or app); `tests/suite/architecture.rs`
//! checks it. The [`plugin`](crate::plugin) wraps these types in
//! components.
//!
//! ```
//! use bevy::math::Vec3;
//! use bevy_cloth::sim::{
//!     connections::Connections, guard::{GuardState, StepInput, step_guarded},
//!     integrate::StepBuffers, particles::Particles, settings::SimSettings,
//! };
//!
//! // A 10×10 sheet, 1 m wide, hanging from its top corners, stepped 1 s.
//! let (n, h) = (10u32, 1.0 / 9.0);
//! let rest: Vec<Vec3> = (0..n * n)
//!     .map(|p| Vec3::new((p % n) as f32 * h, 2.0 - (p / n) as f32 * h, 0.0))
//!     .collect();
//! let connections = Connections::grid(n, n, &rest);
//! let mut particles = Particles::new(rest, vec![0.01; (n * n) as usize]);
//! particles.pin(0);
//! particles.pin(n as usize - 1);
//! let settings = SimSettings::default();
//! let (mut buffers, mut guard) = (StepBuffers::default(), GuardState::default());
//! for _ in 0..60 {
//!     let step = step_guarded(StepInput::new(
//!         &mut particles, &connections, &settings, &mut buffers, &mut guard, 1.0 / 60.0,
//!     ));
//!     assert!(step.report.is_none());
//! }
//! assert!(particles.is_finite() && particles.positions[0] == Vec3::new(0.0, 2.0, 0.0));
//! ```

pub mod adaptive;
pub mod build;
pub mod collision;
pub mod connections;
pub mod crease;
pub(crate) mod frame;
pub mod grid;
pub mod guard;
pub mod integrate;
pub mod lod;
pub mod material;
pub mod model;
pub mod particles;
pub mod settings;
pub(crate) mod sew;
pub(crate) mod skin;
pub mod sleep;
pub(crate) mod soa;
pub mod step;
pub(crate) mod strain_limit;
pub(crate) mod team;
pub(crate) mod tear;
pub mod tether;
pub mod topology;
pub mod wind;
pub mod workers;
