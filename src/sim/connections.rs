//! [`Connections`]: the particle pairs a cloth's internal forces act on.
//!
//! The grid's connections are stored once per unordered pair, in four
//! families that both force models share (MODEL.md §1, §7):
//!
//! | family | offsets | Choi–Ko | Lander | 15×15 |
//! |---|---|---|---|---|
//! | [`structural`](Connections::structural) | (1,0), (0,1) | Type 1 | structural spring | 420 |
//! | [`shear`](Connections::shear) | (1,1), (1,−1) | Type 1 | shear spring | 392 |
//! | [`bend`](Connections::bend) | (2,0), (0,2) | Type 2 | bend spring | 390 |
//! | [`bend_diagonal`](Connections::bend_diagonal) | (2,2), (2,−2) | Type 2 | — (Lander has none) | 338 |
//!
//! So Choi–Ko's Type 1 set is `structural ∪ shear` (812 for 15×15) and its
//! Type 2 set is `bend ∪ bend_diagonal` (728), while Lander's cloth uses the
//! first three families only. Switching models at run time therefore needs no
//! rebuild.

use bevy::math::Vec3;
use bevy::reflect::Reflect;

/// One connection between particles `a` and `b` with its rest length.
///
/// The force on `a` is `f(ℓ)·u` with `u = (x_b − x_a)/ℓ` and the force on `b`
/// is its opposite (MODEL.md §0), so every connection conserves momentum.
///
/// Plain data (`repr(C)`, [`bytemuck::Pod`]), so link lists compare as
/// bytes.
#[derive(Clone, Copy, Debug, PartialEq, Reflect, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Link {
    /// Index of the first particle.
    pub a: u32,
    /// Index of the second particle.
    pub b: u32,
    /// Rest length `L` in metres.
    pub rest_length: f32,
}

impl Link {
    /// A link between `a` and `b` whose rest length is their distance in `rest` (m).
    pub fn from_rest(a: u32, b: u32, rest: &[Vec3]) -> Self {
        Self {
            a,
            b,
            rest_length: rest[a as usize].distance(rest[b as usize]),
        }
    }
}

/// The connections of one cloth, grouped by family (see the module docs).
///
/// Contiguous arrays, so the force loops stream over them.
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
pub struct Connections {
    /// Axial ±1 neighbours, rest length `h`.
    pub structural: Vec<Link>,
    /// Diagonal ±1 neighbours, rest length `√2·h`.
    pub shear: Vec<Link>,
    /// Axial ±2 neighbours, rest length `2h`.
    pub bend: Vec<Link>,
    /// Diagonal ±2 neighbours, rest length `2√2·h` (Choi–Ko only).
    pub bend_diagonal: Vec<Link>,
    /// Tension-only springs added across creases (rest length `L'`, m).
    pub crease: Vec<Link>,
    /// Fold-direction terms of creases with a chosen side.
    pub fold: Vec<FoldTriple>,
    /// Particles per grid row, set by [`Connections::grid`] (0 for
    /// hand-made connections). The parallel force bands
    /// (`model::bands`) need it; they also need each
    /// grid family sorted by `a`, as `grid` builds them.
    pub columns: u32,
}

/// What a cache built from some links remembers of them instead of a copy:
/// the generation their owner gave them (a number that changes whenever
/// the links change, see
/// [`StepBuffers::set_links_generation`](crate::sim::integrate::StepBuffers::set_links_generation))
/// and where the lists are in memory and how long they are. Two equal
/// stamps name the same lists unchanged, so a cache whose stamp matches
/// skips comparing or hashing the links.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct LinkStamp {
    generation: u64,
    /// Address and length of each list.
    lists: [(usize, usize); 6],
    /// [`Connections::columns`].
    columns: u32,
}

/// Where `list` is in memory and how long it is.
fn place<T>(list: &[T]) -> (usize, usize) {
    (list.as_ptr() as usize, list.len())
}

impl LinkStamp {
    /// The stamp of one list at `generation` (`None` without one: then no
    /// stamp equals another and a cache compares the links).
    pub(crate) fn of_list(generation: Option<u64>, list: &[Link]) -> Option<Self> {
        generation.map(|generation| Self {
            generation,
            lists: [place(list), (0, 0), (0, 0), (0, 0), (0, 0), (0, 0)],
            columns: 0,
        })
    }

