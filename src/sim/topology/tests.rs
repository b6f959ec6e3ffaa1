use std::collections::BTreeSet;

use bevy::math::Vec3;
use bevy::mesh::{Mesh, MeshBuilder, Meshable};
use bevy::shape::Plane3d;
use proptest::prelude::*;

use super::*;
use crate::sim::connections::LinkFamily;

/// Positions (m) and indices of a Bevy mesh.
fn parts(mesh: &Mesh) -> (Vec<Vec3>, Vec<u32>) {
    let positions = mesh
        .attribute(Mesh::ATTRIBUTE_POSITION)
        .and_then(|a| a.as_float3())
        .unwrap()
        .iter()
        .map(|&p| Vec3::from_array(p))
        .collect();
    let indices = mesh.indices().unwrap().iter().map(|i| i as u32).collect();
    (positions, indices)
}

/// The pairs of a family as a set of `map`ped particle pairs, each in
/// increasing order.
fn pairs(links: &[Link], map: impl Fn(u32) -> u32) -> BTreeSet<(u32, u32)> {
    links
        .iter()
        .map(|l| {
            let (a, b) = (map(l.a), map(l.b));
            (a.min(b), a.max(b))
        })
        .collect()
}

const FAMILIES: [LinkFamily; 4] = LinkFamily::ALL;

#[test]
fn a_subdivided_plane_gives_the_grid_builders_links() {
    // 15×15 vertices on a 1 m square in the xz plane.
    let mesh = Plane3d::default()
        .mesh()
        .size(1.0, 1.0)
        .subdivisions(13)
        .build();
    let (positions, indices) = parts(&mesh);
    assert_eq!(positions.len(), 225);
    let topology = MeshTopology::new(&positions, Some(&indices)).unwrap();
    assert_eq!(topology.len(), 225);
    assert_eq!(topology.triangles.len(), 2 * 14 * 14);
    assert_eq!(
        (topology.non_manifold_edges, topology.degenerate_triangles),
        (0, 0)
    );
    let links = topology.connections();
    assert_eq!(links.type1_count(), 812);
    assert_eq!(links.type2_count(), 728);
    // The grid's index of each particle, from its rest position.
    let h = 1.0 / 14.0;
    let cell = |p: Vec3| {
        let (i, j) = (((p.x + 0.5) / h).round(), ((p.z + 0.5) / h).round());
        j as u32 * 15 + i as u32
    };
    let grid_index: Vec<u32> = topology.positions.iter().map(|&p| cell(p)).collect();
    let rest: Vec<Vec3> = (0..225)
        .map(|p| Vec3::new((p % 15) as f32 * h - 0.5, 0.0, (p / 15) as f32 * h - 0.5))
        .collect();
    let grid = Connections::grid(15, 15, &rest);
    for family in FAMILIES {
        let mesh_pairs = pairs(links.family(family), |p| grid_index[p as usize]);
        let grid_pairs = pairs(grid.family(family), |p| p);
        assert_eq!(mesh_pairs, grid_pairs, "{family:?}");
        for l in links.family(family) {
            let (a, b) = (grid_index[l.a as usize], grid_index[l.b as usize]);
            let expected = rest[a as usize].distance(rest[b as usize]);
            assert!((l.rest_length - expected).abs() < 1e-5, "{family:?}");
        }
    }
}

/// A regular hexagon of six equilateral triangles around a centre: no
/// quads, so no diagonals; Type 2 only straight across the centre.
#[test]
fn a_hexagon_fan_has_no_diagonals_and_three_straight_type_2_links() {
    let mut positions = vec![Vec3::ZERO];
    positions.extend((0..6).map(|k| {
        let a = k as f32 * std::f32::consts::TAU / 6.0;
        Vec3::new(a.cos(), 0.0, a.sin())
    }));
    let indices: Vec<u32> = (0..6).flat_map(|k| [0, 1 + k, 1 + (k + 1) % 6]).collect();
    let links = MeshTopology::new(&positions, Some(&indices))
        .unwrap()
        .connections();
    assert_eq!((links.structural.len(), links.shear.len()), (12, 0));
    assert_eq!((links.bend.len(), links.bend_diagonal.len()), (3, 0));
    for l in &links.bend {
        assert!((l.rest_length - 2.0).abs() < 1e-5);
    }
    // Across a rim edge the next rim vertex turns 60°: beyond the bound.
    let rim: BTreeSet<u32> = (1..=6).collect();
    assert!(
        links
            .bend
            .iter()
            .all(|l| rim.contains(&l.a) && rim.contains(&l.b))
    );
}

