//! A cloth's contacts with the other cloths near it during its step: the
//! colliding cloths of the step as each sees the others ([`Neighbour`]),
//! which of them are near a cloth ([`NeighbourScratch`]), and the contacts
//! the [`SceneContacts`](crate::sim::collision::scene::SceneContacts) hook
//! holds and resolves with them ([`NeighbourContacts`]).

use bevy::math::Vec3;

use super::{ClothObstacle, ObstacleBuffers, Pair};
use crate::sim::integrate::implicit::{Hold, SolveContact};
use crate::sim::step::Substep;

/// One colliding cloth of the step, as the others see it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Neighbour {
    /// Its surface over the step.
    pub(crate) obstacle: ClothObstacle,
    /// Side of its hash cells, m.
    pub(crate) cell: f32,
}

/// A colliding cloth's scratch: the neighbours near it in this step and
/// the contact passes' lists.
#[derive(Clone, Debug, Default)]
pub(crate) struct NeighbourScratch {
    /// Index among the step's [`Neighbour`]s of the cloth itself, and of
    /// each one near it with the pair's contact.
    pub(crate) near: (Option<usize>, Vec<(usize, Pair)>),
    /// The passes' lists.
    pub(crate) buffers: ObstacleBuffers,
    /// The sum of the unit normals of the contacts listed for each particle
    /// in the substep: the colliders', then the other cloths' (the nearest).
    pub(crate) support: Vec<Vec3>,
    /// The contacts with other cloths of the last prediction, one a
    /// particle (the nearest), and the friction coefficient of each.
    pub(crate) held: Vec<(SolveContact, f32)>,
}

/// A cloth's contacts with other cloths during its step, called by the
/// integrators' contact hook
/// ([`SceneContacts`](crate::sim::collision::scene::SceneContacts)).
pub(crate) struct NeighbourContacts<'a> {
    /// Every colliding cloth of the step.
    pub(crate) neighbours: &'a [Neighbour],
    /// The cloth's own entry and its neighbours.
    pub(crate) scratch: &'a mut NeighbourScratch,
    /// Contacts listed and particles put back so far.
    pub(crate) contacts: u32,
    /// Gravity, m/s².
    pub(crate) gravity: Vec3,
}

impl NeighbourContacts<'_> {
    /// Seconds into the step at the substep's start and end.
    fn times(sub: Substep) -> (f32, f32) {
        let span = sub.to - sub.from;
        if span.is_nan() || span <= 0.0 {
            return (0.0, 0.0);
        }
        // The end as the contacts' prediction reckons it, to the bit.
        let from = sub.from * (sub.dt / span);
        (from, from + sub.dt)
    }
    /// Adds the contacts that hold the cloth (positions `x` m, velocities
    /// `v` m/s, inverse masses `w` 1/kg) off its neighbours over `sub`.
    pub(crate) fn predict(
        &mut self,
        sub: Substep,
        (x, v, w): (&[Vec3], &[Vec3], &[f32]),
        out: &mut Vec<SolveContact>,
    ) {
        let (Some(own), near) = &self.scratch.near else {
            return;
        };
        let me = &self.neighbours[*own];
        if me.obstacle.x.len() != x.len() {
            return;
        }
        let generation = me.obstacle.generation();
        self.scratch.buffers.set_faces_generation(generation);
        let (from, _) = Self::times(sub);
        let before = out.len();
        self.scratch.held.clear();
        // What each particle lies on already (the colliders' contacts).
        let support = &mut self.scratch.support;
        support.clear();
        support.resize(x.len(), Vec3::ZERO);
        for c in &out[..before] {
            if let Some(s) = support.get_mut(c.particle as usize) {
                *s += c.normal;
            }
        }
        for &(k, pair) in near.iter() {
            let from_here = out.len();
            super::predict_cloth_contacts(
                &me.obstacle.faces,
                (x, v, w),
                (from, sub.dt),
                me.cell,
                &self.neighbours[k].obstacle,
                pair,
                &mut self.scratch.buffers,
                out,
            );
            super::predict_edge_contacts(
                &me.obstacle.faces,
                (x, v, w),
                (from, sub.dt),
                &self.neighbours[k].obstacle,
                pair,
                &mut self.scratch.buffers,
                out,
            );
            // A particle lying on a collider is not pressed into it by
            // another cloth: that cloth rests on this one instead (its own
            // particles are held off this one's triangles in its step).
            let support = &self.scratch.support;
            let mut kept = from_here;
            for i in from_here..out.len() {
                let c = out[i];
                if c.normal.dot(support[c.particle as usize]) >= 0.0 {
                    out[kept] = c;
                    kept += 1;
                }
            }
            out.truncate(kept);
            let held = &mut self.scratch.held;
            held.extend(out[from_here..].iter().map(|&c| (c, pair.friction)));
        }
        // One contact a particle for its friction: the nearest.
        let held = &mut self.scratch.held;
        held.sort_unstable_by(|a, b| {
            (a.0.particle.cmp(&b.0.particle)).then(a.0.gap.total_cmp(&b.0.gap))
        });
        held.dedup_by_key(|c| c.0.particle);
        for (c, _) in held.iter() {
            self.scratch.support[c.particle as usize] += c.normal;
        }
        self.contacts += (out.len() - before) as u32;
    }

    /// After a substep: puts back the particles and edges that passed
    /// through a neighbour (`start` → `x`, m; `v`, m/s; `w`, 1/kg; `held` by
    /// the solve, or empty).
    pub(crate) fn resolve(
        &mut self,
        sub: Substep,
        (start, x, v): (&[Vec3], &mut [Vec3], &mut [Vec3]),
        w: &[f32],
        held: &[Hold],
    ) {
        let (Some(own), near) = &self.scratch.near else {
            return;
        };
        let held_on = &self.scratch.held;
        super::rub(held_on, v, held, (self.gravity, sub.dt));
        let me = &self.neighbours[*own].obstacle;
        self.scratch.buffers.set_faces_generation(me.generation());
        let faces = &me.faces;
        // What each particle lies on: its contacts' normals, colliders' and
        // other cloths' (none without the implicit solve).
        let support = if held.len() == x.len() && self.scratch.support.len() == x.len() {
            &self.scratch.support[..]
        } else {
            &[]
        };
        for &(k, pair) in near.iter() {
            let other = &self.neighbours[k].obstacle;
            self.contacts += super::undo_crossings(
                start,
                x,
                v,
                w,
                held,
                Self::times(sub),
                other,
                pair,
                &mut self.scratch.buffers,
            );
            self.contacts += super::undo_edge_crossings(
                faces,
                start,
                x,
                v,
                w,
                (held, support),
                Self::times(sub),
                other,
                pair,
                &mut self.scratch.buffers,
            );
        }
    }
}
