//! A cloth from a glTF file: `assets/pennant.gltf`, written by
//! `assets/make_pennant.py`, loaded by Bevy's glTF loader with its custom
//! `_PIN` attribute mapped to `ATTRIBUTE_PIN`, built and hung in wind.

use crate::common;

use bevy::gltf::{GltfAssetLabel, GltfPlugin};
use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use bevy_cloth::prelude::*;
use bevy_cloth::sim::connections::max_strain;

/// The pennant's first primitive, loaded headless.
fn load_pennant() -> Mesh {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: concat!(env!("CARGO_MANIFEST_DIR"), "/assets").into(),
            ..default()
        },
        bevy::image::ImagePlugin::default(),
        bevy::mesh::MeshPlugin,
        bevy::world_serialization::WorldSerializationPlugin,
        // The file's `_PIN`: Bevy's loader matches custom attributes by
        // their name without the leading underscore.
        GltfPlugin::default().add_custom_vertex_attribute("PIN", ATTRIBUTE_PIN),
    ));
    app.finish();
    app.cleanup();
    let handle: Handle<Mesh> = app.world().resource::<AssetServer>().load(
        GltfAssetLabel::Primitive {
            mesh: 0,
            primitive: 0,
        }
        .from_asset("pennant.gltf"),
    );
    for _ in 0..2000 {
        app.update();
        if let Some(mesh) = app.world().resource::<Assets<Mesh>>().get(&handle) {
            return mesh.clone();
        }
        let server = app.world().resource::<AssetServer>();
        if let Some(bevy::asset::LoadState::Failed(e)) = server.get_load_state(&handle) {
            panic!("pennant.gltf failed to load: {e}");
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    panic!("pennant.gltf did not load");
}

#[test]
fn a_pennant_from_gltf_becomes_a_cloth_pinned_where_it_was_painted() {
    let mesh = load_pennant();
    // What the script wrote: 174 vertices, 286 triangles, 13 on the hoist;
    // a triangle 1.2 m long with a 0.6 m hoist in the xy plane.
    assert_eq!(mesh.count_vertices(), 174);
    assert_eq!(mesh.indices().unwrap().len(), 3 * 286);
    let Some(VertexAttributeValues::Float32x3(x)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("positions")
    };
    for p in x {
        let half = 0.3 * (1.0 - p[0] / 1.2);
        assert!(p[2] == 0.0 && (0.0..=1.2001).contains(&p[0]) && p[1].abs() <= half + 1e-5);
    }
    let cloth = ClothBuilder::from_mesh(&mesh)
        .pin_attribute(ATTRIBUTE_PIN.name)
        .position(Vec3::new(0.0, 2.0, 0.0))
        .build()
        .unwrap();
    let pins: Vec<usize> = (0..cloth.particles.len())
        .filter(|&p| cloth.particles.is_pinned(p))
        .collect();
    assert_eq!((cloth.particles.len(), pins.len()), (174, 13));
    assert!(pins.iter().all(|&p| cloth.particles.positions[p].x == 0.0));
    let layout = cloth.cloth.mesh().expect("a mesh cloth");
    assert!((layout.area() - 0.5 * 1.2 * 0.6).abs() < 1e-4);
    assert_eq!(
        layout.uvs().map(<[_]>::len),
        Some(174),
        "the glTF's UVs are kept"
    );
    // Hung from its hoist in a gusty breeze, it flies and stays whole.
    let mut app = common::app();
    app.insert_resource(ClothWind(Wind {
        velocity: Vec3::new(6.0, 0.0, 2.0),
        gust_amplitude: 0.5,
        ..default()
    }));
    let e = app.world_mut().spawn(cloth).id();
    for _ in 0..300 {
        app.update();
    }
    let p = common::particles(&app, e);
    let links = app.world().get::<ClothConnections>(e).unwrap();
    let strain = max_strain(links.type1(), &p.positions);
    assert!(p.is_finite() && strain < 0.05, "strain {strain}");
    let tip = p.positions.iter().map(|x| x.x).fold(f32::MIN, f32::max);
    assert!(
        tip > 0.8,
        "the pennant flies downwind: its tip at x = {tip} m"
    );
}
