//! Creases on mesh cloths: a crease is a segment in the mesh's rest space;
//! on a mesh shaped like a grid it selects and folds exactly as on the
//! grid, it does not depend on how the mesh is turned, it stays on its side
//! of a tube, and bad creases change nothing.

use crate::common;

use std::collections::BTreeMap;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::connections::Connections;
use bevy_cloth::sim::crease::{Crease, CreaseRecord, FoldSide, RestSurface, apply_creases};
use bevy_cloth::sim::grid::Grid;
use bevy_cloth::sim::topology::MeshTopology;
use common::{app, disc_mesh, paper_app_with as paper_app, particles, triangle_mesh};

/// The crease links of `connections` as `(a, b) → rest length` (m), and
/// the fold triples as `(a, c) → (hinge, sign)`.
type Folded = (BTreeMap<(u32, u32), f32>, BTreeMap<(u32, u32), (u32, f32)>);

fn folded(connections: &Connections) -> Folded {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    (
        connections
            .crease
            .iter()
            .map(|l| (key(l.a, l.b), l.rest_length))
            .collect(),
        connections
            .fold
            .iter()
            .map(|t| (key(t.a, t.c), (t.hinge, t.sign)))
            .collect(),
    )
}

/// Applies `creases` to a copy of `connections` on `surface`.
fn crease(surface: &RestSurface, connections: &Connections, creases: &[Crease]) -> Connections {
    let mut out = connections.clone();
    let errors = apply_creases(surface, &mut out, &mut CreaseRecord::default(), creases);
    assert!(errors.is_empty(), "{errors:?}");
    out
}

fn grid(n: u32) -> Grid {
    Grid {
        cols: n,
        rows: n,
        size: Vec2::ONE,
    }
}

/// Creases of every kind on a 1 m sheet: along a column, a row, the
/// diagonal, a shallow slope, a short piece inside, a segment ending inside.
fn creases() -> Vec<Crease> {
    vec![
        Crease::new(Vec2::new(0.5, -0.1), Vec2::new(0.5, 1.1)).with_side(FoldSide::Mountain),
        Crease::new(Vec2::new(-0.1, 0.3), Vec2::new(1.1, 0.3)).with_side(FoldSide::Valley),
        Crease::new(Vec2::ZERO, Vec2::ONE).with_side(FoldSide::Mountain),
        Crease::new(Vec2::new(0.0, 0.21), Vec2::new(1.0, 0.6)).with_ratio(0.5),
        Crease::new(Vec2::new(0.3, 0.3), Vec2::new(0.6, 0.5)).with_side(FoldSide::Valley),
        Crease::new(Vec2::new(0.13, 1.2), Vec2::new(0.77, 0.45)).with_angle(1.0),
    ]
}

#[test]
fn a_crease_on_a_mesh_shaped_like_a_grid_is_the_same_crease() {
    for n in [8, 15] {
        let grid = grid(n);
        let topology = MeshTopology::from_grid(&grid);
        let mesh_links = topology.connections();
        let grid_links = Connections::grid(n, n, &topology.positions);
        for (k, c) in creases().into_iter().enumerate() {
            let on_grid = crease(&RestSurface::grid(&grid), &grid_links, &[c]);
            let on_mesh = crease(
                &RestSurface::mesh(&topology, &mesh_links),
                &mesh_links,
                &[c],
            );
            let (g, m) = (folded(&on_grid), folded(&on_mesh));
            assert!(!g.0.is_empty(), "{n}: crease {k} selects nothing");
            assert_eq!(
                g.0.keys().collect::<Vec<_>>(),
                m.0.keys().collect::<Vec<_>>(),
                "{n}: crease {k}"
            );
            for (pair, rest) in &g.0 {
                assert!((rest - m.0[pair]).abs() < 1e-6, "{n}: crease {k} {pair:?}");
            }
            // The same fold triples, hinges and sides.
            assert_eq!(g.1, m.1, "{n}: crease {k}");
        }
    }
}

