//! Creases (paper §5, MODEL.md §9): a fold line in the cloth's rest
//! coordinates shortens the Type 2 connections that cross it and adds a
//! Type 1 tension spring of the new length across each, so the cloth folds
//! there and stays folded.
//!
//! Beyond the paper (which only folds along grid lines and whose folds can
//! flip):
//! - a [`Crease`] is a segment in any direction in the cloth's rest space
//!   ([`RestSurface`]: a grid's `(u, 0, v)`, a mesh's own coordinates), on
//!   grid and mesh cloths alike; a polyline is one crease per segment. A
//!   connection is selected when its ends lie strictly on opposite sides of
//!   the plane through the segment along the ends' rest normal, and it
//!   crosses that plane beside the segment itself (on a grid: a sign test
//!   in rest `(u, v)` metres, §9.5);
//! - every selected connection gets its own rest length from the fold
//!   geometry (§9.2): for ends at distances `d_a`, `d_b` from that plane and a
//!   fold (turning) angle `β`, `L'² = L² − 2 d_a d_b (1 − cos β)`. A ratio
//!   `r` means the angle that gives the axial connection centred on the
//!   hinge `L' = rL`, `β = 2 acos r` (so `r = 0.7` folds about 91°), and
//!   diagonal connections get their own ratio;
//! - [`FoldSide::Mountain`] or [`FoldSide::Valley`] adds the fold-direction
//!   term of §9.4b on each crossing triple `(a, b, c)` (hinge `b`, the
//!   particle midway; on a mesh the ends' common neighbour, whose `σ_min`
//!   allows for its distance from the plane): while the hinge's signed
//!   height `σ = (x_b − ½(x_a + x_c))·n_b` is below `σ_min` on the chosen
//!   side, a force `k_σ(σ_min − σ·s)·s·n_b` lifts it (and half of it pulls
//!   on each end), so the fold cannot flip. [`FoldSide::Free`] is the paper's
//!   behaviour.
//!
//! The angle of §9.2 is that of rigid flaps: a sheet stiff enough in
//! bending to keep its flaps flat (measured: `k_b = 10⁻⁴ N·m²` on a 1 m,
//! 15×15 sheet; r = 0.7 folds to 92.8°, a 45° target to 42.3°) folds to it;
//! limp cloth (cotton's `5·10⁻⁷`) pleats around the line instead, since
//! nothing but bending resists the hinge column popping out.
//!
//! `restore` puts back the original rest lengths exactly, so creases
//! can change or go at any time. In an app, the `ClothCreases` component
//! holds a cloth's creases.

use std::collections::{HashMap, HashSet};

use bevy::math::{Vec2, Vec3, Vec3Swizzles};
use bevy::reflect::Reflect;

use crate::error::ClothError;
use crate::sim::connections::{Connections, FoldTriple, Link, LinkFamily};

mod surface;

pub use surface::RestSurface;

/// Which way a crease folds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum FoldSide {
    /// Either way, and it may flip (the paper).
    #[default]
    Free,
    /// The hinge rises along the cloth's rest normal (`+v × +u` side up
    /// for a [`ClothBuilder`](crate::ClothBuilder) sheet, the side its
    /// triangles wind counter-clockwise about on a mesh cloth).
    Mountain,
    /// The hinge sinks.
    Valley,
}

/// How far a crease folds.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum FoldAmount {
    /// The paper's ratio `r ∈ (0, 1]`: the axial connection centred on the
    /// hinge rests at `rL` (1 = no fold).
    Ratio(f32),
    /// The turning angle `β` between the two flaps in rad, in `[0, π)`.
    Angle(f32),
}

impl FoldAmount {
    /// The turning angle β in rad.
    pub fn angle(self) -> f32 {
        match self {
            FoldAmount::Ratio(r) => 2.0 * r.clamp(0.0, 1.0).acos(),
            FoldAmount::Angle(beta) => beta,
        }
    }
}

/// One fold line of a cloth: a segment in its rest space (m,
/// [`RestSurface`]). A fold along a polyline is one crease per segment; a
/// connection two of them select is folded by the first.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct Crease {
    /// Start of the segment in the cloth's rest space, m: `(u, 0, v)` on a
    /// grid cloth ([`Crease::new`]), the mesh's coordinates on a mesh cloth.
    pub from: Vec3,
    /// End of the segment in the cloth's rest space, m.
    pub to: Vec3,
    /// How far it folds.
    pub amount: FoldAmount,
    /// Which way it folds.
    pub side: FoldSide,
    /// `k_σ` of the fold-direction term in N/m (unused for `Free`).
    pub stiffness: f32,
}

