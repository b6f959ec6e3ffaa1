//! Unit tests of the mesh hierarchy: aggregates, the first level the fine
//! operator on rigid motions, Galerkin levels, a symmetric positive
//! definite correction, exact on one level, and scraps.

use super::super::coarse::tests::irregular;
use super::hierarchy::{aggregate, graph};
use super::*;
use crate::sim::topology::{MeshTopology, disc};

/// The irregular block of the `k`th Type 1 link (kg).
fn link_block(k: usize) -> Rank {
    let s = k as f32;
    let u = Vec3::new(s.sin(), (0.7 * s).cos(), 0.3).normalize();
    let (axial, across) = (50.0 + 40.0 * (1.3 * s).sin(), 2.0);
    // across·I + (axial − across)·u uᵀ
    (across, axial - across, u.to_array())
}

/// A disc of `rings` rings, its links, and its hierarchy with a mass of
/// 1 kg per particle (pins as `pinned` says) and an irregular block on
/// every Type 1 link, finished.
fn disc_hierarchy(rings: u32, pinned: impl Fn(usize) -> bool) -> (Connections, MeshCoarse) {
    let (positions, indices) = disc(1.0, rings);
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let links = t.connections();
    let w: Vec<f32> = (0..t.len())
        .map(|p| if pinned(p) { 0.0 } else { 1.0 })
        .collect();
    let mut c = MeshCoarse::default();
    c.place(&positions);
    assert!(c.begin(&links, None, &w, 1.0));
    for (k, l) in links.type1().enumerate() {
        c.add_pair(l.a as usize, l.b as usize, link_block(k));
    }
    assert!(c.finish());
    (links, c)
}

/// `A e` on level `l`, from its residual with `r = 0`.
fn product(c: &mut MeshCoarse, l: usize, e: &[Six]) -> Vec<Six> {
    let level = &mut c.levels[l];
    level.r.fill(Six::ZERO);
    level.e.copy_from_slice(e);
    level.residual();
    level.t.iter().map(|&t| Six::ZERO - t).collect()
}

/// An irregular rigid motion of each of `n` nodes.
fn motions(n: usize, seed: f32) -> Vec<Six> {
    irregular(n, seed)
        .into_iter()
        .zip(irregular(n, seed + 0.5))
        .map(|(t, r)| Six { t, r })
        .collect()
}

/// The largest of a motion's parts.
fn size(v: Six) -> f32 {
    v.t.length().max(v.r.length())
}

#[test]
fn aggregates_are_connected_and_of_about_the_size_asked() {
    let (positions, indices) = disc(1.0, 20);
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let links = t.connections();
    let particles = graph(t.len(), links.type1().map(|l| (l.a, l.b)));
    let mut out = Vec::new();
    for size in [SIZE, FIRST] {
        let count = aggregate(&particles, &mut out, size);
        let n = t.len();
        assert!((n / (2 * size)..=n / 2).contains(&count), "{count} of {n}");
        for a in 0..count as u32 {
            let members: Vec<usize> = (0..n).filter(|&p| out[p] == a).collect();
            assert!((2..=2 * size).contains(&members.len()), "{members:?}");
            // Connected: a search inside the aggregate reaches all of it.
            let mut reached = vec![members[0]];
            let mut k = 0;
            while k < reached.len() {
                let p = reached[k];
                k += 1;
                for &q in &particles[p] {
                    let q = q as usize;
                    if out[q] == a && !reached.contains(&q) {
                        reached.push(q);
                    }
                }
            }
            assert_eq!(reached.len(), members.len(), "aggregate {a}");
        }
    }
}

#[test]
fn the_first_level_is_the_fine_operator_on_rigid_motions() {
    let pinned = |p: usize| p.is_multiple_of(53);
    let (links, mut c) = disc_hierarchy(30, pinned);
    let count = c.levels[0].count();
    let z = motions(count, 3.0);
    // u = Q z: each free particle moves with its aggregate.
    let n = c.aggregate.len();
    let u: Vec<Vec3A> = (0..n)
        .map(|p| match c.aggregate[p] {
            NONE => Vec3A::ZERO,
            a => z[a as usize].moved(c.offset[p]).t,
        })
        .collect();
    // A u, from the masses (1 kg) and the links' blocks.
    let mut au: Vec<Vec3A> = u.clone();
    for (k, l) in links.type1().enumerate() {
        let (t, s, dir) = link_block(k);
        let dir = Vec3A::from_array(dir);
        let (a, b) = (l.a as usize, l.b as usize);
        let d = u[a] - u[b];
        let f = t * d + s * dir.dot(d) * dir;
        au[a] += f;
        au[b] -= f;
    }
    // Qᵀ A u against the first level's A₁ z.
    let mut want = vec![Six::ZERO; count];
    for p in 0..n {
        if !pinned(p) {
            let f = Six {
                t: au[p],
                r: Vec3A::ZERO,
            };
            want[c.aggregate[p] as usize] += f.lifted(c.offset[p]);
        }
    }
    let got = product(&mut c, 0, &z);
    let scale = want.iter().map(|&v| size(v)).fold(0.0, f32::max);
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert!(size(*g - *w) <= 1e-3 * scale, "node {i}: {g:?} vs {w:?}");
    }
}