    /// Whether `now` names the same unchanged lists as `then`.
    pub(crate) fn unchanged(then: Option<Self>, now: Option<Self>) -> bool {
        now.is_some() && then == now
    }
}

/// The fold-direction term of one crossing connection (MODEL.md §9.4b):
/// ends `a`, `c`, hinge particle midway, and the hinge's four grid
/// neighbours for its normal.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct FoldTriple {
    /// One end.
    pub a: u32,
    /// The particle midway between the ends.
    pub hinge: u32,
    /// The other end.
    pub c: u32,
    /// The hinge's neighbours left, right, up and down (for its normal).
    pub around: [u32; 4],
    /// +1 mountain, −1 valley.
    pub sign: f32,
    /// `σ_min`: the hinge height (m) the term keeps on its side.
    pub min_height: f32,
    /// `k_σ` in N/m.
    pub stiffness: f32,
}

/// Adds the fold-direction forces (N) of `triples` to `f`: while the
/// hinge's signed height `σ = (x_b − ½(x_a + x_c))·n_b` is below `σ_min` on
/// the chosen side, `F_b = k_σ(σ_min − σ·s)·s·n_b`, `F_a = F_c = −F_b/2`
/// (they sum to zero).
pub(crate) fn fold_forces(triples: &[FoldTriple], x: &[Vec3], f: &mut [Vec3]) {
    for t in triples {
        let [l, r, u, d] = t.around.map(|p| x[p as usize]);
        let n = (d - u).cross(r - l).normalize_or_zero();
        let (a, b, c) = (t.a as usize, t.hinge as usize, t.c as usize);
        let sigma = (x[b] - 0.5 * (x[a] + x[c])).dot(n);
        let deficit = t.min_height - sigma * t.sign;
        if deficit > 0.0 {
            let push = t.stiffness * deficit * t.sign * n;
            f[b] += push;
            f[a] -= 0.5 * push;
            f[c] -= 0.5 * push;
        }
    }
}

/// The connection families, for code that treats them uniformly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Reflect)]
pub enum LinkFamily {
    /// Axial ±1 neighbours.
    Structural,
    /// Diagonal ±1 neighbours.
    Shear,
    /// Axial ±2 neighbours.
    Bend,
    /// Diagonal ±2 neighbours.
    BendDiagonal,
}

impl LinkFamily {
    /// Every family, in the order of [`Connections`]' fields.
    pub const ALL: [Self; 4] = [
        Self::Structural,
        Self::Shear,
        Self::Bend,
        Self::BendDiagonal,
    ];
}

impl Connections {
    /// The stamp of these links at `generation` (see [`LinkStamp`]).
    pub(crate) fn stamp(&self, generation: Option<u64>) -> Option<LinkStamp> {
        generation.map(|generation| LinkStamp {
            generation,
            lists: [
                place(&self.structural),
                place(&self.shear),
                place(&self.bend),
                place(&self.bend_diagonal),
                place(&self.crease),
                place(&self.fold),
            ],
            columns: self.columns,
        })
    }

    /// Builds every connection of a `cols × rows` grid whose particle
    /// `p = j·cols + i` rests at `rest[p]` (m).
    ///
    /// Each unordered pair is stored once, generated by the offsets
    /// (1,0), (0,1), (1,1), (1,−1) and twice those, keeping only pairs
    /// inside the grid (no wrap-around). `rest.len()` must be `cols·rows`.
    pub fn grid(cols: u32, rows: u32, rest: &[Vec3]) -> Self {
        debug_assert_eq!(rest.len(), (cols * rows) as usize);
        let mut out = Self {
            columns: cols,
            ..Self::default()
        };
        let index = |i: u32, j: u32| j * cols + i;
        for j in 0..rows {
            for i in 0..cols {
                let p = index(i, j);
                for (step, axial, diagonal) in [
                    (1, &mut out.structural, &mut out.shear),
                    (2, &mut out.bend, &mut out.bend_diagonal),
                ] {
                    if i + step < cols {
                        axial.push(Link::from_rest(p, index(i + step, j), rest));
                    }
                    if j + step < rows {
                        axial.push(Link::from_rest(p, index(i, j + step), rest));
                    }
                    if i + step < cols && j + step < rows {
                        diagonal.push(Link::from_rest(p, index(i + step, j + step), rest));
                    }
                    if i + step < cols && j >= step {
                        diagonal.push(Link::from_rest(p, index(i + step, j - step), rest));
                    }
                }
            }
        }
        out
    }

