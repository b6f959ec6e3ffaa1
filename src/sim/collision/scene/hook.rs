//! A cloth's contacts with a [`ColliderScene`] during its step: the
//! integrators' [`ContactHook`] the plugin runs, and any code stepping a
//! cloth with [`step_guarded`](crate::sim::guard::step_guarded) can run
//! too; it measures the impulses on colliders with
//! [`feedback`](SceneCollider::feedback) on the way.

use bevy::math::Vec3;

use super::colliders::{ClothContactLayers, ColliderScene, ContactImpulse, SceneCollider};
use super::feedback::{Carried, Feedback};
use crate::sim::collision::ccd::prevent_crossings;
use crate::sim::collision::cloths::NeighbourContacts;
use crate::sim::collision::contact::{MovingCollider, collide_particles};
use crate::sim::collision::self_collision::keep_apart;
#[cfg(test)]
use crate::sim::collision::self_collision::self_collide;
use crate::sim::collision::{Counts, SelfCollisionBuffers, bounds};
use crate::sim::collision::{edges, predict};
use crate::sim::connections::{Connections, Link};
use crate::sim::grid::{Faces, Grid};
use crate::sim::integrate::implicit::{ContactBuffers, Hold, SolveBody, SolveContact};
use crate::sim::step::{ContactHook, Substep};
use crate::sim::team::both;
use crate::sim::tether::Tethers;

/// Particles from which a cloth's contacts with each collider are resolved
/// in two halves, one on the implicit solver's helper thread, when
/// [`ImplicitSettings::helper_thread`](crate::sim::settings::ImplicitSettings::helper_thread)
/// allows (the result is the same either way).
pub(crate) const SPLIT_PARTICLES: usize = crate::sim::team::SPLIT_PARTICLES;

/// Resolves the contacts of the particles with one collider over a
/// substep, at the cloth's contact `thickness` (m) plus the collider's
/// margin; with `helper`, a cloth of [`SPLIT_PARTICLES`] or more shares the
/// work with the helper thread.
fn collide_one(
    (collider, moving): (&SceneCollider, MovingCollider<'_>),
    sub: Substep,
    (thickness, helper): (f32, bool),
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
) -> Counts {
    let thickness = thickness + collider.margin;
    let collide = |start, x, v, w| collide_particles(&moving, start, x, v, w, thickness, sub.dt);
    if !helper || x.len() < SPLIT_PARTICLES {
        return collide(start, x, v, inverse_masses);
    }
    // Each particle's contact is its own: half of them on the solver's
    // helper thread, to the same result.
    let mid = x.len() / 2;
    let (x0, x1) = x.split_at_mut(mid);
    let (v0, v1) = v.split_at_mut(mid);
    let (s0, s1) = start.split_at(mid);
    let (w0, w1) = inverse_masses.split_at(mid);
    let (mut a, b) = both(|| collide(s0, x0, v0, w0), || collide(s1, x1, v1, w1));
    a += b;
    a
}

/// Resolves the contacts of one substep of one cloth: against the scene's
/// colliders listed in `near` (thickness `thickness` m), then with itself
/// when `self_collision` is given; with `helper`, a cloth of
/// [`SPLIT_PARTICLES`] or more shares the work with the helper thread. The
/// ECS step calls this from the integrator's contact hook; it is a plain
/// function so it can be tested and benched without an `App`.
#[cfg(test)]
#[expect(
    clippy::too_many_arguments,
    reason = "a plain function over the cloth's slices"
)]
pub(crate) fn resolve_substep(
    scene: &ColliderScene,
    near: &[usize],
    (thickness, helper): (f32, bool),
    self_collision: Option<(&impl Faces, f32, &mut SelfCollisionBuffers)>,
    sub: Substep,
    start: &[Vec3],
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
) -> (Counts, Counts) {
    let mut against = Counts::default();
    for &c in near {
        let collider = &scene.colliders[c];
        against += collide_one(
            (collider, collider.between(sub.from, sub.to)),
            sub,
            (thickness, helper),
            start,
            x,
            v,
            inverse_masses,
        );
    }
    let mut itself = Counts::default();
    if let Some((cloth, self_thickness, buffers)) = self_collision {
        itself = self_collide(cloth, start, x, v, inverse_masses, self_thickness, buffers);
    }
    (against, itself)
}

