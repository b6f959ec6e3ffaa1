//! Sewing in an app: [`ClothSew`] joins particle pairs of a cloth into one
//! between fixed steps like a tear, and
//! [`ClothSewn`] tells the game the particles' new indices.
//!
//! A seam is an edit of the cloth's topology: the particles of each pair
//! become one (the smaller index), the particles after them move down, and
//! every per-particle part of the cloth follows: the particles (their masses
//! summed, their momentum kept, their pins joined), the links (rebuilt by
//! the mesh rule, rest lengths kept), external forces, the previous
//! positions of the mesh's interpolation, anchors, grabs (the game's and
//! the pointer's), a skin's bindings and a crease record. The cloth keeps
//! its rendered vertices and UVs. A grid cloth becomes a mesh cloth.
//!
//! Sew particles that are together, or close: they meet at once where
//! their mass-weighted mean is. To close a gap, pull the two edges
//! together first (grabs, anchors), then sew.

use bevy::ecs::query::QueryData;
use bevy::log::warn;
use bevy::prelude::{Commands, Entity, EntityEvent, Message, MessageReader, Query, Reflect};

use crate::plugin::crease::ClothCreaseRecord;
use crate::plugin::interaction::grab::ClothGrabs;
use crate::plugin::render::mesh::ClothPrevious;
use crate::plugin::step::components::{Cloth, ClothConnections, ClothForces, ClothParticles};
use crate::plugin::worn::anchor::ClothAnchors;
use crate::plugin::worn::skin::ClothSkin;
use crate::sim::sew::{self, Seam};

/// Sews particle pairs of a cloth together: each pair (and pairs that chain
/// through a shared particle) becomes one particle. Write it as a message
/// (`MessageWriter<ClothSew>`); it acts after the next fixed step, after
/// tears and cuts. A pair out of range, or a particle with itself, is
/// skipped.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// /// Mends every tear of `cloth`: each copy sewn back onto its particle.
/// fn mend(torn: On<ClothTorn>, mut sew: MessageWriter<ClothSew>) {
///     sew.write(ClothSew {
///         cloth: torn.entity,
///         pairs: torn.split.clone(),
///     });
/// }
/// ```
#[derive(Message, Clone, Debug, PartialEq)]
pub struct ClothSew {
    /// The cloth to sew.
    pub cloth: Entity,
    /// The particle pairs to join (indices of the cloth when the message
    /// is read).
    pub pairs: Vec<(u32, u32)>,
}

/// A cloth was sewn, the fixed step it happened: triggered on the cloth.
#[derive(EntityEvent, Clone, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothSewn {
    /// The cloth.
    pub entity: Entity,
    /// For each particle before the seam, its index after it.
    pub map: Vec<u32>,
}

/// What sewing reads and edits of one cloth.
#[derive(QueryData)]
#[query_data(mutable)]
pub(crate) struct SewQuery {
    cloth: &'static mut Cloth,
    particles: &'static mut ClothParticles,
    connections: &'static mut ClothConnections,
    forces: &'static mut ClothForces,
    previous: Option<&'static mut ClothPrevious>,
    anchors: Option<&'static mut ClothAnchors>,
    grabs: Option<&'static mut ClothGrabs>,
    skin: Option<&'static mut ClothSkin>,
    creases: Option<&'static mut ClothCreaseRecord>,
}

/// [`ClothSystems::Writeback`](crate::ClothSystems::Writeback): applies the
/// [`ClothSew`]s and triggers [`ClothSewn`].
pub(crate) fn sew_cloths(
    _main: crate::plugin::step::schedule::MainThread,
    mut commands: Commands,
    mut sews: MessageReader<ClothSew>,
    #[cfg(feature = "picking")] mut pointers: Option<
        bevy::prelude::ResMut<crate::plugin::interaction::picking::ClothPointerGrabs>,
    >,
    mut cloths: Query<SewQuery>,
) {
    for message in sews.read() {
        let Ok(mut item) = cloths.get_mut(message.cloth) else {
            continue;
        };
        let n = item.particles.len();
        if n != item.cloth.len()
            || crate::plugin::step::components::check_cloth(&item.particles, &item.connections)
                .is_err()
        {
            warn!("cloth {} is not sewn: its parts disagree", message.cloth);
            continue;
        }
        let Some(seam) = Seam::new(n, &message.pairs) else {
            continue;
        };
        let layout = item.cloth.layout().clone();
        let (topology, _) = seam.topology(layout.topology());
        let rule_after = topology.connections();
        let links = sew::rebuild(&item.connections, layout.rule_links(), &rule_after, &seam);
        if let Some(record) = item.creases.as_mut() {
            record.record.remap(&item.connections, &links, &seam.origin);
        }
        item.particles.sew(&seam);
        item.connections.0 = links;
        seam.merge(&mut item.forces.0, |kept, other| *kept += *other);
        if let Some(previous) = item.previous.as_mut() {
            seam.merge(&mut previous.positions, |_, _| {});
            previous.still = false;
        }
        if let Some(anchors) = item.anchors.as_mut() {
            anchors.remap(&seam.map);
        }
        if let Some(grabs) = item.grabs.as_mut() {
            grabs.remap(&seam.map);
        }
        if let Some(skin) = item.skin.as_mut() {
            seam.merge(&mut skin.rest, |_, _| {});
            seam.merge(&mut skin.influences, |_, _| {});
            seam.merge(&mut skin.freedom, |_, _| {});
        }
        #[cfg(feature = "picking")]
        if let Some(pointers) = pointers.as_mut() {
            pointers.remap(message.cloth, &seam.map);
        }
        let sewn = layout.sewn(topology, &seam);
        sewn.keep_rule_links(rule_after);
        item.cloth.set_layout(sewn);
        commands.trigger(ClothSewn {
            entity: message.cloth,
            map: seam.map,
        });
    }
}
