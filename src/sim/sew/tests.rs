use bevy::math::{Vec2, Vec3};

use super::*;
use crate::sim::grid::Grid;
use crate::sim::tear::{self, Adjacency, Blade};

/// An `n × n` grid 1 m across, at rest in the xz plane.
fn grid(n: u32) -> MeshTopology {
    MeshTopology::from_grid(&Grid {
        cols: n,
        rows: n,
        size: Vec2::ONE,
    })
}

/// Every family's links sorted by their ends.
fn sorted(mut c: Connections) -> Connections {
    for family in LinkFamily::ALL {
        c.family_mut(family)
            .sort_unstable_by_key(|l| (l.a.min(l.b), l.a.max(l.b)));
    }
    c
}

#[test]
fn a_seam_joins_chains_of_pairs_into_their_smallest_particle() {
    let seam = Seam::new(6, &[(4, 1), (5, 4), (2, 2), (9, 0)]).unwrap();
    assert_eq!(seam.map, vec![0, 1, 2, 3, 1, 1]);
    assert_eq!((seam.count, seam.origin.clone()), (4, vec![0, 1, 2, 3]));
    let seam = Seam::new(5, &[(3, 1)]).unwrap();
    assert_eq!(
        seam.map,
        vec![0, 1, 2, 1, 3],
        "the particles after move down"
    );
    assert_eq!(seam.origin, vec![0, 1, 2, 4]);
    // Nothing to join.
    assert!(Seam::new(4, &[(2, 2), (7, 1), (u32::MAX, 0)]).is_none());
    assert!(Seam::new(0, &[]).is_none());
    // Values merge into the particle kept.
    let mut masses = vec![1.0, 2.0, 3.0, 4.0, 5.0];
    seam.merge(&mut masses, |kept, other| *kept += *other);
    assert_eq!(masses, vec![1.0, 6.0, 3.0, 5.0]);
    let mut short = vec![1.0; 3];
    seam.merge(&mut short, |kept, other| *kept += *other);
    assert_eq!(short.len(), 3, "a list of another length is left alone");
}

#[test]
fn sewing_a_cut_back_together_gives_the_cloth_it_was() {
    for (n, z) in [(6, 0.45), (9, 0.5), (8, 0.3)] {
        let mut topology = grid(n);
        let whole = topology.clone();
        let rule = topology.connections();
        let x = topology.positions.clone();
        let blades = Blade::quad(
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(2.0, -1.0, z),
            Vec3::new(2.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        );
        let adjacency = Adjacency::new(&topology);
        let (plan, _) = tear::cut(&topology, &x, &blades);
        let outcome = tear::apply(&mut topology, &adjacency, &x, &plan);
        assert!(!outcome.is_empty());
        let torn_rule = topology.connections();
        let origins = outcome.origins(topology.len());
        let torn = tear::rebuild(&rule, &rule, &torn_rule, &origins);
        assert_ne!(sorted(torn.clone()), sorted(rule.clone()));
        // Each copy sewn back onto its particle.
        let pairs: Vec<(u32, u32)> = outcome.copies.iter().map(|&(c, o, _)| (o, c)).collect();
        let seam = Seam::new(topology.len(), &pairs).unwrap();
        assert_eq!(seam.count, (n * n) as usize);
        let (sewn, kept) = seam.topology(&topology);
        assert!(kept.iter().all(|&k| k));
        assert_eq!(sewn.positions, whole.positions);
        assert_eq!(sewn.triangles, whole.triangles, "{n}×{n}");
        assert_eq!(sewn.non_manifold_edges, 0);
        let links = rebuild(&torn, &torn_rule, &sewn.connections(), &seam);
        assert_eq!(
            sorted(links),
            sorted(rule),
            "{n}×{n}: the links of the whole cloth"
        );
    }
}

#[test]
fn a_seam_keeps_rest_lengths_and_drops_what_it_folds_flat() {
    // A 4×4 grid: particle 5 sewn onto 6 (neighbours, a quad's side):
    // the triangles on that side vanish, the rest keep their links' lengths.
    let topology = grid(4);
    let mut old = topology.connections();
    for l in &mut old.structural {
        l.rest_length *= 1.1;
    }
    old.crease.push(Link {
        a: 5,
        b: 6,
        rest_length: 0.1,
    });
    old.crease.push(Link {
        a: 0,
        b: 10,
        rest_length: 0.1,
    });
    let seam = Seam::new(16, &[(5, 6)]).unwrap();
    let (sewn, kept) = seam.topology(&topology);
    assert_eq!(
        kept.iter().filter(|k| !**k).count(),
        2,
        "the two triangles on 5–6"
    );
    assert_eq!(sewn.len(), 15);
    let links = rebuild(&old, &topology.connections(), &sewn.connections(), &seam);
    assert!(links.max_index().is_some_and(|m| m < 15));
    // A structural link away from the seam keeps its edited length.
    let far = links
        .structural
        .iter()
        .find(|l| (l.a.min(l.b), l.a.max(l.b)) == (13, 14))
        .unwrap();
    assert!((far.rest_length - 1.1 / 3.0).abs() < 1e-6);
    assert_eq!(
        links.crease.len(),
        1,
        "the crease link 5–6 became one particle"
    );
    assert_eq!((links.crease[0].a, links.crease[0].b), (0, 9));
}

#[test]
fn sewn_particles_keep_their_mass_and_momentum_and_a_pin_holds_them() {
    use crate::sim::particles::{Particles, PinOwner};
    let x = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
    let mut p = Particles::new(x, vec![1.0, 3.0, 2.0, 2.0]);
    p.velocities = vec![Vec3::X, -Vec3::X, Vec3::Y, Vec3::Z];
    let seam = Seam::new(4, &[(0, 1)]).unwrap();
    let mut free = p.clone();
    free.sew(&seam);
    assert_eq!(free.len(), 3);
    assert_eq!(free.masses, vec![4.0, 2.0, 2.0]);
    assert_eq!(free.inverse_masses[0], 0.25);
    assert_eq!(
        free.positions[0],
        Vec3::new(0.75, 0.0, 0.0),
        "the mass-weighted mean"
    );
    assert_eq!(
        free.velocities[0],
        Vec3::new(-0.5, 0.0, 0.0),
        "momentum kept"
    );
    assert_eq!(free.positions[1], Vec3::Y, "the particles after move down");
    // A pinned particle holds the joined one where it is, with its pins.
    let mut pinned = p.clone();
    pinned.pin_by(1, PinOwner::Anchor);
    let held = pinned.velocities[1];
    pinned.sew(&seam);
    assert!(pinned.is_pinned_by(0, PinOwner::Anchor));
    assert_eq!((pinned.positions[0], pinned.velocities[0]), (Vec3::X, held));
    assert_eq!(pinned.masses[0], 4.0);
    pinned.release_pin(0, PinOwner::Anchor);
    assert_eq!(
        pinned.inverse_masses[0], 0.25,
        "released, it has the joined mass"
    );
}
