//! Level of detail: a cloth no camera sees, or one far away, steps less
//! often, and one beyond a second distance does not step at all.
//!
//! Each fixed step, before anything else of the cloth step, every cloth's
//! [`ClothDetail`] is chosen from the active cameras (`Camera::is_active`)
//! by its [`LodSettings`]: its own [`ClothLod`], or the global
//! [`ClothLodDefaults`]. A camera *sees* a cloth when the cloth's box
//! reaches into the camera's `Frustum` (as Bevy culls meshes; occlusion and
//! render layers are not considered), and its distance is from the
//! camera's position to that box. Each camera gives a detail
//! ([`LodSettings::detail`]); the cloth takes the finest.
//!
//! - **Reduced** ([`Detail::Every`]`(k)`): the cloth takes one step of `k`
//!   fixed steps' time on every `k`th fixed step (cloths of the same rate are
//!   spread over different fixed steps). The forces written into its
//!   [`ClothForces`](crate::ClothForces) over those fixed steps act as
//!   their mean over the combined step (an impulse written once is kept);
//!   the wind is evaluated once for it. In the fixed steps between, its
//!   pins still follow their anchors, skin or frame, and its free
//!   particles are carried with them by the best-fitting rigid motion: a
//!   cape stays on its
//!   character at every level.
//! - **Earned**: a long step is less accurate where the cloth moves fast,
//!   so a new cloth starts at one fixed step a step, and the number it
//!   may combine doubles after every half second of steps that kept its
//!   strain under 10 % and halves after a step that did not.
//!   [`ClothDetail::detail`] is the
//!   level it steps at.
//! - **Frozen** ([`Detail::Frozen`], beyond [`LodSettings::freeze`]): the
//!   cloth is not stepped, only carried by its pins; the time it misses is
//!   dropped and its forces are cleared.
//! - **Back to full**: the steps a reduced cloth still owes are taken at
//!   once, so it arrives where its motion takes it; a frozen one continues
//!   from where it froze.
//!
//! A held cloth (a grab, picking) steps every fixed step. With no active
//! camera, or without the `render` feature (a headless app has none),
//! every cloth steps every fixed step and this costs nothing. A cloth that
//! is not stepped keeps its step count ([`ClothStats::steps`](crate::ClothStats::steps))
//! and its mesh.
//!
//! Invalid settings (a distance of 0, negative or NaN) are a
//! [`ClothError::InvalidLod`](crate::ClothError::InvalidLod): the cloth is
//! warned about once and steps every fixed step.
//!
//! ```
//! # use bevy::prelude::*;
//! # use bevy_cloth::prelude::*;
//! fn far_banners(mut defaults: ResMut<ClothLodDefaults>) {
//!     // Every 2nd step from 30 m, 4th from 60 m, frozen beyond 200 m.
//!     defaults.0.near = 30.0;
//!     defaults.0.freeze = 200.0;
//! }
//!
//! fn hero_cape(mut commands: Commands, cape: Entity) {
//!     // The hero's cape always steps every fixed step.
//!     let off = LodSettings { enabled: false, ..default() };
//!     commands.entity(cape).insert(ClothLod(off));
//! }
//! ```

use bevy::prelude::{
    Component, Reflect, ReflectComponent, ReflectDefault, ReflectResource, Resource,
};

use crate::sim::lod::{Detail, LodSettings, Pacer};

/// A cloth's own [`LodSettings`], in place of [`ClothLodDefaults`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct ClothLod(pub LodSettings);

/// The [`LodSettings`] of every cloth without a [`ClothLod`].
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource, Default)]
pub struct ClothLodDefaults(pub LodSettings);

/// A cloth's level of detail in this fixed step ([module docs](self)): on
/// every cloth, set by the plugin.
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct ClothDetail {
    detail: Detail,
    pacer: Pacer,
    steps: u32,
    distance: Option<f32>,
    warned: bool,
}

impl Default for ClothDetail {
    fn default() -> Self {
        Self {
            detail: Detail::Full,
            pacer: Pacer::default(),
            steps: 1,
            distance: None,
            warned: false,
        }
    }
}

impl ClothDetail {
    /// How often the cloth steps now.
    pub fn detail(&self) -> Detail {
        self.detail
    }

