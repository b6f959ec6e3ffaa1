//! Tearing and cutting in an app: a banner torn by a pull at its fabric's
//! strain, a straight cut that drops the lower half, the render mesh split
//! along a cut, and abuse (a thousand random cuts through pins, anchors,
//! grabs and tethers; yanks at 50 m/s; bad thresholds).

use crate::common;

use bevy::prelude::*;
use bevy_cloth::prelude::*;
use common::torn::{
    Torn, assert_rule_links_kept, assert_valid, banner, layout_of, record_tears, run,
};
use common::{Rng, app, app_with_meshes, particles};

/// A soft fabric (200 N/m) that tears at 10 % strain.
const SOFT: Fabric = Fabric {
    stretch: 200.0,
    shear: 200.0,
    tear_strain: 0.1,
    ..Fabric::COTTON
};

#[test]
fn a_banner_pulled_by_its_edges_tears_at_its_fabric_s_strain() {
    let n = 21;
    let mut app = app();
    record_tears(&mut app);
    // Free in space (no gravity, no pins), pulled apart by its top and
    // bottom rows.
    let strip = ClothBuilder::new(n, n)
        .size(1.0, 1.0)
        .material(ClothMaterial::Fabric(SOFT))
        .position(Vec3::new(0.0, 1.5, 0.0))
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .build()
        .unwrap();
    let settings = ClothSettings(SimSettings {
        gravity: Vec3::ZERO,
        ..default()
    });
    let cloth = app
        .world_mut()
        .spawn((strip, settings, ClothTearing::default()))
        .id();
    // A pull that grows by 5 N/s, shared equally by the n particles of
    // each edge row.
    let (top, bottom): (Vec<u32>, Vec<u32>) = ((0..n).collect(), ((n - 1) * n..n * n).collect());
    let mut pull = 0.0;
    let mut at_break = None;
    for _ in 0..60 * 20 {
        pull += 5.0 / 60.0;
        {
            let mut forces = app.world_mut().get_mut::<ClothForces>(cloth).unwrap();
            for (row, dir) in [(&top, Vec3::Y), (&bottom, Vec3::NEG_Y)] {
                for &p in row {
                    forces.add(p as usize, dir * pull / n as f32, (n * n) as usize);
                }
            }
        }
        app.update();
        if !app.world().resource::<Torn>().0.is_empty() {
            at_break = Some(pull);
            break;
        }
    }
    let at_break = at_break.expect("the banner tore");
    // Tension-only links: the banner narrows freely, so each column's
    // chain of links along the pull carries its share alone, and breaks at
    // k·strain·h: n chains break together at n·k·strain·h.
    let h = 1.0 / (n - 1) as f32;
    let expected = n as f32 * SOFT.stretch * SOFT.tear_strain * h;
    let torn = &app.world().resource::<Torn>().0[0];
    println!(
        "broke at {at_break:.2} N (expected {expected:.2} N), links {:?}",
        torn.links
    );
    assert!(
        (at_break - expected).abs() < 0.1 * expected,
        "tore at {at_break} N, expected {expected} N"
    );
    // The links that broke run along the pull.
    for &(a, b) in &torn.links {
        assert_eq!(b - a, n, "({a}, {b}) runs along the pull");
    }
    assert!(!torn.split.is_empty() && torn.links.len() <= 4);
    assert_valid(&app, cloth);
    // Pulled on, the tear runs across the banner within a second and parts
    // it in two pieces that fly apart.
    for _ in 0..60 {
        {
            let mut forces = app.world_mut().get_mut::<ClothForces>(cloth).unwrap();
            let count = forces.0.len().max((n * n) as usize);
            for (row, dir) in [(&top, Vec3::Y), (&bottom, Vec3::NEG_Y)] {
                for &p in row {
                    forces.add(p as usize, dir * pull / n as f32, count);
                }
            }
        }
        app.update();
    }
    assert_valid(&app, cloth);
    let p = particles(&app, cloth);
    let (high, low) = (p.positions[0].y, p.positions[(n * n - 1) as usize].y);
    assert!(
        high - low > 3.0,
        "the two halves fly apart: {high} m and {low} m"
    );
}