/// What a cloth's contacts keep from step to step: the colliders near it,
/// the impulses its last step gave colliders with feedback, and scratch.
#[derive(Clone, Debug, Default)]
pub struct SceneContactScratch {
    /// Indices into the scene's colliders of those near the cloth.
    pub(crate) near: Vec<usize>,
    /// The inverse masses with the held particles' zeroed, 1/kg.
    pub(crate) masked: Vec<f32>,
    /// The edge contacts' scratch: each particle's local position (m),
    /// distance (m), normal and surface speed (m/s).
    pub(crate) edge_points: Vec<(Vec3, f32, Vec3, f32)>,
    /// The impulses the step gave colliders with feedback.
    pub(crate) feedback: Feedback,
}

impl SceneContactScratch {
    /// Lists the colliders of `scene` the cloth at `positions` (m) may meet
    /// in its next step: those whose swept box overlaps the cloth's box
    /// grown by `pad` m (its contact thickness and how far it may move) and
    /// whose layers meet the cloth's `layers`.
    pub fn select_near(
        &mut self,
        scene: &ColliderScene,
        positions: &[Vec3],
        pad: f32,
        layers: ClothContactLayers,
    ) {
        let (min, max) = bounds(positions, pad);
        self.near.clear();
        self.near.extend(
            scene
                .overlapping(min, max)
                .filter(|&c| scene.colliders[c].layers.interacts(layers)),
        );
    }

    /// Forgets the colliders listed near the cloth.
    pub fn clear_near(&mut self) {
        self.near.clear();
    }

    /// The colliders listed near the cloth, as indices into the scene's
    /// colliders.
    pub fn near(&self) -> &[usize] {
        &self.near
    }

    /// The impulses the last step gave the colliders with
    /// [`feedback`](SceneCollider::feedback): scene index and impulse.
    pub fn impulses(&self) -> &[(usize, ContactImpulse)] {
        &self.feedback.impulses
    }
}