    /// How many fixed steps' time the cloth steps in this fixed step: 1 at
    /// full detail, `k` on the fixed step a reduced cloth takes, 0 when it
    /// skips this one or is frozen.
    pub fn steps_now(&self) -> u32 {
        self.steps
    }

    /// Fixed steps since the cloth's last step (0 when it stepped in this
    /// one; not counted while frozen).
    pub fn waited_steps(&self) -> u32 {
        self.pacer.waited()
    }

    /// After the cloth's step: its largest Type 1 strain (dimensionless)
    /// sets how many fixed steps it may combine ([`Pacer::stepped`]).
    pub(crate) fn stepped(&mut self, strain: f32) {
        self.pacer.stepped(self.steps, strain);
    }

    /// Distance from the nearest active camera to the cloth's box, m
    /// (`None` with no camera, or when the level of detail is off).
    pub fn distance(&self) -> Option<f32> {
        self.distance
    }
}

#[cfg(feature = "render")]
pub(crate) use choose::choose_detail;

#[cfg(feature = "render")]
mod choose {
    use bevy::camera::Camera;
    use bevy::camera::primitives::Frustum;
    use bevy::math::{Vec3, Vec4};
    use bevy::prelude::{Entity, GlobalTransform, Local, Query, Res, warn};

    use super::{ClothDetail, ClothLod, ClothLodDefaults};
    use crate::plugin::collision::bounds;
    use crate::plugin::interaction::grab::ClothGrabs;
    use crate::plugin::step::components::ClothParticles;
    use crate::sim::lod::{Detail, box_in_view, distance_to_box};

    /// [`ClothSystems::Prepare`](crate::ClothSystems::Prepare), first:
    /// chooses every cloth's [`ClothDetail`] for this fixed step from the
    /// active cameras.
    pub(crate) fn choose_detail(
        _main: crate::plugin::step::schedule::MainThread,
        defaults: Res<ClothLodDefaults>,
        cameras: Query<(&Camera, &GlobalTransform, &Frustum)>,
        mut cloths: Query<(
            Entity,
            &ClothParticles,
            Option<&ClothLod>,
            &ClothGrabs,
            &mut ClothDetail,
        )>,
        mut clock: Local<u64>,
        mut views: Local<Vec<(Vec3, [Vec4; 6])>>,
    ) {
        *clock += 1;
        views.clear();
        views.extend(
            cameras
                .iter()
                .filter(|(camera, at, _)| camera.is_active && at.translation().is_finite())
                .map(|(_, at, frustum)| {
                    (at.translation(), frustum.half_spaces.map(|h| h.normal_d()))
                }),
        );
        for (entity, particles, own, grabs, mut detail) in &mut cloths {
            let lod = own.map_or(&defaults.0, |own| &own.0);
            let detail = &mut *detail;
            let valid = match lod.validate() {
                Ok(()) => {
                    detail.warned = false;
                    true
                }
                Err(error) => {
                    if !detail.warned {
                        warn!("cloth {entity} steps every fixed step: {error}");
                        detail.warned = true;
                    }
                    false
                }
            };
            detail.distance = None;
            let mut level = Detail::Full;
            if valid && lod.enabled && !views.is_empty() && grabs.grabs().is_empty() {
                let around = bounds(&particles.positions, 0.0);
                if around.0.is_finite() && around.1.is_finite() {
                    let mut nearest = f32::INFINITY;
                    let mut finest = Detail::Frozen;
                    for (at, planes) in views.iter() {
                        let distance = distance_to_box(*at, around);
                        nearest = nearest.min(distance);
                        let seen = box_in_view(planes, around);
                        finest = finer(finest, lod.detail(Some(distance), seen));
                    }
                    detail.distance = Some(nearest);
                    level = finest;
                }
            }
            // The entity's index spreads cloths of one rate over the steps.
            let phase = entity.index_u32();
            let level = detail.pacer.limited(level);
            detail.steps = detail.pacer.tick(level, *clock, phase);
            detail.detail = level;
        }
    }

    /// The finer of two details: the one that steps more often.
    fn finer(a: Detail, b: Detail) -> Detail {
        let rate = |d: Detail| match d {
            Detail::Full => 1,
            Detail::Every(k) => k,
            Detail::Frozen => u32::MAX,
        };
        if rate(a) <= rate(b) { a } else { b }
    }
}
