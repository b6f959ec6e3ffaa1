//! Tearing and cutting cloth entities: [`ClothTearing`] (opt-in per cloth),
//! [`ClothCut`] (a blade from game code), and the [`ClothTorn`] event.
//!
//! After each fixed step ([`ClothSystems::Writeback`](crate::ClothSystems::Writeback)),
//! a cloth with [`ClothTearing`] breaks its most strained Type 1 links past
//! the threshold, and every cloth a [`ClothCut`] crosses is cut. How a
//! cloth opens: particles split along
//! the triangles' edges, so the pieces stay one entity, each side of a tear
//! with its own particles, links and rendered vertices (UVs kept). A piece
//! that falls away keeps stepping as part of the same cloth.
//!
//! A torn grid cloth becomes a mesh cloth (its [`Cloth::grid`] is gone) at
//! its first tear, with the same particles and links (its force loop then runs link
//! by link, its coarse correction by aggregation). On every tear:
//!
//! - the links are rebuilt:
//!   rest lengths carry over, nothing links or bends across the tear, and a
//!   crease across it ends there. The crease record follows the links
//!   ([`CreaseRecord::remap`](crate::sim::crease::CreaseRecord::remap)), so
//!   creases changed or removed later restore the torn cloth's rest lengths;
//! - a split particle's copy keeps the pins of the builder, the game, an
//!   anchor (the anchor gets an entry for the copy) and a skin (the copy
//!   takes the skin's binding); a grab or the pointer holds the original
//!   only;
//! - tethers are rebuilt from the new links at the next step, so a piece
//!   cut away is not held through the gap; the implicit solve's coarse
//!   correction is rebuilt from them too.
//!
//! Nothing runs for a scene without tearing cloths or cuts.

use bevy::ecs::query::QueryData;
use bevy::log::warn;
use bevy::math::Vec3;
use bevy::prelude::{
    Commands, Component, Entity, EntityEvent, Local, Message, MessageReader, Query, Reflect,
    ReflectComponent, ReflectDefault, Res,
};
use bevy::shape::Ray3d;

use crate::error::ClothError;
use crate::plugin::crease::ClothCreaseRecord;
use crate::plugin::render::mesh::ClothPrevious;
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::step::components::{
    Cloth, ClothConnections, ClothForces, ClothSettingsDefaults,
};
use crate::plugin::step::components::{ClothParticles, ClothSettings};
use crate::plugin::worn::anchor::ClothAnchors;
use crate::plugin::worn::skin::ClothSkin;
use crate::sim::connections::{Connections, Link};
use crate::sim::settings::ClothModel;
pub use crate::sim::tear::Blade;
use crate::sim::tear::{self, Adjacency, TearOutcome};

/// The strain (dimensionless) at which a cloth with a raw material
/// ([`ClothMaterial::Raw`]) tears unless its [`ClothTearing`] sets one:
/// 0.15, cotton's.
pub const DEFAULT_TEAR_STRAIN: f32 = 0.15;

/// Lets a cloth tear: after each fixed step, a Type 1 link stretched past
/// [`strain`](Self::strain), or pulled with more than
/// [`force`](Self::force), breaks (module docs). Opt-in: a cloth without it
/// never tears (it can still be cut with [`ClothCut`]).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) {
///     let banner = ClothBuilder::new(24, 32).material(ClothMaterial::SILK).build().unwrap();
///     // Tears at silk's strain, or at 40 N in any one link.
///     let tearing = ClothTearing::default().with_force(40.0).unwrap();
///     commands.spawn((banner, tearing));
/// }
/// ```
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct ClothTearing {
    /// The strain (dimensionless, > 0) at which a Type 1 link breaks:
    /// stretched by this fraction of its rest length. `None`: the cloth's
    /// fabric's [`tear_strain`](crate::Fabric::tear_strain)
    /// ([`DEFAULT_TEAR_STRAIN`] for a raw material).
    pub strain: Option<f32>,
    /// The tension (N, > 0) at which a Type 1 link breaks, whatever its
    /// strain. `None`: no force limit.
    pub force: Option<f32>,
    /// The most links that break in one fixed step, the most strained
    /// first: a tear grows over steps, from its tip, as a real one does.
    pub max_per_step: u32,
}

