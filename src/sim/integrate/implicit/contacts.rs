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
//!   [`KAPPA`], `m` the particle's mass, or the mass its contact carries
//!   up to [`BODY_STIFFENING`] times that: against a free body its share of
//!   the body's mass, against a fixed surface, for a particle that also
//!   touches a body (under a dish on a tablecloth), its last load over
//!   [`LOAD_GRAVITY`]; `γ` the step's
//!   velocity-to-position factor, `h` for backward Euler), whose rest is
//!   the contact thickness: the solve keeps the particle on the surface to
//!   within `1/(1 + κ)` of its motion into it, and the rest of the cloth
//!   feels the support within the same step. This is the implicit penalty
//!   form of Baraff & Witkin's constraint, which leaves the conjugate
//!   gradient and its preconditioners as they are.
//! - **Friction**, by Coulomb's law with the normal force `λ` (N) the
//!   contact carried in the last step (or, new, the pressure of the forces
//!   on the particle now). A particle sliding along the surface faster than
//!   `v_ε` = [`STICK_SPEED`] feels the kinetic force `μ λ` against its
//!   motion (taking out at most the motion there is). A slower one is held
//!   by a tangential damping `c (I − n nᵀ)`, `c = μ λ / v_ε`, implicit and
//!   so stable at any step: a load within the cone `μ λ` leaves it creeping
//!   below `v_ε`; a larger one moves it faster, and it slides from the next
//!   step on (the lagged, smoothed friction of implicit contact solvers,
//!   after Bridson et al. 2002). A load far past the cone (the held
//!   friction more than [`GRIP_LIMIT`] times `μ λ`: a cloth yanked along a
//!   table) slides within the step: the step is solved again with that
//!   contact's friction at `μ λ`, or the cloth would stay behind its pulled
//!   edge for a step, stretched by the whole pull. A particle that ends a
//!   step sliding against the way its friction was set (pulled back the
//!   way it came) feels Coulomb's friction against its new slip.
//!
//! **A body that gives way.** A contact with a free body ([`SolveContact::body`],
//! one of [`ContactBuffers::bodies`]) holds its particle relative to the
//! body's surface, and the body moves within the same solve under all its
//! contacts' impulses at once, turning as well as moving (`bodies.rs`): a
//! heavy body holds the cloth as a fixed surface does, a light one is
//! pushed along, and a ball in a pocket is held by every side of it
//! together. Its sliding friction is a damping `μ λ / speed` as well, held
//! in step with the body, so friction never turns a light body past the
//! cloth. After the solve, two kinds of contact with a body are corrected
//! and the step solved again, until a pass corrects nothing (at most 8
//! passes; one correction can show the next, as under a plate on a
//! tablecloth over a table): a contact whose spring ends up pulling
//! the body (the particle was leaving it) is let go, and a body that
//! friction carried along faster than Coulomb's law allows (a cloth pulled
//! from under a plate) slides ([`GRIP_LIMIT`]). A particle leaving a body
//! pulled the body its way in that solve, and the cloth under the body
//! held it back: that friction is not friction carrying the body, so a
//! body's friction is judged with its leaving contacts' pulls, and in a
//! pass that lets a contact of a body go no contact with a fixed surface
//! slides (the next pass judges them without it). The caller applies the
//! impulses ([`ContactBuffers::impulses`]) to the body after the step.
//!
//! **Overlap with a body.** A particle the cloth lets give way (a
//! hammock's) found inside a body is brought out at up to
//! [`DEPENETRATION_SPEED`]: out in one step, it would fling the body. A
//! particle lying on a fixed surface under the body cannot give way, and
//! there an overlap taken out as velocity turns into motion that outlasts
//! it: a plate tipped by a tablecloth pulled from under it is pushed out at
//! its sunk rim, overshoots to the other, and rocks faster each step until
//! it is thrown. So the spring of such a contact takes only as much of the
//! overlap as the contact's last load explains (the depth at which it
//! carries that load), and the rest moves the body out, at up to
//! [`SEPARATION_SPEED`], by its position alone
//! ([`ContactBuffers::body_separation`]: a split impulse, shifting the body
//! without turning it), which the caller makes. A sliding contact of a body
//! whose Coulomb bound was set in a pass with a larger normal force than
//! the step ends with takes the smaller bound, and the step is solved
//! again.
//!
//! **A cloth lying on a surface under a body.** A particle lying on a fixed
//! surface (touching it, within [`SHEET_GAP`]) is a piece of sheet between
//! that surface and any body touching it from the other side, and the body
//! can only press it against the surface: its contact with the body takes
//! the surface's normal, reversed, whatever the body's nearest point says,
//! and its contact with the surface is held whether or not the forces on
//! it press it there yet (the body's weight presses it within the solve).
//! A plate's rim, sunk or tipped into the cloth's thickness, faces an
//! oncoming particle half sideways: a tablecloth yanked from under the
//! plate would push it along, and be held back by it, rather than slide
//! under it. A wall standing on the surface, level with the particle,
//! faces it sideways and keeps its normal ([`SHEET_FACING`]).
//!
//! After the solve the spring gives the contact force `λ` of the step: a
//! pulling one means the particle was leaving, and the spring held it back
//! for that step; it is not held again unless it comes back. Otherwise `λ`
//! sets the next step's friction.