#[test]
fn equal_positions_weld_and_a_square_gets_both_diagonals() {
    // Two right triangles given as six separate vertices (no indices).
    let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z);
    let topology = MeshTopology::new(&[a, b, c, a, c, d], None).unwrap();
    assert_eq!(topology.len(), 4);
    assert_eq!(
        topology.particle_of,
        [Some(0), Some(1), Some(2), Some(0), Some(2), Some(3)]
    );
    let links = topology.connections();
    assert_eq!((links.structural.len(), links.shear.len()), (4, 2));
    assert_eq!(links.type2_count(), 0);
    // Folded 90° along the diagonal it is no longer a near-planar quad.
    let folded = MeshTopology::new(&[a, b, c, a, c, Vec3::new(0.5, 0.7, 0.5)], None).unwrap();
    assert_eq!(folded.connections().shear.len(), 0);
    // −0 and +0 are one position; an unused vertex is no particle.
    let t = MeshTopology::new(
        &[Vec3::new(-0.0, 0.0, 0.0), b, d, Vec3::Y, a],
        Some(&[4, 1, 2]),
    )
    .unwrap();
    assert_eq!(t.particle_of, [Some(0), Some(1), Some(2), None, Some(0)]);
}

#[test]
fn a_non_manifold_edge_is_kept_and_reported() {
    // Three triangles on the edge 0–1.
    let positions = [Vec3::ZERO, Vec3::X, Vec3::Z, -Vec3::Z, Vec3::Y];
    let indices = [0, 1, 2, 1, 0, 3, 0, 1, 4];
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    assert_eq!(t.non_manifold_edges, 1);
    let links = t.connections();
    assert_eq!(links.type1_count(), 7);
    assert_eq!(links.shear.len(), 0);
}