impl Default for ClothTearing {
    fn default() -> Self {
        Self {
            strain: None,
            force: None,
            max_per_step: 4,
        }
    }
}

impl ClothTearing {
    /// Tearing at `strain` (dimensionless, finite, > 0).
    pub fn with_strain(mut self, strain: f32) -> Result<Self, ClothError> {
        self.strain = Some(strain);
        self.validate().map(|()| self)
    }

    /// Tearing also at a tension of `newtons` (N, finite, > 0).
    pub fn with_force(mut self, newtons: f32) -> Result<Self, ClothError> {
        self.force = Some(newtons);
        self.validate().map(|()| self)
    }

    /// Checks the thresholds: finite and positive.
    pub fn validate(&self) -> Result<(), ClothError> {
        for (name, value) in [("strain", self.strain), ("force", self.force)] {
            if let Some(value) = value
                && !(value.is_finite() && value > 0.0)
            {
                return Err(ClothError::InvalidTearing { name, value });
            }
        }
        Ok(())
    }
}

/// Cuts cloths along a blade: every mesh edge that crosses it opens, at
/// the end nearer the blade. Write it as a
/// message (`MessageWriter<ClothCut>`); it acts after the next fixed step.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// /// A sword's edge moved from `from` to `to` this frame cuts every cloth.
/// fn slash(mut cuts: MessageWriter<ClothCut>, from: [Vec3; 2], to: [Vec3; 2]) {
///     cuts.write(ClothCut::swept(None, from, to));
/// }
/// ```
///
/// A cut can also name what to open by particle index, on one cloth
/// ([`ClothCut::links`], [`ClothCut::split`]): a seam unpicked link by
/// link, a buttonhole, a hole a game opens where something passed through.
#[derive(Message, Clone, Debug, Default, PartialEq)]
pub struct ClothCut {
    /// The cloth to cut, or every cloth (`None`).
    pub cloth: Option<Entity>,
    /// The cutting surface, triangles in world space (m).
    pub blades: Vec<Blade>,
    /// Type 1 links to break, as particle pairs of [`cloth`](Self::cloth)
    /// (ignored without one): each opens the cloth across it at one end,
    /// as a tear there would.
    /// A pair that is not a link, or out of range, is skipped.
    pub links: Vec<(u32, u32)>,
    /// Particles of [`cloth`](Self::cloth) to split (ignored without one),
    /// each by the plane through it with the given normal (world space, any
    /// length): its triangles on the normal's side keep it, the others get
    /// a copy, and the cloth opens between them.
    /// A particle out of range or a zero or non-finite normal is skipped.
    pub splits: Vec<(u32, Vec3)>,
}

impl ClothCut {
    /// A cut by the quad `a, b, c, d` (m, world, in order around it).
    pub fn quad(cloth: Option<Entity>, [a, b, c, d]: [Vec3; 4]) -> Self {
        Self {
            cloth,
            blades: Blade::quad(a, b, c, d).to_vec(),
            ..Self::default()
        }
    }

    /// Breaks the Type 1 links between the particle pairs `links` of
    /// `cloth` (see [`ClothCut::links`](Self::links)).
    pub fn links(cloth: Entity, links: impl IntoIterator<Item = (u32, u32)>) -> Self {
        Self {
            cloth: Some(cloth),
            links: links.into_iter().collect(),
            ..Self::default()
        }
    }

    /// Splits particle `particle` of `cloth` by the plane through it with
    /// normal `normal` (world space; see [`ClothCut::splits`](Self::splits)).
    pub fn split(cloth: Entity, particle: u32, normal: Vec3) -> Self {
        Self {
            cloth: Some(cloth),
            splits: vec![(particle, normal)],
            ..Self::default()
        }
    }

    /// A blade's edge swept from the segment `from` to the segment `to`
    /// (m, world): a sword's edge over one frame, scissors' closing blades.
    pub fn swept(cloth: Option<Entity>, from: [Vec3; 2], to: [Vec3; 2]) -> Self {
        Self::quad(cloth, [from[0], from[1], to[1], to[0]])
    }

    /// A cut along the segment `a → b` (m, world) drawn on the cloth,
    /// reaching `depth` (m) to either side of it: the quad `a ± depth`,
    /// `b ± depth`. Give `depth` across the cloth (along its normal).
    pub fn along(cloth: Option<Entity>, a: Vec3, b: Vec3, depth: Vec3) -> Self {
        Self::quad(cloth, [a - depth, b - depth, b + depth, a + depth])
    }