#[test]
fn a_straight_cut_drops_the_lower_half_and_splits_the_mesh() {
    // Also with tethers: the fallen half is not held through the gap.
    for tethers in [false, true] {
        let n = 16;
        let mut app = app_with_meshes();
        record_tears(&mut app);
        let cloth = app.world_mut().spawn(banner(n, ClothMaterial::COTTON)).id();
        if tethers {
            app.world_mut()
                .entity_mut(cloth)
                .insert(ClothTethers::default());
        }
        run(&mut app, 90);
        let before = particles(&app, cloth).positions.clone();
        // Across the banner 0.48 m below its top: between rows 7 and 8,
        // nearer row 7, which opens.
        let y = 1.52;
        app.world_mut().write_message(ClothCut::along(
            Some(cloth),
            Vec3::new(-1.0, y, 0.0),
            Vec3::new(1.0, y, 0.0),
            Vec3::Z * 0.5,
        ));
        app.update();
        let torn = app.world().resource::<Torn>().0.clone();
        assert_eq!(torn.len(), 1);
        assert_eq!(
            torn[0].links.len(),
            2 * n as usize - 1,
            "the links the cut crossed"
        );
        let split: Vec<u32> = torn[0].split.iter().map(|s| s.0).collect();
        assert_eq!(split, (7 * n..8 * n).collect::<Vec<_>>(), "row 7 splits");
        assert_valid(&app, cloth);
        // No pop: what still hangs moved less than a millimetre in the
        // step of the cut (the links and coarse correction were rebuilt).
        let after = &particles(&app, cloth).positions;
        let jump = (0..(7 * n) as usize)
            .map(|p| after[p].distance(before[p]))
            .fold(0.0, f32::max);
        assert!(jump < 1e-3, "the hanging half jumped {jump} m");
        // The rendered mesh is rebuilt with the copies.
        let handle = app.world().get::<Mesh3d>(cloth).unwrap().0.clone();
        let mesh = app.world().resource::<Assets<Mesh>>().get(&handle).unwrap();
        assert_eq!(mesh.count_vertices(), (n * n + n) as usize);
        run(&mut app, 60);
        assert_valid(&app, cloth);
        let p = particles(&app, cloth);
        let up = p.positions.iter().filter(|x| x.y > 1.4).count();
        let fallen = p.positions.iter().filter(|x| x.y < 0.5).count();
        assert_eq!(
            (up, fallen),
            (8 * n as usize, 9 * n as usize),
            "tethers {tethers}"
        );
        // What stays up still hangs whole: no link of it is stretched.
        let stats = app.world().get::<ClothStats>(cloth).unwrap();
        assert!(stats.max_strain < 0.05, "strain {}", stats.max_strain);
    }
}

#[test]
fn a_cut_wakes_a_sleeping_cloth() {
    let mut app = app();
    let cloth = app
        .world_mut()
        .spawn(banner(12, ClothMaterial::COTTON))
        .id();
    run(&mut app, 600);
    assert!(
        app.world().get::<ClothSleep>(cloth).unwrap().is_asleep(),
        "the banner fell asleep"
    );
    app.world_mut().write_message(ClothCut::along(
        None,
        Vec3::new(-1.0, 1.3, 0.0),
        Vec3::new(1.0, 1.3, 0.0),
        Vec3::Z,
    ));
    run(&mut app, 30);
    let p = particles(&app, cloth);
    assert!(
        p.positions.iter().any(|x| x.y < 0.5),
        "the cut-off part fell"
    );
}

#[test]
fn a_thousand_random_cuts_through_pins_anchors_grabs_and_tethers_never_break_the_cloth() {
    for (n, frames, seed) in [(3, 1000, 7), (12, 400, 11)] {
        let mut app = app();
        record_tears(&mut app);
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
                ClothTearing::default(),
            ))
            .id();
        app.update();
        common::grab_where_they_are(&mut app, cloth, &[n * n - 1]);
        let mut rng = Rng::new(seed);
        for frame in 0..frames {
            // A random blade through the banner's square, often through the
            // pinned top row, sometimes the same place twice.
            let c = Vec3::new(0.6 * rng.signed(), 1.5 + 0.6 * rng.signed(), 0.0);
            let angle = std::f32::consts::PI * rng.signed();
            let d = Vec3::new(angle.cos(), angle.sin(), 0.0) * (0.1 + 0.5 * rng.unit());
            if frame % 3 != 0 {
                app.world_mut()
                    .write_message(ClothCut::along(None, c - d, c + d, Vec3::Z * 0.3));
            }
            if frame % 50 == 0 {
                app.world_mut()
                    .get_mut::<Transform>(pole)
                    .unwrap()
                    .translation
                    .x += 0.1;
                common::move_grabs(&mut app, cloth, Vec3::new(0.0, -0.05, 0.05));
            }
            app.update();
            assert_valid(&app, cloth);
        }
        let torn = app.world().resource::<Torn>().0.len();
        let p = particles(&app, cloth);
        println!("{n}×{n}: {torn} tears, {} particles", p.len());
        assert!(torn > 5 && p.len() > (n * n) as usize);
        if n == 3 {
            // Cut until nothing joins its 8 triangles: 24 particles.
            assert_eq!(p.len(), 24);
        }
        // The anchor carries every copy of its particle.
        let anchors = app.world().get::<ClothAnchors>(cloth).unwrap();
        assert!(anchors.0.iter().all(|a| (a.particle as usize) < p.len()));
        assert_rule_links_kept(&app, cloth);
    }
}

