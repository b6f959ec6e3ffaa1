//! Contacts inside the implicit solve: a cloth resting on, draped over or
//! carried by a collider at one step per frame.
//!
//! The caller lists, before each implicit step, the particles that touch a
//! collider or will within the step ([`SolveContact`]: the surface normal
//! `n`, the gap to the contact thickness, the surface's velocity `u` and
//! the friction coefficient `μ`). The solve holds each of them with two
//! terms on its diagonal block, both implicit, so both hold at any step:
//!
//! - **Normal**: a stiff spring `k n nᵀ`, `k = κ m/γ²` (`κ` =
//!   [`KAPPA`], `m` the particle's mass, `γ` the step's velocity-to-
//!   position factor, `h` for backward Euler), whose rest is the contact
//!   thickness: the solve keeps the particle on the surface to within
//!   `1/(1 + κ)` of its motion into it, and the rest of the cloth feels the
//!   support within the same step. This is the implicit penalty form of
//!   Baraff & Witkin's constraint, which leaves the conjugate gradient and
//!   its preconditioners as they are.
//! - **Friction**, by Coulomb's law with the normal force `λ` (N) the
//!   contact carried in the last step (or, new, the pressure of the forces
//!   on the particle now). A particle sliding along the surface faster than
//!   `v_ε` = [`STICK_SPEED`] feels the kinetic force `μ λ` against its
//!   motion (taking out at most the motion there is). A slower one is held
//!   by a tangential damping `c (I − n nᵀ)`, `c = μ λ / v_ε`, implicit and
//!   so stable at any step: a load within the cone `μ λ` leaves it creeping
//!   below `v_ε`; a larger one moves it faster, and it slides from the next
//!   step on (the lagged, smoothed friction of implicit contact solvers,
//!   after Bridson et al. 2002).
//!
//! **A body that gives way.** A contact with a free body of mass `M`
//! (shared among the body's contacts: [`SolveContact::body_mass`]) is held
//! by the same spring in series with the body's inertia: the body moves
//! `−γ² λ / M` along the normal within the step as the spring pushes it,
//! which leaves the spring `k / (1 + κ m / M)`. A heavy body (`M ≫ κ m`)
//! holds the particle as a fixed surface does; a light one is pushed along
//! with the particle's motion, and the cloth feels its inertia within the
//! solve rather than a step late. Friction is held in series with the mass
//! the body shows along its surface there ([`SolveContact::body_tangent_mass`],
//! its turning included): a light or spinning body that the cloth rubs is
//! carried along, not flung past the cloth's motion. The caller applies the
//! impulses ([`ContactBuffers::impulses`]) to the body after the step.
//!
//! After the solve the spring gives the contact force `λ` of the step: a
//! pulling one means the particle was leaving, and the spring held it back
//! for that step; it is not held again unless it comes back. Otherwise `λ`
//! sets the next step's friction.

use bevy::math::Vec3;

/// A particle touching a collider, or about to within the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveContact {
    /// The particle.
    pub particle: u32,
    /// Outward unit normal of the surface at the particle.
    pub normal: Vec3,
    /// Distance (m) from the particle to the surface less the contact
    /// thickness, at the start of the step: negative when it is inside.
    pub gap: f32,
    /// Velocity (m/s) of the surface at the particle.
    pub velocity: Vec3,
    /// Coulomb friction coefficient (dimensionless).
    pub friction: f32,
    /// The collider the contact is with, numbered as the caller numbers
    /// them: the solve does not read it, and hands it back with the
    /// contact's impulse ([`ContactBuffers::impulses`]).
    pub source: u32,
    /// The mass (kg) of the body behind the surface that this contact
    /// moves: the body's mass shared among its contacts, or infinite for a
    /// surface that does not give way (module docs).
    pub body_mass: f32,
    /// The mass (kg) the body shows along the surface at this contact, its
    /// turning included, shared among its contacts as
    /// [`body_mass`](Self::body_mass) is; infinite for a surface that does
    /// not give way. Friction takes it in (module docs).
    pub body_tangent_mass: f32,
}

/// How the solve held a particle in the last step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Hold {
    /// Not held.
    #[default]
    Free,
    /// On the surface, sliding along it at [`STICK_SPEED`] or more.
    Slide,
    /// On the surface, held by friction (slower than [`STICK_SPEED`]).
    Stick,
}

/// Normal stiffness of a contact in units of the particle's mass over the
/// step squared (dimensionless, module docs).
pub const KAPPA: f32 = 1000.0;

/// The speed (m/s) below which friction holds rather than slides (module
/// docs): the fastest a particle whose load is within the friction cone can
/// creep.
pub const STICK_SPEED: f32 = 1e-4;

