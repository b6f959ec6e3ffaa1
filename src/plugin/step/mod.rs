//! The cloth step and its schedule: the components that hold a cloth's
//! state, the public [`ClothSystems`] sets, the step itself, the writeback
//! after it (statistics, events, rest and sleep), and the compute pool the
//! step spreads its work over. [`ClothCorePlugin`](crate::plugin::ClothCorePlugin)
//! registers them.
//!
//! What it may import: the simulation and the rest of the plugin layer.

pub(crate) mod components;
pub(crate) mod events;
pub(crate) mod integrate;
pub(crate) mod pool;
pub(crate) mod pose;
pub(crate) mod schedule;
pub(crate) mod sleep;
pub(crate) mod writeback;

pub use components::*;
pub use events::*;
pub use pool::ComputePool;
pub use schedule::*;
pub use sleep::*;