    /// A slash seen from a camera: the surface swept between two rays (a
    /// pointer's at two frames), `length` m along them. What a mouse drag
    /// across a cloth cuts.
    pub fn between_rays(cloth: Option<Entity>, from: Ray3d, to: Ray3d, length: f32) -> Self {
        Self::quad(
            cloth,
            [
                from.origin,
                to.origin,
                to.get_point(length),
                from.get_point(length),
            ],
        )
    }
}

/// A cloth tore or was cut, the fixed step it happened: triggered on the
/// cloth.
#[derive(EntityEvent, Clone, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub struct ClothTorn {
    /// The cloth.
    pub entity: Entity,
    /// The Type 1 links that broke or that a blade crossed, as particle
    /// pairs (indices before the tear, the smaller first).
    pub links: Vec<(u32, u32)>,
    /// Each particle split, with its new copy: `(particle, copy)`. The
    /// copies are the cloth's new last particles.
    pub split: Vec<(u32, u32)>,
}

/// What tearing reads and edits of one cloth.
#[derive(QueryData)]
#[query_data(mutable)]
pub(crate) struct TearQuery {
    entity: Entity,
    cloth: &'static mut Cloth,
    particles: &'static mut ClothParticles,
    connections: &'static mut ClothConnections,
    tearing: Option<&'static ClothTearing>,
    material: Option<&'static ClothMaterial>,
    settings: Option<&'static ClothSettings>,
    forces: &'static mut ClothForces,
    previous: Option<&'static mut ClothPrevious>,
    anchors: Option<&'static mut ClothAnchors>,
    skin: Option<&'static mut ClothSkin>,
    creases: Option<&'static mut ClothCreaseRecord>,
    sleep: &'static crate::plugin::step::sleep::ClothSleep,
}

/// Run condition of [`tear_cloths`]: a cloth tears, or a cut was written.
pub(crate) fn tearing_wanted(
    tearing: Query<(), bevy::prelude::With<ClothTearing>>,
    cuts: MessageReader<ClothCut>,
) -> bool {
    !tearing.is_empty() || !cuts.is_empty()
}

/// The tension (N) in link `l` at positions `x` (m) for stiffness `k`
/// (N/m), and its strain (dimensionless).
fn load(l: &Link, x: &[Vec3], k: f32) -> (f32, f32) {
    let length = x[l.a as usize].distance(x[l.b as usize]);
    let strain = length / l.rest_length - 1.0;
    (k * (length - l.rest_length).max(0.0), strain)
}

/// [`ClothSystems::Writeback`](crate::ClothSystems::Writeback): breaks the
/// links of tearing cloths past their thresholds, applies the cuts, and
/// triggers [`ClothTorn`].
pub(crate) fn tear_cloths(
    _main: crate::plugin::step::schedule::MainThread,
    mut commands: Commands,
    mut cuts: MessageReader<ClothCut>,
    defaults: Option<Res<ClothSettingsDefaults>>,
    mut warned: Local<Vec<Entity>>,
    mut cloths: Query<TearQuery>,
) {
    let cuts: Vec<ClothCut> = cuts.read().cloned().collect();
    let fallback = ClothSettingsDefaults::default();
    let defaults = defaults.as_deref().unwrap_or(&fallback);
    for mut item in &mut cloths {
        let entity = item.entity;
        if item.particles.positions.len() != item.cloth.len()
            || crate::plugin::step::components::check_cloth(&item.particles, &item.connections)
                .is_err()
            || !item.particles.is_finite()
        {
            continue;
        }
        let mut broken: Vec<(u32, u32)> = Vec::new();
        // A sleeping cloth has not moved since it was checked.
        if let Some(tearing) = item.tearing.filter(|_| !item.sleep.is_asleep()) {
            match tearing.validate() {
                Err(error) if !warned.contains(&entity) => {
                    warned.push(entity);
                    warn!("cloth {entity} does not tear: {error}");
                }
                Err(_) => {}
                Ok(()) => broken = overloaded(&item, tearing, defaults),
            }
        }
        let blades = blades_for(&cuts, entity, &item.particles.positions);
        // What game code names by index: links that are Type 1 links, and
        // particles to split.
        let mine = || cuts.iter().filter(|c| c.cloth == Some(entity));
        let asked = asked_links(&item.connections, mine(), &broken);
        broken.extend(asked);
        let splits: Vec<(u32, Vec3)> = mine().flat_map(|c| c.splits.iter().copied()).collect();
        if broken.is_empty() && blades.is_empty() && splits.is_empty() {
            continue;
        }
        if let Some(torn) = tear_one(&mut item, broken, &blades, &splits) {
            commands.trigger(torn);
        }
    }
}

