use std::collections::BTreeSet;

use bevy::math::{Vec2, Vec3};
use proptest::prelude::*;

use super::*;
use crate::sim::connections::{Link, LinkFamily};
use crate::sim::grid::Grid;

const FAMILIES: [LinkFamily; 4] = LinkFamily::ALL;

/// An `n × n` grid 1 m across, at rest in the xz plane.
fn grid(n: u32) -> (Grid, MeshTopology) {
    let grid = Grid {
        cols: n,
        rows: n,
        size: Vec2::ONE,
    };
    let topology = MeshTopology::from_grid(&grid);
    (grid, topology)
}

/// The pairs of a family, each in increasing order.
fn pairs(links: &[Link]) -> BTreeSet<(u32, u32)> {
    links.iter().map(|l| (l.a.min(l.b), l.a.max(l.b))).collect()
}

/// Checks what a tear must keep: every triangle's corners in range and
/// distinct, every particle in a triangle, every link in range.
fn assert_valid(topology: &MeshTopology) {
    let n = topology.len() as u32;
    let mut used = vec![false; n as usize];
    for t in &topology.triangles {
        assert!(t.iter().all(|&p| p < n), "{t:?} out of {n}");
        assert!(t[0] != t[1] && t[1] != t[2] && t[2] != t[0], "{t:?}");
        for &p in t {
            used[p as usize] = true;
        }
    }
    assert!(used.iter().all(|&u| u), "a particle no triangle uses");
    let c = topology.connections();
    assert!(c.max_index().is_none_or(|m| m < n));
}

#[test]
fn a_grid_s_topology_has_the_grid_s_links() {
    for n in [3, 5, 15] {
        let (grid, topology) = grid(n);
        let rest = topology.positions.clone();
        let (mesh, grid_links) = (topology.connections(), Connections::grid(n, n, &rest));
        for family in FAMILIES {
            assert_eq!(
                pairs(mesh.family(family)),
                pairs(grid_links.family(family)),
                "{n}×{n} {family:?}"
            );
        }
        assert_eq!(grid.len(), topology.len());
    }
}

#[test]
fn a_rebuild_without_a_tear_keeps_every_link_even_a_grid_s_own() {
    // Cells 1 × 0.5: the mesh rule's Type 2 links differ from the grid's.
    let grid = Grid {
        cols: 6,
        rows: 11,
        size: Vec2::new(1.0, 1.0),
    };
    let topology = MeshTopology::from_grid(&grid);
    let old = Connections::grid(grid.cols, grid.rows, &topology.positions);
    let rule = topology.connections();
    assert_ne!(pairs(&old.bend_diagonal), pairs(&rule.bend_diagonal));
    let new = rebuild(
        &old,
        &rule,
        &rule,
        &(0..topology.len() as u32).collect::<Vec<_>>(),
    );
    for family in FAMILIES {
        let mut expected = old.family(family).to_vec();
        expected.sort_unstable_by_key(|l| (l.a, l.b));
        assert_eq!(new.family(family), expected, "{family:?}");
    }
}

/// The links a cut across the grid at `z` must leave: those of the
/// triangles on each side (by their centroids), each side built alone.
fn expected_after_cut(topology: &MeshTopology, z: f32) -> (usize, usize) {
    let (mut type1, mut type2) = (0, 0);
    for below in [true, false] {
        let triangles: Vec<u32> = topology
            .triangles
            .iter()
            .filter(|t| {
                let c = t
                    .iter()
                    .map(|&p| topology.positions[p as usize].z)
                    .sum::<f32>()
                    / 3.0;
                (c < z) == below
            })
            .flatten()
            .copied()
            .collect();
        let side = MeshTopology::new(&topology.positions, Some(&triangles)).unwrap();
        let links = side.connections();
        type1 += links.type1_count();
        type2 += links.type2_count();
    }
    (type1, type2)
}

/// Cuts `topology` (at rest) with `blades`; returns the outcome, the links
/// it crossed and the cloth's links after.
fn cut_at_rest(
    topology: &mut MeshTopology,
    blades: &[Blade],
) -> (TearOutcome, Vec<(u32, u32)>, Connections) {
    let x = topology.positions.clone();
    let old = topology.connections();
    let adjacency = Adjacency::new(topology);
    let (plan, crossed) = cut(topology, &x, blades);
    let outcome = apply(topology, &adjacency, &x, &plan);
    let after = topology.connections();
    let links = rebuild(&old, &old, &after, &outcome.origins(topology.len()));
    (outcome, crossed, links)
}