    /// The links of one family.
    pub fn family(&self, family: LinkFamily) -> &[Link] {
        match family {
            LinkFamily::Structural => &self.structural,
            LinkFamily::Shear => &self.shear,
            LinkFamily::Bend => &self.bend,
            LinkFamily::BendDiagonal => &self.bend_diagonal,
        }
    }

    /// The links of one family, to edit.
    pub fn family_mut(&mut self, family: LinkFamily) -> &mut Vec<Link> {
        match family {
            LinkFamily::Structural => &mut self.structural,
            LinkFamily::Shear => &mut self.shear,
            LinkFamily::Bend => &mut self.bend,
            LinkFamily::BendDiagonal => &mut self.bend_diagonal,
        }
    }

    /// Choi–Ko's Type 1 connections (tension only): structural then shear.
    pub fn type1(&self) -> impl Iterator<Item = &Link> {
        self.structural.iter().chain(&self.shear)
    }

    /// Choi–Ko's Type 2 connections (buckling): bend then diagonal bend.
    pub fn type2(&self) -> impl Iterator<Item = &Link> {
        self.bend.iter().chain(&self.bend_diagonal)
    }

    /// Number of Type 1 connections (structural + shear).
    pub fn type1_count(&self) -> usize {
        self.structural.len() + self.shear.len()
    }

    /// Number of Type 2 connections (bend + diagonal bend).
    pub fn type2_count(&self) -> usize {
        self.bend.len() + self.bend_diagonal.len()
    }

    /// Largest index any link refers to, or `None` without links.
    pub fn max_index(&self) -> Option<u32> {
        self.structural
            .iter()
            .chain(&self.shear)
            .chain(&self.bend)
            .chain(&self.bend_diagonal)
            .chain(&self.crease)
            .map(|l| l.a.max(l.b))
            .chain(self.fold.iter().map(|t| {
                t.a.max(t.c)
                    .max(t.hinge)
                    .max(t.around.into_iter().max().unwrap_or(0))
            }))
            .max()
    }

    /// The piece of each of `n` particles: the particles that Type 1 links
    /// join, directly or through others, are one piece. Pieces are
    /// numbered 0, 1, … in the order of their first particle, so the
    /// largest number plus one is how many there are: a whole cloth is one
    /// piece, and a torn one falls apart into several of the same entity.
    /// Links to particles past `n` are ignored.
    pub fn pieces(&self, n: usize) -> Vec<u32> {
        fn root(parent: &mut [u32], mut i: u32) -> u32 {
            while parent[i as usize] != i {
                parent[i as usize] = parent[parent[i as usize] as usize];
                i = parent[i as usize];
            }
            i
        }
        let mut parent: Vec<u32> = (0..n as u32).collect();
        for l in self.type1() {
            if (l.a as usize) < n && (l.b as usize) < n {
                let (a, b) = (root(&mut parent, l.a), root(&mut parent, l.b));
                parent[a.max(b) as usize] = a.min(b);
            }
        }
        let mut number = vec![u32::MAX; n];
        let mut count = 0;
        (0..n as u32)
            .map(|i| {
                let r = root(&mut parent, i) as usize;
                if number[r] == u32::MAX {
                    number[r] = count;
                    count += 1;
                }
                number[r]
            })
            .collect()
    }
}

