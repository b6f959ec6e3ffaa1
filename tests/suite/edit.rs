//! Topology edits by game code in an app: links and particles opened by
//! index (`ClothCut::links`, `ClothCut::split`) and seams (`ClothSew`),
//! with abuse (random edits, bad requests).

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::torn::{Torn, assert_rule_links_kept, assert_valid, banner, record_tears, run};
use common::{Rng, app, app_with_meshes, particles};

/// Whether `connections` link `a` and `b` by any link.
fn linked(connections: &ClothConnections, a: u32, b: u32) -> bool {
    [
        &connections.structural,
        &connections.shear,
        &connections.bend,
        &connections.bend_diagonal,
    ]
    .iter()
    .flat_map(|family| family.iter())
    .any(|l| (l.a, l.b) == (a, b) || (l.a, l.b) == (b, a))
}

#[test]
fn links_and_particles_named_by_index_open_the_cloth_there() {
    let n = 8;
    let mut app = app_with_meshes();
    record_tears(&mut app);
    let cloth = app.world_mut().spawn(banner(n, ClothMaterial::COTTON)).id();
    run(&mut app, 30);
    // Requests that name nothing: no cloth, pairs that are not links,
    // particles out of range, normals that are no direction.
    let messages = [
        ClothCut {
            links: vec![(0, 1)],
            splits: vec![(3, Vec3::X)],
            ..default()
        },
        ClothCut::links(cloth, [(0, n * n - 1), (999, 1000), (5, 5), (u32::MAX, 0)]),
        ClothCut {
            cloth: Some(cloth),
            splits: vec![(999, Vec3::X), (10, Vec3::NAN), (10, Vec3::ZERO)],
            ..default()
        },
    ];
    for m in messages {
        app.world_mut().write_message(m);
    }
    app.update();
    assert!(app.world().resource::<Torn>().0.is_empty());
    assert_eq!(particles(&app, cloth).len(), (n * n) as usize);
    assert!(app.world().get::<Cloth>(cloth).unwrap().grid().is_some());
    // A buttonhole: one particle split by a vertical plane; the cloth opens
    // above and below it, and nothing bends across the opening.
    let p = 3 * n + 3;
    let links = |app: &App| app.world().get::<ClothConnections>(cloth).unwrap().clone();
    assert!(linked(&links(&app), p - 1, p + 1));
    app.world_mut()
        .write_message(ClothCut::split(cloth, p, Vec3::X));
    app.update();
    let torn = app.world().resource::<Torn>().0.clone();
    assert_eq!(torn.len(), 1);
    assert_eq!(torn[0].split, vec![(p, n * n)]);
    assert_eq!(particles(&app, cloth).len(), (n * n + 1) as usize);
    assert!(
        !linked(&links(&app), p - 1, p + 1),
        "a bend across the hole"
    );
    assert!(app.world().get::<Cloth>(cloth).unwrap().grid().is_none());
    assert_valid(&app, cloth);
    // A seam unpicked: every Type 1 link between rows 5 and 6.
    let row = |q: u32| (q < n * n).then_some(q / n);
    let seam: Vec<(u32, u32)> = links(&app)
        .type1()
        .map(|l| (l.a.min(l.b), l.a.max(l.b)))
        .filter(|&(a, b)| row(a) == Some(5) && row(b) == Some(6))
        .collect();
    assert!(seam.len() >= n as usize);
    app.world_mut()
        .write_message(ClothCut::links(cloth, seam.iter().map(|&(a, b)| (b, a))));
    app.update();
    let torn = app.world().resource::<Torn>().0.clone();
    assert_eq!(torn.len(), 2);
    assert!(seam.iter().all(|pair| torn[1].links.contains(pair)));
    run(&mut app, 60);
    assert_valid(&app, cloth);
    let x = &particles(&app, cloth).positions;
    let fallen = x.iter().filter(|x| x.y < 0.5).count();
    let up = x.iter().filter(|x| x.y > 1.2).count();
    assert!(
        fallen >= 2 * n as usize && up >= 6 * n as usize,
        "{fallen} fell, {up} hang"
    );
}

