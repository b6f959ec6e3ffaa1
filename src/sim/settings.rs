//! [`SimSettings`]: force model, integrator, material constants, the guard,
//! adaptive substeps and stepping: every parameter of a step.
//!
//! In an app, the `ClothSettingsDefaults` resource holds the settings every cloth
//! uses and a `ClothSettings` component on a cloth overrides them; both wrap
//! a `SimSettings`. Everything reflects, so an inspector can edit it live.

use bevy::math::Vec3;
use bevy::reflect::Reflect;
use bevy::reflect::std_traits::ReflectDefault;

use crate::error::ClothError;
pub use crate::sim::sleep::SleepSettings;

/// Which internal force model a cloth uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum ClothModel {
    /// Choi & Ko (2002) as in the paper: tension-only Type 1 links and
    /// buckling Type 2 links (MODEL.md §2–§3).
    #[default]
    ChoiKo,
    /// Lander (1999): two-sided damped springs, structural, shear and ±2
    /// axial bend (MODEL.md §7); the paper's baseline.
    Lander,
}

/// Which time integrator advances a cloth (MODEL.md §6).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum Integrator {
    /// The paper's explicit Euler (eq. 6): positions move with the *old*
    /// velocity. Stable only for `dt ≤ c/ω²` (MODEL.md §6.1); kept to
    /// reproduce the paper, not for games.
    ExplicitEuler,
    /// Symplectic Euler: positions move with the *new* velocity. Same cost
    /// as explicit Euler, stable for `dt ≲ 2/ω_max` (MODEL.md §6.2).
    SymplecticEuler,
    /// Classical Runge–Kutta, 4 force evaluations a step, stable for
    /// `dt ≲ 2.83/ω_max` (MODEL.md §6.3).
    Rk4,
    /// Linearised backward Euler (Baraff–Witkin, MODEL.md §6.5): one linear
    /// solve a step, stable at any step; first order. The default: one step
    /// per fixed step holds any cloth, and its numerical damping takes the
    /// energy out of a yank or a storm.
    #[default]
    BackwardEuler,
    /// Second-order BDF, what Choi & Ko used (MODEL.md §6.6): one linear
    /// solve a step, stable at any step; second order. Its first step (and
    /// any step after the state was changed from outside) is backward Euler.
    Bdf2,
}

impl Integrator {
    /// Every integrator, in the order the tables list them.
    pub const ALL: [Integrator; 5] = [
        Self::ExplicitEuler,
        Self::SymplecticEuler,
        Self::Rk4,
        Self::BackwardEuler,
        Self::Bdf2,
    ];

    /// The explicit integrators (no linear solve).
    pub const EXPLICIT: [Integrator; 3] = [Self::ExplicitEuler, Self::SymplecticEuler, Self::Rk4];

    /// Whether a step solves a linear system.
    pub fn is_implicit(self) -> bool {
        matches!(self, Self::BackwardEuler | Self::Bdf2)
    }

    /// A short name for tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Self::ExplicitEuler => "explicit_euler",
            Self::SymplecticEuler => "symplectic_euler",
            Self::Rk4 => "rk4",
            Self::BackwardEuler => "backward_euler",
            Self::Bdf2 => "bdf2",
        }
    }
}

/// Which Type 2 Jacobian the implicit integrators use (MODEL.md §3.7).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum Type2Jacobian {
    /// Axial term only, `(df*/dℓ) P_u`: always positive semidefinite (as
    /// Blender does). The default.
    #[default]
    Axial,
    /// Axial plus the (negative) transverse term `(f*/ℓ) P_⊥`: the exact
    /// derivative, indefinite for sharp folds.
    Full,
}

/// Whether a slack Type 1 link keeps its axial stiffness `k P_u` in the
/// implicit solve while its force is 0 (MODEL.md §2).
///
/// Keeping it stops a large step from overshooting a slack link deep into
/// tension (a 1/30 s drop test strained 112 % without it, 7 % with it), but
/// it is not the derivative of the force, so at small steps it costs
/// accuracy (measured: 15× the error at 1e-4 s on the paper's cloth).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum SlackStiffness {
    /// Keep it when the step cannot resolve the stiffest spring,
    /// `h·√(k·max(1/m)) > 1`; drop it otherwise. The default.
    #[default]
    Auto,
    /// Always keep it.
    Keep,
    /// Never keep it (the exact derivative).
    Drop,
}

