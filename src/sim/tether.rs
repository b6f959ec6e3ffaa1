//! Tethers (long-range attachments): each free particle is kept within
//! `slack` times its rest geodesic distance of its nearest pinned particle,
//! measured along the Type 1 links. A long chain of soft links stretches
//! link by link under fast motion; a tether bounds the whole chain at once,
//! in one pass over the particles with no solve.
//!
//! The geodesic distances and nearest pins come from Dijkstra's search
//! over the links' rest lengths from every pinned particle at once
//! ([`Tethers::update`]), redone only when the pins or the links change.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use bevy::math::Vec3;

use crate::sim::connections::{Connections, LinkStamp};

/// Marks a particle with no pinned particle to tether to.
const NONE: u32 = u32::MAX;

/// Each particle's nearest pinned particle and its rest geodesic distance
/// to it (m), for the current pins.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tethers {
    /// Nearest pinned particle of each particle ([`u32::MAX`] for none;
    /// itself for a pinned one).
    anchor: Vec<u32>,
    /// Rest geodesic distance to it, m.
    length: Vec<f32>,
    /// What the tethers were made for: particles, links and pins.
    key: u64,
    /// The links' part of `key` and the stamp of the links it was
    /// computed for.
    links: (u64, Option<LinkStamp>),
}

impl Tethers {
    /// Makes the tethers of the cloth with links `connections` and inverse
    /// masses `inverse_masses` (1/kg, 0 pins) unless they are made already;
    /// returns whether they were (re)made.
    pub fn update(&mut self, connections: &Connections, inverse_masses: &[f32]) -> bool {
        self.update_tracked(connections, None, inverse_masses)
    }

    /// [`update`](Self::update) for links whose owner names them by
    /// `generation` (see
    /// [`StepBuffers::set_links_generation`](crate::sim::integrate::StepBuffers::set_links_generation)):
    /// while it stays the same, only the pins are compared.
    pub fn update_tracked(
        &mut self,
        connections: &Connections,
        generation: Option<u64>,
        inverse_masses: &[f32],
    ) -> bool {
        let stamp = connections.stamp(generation);
        if !LinkStamp::unchanged(self.links.1, stamp) {
            self.links.0 = links_key(connections);
        }
        self.links.1 = stamp;
        let key = key(self.links.0, inverse_masses);
        if key == self.key && self.anchor.len() == inverse_masses.len() {
            return false;
        }
        self.key = key;
        let n = inverse_masses.len();
        let mut neighbours: Vec<Vec<(u32, f32)>> = vec![Vec::new(); n];
        for l in connections.type1() {
            let (a, b) = (l.a as usize, l.b as usize);
            if a < n && b < n && l.rest_length.is_finite() && l.rest_length >= 0.0 {
                neighbours[a].push((l.b, l.rest_length));
                neighbours[b].push((l.a, l.rest_length));
            }
        }
        self.anchor.clear();
        self.anchor.resize(n, NONE);
        self.length.clear();
        self.length.resize(n, f32::INFINITY);
        // Non-negative f32s order as their bits.
        let mut queue = BinaryHeap::new();
        for (p, &w) in inverse_masses.iter().enumerate() {
            if w == 0.0 {
                self.anchor[p] = p as u32;
                self.length[p] = 0.0;
                queue.push(Reverse((0u32, p as u32)));
            }
        }
        while let Some(Reverse((bits, p))) = queue.pop() {
            let (p, d) = (p as usize, f32::from_bits(bits));
            if d > self.length[p] {
                continue;
            }
            for &(q, rest) in &neighbours[p] {
                let q = q as usize;
                let through = d + rest;
                if through < self.length[q] {
                    self.length[q] = through;
                    self.anchor[q] = self.anchor[p];
                    queue.push(Reverse((through.to_bits(), q as u32)));
                }
            }
        }
        true
    }

    /// Particle `p`'s nearest pinned particle and its rest geodesic
    /// distance (m), if it has one.
    pub fn anchor_of(&self, p: usize) -> Option<(u32, f32)> {
        match self.anchor.get(p) {
            Some(&a) if a != NONE => Some((a, self.length[p])),
            _ => None,
        }
    }