use bevy::math::Vec3;

use super::bodies::Coupling;
pub use super::bodies::SolveBody;
use super::separate::{Overlap, push_out};

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
    /// contact's impulse.
    pub source: u32,
    /// The free body behind the surface, as an index into the bodies the
    /// hook gives, or `u32::MAX` for a surface that moves
    /// as it was going to whatever the cloth does.
    pub body: u32,
    /// Whether the particle is held as an end of a link whose point between
    /// its ends touches the surface: `normal`,
    /// `gap` and `velocity` are that point's. Its normal force is kept
    /// apart from the particle's own contact's, for its friction.
    pub edge: bool,
}

/// [`SolveContact::body`] of a surface with no free body behind it.
pub const NO_BODY: u32 = u32::MAX;

/// What a particle touches in this step ([`ContactBuffers::begin`]).
#[derive(Clone, Copy, Debug, Default)]
struct Touches {
    /// A free body.
    body: bool,
    /// The outward normal of the fixed surface it lies on (within
    /// [`SHEET_GAP`]), or zero.
    support: Vec3,
}

/// How the solve held a particle in the last step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Hold {
    /// Not held.
    #[default]
    Free,
    /// On the surface, sliding along it at 0.1 mm/s or more.
    Slide,
    /// On the surface, held by friction (slower than 0.1 mm/s).
    Stick,
}

/// Normal stiffness of a contact in units of the particle's mass over the
/// step squared (dimensionless, module docs).
pub const KAPPA: f32 = 1000.0;

/// The most a contact is stiffened over one with a fixed surface that
/// carries only its particle (dimensionless, module docs): beyond it, the
/// contact's force, the product of a stiffness and a stretch of a few
/// nanometres, loses its precision in `f32`.
pub const BODY_STIFFENING: f32 = 10.0;

/// The acceleration (m/s²) that turns a contact's load into the mass it
/// carries, for the stiffening of the contact with a fixed surface of a
/// particle squeezed between it and a body (standard gravity; module
/// docs).
pub const LOAD_GRAVITY: f32 = 9.81;

/// How far outside its contact thickness (m) a particle still lies on a
/// fixed surface, for a body's contact from the other side to press it
/// against that surface (module docs).
pub const SHEET_GAP: f32 = 1e-3;

/// How far a body's contact must face against the fixed surface a particle
/// lies on (the cosine between their normals, below its negative) to press
/// the particle against it: a wall standing on the surface, level with the
/// particle, keeps its own normal (module docs).
pub const SHEET_FACING: f32 = 0.05;

/// The fastest (m/s) a particle the cloth lets give way is brought out of a
/// free body it is found inside (module docs).
pub const DEPENETRATION_SPEED: f32 = 1.0;

/// The fastest (m/s) a free body pressing the cloth onto a fixed surface is
/// moved out of it (module docs): a wrinkle of a tablecloth yanked from
/// under a plate would otherwise lift the plate clear of the cloth in one
/// step and drop it back, tipped, onto the sliding cloth.
pub const SEPARATION_SPEED: f32 = 0.1;