/// Most past solutions the implicit solve's starting guess may combine
/// ([`ImplicitSettings::past_solutions`]).
pub(crate) const MAX_PAST_SOLUTIONS: u32 = 8;

/// Settings of the implicit integrators' linear solve.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Default)]
pub struct ImplicitSettings {
    /// Relative tolerance ε of the preconditioned conjugate gradient: stop
    /// when `rᵀP⁻¹r ≤ ε² bᵀP⁻¹b` (dimensionless; MODEL.md §6.5 uses 1e-3).
    /// `rᵀP⁻¹r` is close to the error's energy `Σ m|δv|² + Σ k δℓ²` (J):
    /// the solve stops once its error is worth a thousandth of the step's
    /// velocity change (docs/architecture.md, "The implicit solve").
    pub tolerance: f32,
    /// Absolute tolerance of the solve in m/s: it also stops once the
    /// error is worth no more than the whole cloth moving at this speed
    /// (`rᵀP⁻¹r ≤ v_tol² Σm`). A cloth at or near rest asks for almost no
    /// change, and the relative tolerance alone would then chase digits
    /// that move nothing: the default 1 mm/s is 17 µm in a 1/60 s step. A
    /// cloth draped on a ball then needs about a quarter of the iterations
    /// while it settles, and the same drape (tested).
    pub velocity_tolerance: f32,
    /// Most conjugate-gradient iterations per step.
    pub max_iterations: u32,
    /// How many of the last steps' velocity changes the solve's starting
    /// guess combines (0 to 8): the combination
    /// closest to this step's solution in the solve's energy norm (a
    /// Galerkin projection). A cloth in motion repeats much of its last
    /// steps' motion (its fall, its swing, a fold flapping back and forth
    /// from one step to the next), so the solve starts most of the way
    /// there, and then searches only across them; a cloth in pieces (torn,
    /// cut) takes a combination of its own on each piece. It costs one
    /// product with the step's matrix per kept solution, so it is used
    /// once a solve has taken four fifths of
    /// [`max_iterations`](Self::max_iterations) and until 30 solves in a
    /// row take less than a quarter: a cloth whose solves stay short (at
    /// rest, swinging gently) starts from the last step's solution alone,
    /// as with 0. A cloth hung from its centre, or the pieces of a cut
    /// one, take about half the iterations and their solves off the cap
    /// (docs/architecture.md, "The starting guess"). 4 by default; 0 turns
    /// it off.
    pub past_solutions: u32,
    /// Type 2 Jacobian.
    pub type2_jacobian: Type2Jacobian,
    /// Slack Type 1 stiffness.
    pub slack_stiffness: SlackStiffness,
    /// Whether the preconditioner adds a coarse correction: for grid cloths of
    /// at least 4×4 a multigrid V-cycle over squares of 2 × 2 particles,
    /// 4 × 4 and so on, which keeps the iterations of a cloth in motion
    /// about the same from 32×32 to 256×256 (13 to 25 a frame); for mesh
    /// cloths of at least 64 particles a V-cycle over groups of about 12
    /// linked particles that move rigidly (a translation and a rotation
    /// each), 4 groups and so on (35 → 10 iterations a step on a
    /// 3,997-particle disc).
    /// Smaller cloths solve without it. On by default. It costs more than
    /// it saves where solves are short (small cloths, cloths kept awake at
    /// rest), but without it the solve's stopping rule undercounts slow,
    /// whole-cloth motion: a cloth lying on a turning board slides off its
    /// place (docs/performance.md, "Where the solver's machinery pays").
    pub coarse_grid: bool,
    /// Whether a grid cloth of at least 2048 particles shares the passes
    /// of its conjugate gradient with a helper thread: on a 2-core x86-64
    /// a 64×64 solve takes about 1.2 ms rather than 2. It
    /// also lets such a cloth, with any integrator, resolve its contacts in
    /// two halves on the two threads.
    /// The result is bitwise the same either way. On by default.
    pub helper_thread: bool,
    /// Most extra Newton iterations of a step whose end state strains a Type 1 link past
    /// [`newton_strain`](Self::newton_strain): a step that moves the cloth
    /// far from where its forces were linearised (a storm's first gust on
    /// a slack sheet) is solved again where it ended, before the
    /// [`strain_limit`](Self::strain_limit) applies. 0 (the default) turns
    /// them off: each is a solve of its own, ten times tighter, and one
    /// that starts far from the solution can diverge (it is then undone),
    /// while the strain limit holds the strain for a few sweeps over the
    /// links.
    pub newton_iterations: u32,
    /// The Type 1 strain (dimensionless) above which a step gets its extra
    /// Newton iterations, if it also grew by a fifth since the last step;
    /// their solves use tolerances ten times tighter (relative 0.1 of the
    /// step's own).
    /// 5 % by default.
    pub newton_strain: f32,
    /// The largest Type 1 strain (dimensionless) an implicit step may leave
    /// links stretched past it
    /// at the end of a step are shortened to it and their particles'
    /// velocities follow, unless the solve held contacts that step. The
    /// step is linearised where it starts, so a stiff or fine sheet let go
    /// horizontal would stretch the links at its pins far past what its
    /// forces allow (a fifth at 256×256). Where the sweeps cannot bring the
    /// links to it and take less than half the worst excess off (links
    /// held stretched between pinned or grabbed particles, as a player's
    /// drag does), the step stands as the solve left it. 5 % by default;
    /// `f32::INFINITY` turns it off. A cloth with
    /// [`ClothTearing`](crate::plugin::tearing::tear::ClothTearing) is not limited:
    /// its threads must be free to reach their tear strain (15 % for
    /// cotton), and the guard's strain-spike rule takes its place.
    pub strain_limit: f32,
}

