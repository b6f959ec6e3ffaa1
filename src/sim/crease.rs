//! Creases (paper §5, MODEL.md §9): a fold line in the cloth's rest
//! coordinates shortens the Type 2 connections that cross it and adds a
//! Type 1 tension spring of the new length across each, so the cloth folds
//! there and stays folded.
//!
//! Beyond the paper (which only folds along grid lines and whose folds can
//! flip):
//! - a [`Crease`] is a segment in any direction; a connection is selected
//!   when its ends lie strictly on opposite sides of the segment's line and
//!   it crosses the segment itself (a sign test in rest `(u, v)` metres,
//!   §9.5);
//! - every selected connection gets its own rest length from the fold
//!   geometry (§9.2): for ends at distances `d_a`, `d_b` from the line and a
//!   fold (turning) angle `β`, `L'² = L² − 2 d_a d_b (1 − cos β)`. A ratio
//!   `r` means the angle that gives the axial connection centred on the
//!   hinge `L' = rL`, `β = 2 acos r` (so `r = 0.7` folds about 91°), and
//!   diagonal connections get their own ratio;
//! - [`FoldSide::Mountain`] or [`FoldSide::Valley`] adds the fold-direction
//!   term of §9.4b on each crossing triple `(a, b, c)` (hinge `b`, the
//!   particle midway): while the hinge's signed height
//!   `σ = (x_b − ½(x_a + x_c))·n_b` is below `σ_min` on the chosen side, a
//!   force `k_σ(σ_min − σ·s)·s·n_b` lifts it (and half of it pulls on each
//!   end), so the fold cannot flip. [`FoldSide::Free`] is the paper's
//!   behaviour.
//!
//! The angle of §9.2 is that of rigid flaps: a sheet stiff enough in
//! bending to keep its flaps flat (measured: `k_b = 10⁻⁴ N·m²` on a 1 m,
//! 15×15 sheet; r = 0.7 folds to 92.8°, a 45° target to 42.3°) folds to it;
//! limp cloth (cotton's `5·10⁻⁷`) pleats around the line instead, since
//! nothing but bending resists the hinge column popping out.
//!
//! [`restore`] puts back the original rest lengths exactly, so creases
//! can change or go at any time. In an app, the `ClothCreases` component
//! holds a cloth's creases.

use bevy::math::Vec2;
use bevy::reflect::Reflect;

use crate::error::ClothError;
use crate::sim::connections::{Connections, FoldTriple, Link, LinkFamily};
use crate::sim::grid::Grid;

/// Which way a crease folds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum FoldSide {
    /// Either way, and it may flip (the paper).
    #[default]
    Free,
    /// The hinge rises along the cloth's normal (`+v × +u` side up for a
    /// [`ClothBuilder`](crate::ClothBuilder) sheet).
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

/// One fold line of a cloth.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct Crease {
    /// Start of the segment in rest coordinates `(u, v)`, m.
    pub from: Vec2,
    /// End of the segment in rest coordinates `(u, v)`, m.
    pub to: Vec2,
    /// How far it folds.
    pub amount: FoldAmount,
    /// Which way it folds.
    pub side: FoldSide,
    /// `k_σ` of the fold-direction term in N/m (unused for `Free`).
    pub stiffness: f32,
}

impl Crease {
    /// A free crease from `from` to `to` (rest `(u, v)`, m) with the paper's
    /// ratio 0.7 and `k_σ` = 20 N/m.
    pub fn new(from: Vec2, to: Vec2) -> Self {
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
    /// the cloth's rest rectangle.
    pub fn validate(&self, cloth: &Grid) -> Result<(), ClothError> {
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
        if !segment_meets_rect(self.from, self.to, cloth.size) {
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

/// Which side of the line through `p → q` point `x` is on (signed, m²).
fn side(p: Vec2, q: Vec2, x: Vec2) -> f32 {
    (q - p).perp_dot(x - p)
}

/// The Type 2 connections of `connections` that `crease` selects: their
/// ends (rest `uv`) strictly on opposite sides of its line, crossing the
/// segment itself. Returns (family, index in that family).
pub fn crossing(
    cloth: &Grid,
    connections: &Connections,
    crease: &Crease,
) -> Vec<(LinkFamily, usize)> {
    let (p, q) = (crease.from, crease.to);
    let mut out = Vec::new();
    for family in [LinkFamily::Bend, LinkFamily::BendDiagonal] {
        for (k, l) in connections.family(family).iter().enumerate() {
            let (a, c) = (cloth.rest_uv(l.a), cloth.rest_uv(l.b));
            let (sa, sc) = (side(p, q, a), side(p, q, c));
            if sa * sc >= 0.0 {
                continue;
            }
            // Where the connection meets the line, as a fraction of p → q.
            let hit = a + (c - a) * (sa / (sa - sc));
            let t = (hit - p).dot(q - p) / (q - p).length_squared();
            if (0.0..=1.0).contains(&t) {
                out.push((family, k));
            }
        }
    }
    out
}

/// Applies `creases` to `connections`: first restores what `record` says
/// was changed, then shortens every crossing Type 2 connection, adds the
/// tension springs and (for a chosen side) the fold triples. Creases that
/// fail [`Crease::validate`] are skipped and returned as errors.
pub fn apply_creases(
    cloth: &Grid,
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
pub fn apply_closing<'a>(
    cloth: &Grid,
    connections: &mut Connections,
    record: &mut CreaseRecord,
    creases: impl IntoIterator<Item = (&'a Crease, f32)>,
) -> Vec<ClothError> {
    restore(connections, record);
    let mut errors = Vec::new();
    for (crease, fraction) in creases {
        if let Err(e) = crease.validate(cloth) {
            errors.push(e);
            continue;
        }
        let fraction = if fraction.is_nan() {
            1.0
        } else {
            fraction.clamp(0.0, 1.0)
        };
        let beta = crease.amount.angle() * fraction;
        let dir = (crease.to - crease.from).normalize();
        let sign = match crease.side {
            FoldSide::Free => 0.0,
            FoldSide::Mountain => 1.0,
            FoldSide::Valley => -1.0,
        };
        for (family, k) in crossing(cloth, connections, crease) {
            let links = match family {
                LinkFamily::Bend => &mut connections.bend,
                _ => &mut connections.bend_diagonal,
            };
            let l = links[k];
            let (a, c) = (cloth.rest_uv(l.a), cloth.rest_uv(l.b));
            let (da, dc) = (
                dir.perp_dot(a - crease.from).abs(),
                dir.perp_dot(c - crease.from).abs(),
            );
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
            if sign != 0.0 {
                let (ia, ja) = (l.a % cloth.cols, l.a / cloth.cols);
                let (ic, jc) = (l.b % cloth.cols, l.b / cloth.cols);
                let (ih, jh) = ((ia + ic) / 2, (ja + jc) / 2);
                let hinge = cloth.index(ih, jh);
                let around = [
                    cloth.index(ih.saturating_sub(1), jh),
                    cloth.index((ih + 1).min(cloth.cols - 1), jh),
                    cloth.index(ih, jh.saturating_sub(1)),
                    cloth.index(ih, (jh + 1).min(cloth.rows - 1)),
                ];
                connections.fold.push(FoldTriple {
                    a: l.a,
                    hinge,
                    c: l.b,
                    around,
                    sign,
                    min_height: 0.25 * original * (beta / 2.0).sin().min(0.5),
                    stiffness: crease.stiffness,
                });
            }
        }
    }
    errors
}

/// Puts back every rest length `record` holds and drops the crease
/// connections.
pub fn restore(connections: &mut Connections, record: &mut CreaseRecord) {
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