#[test]
fn random_links_and_splits_by_index_never_break_the_cloth() {
    let n = 5;
    let mut app = app();
    record_tears(&mut app);
    let cloth = app
        .world_mut()
        .spawn((banner(n, ClothMaterial::COTTON), ClothTethers::default()))
        .id();
    app.update();
    let mut rng = Rng::new(23);
    for frame in 0..600 {
        let count = particles(&app, cloth).len() as u32;
        let any = |rng: &mut Rng| (rng.unit() * (count + 3) as f32) as u32;
        let message = if frame % 2 == 0 {
            // Mostly links of the cloth, sometimes any pair at all.
            let links = app.world().get::<ClothConnections>(cloth).unwrap();
            let type1: Vec<(u32, u32)> = links.type1().map(|l| (l.a, l.b)).collect();
            let pair = match type1.len() {
                0 => (any(&mut rng), any(&mut rng)),
                len if frame % 6 != 0 => type1[(rng.unit() * len as f32) as usize % len],
                _ => (any(&mut rng), any(&mut rng)),
            };
            ClothCut::links(cloth, [pair])
        } else {
            let normal = match frame % 7 {
                0 => Vec3::NAN,
                1 => Vec3::ZERO,
                _ => Vec3::new(rng.signed(), rng.signed(), rng.signed()),
            };
            ClothCut::split(cloth, any(&mut rng), normal)
        };
        app.world_mut().write_message(message);
        app.update();
        assert_valid(&app, cloth);
    }
    let p = particles(&app, cloth);
    assert!(p.len() > (n * n) as usize && app.world().resource::<Torn>().0.len() > 20);
    assert_rule_links_kept(&app, cloth);
}

/// The `ClothSewn` events seen, in order.
#[derive(Resource, Default)]
struct Sewn(Vec<ClothSewn>);

fn record_seams(app: &mut App) {
    app.init_resource::<Sewn>()
        .add_observer(|sewn: On<ClothSewn>, mut seen: ResMut<Sewn>| {
            seen.0.push(sewn.event().clone())
        });
}

#[test]
fn a_banner_cut_in_two_and_sewn_back_hangs_whole_again() {
    let n = 12;
    let mut app = app_with_meshes();
    record_tears(&mut app);
    record_seams(&mut app);
    let cloth = app.world_mut().spawn(banner(n, ClothMaterial::COTTON)).id();
    run(&mut app, 60);
    let whole = app.world().get::<Cloth>(cloth).unwrap().layout().clone();
    let y = 1.52;
    app.world_mut().write_message(ClothCut::along(
        Some(cloth),
        Vec3::new(-1.0, y, 0.0),
        Vec3::new(1.0, y, 0.0),
        Vec3::Z * 0.5,
    ));
    app.update();
    let torn = app.world().resource::<Torn>().0[0].clone();
    assert_eq!(particles(&app, cloth).len(), (n * n + n) as usize);
    let before = particles(&app, cloth).positions.clone();
    // Every copy sewn back onto its particle, one frame later.
    app.world_mut().write_message(ClothSew {
        cloth,
        pairs: torn.split.clone(),
    });
    app.update();
    let sewn = app.world().resource::<Sewn>().0.clone();
    assert_eq!(sewn.len(), 1);
    let map = &sewn[0].map;
    assert_eq!(map.len(), (n * n + n) as usize);
    assert!(
        torn.split
            .iter()
            .all(|&(p, copy)| map[copy as usize] == map[p as usize])
    );
    assert_eq!(particles(&app, cloth).len(), (n * n) as usize);
    assert_valid(&app, cloth);
    let shape = app.world().get::<Cloth>(cloth).unwrap();
    assert_eq!(
        shape.layout().topology(),
        whole.topology(),
        "the grid's triangles again"
    );
    assert!(shape.grid().is_none(), "a sewn grid is a mesh cloth");
    // No pop: the seam's particles met where they were, within the fall of
    // the lower half over the one frame it was free.
    let after = &particles(&app, cloth).positions;
    let jump = (0..(n * n) as usize)
        .map(|p| after[p].distance(before[p]))
        .fold(0.0, f32::max);
    assert!(jump < 0.01, "a particle jumped {jump} m");
    run(&mut app, 120);
    assert_valid(&app, cloth);
    let p = particles(&app, cloth);
    let lowest = p
        .positions
        .iter()
        .map(|x| x.y)
        .fold(f32::INFINITY, f32::min);
    assert!(lowest > 0.9, "the lower half fell to {lowest} m");
    let stats = app.world().get::<ClothStats>(cloth).unwrap();
    assert!(stats.max_strain < 0.05, "strain {}", stats.max_strain);
}

