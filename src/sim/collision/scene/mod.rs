//! A cloth's contacts with the colliders of a scene: the colliders of a
//! fixed step ([`ColliderScene`], filled by any source) and the contact
//! hook that resolves a cloth's step against them ([`SceneContacts`]),
//! the same code the plugin runs for every cloth.
//!
//! It may import the rest of [`sim`](crate::sim) and [`error`](crate::error).

mod colliders;
mod feedback;
mod hook;
mod watch;

pub(crate) use colliders::check_surface;
pub use colliders::{
    ClothContactLayers, ColliderKey, ColliderScene, ColliderShape, ContactImpulse, MeshShape,
    SceneCollider,
};
pub use hook::{SceneContactScratch, SceneContacts};
pub(crate) use watch::ColliderWatch;

#[cfg(test)]
mod tests;