#[test]
fn each_level_is_the_galerkin_operator_of_the_one_below() {
    let (_, mut c) = disc_hierarchy(30, |p| p % 97 == 0);
    assert!(c.levels.len() >= 3, "{} levels", c.levels.len());
    assert!(c.exact);
    for l in 0..c.levels.len() - 1 {
        let up = c.levels[l + 1].count();
        let e = motions(up, l as f32);
        // T e on level l, then Tᵀ A T e.
        let (parent, offset) = (c.levels[l].parent.clone(), c.levels[l].offset.clone());
        let te: Vec<Six> = parent
            .iter()
            .zip(&offset)
            .map(|(&p, &d)| e[p as usize].moved(d))
            .collect();
        let ate = product(&mut c, l, &te);
        let mut want = vec![Six::ZERO; up];
        for (i, &p) in parent.iter().enumerate() {
            want[p as usize] += ate[i].lifted(offset[i]);
        }
        let got = product(&mut c, l + 1, &e);
        let scale = want.iter().map(|&v| size(v)).fold(0.0, f32::max);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                size(*g - *w) <= 1e-4 * scale,
                "level {l} node {i}: {g:?} vs {w:?}"
            );
        }
    }
}

#[test]
fn the_correction_is_symmetric_positive_definite_and_exact_on_a_small_cloth() {
    for (rings, exact) in [(30, false), (6, true)] {
        let (links, mut c) = disc_hierarchy(rings, |p| p == 3);
        let n = links.max_index().unwrap() as usize + 1;
        let free: Vec<f32> = (0..n).map(|p| if p == 3 { 0.0 } else { 1.0 }).collect();
        let vector = |seed: f32| {
            let mut v = Soa::default();
            v.resize(n);
            for (p, x) in irregular(n, seed).into_iter().enumerate() {
                v.set(p, free[p] * Vec3::from(x));
            }
            v
        };
        let image = |c: &mut MeshCoarse, v: &Soa| {
            let mut y = Soa::default();
            y.resize(n);
            c.add(v, &mut y, &free);
            y
        };
        let dot = |a: &Soa, b: &Soa| (0..n).map(|p| a.get(p).dot(b.get(p)) as f64).sum::<f64>();
        let vs: Vec<Soa> = (0..4).map(|k| vector(7.0 * k as f32)).collect();
        let ys: Vec<Soa> = vs.iter().map(|v| image(&mut c, v)).collect();
        for i in 0..4 {
            let uu = dot(&vs[i], &ys[i]);
            assert!(uu > 0.0, "{rings} rings: {uu}");
            for j in i + 1..4 {
                let (uv, vu) = (dot(&vs[i], &ys[j]), dot(&vs[j], &ys[i]));
                let scale = (uu * dot(&vs[j], &ys[j])).sqrt();
                assert!(
                    (uv - vu).abs() <= 1e-4 * scale,
                    "{rings} rings: {uv} vs {vu}"
                );
            }
        }
        if exact {
            // One level, solved exactly: A₁ times the correction gives
            // Rᵀ r back.
            assert_eq!(c.levels.len(), 1);
            let e = c.levels[0].e.clone();
            let r = c.levels[0].r.clone();
            let got = product(&mut c, 0, &e);
            let scale = r.iter().map(|&v| size(v)).fold(0.0, f32::max);
            for (g, w) in got.iter().zip(&r) {
                assert!(size(*g - *w) <= 1e-4 * scale, "{g:?} vs {w:?}");
            }
        }
    }
}

#[test]
fn scraps_that_do_not_aggregate_take_a_sweep_on_the_last_level() {
    // 300 particles and no links: a cloth cut to pieces of one.
    let links = Connections::default();
    let w = vec![1.0; 300];
    let mut c = MeshCoarse::default();
    c.place(&vec![Vec3::ZERO; 300]);
    assert!(c.begin(&links, None, &w, 1.0));
    assert!(c.finish());
    assert!(!c.exact);
    assert!(c.matrix.is_empty(), "no dense matrix of 900² entries");
    let mut r = Soa::default();
    r.resize(300);
    r.set(5, Vec3::new(2.0, 0.0, -1.0));
    let mut y = Soa::default();
    y.resize(300);
    c.add(&r, &mut y, &w);
    // A particle alone: one sweep gives ω r / m there, nothing elsewhere.
    assert!(
        (y.get(5) - 0.6 * Vec3::new(2.0, 0.0, -1.0)).length() < 1e-6,
        "{}",
        y.get(5)
    );
    assert_eq!(y.get(6), Vec3::ZERO);
}