/// The contacts of one cloth's step with the colliders of a
/// [`ColliderScene`] and with itself, as the integrators' [`ContactHook`]:
/// implicit steps hold the contacts
/// [`predict`](predict::predict_contacts) lists inside their solve; after
/// every substep the rest are resolved, leaving the particles the solve
/// held alone. The impulses on colliders with feedback are measured into
/// the [`SceneContactScratch`] on the way.
///
/// ```
/// use bevy::math::{Isometry3d, Vec3};
/// use bevy_cloth::prelude::*;
/// use bevy_cloth::sim::collision::Shape;
/// use bevy_cloth::sim::collision::scene::*;
/// use bevy_cloth::sim::guard::{GuardState, StepInput, step_guarded};
/// use bevy_cloth::sim::integrate::StepBuffers;
///
/// // A 1 m sheet laid flat 30 cm above a floor (the plane y = 0 of its pose).
/// let mut cloth = ClothBuilder::new(9, 9).build()?;
/// let floor_y = cloth.particles.positions[0].y - 0.3;
/// let floor = Isometry3d::from_translation(Vec3::new(0.0, floor_y, 0.0));
/// let mut scene = ColliderScene::default();
/// scene.push(SceneCollider::new(ColliderKey(1), ColliderShape::Analytic(Shape::Plane), floor, floor))?;
/// let settings = SimSettings::default();
/// let (mut buffers, mut guard) = (StepBuffers::default(), GuardState::default());
/// let mut scratch = SceneContactScratch::default();
/// for _ in 0..60 {
///     let (positions, layers) = (&cloth.particles.positions, ClothContactLayers::ALL);
///     scratch.select_near(&scene, positions, 0.2, layers);
///     let mut contacts = SceneContacts::new(&scene, &cloth.connections, 0.01, &mut scratch);
///     step_guarded(
///         StepInput::new(&mut cloth.particles, &cloth.connections, &settings, &mut buffers, &mut guard, 1.0 / 60.0)
///             .with_contacts(Some(&mut contacts)),
///     );
/// }
/// // It lies on the floor, no particle below it.
/// assert!(cloth.particles.positions.iter().all(|p| (p.y - floor_y).abs() < 0.02));
/// # Ok::<(), bevy_cloth::error::ClothError>(())
/// ```
pub struct SceneContacts<'a, F: Faces = Grid> {
    /// The scene.
    pub(crate) scene: &'a ColliderScene,
    /// The scene's colliders near the cloth.
    pub(crate) near: &'a [usize],
    /// Contact thickness, m.
    pub(crate) thickness: f32,
    /// Whether a large cloth may share the work with the helper thread.
    pub(crate) helper: bool,
    /// The cloth's triangles, its self-collision thickness (m) and buffers,
    /// when it collides with itself.
    pub(crate) self_collision: Option<(&'a F, f32, &'a mut SelfCollisionBuffers)>,
    /// Whether the implicit solve holds contacts (otherwise they are all
    /// resolved after each substep).
    pub(crate) in_solve: bool,
    /// The cloth's tethers and their slack, applied before the contacts.
    pub(crate) tethers: Option<(&'a Tethers, f32)>,
    /// The cloth's Type 1 links (structural and shear), held off the
    /// colliders' edges and corners in the solve
    /// ([`edges`](crate::sim::collision::edges)).
    pub(crate) links: [&'a [Link]; 2],
    /// Scratch: the inverse masses with the held particles' zeroed.
    pub(crate) masked: &'a mut Vec<f32>,
    /// Scratch of the edge contacts: each particle's local position,
    /// distance (m), normal and surface speed (m/s).
    pub(crate) edge_points: &'a mut Vec<(Vec3, f32, Vec3, f32)>,
    /// The impulses on colliders with feedback.
    pub(crate) feedback: &'a mut Feedback,
    /// Tests and contacts so far: against colliders, with itself.
    pub(crate) counts: (Counts, Counts),
    /// Its contacts with other cloths, when it has some near.
    pub(crate) cloths: Option<NeighbourContacts<'a>>,
}

impl<'a> SceneContacts<'a> {
    /// The contacts of a cloth with `connections` against the colliders of
    /// `scene` that `scratch` lists near it
    /// ([`select_near`](SceneContactScratch::select_near)), at a contact
    /// thickness of `thickness` m; held in the implicit solve, on this
    /// thread alone.
    pub fn new(
        scene: &'a ColliderScene,
        connections: &'a Connections,
        thickness: f32,
        scratch: &'a mut SceneContactScratch,
    ) -> Self {
        let SceneContactScratch {
            near,
            masked,
            edge_points,
            feedback,
        } = scratch;
        Self {
            scene,
            near,
            thickness,
            helper: false,
            self_collision: None,
            in_solve: true,
            tethers: None,
            links: [&connections.structural, &connections.shear],
            masked,
            edge_points,
            feedback,
            counts: Default::default(),
            cloths: None,
        }
    }
}

impl<'a, F: Faces> SceneContacts<'a, F> {
    /// With the cloth colliding with itself: its triangles, its
    /// self-collision thickness (m) and buffers.
    pub(crate) fn with_self_collision<G: Faces>(
        self,
        self_collision: Option<(&'a G, f32, &'a mut SelfCollisionBuffers)>,
    ) -> SceneContacts<'a, G> {
        SceneContacts {
            scene: self.scene,
            near: self.near,
            thickness: self.thickness,
            helper: self.helper,
            self_collision,
            in_solve: self.in_solve,
            tethers: self.tethers,
            links: self.links,
            masked: self.masked,
            edge_points: self.edge_points,
            feedback: self.feedback,
            counts: self.counts,
            cloths: self.cloths,
        }
    }

    /// With a cloth of many particles sharing the work with the implicit
    /// solver's helper thread (the same result either way).
    pub fn with_helper_thread(mut self, helper: bool) -> Self {
        self.helper = helper;
        self
    }

    /// With the contacts held inside the implicit solve (`true`, the
    /// default) or all resolved after each substep.
    pub fn with_contacts_in_solve(mut self, in_solve: bool) -> Self {
        self.in_solve = in_solve;
        self
    }

    /// The tests and contacts so far: against the colliders, and of the
    /// cloth with itself.
    pub fn counts(&self) -> (Counts, Counts) {
        self.counts
    }
}

