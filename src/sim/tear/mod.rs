//! Tearing and cutting a triangle-mesh cloth: which particles a tear or a
//! blade splits, and the topology edit that opens the cloth there.
//!
//! A cloth opens along its triangles' edges; triangles are never cut. A
//! particle is split by a plane: its triangles on one side keep it, those
//! on the other side get a copy of it (same rest and current position),
//! which takes their share of its mass (by area). A triangle is on the side
//! of its particles that are not split, so a crack runs through the split
//! particles and each triangle lies wholly on one side of it; one whose
//! other particles straddle the plane goes to the side the split particle
//! is not on. The edges between the two sides open; the larger side keeps
//! the particle's index.
//!
//! - **A broken Type 1 link** splits one end, by the plane through that end
//!   across the link (the other end if the first has triangles on one side
//!   only). The crack opens across the link, along the edges at that end,
//!   where a real tear runs: across the stress. The load moves to the
//!   crack's tips, whose links break next, and the crack grows.
//! - **A blade** ([`Blade`]) splits, for every mesh edge that crosses it,
//!   the edge's end nearer the blade's plane, by that plane: the cut snaps
//!   to the particles next to it, and every edge it crosses opens. A
//!   straight cut across a grid opens it along the row of particles
//!   nearest to the cut. Blades in one plane are one cut; where two cuts
//!   cross, the particle there is split by both (its copy too), so crossing
//!   cuts part a cloth into the pieces between them.
//!
//! The links are then those of the new triangles ([`rebuild`]): each side
//! keeps its own edge links, and no Type 1 or Type 2 link reaches across an
//! opened edge, so nothing bends across a tear. The smallest piece a cloth
//! falls into is one triangle.

use std::collections::{HashMap, HashSet};

use bevy::math::Vec3;

use crate::sim::connections::{Connections, Link};
use crate::sim::topology::MeshTopology;

/// A plane a tear or cut separates triangles by: a point on it (m) and
/// its normal (unit).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Plane {
    point: Vec3,
    normal: Vec3,
}

impl Plane {
    /// Which side of the plane `p` is on (`true`: the normal's side, or on
    /// the plane).
    fn above(&self, p: Vec3) -> bool {
        (p - self.point).dot(self.normal) >= 0.0
    }
}

/// A cutting surface in world space: a triangle (m). A straight cut is the
/// two triangles of a quad ([`Blade::quad`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blade(pub [Vec3; 3]);

impl Blade {
    /// The two triangles of the quad `a, b, c, d` (m, in order around it).
    pub fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> [Self; 2] {
        [Self([a, b, c]), Self([a, c, d])]
    }

    /// The plane of the blade, if it has area.
    fn plane(&self) -> Option<Plane> {
        let [a, b, c] = self.0;
        let normal = (b - a).cross(c - a).try_normalize()?;
        Some(Plane { point: a, normal })
    }

    /// Whether the segment `p → q` (m) crosses the blade: its ends on
    /// opposite sides of the blade's plane (or one on it), meeting the
    /// plane within the triangle or within 10⁻⁴ of its size of it, so that
    /// a segment through an edge the blade's two triangles share is not
    /// missed.
    pub fn crosses(&self, p: Vec3, q: Vec3) -> bool {
        let [a, b, c] = self.0;
        let n = (b - a).cross(c - a);
        let (hp, hq) = ((p - a).dot(n), (q - a).dot(n));
        if hp * hq > 0.0 || hp == hq || !(hp.is_finite() && hq.is_finite()) {
            return false;
        }
        let hit = p + (q - p) * (hp / (hp - hq));
        // Barycentric coordinates of the hit in the blade.
        let nn = n.length_squared();
        let u = (c - b).cross(hit - b).dot(n) / nn;
        let v = (a - c).cross(hit - c).dot(n) / nn;
        let w = 1.0 - u - v;
        let slack = -1e-4;
        u >= slack && v >= slack && w >= slack
    }
}

/// What a tear or cut asks of a topology: particles to split, each with
/// the plane its triangles are sorted by, and a second choice for a
/// particle that the plane does not split.
#[derive(Clone, Debug, Default)]
pub(crate) struct TearPlan {
    splits: Vec<Split>,
    /// How many cracks the splits belong to (a broken link or a blade
    /// each).
    cracks: u32,
}

/// A particle to split by a plane, a second choice, and the crack it
/// belongs to.
type Split = (u32, Plane, Option<(u32, Plane)>, u32);