impl Default for ImplicitSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-3,
            velocity_tolerance: 1e-3,
            max_iterations: 100,
            past_solutions: 4,
            type2_jacobian: Type2Jacobian::Axial,
            slack_stiffness: SlackStiffness::Auto,
            coarse_grid: true,
            helper_thread: true,
            newton_iterations: 0,
            newton_strain: 0.05,
            strain_limit: 0.05,
        }
    }
}

/// Choi–Ko constants per link (MODEL.md §11 defaults: cotton, 1 m, 15×15).
///
/// These are the raw per-link constants; a cloth whose
/// [`ClothMaterial`](crate::plugin::spawn::material::ClothMaterial) is a fabric gets them
/// from the fabric and its spacing instead.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Default)]
pub struct ChoiKoSettings {
    /// Spring constant `k` in N/m of the Type 1 links along the grid
    /// (structural) and of crease springs.
    pub stiffness: f32,
    /// Spring constant in N/m of the diagonal Type 1 links (shear).
    pub shear_stiffness: f32,
    /// Flexural rigidity `k_b` of the Type 2 links in N·m².
    pub bending_rigidity: f32,
    /// Slope `c_b` of the linear pre-buckling ramp in N/m (paper eq. 4; the
    /// paper sets it to about `k`).
    pub buckling_slope: f32,
    /// Axial pair damping `k_d` on taut Type 1 links in N·s/m (MODEL.md §4);
    /// 0 turns it off.
    pub pair_damping: f32,
}

impl Default for ChoiKoSettings {
    fn default() -> Self {
        Self {
            stiffness: 1000.0,
            shear_stiffness: 1000.0,
            bending_rigidity: 5e-7,
            buckling_slope: 1000.0,
            pair_damping: 0.05,
        }
    }
}

/// One family of Lander springs.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct SpringSettings {
    /// Spring constant `k_s` in N/m.
    pub stiffness: f32,
    /// Axial damping `k_d` in N·s/m.
    pub damping: f32,
}

/// Lander's three spring families (MODEL.md §7).
///
/// The defaults keep his demo's ratios (bend = 0.6 × structural) scaled to
/// the Choi–Ko default `k` = 1000 N/m, so the two models compare at the same
/// stretch stiffness.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Default)]
pub struct LanderSettings {
    /// ±1 axial springs.
    pub structural: SpringSettings,
    /// ±1 diagonal springs.
    pub shear: SpringSettings,
    /// ±2 axial springs.
    pub bend: SpringSettings,
}

impl Default for LanderSettings {
    fn default() -> Self {
        let spring = |stiffness| SpringSettings {
            stiffness,
            damping: 0.05,
        };
        Self {
            structural: spring(1000.0),
            shear: spring(1000.0),
            bend: spring(600.0),
        }
    }
}

/// What the guard's last retry changes.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum Fallback {
    /// Only more substeps: every retry doubles them (up to the limit).
    MoreSubsteps,
    /// The last retry switches to this integrator (the earlier ones double
    /// the substeps). An implicit one makes the last retry stable at any
    /// step.
    Integrator(Integrator),
}

