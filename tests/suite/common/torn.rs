//! What the tearing and editing tests share: a banner, the events seen,
//! and the checks every edit must pass.

use bevy::prelude::*;
use bevy_cloth::plugin::spawn::MeshLayout;
use bevy_cloth::prelude::*;

/// The `ClothTorn` events seen, in order.
#[derive(Resource, Default)]
pub struct Torn(pub Vec<ClothTorn>);

pub fn record_tears(app: &mut App) {
    app.init_resource::<Torn>()
        .add_observer(|torn: On<ClothTorn>, mut seen: ResMut<Torn>| {
            seen.0.push(torn.event().clone())
        });
}

pub fn run(app: &mut App, frames: usize) {
    for _ in 0..frames {
        app.update();
    }
}

/// A banner `n × n`, 1 m square, hanging in the xy plane from its top
/// edge at y = 2 m (row 0 on top).
pub fn banner(n: u32, material: ClothMaterial) -> ClothBundle {
    ClothBuilder::new(n, n)
        .size(1.0, 1.0)
        .material(material)
        .position(Vec3::new(0.0, 1.5, 0.0))
        .rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2))
        .pin_edge(GridEdge::Top)
        .build()
        .unwrap()
}

/// Checks what every tear must keep: the arrays of one length, every link
/// and rendered triangle in range, no triangle with a repeated particle,
/// finite state.
pub fn assert_valid(app: &App, cloth: Entity) {
    let world = app.world();
    let p = world.get::<ClothParticles>(cloth).unwrap();
    let c = world.get::<ClothConnections>(cloth).unwrap();
    let shape = world.get::<Cloth>(cloth).unwrap();
    assert!(p.is_finite(), "non-finite state");
    assert!(bevy_cloth::check_cloth(p, c).is_ok());
    assert_eq!(shape.len(), p.len());
    let forces = world.get::<ClothForces>(cloth).unwrap().0.len();
    assert!(forces == 0 || forces == p.len());
    assert_layout(shape.layout(), p.len());
}

/// The mesh layout of a mesh (or torn) cloth.
pub fn layout_of(app: &App, cloth: Entity) -> MeshLayout {
    let shape = app.world().get::<Cloth>(cloth).unwrap();
    shape.mesh().expect("a mesh cloth").clone()
}

/// A torn cloth's layout holds the mesh rule's links of its own topology
/// (the next tear maps the cloth's links from them).
pub fn assert_rule_links_kept(app: &App, cloth: Entity) {
    let layout = layout_of(app, cloth);
    assert_eq!(layout.rule_links(), &layout.topology().connections());
}

pub fn assert_layout(layout: &MeshLayout, n: usize) {
    let vertices = layout.vertex_particles();
    assert!(vertices.iter().all(|&q| (q as usize) < n));
    assert_eq!(layout.indices().len() % 3, 0);
    for t in layout.indices().chunks_exact(3) {
        assert!(t.iter().all(|&r| (r as usize) < vertices.len()));
        let q = [t[0], t[1], t[2]].map(|r| vertices[r as usize]);
        assert!(q[0] != q[1] && q[1] != q[2] && q[2] != q[0], "{q:?}");
    }
    for t in &layout.topology().triangles {
        assert!(t.iter().all(|&q| (q as usize) < n));
        assert!(t[0] != t[1] && t[1] != t[2] && t[2] != t[0], "{t:?}");
    }
    assert_eq!(layout.uvs().map(<[_]>::len), Some(vertices.len()));
}