impl TearPlan {
    /// Adds `other`'s splits after this plan's.
    pub fn extend(&mut self, other: Self) {
        let offset = self.cracks;
        self.splits.extend(
            other
                .splits
                .into_iter()
                .map(|(v, p, s, c)| (v, p, s, c + offset)),
        );
        self.cracks += other.cracks;
    }
}

/// The triangles around each particle of one topology.
pub(crate) struct Adjacency {
    around: Vec<Vec<u32>>,
}

impl Adjacency {
    /// The adjacency of `topology`'s triangles.
    pub fn new(topology: &MeshTopology) -> Self {
        let mut around = vec![Vec::new(); topology.len()];
        for (t, tri) in topology.triangles.iter().enumerate() {
            for &p in tri {
                around[p as usize].push(t as u32);
            }
        }
        Self { around }
    }
}

/// The centroid of triangle `t` at positions `x` (m).
fn centroid(topology: &MeshTopology, x: &[Vec3], t: u32) -> Vec3 {
    let [a, b, c] = topology.triangles[t as usize];
    (x[a as usize] + x[b as usize] + x[c as usize]) / 3.0
}

/// Which side of `plane` triangle `t` goes to when its particle `v` (at
/// positions `x`, m) is split: the side of its particles that the crack
/// does not split (`split`; a copy counts as the particle it copies); a
/// triangle they straddle goes to the side `v` is not on, so the crack runs
/// through `v`; one whose particles all split, by its centroid.
fn above(
    topology: &MeshTopology,
    x: &[Vec3],
    plane: &Plane,
    (v, split, origin): (u32, &HashSet<u32>, &Origins),
    t: u32,
) -> bool {
    let height = |p: u32| (x[p as usize] - plane.point).dot(plane.normal);
    let (mut up, mut down) = (false, false);
    for &p in &topology.triangles[t as usize] {
        if p != v && !split.contains(&origin.of(p)) {
            let h = height(p);
            up |= h > 0.0;
            down |= h < 0.0;
        }
    }
    match (up, down) {
        (true, false) => true,
        (false, true) => false,
        (true, true) if height(v) != 0.0 => height(v) < 0.0,
        _ => plane.above(centroid(topology, x, t)),
    }
}

/// The particle each copy made during a tear comes from.
struct Origins {
    /// The first copy's index: the particle count before the tear.
    first_copy: u32,
    /// The original of each copy, in order.
    of_copy: Vec<u32>,
}

impl Origins {
    /// The particle before the tear that `p` is or copies.
    fn of(&self, p: u32) -> u32 {
        p.checked_sub(self.first_copy)
            .and_then(|k| self.of_copy.get(k as usize))
            .copied()
            .unwrap_or(p)
    }
}

/// The plan that breaks the Type 1 links `links` (particle pairs) of a
/// cloth at positions `x` (m): each opens a crack across it at one end,
/// the particle split by the plane through it across the link (the other
/// end if that splits nothing). A link of zero length or out of range is
/// skipped.
pub(crate) fn break_links(x: &[Vec3], links: &[(u32, u32)]) -> TearPlan {
    let mut plan = TearPlan::default();
    let n = x.len() as u32;
    for &(a, b) in links {
        if a >= n || b >= n || a == b {
            continue;
        }
        let (pa, pb) = (x[a as usize], x[b as usize]);
        let Some(normal) = (pb - pa).try_normalize() else {
            continue;
        };
        let at = |p: Vec3, normal: Vec3| Plane { point: p, normal };
        plan.splits
            .push((a, at(pa, normal), Some((b, at(pb, -normal))), plan.cracks));
        plan.cracks += 1;
    }
    plan
}

/// The plan that splits each particle `p` of `particles` by the plane
/// through it (at positions `x`, m) with normal `normal`: its triangles on
/// the normal's side keep it, the others get a copy, and the edges between
/// them open. Each is a crack of its own. A particle out of range, or a
/// normal that is zero or not finite, is skipped.
pub(crate) fn split_particles(x: &[Vec3], particles: &[(u32, Vec3)]) -> TearPlan {
    let mut plan = TearPlan::default();
    for &(p, normal) in particles {
        let (Some(&point), Some(normal)) = (x.get(p as usize), normal.try_normalize()) else {
            continue;
        };
        plan.splits
            .push((p, Plane { point, normal }, None, plan.cracks));
        plan.cracks += 1;
    }
    plan
}

