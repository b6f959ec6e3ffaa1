//! [`ClothCreases`]: a cloth entity's creases, applied to its connections
//! when they change ([`crate::sim::crease`] holds the geometry).
//!
//! A new crease closes over [`CREASE_CLOSING_TIME`]: its fold angle grows
//! from flat to the whole fold, one fixed step at a time, so the cloth
//! folds as a hand would fold it rather than in one step. Changing or
//! removing `ClothCreases` restores the original rest lengths exactly and
//! rebuilds only the crease connections; a crease that stays in the list
//! keeps its fold. A crease is a segment in the cloth's rest space
//! ([`RestSurface`]): a grid's rest `(u, 0, v)`, a mesh cloth's own mesh
//! coordinates. Cloths without creases do no crease work (the system
//! runs only while some cloth has `ClothCreases`, and touches a cloth only
//! when its creases changed or one of them is still closing).

use bevy::prelude::*;

use crate::plugin::step::components::{Cloth, ClothConnections};
use crate::sim::crease::{Crease, CreaseRecord, RestSurface, apply_closing, restore};

/// How long a new crease takes to close, s: its fold angle grows linearly
/// from 0 to the whole fold over this time.
pub const CREASE_CLOSING_TIME: f32 = 0.2;

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

/// What a cloth's creases changed, kept on the cloth: the original rest
/// lengths, to restore them exactly, and how far each crease has closed.
#[derive(Component, Clone, Debug, Default)]
pub struct ClothCreaseRecord {
    /// The original rest lengths the creases changed.
    pub record: CreaseRecord,
    /// Each applied crease with the fraction of its fold angle it has
    /// reached (dimensionless, 0 = flat, 1 = closed).
    pub closing: Vec<(Crease, f32)>,
}

impl ClothCreaseRecord {
    /// Whether some crease has not closed yet.
    fn closing(&self) -> bool {
        self.closing.iter().any(|(_, f)| *f < 1.0)
    }
}

/// [`ClothSystems::Crease`](crate::ClothSystems::Crease): applies changed
/// creases and closes new ones a step further.
#[expect(
    clippy::type_complexity,
    reason = "one query gathers what a crease edit needs"
)]
pub(crate) fn update_creases(
    _main: crate::plugin::step::schedule::MainThread,
    time: Res<Time<Fixed>>,
    mut commands: Commands,
    mut cloths: Query<(
        Entity,
        &Cloth,
        Ref<ClothCreases>,
        &mut ClothConnections,
        Option<&mut ClothCreaseRecord>,
    )>,
) {
    let step = time.timestep().as_secs_f32() / CREASE_CLOSING_TIME;
    for (entity, cloth, creases, mut connections, record) in &mut cloths {
        let changed = creases.is_changed();
        if !changed && !record.as_ref().is_some_and(|r| r.closing()) {
            continue;
        }
        let surface = match cloth.grid() {
            Some(grid) => RestSurface::grid(grid),
            None => RestSurface::mesh(cloth.layout().topology(), &connections),
        };
        let mut fresh = ClothCreaseRecord::default();
        let had_record = record.is_some();
        let record = match record {
            Some(r) => r.into_inner(),
            None => &mut fresh,
        };
        if changed {
            // A crease already in the list keeps how far it has closed.
            let closing = creases
                .0
                .iter()
                .map(|c| {
                    let kept = record.closing.iter().find(|(old, _)| old == c);
                    (*c, kept.map_or(0.0, |(_, f)| *f))
                })
                .collect();
            record.closing = closing;
        }
        for (_, fraction) in &mut record.closing {
            // The last step closes it exactly, whatever the rounding of
            // the steps before.
            *fraction += step;
            if *fraction > 1.0 - 1e-4 {
                *fraction = 1.0;
            }
        }
        let errors = apply_closing(
            &surface,
            &mut connections,
            &mut record.record,
            record.closing.iter().map(|(c, f)| (c, *f)),
        );
        if changed {
            for error in errors {
                warn!("a crease of cloth {entity} is ignored: {error}");
            }
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
        restore(&mut connections, &mut record.record);
        record.closing.clear();
    }
}
