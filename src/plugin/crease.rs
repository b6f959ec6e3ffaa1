//! [`ClothCreases`]: a cloth entity's creases, applied to its connections
//! when they change ([`crate::sim::crease`] holds the geometry).
//!
//! Changing or removing `ClothCreases` restores the original rest lengths
//! exactly and rebuilds only the crease connections. Creases are lines
//! in a grid's rest `(u, v)` coordinates: a mesh cloth has none, and its
//! `ClothCreases` are ignored with a warning. Cloths without creases
//! do no crease work (the system runs only on changed `ClothCreases`).

use bevy::prelude::*;

use crate::plugin::components::{Cloth, ClothConnections};
use crate::sim::crease::{Crease, CreaseRecord, apply_creases, restore};

/// The creases of a cloth. Add, change or remove it at any time.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn fold_in_half(mut commands: Commands, cloth: Single<Entity, With<Cloth>>) {
///     let middle = Crease::new(Vec2::new(0.5, 0.0), Vec2::new(0.5, 1.0)).with_side(FoldSide::Mountain);
///     commands.entity(*cloth).insert(ClothCreases(vec![middle]));
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothCreases(pub Vec<Crease>);

/// The original rest lengths a cloth's creases changed, kept on the cloth
/// to restore them exactly.
#[derive(Component, Clone, Debug, Default, Deref, DerefMut)]
pub struct ClothCreaseRecord(pub CreaseRecord);

/// [`ClothSystems::Crease`](crate::ClothSystems::Crease): applies changed
/// creases (only cloths whose `ClothCreases` changed do any work).
#[expect(
    clippy::type_complexity,
    reason = "one query gathers what a crease edit needs"
)]
pub(crate) fn update_creases(
    _main: crate::plugin::schedule::MainThread,
    mut commands: Commands,
    mut cloths: Query<
        (
            Entity,
            &Cloth,
            &ClothCreases,
            &mut ClothConnections,
            Option<&mut ClothCreaseRecord>,
        ),
        Changed<ClothCreases>,
    >,
) {
    for (entity, cloth, creases, mut connections, record) in &mut cloths {
        let Some(grid) = cloth.grid() else {
            if !creases.0.is_empty() {
                warn!("the creases of cloth {entity} are ignored: creases need a grid cloth");
            }
            continue;
        };
        let mut fresh = ClothCreaseRecord::default();
        let had_record = record.is_some();
        let record = match record {
            Some(r) => r.into_inner(),
            None => &mut fresh,
        };
        for error in apply_creases(grid, &mut connections, record, &creases.0) {
            warn!("a crease of cloth {entity} is ignored: {error}");
        }
        if !had_record {
            commands.entity(entity).try_insert(fresh);
        }
    }
}

/// When `ClothCreases` is removed, the original rest lengths come back.
pub(crate) fn remove_creases(
    event: On<Remove<ClothCreases>>,
    mut cloths: Query<(&mut ClothConnections, &mut ClothCreaseRecord)>,
) {
    if let Ok((mut connections, mut record)) = cloths.get_mut(event.entity) {
        restore(&mut connections, &mut record);
    }
}
