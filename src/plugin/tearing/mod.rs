//! Editing a cloth's topology between fixed steps: tearing and cutting
//! ([`ClothTearing`], [`ClothCut`], [`ClothTorn`]) and sewing
//! ([`ClothSew`], [`ClothSewn`]).
//!
//! What it may import: the simulation and the rest of the plugin layer.

pub(crate) mod sew;
pub(crate) mod tear;

pub use sew::*;
pub use tear::*;