impl Crease {
    /// A free crease from `from` to `to` in a grid's rest coordinates
    /// `(u, v)` (m; the rest space's `(u, 0, v)`, which is also the xz plane
    /// of a flat mesh) with the paper's ratio 0.7 and `k_σ` = 20 N/m.
    pub fn new(from: Vec2, to: Vec2) -> Self {
        Self::on_rest(Vec3::new(from.x, 0.0, from.y), Vec3::new(to.x, 0.0, to.y))
    }

    /// A free crease from `from` to `to` in the cloth's rest space (m): a
    /// mesh cloth's mesh coordinates, the points on or near its rest
    /// surface. Ratio 0.7, `k_σ` = 20 N/m.
    pub fn on_rest(from: Vec3, to: Vec3) -> Self {
        Self {
            from,
            to,
            amount: FoldAmount::Ratio(0.7),
            side: FoldSide::Free,
            stiffness: 20.0,
        }
    }

    /// The same crease with ratio `r`.
    pub fn with_ratio(mut self, r: f32) -> Self {
        self.amount = FoldAmount::Ratio(r);
        self
    }

    /// The same crease folding by `beta` rad.
    pub fn with_angle(mut self, beta: f32) -> Self {
        self.amount = FoldAmount::Angle(beta);
        self
    }

    /// The same crease folding to `side`.
    pub fn with_side(mut self, side: FoldSide) -> Self {
        self.side = side;
        self
    }

    /// Checks the crease against `cloth`: finite values, a ratio in (0, 1]
    /// or an angle in [0, π), a positive length, and a segment that meets
    /// the cloth: a grid's rest rectangle (seen along `y`), a mesh's
    /// surface (some Type 2 connection of `connections` crosses it).
    pub fn validate(
        &self,
        cloth: &RestSurface,
        connections: &Connections,
    ) -> Result<(), ClothError> {
        self.validate_meeting(cloth, || !crossings(cloth, connections, self).is_empty())
    }

    /// [`validate`](Self::validate), with `meets_mesh` telling whether the
    /// segment meets a mesh cloth (asked only of a mesh, and last).
    fn validate_meeting(
        &self,
        cloth: &RestSurface,
        meets_mesh: impl FnOnce() -> bool,
    ) -> Result<(), ClothError> {
        let finite = self.from.is_finite() && self.to.is_finite() && self.stiffness.is_finite();
        if !finite || self.stiffness < 0.0 {
            return Err(ClothError::InvalidCrease(
                "values must be finite, stiffness non-negative",
            ));
        }
        match self.amount {
            FoldAmount::Ratio(r) if !(r > 0.0 && r <= 1.0) => {
                return Err(ClothError::InvalidCrease("ratio must be in (0, 1]"));
            }
            FoldAmount::Angle(b)
                if !(b.is_finite() && (0.0..std::f32::consts::PI).contains(&b)) =>
            {
                return Err(ClothError::InvalidCrease("angle must be in [0, π)"));
            }
            _ => {}
        }
        if self.from.distance(self.to) < 1e-6 {
            return Err(ClothError::InvalidCrease("the segment has no length"));
        }
        let meets = match cloth.grid_size() {
            Some(size) => segment_meets_rect(self.from.xz(), self.to.xz(), size),
            None => meets_mesh(),
        };
        if !meets {
            return Err(ClothError::InvalidCrease("the segment misses the cloth"));
        }
        Ok(())
    }
}