    /// Keeps every free particle within `slack` (≥ 1) times its rest
    /// geodesic distance of its pinned particle: one farther out is moved
    /// onto that sphere and loses its velocity away from the pin (relative
    /// to the pin's). `x` in m, `v` in m/s, `w` in 1/kg. Returns how many
    /// particles were moved.
    pub fn apply(&self, x: &mut [Vec3], v: &mut [Vec3], w: &[f32], slack: f32) -> u32 {
        if self.anchor.len() != x.len() || !(slack.is_finite() && slack >= 1.0) {
            return 0;
        }
        let mut moved = 0;
        for p in 0..x.len() {
            let a = self.anchor[p];
            if a == NONE || a as usize == p || w[p] == 0.0 {
                continue;
            }
            let a = a as usize;
            let longest = slack * self.length[p];
            let d = x[p] - x[a];
            let far = d.length_squared();
            if far <= longest * longest || !far.is_finite() {
                continue;
            }
            let n = d / far.sqrt();
            x[p] = x[a] + n * longest;
            let away = (v[p] - v[a]).dot(n);
            if away > 0.0 {
                v[p] -= away * n;
            }
            moved += 1;
        }
        moved
    }
}

/// Mixes `v` into the checksum `sum`.
fn mix(sum: &mut u64, v: u64) {
    *sum = sum.rotate_left(7).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ v;
}

/// A checksum of the Type 1 links: their ends and rest lengths.
fn links_key(connections: &Connections) -> u64 {
    let mut sum = 0;
    for l in connections.type1() {
        mix(&mut sum, ((l.a as u64) << 32) | l.b as u64);
        mix(&mut sum, l.rest_length.to_bits() as u64);
    }
    sum
}

/// What tethers depend on: the particle count, the Type 1 links (their
/// checksum `links`) and which particles are pinned.
fn key(links: u64, inverse_masses: &[f32]) -> u64 {
    let mut sum = inverse_masses.len() as u64;
    let mut mix = |v: u64| mix(&mut sum, v);
    mix(links);
    for (p, &w) in inverse_masses.iter().enumerate() {
        if w == 0.0 {
            mix(p as u64);
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 5 × 5 grid, 1 m, pinned at particle 0.
    fn grid() -> (Vec<Vec3>, Connections, Vec<f32>) {
        let x: Vec<Vec3> = (0..25)
            .map(|p| Vec3::new((p % 5) as f32 * 0.25, 0.0, (p / 5) as f32 * 0.25))
            .collect();
        let links = Connections::grid(5, 5, &x);
        let mut w = vec![1.0; 25];
        w[0] = 0.0;
        (x, links, w)
    }

    #[test]
    fn geodesics_follow_the_links_to_the_nearest_pin() {
        let (_, links, mut w) = grid();
        let mut t = Tethers::default();
        assert!(t.update(&links, &w));
        assert!(!t.update(&links, &w), "unchanged pins: nothing to redo");
        // Along the row: 4 spacings; the far corner: 4 diagonals.
        let (a, l) = t.anchor_of(4).unwrap();
        assert_eq!(a, 0);
        assert!((l - 1.0).abs() < 1e-6);
        let (_, l) = t.anchor_of(24).unwrap();
        assert!((l - 4.0 * 0.25 * 2f32.sqrt()).abs() < 1e-5);
        // A second pin at the far corner takes the particles nearer to it.
        w[24] = 0.0;
        assert!(t.update(&links, &w));
        assert_eq!(t.anchor_of(23).unwrap().0, 24);
        assert_eq!(t.anchor_of(1).unwrap().0, 0);
        // No pin: no tethers.
        assert!(t.update(&links, &[1.0; 25]));
        assert_eq!(t.anchor_of(3), None);
    }

    #[test]
    fn a_particle_past_its_tether_is_brought_back_and_stops_moving_away() {
        let (mut x, links, w) = grid();
        let mut t = Tethers::default();
        t.update(&links, &w);
        let mut v = vec![Vec3::ZERO; 25];
        x[24] = Vec3::new(5.0, -3.0, 2.0);
        v[24] = Vec3::new(2.0, 0.0, 0.0);
        x[12] += Vec3::new(0.01, 0.0, 0.0);
        let moved = t.apply(&mut x, &mut v, &w, 1.1);
        assert_eq!(moved, 1);
        let limit = 1.1 * 4.0 * 0.25 * 2f32.sqrt();
        assert!((x[24].distance(x[0]) - limit).abs() < 1e-5);
        assert!(v[24].dot(x[24] - x[0]) <= 1e-6);
        // Slack below 1 or NaN does nothing.
        assert_eq!(t.apply(&mut x, &mut v, &w, f32::NAN), 0);
    }
}