#[test]
fn a_straight_cut_across_a_grid_leaves_the_links_of_its_two_sides() {
    // The last two cut exactly through a row of particles.
    for (n, z) in [
        (8, 0.4),
        (9, 0.45),
        (15, 0.33),
        (4, 0.7),
        (9, 0.5),
        (15, 0.5),
    ] {
        let through_a_row = ((n - 1) as f32 * z).fract() == 0.0;
        // The cut opens along the row of particles nearest to it.
        let row = ((n - 1) as f32 * z).round() / (n - 1) as f32;
        let (_, mut topology) = grid(n);
        let before = topology.clone();
        // A blade standing across the cloth at `z`, wider than it.
        let blades = Blade::quad(
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(2.0, -1.0, z),
            Vec3::new(2.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        );
        let (outcome, crossed, links) = cut_at_rest(&mut topology, &blades);
        assert_valid(&topology);
        // The blade crosses the n vertical and n − 1 diagonal edges of one
        // band of cells.
        if !through_a_row {
            assert_eq!(crossed.len(), 2 * n as usize - 1, "{n}×{n} cut at {z}");
        }
        assert_eq!(
            (links.type1_count(), links.type2_count()),
            expected_after_cut(&before, row),
            "{n}×{n} cut at {z}"
        );
        // Two pieces: no link joins a particle whose triangles lie below
        // the cut to one whose triangles lie above; one row is doubled.
        let mut side = vec![None; topology.len()];
        for t in &topology.triangles {
            let c = t
                .iter()
                .map(|&p| topology.positions[p as usize].z)
                .sum::<f32>()
                / 3.0;
            for &p in t {
                assert_ne!(
                    side[p as usize],
                    Some(c >= row),
                    "particle {p} on both sides"
                );
                side[p as usize] = Some(c < row);
            }
        }
        for l in links.type1().chain(links.type2()) {
            assert_eq!(
                side[l.a as usize], side[l.b as usize],
                "{l:?} crosses the cut"
            );
        }
        assert_eq!(outcome.copies.len(), n as usize);
        assert!(outcome.copies.iter().all(|&(_, _, s)| s > 0.0 && s <= 0.5));
    }
}

#[test]
fn a_blade_that_misses_changes_nothing() {
    let (_, mut topology) = grid(6);
    let before = topology.clone();
    let far = Blade::quad(
        Vec3::new(3.0, -1.0, 0.5),
        Vec3::new(4.0, -1.0, 0.5),
        Vec3::new(4.0, 1.0, 0.5),
        Vec3::new(3.0, 1.0, 0.5),
    );
    let (outcome, crossed, _) = cut_at_rest(&mut topology, &far);
    assert!(outcome.is_empty() && crossed.is_empty());
    assert_eq!(topology, before);
}

#[test]
fn a_broken_link_opens_a_crack_across_it_and_nothing_bends_across() {
    let (grid, mut topology) = grid(9);
    let old = topology.connections();
    let x = topology.positions.clone();
    let adjacency = Adjacency::new(&topology);
    // The link between (4, 4) and (4, 5), along z.
    let (a, b) = (grid.index(4, 4), grid.index(4, 5));
    let plan = break_links(&x, &[(a, b)]);
    let outcome = apply(&mut topology, &adjacency, &x, &plan);
    assert_valid(&topology);
    // One end splits in halves; its copy takes the side away from the link.
    assert_eq!(outcome.copies.len(), 1);
    let (copy, original, share) = outcome.copies[0];
    assert_eq!((original, share), (a, 0.5));
    let links = rebuild(
        &old,
        &old,
        &topology.connections(),
        &outcome.origins(topology.len()),
    );
    let row = |p: u32| if p == copy { 4 } else { p / 9 };
    for l in links.type1().chain(links.type2()) {
        for (p, q) in [(l.a, l.b), (l.b, l.a)] {
            assert!(!(p == a && row(q) < 4), "{l:?}: the kept end reaches below");
            assert!(!(p == copy && row(q) > 4), "{l:?}: the copy reaches above");
        }
    }
    // The link itself stays, on the kept side; the vertical bend through
    // the split particle is gone.
    let has = |links: &Connections, p: u32, q: u32| {
        links
            .type1()
            .chain(links.type2())
            .any(|l| (l.a.min(l.b), l.a.max(l.b)) == (p.min(q), p.max(q)))
    };
    assert!(has(&links, a, b));
    let (under, over) = (grid.index(4, 3), grid.index(4, 5));
    assert!(has(&old, under, over) && !has(&links, under, over));
}

#[test]
fn tearing_a_boundary_link_and_a_quad_s_other_diagonal_opens_the_cloth() {
    let (grid, topology) = grid(5);
    for link in [
        (grid.index(0, 2), grid.index(0, 3)),
        // (1, 1)–(2, 2) is a mesh edge; (2, 1)–(1, 2) is the added one.
        (grid.index(2, 1), grid.index(1, 2)),
        (grid.index(4, 4), grid.index(3, 4)),
    ] {
        let mut t = topology.clone();
        let x = t.positions.clone();
        let adjacency = Adjacency::new(&t);
        let plan = break_links(&x, &[link]);
        let outcome = apply(&mut t, &adjacency, &x, &plan);
        assert_valid(&t);
        assert_eq!(outcome.copies.len(), 1, "{link:?}");
    }
}

#[test]
fn rest_lengths_and_creases_carry_over_a_tear() {
    let (grid, mut topology) = grid(7);
    let x = topology.positions.clone();
    let rule = topology.connections();
    let mut old = rule.clone();
    // A changed rest length far from the tear, and crease links on bends.
    let far = (grid.index(0, 0), grid.index(1, 0));
    old.structural
        .iter_mut()
        .find(|l| (l.a, l.b) == far)
        .unwrap()
        .rest_length = 0.1;
    let bend = *old.bend.iter().find(|l| l.a == grid.index(0, 0)).unwrap();
    let crossing = *old
        .bend
        .iter()
        .find(|l| l.a == grid.index(3, 2) && l.b == grid.index(3, 4))
        .unwrap();
    old.crease = vec![bend, crossing];
    let adjacency = Adjacency::new(&topology);
    let plan = break_links(&x, &[(grid.index(3, 3), grid.index(3, 4))]);
    let outcome = apply(&mut topology, &adjacency, &x, &plan);
    let new = rebuild(
        &old,
        &rule,
        &topology.connections(),
        &outcome.origins(topology.len()),
    );
    let kept = new.structural.iter().find(|l| (l.a, l.b) == far).unwrap();
    assert_eq!(kept.rest_length, 0.1);
    // The crease ends at the tear: the link across it is gone.
    assert_eq!(new.crease, vec![bend]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// A thousand random cuts and tears, through the same place twice,
    /// until the cloth is in pieces: a valid topology after every one, and
    /// the mass of every original particle conserved.
    #[test]
    fn random_cuts_and_tears_keep_the_topology_valid(
        n in 3u32..9,
        cuts in prop::collection::vec(
            (0.0f32..1.0, 0.0f32..1.0, -3.2f32..3.2, any::<bool>(), 0usize..400),
            80,
        ),
    ) {
        let (_, mut topology) = grid(n);
        let mut x = topology.positions.clone();
        let mut mass = topology.lumped_masses(1.0);
        let total: f32 = mass.iter().sum();
        let mut links = topology.connections();
        for (u, v, angle, blade, link) in cuts {
            let adjacency = Adjacency::new(&topology);
            let rule = topology.connections();
            let plan = if blade {
                let d = Vec3::new(angle.cos(), 0.0, angle.sin());
                let c = Vec3::new(u, 0.0, v);
                cut(&topology, &x, &Blade::quad(
                    c - d + Vec3::NEG_Y, c + d + Vec3::NEG_Y, c + d + Vec3::Y, c - d + Vec3::Y,
                )).0
            } else {
                let all: Vec<(u32, u32)> = links.type1().map(|l| (l.a, l.b)).collect();
                if all.is_empty() {
                    continue;
                }
                break_links(&x, &[all[link % all.len()]])
            };
            let outcome = apply(&mut topology, &adjacency, &x, &plan);
            for &(copy, original, share) in &outcome.copies {
                prop_assert_eq!(copy as usize, x.len());
                x.push(x[original as usize]);
                let m = mass[original as usize];
                mass[original as usize] = m * (1.0 - share);
                mass.push(m * share);
            }
            assert_valid(&topology);
            prop_assert_eq!(x.len(), topology.len());
            links = rebuild(&links, &rule, &topology.connections(), &outcome.origins(x.len()));
            prop_assert!(links.max_index().is_none_or(|m| (m as usize) < x.len()));
        }
        let now: f32 = mass.iter().sum();
        prop_assert!((now - total).abs() < 1e-4 * total);
    }
}

/// The number of pieces of `links` over `n` particles (by any link).
fn pieces(n: usize, links: &Connections) -> usize {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for l in links.type1().chain(links.type2()) {
        let (a, b) = (
            root(&mut parent, l.a as usize),
            root(&mut parent, l.b as usize),
        );
        parent[a] = b;
    }
    (0..n).filter(|&i| root(&mut parent, i) == i).count()
}

#[test]
fn a_straight_cut_across_an_irregular_disc_parts_it_in_two() {
    let (positions, indices) = crate::sim::topology::disc(0.5, 10);
    let topology = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let cuts = [0.1f32, -0.23, 0.37, 0.0, 0.05]
        .map(|x| (x, 0.0f32))
        .into_iter()
        .chain([(0.07, 0.3), (-0.12, 1.1), (0.2, 2.0), (0.0, 0.7)]);
    for (x, angle) in cuts {
        let mut t = topology.clone();
        // A blade through (x, 0, 0), turned by `angle` about y.
        let (across, along) = (
            Vec3::new(angle.cos(), 0.0, angle.sin()),
            Vec3::new(-angle.sin(), 0.0, angle.cos()),
        );
        let c = across * x;
        let blades = Blade::quad(
            c - along - Vec3::Y,
            c + along - Vec3::Y,
            c + along + Vec3::Y,
            c - along + Vec3::Y,
        );
        let (_, crossed, links) = cut_at_rest(&mut t, &blades);
        assert_valid(&t);
        assert!(!crossed.is_empty());
        assert_eq!(pieces(t.len(), &links), 2, "cut at {x} m, {angle} rad");
    }
}

#[test]
fn cuts_that_cross_part_a_grid_in_the_pieces_between_them() {
    // Blades standing across the sheet along z (at x) and along x (at z).
    let across_x = |x: f32| {
        Blade::quad(
            Vec3::new(x, -1.0, -1.0),
            Vec3::new(x, -1.0, 2.0),
            Vec3::new(x, 1.0, 2.0),
            Vec3::new(x, 1.0, -1.0),
        )
    };
    let across_z = |z: f32| {
        Blade::quad(
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(2.0, -1.0, z),
            Vec3::new(2.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        )
    };
    for (n, xs, zs, expected) in [
        (9, vec![0.47], vec![0.52], 4),
        (32, vec![0.25, 0.5, 0.75], vec![0.2, 0.4, 0.6, 0.8], 20),
        (12, vec![0.3, 0.7], vec![0.5], 6),
        (32, vec![], vec![0.2, 0.4, 0.6, 0.8], 5),
        (32, vec![0.25, 0.5, 0.75], vec![], 4),
        (32, vec![0.5], vec![], 2),
        (32, vec![0.25], vec![0.2], 4),
        (32, vec![0.5], vec![0.2], 4),
        (32, vec![0.5], vec![0.4], 4),
        (32, vec![0.75], vec![0.6], 4),
        (32, vec![0.25], vec![0.8], 4),
        (32, vec![0.25, 0.75], vec![0.2, 0.4, 0.6, 0.8], 15),
    ] {
        let (_, mut topology) = grid(n);
        let blades: Vec<Blade> = xs
            .iter()
            .flat_map(|&x| across_x(x))
            .chain(zs.iter().flat_map(|&z| across_z(z)))
            .collect();
        let (_, _, links) = cut_at_rest(&mut topology, &blades);
        assert_valid(&topology);
        let got = pieces(topology.len(), &links);
        assert_eq!(got, expected, "{n}×{n} cut at x {xs:?} and z {zs:?}");
    }
}