/// Whether segment `p → q` touches the rectangle `[0, size.x] × [0, size.y]`
/// (Liang–Barsky clipping).
fn segment_meets_rect(p: Vec2, q: Vec2, size: Vec2) -> bool {
    let d = q - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for (pk, qk) in [
        (-d.x, p.x),
        (d.x, size.x - p.x),
        (-d.y, p.y),
        (d.y, size.y - p.y),
    ] {
        if pk == 0.0 {
            if qk < 0.0 {
                return false;
            }
        } else {
            let t = qk / pk;
            if pk < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    t0 <= t1
}

/// The original rest lengths the creases changed, to restore them exactly.
#[derive(Clone, Debug, Default)]
pub struct CreaseRecord {
    changed: Vec<(LinkFamily, usize, f32)>,
}

impl CreaseRecord {
    /// Follows an edit of the links from `old` to `new` in which particle
    /// `p` of `new` stands for particle `origin[p]` of `old` (a tear's
    /// copies):
    /// every link of `new` that stands for a link the creases changed
    /// keeps that link's original rest length; a link that is gone is
    /// forgotten.
    pub fn remap(&mut self, old: &Connections, new: &Connections, origin: &[u32]) {
        let key = |a: u32, b: u32| (a.min(b), a.max(b));
        let from = |p: u32| origin.get(p as usize).copied().unwrap_or(p);
        let wanted: HashMap<(LinkFamily, (u32, u32)), f32> = self
            .changed
            .drain(..)
            .filter_map(|(family, k, rest)| {
                let l = old.family(family).get(k)?;
                Some(((family, key(l.a, l.b)), rest))
            })
            .collect();
        if wanted.is_empty() {
            return;
        }
        for family in LinkFamily::ALL {
            for (j, m) in new.family(family).iter().enumerate() {
                if let Some(&rest) = wanted.get(&(family, key(from(m.a), from(m.b)))) {
                    self.changed.push((family, j, rest));
                }
            }
        }
    }
}

/// A Type 2 connection a crease selects: its family, its index there, its
/// ends' distances from the crease's plane (m), and that plane's unit
/// normal.
struct Crossing {
    family: LinkFamily,
    index: usize,
    distances: (f32, f32),
    across: Vec3,
}

/// The Type 2 connections of `connections` that `crease` selects on
/// `cloth` (module docs), with their ends' distances from its plane.
fn crossings(cloth: &RestSurface, connections: &Connections, crease: &Crease) -> Vec<Crossing> {
    let (p, along) = (crease.from, crease.to - crease.from);
    let mut out = Vec::new();
    for family in [LinkFamily::Bend, LinkFamily::BendDiagonal] {
        for (index, l) in connections.family(family).iter().enumerate() {
            if l.a as usize >= cloth.len() || l.b as usize >= cloth.len() {
                continue;
            }
            let (a, c) = (cloth.position(l.a), cloth.position(l.b));
            let normal = cloth.normal(l.a) + cloth.normal(l.b);
            // The plane through the segment along the rest normal.
            let Some(across) = along.cross(normal).try_normalize() else {
                continue;
            };
            let (sa, sc) = (across.dot(a - p), across.dot(c - p));
            if sa * sc >= 0.0 {
                continue;
            }
            // Where the connection meets the plane, as a fraction of p → q,
            // and how far from the segment's line (0 on a flat cloth; on a
            // curved one this keeps a crease on one side of a tube off the
            // other).
            let hit = a + (c - a) * (sa / (sa - sc));
            let t = (hit - p).dot(along) / along.length_squared();
            let off = hit.distance(p + t * along);
            if (0.0..=1.0).contains(&t) && off <= a.distance(c) {
                out.push(Crossing {
                    family,
                    index,
                    distances: (sa.abs(), sc.abs()),
                    across,
                });
            }
        }
    }
    out
}

/// The Type 2 connections of `connections` that `crease` selects on
/// `cloth`: their ends strictly on opposite sides of the plane through the
/// segment along the ends' rest normal, crossing it beside the segment
/// itself. Returns (family, index in that family).
pub fn crossing(
    cloth: &RestSurface,
    connections: &Connections,
    crease: &Crease,
) -> Vec<(LinkFamily, usize)> {
    crossings(cloth, connections, crease)
        .into_iter()
        .map(|c| (c.family, c.index))
        .collect()
}

/// Applies `creases` to `connections`: first restores what `record` says
/// was changed, then shortens every crossing Type 2 connection, adds the
/// tension springs and (for a chosen side) the fold triples. Creases that
/// fail [`Crease::validate`] are skipped and returned as errors.
pub fn apply_creases(
    cloth: &RestSurface,
    connections: &mut Connections,
    record: &mut CreaseRecord,
    creases: &[Crease],
) -> Vec<ClothError> {
    apply_closing(cloth, connections, record, creases.iter().map(|c| (c, 1.0)))
}

/// [`apply_creases`] with each crease folded by a fraction of its angle
/// (dimensionless, 0 = flat, 1 = the whole fold `β`), so that a fold can
/// close over several steps: each crossing connection's rest length then
/// follows `L'² = L² − 2 d_a d_b (1 − cos(fraction · β))`. A fraction
/// outside `[0, 1]` is clamped to it; NaN folds the whole way.
pub(crate) fn apply_closing<'a>(
    cloth: &RestSurface,
    connections: &mut Connections,
    record: &mut CreaseRecord,
    creases: impl IntoIterator<Item = (&'a Crease, f32)>,
) -> Vec<ClothError> {
    restore(connections, record);
    let mut errors = Vec::new();
    let mut folded = HashSet::new();
    for (crease, fraction) in creases {
        // A mesh's crossings tell whether the crease meets it: found once.
        let mut found = None;
        let meets = || {
            !found
                .insert(crossings(cloth, connections, crease))
                .is_empty()
        };
        if let Err(e) = crease.validate_meeting(cloth, meets) {
            errors.push(e);
            continue;
        }
        let found = found.unwrap_or_else(|| crossings(cloth, connections, crease));
        let fraction = if fraction.is_nan() {
            1.0
        } else {
            fraction.clamp(0.0, 1.0)
        };
        let beta = crease.amount.angle() * fraction;
        let sign = match crease.side {
            FoldSide::Free => 0.0,
            FoldSide::Mountain => 1.0,
            FoldSide::Valley => -1.0,
        };
        for crossing in found {
            let (family, k) = (crossing.family, crossing.index);
            // A connection an earlier crease of this list folds stays its.
            if !folded.insert((family, k)) {
                continue;
            }
            let links = match family {
                LinkFamily::Bend => &mut connections.bend,
                _ => &mut connections.bend_diagonal,
            };
            let l = links[k];
            let (da, dc) = crossing.distances;
            let original = record
                .changed
                .iter()
                .find(|(f, i, _)| *f == family && *i == k)
                .map_or(l.rest_length, |(.., r)| *r);
            let shortened = (original * original - 2.0 * da * dc * (1.0 - beta.cos()))
                .max((0.05 * original).powi(2))
                .sqrt();
            if !record
                .changed
                .iter()
                .any(|(f, i, _)| *f == family && *i == k)
            {
                record.changed.push((family, k, original));
            }
            links[k].rest_length = shortened;
            connections.crease.push(Link {
                a: l.a,
                b: l.b,
                rest_length: shortened,
            });
            let Some((hinge, around)) = cloth.hinge(l.a, l.b).filter(|_| sign != 0.0) else {
                continue;
            };
            // Half the hinge's height over its ends when rigid flaps fold
            // by β: `sin(β/2)(½(d_a + d_c) − e)` for a hinge `e` m from the
            // plane, `sin(β/2) L/2` for a grid's (on the line; its diagonal
            // connections keep that of the axial ones).
            // A mesh hinge farther from the plane than its ends are, on
            // average, has nothing to keep.
            let lift = (beta / 2.0).sin().min(0.5);
            let (min_height, keep) = if cloth.grid_size().is_some() {
                (0.25 * original * lift, true)
            } else {
                let off = crossing
                    .across
                    .dot(cloth.position(hinge) - crease.from)
                    .abs();
                let height = 0.5 * lift * (0.5 * (da + dc) - off);
                (height, height > 0.0)
            };
            if keep {
                connections.fold.push(FoldTriple {
                    a: l.a,
                    hinge,
                    c: l.b,
                    around,
                    sign,
                    min_height,
                    stiffness: crease.stiffness,
                });
            }
        }
    }
    errors
}

/// Puts back every rest length `record` holds and drops the crease
/// connections.
pub(crate) fn restore(connections: &mut Connections, record: &mut CreaseRecord) {
    for (family, k, rest) in record.changed.drain(..) {
        let links = match family {
            LinkFamily::Bend => &mut connections.bend,
            LinkFamily::BendDiagonal => &mut connections.bend_diagonal,
            LinkFamily::Structural => &mut connections.structural,
            LinkFamily::Shear => &mut connections.shear,
        };
        if let Some(l) = links.get_mut(k) {
            l.rest_length = rest;
        }
    }
    connections.crease.clear();
    connections.fold.clear();
}