#[test]
fn a_crease_turned_with_its_mesh_selects_the_same_links() {
    let (positions, indices) = common::jittered_disc(8, 0.5, 0.6);
    let turn = Quat::from_euler(EulerRot::XYZ, 0.7, -1.1, 0.4);
    let turned: Vec<Vec3> = positions.iter().map(|&p| turn * p + Vec3::X).collect();
    let flat = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let tilted = MeshTopology::new(&turned, Some(&indices)).unwrap();
    let (flat_links, tilted_links) = (flat.connections(), tilted.connections());
    for (k, c) in creases().into_iter().enumerate() {
        // The sheet's creases, moved onto the disc (centred on the origin)
        // and off its particles: a particle on a crease's plane is on
        // neither side, and turned it is on one of them by rounding.
        let off = Vec3::new(0.5 - 0.0137, 0.0, 0.5 - 0.0071);
        let c = Crease {
            from: c.from - off,
            to: c.to - off,
            ..c
        };
        let moved = Crease {
            from: turn * c.from + Vec3::X,
            to: turn * c.to + Vec3::X,
            ..c
        };
        let a = folded(&crease(
            &RestSurface::mesh(&flat, &flat_links),
            &flat_links,
            &[c],
        ));
        let b = folded(&crease(
            &RestSurface::mesh(&tilted, &tilted_links),
            &tilted_links,
            &[moved],
        ));
        assert!(!a.0.is_empty(), "crease {k} selects nothing");
        assert_eq!(
            a.0.keys().collect::<Vec<_>>(),
            b.0.keys().collect::<Vec<_>>(),
            "crease {k}"
        );
        for (pair, rest) in &a.0 {
            assert!((rest - b.0[pair]).abs() < 1e-5, "crease {k} {pair:?}");
        }
        assert_eq!(a.1, b.1, "crease {k}");
    }
}

/// An open tube of radius `r` m around the y axis, 0.6 m long: `around`
/// particles per ring, 13 rings, its triangles facing out.
fn tube(r: f32, around: u32) -> (Vec<Vec3>, Vec<u32>) {
    let rings = 13;
    let positions = (0..rings)
        .flat_map(|j| {
            (0..around).map(move |i| {
                let a = std::f32::consts::TAU * i as f32 / around as f32;
                Vec3::new(r * a.sin(), 0.05 * j as f32 - 0.3, r * a.cos())
            })
        })
        .collect();
    let mut indices = Vec::new();
    for j in 0..rings - 1 {
        for i in 0..around {
            let p = |i: u32, j: u32| j * around + i % around;
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            indices.extend([a, b, c, a, c, d]);
        }
    }
    (positions, indices)
}

#[test]
fn a_crease_on_one_side_of_a_tube_leaves_the_other_side_alone() {
    let (positions, indices) = tube(0.2, 24);
    let topology = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let links = topology.connections();
    let surface = RestSurface::mesh(&topology, &links);
    // Outward normals.
    assert!(
        surface.normal(0).dot(Vec3::Z) > 0.9,
        "{}",
        surface.normal(0)
    );
    // Down the front of the tube, at z = +r: its plane (x = 0) cuts the
    // back of the tube too, 0.4 m away.
    let front = Crease::on_rest(Vec3::new(0.0, -0.35, 0.2), Vec3::new(0.0, 0.35, 0.2))
        .with_side(FoldSide::Mountain);
    let creased = crease(&surface, &links, &[front]);
    assert!(!creased.crease.is_empty());
    for l in &creased.crease {
        let (a, b) = (positions[l.a as usize], positions[l.b as usize]);
        assert!(a.z > 0.1 && b.z > 0.1, "{a} – {b}");
    }
    // The crease runs the tube's length: a link across it in every ring.
    assert!(creased.crease.len() >= 13, "{}", creased.crease.len());
    // Its fold triples' hinges are on the crease, their normals outward.
    for t in &creased.fold {
        assert!(positions[t.hinge as usize].x.abs() < 1e-4);
    }
}

