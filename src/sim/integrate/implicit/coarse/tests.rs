//! Unit tests of the multigrid hierarchy: each level is the Galerkin
//! operator of the one below, the coarsest is solved exactly, and the
//! preconditioner is symmetric positive definite.

use bevy::math::{Vec3, Vec3A};

use super::super::operator::{Operator, Soa};
use super::super::tests::{deformed, soa};
use super::{Coarse, LevelWork, OMEGA, THETA};

/// The operator and hierarchy of a deformed, moving `n × n` cloth at
/// 1/60 s.
fn hierarchy(n: u32) -> (Operator, Coarse) {
    let (cloth, _, blocks) = deformed(n);
    let w = &cloth.particles.inverse_masses;
    let h = 1.0 / 60.0;
    let mut coarse = Coarse::default();
    assert!(coarse.begin(n as usize, w, 1.1));
    let mut op = Operator::default();
    op.build(n as usize, w, 1.1, &blocks, h, h * h, Some(&mut coarse));
    assert!(coarse.finish());
    (op, coarse)
}

/// An irregular vector of `count` entries (dimensionless).
pub(in super::super) fn irregular(count: usize, seed: f32) -> Vec<Vec3A> {
    (0..count)
        .map(|i| {
            let s = i as f32 + seed;
            Vec3A::new((1.7 * s).sin(), (0.3 * s).cos(), (2.9 * s).sin() * 0.5)
        })
        .collect()
}

/// `A e` on a level, from its residual: `r − (r − A e)` with `r = 0`.
fn level_product(coarse: &Coarse, l: usize, e: &[Vec3A]) -> Vec<Vec3A> {
    let zero = vec![Vec3A::ZERO; e.len()];
    let mut t = zero.clone();
    coarse.levels()[l].residual(&zero, e, &mut t);
    t.iter().map(|t| -*t).collect()
}

fn close(a: Vec3A, b: Vec3A, scale: f32, tolerance: f32) -> bool {
    (a - b).length() <= tolerance * scale
}

#[test]
fn the_first_level_is_r_transpose_a_r() {
    // Even and odd sides: aggregates of one column or row at the edges.
    for n in [8, 13, 32] {
        let (mut op, mut coarse) = hierarchy(n);
        let particles = (n * n) as usize;
        let count = coarse.levels()[0].count();
        let e = irregular(count, 0.0);
        // R e, 0 at pins.
        let re = soa(particles, |p| {
            if op.free[p] == 0.0 {
                Vec3::ZERO
            } else {
                e[coarse.aggregate_of(p)].into()
            }
        });
        let mut are = soa(particles, |_| Vec3::ZERO);
        op.apply(&re, &mut are);
        // Rᵀ(A R e) through the bands' restriction.
        let mut s = coarse.take_scratch();
        let per_band = coarse.per_band();
        let (r, rows) = (&mut s.top[0], &mut s.rows[0]);
        for (j, rc) in r.chunks_mut(per_band).enumerate() {
            let range = coarse.band_rows(j, particles);
            let band = are.0.each_ref().map(|c| &c[range.clone()]);
            coarse.restrict_band(band, rc, rows);
        }
        let want = s.top[0].clone();
        coarse.put_scratch(s);
        let got = level_product(&coarse, 0, &e);
        let scale = want.iter().map(|v| v.length()).fold(0.0, f32::max);
        for (a, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!(
                close(*g, *w, scale, 1e-4),
                "{n}×{n}, aggregate {a}: {g} vs {w}"
            );
        }
    }
}

#[test]
fn each_level_is_the_galerkin_operator_of_the_one_below() {
    for n in [64, 100] {
        let (_, coarse) = hierarchy(n);
        let levels = coarse.levels();
        assert!(levels.len() >= 3, "{n}×{n}: {} levels", levels.len());
        assert!(levels.last().unwrap().count() <= super::COARSEST);
        for l in 0..levels.len() - 1 {
            let (fine, above) = (&levels[l], &levels[l + 1]);
            let e = irregular(above.count(), l as f32);
            // R e on the level below, then A R e, then Rᵀ A R e.
            let mut re = vec![Vec3A::ZERO; fine.count()];
            fine.prolong(1.0, &e, &mut re);
            let are = level_product(&coarse, l, &re);
            let mut want = vec![Vec3A::ZERO; above.count()];
            fine.restrict(&are, &mut want);
            let got = level_product(&coarse, l + 1, &e);
            let scale = want.iter().map(|v| v.length()).fold(0.0, f32::max);
            for (a, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    close(*g, *w, scale, 1e-4),
                    "{n}×{n}, level {}, node {a}: {g} vs {w}",
                    l + 2
                );
            }
        }
    }
}

