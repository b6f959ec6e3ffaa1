//! The collider pipeline: the [`ClothColliderScene`] every source feeds in
//! [`ClothColliderSources`], and the [`ClothContactImpulses`] the step
//! reports back for bridges to apply. The colliders themselves
//! ([`SceneCollider`]) and the contacts with them are plain simulation
//! values ([`sim::collision::scene`](crate::sim::collision::scene)).

use bevy::ecs::component::{Mutable, StorageType};
use bevy::ecs::schedule::SystemSet;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use crate::sim::collision::scene::{
    ClothContactLayers, ColliderKey, ColliderScene, ContactImpulse,
};

/// The system set, in [`ClothSystems::Prepare`](crate::plugin::step::schedule::ClothSystems::Prepare),
/// in which collider sources push this step's colliders into the
/// [`ClothColliderScene`]: the crate's own [`ClothCollider`](super::ClothCollider)s,
/// the avian and rapier bridges, and any of a game's own. The scene is
/// emptied just before the set runs.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy::math::Isometry3d;
/// # use bevy_cloth::prelude::*;
/// # use bevy_cloth::plugin::collision::{ClothColliderSources, ClothColliderScene, ColliderShape, SceneCollider, Shape};
/// /// A game's own obstacle: a ball that follows a scripted path.
/// #[derive(Component)]
/// struct Boulder { radius: f32, now: Vec3, next: Vec3 }
///
/// fn boulders(boulders: Query<(Entity, &Boulder)>, mut scene: ResMut<ClothColliderScene>) {
///     for (entity, b) in &boulders {
///         let shape = ColliderShape::Analytic(Shape::Sphere { radius: b.radius });
///         let (start, end) = (Isometry3d::from_translation(b.now), Isometry3d::from_translation(b.next));
///         if let Err(error) = scene.push(SceneCollider::new(entity, shape, start, end)) {
///             warn_once!("a boulder is ignored: {error}");
///         }
///     }
/// }
///
/// # let mut app = App::new();
/// app.add_systems(FixedUpdate, boulders.in_set(ClothColliderSources));
/// ```
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ClothColliderSources;

/// On a cloth or a collider's entity, its layers (see
/// [`ClothContactLayers`]).
impl Component for ClothContactLayers {
    const STORAGE_TYPE: StorageType = StorageType::Table;
    type Mutability = Mutable;
}

/// A collider source's entity as its key: the one the plugin's sources use.
impl From<Entity> for ColliderKey {
    fn from(entity: Entity) -> Self {
        Self(entity.to_bits())
    }
}

impl ColliderKey {
    /// The entity whose key this is, if it is an entity's.
    pub fn entity(self) -> Option<Entity> {
        Entity::try_from_bits(self.0)
    }
}

/// The colliders of the current fixed step, fed by every source in
/// [`ClothColliderSources`] (a [`ColliderScene`], which it dereferences
/// to).
#[derive(Resource, Clone, Debug, Default, Deref, DerefMut)]
pub struct ClothColliderScene(pub ColliderScene);

/// The impulses every cloth gave each collider with
/// [`feedback`](crate::sim::collision::scene::SceneCollider::feedback) over the last fixed step,
/// per collider entity (the entity of its [`ColliderKey`]): set in
/// [`ClothSystems::Integrate`](crate::plugin::step::schedule::ClothSystems::Integrate),
/// read by bridges after it (the avian bridge applies them to dynamic bodies
/// in [`ClothSystems::Writeback`](crate::plugin::step::schedule::ClothSystems::Writeback)).
#[derive(Resource, Clone, Debug, Default)]
pub struct ClothContactImpulses {
    pub(crate) map: HashMap<Entity, ContactImpulse>,
}

impl ClothContactImpulses {
    /// The impulse on `entity`'s colliders, if the cloth touched them.
    pub fn get(&self, entity: Entity) -> Option<&ContactImpulse> {
        self.map.get(&entity)
    }

    /// Every collider entity the cloth touched, with its impulse.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, &ContactImpulse)> + '_ {
        self.map.iter().map(|(e, i)| (*e, i))
    }

    /// Whether no collider was touched.
    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }
}

/// Marks an entity with a [`ClothCollider`](super::ClothCollider) whose
/// impulses from the cloth are measured into [`ClothContactImpulses`], for
/// a game to apply to its own bodies. The avian bridge does this for
/// dynamic bodies by itself.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component, Default)]
pub struct ClothReportImpulses;