#[test]
fn bad_creases_on_a_mesh_are_errors_and_change_nothing() {
    let (positions, indices) = tube(0.2, 24);
    let topology = MeshTopology::new(&positions, Some(&indices)).unwrap();
    let links = topology.connections();
    let surface = RestSurface::mesh(&topology, &links);
    let good = Crease::on_rest(Vec3::new(0.0, -0.35, 0.2), Vec3::new(0.0, 0.35, 0.2));
    assert!(good.validate(&surface, &links).is_ok());
    for bad in [
        // Beside the tube.
        Crease::on_rest(Vec3::new(2.0, -0.35, 0.2), Vec3::new(2.0, 0.35, 0.2)),
        // Through its hollow middle, along its axis: no link crosses it
        // near the segment.
        Crease::on_rest(Vec3::new(0.0, -0.35, 0.0), Vec3::new(0.0, 0.35, 0.0)),
        Crease::on_rest(Vec3::new(f32::NAN, 0.0, 0.2), Vec3::new(0.0, 0.35, 0.2)),
        Crease::on_rest(Vec3::splat(0.2), Vec3::splat(0.2)),
        good.with_ratio(0.0),
        good.with_angle(f32::INFINITY),
    ] {
        assert!(
            matches!(
                bad.validate(&surface, &links),
                Err(ClothError::InvalidCrease(_))
            ),
            "{bad:?}"
        );
        let mut after = links.clone();
        let errors = apply_creases(&surface, &mut after, &mut CreaseRecord::default(), &[bad]);
        assert_eq!(errors.len(), 1);
        assert_eq!(after, links);
    }
}

/// A 15×15, 1 m sheet as a mesh cloth: the grid's triangles, laid as the
/// grid sheet is (its rest `(u, 0, v)` at `(u − ½, 1, v − ½)`), with the
/// grid's particles (a mesh lumps a corner's mass by its triangles, a grid
/// by its cell).
fn mesh_sheet() -> ClothBundle {
    let grid = grid(15);
    let topology = MeshTopology::from_grid(&grid);
    let indices = grid.triangles().into_iter().flatten().collect();
    let mesh = triangle_mesh(&topology.positions, indices);
    let mut sheet = ClothBuilder::from_mesh(&mesh)
        .material(ClothMaterial::Raw)
        .position(Vec3::new(-0.5, 1.0, -0.5))
        .build()
        .unwrap();
    let particles = grid_sheet().particles;
    assert_eq!(particles.positions, sheet.particles.positions);
    sheet.particles = particles;
    sheet
}

fn grid_sheet() -> ClothBundle {
    ClothBuilder::new(15, 15)
        .material(ClothMaterial::Raw)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .build()
        .unwrap()
}

/// The angle (degrees) between the mean normals of the flaps, the
/// triangles whose rest centroids are more than 0.15 m either side of
/// `x` = 0, and the height (m) of the particles within 2 cm of that line
/// (at rest) over the flaps' particles, along the flaps' mean normal: both
/// the same however the folded cloth has turned.
fn fold(rest: &[Vec3], x: &[Vec3], triangles: &[[u32; 3]]) -> (f32, f32) {
    let mut flaps = [Vec3::ZERO; 2];
    for t in triangles {
        let [a, b, c] = t.map(|p| x[p as usize]);
        let centre = t.map(|p| rest[p as usize]).iter().sum::<Vec3>() / 3.0;
        let n = (b - a).cross(c - a).normalize_or_zero();
        if centre.x < -0.15 {
            flaps[0] += n;
        } else if centre.x > 0.15 {
            flaps[1] += n;
        }
    }
    let up = (flaps[0].normalize() + flaps[1].normalize()).normalize();
    let mean = |keep: &dyn Fn(f32) -> bool| {
        let (sum, count) = x
            .iter()
            .zip(rest)
            .filter(|(_, r)| keep(r.x))
            .fold((0.0, 0), |(s, c), (p, _)| (s + p.dot(up), c + 1));
        sum / count as f32
    };
    (
        flaps[0]
            .normalize()
            .angle_between(flaps[1].normalize())
            .to_degrees(),
        mean(&|x| x.abs() < 0.02) - mean(&|x| x.abs() > 0.15),
    )
}