/// How friction acts on a held contact in this step's solve.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Friction {
    /// Holding: a tangential damping (N·s/m).
    Hold(f32),
    /// Sliding: Coulomb's impulse (N·s) against the motion.
    Slide(Vec3),
}

/// One contact held in this step's solve.
#[derive(Clone, Copy, Debug)]
struct Held {
    /// Index into `list`.
    index: usize,
    /// Normal spring constant, N/m.
    k: f32,
    /// The particle's mass, kg.
    mass: f32,
    /// The displacement the step gives the particle besides `γ Δv`, m.
    displacement: Vec3,
    /// How far into the surface that displacement would take it, m (the
    /// spring's stretch before `γ Δv`).
    reach: f32,
    /// The particle's velocity along the surface relative to it at the
    /// start of the step, m/s.
    along: Vec3,
    friction: Friction,
}

/// The contacts of a cloth's implicit solve, kept between steps.
#[derive(Clone, Debug, Default)]
pub struct ContactBuffers {
    /// This step's contacts, listed by the caller before the step.
    pub list: Vec<SolveContact>,
    /// How each particle was held in the last step.
    pub(super) hold: Vec<Hold>,
    /// Each particle's normal force in the last step (N; 0 when free).
    load: Vec<f32>,
    /// Whether any particle is held now (so `hold` needs clearing).
    pub(super) any: bool,
    /// This step's held contacts.
    held: Vec<Held>,
    /// `α`, `β` of this step's solve.
    factors: (f32, f32),
    /// The impulse (N·s) each held contact gave its particle in the last
    /// solve, with the contact's index in `list`.
    impulses: Vec<(u32, Vec3)>,
}

impl ContactBuffers {
    /// How particle `p` was held in the last step.
    pub fn hold(&self, p: usize) -> Hold {
        self.hold.get(p).copied().unwrap_or_default()
    }

    /// Whether the last step held any particle.
    pub fn any(&self) -> bool {
        self.any
    }

    /// Every particle's hold in the last step (empty when none was held).
    pub fn holds(&self) -> &[Hold] {
        if self.any { &self.hold } else { &[] }
    }