#[test]
fn a_banner_diced_into_scraps_keeps_stepping_every_scrap() {
    // 16×16: a mesh cloth once torn, with its coarse correction on; diced
    // along every line between its rows and columns, its scraps no longer
    // aggregate, and the correction's last level takes a sweep.
    let n = 16;
    let mut app = app();
    let cloth = app.world_mut().spawn(banner(n, ClothMaterial::COTTON)).id();
    app.update();
    let spacing = 1.0 / (n - 1) as f32;
    for k in 0..n - 1 {
        let at = (k as f32 + 0.5) * spacing;
        for (from, to) in [
            (Vec3::new(at - 0.5, 2.5, 0.0), Vec3::new(at - 0.5, 0.5, 0.0)),
            (
                Vec3::new(-1.0, 2.0 - at, 0.0),
                Vec3::new(1.0, 2.0 - at, 0.0),
            ),
        ] {
            app.world_mut()
                .write_message(ClothCut::along(Some(cloth), from, to, Vec3::Z * 0.5));
        }
    }
    app.update();
    assert_valid(&app, cloth);
    let n_particles = particles(&app, cloth).len();
    let links = app.world().get::<ClothConnections>(cloth).unwrap();
    let piece = links.pieces(n_particles);
    let count = piece.iter().max().map_or(0, |&m| m as usize + 1);
    assert!(count >= (n * n / 2) as usize, "{count} pieces");
    for _ in 0..120 {
        app.update();
        assert_valid(&app, cloth);
    }
    // Two seconds of falling (against the fabric's damping) from 1–2 m:
    // every scrap without a pin is 3 m or more below where it started; the
    // pinned row and what hangs from it stay up.
    let p = particles(&app, cloth);
    assert!(p.len() > (n * n) as usize);
    // The pieces with a pin.
    let mut pinned = vec![false; count];
    for (&k, &w) in piece.iter().zip(&p.inverse_masses) {
        pinned[k as usize] |= w == 0.0;
    }
    let mut fell = 0;
    for (i, x) in p.positions.iter().enumerate() {
        if pinned[piece[i] as usize] {
            assert!(x.y > 1.5, "a held particle at {x}");
        } else {
            assert!(x.y < -2.0, "a scrap at {x}");
            fell += 1;
        }
    }
    assert!(fell >= (n * n / 2) as usize, "{fell} fell");
}

#[test]
fn a_banner_yanked_at_50_m_s_with_the_default_tearing_rips_and_stays_finite() {
    let mut app = app();
    record_tears(&mut app);
    let n = 24;
    let cloth = app
        .world_mut()
        .spawn((banner(n, ClothMaterial::COTTON), ClothTearing::default()))
        .id();
    run(&mut app, 30);
    let corner = n * n - 1;
    common::grab_where_they_are(&mut app, cloth, &[corner]);
    // 50 m/s down and out for 0.2 s, then let go.
    for _ in 0..12 {
        common::move_grabs(
            &mut app,
            cloth,
            Vec3::new(0.5, -0.6, 0.3) * (50.0 / 60.0 / 0.84),
        );
        app.update();
        assert_valid(&app, cloth);
    }
    app.world_mut()
        .get_mut::<ClothGrabs>(cloth)
        .unwrap()
        .release(corner);
    run(&mut app, 180);
    assert_valid(&app, cloth);
    assert!(
        !app.world().resource::<Torn>().0.is_empty(),
        "the yank tore it"
    );
    // Whatever still holds together is under the tear strain.
    let stats = app.world().get::<ClothStats>(cloth).unwrap();
    assert!(stats.max_strain < 0.15, "strain {}", stats.max_strain);
}