#[test]
fn a_seam_carries_grabs_and_anchors_and_keeps_the_mass() {
    let n = 6;
    let mut app = app();
    record_seams(&mut app);
    let pole = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 2.0, 0.0))
        .id();
    let cloth = app
        .world_mut()
        .spawn((
            banner(n, ClothMaterial::COTTON),
            ClothAnchors::default().with(n * n - 1, pole),
        ))
        .id();
    run(&mut app, 10);
    common::grab_where_they_are(&mut app, cloth, &[n * n - 2]);
    run(&mut app, 2);
    let mass = |app: &App| particles(app, cloth).masses.iter().sum::<f32>();
    let (m0, count) = (mass(&app), particles(&app, cloth).len());
    // Two free neighbours in the middle rows, and a chain onto particle 8.
    let pairs = vec![(2 * n + 2, 2 * n + 3), (3 * n + 2, 2 * n + 2), (9, 8)];
    let joined = [2 * n + 2, 2 * n + 3, 3 * n + 2].map(|q| q as usize);
    app.world_mut().write_message(ClothSew { cloth, pairs });
    app.update();
    let map = app.world().resource::<Sewn>().0[0].map.clone();
    let after = particles(&app, cloth).clone();
    assert_eq!(after.len(), count - 3);
    assert!((mass(&app) - m0).abs() < 1e-5 * m0, "mass kept");
    assert_eq!(map[joined[1]], map[joined[0]]);
    assert_eq!(map[joined[2]], map[joined[0]]);
    // The grab and the anchor follow their particles' new indices.
    let grabs = app.world().get::<ClothGrabs>(cloth).unwrap();
    assert_eq!(grabs.grabs()[0].particle, map[(n * n - 2) as usize]);
    let anchors = app.world().get::<ClothAnchors>(cloth).unwrap();
    assert_eq!(anchors.anchors()[0].particle, map[(n * n - 1) as usize]);
    assert!(after.is_pinned(map[(n * n - 1) as usize] as usize));
    assert!(after.is_pinned(map[(n * n - 2) as usize] as usize));
    assert_valid(&app, cloth);
    run(&mut app, 30);
    assert_valid(&app, cloth);
}

#[test]
fn random_seams_and_cuts_never_break_the_cloth() {
    for (n, seed) in [(4, 5), (8, 9)] {
        let mut app = app();
        record_tears(&mut app);
        record_seams(&mut app);
        let pole = app
            .world_mut()
            .spawn(Transform::from_xyz(0.0, 2.0, 0.0))
            .id();
        let cloth = app
            .world_mut()
            .spawn((
                banner(n, ClothMaterial::COTTON),
                ClothAnchors::default().with(n - 1, pole),
                ClothTethers::default(),
                ClothSelfCollision::default(),
                ClothToClothCollision::default(),
            ))
            .id();
        // A sheet below that the pieces fall onto.
        let sheet = ClothBuilder::new(6, 6)
            .size(1.6, 1.6)
            .position(Vec3::new(0.0, 0.8, 0.0))
            .pin_corner(GridCorner::TopLeft)
            .pin_corner(GridCorner::TopRight)
            .pin_corner(GridCorner::BottomLeft)
            .pin_corner(GridCorner::BottomRight)
            .build()
            .unwrap();
        let sheet = app
            .world_mut()
            .spawn((sheet, ClothToClothCollision::default()))
            .id();
        app.update();
        common::grab_where_they_are(&mut app, cloth, &[n * n - 1]);
        let mut rng = Rng::new(seed);
        for frame in 0..500 {
            let count = particles(&app, cloth).len() as u32;
            let any = |rng: &mut Rng| (rng.unit() * (count + 2) as f32) as u32;
            match frame % 4 {
                0 => {
                    let c = Vec3::new(0.6 * rng.signed(), 1.5 + 0.6 * rng.signed(), 0.0);
                    let d = Vec3::new(rng.signed(), rng.signed(), 0.0) * 0.5;
                    app.world_mut().write_message(ClothCut::along(
                        Some(cloth),
                        c - d,
                        c + d,
                        Vec3::Z * 0.3,
                    ));
                }
                2 => {
                    // Mostly half of the last tear mended; sometimes any
                    // pair at all; always a particle with itself and one
                    // out of range.
                    let torn = app.world().resource::<Torn>().0.last().cloned();
                    let a = any(&mut rng);
                    let mut pairs = vec![(a, a), (a, u32::MAX)];
                    match torn {
                        Some(t) if frame % 40 != 2 => {
                            pairs.extend(t.split.iter().copied().filter(|_| rng.unit() < 0.5));
                        }
                        _ => pairs.push((a, any(&mut rng))),
                    }
                    app.world_mut().write_message(ClothSew { cloth, pairs });
                }
                _ => {}
            }
            app.update();
            assert_valid(&app, cloth);
            assert!(particles(&app, sheet).is_finite());
        }
        let seams = app.world().resource::<Sewn>().0.len();
        let tears = app.world().resource::<Torn>().0.len();
        println!(
            "{n}×{n}: {seams} seams, {tears} tears, {} particles",
            particles(&app, cloth).len()
        );
        assert!(seams > 20 && tears > 20, "{seams} seams, {tears} tears");
        assert_rule_links_kept(&app, cloth);
    }
    // Everything sewn into one particle: a cloth of one particle and no
    // triangle keeps stepping.
    let mut app = app();
    let cloth = app.world_mut().spawn(banner(4, ClothMaterial::COTTON)).id();
    app.update();
    let pairs = (1..16).map(|p| (0, p)).collect();
    app.world_mut().write_message(ClothSew { cloth, pairs });
    run(&mut app, 10);
    assert_eq!(particles(&app, cloth).len(), 1);
    assert_valid(&app, cloth);
}
