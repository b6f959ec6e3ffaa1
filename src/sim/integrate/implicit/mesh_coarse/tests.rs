//! Unit tests of the mesh hierarchy: aggregates, Galerkin levels, a
//! symmetric positive definite correction, exact on one level, and scraps.

use super::super::coarse::tests::irregular;
use super::*;
use crate::sim::topology::{MeshTopology, disc};

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
    assert!(c.begin(&links, None, &w, 1.0));
    for (k, l) in links.type1().enumerate() {
        let s = k as f32;
        let u = Vec3::new(s.sin(), (0.7 * s).cos(), 0.3).normalize();
        let (axial, across) = (50.0 + 40.0 * (1.3 * s).sin(), 2.0);
        // across·I + (axial − across)·u uᵀ
        let d = axial - across;
        let block = [
            across + d * u.x * u.x,
            across + d * u.y * u.y,
            across + d * u.z * u.z,
            d * u.x * u.y,
            d * u.x * u.z,
            d * u.y * u.z,
        ];
        c.add_pair(l.a as usize, l.b as usize, &block);
    }
    assert!(c.finish());
    (links, c)
}

/// `A e` on level `l`, from its residual with `r = 0`.
fn product(c: &mut MeshCoarse, l: usize, e: &[Vec3A]) -> Vec<Vec3A> {
    let level = &mut c.levels[l];
    level.r.fill(Vec3A::ZERO);
    level.e.copy_from_slice(e);
    level.residual();
    level.t.iter().map(|t| -*t).collect()
}

#[test]
fn aggregates_are_connected_and_of_about_the_size_asked() {
    let (positions, indices) = disc(1.0, 20);
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let links = t.connections();
    let particles = graph(t.len(), links.type1().map(|l| (l.a, l.b)));
    let mut out = Vec::new();
    let count = aggregate(&particles, &mut out);
    let n = t.len();
    assert!((n / (2 * SIZE)..=n / 2).contains(&count), "{count} of {n}");
    for a in 0..count as u32 {
        let members: Vec<usize> = (0..n).filter(|&p| out[p] == a).collect();
        assert!((2..=2 * SIZE).contains(&members.len()), "{members:?}");
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

#[test]
fn each_level_is_the_galerkin_operator_of_the_one_below() {
    let (_, mut c) = disc_hierarchy(30, |p| p % 97 == 0);
    assert!(c.levels.len() >= 3, "{} levels", c.levels.len());
    assert!(c.exact);
    for l in 0..c.levels.len() - 1 {
        let up = c.levels[l + 1].count();
        let e = irregular(up, l as f32);
        // R e on level l, then Rᵀ A R e.
        let parent = c.levels[l].parent.clone();
        let re: Vec<Vec3A> = parent.iter().map(|&p| e[p as usize]).collect();
        let are = product(&mut c, l, &re);
        let mut want = vec![Vec3A::ZERO; up];
        for (i, &p) in parent.iter().enumerate() {
            want[p as usize] += are[i];
        }
        let got = product(&mut c, l + 1, &e);
        let scale = want.iter().map(|v| v.length()).fold(0.0, f32::max);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                (*g - *w).length() <= 1e-4 * scale,
                "level {l} node {i}: {g} vs {w}"
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
            let scale = r.iter().map(|v| v.length()).fold(0.0, f32::max);
            for (g, w) in got.iter().zip(&r) {
                assert!((*g - *w).length() <= 1e-4 * scale, "{g} vs {w}");
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