/// The links of a tearing cloth past its strain or force threshold this
/// step, the most strained first, at most `tearing.max_per_step`.
fn overloaded(
    item: &TearQueryItem,
    tearing: &ClothTearing,
    defaults: &ClothSettingsDefaults,
) -> Vec<(u32, u32)> {
    let material = item.material.copied().unwrap_or_default();
    let base = item.settings.map_or(&defaults.0, |s| &s.0);
    let settings = material.settings(base, item.cloth.spacing());
    let (k_axial, k_diagonal) = match settings.model {
        ClothModel::ChoiKo => (settings.choi_ko.stiffness, settings.choi_ko.shear_stiffness),
        ClothModel::Lander => (
            settings.lander.structural.stiffness,
            settings.lander.shear.stiffness,
        ),
    };
    let strain_limit = tearing.strain.unwrap_or(
        material
            .fabric()
            .map_or(DEFAULT_TEAR_STRAIN, |f| f.tear_strain),
    );
    let force_limit = tearing.force.unwrap_or(f32::INFINITY);
    let x = &item.particles.positions;
    let mut over: Vec<(f32, (u32, u32))> = Vec::new();
    for (links, k) in [
        (&item.connections.structural, k_axial),
        (&item.connections.shear, k_diagonal),
    ] {
        for l in links.iter().filter(|l| l.rest_length > 0.0) {
            let (force, strain) = load(l, x, k);
            if strain > strain_limit || force > force_limit {
                over.push((strain, (l.a.min(l.b), l.a.max(l.b))));
            }
        }
    }
    over.sort_by(|p, q| q.0.total_cmp(&p.0));
    over.truncate(tearing.max_per_step as usize);
    over.into_iter().map(|(_, pair)| pair).collect()
}

/// The blades of `cuts` meant for `entity` (or for every cloth) that reach
/// the box of its positions `x` (m): a cut that misses it costs it nothing
/// more.
fn blades_for(cuts: &[ClothCut], entity: Entity, x: &[Vec3]) -> Vec<Blade> {
    let mut blades: Vec<Blade> = cuts
        .iter()
        .filter(|c| c.cloth.is_none_or(|e| e == entity))
        .flat_map(|c| c.blades.iter().copied())
        .collect();
    if !blades.is_empty() {
        let (lo, hi) = x
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(*p), hi.max(*p))
            });
        blades.retain(|blade| {
            let [a, b, c] = blade.0;
            a.min(b).min(c).cmple(hi).all() && a.max(b).max(c).cmpge(lo).all()
        });
    }
    blades
}

/// The links the cloth's own `cuts` name by index that are Type 1 links of
/// `connections` and not already in `broken`, each once.
fn asked_links<'a>(
    connections: &Connections,
    cuts: impl Iterator<Item = &'a ClothCut>,
    broken: &[(u32, u32)],
) -> Vec<(u32, u32)> {
    let mut asked: Vec<(u32, u32)> = cuts
        .flat_map(|c| c.links.iter().map(|&(a, b)| (a.min(b), a.max(b))))
        .collect();
    if asked.is_empty() {
        return asked;
    }
    asked.sort_unstable();
    asked.dedup();
    let mut found: Vec<(u32, u32)> = connections
        .type1()
        .map(|l| (l.a.min(l.b), l.a.max(l.b)))
        .filter(|pair| asked.binary_search(pair).is_ok())
        .collect();
    found.sort_unstable();
    found.dedup();
    found.retain(|pair| !broken.contains(pair));
    found
}