    /// The impulse (N·s) each contact of [`list`](Self::list) held in the
    /// last solve gave its particle: the normal spring's and the friction's,
    /// over the step (a pulling spring's too, so that momentum adds up). The
    /// collider feels the opposite.
    pub fn impulses(&self) -> impl Iterator<Item = (&SolveContact, Vec3)> + '_ {
        self.impulses
            .iter()
            .filter_map(|&(i, j)| self.list.get(i as usize).map(|c| (c, j)))
    }

    /// Forgets every hold (a reset, a teleport).
    pub fn clear(&mut self) {
        self.impulses.clear();
        self.hold.clear();
        self.load.clear();
        self.any = false;
    }

    /// Decides how this step holds its contacts, once the forces at the
    /// start of the step are known (`force`, N, total on each particle; `v`
    /// the velocities, m/s). `D = scale · displacement` is what the step
    /// moves each particle besides `γ Δv` (m; backward Euler: `h v₀`); `α`,
    /// `β` as in the solve, `β = αγ`; `h` the step (s). Returns whether any
    /// contact is held; [`emit`](Self::emit) gives the solve its terms.
    pub(super) fn begin(
        &mut self,
        inverse_masses: &[f32],
        force: &[Vec3],
        v: &[Vec3],
        (displacement, scale): (&[Vec3], f32),
        (alpha, beta, h): (f32, f32, f32),
    ) -> bool {
        let n = inverse_masses.len();
        self.held.clear();
        self.impulses.clear();
        self.factors = (alpha, beta);
        if self.list.is_empty() {
            self.clear();
            return false;
        }
        self.hold.resize(n, Hold::Free);
        self.load.resize(n, 0.0);
        let gamma = beta / alpha;
        for (index, c) in self.list.iter().enumerate() {
            let p = c.particle as usize;
            let w = match inverse_masses.get(p) {
                Some(&w) if w > 0.0 => w,
                _ => continue,
            };
            let d = scale * displacement[p];
            let pressure = -force[p].dot(c.normal);
            let reach = -c.gap - (d - h * c.velocity).dot(c.normal);
            // Outside and staying outside without the contact (its motion
            // and the forces carry it clear): not held.
            if c.gap >= 0.0 && -reach - h * h * w * pressure >= 0.0 {
                continue;
            }
            let relative = v[p] - c.velocity;
            let along = relative - relative.dot(c.normal) * c.normal;
            let speed = along.length();
            let load = self.load[p].max(pressure).max(0.0);
            // Sliding: Coulomb's force against the motion (`finish` stops
            // it rather than let it reverse). Otherwise held, by a damping
            // that lets it creep below the stick speed: a load past the
            // cone moves it faster than that, and it slides from the next
            // step on.
            // A body that gives way along the surface takes the friction in
            // series with its inertia there, as the normal spring does: it
            // never drives the two past moving together.
            let body = c.body_tangent_mass;
            let friction = if speed > STICK_SPEED {
                let kinetic = alpha * c.friction * load;
                Friction::Slide(kinetic.min(body * speed) / speed * along)
            } else {
                let damping = c.friction * load / STICK_SPEED;
                Friction::Hold(damping / (1.0 + alpha * damping / body))
            };
            self.held.push(Held {
                index,
                k: KAPPA / (w * gamma * gamma) / (1.0 + KAPPA / (w * c.body_mass)),
                mass: 1.0 / w,
                displacement: d,
                reach,
                along,
                friction,
            });
        }
        self.hold.fill(Hold::Free);
        self.load.fill(0.0);
        self.any = !self.held.is_empty();
        self.any
    }

    /// The solve's terms of the held contacts: each one's diagonal block
    /// `β k n nᵀ + α c (I − n nᵀ)` into `extra` (sorted by particle), and
    /// its right-hand side, `α k reach n` less the friction's impulse at
    /// the start of the step, through `rhs`.
    pub(super) fn emit(&self, extra: &mut Vec<(u32, [f32; 6])>, mut rhs: impl FnMut(usize, Vec3)) {
        let (alpha, beta) = self.factors;
        extra.clear();
        for held in &self.held {
            let c = &self.list[held.index];
            let p = c.particle as usize;
            // Holding, the damping's force at the start of the step is the
            // right-hand side's; its change is the block's.
            let (damping, kinetic) = match held.friction {
                Friction::Hold(damping) => (damping, alpha * damping * held.along),
                Friction::Slide(impulse) => (0.0, impulse),
            };
            rhs(p, alpha * held.k * held.reach * c.normal - kinetic);
            let (s, t) = (beta * held.k, alpha * damping);
            let m = c.normal;
            // s n nᵀ + t (I − n nᵀ), as xx, yy, zz, xy, xz, yz.
            extra.push((
                p as u32,
                [
                    t + (s - t) * m.x * m.x,
                    t + (s - t) * m.y * m.y,
                    t + (s - t) * m.z * m.z,
                    (s - t) * m.x * m.y,
                    (s - t) * m.x * m.z,
                    (s - t) * m.y * m.z,
                ],
            ));
        }
        extra.sort_unstable_by_key(|e| e.0);
    }

    /// After the solve: a kinetic friction that would have reversed a
    /// particle's sliding stops it instead (`x`, `v` at the end of the step,
    /// m and m/s); each held contact's force `λ` (module docs), and its
    /// hold for the next step. `dv` the solve's `Δv` (m/s), `γ` as in
    /// [`begin`](Self::begin), `h` the step (s).
    pub(super) fn finish(
        &mut self,
        (x, v): (&mut [Vec3], &mut [Vec3]),
        dv: impl Fn(usize) -> Vec3,
        (gamma, h): (f32, f32),
    ) {
        let alpha = self.factors.0;
        for held in &self.held {
            let c = self.list[held.index];
            let p = c.particle as usize;
            let reach = (held.displacement + gamma * dv(p) - h * c.velocity).dot(c.normal);
            let force = held.k * (-c.gap - reach);
            let relative = v[p] - c.velocity;
            let mut along = relative - relative.dot(c.normal) * c.normal;
            // The spring's impulse `α λ n` and the friction's: the damping's
            // on the final sliding velocity, or Coulomb's.
            let mut impulse = alpha * force * c.normal;
            match held.friction {
                Friction::Hold(damping) => impulse -= alpha * damping * along,
                Friction::Slide(kinetic) => impulse -= kinetic,
            }
            if let Friction::Slide(kinetic) = held.friction
                && along.dot(kinetic) < 0.0
            {
                // Friction took out more than the motion: it stops.
                impulse -= held.mass * along;
                v[p] -= along;
                x[p] -= gamma * along;
                along = Vec3::ZERO;
            }
            self.impulses.push((held.index as u32, impulse));
            if force <= 0.0 {
                // The spring held the particle back: it was leaving.
                continue;
            }
            self.load[p] = force;
            self.hold[p] = if along.length() < STICK_SPEED {
                Hold::Stick
            } else {
                Hold::Slide
            };
        }
    }
}
