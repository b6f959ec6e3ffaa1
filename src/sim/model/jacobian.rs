//! Forces and their Jacobians in one pass, for the implicit integrators.
//!
//! For every connection `(a, b)` the force on `a` is `F_a = f(ℓ)·u` and its
//! blocks are `∂F_a/∂x_b = H`, `∂F_a/∂v_b = D` (so `∂F_a/∂x_a = −H` and so
//! on, MODEL.md §0). [`assemble`] returns the internal forces and one
//! [`Block`] per active connection; the solver applies `K` and `D` from the
//! blocks without forming a matrix.
//!
//! Choices, each from MODEL.md:
//! - **Type 1** (§2): `H = k P_u + k(1 − L/ℓ) P_⊥` when taut. When slack the
//!   force is 0; with `keep_slack` the axial term `k P_u` is **kept**, so the
//!   linear solve still sees the spring (without it a drop test at 1/30 s
//!   strained 112 %, with it 7 %; see [`SlackStiffness`](crate::sim::settings::SlackStiffness)).
//!   Pair damping `D = k_d P_u` while taut.
//! - **Type 2** (§3.7): `H = (df*/dℓ) P_u` by default (the transverse term
//!   `(f*/ℓ) P_⊥` is negative and is dropped, as Blender does, keeping `K`
//!   negative semidefinite); [`Type2Jacobian::Full`] keeps it.
//! - **Lander** (§7): `H = k P_u + k·max(0, 1 − L/ℓ) P_⊥` (the compressed
//!   transverse term, negative, is clamped for a definite system; `Full`
//!   keeps it), damping `D = k_d P_u`.

#[cfg(test)]
use bevy::math::Mat3;
use bevy::math::Vec3;

use super::choi_ko::{BUCKLING_TABLE, MIN_LENGTH, type2_magnitude};
use super::kernel::Law;
use super::streams::{ForceStreams, Linearisation};
use crate::sim::connections::{Connections, Link};
use crate::sim::settings::{SimSettings, Type2Jacobian};

/// The Jacobian blocks of one connection, kept as the few numbers they are
/// made of (32 bytes rather than two 3×3 matrices): with `P_u = u uᵀ` and
/// `P_⊥ = I − P_u`,
/// `∂F_a/∂x_b = axial·P_u + transverse·P_⊥` and `∂F_a/∂v_b = damping·P_u`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Block {
    /// First particle.
    pub a: u32,
    /// Second particle.
    pub b: u32,
    /// Unit vector from `a` to `b` (dimensionless).
    pub u: Vec3,
    /// Stiffness along `u`, N/m.
    pub axial: f32,
    /// Stiffness across `u`, N/m.
    pub transverse: f32,
    /// Damping along `u`, N·s/m.
    pub damping: f32,
}

impl Block {
    /// `∂F_a/∂x_b` in N/m (symmetric).
    #[cfg(test)]
    pub fn k(&self) -> Mat3 {
        let pu = outer(self.u);
        pu * self.axial + (Mat3::IDENTITY - pu) * self.transverse
    }

    /// `∂F_a/∂x_b · w` (N for `w` in m).
    #[inline]
    pub fn k_times(&self, w: Vec3) -> Vec3 {
        self.transverse * w + (self.axial - self.transverse) * self.u.dot(w) * self.u
    }
}

#[cfg(test)]
fn outer(u: Vec3) -> Mat3 {
    Mat3::from_cols(u * u.x, u * u.y, u * u.z)
}

/// Adds `force` on `a` (and its opposite on `b`) and records the blocks
/// `(axial, transverse, damping)` along `u`.
fn push(l: &Link, force: Vec3, u: Vec3, kd: [f32; 3], f: &mut [Vec3], blocks: &mut Vec<Block>) {
    f[l.a as usize] += force;
    f[l.b as usize] -= force;
    let [axial, transverse, damping] = kd;
    blocks.push(Block {
        a: l.a,
        b: l.b,
        u,
        axial,
        transverse,
        damping,
    });
}

fn stretch(
    links: &[Link],
    (k, kd): (f32, f32),
    (two_sided, full, keep_slack): (bool, bool, bool),
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
    out: &mut Vec<Block>,
) {
    for l in links {
        let delta = x[l.b as usize] - x[l.a as usize];
        let len = delta.length();
        if len < MIN_LENGTH {
            continue;
        }
        let u = delta / len;
        let taut = len >= l.rest_length;
        if !taut && !two_sided {
            // Slack Type 1: no force; maybe keep the axial stiffness.
            if keep_slack {
                push(l, Vec3::ZERO, u, [k, 0.0, 0.0], f, out);
            }
            continue;
        }
        let damping = kd * (v[l.b as usize] - v[l.a as usize]).dot(u);
        let force = (k * (len - l.rest_length) + damping) * u;
        let mut transverse = k * (1.0 - l.rest_length / len);
        if !full {
            transverse = transverse.max(0.0);
        }
        push(l, force, u, [k, transverse, kd], f, out);
    }
}