#[test]
fn bad_thresholds_are_refused_and_a_bad_component_only_warns() {
    for bad in [0.0, -0.1, f32::NAN, f32::INFINITY] {
        assert!(ClothTearing::default().with_strain(bad).is_err());
        assert!(ClothTearing::default().with_force(bad).is_err());
    }
    let bad_fabric = ClothMaterial::Fabric(Fabric {
        tear_strain: f32::NAN,
        ..Fabric::COTTON
    });
    assert!(bad_fabric.validate().is_err());
    // Written straight into the component: the cloth steps on untorn.
    let mut app = app();
    record_tears(&mut app);
    let cloth = app
        .world_mut()
        .spawn((
            banner(8, ClothMaterial::COTTON),
            ClothTearing {
                strain: Some(f32::NAN),
                ..default()
            },
        ))
        .id();
    run(&mut app, 5);
    common::grab_where_they_are(&mut app, cloth, &[63]);
    common::move_grabs(&mut app, cloth, Vec3::NEG_Y);
    run(&mut app, 30);
    assert!(app.world().resource::<Torn>().0.is_empty());
    assert_valid(&app, cloth);
}

#[test]
fn a_creased_sheet_cut_across_its_crease_keeps_the_crease_on_each_side() {
    use bevy_cloth::sim::crease::Crease;
    let mut app = app();
    record_tears(&mut app);
    // A flat 15×15 sheet creased along its middle column, in the xz plane.
    let sheet = ClothBuilder::new(15, 15)
        .size(1.0, 1.0)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin_corner(GridCorner::TopLeft)
        .build()
        .unwrap();
    let crease = Crease::new(Vec2::new(0.5, -0.1), Vec2::new(0.5, 1.1));
    let cloth = app
        .world_mut()
        .spawn((sheet, ClothCreases(vec![crease])))
        .id();
    run(&mut app, 60);
    let before = app
        .world()
        .get::<ClothConnections>(cloth)
        .unwrap()
        .crease
        .len();
    assert!(before > 0);
    // Cut across the crease, along x through the middle of the sheet.
    let x = particles(&app, cloth).positions.clone();
    let centre = x.iter().sum::<Vec3>() / x.len() as f32;
    app.world_mut().write_message(ClothCut::along(
        None,
        centre - Vec3::X,
        centre + Vec3::X,
        Vec3::Y * 0.5,
    ));
    run(&mut app, 60);
    assert_eq!(app.world().resource::<Torn>().0.len(), 1);
    assert_valid(&app, cloth);
    // The crease ends at the cut: its links across the cut are gone, the
    // rest stay.
    let after = app
        .world()
        .get::<ClothConnections>(cloth)
        .unwrap()
        .crease
        .len();
    assert!(
        after > 0 && after < before,
        "{after} of {before} crease links"
    );
    // Removed, the crease gives back every rest length it changed, on
    // both pieces: each Type 2 link rests at its ends' rest distance.
    app.world_mut().entity_mut(cloth).remove::<ClothCreases>();
    run(&mut app, 10);
    assert_valid(&app, cloth);
    let world = app.world();
    let rest = &world
        .get::<Cloth>(cloth)
        .unwrap()
        .mesh()
        .unwrap()
        .topology()
        .positions;
    let links = world.get::<ClothConnections>(cloth).unwrap();
    assert!(links.crease.is_empty());
    for l in links.type2() {
        let want = rest[l.a as usize].distance(rest[l.b as usize]);
        assert!(
            (l.rest_length - want).abs() < 1e-5,
            "{}–{} rests at {} m, its ends {want} m apart",
            l.a,
            l.b,
            l.rest_length
        );
    }
}

#[test]
fn a_mesh_cloth_with_self_collision_is_cut_in_two_and_keeps_its_uvs() {
    let mut app = app();
    record_tears(&mut app);
    let disc = bevy_cloth::plugin::spawn::disc_mesh(0.5, 10);
    let shape = ClothBuilder::from_mesh(&disc)
        .position(Vec3::new(0.0, 1.0, 0.0))
        .pin_where(|p| p.x < -0.45)
        .build()
        .unwrap();
    let cloth = app
        .world_mut()
        .spawn((
            shape,
            ClothSelfCollision::default(),
            ClothTearing::default(),
        ))
        .id();
    run(&mut app, 10);
    let layout = layout_of(&app, cloth);
    let uv_of: std::collections::HashMap<u32, [f32; 2]> = layout
        .vertex_particles()
        .iter()
        .zip(layout.uvs().unwrap())
        .map(|(&p, &uv)| (p, uv))
        .collect();
    let n = particles(&app, cloth).len();
    // A vertical blade across the disc at x = 0.1.
    app.world_mut().write_message(ClothCut::quad(
        Some(cloth),
        [
            Vec3::new(0.1, -1.0, -1.0),
            Vec3::new(0.1, -1.0, 1.0),
            Vec3::new(0.1, 3.0, 1.0),
            Vec3::new(0.1, 3.0, -1.0),
        ],
    ));
    run(&mut app, 90);
    assert_valid(&app, cloth);
    let torn = app.world().resource::<Torn>().0.clone();
    assert!(!torn.is_empty());
    let layout = layout_of(&app, cloth);
    // Each rendered vertex keeps its particle's UV: a copy its original's.
    let origin = |p: u32| {
        torn.iter()
            .flat_map(|t| &t.split)
            .find(|s| s.1 == p)
            .map_or(p, |s| s.0)
    };
    for (&p, uv) in layout.vertex_particles().iter().zip(layout.uvs().unwrap()) {
        assert_eq!(Some(uv), uv_of.get(&origin(p)), "particle {p}");
    }
    // The part beyond the cut fell; the pinned side still hangs.
    let p = particles(&app, cloth);
    assert!(p.len() > n);
    let fallen = (0..p.len()).filter(|&i| p.positions[i].y < 0.0).count();
    assert!(fallen > n / 4, "{fallen} of {} fell", p.len());
    assert!(p.positions.iter().filter(|x| x.x < -0.3).all(|x| x.y > 0.0));
}

