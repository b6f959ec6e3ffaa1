//! Sewing a triangle-mesh cloth: seams that join particles into one, the
//! opposite edit of a tear ([`tear`](crate::sim::tear)).
//!
//! A seam is a list of particle pairs. The particles of each pair (and of
//! pairs that chain through a shared particle) become one particle, the
//! one with the smallest index; the others leave the cloth, and the
//! particles after them move down to close the gaps, in order
//! ([`Seam::map`]). The triangles that used a particle that left use the
//! one it joined; a triangle left with a repeated particle (one whose two
//! corners were sewn together) is dropped.
//!
//! The links are then those of the new triangles by the mesh rule
//! ([`rebuild`]): a link that was there before keeps its rest length (the
//! mean of those that land on it, where a seam lays two edges onto one),
//! and a link the seam makes (a Type 2 link across it) takes its length in
//! the rest shape. The joined particle keeps the rest position of the one
//! it is, so a seam belongs between edges that lie together in the rest
//! shape: a tear mended, the two sides of a mesh's seam that were not
//! welded on import.

use std::collections::HashMap;

use bevy::math::Vec3;

use crate::sim::connections::{Connections, FoldTriple, Link, LinkFamily};
use crate::sim::topology::{MeshTopology, non_manifold_edges};

/// Which particle each particle of a cloth becomes after a seam.
#[derive(Clone, Debug, PartialEq)]
pub struct Seam {
    /// For each particle before the seam, its index after it.
    pub map: Vec<u32>,
    /// Particles after the seam.
    pub count: usize,
    /// For each particle after the seam, the particle it was before (the
    /// smallest of those sewn into it).
    pub origin: Vec<u32>,
}

impl Seam {
    /// The seam that joins the particle pairs `pairs` of a cloth of `n`
    /// particles; `None` when it joins nothing (every pair out of range or
    /// a particle with itself).
    pub fn new(n: usize, pairs: &[(u32, u32)]) -> Option<Self> {
        let mut root: Vec<u32> = (0..n as u32).collect();
        fn find(root: &mut [u32], mut p: u32) -> u32 {
            while root[p as usize] != p {
                let up = root[root[p as usize] as usize];
                root[p as usize] = up;
                p = up;
            }
            p
        }
        let mut joined = false;
        for &(a, b) in pairs {
            if a as usize >= n || b as usize >= n {
                continue;
            }
            let (ra, rb) = (find(&mut root, a), find(&mut root, b));
            if ra != rb {
                // The smaller index stays.
                root[ra.max(rb) as usize] = ra.min(rb);
                joined = true;
            }
        }
        if !joined {
            return None;
        }
        let mut map = vec![0; n];
        let mut origin = Vec::new();
        for p in 0..n as u32 {
            let r = find(&mut root, p);
            if r == p {
                map[p as usize] = origin.len() as u32;
                origin.push(p);
            } else {
                // Roots are smaller than their members: mapped already.
                map[p as usize] = map[r as usize];
            }
        }
        Some(Self {
            count: origin.len(),
            map,
            origin,
        })
    }

    /// `p`'s index after the seam (`p` itself when out of range).
    fn at(&self, p: u32) -> u32 {
        self.map.get(p as usize).copied().unwrap_or(p)
    }

    /// `topology` after the seam, and for each of its triangles whether it
    /// is kept (not left with a repeated particle).
    pub fn topology(&self, topology: &MeshTopology) -> (MeshTopology, Vec<bool>) {
        let mut kept = Vec::with_capacity(topology.triangles.len());
        let mut triangles = Vec::with_capacity(topology.triangles.len());
        for t in &topology.triangles {
            let [a, b, c] = t.map(|p| self.at(p));
            let keep = a != b && b != c && c != a;
            kept.push(keep);
            if keep {
                triangles.push([a, b, c]);
            }
        }
        let positions = self
            .origin
            .iter()
            .map(|&p| {
                topology
                    .positions
                    .get(p as usize)
                    .copied()
                    .unwrap_or(Vec3::ZERO)
            })
            .collect();
        let dropped = kept.iter().filter(|k| !**k).count();
        let out = MeshTopology {
            positions,
            non_manifold_edges: non_manifold_edges(&triangles),
            triangles,
            particle_of: topology
                .particle_of
                .iter()
                .map(|p| p.map(|p| self.at(p)))
                .collect(),
            degenerate_triangles: topology.degenerate_triangles + dropped,
        };
        (out, kept)
    }

    /// Combines the per-particle values `v` (one per particle before the
    /// seam) into one per particle after it: `join(kept, other)` folds each
    /// sewn particle's value into the one it joined. A list of another
    /// length is left alone.
    pub fn merge<T: Clone>(&self, v: &mut Vec<T>, mut join: impl FnMut(&mut T, &T)) {
        if v.len() != self.map.len() {
            return;
        }
        let mut out: Vec<T> = self.origin.iter().map(|&p| v[p as usize].clone()).collect();
        for (p, &to) in self.map.iter().enumerate() {
            if self.origin[to as usize] != p as u32 {
                join(&mut out[to as usize], &v[p]);
            }
        }
        *v = out;
    }
}

/// The links of a cloth after the seam `seam`: `old`, its links before;
/// `before` and `after`, the mesh rule's links of its topology before and
/// after the seam ([`MeshTopology::connections`]).
///
/// Each link of the rule after the seam keeps the rest length of the old
/// links of its family that land on it (their mean), or has the rule's
/// where none does (a link across the seam); an old link that is not the
/// rule's (a grid's own) is kept where it lands on two particles; crease
/// links and fold triples are kept where their particles stay apart.
pub fn rebuild(
    old: &Connections,
    before: &Connections,
    after: &Connections,
    seam: &Seam,
) -> Connections {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut out = Connections::default();
    for family in LinkFamily::ALL {
        let ruled: std::collections::HashSet<(u32, u32)> = before
            .family(family)
            .iter()
            .map(|l| key(l.a, l.b))
            .collect();
        let mut landed: HashMap<(u32, u32), (f32, u32)> = HashMap::new();
        let mut own: Vec<Link> = Vec::new();
        for l in old.family(family) {
            let (a, b) = (seam.at(l.a), seam.at(l.b));
            if a == b {
                continue;
            }
            if ruled.contains(&key(l.a, l.b)) {
                let sum = landed.entry(key(a, b)).or_insert((0.0, 0));
                sum.0 += l.rest_length;
                sum.1 += 1;
            } else {
                own.push(Link { a, b, ..*l });
            }
        }
        let links = out.family_mut(family);
        for l in after.family(family) {
            let rest_length = landed
                .get(&key(l.a, l.b))
                .map_or(l.rest_length, |&(sum, count)| sum / count as f32);
            links.push(Link { rest_length, ..*l });
        }
        links.extend(own);
        links.sort_unstable_by_key(|l| key(l.a, l.b));
        links.dedup_by_key(|l| key(l.a, l.b));
    }
    out.crease = old
        .crease
        .iter()
        .map(|l| Link {
            a: seam.at(l.a),
            b: seam.at(l.b),
            ..*l
        })
        .filter(|l| l.a != l.b)
        .collect();
    out.fold = old
        .fold
        .iter()
        .map(|t| FoldTriple {
            a: seam.at(t.a),
            hinge: seam.at(t.hinge),
            c: seam.at(t.c),
            around: t.around.map(|p| seam.at(p)),
            ..*t
        })
        .filter(|t| t.a != t.hinge && t.hinge != t.c && t.c != t.a)
        .collect();
    out
}

#[cfg(test)]
mod tests;