/// Bounds of the divergence guard ([`guard`](crate::sim::guard)).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct GuardSettings {
    /// Whether the guard checks at all.
    pub enabled: bool,
    /// Largest Type 1 strain `(ℓ − L)/L` allowed (dimensionless; 3 = 300 %,
    /// beyond any real cloth but well short of a blow-up).
    pub max_strain: f32,
    /// Largest speed of a free particle, m/s.
    pub max_speed: f32,
    /// Retries per fixed step.
    pub retries: u32,
    /// The guard never runs more than this many times the substeps the
    /// cloth asked for, so a trip more substeps cannot cure cannot make the
    /// cost run away.
    pub max_boost: u32,
    /// What the last retry changes.
    pub fallback: Fallback,
}

impl Default for GuardSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            max_strain: 3.0,
            max_speed: 200.0,
            retries: 3,
            max_boost: 16,
            fallback: Fallback::Integrator(Integrator::BackwardEuler),
        }
    }
}

/// Adaptive substeps, on by default ([`SimSettings::adaptive`]).
///
/// With it, an explicit integrator runs `max(substeps, n)` substeps, `n`
/// being the fewest that keep each substep within `safety` times its
/// stability bound ([`adaptive`](crate::sim::adaptive) module docs); set [`SimSettings::substeps`] to 1 to
/// let the estimate decide alone. Implicit integrators are unaffected.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct AdaptiveSubsteps {
    /// Fraction of the stability bound a substep may use, in (0, 1].
    pub safety: f32,
    /// Most substeps per fixed step, whatever the estimate asks.
    pub max_substeps: u32,
}

impl Default for AdaptiveSubsteps {
    fn default() -> Self {
        Self {
            safety: 0.9,
            max_substeps: 4096,
        }
    }
}

/// How a cloth is simulated. In an app, a `ClothSettings` component wraps
/// it on a cloth entity and overrides the `ClothSettingsDefaults` resource.
///
/// The default steps every cloth, of any size and material, once per fixed
/// step with backward Euler, whose linear solve is stable at any step.
/// Choosing an explicit integrator (`with_integrator`) keeps
/// [`adaptive`](Self::adaptive) substeps on, so the substep follows the
/// cloth's stiffest mode and no stability bound needs computing by hand.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// fn spawn(mut commands: Commands) -> Result<(), ClothError> {
///     // BDF2, one step per fixed step, and a stronger gravity.
///     let mut settings = SimSettings::default().with_integrator(Integrator::Bdf2, 1);
///     settings.gravity = Vec3::new(0.0, -12.0, 0.0);
///     commands.spawn((ClothBuilder::new(32, 32).build()?, ClothSettings(settings)));
///     Ok(())
/// }
/// ```
#[derive(Clone, Debug, PartialEq, Reflect)]
#[reflect(Default)]
pub struct SimSettings {
    /// Internal force model.
    pub model: ClothModel,
    /// Time integrator.
    pub integrator: Integrator,
    /// Integrator steps per `FixedUpdate` step (≥ 1). The substep is the
    /// fixed timestep divided by this.
    pub substeps: u32,
    /// Gravitational acceleration in m/s².
    pub gravity: Vec3,
    /// Absolute velocity damping `c` in s⁻¹: the acceleration `−c·v` of the paper's
    /// eq. 5. Free-fall terminal speed is `|g|/c`.
    pub damping: f32,
    /// Constants of the Choi–Ko model.
    pub choi_ko: ChoiKoSettings,
    /// Constants of Lander's model.
    pub lander: LanderSettings,
    /// Linear solve of the implicit integrators.
    pub implicit: ImplicitSettings,
    /// The divergence guard ([`guard`](crate::sim::guard)).
    pub guard: GuardSettings,
    /// Whether the internal forces are evaluated in parallel bands.
    pub parallel: Parallelism,
    /// Adaptive substeps for the explicit integrators (on by default; the
    /// implicit ones ignore it): at least [`substeps`](Self::substeps), and
    /// as many more as the cloth's stiffest mode needs. `None` runs exactly
    /// [`substeps`](Self::substeps).
    pub adaptive: Option<AdaptiveSubsteps>,
    /// When the cloth is at rest, and whether it then sleeps (on by
    /// default).
    pub sleep: SleepSettings,
}