/// The speed (m/s) below which friction holds rather than slides (module
/// docs): the fastest a particle whose load is within the friction cone can
/// creep.
pub const STICK_SPEED: f32 = 1e-4;

/// How far past its Coulomb bound a contact's holding friction (or that on
/// a free body, net across its weight) may go before it slides instead
/// (dimensionless; module docs). A held particle creeping at up to
/// `GRIP_LIMIT` times [`STICK_SPEED`] is left to the next step. On a body
/// the holds, stiffer than the normal springs, carry part of a ball's
/// weight in a pocket: at rest its net friction is 1.3 to 1.9 times its
/// bound, and across its weight up to about 1.3 times. A plate on a cloth
/// pulled from under it shows ten times and more.
pub const GRIP_LIMIT: f32 = 3.0;

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
    /// The particle's position at the start of the step, m.
    start: Vec3,
    /// The contact's gap (m, [`SolveContact::gap`]), or against a free
    /// body the part of it its spring takes (module docs).
    gap: f32,
    /// The part of an overlap with a free body its spring leaves to moving
    /// the body out, m (0 when none).
    overlap: f32,
    /// The displacement the step gives the particle besides `γ Δv`, m.
    displacement: Vec3,
    /// How far into the surface that displacement would take it, m (the
    /// spring's stretch before `γ Δv`).
    reach: f32,
    /// The free body it holds against, and the particle's offset from the
    /// body's centre of mass (m).
    body: Option<(u32, Vec3)>,
    /// The particle's velocity along the surface relative to it at the
    /// start of the step, m/s.
    along: Vec3,
    friction: Friction,
}

impl Held {
    /// The normal force (N) of the spring of contact `c` at the end of the
    /// step, given the particle's velocity change relative to the surface
    /// (`Δv` less the body's surface change, m/s); `γ`, `h` (s) as for
    /// [`ContactBuffers::finish`]. Negative when it pulls.
    fn force(&self, c: &SolveContact, change: Vec3, (gamma, h): (f32, f32)) -> f32 {
        let reach = (self.displacement + gamma * change - h * c.velocity).dot(c.normal);
        self.k * (-self.gap - reach)
    }
}

/// The contacts of a cloth's implicit solve, kept between steps.
#[derive(Clone, Debug, Default)]
pub struct ContactBuffers {
    /// This step's contacts, listed by the caller before the step. The
    /// step may turn the normal of a body's contact with a particle lying
    /// on a fixed surface (module docs).
    pub list: Vec<SolveContact>,
    /// The free bodies behind them ([`SolveContact::body`]), listed by the
    /// caller with them.
    pub bodies: Vec<SolveBody>,
    /// How each particle was held in the last step.
    pub(super) hold: Vec<Hold>,
    /// Each particle's normal force in the last step (N; 0 when free): of
    /// its own contact, and of its edge contact.
    load: Vec<[f32; 2]>,
    /// Whether any particle is held now (so `hold` needs clearing).
    pub(super) any: bool,
    /// This step's held contacts.
    held: Vec<Held>,
    /// `α`, `β` and the step `h` (s) of this step's solve.
    factors: (f32, f32, f32),
    /// Each body's velocity change in the last solve: linear (m/s) and
    /// angular (rad/s), by index into `bodies` (zero for one not moved).
    changes: Vec<[Vec3; 2]>,
    /// Scratch: the coupled contacts by body, and each body's count of
    /// contacts (in `begin`) or Coulomb bound `Σ α μ λ` (N·s, in `revise`).
    links: Vec<(u32, u32, [f32; 6], Vec3, Vec3)>,
    counts: Vec<f32>,
    /// Scratch of [`begin`](Self::begin): what each particle touches
    /// (nothing again after it).
    touches: Vec<Touches>,
    /// Scratch of [`revise`](Self::revise): each held contact's normal
    /// force (N) and holding friction's impulse (N·s), and each body's net
    /// friction impulse (N·s).
    grips: Vec<(f32, Vec3)>,
    net: Vec<Vec3>,
    /// The impulse (N·s) each held contact gave its particle in the last
    /// solve, with the contact's index in `list`.
    impulses: Vec<(u32, Vec3, Vec3)>,
    /// Scratch of [`finish`](Self::finish): the velocity changes (m/s) its
    /// stops gave particles after the solve.
    stops: Vec<(u32, Vec3)>,
    /// Scratch of [`finish`](Self::finish): the contacts whose overlap moves
    /// their body out, with the body, one body's, and their pushes.
    overlaps: Vec<(u32, Overlap)>,
    scratch: Vec<Overlap>,
    pushes: Vec<f32>,
    /// Each body's shift (m) out of the cloth after the last solve, by
    /// index into `bodies`.
    separations: Vec<Vec3>,
}