impl<F: Faces> ContactHook for SceneContacts<'_, F> {
    fn resolve(
        &mut self,
        sub: Substep,
        start: &[Vec3],
        x: &mut [Vec3],
        v: &mut [Vec3],
        w: &[f32],
        held: &[Hold],
    ) {
        let all = w;
        let w = if held.len() == w.len() {
            self.masked.clear();
            self.masked.extend(
                w.iter()
                    .zip(held)
                    .map(|(&w, &h)| if h == Hold::Free { w } else { 0.0 }),
            );
            &self.masked[..]
        } else {
            w
        };
        if let Some((tethers, slack)) = self.tethers {
            tethers.apply(x, v, w, slack);
        }
        let mut against = Counts::default();
        for &c in self.near {
            let collider = &self.scene.colliders[c];
            if collider.feedback {
                self.feedback.mark(v);
            }
            let moving = self.feedback.moving(collider, c, sub);
            let both = (collider, moving);
            // A body that gives way holds, within the solve, the particles
            // in its contact thickness; after the step only a particle
            // that crossed into the body itself is stopped, and the next
            // step's springs hold what overlap is left.
            let thickness = if held.len() == x.len() && collider.body().is_some() {
                0.0
            } else {
                self.thickness
            };
            against += collide_one(both, sub, (thickness, self.helper), start, x, v, w);
            if collider.feedback {
                self.feedback.measure(c, x, v, all);
            }
        }
        let mut itself = Counts::default();
        if let Some((cloth, thickness, buffers)) = self.self_collision.as_mut() {
            itself = keep_apart(*cloth, start, x, v, w, *thickness, buffers);
        }
        if let Some(cloths) = self.cloths.as_mut() {
            cloths.resolve(sub, (start, x, v), all, held);
        }
        if held.len() == x.len() {
            for &c in self.near {
                let collider = &self.scene.colliders[c];
                // A body that gives way moved within the solve: its held
                // particles are where the solve left them, and the next
                // step's springs hold what overlap is left.
                if collider.body().is_some() {
                    continue;
                }
                if collider.feedback {
                    self.feedback.mark(v);
                }
                let moving = self.feedback.moving(collider, c, sub);
                against.contacts += predict::push_out_held(
                    &moving,
                    held,
                    (start, x, v),
                    self.thickness + collider.margin,
                    sub.dt,
                );
                if collider.feedback {
                    self.feedback.measure(c, x, v, all);
                }
            }
        }
        // Last, so that nothing after it moves the cloth through itself:
        // the particles held against colliders may give way here too.
        if let Some((cloth, thickness, buffers)) = self.self_collision.as_mut() {
            let crossings = buffers.crossings();
            itself += prevent_crossings(*cloth, start, x, v, all, *thickness, crossings).into();
        }
        self.counts.0 += against;
        self.counts.1 += itself;
    }

    fn predict(
        &mut self,
        sub: Substep,
        x: &[Vec3],
        v: &[Vec3],
        w: &[f32],
        out: &mut Vec<SolveContact>,
        bodies: &mut Vec<SolveBody>,
    ) {
        if !self.in_solve {
            return;
        }
        if sub.from == 0.0 {
            self.feedback.carried.clear();
        }
        // The links' extent, once for every fixed collider of the step.
        let mut extent = None;
        for &c in self.near {
            let collider = &self.scene.colliders[c];
            let moving = self.feedback.moving(collider, c, sub);
            let from = out.len();
            let free = collider.body().is_some();
            let thickness = self.thickness + collider.margin;
            predict::predict_contacts(&moving, (x, v, w), (thickness, sub.dt), free, out);
            if !free {
                let extent = *extent.get_or_insert_with(|| edges::link_extent(&self.links, x, v));
                edges::predict_edge_contacts(
                    &moving,
                    &self.links,
                    (x, v, w),
                    (thickness, sub.dt),
                    extent,
                    self.edge_points,
                    out,
                );
            }
            for contact in &mut out[from..] {
                contact.source = c as u32;
            }
        }
        if let Some(cloths) = self.cloths.as_mut() {
            cloths.predict(sub, (x, v, w), out);
        }
        let colliders = &self.scene.colliders;
        // Kinds of surface: fixed, a free body, another cloth.
        predict::keep_nearest(out, |source| match colliders.get(source as usize) {
            Some(c) if c.body().is_some() => 1,
            Some(_) => 0,
            None => 2,
        });
        // A body that gives way moves within the solve, under all its
        // contacts at once, from where the substeps so far took it. The
        // pieces of one collider, and the colliders of one body (the same
        // mass, centre and inertia), are one body.
        self.feedback.sources.clear();
        self.feedback.at = sub;
        for &c in self.near {
            let collider = &self.scene.colliders[c];
            let Some(mut body) = collider.body() else {
                continue;
            };
            let source = c as u32;
            if !out.iter().any(|s| s.source == source) {
                continue;
            }
            let same = |&(other, _): &(usize, u32)| {
                let o = &self.scene.colliders[other];
                o.key == collider.key
                    || (o.mass == collider.mass
                        && o.centre == collider.centre
                        && o.inverse_inertia == collider.inverse_inertia)
            };
            let index = match self.feedback.sources.iter().find(|s| same(s)) {
                Some(&(_, index)) => index,
                None => {
                    let moving = self.feedback.moving(collider, c, sub);
                    body.centre += Vec3::from(moving.start.translation)
                        - Vec3::from(collider.start.translation);
                    bodies.push(body);
                    (bodies.len() - 1) as u32
                }
            };
            for contact in out.iter_mut().filter(|s| s.source == source) {
                contact.body = index;
            }
            self.feedback.sources.push((c, index));
        }
    }

    fn undo(&mut self) {
        self.feedback.impulses.clear();
        self.feedback.carried.clear();
    }

    fn solved(&mut self, _x: &[Vec3], v: &[Vec3], contacts: &ContactBuffers) {
        // The bodies the solve moved move so for the rest of the step.
        let Feedback {
            sources,
            carried,
            at,
            ..
        } = &mut *self.feedback;
        for &(collider, b) in sources.iter() {
            let [linear, angular] = contacts.body_change(b as usize);
            let shift = contacts.body_separation(b as usize);
            if [linear, angular, shift].iter().any(|&m| m != Vec3::ZERO) {
                carried.push(Carried {
                    collider,
                    linear,
                    angular,
                    shift,
                    from: at.to,
                });
            }
        }
        // A body's shift is reported once, with its first collider.
        for k in 0..self.feedback.sources.len() {
            let (collider, b) = self.feedback.sources[k];
            let shift = contacts.body_separation(b as usize);
            let first = !self.feedback.sources[..k].iter().any(|s| s.1 == b);
            if first
                && shift != Vec3::ZERO
                && self
                    .scene
                    .colliders
                    .get(collider)
                    .is_some_and(|c| c.feedback)
            {
                self.feedback.entry(collider).shift += shift;
            }
        }
        for (contact, impulse, at) in contacts.impulses() {
            let c = contact.source as usize;
            let p = contact.particle as usize;
            if let (Some(collider), Some(&moving)) = (self.scene.colliders.get(c), v.get(p))
                && collider.feedback
            {
                self.feedback.entry(c).add_at(-impulse, at, moving);
            }
        }
    }
}