/// Breaks the `broken` links of one cloth, splits its `splits` particles
/// and cuts it along `blades`: its topology, links, per-particle state and
/// crease record follow. What tore, if anything did.
fn tear_one(
    item: &mut TearQueryItem,
    mut broken: Vec<(u32, u32)>,
    blades: &[Blade],
    splits: &[(u32, Vec3)],
) -> Option<ClothTorn> {
    let x = &item.particles.positions;
    let layout = item.cloth.layout().clone();
    let mut topology = layout.topology().clone();
    let adjacency = Adjacency::new(&topology);
    let mut plan = tear::break_links(x, &broken);
    plan.extend(tear::split_particles(x, splits));
    let (cut, crossed) = tear::cut(&topology, x, blades);
    plan.extend(cut);
    let outcome = tear::apply(&mut topology, &adjacency, x, &plan);
    if outcome.is_empty() {
        return None;
    }
    // The layout still holds the topology before the tear.
    let origins = outcome.origins(topology.len());
    let rule_after = topology.connections();
    let links = tear::rebuild(
        &item.connections,
        layout.rule_links(),
        &rule_after,
        &origins,
    );
    if let Some(record) = item.creases.as_mut() {
        record.record.remap(&item.connections, &links, &origins);
    }
    split_state(item, &outcome);
    item.connections.0 = links;
    let torn = layout.torn(topology);
    torn.keep_rule_links(rule_after);
    item.cloth.set_layout(torn);
    broken.extend(crossed);
    broken.sort_unstable();
    broken.dedup();
    Some(ClothTorn {
        entity: item.entity,
        links: broken,
        split: outcome.copies.iter().map(|&(c, o, _)| (o, c)).collect(),
    })
}

/// Gives every per-particle array of the cloth its copies (in order).
fn split_state(item: &mut TearQueryItem, outcome: &TearOutcome) {
    for &(copy, original, share) in &outcome.copies {
        let o = original as usize;
        let made = item.particles.push_copy(o, share);
        debug_assert_eq!(made, Some(copy));
        copy_entry(&mut item.forces.0, o, copy);
        if let Some(previous) = item.previous.as_mut() {
            copy_entry(&mut previous.positions, o, copy);
        }
        if let Some(anchors) = item.anchors.as_mut()
            && let Some(a) = anchors.0.iter().find(|a| a.particle == original).copied()
        {
            anchors.attach(copy, a.target, a.offset);
        }
        if let Some(skin) = item.skin.as_mut() {
            copy_entry(&mut skin.rest, o, copy);
            copy_entry(&mut skin.influences, o, copy);
            copy_entry(&mut skin.freedom, o, copy);
        }
    }
}

/// Sets `v[copy]` to `v[original]` when `v` has `original` and reaches
/// `copy` once grown by one.
fn copy_entry<T: Clone>(v: &mut Vec<T>, original: usize, copy: u32) {
    if v.len() == copy as usize
        && let Some(e) = v.get(original).cloned()
    {
        v.push(e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_must_be_finite_and_positive() {
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                ClothTearing::default().with_strain(bad),
                Err(ClothError::InvalidTearing { name: "strain", .. })
            ));
            assert!(matches!(
                ClothTearing::default().with_force(bad),
                Err(ClothError::InvalidTearing { name: "force", .. })
            ));
        }
        let ok = ClothTearing::default().with_strain(0.2).unwrap();
        assert_eq!(ok.with_force(30.0).unwrap().force, Some(30.0));
    }

    #[test]
    fn a_slash_between_two_rays_spans_them() {
        let from = Ray3d::new(Vec3::ZERO, bevy::math::Dir3::NEG_Z);
        let to = Ray3d::new(Vec3::X, bevy::math::Dir3::NEG_Z);
        let cut = ClothCut::between_rays(None, from, to, 10.0);
        let crosses = |p: Vec3, q: Vec3| cut.blades.iter().any(|b| b.crosses(p, q));
        assert!(crosses(
            Vec3::new(0.5, 1.0, -5.0),
            Vec3::new(0.5, -1.0, -5.0)
        ));
        assert!(!crosses(
            Vec3::new(1.5, 1.0, -5.0),
            Vec3::new(1.5, -1.0, -5.0)
        ));
        assert!(!crosses(
            Vec3::new(0.5, 1.0, -11.0),
            Vec3::new(0.5, -1.0, -11.0)
        ));
    }
}
