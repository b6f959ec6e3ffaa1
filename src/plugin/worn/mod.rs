//! Cloth worn by a character or carried by other entities: anchors
//! ([`ClothAnchors`]), a skeleton's skin ([`ClothSkin`]), tethers to the pins
//! ([`ClothTethers`]), and the inertia of a moving frame ([`ClothInertia`],
//! [`TeleportCloth`]).
//!
//! What it may import: the simulation and the rest of the plugin layer.

pub(crate) mod anchor;
pub(crate) mod frame;
pub(crate) mod skin;
pub(crate) mod tether;

pub use anchor::*;
pub use frame::*;
pub use skin::*;
pub use tether::*;
