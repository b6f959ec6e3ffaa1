//! Pick and pull with the mouse (feature `picking`): press on a cloth to
//! grab the particle nearest the hit (a corner of the triangle hit,
//! [`nearest_on_surface`]), drag to carry it along the cursor ray
//! at the grab's depth, release to let go; the secondary button pins or
//! unpins that particle. Built on [`ClothGrabs`], so game code sees
//! the player's grabs like its own.
//!
//! Needs a picking backend that hits meshes, such as Bevy's
//! `MeshPickingPlugin`, which the game adds (see
//! [`ClothPlugin`](crate::ClothPlugin) for why the plugin does not); without
//! one, the plugin warns once at start-up. A UI that takes part
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
use bevy::picking::events::{PointerDrag, PointerDragEnd, PointerPress, PointerRelease};
use bevy::picking::hover::HoverMap;
use bevy::picking::pointer::{PointerButton, PointerId};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use crate::plugin::interaction::grab::{ClothGrabs, GrabMode, nearest_on_surface};
use crate::plugin::step::components::{Cloth, ClothParticles};

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

/// A particle a pointer holds.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct PointerGrab {
    /// The cloth.
    pub cloth: Entity,
    /// The held particle's index.
    pub particle: u32,
    /// The camera whose ray carries it.
    pub camera: Entity,
    /// Its depth along that camera's ray, m.
    pub depth: f32,
}

/// The grab each pointer holds.
#[derive(Resource, Clone, Debug, Default)]
pub struct ClothPointerGrabs(HashMap<PointerId, PointerGrab>);

impl ClothPointerGrabs {
    /// Follows a seam of `cloth` ([`ClothSew`](crate::plugin::tearing::sew::ClothSew)):
    /// each held particle of it becomes `map[particle]`.
    pub(crate) fn remap(&mut self, cloth: Entity, map: &[u32]) {
        for grab in self.0.values_mut().filter(|g| g.cloth == cloth) {
            if let Some(&to) = map.get(grab.particle as usize) {
                grab.particle = to;
            }
        }
    }

    /// Whether any pointer holds a particle (an orbit camera should then
    /// leave the mouse alone).
    pub fn active(&self) -> bool {
        !self.0.is_empty()
    }

    /// The grab `pointer` holds, if any.
    pub fn get(&self, pointer: &PointerId) -> Option<&PointerGrab> {
        self.0.get(pointer)
    }

    /// Every pointer's grab.
    pub fn iter(&self) -> impl Iterator<Item = (&PointerId, &PointerGrab)> {
        self.0.iter()
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
    held: Res<'w, ClothPointerGrabs>,
    cloths: Query<'w, 's, (), With<crate::plugin::step::components::Cloth>>,
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

/// Warns once when the app has picking but no mesh picking backend, so the
/// pointer cannot reach a cloth (unless cloth picking is turned off).
pub(crate) fn warn_without_backend(app: &App) {
    let enabled = app
        .world()
        .get_resource::<ClothPicking>()
        .is_none_or(|p| p.enabled);
    if enabled
        && app.is_plugin_added::<bevy::picking::PickingPlugin>()
        && !app.is_plugin_added::<bevy::picking::mesh_picking::MeshPickingPlugin>()
    {
        warn!(
            "bevy_cloth: the pointer cannot grab cloths, as the app has no mesh picking \
             backend: add `MeshPickingPlugin` (bevy::picking::mesh_picking), or set \
             `ClothPicking {{ enabled: false, .. }}` to silence this"
        );
    }
}

pub(crate) fn configure(app: &mut App) {
    app.init_resource::<ClothPicking>()
        .init_resource::<ClothPointerGrabs>()
        .register_type::<ClothPicking>()
        .add_observer(press)
        .add_observer(drag)
        .add_observer(release)
        .add_observer(drag_end);
}

fn press(
    event: On<PointerPress>,
    settings: Res<ClothPicking>,
    mut held: ResMut<ClothPointerGrabs>,
    mut cloths: Query<(&Cloth, &mut ClothParticles, &mut ClothGrabs)>,
) {
    let cloth = event.entity;
    let (Ok((shape, mut particles, mut grabs)), Some(hit)) =
        (cloths.get_mut(cloth), event.hit.position)
    else {
        return;
    };
    if !settings.enabled {
        return;
    }
    let Some(p) = nearest_on_surface(shape, &particles, hit) else {
        return;
    };
    match event.button {
        PointerButton::Primary => {
            let at = particles.positions[p as usize];
            grabs.grab(p, at, settings.mode);
            held.0.insert(
                event.pointer.id,
                PointerGrab {
                    cloth,
                    particle: p,
                    camera: event.hit.camera,
                    depth: event.hit.depth,
                },
            );
        }
        PointerButton::Secondary => {
            let i = p as usize;
            if particles.is_pinned(i) {
                particles.unpin(i);
            } else {
                particles.pin_by(i, crate::sim::particles::PinOwner::Picking);
            }
        }
        PointerButton::Middle => {}
    }
}

fn drag(
    event: On<PointerDrag>,
    rays: Res<RayMap>,
    held: Res<ClothPointerGrabs>,
    mut cloths: Query<&mut ClothGrabs>,
) {
    let Some(&PointerGrab {
        cloth,
        particle,
        camera,
        depth,
    }) = held.get(&event.pointer.id)
    else {
        return;
    };
    let Some(ray) = rays.map.get(&RayId::new(camera, event.pointer.id)) else {
        return;
    };
    if let Ok(mut grabs) = cloths.get_mut(cloth) {
        grabs.set_target(particle, ray.origin + *ray.direction * depth);
    }
}

/// A press and release on the cloth without dragging.
fn release(
    event: On<PointerRelease>,
    held: ResMut<ClothPointerGrabs>,
    cloths: Query<&mut ClothGrabs>,
) {
    if event.button == PointerButton::Primary {
        let_go(event.pointer.id, held, cloths);
    }
}

/// The end of a drag (sent to the dragged cloth wherever the pointer is).
fn drag_end(
    event: On<PointerDragEnd>,
    held: ResMut<ClothPointerGrabs>,
    cloths: Query<&mut ClothGrabs>,
) {
    if event.button == PointerButton::Primary {
        let_go(event.pointer.id, held, cloths);
    }
}

fn let_go(
    pointer: PointerId,
    mut held: ResMut<ClothPointerGrabs>,
    mut cloths: Query<&mut ClothGrabs>,
) {
    if let Some(PointerGrab {
        cloth, particle, ..
    }) = held.0.remove(&pointer)
        && let Ok(mut grabs) = cloths.get_mut(cloth)
    {
        grabs.release(particle);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seam_moves_the_pointers_grab_of_its_cloth_only() {
        let (cloth, other) = (
            Entity::from_raw_u32(1).unwrap(),
            Entity::from_raw_u32(2).unwrap(),
        );
        let grab = |cloth, particle| PointerGrab {
            cloth,
            particle,
            camera: Entity::PLACEHOLDER,
            depth: 1.0,
        };
        let mut held = ClothPointerGrabs::default();
        held.0.insert(PointerId::Mouse, grab(cloth, 4));
        held.0.insert(PointerId::Touch(1), grab(other, 4));
        held.remap(cloth, &[0, 1, 2, 1, 3]);
        assert_eq!(held.0[&PointerId::Mouse].particle, 3);
        assert_eq!(
            held.0[&PointerId::Touch(1)].particle,
            4,
            "another cloth's grab"
        );
    }
}