#[test]
fn bad_meshes_get_an_error() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Z];
    assert_eq!(
        MeshTopology::new(&[], None),
        Err(ClothError::NoTriangles { indices: 0 })
    );
    assert_eq!(
        MeshTopology::new(&tri, Some(&[0, 1])),
        Err(ClothError::NoTriangles { indices: 2 })
    );
    assert!(matches!(
        MeshTopology::new(&[Vec3::ZERO, Vec3::NAN, Vec3::Z], None),
        Err(ClothError::NonFiniteVertex { vertex: 1, .. })
    ));
    assert_eq!(
        MeshTopology::new(&tri, Some(&[0, 1, 7])),
        Err(ClothError::ParticleOutOfRange { index: 7, count: 3 })
    );
    // A repeated vertex, a welded repeat, and three points on a line.
    let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::ZERO];
    assert_eq!(
        MeshTopology::new(&line, Some(&[0, 0, 1, 0, 3, 1, 0, 1, 2])),
        Err(ClothError::DegenerateMesh { triangles: 3 })
    );
    assert_eq!(
        MeshTopology::with_limit(&tri, None, 2),
        Err(ClothError::MeshTooLarge {
            particles: 3,
            max: 2
        })
    );
    // A degenerate triangle beside a good one is dropped and counted.
    let t = MeshTopology::new(&line, Some(&[0, 1, 2, 0, 1, 1])).unwrap_err();
    assert_eq!(t, ClothError::DegenerateMesh { triangles: 2 });
    let ok = MeshTopology::new(&[tri[0], tri[1], tri[2], tri[0]], Some(&[0, 1, 2, 0, 3, 1]));
    assert_eq!(ok.unwrap().degenerate_triangles, 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Random positions (some not finite) and random index buffers (some
    /// out of range, of any length): an error or a topology whose links
    /// all join two of its particles, never a panic.
    #[test]
    fn random_meshes_give_an_error_or_valid_links(
        coords in prop::collection::vec(
            prop_oneof![8 => -2.0f32..2.0, 1 => Just(0.0f32), 1 => Just(f32::NAN)],
            0..60,
        ),
        indices in prop::collection::vec(0u32..24, 0..60),
        indexed in any::<bool>(),
    ) {
        let positions: Vec<Vec3> = coords
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let result = MeshTopology::new(&positions, indexed.then_some(&indices[..]));
        if let Ok(t) = result {
            let n = t.len() as u32;
            prop_assert!(n > 0 && t.triangles.iter().flatten().all(|&i| i < n));
            let links = t.connections();
            for family in FAMILIES {
                for l in links.family(family) {
                    prop_assert!(l.a < n && l.b < n && l.a != l.b);
                    prop_assert!(l.rest_length.is_finite() && l.rest_length > 0.0);
                }
            }
        }
    }
}

/// A disc: every triangle faces +y, and every interior particle has a
/// Type 2 link; every link joins two of its particles.
#[test]
fn a_disc_has_type_2_links_at_every_interior_particle() {
    let rings = 8;
    let (positions, indices) = disc(1.0, rings);
    assert_eq!(positions.len(), 1 + 3 * 8 * 9);
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    assert_eq!(t.len(), positions.len());
    assert_eq!((t.non_manifold_edges, t.degenerate_triangles), (0, 0));
    for tri in &t.triangles {
        let [a, b, c] = tri.map(|i| t.positions[i as usize]);
        assert!((b - a).cross(c - a).y > 0.0, "{tri:?}");
    }
    // Area 6·(√3/4)… close to π: the lumped masses add up to the sheet.
    let mass: f32 = t.lumped_masses(1.0).iter().sum();
    assert!((mass - std::f32::consts::PI).abs() < 0.1, "{mass}");
    // Pins by place: the rim of 48 particles.
    let rim = t.particles_where(|p| p.length() > 0.999);
    assert_eq!(rim.len(), 6 * rings as usize);
    assert!(rim.windows(2).all(|w| w[0] < w[1]));
    let links = t.connections();
    let mut has = vec![false; t.len()];
    for l in links.type2() {
        has[l.a as usize] = true;
        has[l.b as usize] = true;
    }
    let interior = positions.len() - 6 * rings as usize;
    let missing = (0..interior).filter(|&p| !has[p]).count();
    assert_eq!(missing, 0, "interior particles without Type 2");
    assert!(links.type2_count() > t.len(), "{}", links.type2_count());
    // Rims have no quads here: the triangles are near-equilateral.
    // Type 1 is every mesh edge (Euler: 3V − 3 − boundary vertices) plus
    // one added diagonal per quad, whose split diagonal is `shear` too.
    let edges = 3 * t.len() - 3 - 6 * rings as usize;
    assert_eq!(links.shear.len() % 2, 0);
    assert_eq!(links.structural.len() + links.shear.len() / 2, edges);
}

/// Wind and self-collision act on a mesh's faces as on a grid's: face-on
/// air pushes a flat disc with the drag of its area, and a particle pushed
/// through the disc is put back out.
#[test]
fn wind_and_self_collision_act_on_a_meshs_faces() {
    use crate::sim::collision::self_collision::{SelfCollisionBuffers, self_collide};
    use crate::sim::wind::{Wind, wind_forces};
    let (positions, indices) = disc(0.5, 6);
    let t = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let area: f32 = t
        .faces()
        .map(|[a, b, c]| {
            let [a, b, c] = [a, b, c].map(|i| t.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let wind = Wind {
        velocity: Vec3::Y * 10.0,
        ..Default::default()
    };
    let v = vec![Vec3::ZERO; t.len()];
    let mut f = vec![Vec3::ZERO; t.len()];
    wind_forces(&t, &wind, wind.velocity, &t.positions, &v, &mut f);
    // Face-on: ½ρC_d A |v|² along the wind, no lift.
    let total: Vec3 = f.iter().sum();
    let drag = 0.5 * wind.density * wind.drag * area * 100.0;
    assert!(
        (total - Vec3::Y * drag).length() < 1e-3 * drag,
        "{total} vs {drag}"
    );
    // A rim particle folded over to 4 mm above the middle is put a
    // thickness (1 cm) from the triangle under it, which moves too.
    let mut x = t.positions.clone();
    let mut v = vec![Vec3::ZERO; t.len()];
    let w = vec![1.0; t.len()];
    let rim = t.len() - 1;
    x[rim] = Vec3::new(0.01, 0.004, 0.02);
    let mut buffers = SelfCollisionBuffers::default();
    let spacing = 0.5 / 6.0;
    assert!(t.cell_size() > spacing && t.cell_size() < 2.0 * spacing);
    let counts = self_collide(&t, &x.clone(), &mut x, &mut v, &w, 0.01, &mut buffers);
    assert!(counts.contacts > 0);
    let below = (0..7).map(|p| x[p].y).fold(f32::NEG_INFINITY, f32::max);
    let gap = x[rim].y - below;
    assert!(gap > 0.009, "{gap}");
    assert!(x.iter().all(|p| p.is_finite()));
}