#[test]
fn a_worn_ribbon_cut_across_lets_its_free_end_fall_and_keeps_its_skin() {
    let mut app = app();
    record_tears(&mut app);
    let (_, _, cloth) = common::wear(&mut app, 0.0);
    run(&mut app, 30);
    let n = particles(&app, cloth).len();
    // Across the ribbon between its rows at y = 1.1 m and 1.0 m.
    app.world_mut().write_message(ClothCut::along(
        Some(cloth),
        Vec3::new(-1.0, 1.04, -0.1),
        Vec3::new(1.0, 1.04, -0.1),
        Vec3::Z * 0.5,
    ));
    run(&mut app, 60);
    assert_valid(&app, cloth);
    assert_eq!(app.world().resource::<Torn>().0.len(), 1);
    let p = particles(&app, cloth);
    assert!(p.len() > n);
    let skin = app.world().get::<ClothSkin>(cloth).unwrap();
    assert_eq!(
        (skin.rest.len(), skin.influences.len(), skin.freedom.len()),
        (p.len(), p.len(), p.len())
    );
    // The skinned top stays on the body; the free end below the cut fell.
    assert!(p.positions.iter().any(|x| x.y > 1.5));
    assert!(
        p.positions.iter().any(|x| x.y < 0.5),
        "the cut-off end fell"
    );
}

#[test]
fn a_press_next_to_a_cut_picks_the_piece_it_hits() {
    use bevy_cloth::plugin::interaction::{nearest, nearest_on_surface};
    let n = 16;
    let mut app = app();
    record_tears(&mut app);
    let cloth = app.world_mut().spawn(banner(n, ClothMaterial::COTTON)).id();
    run(&mut app, 90);
    app.world_mut().write_message(ClothCut::along(
        Some(cloth),
        Vec3::new(-1.0, 1.52, 0.0),
        Vec3::new(1.0, 1.52, 0.0),
        Vec3::Z * 0.5,
    ));
    app.update();
    let split = app.world().resource::<Torn>().0[0].split.clone();
    let on_crack: Vec<u32> = split.iter().flat_map(|&(o, c)| [o, c]).collect();
    let world = app.world();
    let (shape, p) = (
        world.get::<Cloth>(cloth).unwrap(),
        world.get::<ClothParticles>(cloth).unwrap(),
    );
    let links = world.get::<ClothConnections>(cloth).unwrap();
    // A point a quarter of the way from a crack particle to a neighbour
    // off the crack: on that particle's piece.
    let beside = |q: u32| {
        let next = links
            .structural
            .iter()
            .find_map(|l| match (l.a == q, l.b == q) {
                (true, _) if !on_crack.contains(&l.b) => Some(l.b),
                (_, true) if !on_crack.contains(&l.a) => Some(l.a),
                _ => None,
            })
            .expect("a neighbour off the crack");
        let x = &p.positions;
        x[q as usize].lerp(x[next as usize], 0.25)
    };
    let mut confused = 0;
    for &(original, copy) in &split {
        let (a, b) = (beside(original), beside(copy));
        assert_eq!(nearest_on_surface(shape, p, a), Some(original));
        assert_eq!(nearest_on_surface(shape, p, b), Some(copy));
        // The nearest particle alone cannot tell the two pieces apart:
        // the original and its copy stand at one place.
        if nearest(p, a) == nearest(p, b) {
            confused += 1;
        }
    }
    assert_eq!(confused, split.len());
}
