//! Pick and pull with the mouse (feature `picking`): press on a cloth to
//! grab the particle nearest the hit, drag to carry it along the cursor ray
//! at the grab's depth, release to let go; the secondary button pins or
//! unpins the nearest particle. Built on [`ClothGrabs`], so game code sees
//! the player's grabs like its own.
//!
//! Needs Bevy's `MeshPickingPlugin`, which [`ClothPlugin`](crate::ClothPlugin)
//! adds when the app has picking but no mesh backend. A UI that takes part
//! in picking (bevy_egui with its `picking` feature) sits in front of the
//! cloth, so pointer events over a panel never reach it.
//!
//! A camera controller should leave the mouse alone while it pulls a
//! cloth (or works a panel); [`ClothPointer`] says when:
//!
//! ```
//! # use bevy::prelude::*;
//! # use bevy_cloth::prelude::*;
//! /// Stands in for an orbit camera's controller.
//! #[derive(Component)]
//! struct Orbit {
//!     enabled: bool,
//! }
//!
//! fn orbit_unless_on_cloth(pointer: ClothPointer, mut cameras: Query<&mut Orbit>) {
//!     for mut orbit in &mut cameras {
//!         orbit.enabled = !pointer.busy();
//!     }
//! }
//! ```

use bevy::ecs::system::SystemParam;
use bevy::picking::backend::ray::{RayId, RayMap};
use bevy::picking::events::{Drag, DragEnd, Pointer, Press, Release};
use bevy::picking::hover::HoverMap;
use bevy::picking::pointer::{PointerButton, PointerId};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use crate::plugin::components::ClothParticles;
use crate::plugin::interaction::{ClothGrabs, GrabMode, nearest};

/// How the pointer acts on cloths.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct ClothPicking {
    /// Whether the pointer grabs and pins at all.
    pub enabled: bool,
    /// How a grabbed particle follows the cursor.
    pub mode: GrabMode,
}

impl Default for ClothPicking {
    fn default() -> Self {
        Self {
            enabled: true,
            mode: GrabMode::Kinematic,
        }
    }
}

/// The grab each pointer holds: cloth, particle, camera, depth along the
/// camera ray (m).
#[derive(Resource, Clone, Debug, Default)]
pub struct PointerGrabs(pub HashMap<PointerId, (Entity, u32, Entity, f32)>);

impl PointerGrabs {
    /// Whether any pointer holds a particle (an orbit camera should then
    /// leave the mouse alone).
    pub fn active(&self) -> bool {
        !self.0.is_empty()
    }
}

/// Whether the mouse is busy with a cloth: over one (a press there grabs
/// it) or holding a particle; with the `egui` feature, also whether an egui
/// panel has it. A system parameter for camera controllers.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// #[derive(Component)]
/// struct MyOrbitCamera {
///     enabled: bool,
/// }
///
/// fn orbit_unless_on_cloth(pointer: ClothPointer, mut cameras: Query<&mut MyOrbitCamera>) {
///     for mut camera in &mut cameras {
///         camera.enabled = !pointer.busy();
///     }
/// }
/// ```
#[derive(SystemParam)]
pub struct ClothPointer<'w, 's> {
    hovers: Option<Res<'w, HoverMap>>,
    held: Res<'w, PointerGrabs>,
    cloths: Query<'w, 's, (), With<crate::plugin::components::Cloth>>,
    #[cfg(feature = "egui")]
    egui: Option<Res<'w, bevy_egui::input::EguiWantsInput>>,
}

impl ClothPointer<'_, '_> {
    /// Whether a camera should leave the mouse alone: [`Self::on_cloth`],
    /// or (feature `egui`) an egui panel is under or using the pointer.
    pub fn busy(&self) -> bool {
        #[cfg(feature = "egui")]
        if self
            .egui
            .as_ref()
            .is_some_and(|e| e.wants_pointer_input() || e.is_pointer_over_area())
        {
            return true;
        }
        self.on_cloth()
    }

    /// Whether a pointer holds a particle or hovers over a cloth.
    pub fn on_cloth(&self) -> bool {
        self.held.active()
            || self.hovers.as_ref().is_some_and(|hovers| {
                hovers
                    .values()
                    .flat_map(|hits| hits.keys())
                    .any(|e| self.cloths.contains(*e))
            })
    }
}

pub(crate) fn configure(app: &mut App) {
    app.init_resource::<ClothPicking>()
        .init_resource::<PointerGrabs>()
        .register_type::<ClothPicking>()
        .add_observer(press)
        .add_observer(drag)
        .add_observer(release)
        .add_observer(drag_end);
}

fn press(
    event: On<Pointer<Press>>,
    settings: Res<ClothPicking>,
    mut held: ResMut<PointerGrabs>,
    mut cloths: Query<(&mut ClothParticles, &mut ClothGrabs)>,
) {
    let cloth = event.entity;
    let (Ok((mut particles, mut grabs)), Some(hit)) =
        (cloths.get_mut(cloth), event.event.hit.position)
    else {
        return;
    };
    if !settings.enabled {
        return;
    }
    let Some(p) = nearest(&particles, hit) else {
        return;
    };
    match event.event.button {
        PointerButton::Primary => {
            let at = particles.positions[p as usize];
            grabs.grab(p, at, settings.mode);
            held.0.insert(
                event.pointer_id,
                (cloth, p, event.event.hit.camera, event.event.hit.depth),
            );
        }
        PointerButton::Secondary => {
            let i = p as usize;
            if particles.is_pinned(i) {
                particles.unpin(i);
            } else {
                particles.pin(i);
            }
        }
        PointerButton::Middle => {}
    }
}

fn drag(
    event: On<Pointer<Drag>>,
    rays: Res<RayMap>,
    held: Res<PointerGrabs>,
    mut cloths: Query<&mut ClothGrabs>,
) {
    let Some(&(cloth, particle, camera, depth)) = held.0.get(&event.pointer_id) else {
        return;
    };
    let Some(ray) = rays.map.get(&RayId::new(camera, event.pointer_id)) else {
        return;
    };
    if let Ok(mut grabs) = cloths.get_mut(cloth) {
        grabs.set_target(particle, ray.origin + *ray.direction * depth);
    }
}

/// A press and release on the cloth without dragging.
fn release(
    event: On<Pointer<Release>>,
    held: ResMut<PointerGrabs>,
    cloths: Query<&mut ClothGrabs>,
) {
    if event.event.button == PointerButton::Primary {
        let_go(event.pointer_id, held, cloths);
    }
}

/// The end of a drag (sent to the dragged cloth wherever the pointer is).
fn drag_end(
    event: On<Pointer<DragEnd>>,
    held: ResMut<PointerGrabs>,
    cloths: Query<&mut ClothGrabs>,
) {
    if event.event.button == PointerButton::Primary {
        let_go(event.pointer_id, held, cloths);
    }
}

fn let_go(pointer: PointerId, mut held: ResMut<PointerGrabs>, mut cloths: Query<&mut ClothGrabs>) {
    if let Some((cloth, particle, ..)) = held.0.remove(&pointer)
        && let Ok(mut grabs) = cloths.get_mut(cloth)
    {
        grabs.release(particle);
    }
}