/// The largest relative stretch `(ℓ − L)/L` over `links` (dimensionless);
/// 0 when every link is at or below its rest length, NaN if a position is NaN.
///
/// It compares squared length ratios `ℓ²/L²` without a branch and takes one
/// square root at the end: on a 64×64 cloth 37 µs for its 16 002 links
/// where a square root and a division per link took 54.
pub fn max_strain<'a>(links: impl IntoIterator<Item = &'a Link>, x: &[Vec3]) -> f32 {
    let (mut worst, mut nan) = (1.0_f32, false);
    for l in links {
        let d = x[l.b as usize] - x[l.a as usize];
        let ratio = d.length_squared() / (l.rest_length * l.rest_length);
        nan |= ratio.is_nan();
        worst = worst.max(ratio);
    }
    if nan { f32::NAN } else { worst.sqrt() - 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(cols: u32, rows: u32, h: f32) -> Vec<Vec3> {
        (0..rows)
            .flat_map(|j| (0..cols).map(move |i| Vec3::new(i as f32 * h, 0.0, j as f32 * h)))
            .collect()
    }

    #[test]
    fn pieces_are_the_particles_type_1_links_join() {
        let mut c = Connections::grid(3, 3, &flat(3, 3, 1.0));
        assert_eq!(c.pieces(9), vec![0; 9]);
        // Particle 3 (an edge's middle) and the corner 8 cut loose; bend
        // links (Type 2) do not join.
        c.structural
            .retain(|l| ![3, 8].contains(&l.a) && ![3, 8].contains(&l.b));
        c.shear
            .retain(|l| ![3, 8].contains(&l.a) && ![3, 8].contains(&l.b));
        assert!(c.type2().any(|l| l.a == 3 || l.b == 3));
        assert_eq!(c.pieces(9), vec![0, 0, 0, 1, 0, 0, 0, 0, 2]);
        // A link to a particle past the count is ignored.
        c.structural.push(Link::from_rest(0, 20, &flat(5, 5, 1.0)));
        assert_eq!(c.pieces(9)[0], 0);
        assert!(Connections::default().pieces(0).is_empty());
    }

    #[test]
    fn counts_for_15x15_match_model_section_1_and_7() {
        let c = Connections::grid(15, 15, &flat(15, 15, 1.0 / 14.0));
        // Choi–Ko (MODEL.md §1): N1 = 812, N2 = 728.
        assert_eq!(c.type1_count(), 812);
        assert_eq!(c.type2_count(), 728);
        // Lander (MODEL.md §7): 420 structural, 392 shear, 390 bend.
        assert_eq!(c.structural.len(), 420);
        assert_eq!(c.shear.len(), 392);
        assert_eq!(c.bend.len(), 390);
    }

    #[test]
    fn counts_follow_the_closed_forms_for_rectangles() {
        for (n, m) in [(3, 3), (3, 7), (8, 5), (16, 16)] {
            let c = Connections::grid(n, m, &flat(n, m, 0.1));
            let n1 = (n - 1) * m + n * (m - 1) + 2 * (n - 1) * (m - 1);
            let n2 = (n - 2) * m + n * (m - 2) + 2 * (n - 2) * (m - 2);
            assert_eq!(c.type1_count() as u32, n1, "{n}x{m}");
            assert_eq!(c.type2_count() as u32, n2, "{n}x{m}");
        }
    }

    #[test]
    fn rest_lengths_and_uniqueness() {
        let h = 0.25;
        let c = Connections::grid(6, 5, &flat(6, 5, h));
        let s2 = std::f32::consts::SQRT_2;
        for (links, len) in [
            (&c.structural, h),
            (&c.shear, s2 * h),
            (&c.bend, 2.0 * h),
            (&c.bend_diagonal, 2.0 * s2 * h),
        ] {
            for l in links {
                assert!((l.rest_length - len).abs() < 1e-6);
            }
        }
        let mut pairs: Vec<(u32, u32)> = c
            .type1()
            .chain(c.type2())
            .map(|l| (l.a.min(l.b), l.a.max(l.b)))
            .collect();
        let before = pairs.len();
        pairs.sort_unstable();
        pairs.dedup();
        assert_eq!(pairs.len(), before, "a pair is stored twice");
        // An interior particle has 8 Type 1 and 8 Type 2 neighbours.
        let p = 2 * 6 + 2;
        let deg = |it: &mut dyn Iterator<Item = &Link>| it.filter(|l| l.a == p || l.b == p).count();
        assert_eq!(deg(&mut c.type1()), 8);
        assert_eq!(deg(&mut c.type2()), 8);
    }

    #[test]
    fn max_strain_reports_the_worst_stretch() {
        let mut x = flat(3, 3, 1.0);
        let c = Connections::grid(3, 3, &x);
        assert_eq!(max_strain(c.type1(), &x), 0.0);
        x[8].x += 0.5; // stretches (1,2)-(2,2) by 50%
        assert!((max_strain(c.type1(), &x) - 0.5).abs() < 1e-6);
        x[0] = Vec3::NAN;
        assert!(max_strain(c.type1(), &x).is_nan());
    }
}