#[test]
fn the_coarsest_level_is_solved_exactly() {
    for n in [16, 64, 100] {
        let (_, coarse) = hierarchy(n);
        let last = coarse.levels().len() - 1;
        let level = &coarse.levels()[last];
        let e: Vec<Vec3A> = irregular(level.count(), 3.0)
            .into_iter()
            .zip(&level.filled)
            .map(|(e, &filled)| if filled { e } else { Vec3A::ZERO })
            .collect();
        let ae = level_product(&coarse, last, &e);
        let mut z = vec![0.0; 3 * level.count()];
        let mut back = vec![Vec3A::ZERO; level.count()];
        coarse.solve_coarsest(&ae, &mut back, &mut z);
        for (a, (b, e)) in back.iter().zip(&e).enumerate() {
            assert!(close(*b, *e, 1.0, 2e-3), "{n}×{n}, node {a}: {b} vs {e}");
        }
    }
}

/// `P⁻¹ r` of the whole preconditioner (block-Jacobi plus the cycle).
fn precondition(op: &Operator, coarse: &mut Coarse, r: &Soa) -> Soa {
    let mut y = soa(op.free.len(), |_| Vec3::ZERO);
    op.precondition(r, &mut y);
    coarse.add(r, &mut y, &op.free);
    y
}

fn dot(a: &Soa, b: &Soa) -> f64 {
    (0..3)
        .map(|k| {
            a.0[k]
                .iter()
                .zip(&b.0[k])
                .map(|(x, y)| (x * y) as f64)
                .sum::<f64>()
        })
        .sum()
}

#[test]
fn the_preconditioner_is_symmetric_positive_definite() {
    // The cycle's weights are what the claim rests on.
    const { assert!(OMEGA > 0.0 && OMEGA < 1.0 && THETA > 0.0 && THETA < 2.0) };
    for n in [13, 64, 100] {
        let (op, mut coarse) = hierarchy(n);
        let particles = (n * n) as usize;
        let pinned = |p: usize, v: Vec3| if op.free[p] == 0.0 { Vec3::ZERO } else { v };
        let vectors: Vec<Soa> = (0..4)
            .map(|k| {
                soa(particles, |p| {
                    let s = p as f32 * (0.37 + 0.21 * k as f32);
                    let smooth = Vec3::new((p as f32 * 0.01).sin(), 0.3, -1.0);
                    pinned(
                        p,
                        Vec3::new(s.sin(), (1.3 * s).cos(), (0.7 * s).sin()) + smooth * k as f32,
                    )
                })
            })
            .collect();
        let images: Vec<Soa> = vectors
            .iter()
            .map(|v| precondition(&op, &mut coarse, v))
            .collect();
        for (i, u) in vectors.iter().enumerate() {
            let uu = dot(u, &images[i]);
            assert!(uu > 0.0, "{n}×{n}: uᵀP⁻¹u = {uu}");
            for (j, v) in vectors.iter().enumerate().skip(i + 1) {
                let (uv, vu) = (dot(u, &images[j]), dot(v, &images[i]));
                let scale = (uu * dot(v, &images[j])).sqrt();
                assert!((uv - vu).abs() <= 1e-4 * scale, "{n}×{n}: {uv} vs {vu}");
            }
        }
    }
}

#[test]
fn a_split_cycle_uses_the_same_scratch_sizes() {
    // The split solve lends out the scratch: its sizes follow the levels.
    let (_, mut coarse) = hierarchy(64);
    let s = coarse.take_scratch();
    assert_eq!(s.top[0].len(), coarse.levels()[0].count());
    assert_eq!(s.work.len(), coarse.levels().len());
    let work: &Vec<LevelWork> = &s.work;
    for (w, level) in work.iter().zip(coarse.levels()) {
        assert_eq!(w.t.len(), level.count());
    }
    coarse.put_scratch(s);
}
