//! [`ClothTethers`]: long-range attachments that keep a cloth's free
//! particles within reach of its pins ([`crate::sim::tether`] holds the
//! geometry).

use bevy::prelude::{Component, Reflect, ReflectComponent, ReflectDefault};

use crate::sim::tether::Tethers;

/// Tethers for this cloth: every free particle is kept within `slack`
/// times its rest distance, measured along the Type 1 links, of its
/// nearest pinned particle (anchored, grabbed and pinned particles alike).
/// It bounds the stretch a long chain of links shows under fast motion (a
/// cape on a running character, a banner on a swung pole) in one cheap
/// pass after each substep, before collisions. The nearest pins are found
/// again whenever the pins or the links change.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) -> Result<(), ClothError> {
///     let banner = ClothBuilder::new(16, 32).pin_edge(GridEdge::Top).build()?;
///     commands.spawn((banner, ClothTethers::default()));
///     Ok(())
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
#[require(TetherScratch)]
pub struct ClothTethers {
    /// How far past its rest geodesic distance a particle may go, as a
    /// factor (≥ 1, dimensionless): the default 1.03 allows 3 % of
    /// stretch along the chain to the pin.
    pub slack: f32,
}

impl Default for ClothTethers {
    fn default() -> Self {
        Self { slack: 1.03 }
    }
}

/// Each particle's nearest pin and rest distance to it, for
/// [`ClothTethers`].
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct TetherScratch(pub(crate) Tethers);
