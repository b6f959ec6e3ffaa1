//! Making a cloth entity: [`ClothBuilder`] for a grid, [`MeshClothBuilder`]
//! for any Bevy `Mesh` (its topology in [`MeshLayout`]), the
//! [`ClothBundle`] both make, and the fabric ([`ClothMaterial`]).
//!
//! What it may import: the simulation and the rest of the plugin layer.

pub(crate) mod builder;
pub(crate) mod material;
pub(crate) mod mesh_builder;
pub(crate) mod mesh_cloth;

pub use builder::*;
pub use material::*;
pub use mesh_builder::*;
pub use mesh_cloth::*;