/// Spawns `cloth` with `creases` in `app`, steps it `frames` frames, and
/// returns its fold ([`fold`]) and its particles.
fn fold_in_app(
    mut app: App,
    cloth: ClothBundle,
    creases: Vec<Crease>,
    frames: usize,
) -> ((f32, f32), Vec<Vec3>) {
    let triangles = cloth.cloth.layout().topology().triangles.clone();
    let rest = cloth.particles.positions.clone();
    let e = app.world_mut().spawn((cloth, ClothCreases(creases))).id();
    for _ in 0..frames {
        app.update();
    }
    let x = particles(&app, e).positions.clone();
    assert!(x.iter().all(|p| p.is_finite()));
    (fold(&rest, &x, &triangles), x)
}

/// 40 substeps of symplectic Euler a frame: no numerical damping, so the
/// crease model's own motion shows as it is.
fn undamped() -> ClothSettings {
    ClothSettings::default()
        .with_integrator(Integrator::SymplecticEuler, 40)
        .without_adaptive()
}

#[test]
fn a_mesh_cloth_folds_along_its_crease_as_the_grid_does() {
    // A free fold (the paper's r = 0.7) down the middle of the sheet: the
    // same links and crease springs (the test above), the same fold.
    let middle = Crease::new(Vec2::new(0.5, -0.1), Vec2::new(0.5, 1.1));
    // A start that sets the fold's direction: the middle column lifted.
    let lift = |mut cloth: ClothBundle| {
        for x in &mut cloth.particles.positions {
            x.y += 0.02 * (1.0 - (x.x / 0.1).powi(2)).max(0.0);
        }
        cloth
    };
    let (grid, _) = fold_in_app(paper_app(undamped()), lift(grid_sheet()), vec![middle], 300);
    let (mesh, _) = fold_in_app(paper_app(undamped()), lift(mesh_sheet()), vec![middle], 300);
    eprintln!("free r = 0.7 fold: grid {grid:?}, mesh {mesh:?} (angle °, ridge height m)");
    assert!((grid.0 - 91.1).abs() <= 10.0, "{grid:?}");
    // A mesh cloth's forces are summed link by link, a grid's in bands:
    // without a crease the two part by 4 mm over half a second of this
    // undamped motion. Folded, they come to the same angle and ridge.
    assert!((grid.0 - mesh.0).abs() < 2.0, "{grid:?} {mesh:?}");
    assert!((grid.1 - mesh.1).abs() < 0.005, "{grid:?} {mesh:?}");
    // A mountain fold of 45° from flat: the fold triples' normals come
    // from other neighbours on a mesh, so the motion differs a little, but
    // both fold to the angle with the ridge up.
    let mountain = middle
        .with_angle(45f32.to_radians())
        .with_side(FoldSide::Mountain);
    for (name, cloth) in [("grid", grid_sheet()), ("mesh", mesh_sheet())] {
        let ((angle, ridge), _) = fold_in_app(paper_app(undamped()), cloth, vec![mountain], 300);
        eprintln!("45° mountain fold, {name}: {angle:.1}°, ridge {ridge:.3} m");
        assert!((angle - 45.0).abs() <= 10.0, "{name}: {angle}°");
        assert!(ridge > 0.02, "{name}: ridge {ridge} m");
    }
}

#[test]
fn an_irregular_disc_folds_along_a_crease_either_way() {
    for (side, up) in [(FoldSide::Mountain, 1.0), (FoldSide::Valley, -1.0)] {
        let crease = Crease::on_rest(Vec3::new(0.0, 0.0, -0.6), Vec3::new(0.0, 0.0, 0.6))
            .with_angle(60f32.to_radians())
            .with_side(side);
        let disc = ClothBuilder::from_mesh(&disc_mesh(10, 0.5, 0.5))
            .material(ClothMaterial::Raw)
            .position(Vec3::Y)
            .build()
            .unwrap();
        // The default stepping, whose damping settles the fold.
        let ((angle, ridge), _) = fold_in_app(paper_app(default()), disc, vec![crease], 900);
        eprintln!("disc, 60° {side:?}: {angle:.1}°, ridge {ridge:.3} m");
        // Its hinges lie off the line, among irregular triangles: 68.7°
        // either way.
        assert!((angle - 60.0).abs() < 15.0, "{side:?}: {angle}°");
        assert!(ridge * up > 0.02, "{side:?}: ridge {ridge} m");
    }
}