/// Whether a cloth's internal forces are evaluated in parallel row bands on
/// Bevy's `ComputeTaskPool` (`model::bands`).
///
/// The banded evaluation adds forces in an order fixed by the cloth alone,
/// so its result is bitwise the same whatever the number of threads (one,
/// when the pool is absent or Bevy's `multi_threaded` feature is off).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum Parallelism {
    /// Always one thread: the explicit integrators' force streams
    /// (`model::streams`), the pair kernel for the
    /// implicit ones.
    Off,
    /// Bands for cloths of at least [`Parallelism::AUTO_MIN_PARTICLES`]
    /// particles when the compute pool has at least
    /// [`Parallelism::AUTO_MIN_THREADS`] threads; otherwise one thread is
    /// cheaper. The choice depends on the machine: use `Off` or `On` for
    /// results that are bitwise the same on every machine.
    #[default]
    Auto,
    /// Bands for every grid cloth.
    On,
}

impl Parallelism {
    /// The cloth size (particles) from which [`Parallelism::Auto`] uses
    /// bands, given [`AUTO_MIN_THREADS`](Self::AUTO_MIN_THREADS): 128×128,
    /// below which each band's task costs more than its share of the work.
    pub const AUTO_MIN_PARTICLES: usize = 128 * 128;

    /// The compute-pool threads from which [`Parallelism::Auto`] uses
    /// bands: 4. The bands run the link-by-link pair kernel, which costs
    /// 2.7 times as much per link as the single-threaded force streams
    /// (128×128: 529 against 194 µs), so they need three threads to break
    /// even. On a 2-core x86-64 the streams on one thread
    /// beat the bands on two at every size measured (256×256: 1.07 against
    /// 1.62 ms). The figure of 4 is that estimate, not a measurement.
    pub const AUTO_MIN_THREADS: usize = 4;

    /// Whether a cloth of `particles` particles is evaluated in bands when
    /// the compute pool has `threads` threads.
    pub fn banded(self, particles: usize, threads: usize) -> bool {
        match self {
            Self::Off => false,
            Self::Auto => {
                particles >= Self::AUTO_MIN_PARTICLES && threads >= Self::AUTO_MIN_THREADS
            }
            Self::On => true,
        }
    }
}

impl Default for SimSettings {
    fn default() -> Self {
        Self {
            model: ClothModel::ChoiKo,
            integrator: Integrator::BackwardEuler,
            substeps: 1,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            damping: 2.0,
            choi_ko: ChoiKoSettings::default(),
            lander: LanderSettings::default(),
            implicit: ImplicitSettings::default(),
            guard: GuardSettings::default(),
            parallel: Parallelism::Auto,
            adaptive: Some(AdaptiveSubsteps::default()),
            sleep: SleepSettings::default(),
        }
    }
}

/// Largest accepted [`SimSettings::substeps`].
pub const MAX_SUBSTEPS: u32 = 100_000;

fn positive(name: &'static str, value: f32) -> Result<(), ClothError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ClothError::InvalidStiffness { name, value })
    }
}

fn non_negative(name: &'static str, value: f32) -> Result<(), ClothError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(ClothError::InvalidDamping { name, value })
    }
}