/// The plan that cuts `topology` at positions `x` (m) along `blades`: for
/// every mesh edge that crosses a blade, its end nearer the blade's plane
/// is split by that plane. Also returns the Type 1 links the blades cross
/// (particle pairs, in increasing order).
pub fn cut(topology: &MeshTopology, x: &[Vec3], blades: &[Blade]) -> (TearPlan, Vec<(u32, u32)>) {
    let mut plan = TearPlan::default();
    let mut crossed = Vec::new();
    if x.len() < topology.len() {
        return (plan, crossed);
    }
    // One crack per plane: the two triangles of a quad are one cut.
    let planes: Vec<Option<Plane>> = blades.iter().map(Blade::plane).collect();
    let mut crack_of = Vec::with_capacity(blades.len());
    let mut cracks: Vec<Plane> = Vec::new();
    for plane in &planes {
        crack_of.push(plane.map(|p| {
            let same = cracks.iter().position(|c| {
                c.normal.dot(p.normal).abs() > 1.0 - 1e-6
                    && (p.point - c.point).dot(c.normal).abs() <= 1e-6 * (1.0 + p.point.length())
            });
            same.unwrap_or_else(|| {
                cracks.push(p);
                cracks.len() - 1
            })
        }));
    }
    plan.cracks = cracks.len() as u32;
    let mut edges: Vec<(u32, u32)> = topology
        .triangles
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    let mut chosen: HashSet<(u32, usize)> = HashSet::new();
    for (a, b) in edges {
        let (pa, pb) = (x[a as usize], x[b as usize]);
        let mut hit = false;
        for (blade, crack) in blades.iter().zip(&crack_of) {
            let Some(crack) = *crack else {
                continue;
            };
            if !blade.crosses(pa, pb) {
                continue;
            }
            hit = true;
            let plane = cracks[crack];
            let distance = |p: Vec3| (p - plane.point).dot(plane.normal).abs();
            let v = if distance(pa) <= distance(pb) { a } else { b };
            // Once per crack: a particle where two cuts cross is split by
            // both.
            if chosen.insert((v, crack)) {
                plan.splits.push((v, plane, None, crack as u32));
            }
        }
        if hit {
            crossed.push((a, b));
        }
    }
    (plan, crossed)
}

/// What a tear did to a topology.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TearOutcome {
    /// The particles added, each a copy of an earlier one: `(copy,
    /// original, share)`, where `share` is the fraction of the original's
    /// mass the copy takes (dimensionless, in (0, 1)). The original may be
    /// a copy made earlier in the same tear (where two cuts cross).
    pub copies: Vec<(u32, u32, f32)>,
}

impl TearOutcome {
    /// Whether the tear changed nothing.
    pub fn is_empty(&self) -> bool {
        self.copies.is_empty()
    }

    /// For each particle after the tear (`len` of them), the particle before
    /// it that it comes from (itself for the particles that were there; a
    /// copy of a copy comes from the first one's original).
    pub fn origins(&self, len: usize) -> Vec<u32> {
        let mut origin: Vec<u32> = (0..len as u32).collect();
        for &(copy, original, _) in &self.copies {
            let from = origin.get(original as usize).copied().unwrap_or(original);
            if let Some(o) = origin.get_mut(copy as usize) {
                *o = from;
            }
        }
        origin
    }
}