fn buckle(
    links: &[Link],
    kb: f32,
    cb: f32,
    full: bool,
    x: &[Vec3],
    f: &mut [Vec3],
    out: &mut Vec<Block>,
) {
    let table = &*BUCKLING_TABLE;
    for l in links {
        let delta = x[l.b as usize] - x[l.a as usize];
        let len = delta.length();
        if len >= l.rest_length || len < MIN_LENGTH {
            continue;
        }
        let u = delta / len;
        let (mag, slope) = type2_magnitude(table, len, l.rest_length, kb, cb);
        let transverse = if full { mag / len } else { 0.0 };
        push(l, mag * u, u, [slope, transverse, 0.0], f, out);
    }
}

/// Writes the internal forces (N) at `(x, v)` into `f` (zeroed first) and
/// the blocks of every active connection into `blocks` (cleared first; its
/// capacity is reused, so a warm call does not allocate). `keep_slack`
/// keeps the axial stiffness of slack Type 1 links (module docs).
#[cfg(test)]
pub fn assemble(
    settings: &SimSettings,
    connections: &Connections,
    keep_slack: bool,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
    blocks: &mut Vec<Block>,
) {
    f.fill(Vec3::ZERO);
    blocks.clear();
    let full = settings.implicit.type2_jacobian == Type2Jacobian::Full;
    // The stretching families first, then the buckling ones.
    let laws = super::laws(settings, connections);
    for (links, law) in laws.clone() {
        match law {
            Law::Tension { k, kd } => {
                stretch(links, (k, kd), (false, full, keep_slack), x, v, f, blocks)
            }
            Law::Spring { ks, kd } => {
                stretch(links, (ks, kd), (true, full, false), x, v, f, blocks)
            }
            Law::Buckling { .. } => {}
        }
    }
    for (links, law) in laws {
        if let Law::Buckling { kb, cb, .. } = law {
            buckle(links, kb, cb, full, x, f, blocks);
        }
    }
    // The fold-direction term enters as a force only (no Jacobian block).
    crate::sim::connections::fold_forces(&connections.fold, x, f);
}

/// [`assemble`] with the grid families linearised by stream
/// ([`streams`](super::streams)), for the implicit integrators: writes the
/// internal forces (N) into `f` and `K w` (N) into `kw` (`w` in m), keeps
/// the blocks `C = αD + βK` of the streams in `streams`, and writes only
/// the blocks of the other links (crease springs, links of an unusual
/// step) into `blocks`. `alpha` in s, `beta` in s².
#[allow(clippy::too_many_arguments)]
pub(crate) fn assemble_streamed(
    settings: &SimSettings,
    connections: &Connections,
    (keep_slack, alpha, beta): (bool, f32, f32),
    x: &[Vec3],
    v: &[Vec3],
    w: &[Vec3],
    (f, kw): (&mut [Vec3], &mut [Vec3]),
    blocks: &mut Vec<Block>,
    streams: &mut ForceStreams,
) {
    let (laws, count) = super::grid_laws(settings, super::grid_families(connections));
    let laws = &laws[..count];
    streams.sync(laws.iter().map(|l| l.0), x.len());
    let full = settings.implicit.type2_jacobian == Type2Jacobian::Full;
    let lin = Linearisation {
        alpha,
        beta,
        keep_slack,
        full,
        split: settings.implicit.helper_thread && x.len() >= crate::sim::team::SPLIT_PARTICLES,
    };
    streams.linearise_synced(laws, x, v, w, lin, f, kw);
    blocks.clear();
    for (family, &(_, law)) in laws.iter().enumerate() {
        let others = streams.others(family);
        match law {
            Law::Tension { k, kd } => {
                stretch(others, (k, kd), (false, full, keep_slack), x, v, f, blocks)
            }
            Law::Spring { ks, kd } => {
                stretch(others, (ks, kd), (true, full, false), x, v, f, blocks)
            }
            Law::Buckling { kb, cb, .. } => buckle(others, kb, cb, full, x, f, blocks),
        }
    }
    if let Law::Tension { k, kd } = super::crease_law(settings) {
        let crease = &connections.crease;
        stretch(crease, (k, kd), (false, full, keep_slack), x, v, f, blocks);
    }
    crate::sim::connections::fold_forces(&connections.fold, x, f);
    add_k_times(blocks, w, kw);
}