#[test]
fn removing_a_mesh_cloths_creases_restores_its_links_and_a_torn_one_takes_new_ones() {
    let mut app = app();
    let disc = ClothBuilder::from_mesh(&disc_mesh(8, 0.5, 0.5))
        .position(Vec3::Y)
        .build()
        .unwrap();
    let original = disc.connections.clone();
    let across = Crease::on_rest(Vec3::new(-0.6, 0.0, 0.1), Vec3::new(0.6, 0.0, -0.1));
    let e = app
        .world_mut()
        .spawn((disc, ClothCreases(vec![across]), ClothTearing::default()))
        .id();
    for _ in 0..20 {
        app.update();
    }
    let creased = app.world().get::<ClothConnections>(e).unwrap().clone();
    assert!(!creased.crease.is_empty());
    app.world_mut().entity_mut(e).remove::<ClothCreases>();
    app.update();
    let links = app.world().get::<ClothConnections>(e).unwrap();
    assert_eq!(links.structural, original.structural);
    assert_eq!(links.bend, original.bend);
    assert_eq!(links.bend_diagonal, original.bend_diagonal);
    assert!(links.crease.is_empty() && links.fold.is_empty());
    // Cut across the crease's line, then creased again: the torn disc
    // takes the crease on both pieces and stays whole and finite.
    let before = particles(&app, e).len();
    app.world_mut().write_message(ClothCut::along(
        Some(e),
        Vec3::new(0.0, 1.0, -0.6),
        Vec3::new(0.0, 1.0, 0.6),
        Vec3::Y,
    ));
    app.update();
    assert!(particles(&app, e).len() > before, "not cut");
    app.world_mut()
        .entity_mut(e)
        .insert(ClothCreases(vec![across]));
    for _ in 0..60 {
        app.update();
        let stats = app.world().get::<ClothStats>(e).unwrap();
        assert!(stats.finite);
    }
    assert!(
        !app.world()
            .get::<ClothConnections>(e)
            .unwrap()
            .crease
            .is_empty()
    );
}

#[test]
fn creases_rewritten_every_frame_on_a_falling_mesh_cloth_stay_finite() {
    // A pinned-centre disc, every default, self-collision on: for 300
    // frames its creases are replaced every frame by 0 to 3 random
    // segments (some through the pin, some far off, some NaN or of no
    // length), then removed: it stays finite and valid, and its links come
    // back exactly.
    let mut app = app();
    let disc = ClothBuilder::from_mesh(&disc_mesh(8, 0.5, 0.5))
        .position(Vec3::Y)
        .pin_where(|rest| rest.length() < 0.01)
        .build()
        .unwrap();
    let original = disc.connections.clone();
    let e = app
        .world_mut()
        .spawn((disc, ClothSelfCollision::default()))
        .id();
    let mut rng = common::Rng::new(7);
    let point = |rng: &mut common::Rng| {
        let p = Vec3::new(rng.signed(), 0.1 * rng.signed(), rng.signed()) * 0.7;
        match rng.below(20) {
            0 => Vec3::NAN,
            1 => Vec3::splat(1e9),
            _ => p,
        }
    };
    for frame in 0..300 {
        let creases = (0..rng.below(4))
            .map(|_| {
                let from = point(&mut rng);
                let to = if rng.below(10) == 0 {
                    from
                } else {
                    point(&mut rng)
                };
                let side =
                    [FoldSide::Free, FoldSide::Mountain, FoldSide::Valley][rng.below(3) as usize];
                Crease::on_rest(from, to)
                    .with_angle(3.0 * rng.unit())
                    .with_side(side)
            })
            .collect();
        app.world_mut().entity_mut(e).insert(ClothCreases(creases));
        app.update();
        let p = particles(&app, e);
        let c = app.world().get::<ClothConnections>(e).unwrap();
        assert!(p.is_finite(), "frame {frame}");
        assert!(bevy_cloth::check_cloth(p, c).is_ok(), "frame {frame}");
    }
    app.world_mut().entity_mut(e).remove::<ClothCreases>();
    app.update();
    let links = app.world().get::<ClothConnections>(e).unwrap();
    assert_eq!(links.bend, original.bend);
    assert_eq!(links.bend_diagonal, original.bend_diagonal);
    assert!(links.crease.is_empty() && links.fold.is_empty());
}
