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
}

mod solve;