/// Adds `K w` of `blocks` to `out` (N, `w` in m):
/// `(K w)_a += H (w_b − w_a)`, `(K w)_b += H (w_a − w_b)`.
pub fn add_k_times(blocks: &[Block], w: &[Vec3], out: &mut [Vec3]) {
    for blk in blocks {
        let (a, b) = (blk.a as usize, blk.b as usize);
        let t = blk.k_times(w[b] - w[a]);
        out[a] += t;
        out[b] -= t;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::model::internal_forces;
    use crate::sim::settings::ClothModel;

    fn grid(n: u32) -> (Connections, Vec<Vec3>) {
        let rest: Vec<Vec3> = (0..n * n)
            .map(|p| Vec3::new((p % n) as f32 * 0.1, 0.0, (p / n) as f32 * 0.1))
            .collect();
        (Connections::grid(n, n, &rest), rest)
    }

    fn deformed(rest: &[Vec3]) -> Vec<Vec3> {
        rest.iter()
            .enumerate()
            .map(|(i, p)| {
                let s = i as f32;
                *p + 0.03 * Vec3::new((s * 1.7).sin(), (s * 0.9).cos(), (s * 2.3).sin())
            })
            .collect()
    }

    #[test]
    fn forces_match_the_explicit_model() {
        let (conn, rest) = grid(6);
        let x = deformed(&rest);
        let v: Vec<Vec3> = (0..x.len())
            .map(|i| Vec3::splat((i as f32 * 0.37).sin()))
            .collect();
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let mut s = SimSettings::default().with_model(model);
            s.choi_ko.bending_rigidity = 0.05;
            let mut want = vec![Vec3::ZERO; x.len()];
            internal_forces(&s, &conn, &x, &v, &mut want);
            let mut got = vec![Vec3::ZERO; x.len()];
            let mut blocks = Vec::new();
            assemble(&s, &conn, true, &x, &v, &mut got, &mut blocks);
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (*g - *w).length() < 1e-3 * (1.0 + w.length()),
                    "{model:?}: {g} vs {w}"
                );
            }
        }
    }

    /// Finite differences: the full blocks are the true derivatives, the
    /// default ones differ only by the dropped (negative) terms.
    #[test]
    fn full_blocks_are_the_derivatives_of_the_forces() {
        let (conn, rest) = grid(5);
        let x = deformed(&rest);
        let v = vec![Vec3::ZERO; x.len()];
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let mut s = SimSettings::default().with_model(model);
            s.choi_ko.bending_rigidity = 0.05;
            s.implicit.type2_jacobian = Type2Jacobian::Full;
            let mut f0 = vec![Vec3::ZERO; x.len()];
            let mut blocks = Vec::new();
            assemble(&s, &conn, true, &x, &v, &mut f0, &mut blocks);
            // Perturb particle p along each axis; F_a of every neighbour a
            // changes by ∂F_a/∂x_p · e = H_{a,p} e.
            let p = 12usize;
            let e = 1e-3;
            for axis in 0..3 {
                let mut xp = x.clone();
                xp[p][axis] += e;
                let mut f1 = vec![Vec3::ZERO; x.len()];
                let mut scratch = Vec::new();
                assemble(&s, &conn, true, &xp, &v, &mut f1, &mut scratch);
                for blk in blocks
                    .iter()
                    .filter(|b| b.a as usize == p || b.b as usize == p)
                {
                    let other = if blk.a as usize == p { blk.b } else { blk.a } as usize;
                    // A slack Type 1 link keeps its axial stiffness on purpose
                    // while its force is 0: not a derivative, skip it.
                    let stretch_link = conn
                        .structural
                        .iter()
                        .chain(&conn.shear)
                        .find(|l| (l.a, l.b) == (blk.a, blk.b));
                    if model == ClothModel::ChoiKo
                        && stretch_link.is_some_and(|l| {
                            x[l.a as usize].distance(x[l.b as usize]) < l.rest_length
                        })
                    {
                        continue;
                    }
                    // Only this link joins `other` and `p`, so the change of
                    // F_other is H·e (∂F_a/∂x_b = ∂F_b/∂x_a = H).
                    let numeric = (f1[other] - f0[other]) / e;
                    let mut unit = Vec3::ZERO;
                    unit[axis] = 1.0;
                    let analytic = blk.k() * unit;
                    let err = (numeric - analytic).length();
                    assert!(
                        err < 0.05 * (1.0 + analytic.length()) + 0.5,
                        "{model:?} axis {axis}: {numeric} vs {analytic}"
                    );
                }
            }
        }
    }
}
