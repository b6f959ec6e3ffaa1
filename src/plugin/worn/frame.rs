//! Cloth on a moving character or vehicle: [`ClothInertia`] (how much of
//! its frame's motion the cloth feels) and [`TeleportCloth`] (move the
//! whole cloth with its frame).

use bevy::ecs::system::EntityCommand;
use bevy::math::Isometry3d;
use bevy::prelude::{
    Component, Entity, EntityWorldMut, Local, Query, Reflect, ReflectComponent, Vec3,
};

use crate::plugin::render::mesh::ClothPrevious;
use crate::plugin::step::components::ClothParticles;
use crate::plugin::step::pose::WorldPose;
use crate::plugin::step::writeback::ClothScratch;
use crate::plugin::worn::anchor::ClothAnchors;
use crate::plugin::worn::skin::ClothSkin;
use crate::sim::frame::{Carry, InertiaScale, teleport};

/// The frame a cloth moves with (a character's body, a cart) and how much
/// of that frame's motion the cloth feels, as NvCloth's and Chaos's
/// inertia scales: before each step the free particles are carried by the
/// unfelt share of the frame's motion since the last step. At 1 (and without this component)
/// the cloth feels all of it; lower scales keep a cape on a running,
/// spinning or jumping character from streaming out behind it.
///
/// The frame is read as anchors' targets are (a root entity's own
/// `Transform`, a child's `GlobalTransform`).
/// Use [`TeleportCloth`] to move a character and its cloth somewhere else.
/// The frame's own anchors and a [`ClothSkin`]'s kinematic particles are
/// carried with the free particles. A collider that moves with the frame
/// takes the carried share for motion against it: keep the cloth off the
/// body it hangs from with [`ClothSkin`] backstops instead.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn wear(mut commands: Commands, body: Entity) -> Result<(), ClothError> {
///     let cape = ClothBuilder::new(10, 14).pin_edge(GridEdge::Top).build()?;
///     commands.spawn((cape, ClothInertia::new(body, 0.3, 0.2)));
///     Ok(())
/// }
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(ClothFramePose)]
pub struct ClothInertia {
    /// The entity whose motion is the frame's.
    pub frame: Entity,
    /// Share of the frame's translation the cloth feels, in `[0, 1]`.
    pub linear_scale: f32,
    /// Share of the frame's rotation the cloth feels, in `[0, 1]`.
    pub angular_scale: f32,
}

impl ClothInertia {
    /// The frame `frame`, with the shares of its translation and rotation
    /// the cloth feels (each in `[0, 1]`).
    pub fn new(frame: Entity, linear_scale: f32, angular_scale: f32) -> Self {
        Self {
            frame,
            linear_scale,
            angular_scale,
        }
    }
}

/// The frame's pose at the last step (m, rad), for [`ClothInertia`].
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct ClothFramePose(pub Option<Isometry3d>);

/// What carrying a cloth with its frame reads and writes.
type CarryQuery = (
    &'static ClothInertia,
    &'static mut ClothFramePose,
    &'static mut ClothParticles,
    &'static mut ClothScratch,
    Option<&'static ClothAnchors>,
    Option<&'static ClothSkin>,
);

/// [`ClothSystems::Prepare`](crate::ClothSystems::Prepare): carries each
/// cloth's free particles by the unfelt share of its frame's motion.
pub(crate) fn carry_with_frames(
    _main: crate::plugin::step::schedule::MainThread,
    frames: Query<WorldPose>,
    mut cloths: Query<CarryQuery>,
    mut carried: Local<Vec<bool>>,
) {
    for (inertia, mut last, mut particles, mut scratch, anchors, skin) in &mut cloths {
        let Some(now) = frames.get(inertia.frame).ok().and_then(|p| p.isometry()) else {
            last.0 = None;
            continue;
        };
        if let Some(before) = last.0 {
            let scale = InertiaScale {
                linear: inertia.linear_scale,
                angular: inertia.angular_scale,
            };
            if let Some(carry) = Carry::new((before, now), scale) {
                // The free particles, and the pins that move with the
                // frame: its anchors and a skin's kinematic particles.
                let p = &mut particles.0;
                carried.clear();
                carried.extend(p.inverse_masses.iter().map(|&w| w > 0.0));
                if let Some(skin) = skin {
                    for (c, &f) in carried.iter_mut().zip(&skin.freedom) {
                        *c |= f <= 0.0;
                    }
                }
                for anchor in anchors.iter().flat_map(|a| a.anchors()) {
                    if anchor.target == inertia.frame
                        && let Some(c) = carried.get_mut(anchor.particle as usize)
                    {
                        *c = true;
                    }
                }
                let moves = |i: usize| carried[i];
                carry.apply(&mut p.positions, &mut p.velocities, moves);
                scratch.buffers.implicit.carry_history(&carry, moves);
            }
        }
        last.0 = Some(now);
    }
}

/// Moves a cloth and everything it remembers of its motion (the mesh's
/// interpolation, the BDF2 history, its frame's last pose) by a rigid
/// motion, as a command: teleport a character, then its cloth by the same
/// motion, and the cloth arrives as it left, unstretched.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn respawn(mut commands: Commands, body: Entity, cape: Entity, mut bodies: Query<&mut Transform>) {
///     let by = Isometry3d::from_translation(Vec3::new(0.0, 0.0, -40.0));
///     if let Ok(mut t) = bodies.get_mut(body) {
///         t.translation += Vec3::new(0.0, 0.0, -40.0);
///     }
///     commands.entity(cape).queue(TeleportCloth(by));
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TeleportCloth(pub Isometry3d);

impl EntityCommand for TeleportCloth {
    type Out = ();

    fn apply(self, mut entity: EntityWorldMut) {
        let by = self.0;
        if !(Vec3::from(by.translation).is_finite() && by.rotation.is_finite()) {
            return;
        }
        if let Some(mut particles) = entity.get_mut::<ClothParticles>() {
            let p = &mut particles.0;
            teleport(&mut p.positions, &mut p.velocities, by);
        }
        if let Some(mut previous) = entity.get_mut::<ClothPrevious>() {
            for x in &mut previous.positions {
                *x = Vec3::from(by.transform_point(*x));
            }
        }
        if let Some(mut scratch) = entity.get_mut::<ClothScratch>() {
            scratch
                .buffers
                .implicit
                .carry_history(&Carry::rigid(by), |_| true);
        }
        if let Some(mut last) = entity.get_mut::<ClothFramePose>()
            && let Some(pose) = last.0
        {
            last.0 = Some(by * pose);
        }
    }
}