/// Opens `topology` (particles at `x`, m) as `plan` says (module docs):
/// each particle to split whose triangles lie on both sides of its plane
/// gets a copy (rest position copied), and the smaller side by area moves
/// to the copy. `adjacency` is the topology's before the tear.
pub(crate) fn apply(
    topology: &mut MeshTopology,
    adjacency: &Adjacency,
    x: &[Vec3],
    plan: &TearPlan,
) -> TearOutcome {
    let mut outcome = TearOutcome::default();
    if x.len() < topology.len() {
        return outcome;
    }
    // The positions of the particles and of the copies made so far.
    let mut x = x[..topology.len()].to_vec();
    // The particles each crack splits first: a triangle goes to the side of
    // its other particles, so that a cut snaps to them. Copies count as
    // split too.
    let mut cracks: HashMap<u32, HashSet<u32>> = HashMap::new();
    for &(v, _, _, crack) in &plan.splits {
        cracks.entry(crack).or_default().insert(v);
    }
    let none = HashSet::new();
    let mut origin = Origins {
        first_copy: topology.len() as u32,
        of_copy: Vec::new(),
    };
    let area = |topology: &MeshTopology, t: u32| {
        let [a, b, c] = topology.triangles[t as usize].map(|p| topology.positions[p as usize]);
        0.5 * (b - a).cross(c - a).length()
    };
    // Each particle with the copies made of it so far: a second plane
    // through a particle splits its copies too (two cuts that cross).
    let mut members: HashMap<u32, Vec<u32>> = HashMap::new();
    for &(first, plane, second, crack) in &plan.splits {
        let split = cracks.get(&crack).unwrap_or(&none);
        for (v, plane) in std::iter::once((first, plane)).chain(second) {
            let Some(fan) = adjacency.around.get(v as usize) else {
                continue;
            };
            let family = members.get(&v).cloned().unwrap_or_else(|| vec![v]);
            let mut any = false;
            for m in family {
                let (mut upper, mut lower) = ((0.0f32, Vec::new()), (0.0f32, Vec::new()));
                for &t in fan {
                    if !topology.triangles[t as usize].contains(&m) {
                        continue;
                    }
                    let side = if above(topology, &x, &plane, (m, split, &origin), t) {
                        &mut upper
                    } else {
                        &mut lower
                    };
                    side.0 += area(topology, t);
                    side.1.push(t);
                }
                if upper.1.is_empty() || lower.1.is_empty() {
                    continue;
                }
                let (kept, moved) = if upper.0 >= lower.0 {
                    (upper, lower)
                } else {
                    (lower, upper)
                };
                let total = kept.0 + moved.0;
                let share = if total > 0.0 { moved.0 / total } else { 0.5 };
                let copy = topology.len() as u32;
                outcome
                    .copies
                    .push((copy, m, share.clamp(1e-6, 1.0 - 1e-6)));
                let rest = topology.positions[m as usize];
                topology.positions.push(rest);
                x.push(x[m as usize]);
                for t in moved.1 {
                    for p in &mut topology.triangles[t as usize] {
                        if *p == m {
                            *p = copy;
                        }
                    }
                }
                members.entry(v).or_insert_with(|| vec![v]).push(copy);
                origin.of_copy.push(v);
                any = true;
            }
            if any {
                break;
            }
        }
    }
    outcome
}

/// The links of a cloth after a tear. `old` are its links before;
/// `before` and `after` the links [`MeshTopology::connections`] gives its
/// topology before and after the tear, and `origin` maps each particle
/// after the tear to its particle before ([`TearOutcome::origins`]).
///
/// A link of `old` that the topology's rule gives goes where the rule now
/// puts it: onto a copy, onto both sides of a crack, or nowhere when the
/// tear removed it, keeping its rest length (m), which a crease or the
/// game may have changed. Any other link of `old` (a grid's own, or one
/// the game added) stays if neither end was split. Links the rule adds
/// only after the tear (new continuations along a crack's sides) are not
/// added. Crease links and fold triples stay where their Type 2 link and
/// all their particles stay: a crease across a tear ends at the tear.
pub(crate) fn rebuild(
    old: &Connections,
    before: &Connections,
    after: &Connections,
    origin: &[u32],
) -> Connections {
    use crate::sim::connections::LinkFamily;
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let from = |p: u32| origin.get(p as usize).copied().unwrap_or(p);
    let split: HashSet<u32> = origin
        .iter()
        .enumerate()
        .filter(|&(p, &o)| p as u32 != o)
        .map(|(_, &o)| o)
        .collect();
    let mut out = Connections::default();
    for family in LinkFamily::ALL {
        let ruled: HashSet<(u32, u32)> = before
            .family(family)
            .iter()
            .map(|l| key(l.a, l.b))
            .collect();
        let mut now: HashMap<(u32, u32), Vec<(u32, u32)>> = HashMap::new();
        for l in after.family(family) {
            now.entry(key(from(l.a), from(l.b)))
                .or_default()
                .push((l.a, l.b));
        }
        let links = out.family_mut(family);
        for l in old.family(family) {
            let pair = key(l.a, l.b);
            if ruled.contains(&pair) {
                for &(a, b) in now.get(&pair).map_or(&[][..], Vec::as_slice) {
                    links.push(Link { a, b, ..*l });
                }
            } else if !split.contains(&l.a) && !split.contains(&l.b) {
                links.push(*l);
            }
        }
        links.sort_unstable_by_key(|l| (l.a, l.b));
        links.dedup_by_key(|l| (l.a, l.b));
    }
    let bends: HashSet<(u32, u32)> = out.type2().map(|l| key(l.a, l.b)).collect();
    let kept = |p: u32| !split.contains(&p);
    out.crease = old
        .crease
        .iter()
        .filter(|l| bends.contains(&key(l.a, l.b)) && kept(l.a) && kept(l.b))
        .copied()
        .collect();
    out.fold = old
        .fold
        .iter()
        .filter(|t| {
            bends.contains(&key(t.a, t.c))
                && [t.a, t.hinge, t.c].into_iter().chain(t.around).all(kept)
        })
        .copied()
        .collect();
    out
}

#[cfg(test)]
mod tests;