impl SimSettings {
    /// Checks every constant: stiffnesses finite and positive, dampings
    /// finite and non-negative, gravity finite, `1 ≤ substeps ≤ 100 000`.
    pub fn validate(&self) -> Result<(), ClothError> {
        if self.substeps == 0 || self.substeps > MAX_SUBSTEPS {
            return Err(ClothError::InvalidSubsteps(self.substeps));
        }
        self.sleep.validate()?;
        if !self.gravity.is_finite() {
            return Err(ClothError::InvalidGravity(self.gravity));
        }
        non_negative("damping", self.damping)?;
        let tolerance = self.implicit.tolerance;
        if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0)
            || self.implicit.max_iterations == 0
            || self.implicit.past_solutions > MAX_PAST_SOLUTIONS
            || !(self.implicit.newton_strain.is_finite() && self.implicit.newton_strain >= 0.0)
            || self.implicit.strain_limit.is_nan()
            || self.implicit.strain_limit <= 0.0
            || !(self.implicit.velocity_tolerance.is_finite()
                && self.implicit.velocity_tolerance >= 0.0)
        {
            return Err(ClothError::InvalidSolver);
        }
        if let Some(a) = self.adaptive
            && !(a.safety > 0.0 && a.safety <= 1.0 && (1..=MAX_SUBSTEPS).contains(&a.max_substeps))
        {
            return Err(ClothError::InvalidAdaptive {
                safety: a.safety,
                max_substeps: a.max_substeps,
            });
        }
        let ck = &self.choi_ko;
        positive("choi_ko.stiffness", ck.stiffness)?;
        positive("choi_ko.shear_stiffness", ck.shear_stiffness)?;
        positive("choi_ko.bending_rigidity", ck.bending_rigidity)?;
        positive("choi_ko.buckling_slope", ck.buckling_slope)?;
        non_negative("choi_ko.pair_damping", ck.pair_damping)?;
        for (name, damping, spring) in [
            (
                "lander.structural",
                "lander.structural.damping",
                self.lander.structural,
            ),
            ("lander.shear", "lander.shear.damping", self.lander.shear),
            ("lander.bend", "lander.bend.damping", self.lander.bend),
        ] {
            positive(name, spring.stiffness)?;
            non_negative(damping, spring.damping)?;
        }
        Ok(())
    }

    /// The same settings with another model.
    pub fn with_model(mut self, model: ClothModel) -> Self {
        self.model = model;
        self
    }

    /// The same settings with another integrator and substep count (the
    /// least count, when [`adaptive`](Self::adaptive) substeps are on and
    /// the integrator is explicit).
    ///
    /// ```
    /// use bevy_cloth::prelude::*;
    /// // RK4 with as many substeps as the cloth's stiffest mode needs.
    /// let rk4 = SimSettings::default().with_integrator(Integrator::Rk4, 1);
    /// // Exactly 40 substeps of symplectic Euler, whatever the cloth.
    /// let fixed = SimSettings::default()
    ///     .with_integrator(Integrator::SymplecticEuler, 40)
    ///     .without_adaptive();
    /// assert!(rk4.adaptive.is_some() && fixed.adaptive.is_none());
    /// ```
    pub fn with_integrator(mut self, integrator: Integrator, substeps: u32) -> Self {
        self.integrator = integrator;
        self.substeps = substeps;
        self
    }

    /// The same settings with adaptive substeps off: an explicit integrator
    /// runs exactly [`substeps`](Self::substeps), stable or not.
    pub fn without_adaptive(mut self) -> Self {
        self.adaptive = None;
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_bad_values_do_not() {
        assert!(SimSettings::default().validate().is_ok());
        let bad = |f: fn(&mut SimSettings)| {
            let mut s = SimSettings::default();
            f(&mut s);
            s.validate().unwrap_err()
        };
        assert!(matches!(
            bad(|s| s.substeps = 0),
            ClothError::InvalidSubsteps(0)
        ));
        assert!(matches!(
            bad(|s| s.gravity.y = f32::NAN),
            ClothError::InvalidGravity(_)
        ));
        assert!(matches!(
            bad(|s| s.damping = -1.0),
            ClothError::InvalidDamping { .. }
        ));
        assert!(matches!(
            bad(|s| s.choi_ko.stiffness = 0.0),
            ClothError::InvalidStiffness {
                name: "choi_ko.stiffness",
                ..
            }
        ));
        assert!(matches!(
            bad(|s| s.choi_ko.bending_rigidity = f32::INFINITY),
            ClothError::InvalidStiffness { .. }
        ));
        assert!(matches!(
            bad(|s| s.lander.bend.stiffness = -3.0),
            ClothError::InvalidStiffness { .. }
        ));
        assert!(matches!(
            bad(|s| s.lander.shear.damping = f32::NAN),
            ClothError::InvalidDamping { .. }
        ));
        for limit in [0.0, -0.05, f32::NAN, f32::NEG_INFINITY] {
            let mut s = SimSettings::default();
            s.implicit.strain_limit = limit;
            assert!(
                matches!(s.validate(), Err(ClothError::InvalidSolver)),
                "{limit}"
            );
        }
        let mut many = SimSettings::default();
        many.implicit.past_solutions = MAX_PAST_SOLUTIONS + 1;
        assert!(matches!(many.validate(), Err(ClothError::InvalidSolver)));
        many.implicit.past_solutions = MAX_PAST_SOLUTIONS;
        assert!(many.validate().is_ok());
        let mut off = SimSettings::default();
        off.implicit.strain_limit = f32::INFINITY;
        assert!(
            off.validate().is_ok(),
            "an infinite strain limit turns it off"
        );
    }
}