/// The velocity change (m/s) `stops` gave particle `p`.
fn stopped(stops: &[(u32, Vec3)], p: usize) -> Vec3 {
    stops
        .iter()
        .filter(|s| s.0 as usize == p)
        .map(|s| s.1)
        .sum()
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

    /// Whether this step has no contact to hold and the last held none: its
    /// solve is the cloth's alone.
    pub fn none(&self) -> bool {
        self.list.is_empty() && !self.any
    }

    /// Every particle's hold in the last step (empty when none was held).
    pub fn holds(&self) -> &[Hold] {
        if self.any { &self.hold } else { &[] }
    }

    /// The impulse (N·s) each contact of [`list`](Self::list) held in the
    /// last solve gave its particle: the normal spring's and the friction's,
    /// over the step (a pulling spring's too, so that momentum adds up),
    /// with the point where it acted: the particle at the start of the step
    /// (m), as the solve turned a free body about it. The collider feels
    /// the opposite.
    pub fn impulses(&self) -> impl Iterator<Item = (&SolveContact, Vec3, Vec3)> + '_ {
        self.impulses
            .iter()
            .filter_map(|&(i, j, at)| self.list.get(i as usize).map(|c| (c, j, at)))
    }

    /// The velocity change the last solve gave body `body` (an index into
    /// [`bodies`](Self::bodies)), gravity included: linear (m/s) and
    /// angular (rad/s); zero for a body it did not move.
    pub fn body_change(&self, body: usize) -> [Vec3; 2] {
        self.changes.get(body).copied().unwrap_or([Vec3::ZERO; 2])
    }

    /// The shift (m) out of the cloth the last solve's overlaps call for of
    /// body `body` (an index into [`bodies`](Self::bodies)), to be made to
    /// its position without any change to its velocity; zero for a body
    /// that does not overlap the cloth more than its load explains (module
    /// docs).
    pub fn body_separation(&self, body: usize) -> Vec3 {
        self.separations.get(body).copied().unwrap_or(Vec3::ZERO)
    }

    /// Forgets every hold (a reset, a teleport).
    pub fn clear(&mut self) {
        self.impulses.clear();
        self.changes.clear();
        self.separations.clear();
        self.hold.clear();
        self.load.clear();
        self.any = false;
    }

    /// Decides how this step holds its contacts, once the forces at the
    /// start of the step are known (`force`, N, total on each particle; `x`,
    /// `v` the positions and velocities, m and m/s). `D = scale ·
    /// displacement` is what the step moves each particle besides `γ Δv`
    /// (m; backward Euler: `h v₀`); `α`, `β` as in the solve, `β = αγ`; `h`
    /// the step (s). Returns whether any contact is held;
    /// [`emit`](Self::emit) gives the solve its terms.
    pub(super) fn begin(
        &mut self,
        inverse_masses: &[f32],
        force: &[Vec3],
        (x, v): (&[Vec3], &[Vec3]),
        (displacement, scale): (&[Vec3], f32),
        (alpha, beta, h): (f32, f32, f32),
    ) -> bool {
        let n = inverse_masses.len();
        self.held.clear();
        self.impulses.clear();
        self.changes.clear();
        self.separations.clear();
        self.factors = (alpha, beta, h);
        if self.list.is_empty() {
            self.clear();
            return false;
        }
        self.hold.resize(n, Hold::Free);
        self.load.resize(n, [0.0; 2]);
        self.count_touches(n);
        self.press_sheets();
        let gamma = beta / alpha;
        for (index, c) in self.list.iter().enumerate() {
            let p = c.particle as usize;
            let w = match inverse_masses.get(p) {
                Some(&w) if w > 0.0 => w,
                _ => continue,
            };
            let d = scale * displacement[p];
            let pressure = -force[p].dot(c.normal);
            let body = self
                .bodies
                .get(c.body as usize)
                .filter(|b| b.is_usable())
                .map(|b| (c.body, x[p] - b.centre, b));
            let reach = -c.gap - (d - h * c.velocity).dot(c.normal);
            // Outside and staying outside without the contact (its motion
            // and the forces carry it clear): not held. Unless it lies on a
            // fixed surface under a body, whose weight presses it within
            // the solve.
            let under_body = body.is_none() && self.touches[p].body && c.gap <= SHEET_GAP;
            if c.gap >= 0.0 && -reach - h * h * w * pressure >= 0.0 && !under_body {
                continue;
            }
            let relative = v[p] - c.velocity;
            let along = relative - relative.dot(c.normal) * c.normal;
            let speed = along.length();
            let load = self.load[p][c.edge as usize].max(pressure).max(0.0);
            // Sliding: Coulomb's force against the motion (`finish` stops
            // it rather than let it reverse). Otherwise held, by a damping
            // that lets it creep below the stick speed: a load past the
            // cone moves it faster than that, and it slides from the next
            // step on. On a free body the sliding force is a damping too,
            // `μ λ / speed`, which the solve holds in step with the body:
            // as an impulse fixed at the start of the step it would turn a
            // light body past the cloth, and back the next step.
            let friction = if speed > STICK_SPEED && body.is_none() {
                let kinetic = alpha * c.friction * load;
                Friction::Slide(kinetic / speed * along)
            } else {
                Friction::Hold(c.friction * load / speed.max(STICK_SPEED))
            };
            // Against a free body the spring takes the body's share of its
            // mass, up to [`BODY_STIFFENING`] times the particle's, so that
            // the body's weight does not press a spring sized for a particle
            // of cloth far into it (a 5 kg ball on 11 contacts of 0.8 g
            // particles: 0.16 mm rather than 1.6 mm). A particle squeezed
            // between a fixed surface and a body carries the body's weight
            // to that surface: its contact there takes the mass its load
            // stands for ([`LOAD_GRAVITY`]), as far, or sized for the
            // particle alone it would let a dish on a tablecloth sink into
            // the cloth's thickness and tip (a 0.9 kg bottle on a 2.5 cm
            // grid: 2.6 mm). A cloth pressed by a fixed surface alone (a
            // ball pushed into a hammock) keeps its spring: stiffened by
            // the cloth's tension, it would jolt the cloth as it lands.
            let stiffening = match body {
                Some((k, _, b)) => b.mass * w / self.counts[k as usize],
                None if self.touches[p].body => load * w / LOAD_GRAVITY,
                None => 1.0,
            }
            .clamp(1.0, BODY_STIFFENING);
            let k = stiffening * KAPPA / (w * gamma * gamma);
            // Against a free body pressing the particle onto a fixed
            // surface the spring takes as much of an overlap as its last
            // load explains (the depth at which it carries that load), and
            // the rest moves the body out (`separate.rs`). Against one the
            // cloth can give way to, it takes the overlap out at up to
            // DEPENETRATION_SPEED: out in one step, it would fling the body
            // (a light ball squeezed into the cloth by a heavy one).
            let gap = match body {
                Some(_) if self.touches[p].support != Vec3::ZERO => c.gap.max(-load / k),
                Some(_) => c.gap.max(-DEPENETRATION_SPEED * h),
                None => c.gap,
            };
            let reach = reach + c.gap - gap;
            self.held.push(Held {
                index,
                k,
                mass: 1.0 / w,
                start: x[p],
                gap,
                overlap: gap - c.gap,
                displacement: d,
                reach,
                body: body.map(|(k, r, _)| (k, r)),
                along,
                friction,
            });
        }
        self.forget_touches();
        self.any = !self.held.is_empty();
        self.any
    }

    /// Counts the contacts of each free body (each shows its share of the
    /// body's mass along the surface to sliding friction) and marks what
    /// each of the `n` particles touches: a body, or a fixed surface it
    /// lies on.
    fn count_touches(&mut self, n: usize) {
        self.counts.clear();
        self.counts.resize(self.bodies.len(), 0.0);
        self.touches.resize(n, Touches::default());
        for c in &self.list {
            let Some(touches) = self.touches.get_mut(c.particle as usize) else {
                continue;
            };
            if let Some(count) = self.counts.get_mut(c.body as usize) {
                *count += 1.0;
                touches.body = true;
            } else if c.body == NO_BODY && !c.edge && c.gap <= SHEET_GAP {
                touches.support = c.normal;
            }
        }
    }

    /// Clears what [`begin`](Self::begin) marked per particle (touches,
    /// holds, loads) for the next step.
    fn forget_touches(&mut self) {
        for c in &self.list {
            if let Some(touches) = self.touches.get_mut(c.particle as usize) {
                *touches = Touches::default();
            }
        }
        self.hold.fill(Hold::Free);
        self.load.fill([0.0; 2]);
    }

    /// Turns the contact of a body with a particle lying on a fixed surface
    /// (touching it, within [`SHEET_GAP`]: [`Touches::support`]) from the
    /// other side to that surface's normal, reversed (module docs).
    fn press_sheets(&mut self) {
        for c in self.list.iter_mut().filter(|c| c.body != NO_BODY) {
            let support = self.touches.get(c.particle as usize).map(|t| t.support);
            if let Some(support) = support.filter(|&s| c.normal.dot(s) < -SHEET_FACING) {
                c.normal = -support;
            }
        }
    }

    /// The solve's terms of the held contacts: each one's diagonal block
    /// `β k n nᵀ + α c (I − n nᵀ)` into `extra` (sorted by particle), the
    /// free bodies' terms into `coupling`, and its right-hand side, `α k
    /// reach n` less the friction's impulse at the start of the step (and
    /// its body's share), through `rhs`.
    pub(super) fn emit(
        &mut self,
        extra: &mut Vec<(u32, [f32; 6])>,
        coupling: &mut Coupling,
        mut rhs: impl FnMut(usize, Vec3),
    ) {
        let (alpha, beta, h) = self.factors;
        extra.clear();
        self.links.clear();
        for held in &self.held {
            let c = &self.list[held.index];
            let p = c.particle as usize;
            // Holding, the damping's force at the start of the step is the
            // right-hand side's; its change is the block's.
            let (damping, kinetic) = match held.friction {
                Friction::Hold(damping) => (damping, alpha * damping * held.along),
                Friction::Slide(impulse) => (0.0, impulse),
            };
            let b = alpha * held.k * held.reach * c.normal - kinetic;
            rhs(p, b);
            let (s, t) = (beta * held.k, alpha * damping);
            let m = c.normal;
            // s n nᵀ + t (I − n nᵀ), as xx, yy, zz, xy, xz, yz.
            let block = [
                t + (s - t) * m.x * m.x,
                t + (s - t) * m.y * m.y,
                t + (s - t) * m.z * m.z,
                (s - t) * m.x * m.y,
                (s - t) * m.x * m.z,
                (s - t) * m.y * m.z,
            ];
            extra.push((p as u32, block));
            if let Some((body, r)) = held.body {
                self.links.push((body, p as u32, block, r, b));
            }
        }
        extra.sort_unstable_by_key(|e| e.0);
        self.links.sort_by_key(|l| l.0);
        coupling.build(&self.bodies, self.links.iter().copied(), h);
        coupling.rhs(rhs);
    }

    /// After a solve, the contacts it got wrong, for the step to be solved
    /// again with them corrected:
    ///
    /// - a held contact with a fixed surface whose friction took more than
    ///   [`GRIP_LIMIT`] times its bound `μ λ` slides, with that bound, in
    ///   the direction its friction acted;
    /// - a contact with a free body whose spring ended up pulling (the
    ///   particle was leaving the body; held, it would pull the body along)
    ///   is let go;
    /// - a body whose contacts' holding friction, net across its weight
    ///   (its engine's acceleration), took more than [`GRIP_LIMIT`] times
    ///   its Coulomb bound `Σ μ λ` (a cloth pulled from under it faster than
    ///   friction can carry it) slides: each of its contacts past its own
    ///   bound `μ λ` takes that bound, in the direction its friction acted.
    ///   Held by a damping sized for creeping, the body would be carried
    ///   along with the cloth at any speed;
    /// - a contact with a body sliding with more than [`GRIP_LIMIT`] times
    ///   its bound (set in a pass with a larger normal force) takes its
    ///   bound.
    ///
    /// A body's friction is judged with the pulls of its contacts that let
    /// go, which that friction held back; in a pass that lets a contact of
    /// a body go, no contact with a fixed surface slides.
    ///
    /// `v` each particle's velocity at the end of the solve (m/s), `dv` the
    /// solve's `Δv` (m/s), `coupling` the free bodies' velocity changes, `γ`
    /// and `h` (s) as for [`finish`](Self::finish). Returns whether any
    /// contact changed.
    pub(super) fn revise(
        &mut self,
        v: impl Fn(usize) -> Vec3,
        dv: impl Fn(usize) -> Vec3,
        coupling: &Coupling,
        (gamma, h): (f32, f32),
    ) -> bool {
        let alpha = self.factors.0;
        // Each held contact's normal force (N) and holding friction's
        // impulse (N·s); each body's net friction impulse and its bound.
        self.grips.clear();
        self.counts.clear();
        self.counts.resize(self.bodies.len(), 0.0);
        self.net.clear();
        self.net.resize(self.bodies.len(), Vec3::ZERO);
        for held in &self.held {
            let c = &self.list[held.index];
            let p = c.particle as usize;
            let moved = held
                .body
                .map_or(Vec3::ZERO, |(body, r)| coupling.surface_change(body, r));
            let force = held.force(c, dv(p) - moved, (gamma, h));
            let grip = match held.friction {
                Friction::Hold(damping) => {
                    let relative = v(p) - c.velocity - moved;
                    alpha * damping * (relative - relative.dot(c.normal) * c.normal)
                }
                Friction::Slide(_) => Vec3::ZERO,
            };
            if let Some((body, _)) = held.body {
                // A leaving particle's spring pulls the body its way, and
                // the friction under the body that holds it back is not
                // friction carrying the body: counted with that pull, it
                // adds up to what moves the body. (`grip` is the impulse
                // friction gives the body.)
                let pull = -alpha * force.min(0.0) * c.normal;
                self.net[body as usize] += grip + pull;
                self.counts[body as usize] += alpha * c.friction * force.max(0.0);
            }
            self.grips.push((force, grip));
        }
        // Friction along the body's weight is in part the support its
        // contacts' stiff holds carry of it at rest in a pocket; what is
        // across the weight is friction carrying the body along.
        for (net, body) in self.net.iter_mut().zip(&self.bodies) {
            let down = body.acceleration.normalize_or_zero();
            *net -= net.dot(down) * down;
        }
        // Where a contact lets go of a body, the cloth under the body was
        // held in this solve by the frictions its pull set up: a table's
        // contacts slide only once the step is solved without it.
        let leaving = self
            .held
            .iter()
            .zip(&self.grips)
            .any(|(held, &(force, _))| held.body.is_some() && force < 0.0);
        let list = &self.list;
        let (net, counts) = (&self.net, &self.counts);
        let mut changed = false;
        let mut grips = self.grips.iter();
        self.held.retain_mut(|held| {
            let &(force, grip) = grips.next().expect("one grip a held contact");
            let bound = alpha * list[held.index].friction * force;
            let Some((body, _)) = held.body else {
                if !leaving && force > 0.0 && grip.length() > GRIP_LIMIT * bound {
                    held.friction = Friction::Slide(grip * (bound / grip.length()));
                    changed = true;
                }
                return true;
            };
            if force < 0.0 {
                changed = true;
                return false;
            }
            let b = body as usize;
            match held.friction {
                Friction::Hold(_)
                    if net[b].length() > GRIP_LIMIT * counts[b] && grip.length() > bound =>
                {
                    held.friction = Friction::Slide(grip * (bound / grip.length()));
                    changed = true;
                }
                // Sliding, with a bound set by a pass whose normal force has
                // fallen since.
                Friction::Slide(kinetic) if kinetic.length() > GRIP_LIMIT * bound => {
                    held.friction = Friction::Slide(kinetic * (bound / kinetic.length()));
                    changed = true;
                }
                _ => {}
            }
            true
        });
        self.any = !self.held.is_empty();
        changed
    }

    /// After the solve: a kinetic friction that would have reversed a
    /// particle's sliding stops it instead (`x`, `v` at the end of the step,
    /// m and m/s); each held contact's force `λ` (module docs), and its
    /// hold for the next step. `dv` the solve's `Δv` (m/s), `coupling`
    /// the free bodies' velocity changes, `γ` as in [`begin`](Self::begin),
    /// `h` the step (s).
    pub(super) fn finish(
        &mut self,
        (x, v): (&mut [Vec3], &mut [Vec3]),
        dv: impl Fn(usize) -> Vec3,
        coupling: &Coupling,
        (gamma, h): (f32, f32),
    ) {
        let alpha = self.factors.0;
        self.stops.clear();
        self.changes.clear();
        self.changes
            .extend((0..self.bodies.len() as u32).map(|b| coupling.change(b)));
        for held in &self.held {
            let c = self.list[held.index];
            let p = c.particle as usize;
            // The surface moved with the body's velocity change too.
            let moved = held
                .body
                .map_or(Vec3::ZERO, |(body, r)| coupling.surface_change(body, r));
            let force = held.force(&c, dv(p) - moved, (gamma, h));
            // A body's friction is what the solve gave it: a particle that
            // another contact stopped after the solve (squeezed between a
            // table and a plate) does not drag the body by its holding
            // damping's stiffness times that stop.
            let solved = match held.body {
                Some(_) => v[p] - stopped(&self.stops, p),
                None => v[p],
            };
            let relative = solved - c.velocity - moved;
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
                // The particle ends sliding against the way it was going,
                // and friction, fixed against the old way, pushed it on.
                // Coulomb's law with the slip the rest of the step gave it:
                // it stops if friction can take that out, and slides on
                // with friction against it otherwise (the cloth pulled it
                // the other way).
                let free = along + kinetic / held.mass;
                let stop = kinetic.length() / held.mass;
                let end = if free.length() <= stop {
                    Vec3::ZERO
                } else {
                    free - stop * free.normalize()
                };
                let change = end - along;
                impulse += held.mass * change;
                v[p] += change;
                x[p] += gamma * change;
                self.stops.push((p as u32, change));
                along = end;
            }
            self.impulses.push((held.index as u32, impulse, held.start));
            if let Some((body, _)) = held.body {
                let depth = held.overlap.min(SEPARATION_SPEED * h);
                if depth > 0.0 {
                    self.overlaps.push((
                        body,
                        Overlap {
                            normal: c.normal,
                            depth,
                        },
                    ));
                }
            }
            if force <= 0.0 {
                // The spring held the particle back: it was leaving.
                continue;
            }
            // A particle squeezed between a surface and a body has two
            // contacts: the larger load, and sliding if either slides.
            let load = &mut self.load[p][c.edge as usize];
            *load = load.max(force);
            self.hold[p] = if along.length() < STICK_SPEED && self.hold[p] != Hold::Slide {
                Hold::Stick
            } else {
                Hold::Slide
            };
        }
        self.separate();
    }

    /// Each body's shift out of its contacts' overlaps ([`push_out`]), into
    /// `separations`.
    fn separate(&mut self) {
        self.separations.clear();
        self.separations.resize(self.bodies.len(), Vec3::ZERO);
        if self.overlaps.is_empty() {
            return;
        }
        self.overlaps.sort_unstable_by_key(|o| o.0);
        for group in self.overlaps.chunk_by(|a, b| a.0 == b.0) {
            let body = group[0].0 as usize;
            let Some(out) = self.separations.get_mut(body) else {
                continue;
            };
            self.scratch.clear();
            self.scratch.extend(group.iter().map(|o| o.1));
            *out = push_out(&self.scratch, &mut self.pushes);
        }
        self.overlaps.clear();
    }
}
