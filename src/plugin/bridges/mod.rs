//! The physics-engine bridges, each a thin room on the crate's public
//! collision port ([`ClothColliderSources`](crate::plugin::collision::ClothColliderSources),
//! [`ClothColliderScene`](crate::plugin::collision::ClothColliderScene),
//! [`ClothContactImpulses`](crate::plugin::collision::ClothContactImpulses)):
//! `avian` (feature `avian`, [`ClothAvianPlugin`](avian::ClothAvianPlugin))
//! and `rapier` (feature `rapier`, [`ClothRapierPlugin`](rapier::ClothRapierPlugin)),
//! and the code they share: the engines' shapes as the cloth's colliders
//! (`parry_shapes`) and their bodies' motion over a fixed step
//! (`body_motion`).
//!
//! What it may import: anything of Bevy, the engines, and the rest of the
//! plugin layer's public port.

#[cfg(feature = "avian")]
pub mod avian;
#[cfg(any(feature = "avian", feature = "rapier"))]
mod body_motion;
#[cfg(any(feature = "avian", feature = "rapier"))]
mod parry_shapes;
#[cfg(feature = "rapier")]
pub mod rapier;
