//! Grabbing a cloth: [`ClothGrabs`] from game code, and pick and pull with
//! the mouse (`ClothPicking`, feature `picking`).
//!
//! What it may import: the simulation and the rest of the plugin layer.

pub(crate) mod grab;
#[cfg(feature = "picking")]
pub(crate) mod picking;

pub use grab::*;
#[cfg(feature = "picking")]
pub use picking::*;
