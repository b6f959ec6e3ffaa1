//! The divergence guard: a cloth whose step blows up is never lost, and
//! never frozen.
//!
//! [`step_guarded`] wraps one fixed step ([`step_cloth_with`]):
//!
//! 1. **Input.** A particle whose position or velocity is not finite when
//!    the step starts (game code wrote a NaN) goes back to its position at
//!    the start of the last step, at rest; non-finite external forces are
//!    ignored. A [`Divergence::NonFiniteInput`] reports it.
//! 2. **Check.** After the step a cheap scan looks for non-finite values, a
//!    Type 1 strain above [`GuardSettings::max_strain`] or a free particle
//!    faster than [`GuardSettings::max_speed`]. Strain and speed count only
//!    when they *grew* beyond what the step started from and beyond what
//!    pinned particles moving under a grab or an anchor can cause in one
//!    step ([`Limits`]): a cloth a kinematic grab stretched past the bound
//!    is not diverging, so it steps on, and relaxes once let go.
//! 3. **Retry.** A tripped step is undone and redone with twice the
//!    substeps, up to [`GuardSettings::retries`] times and at most
//!    [`GuardSettings::max_boost`] times the substeps the cloth asked for;
//!    the last retry switches to the [`GuardSettings::fallback`] integrator
//!    (backward Euler by default, stable at any step).
//! 4. **Strain spikes.** An implicit step that strained a Type 1 link past
//!    [`SPIKE_STRAIN`] and [`SPIKE_GROWTH`] times what the last step left
//!    did so because it was linearised where it started: a stiff or fine
//!    sheet let go horizontal pulls on its pins with no stiffness across
//!    its plane in the linearisation, and a 256×256 cotton sheet's first
//!    step stretched its corner links 21 %. The strain limit
//!    ([`ImplicitParams::strain_limit`](crate::sim::settings::ImplicitParams::strain_limit),
//!    after any Newton corrections) shortens such links again. A step it
//!    could not bring below the spike (turned off, or contacts held in the
//!    solve) is undone and redone in twice the substeps, up to
//!    [`SPIKE_SUBSTEPS`], quietly (no message: nothing diverged), and the
//!    boost relaxes as below.
//! 5. **Never frozen.** If the last retry still trips on a finite state
//!    (violent, not diverging), it is kept with the free particles' speeds
//!    clamped to the bound. If it is not finite, the free particles go back
//!    to the start of the step at rest (pinned ones keep their prescribed
//!    motion) and the fallback integrator stays in force, so the next step
//!    starts from a finite state with an integrator stable at any step: a
//!    cloth is held back for one step at most. A cloth whose worst link its
//!    contacts hold stretched past the bound, and not relaxing by
//!    `SNAG_CHANGE` (0.1 %) a step, for [`SNAGGED_STEPS`] steps (caught on
//!    a thin collider, a link through it) takes one step without contacts.
//!
//! The stronger setting stays in force for that cloth for a while (see
//! [`GuardState::relax`] and [`ClothStats`](crate::ClothStats)), a
//! [`ClothDiverged`](crate::plugin::events::ClothDiverged) message says what happened, and the plugin logs a
//! warning once per cloth.
//!
//! A boost is for the transient that tripped it (an impact, a violent
//! grab), so it does not last. With
//! [`AdaptiveSubsteps`](crate::sim::adaptive::AdaptiveSubsteps) on, the estimate
//! follows the cloth's state and the boost halves every [`RELAX_AFTER`]
//! clean steps until the estimate alone decides again. Without it, the
//! configured substeps may simply be too few, so the guard probes: it
//! halves the boost after [`RELAX_AFTER_FIXED`] clean steps, and every
//! further trip doubles that wait (up to 2¹⁰ times), so a cloth that keeps
//! tripping settles on its boost and pays a redone step ever more rarely.

use bevy::math::Vec3;
use bevy::reflect::Reflect;

use crate::sim::connections::{Connections, max_strain};
use crate::sim::integrate::StepBuffers;
use crate::sim::integrate::implicit::newton_correction;
use crate::sim::model::Dynamics;
use crate::sim::particles::Particles;
pub use crate::sim::settings::{Fallback, GuardSettings};
use crate::sim::settings::{Integrator, MAX_SUBSTEPS, SimSettings};
use crate::sim::step::{ContactHook, NoContacts, Substep, step_cloth_with};
use crate::sim::strain_limit::{MAX_SWEEPS, limit_strain};
use crate::sim::team::{self, SPLIT_PARTICLES};

/// Why the guard tripped.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[non_exhaustive]
pub enum Divergence {
    /// A position or velocity became NaN or infinite during the step.
    NonFinite,
    /// A position, velocity or external force was NaN or infinite before
    /// the step (written by game code); the particles concerned went back
    /// to their last good position at rest.
    NonFiniteInput,
    /// A Type 1 strain (dimensionless) above the bound.
    Strain(f32),
    /// A free particle's speed (m/s) above the bound.
    Speed(f32),
}

/// Checks `particles` against `guard`'s bounds (`None`: all is well), as if
/// the cloth were at rest before: no allowance for growth.
pub fn check(
    particles: &Particles,
    connections: &Connections,
    guard: &GuardSettings,
) -> Option<Divergence> {
    check_measured(particles, connections, guard, false).0
}

/// [`check`], and the largest Type 1 strain (as [`max_strain`]) if it got
/// as far as measuring it: the state is finite and slow enough. With
/// `helper`, a cloth of [`SPLIT_PARTICLES`] or more has its shear links
/// measured on the helper thread meanwhile, to the same result (the
/// largest of two largest).
pub(crate) fn check_measured(
    particles: &Particles,
    connections: &Connections,
    guard: &GuardSettings,
    helper: bool,
) -> (Option<Divergence>, Option<f32>) {
    let x = &particles.positions;
    let here = || {
        let finite = particles.is_finite();
        (finite, fastest_free(particles))
    };
    let ((finite, fastest), strain) = if helper && particles.len() >= SPLIT_PARTICLES {
        let ((state, structural), shear) = team::both(
            || (here(), max_strain(&connections.structural, x)),
            || max_strain(&connections.shear, x),
        );
        let strain = if structural.is_nan() || shear.is_nan() {
            f32::NAN
        } else {
            structural.max(shear)
        };
        (state, Some(strain))
    } else {
        (here(), None)
    };
    if !finite {
        return (Some(Divergence::NonFinite), None);
    }
    if fastest > guard.max_speed {
        return (Some(Divergence::Speed(fastest)), None);
    }
    let strain = strain.unwrap_or_else(|| max_strain(connections.type1(), x));
    if !strain.is_finite() {
        return (Some(Divergence::NonFinite), None);
    }
    let tripped = (strain > guard.max_strain).then_some(Divergence::Strain(strain));
    (tripped, Some(strain))
}

/// The largest speed (m/s) of a free particle.
fn fastest_free(particles: &Particles) -> f32 {
    fastest(&particles.velocities, &particles.inverse_masses, false)
}

/// The largest speed (m/s) among the velocities `v` of the pinned particles
/// (`pinned`: inverse mass `w` 0; a grab or an anchor carrying them) or of
/// the free ones.
fn fastest(v: &[Vec3], w: &[f32], pinned: bool) -> f32 {
    v.iter()
        .zip(w)
        .filter(|(_, w)| (**w == 0.0) == pinned)
        .map(|(v, _)| v.length_squared())
        .fold(0.0f32, f32::max)
        .sqrt()
}

/// How far strain and speed may go in one step before the guard calls it a
/// divergence: beyond the bound, beyond 1.5 times what the step started
/// from, and beyond what the pinned particles' prescribed motion can cause
/// in one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest Type 1 strain (dimensionless).
    pub strain: f32,
    /// Largest free particle speed (m/s).
    pub speed: f32,
}

impl Limits {
    /// The limits of a step of `dt` s that started at positions `x` (m) and
    /// velocities `v` (m/s), with inverse masses `w` (1/kg), under `guard`:
    /// a pinned particle moving at speed `u` moves `u·dt` in the step and
    /// can stretch a link of rest length `L` by `u·dt/L` more, and drag its
    /// free neighbours up to about twice its speed.
    pub fn new(
        (x, v, w): (&[Vec3], &[Vec3], &[f32]),
        connections: &Connections,
        guard: &GuardSettings,
        dt: f32,
    ) -> Self {
        let start_strain = max_strain(connections.type1(), x);
        let start_speed = fastest(v, w, false);
        let pinned_speed = fastest(v, w, true);
        let reach = pinned_reach(pinned_speed, connections, dt);
        let grown = |start: f32, bound: f32| {
            if start.is_finite() {
                bound.max(1.5 * start)
            } else {
                bound
            }
        };
        Self {
            strain: grown(start_strain, guard.max_strain) + reach,
            speed: grown(start_speed, guard.max_speed).max(2.0 * pinned_speed),
        }
    }

    /// Whether `reason` (from [`check`]) is a divergence under these limits.
    pub fn exceeded(&self, reason: Divergence) -> bool {
        match reason {
            Divergence::NonFinite | Divergence::NonFiniteInput => true,
            Divergence::Strain(s) => s > self.strain,
            Divergence::Speed(v) => v > self.speed,
        }
    }
}

/// The strain pinned particles moving at up to `pinned_speed` (m/s) can
/// add to a link in a step of `dt` s: `u·dt/L` for the shortest rest
/// length `L` (dimensionless).
fn pinned_reach(pinned_speed: f32, connections: &Connections, dt: f32) -> f32 {
    if pinned_speed > 0.0 {
        let shortest = connections
            .type1()
            .map(|l| l.rest_length)
            .fold(f32::INFINITY, f32::min);
        pinned_speed * dt / shortest.max(1e-6)
    } else {
        0.0
    }
}

/// A divergence [`step_guarded`] reports: what tripped first and what the
/// cloth runs with now.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct GuardReport {
    /// What tripped (on the first attempt).
    pub reason: Divergence,
    /// The substeps the cloth runs with now.
    pub substeps: u32,
    /// The integrator the cloth runs with now.
    pub integrator: Integrator,
    /// Whether a retry succeeded (otherwise speeds were clamped or the
    /// cloth held for this step).
    pub recovered: bool,
}

impl GuardReport {
    fn new(reason: Divergence, settings: &SimSettings, recovered: bool) -> Self {
        Self {
            reason,
            substeps: settings.substeps,
            integrator: settings.integrator,
            recovered,
        }
    }
}

/// What [`step_guarded`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct GuardedStep {
    /// Substeps of the attempt that was kept.
    pub substeps: u32,
    /// Integrator of the attempt that was kept.
    pub integrator: Integrator,
    /// The Type 1 strain of the state the step left, if the check measured
    /// it (dimensionless).
    pub strain: Option<f32>,
    /// The divergence to report, if the step tripped.
    pub report: Option<GuardReport>,
}

/// One fixed step of one cloth, as [`step_guarded`] takes it: the cloth's
/// state, its links and settings, the step length, and optionally external
/// forces, a contact hook and the helper thread. Made by [`StepInput::new`]
/// and the `with_…` methods, so that a new option does not break callers.
#[non_exhaustive]
pub struct StepInput<'a, H: ContactHook = NoContacts> {
    /// Positions (m), velocities (m/s) and inverse masses (1/kg).
    pub particles: &'a mut Particles,
    /// The cloth's links.
    pub connections: &'a Connections,
    /// The step's settings.
    pub settings: &'a SimSettings,
    /// External force per particle (N), or empty for none.
    pub external: &'a [Vec3],
    /// The integrators' scratch, kept between steps.
    pub buffers: &'a mut StepBuffers,
    /// The guard's memory, kept between steps.
    pub state: &'a mut GuardState,
    /// The step's length, s.
    pub dt: f32,
    /// Resolves contacts after every substep (and inside the implicit
    /// solve), if any.
    pub contacts: Option<&'a mut H>,
    /// Whether a large cloth may measure its strain on the helper thread.
    pub helper_thread: bool,
}

impl<'a> StepInput<'a, NoContacts> {
    /// A step of `dt` s of the cloth `particles` with `connections` under
    /// `settings`, keeping its scratch in `buffers` and the guard's memory
    /// in `state`: no external force, no contacts, no helper thread.
    pub fn new(
        particles: &'a mut Particles,
        connections: &'a Connections,
        settings: &'a SimSettings,
        buffers: &'a mut StepBuffers,
        state: &'a mut GuardState,
        dt: f32,
    ) -> Self {
        Self {
            particles,
            connections,
            settings,
            external: &[],
            buffers,
            state,
            dt,
            contacts: None,
            helper_thread: false,
        }
    }
}

impl<'a, H: ContactHook> StepInput<'a, H> {
    /// External forces, one per particle (N).
    pub fn with_external(mut self, forces: &'a [Vec3]) -> Self {
        self.external = forces;
        self
    }

    /// Contacts resolved by `hook` (none when `None`).
    pub fn with_contacts<C: ContactHook>(self, hook: Option<&'a mut C>) -> StepInput<'a, C> {
        StepInput {
            particles: self.particles,
            connections: self.connections,
            settings: self.settings,
            external: self.external,
            buffers: self.buffers,
            state: self.state,
            dt: self.dt,
            contacts: hook,
            helper_thread: self.helper_thread,
        }
    }

    /// Lets a large cloth measure its strain on the helper thread.
    pub fn with_helper_thread(mut self, on: bool) -> Self {
        self.helper_thread = on;
        self
    }
}

/// One fixed step of one cloth under the divergence guard of its settings
/// (module docs): [`step_cloth_with`] plus the input repair, the check, the
/// retries and the fallback. [`StepInput`] says what is stepped.
///
/// ```
/// use bevy_cloth::prelude::*;
/// use bevy_cloth::sim::guard::{GuardState, StepInput, step_guarded};
/// use bevy_cloth::sim::integrate::StepBuffers;
///
/// let mut cloth = ClothBuilder::new(8, 8).pin_corner(GridCorner::TopLeft).build().unwrap();
/// let settings = SimSettings::default();
/// let (mut buffers, mut guard) = (StepBuffers::default(), GuardState::default());
/// cloth.particles.positions[20].x = f32::NAN; // a bug in game code
/// let step = step_guarded(StepInput::new(
///     &mut cloth.particles,
///     &cloth.connections,
///     &settings,
///     &mut buffers,
///     &mut guard,
///     1.0 / 60.0,
/// ));
/// assert!(cloth.particles.is_finite());
/// assert!(step.report.is_some());
/// ```
pub fn step_guarded<H: ContactHook>(input: StepInput<'_, H>) -> GuardedStep {
    let StepInput {
        particles,
        connections,
        settings,
        external,
        buffers,
        state,
        dt,
        contacts: mut hook,
        helper_thread: helper,
    } = input;
    let guard = settings.guard;
    let mut effective = settings.clone();
    if let Some((substeps, integrator)) = state.boost {
        effective.substeps = substeps;
        effective.integrator = integrator;
    }
    let mut input = None;
    let cleaned: Vec<Vec3>;
    let external = if external.iter().all(|f| f.is_finite()) {
        external
    } else {
        // A bug in game code, not a step to make fast: a copy will do.
        input = Some(Divergence::NonFiniteInput);
        cleaned = external
            .iter()
            .map(|f| if f.is_finite() { *f } else { Vec3::ZERO })
            .collect();
        &cleaned
    };
    if !guard.enabled {
        let substeps = step_cloth_with(
            particles,
            connections,
            &effective,
            external,
            buffers,
            dt,
            hook.as_deref_mut(),
        );
        return GuardedStep {
            substeps,
            integrator: effective.integrator,
            strain: None,
            report: None,
        };
    }
    if !particles.is_finite() {
        input = Some(Divergence::NonFiniteInput);
        repair(particles, &state.good_x);
        buffers.implicit.reset_history();
    }
    state.good_x.clone_from(&particles.positions);
    state.good_v.clone_from(&particles.velocities);
    if state.snagged >= SNAGGED_STEPS {
        // Held over-stretched and still by its contacts: the cloth is caught
        // on a collider (a link through a thin table top after a violent
        // yank). One step without contacts lets it go.
        hook = None;
        state.snagged = 0;
    }
    let mut limits = None;
    let mut tripped = None;
    let base = settings.substeps.max(1);
    for attempt in 0..=guard.retries {
        let used = step_cloth_with(
            particles,
            connections,
            &effective,
            external,
            buffers,
            dt,
            hook.as_deref_mut(),
        );
        effective.substeps = used;
        let (mut reason, mut strain) = check_measured(particles, connections, &guard, helper);
        if effective.integrator.is_implicit() {
            (reason, strain) = refine(
                Refine {
                    particles: &mut *particles,
                    connections,
                    settings: &effective,
                    external,
                    buffers: &mut *buffers,
                    dt,
                    helper,
                },
                state,
                hook.as_deref_mut(),
                (reason, strain),
            );
        }
        // A spike of strain the step's linearisation made rather than its
        // forces (a stiff or fine sheet let go horizontal pulls on its pins
        // with no stiffness across its plane), beyond what its pins' own
        // motion can cause (a grab lifting a particle): the step is taken
        // again in twice the substeps, quietly, as a boost that relaxes.
        let spike = matches!(strain, Some(now)
        if now > SPIKE_STRAIN
            && now > SPIKE_GROWTH * state.last_strain.unwrap_or(0.0)
            && now > SPIKE_STRAIN + pinned_reach(
                fastest(&state.good_v, &particles.inverse_masses, true),
                connections,
                dt,
            ));
        if spike
            && reason.is_none()
            && effective.integrator.is_implicit()
            && attempt < guard.retries
            && effective.substeps < SPIKE_SUBSTEPS.min(MAX_SUBSTEPS)
        {
            if let Some(hook) = hook.as_mut() {
                hook.undo();
            }
            particles.positions.clone_from(&state.good_x);
            particles.velocities.clone_from(&state.good_v);
            buffers.implicit.reset_history();
            effective.substeps *= 2;
            state.boost = Some((effective.substeps, effective.integrator));
            state.clean = 0;
            continue;
        }
        let diverged = reason.filter(|&r| {
            let start = (
                &state.good_x[..],
                &state.good_v[..],
                &particles.inverse_masses[..],
            );
            limits
                .get_or_insert_with(|| Limits::new(start, connections, &guard, dt))
                .exceeded(r)
        });
        let Some(reason) = diverged else {
            let report = match (tripped, input) {
                (Some(first), _) => Some(GuardReport::new(first, &effective, true)),
                (None, Some(input)) => Some(GuardReport::new(input, &effective, true)),
                (None, None) => {
                    state.relax(settings.integrator, base, settings.adaptive.is_some());
                    None
                }
            };
            // Caught: stretched far past any rest, and the worst link does
            // not relax while contacts act on it (it may tremble).
            let held = hook.is_some()
                && matches!((strain, state.last_strain), (Some(now), Some(last))
                    if now > guard.max_strain && now - last >= -SNAG_CHANGE * now);
            state.snagged = if held { state.snagged + 1 } else { 0 };
            state.last_strain = strain;
            return GuardedStep {
                substeps: effective.substeps,
                integrator: effective.integrator,
                strain,
                report,
            };
        };
        if tripped.is_none() {
            state.trips = state.trips.saturating_add(1);
        }
        let first = *tripped.get_or_insert(input.unwrap_or(reason));
        let last = attempt == guard.retries;
        if last && reason != Divergence::NonFinite {
            // Violent motion rather than a blow-up: keep it, with every
            // free speed clamped to the limit.
            let max_speed = limits.map_or(guard.max_speed, |l| l.speed.min(guard.max_speed));
            for (v, &w) in particles
                .velocities
                .iter_mut()
                .zip(&particles.inverse_masses)
            {
                if w != 0.0 {
                    *v = v.clamp_length_max(max_speed);
                }
            }
            return kept(state, effective, first, false);
        }
        // Undo the attempt.
        if let Some(hook) = hook.as_mut() {
            hook.undo();
        }
        particles.positions.clone_from(&state.good_x);
        particles.velocities.clone_from(&state.good_v);
        buffers.implicit.reset_history();
        if last {
            // Not finite even so: the free particles stay at the start of
            // the step, at rest; the next step starts from there with the
            // fallback integrator.
            for (v, &w) in particles
                .velocities
                .iter_mut()
                .zip(&particles.inverse_masses)
            {
                if w != 0.0 {
                    *v = Vec3::ZERO;
                }
            }
            if let Fallback::Integrator(i) = guard.fallback {
                effective.integrator = i;
                effective.substeps = 1;
                state.boost = Some((1, i));
            }
            return kept(state, effective, first, false);
        }
        // More substeps, up to the boost limit (and the adaptive cap of an
        // explicit integrator); the fallback integrator on the last retry,
        // or as soon as no more substeps may be added.
        let mut cap = crate::sim::adaptive::substeps_for(
            settings,
            connections,
            particles,
            dt,
            &mut buffers.mode_sums,
        )
        .saturating_mul(guard.max_boost.max(1))
        .min(MAX_SUBSTEPS);
        if let Some(adaptive) = settings.adaptive
            && !effective.integrator.is_implicit()
        {
            cap = cap.min(adaptive.max_substeps.max(1));
        }
        let doubled = effective.substeps.saturating_mul(2).min(cap);
        let stuck = doubled <= effective.substeps;
        effective.substeps = doubled.max(effective.substeps);
        if (stuck || attempt + 1 == guard.retries)
            && let Fallback::Integrator(i) = guard.fallback
            && effective.integrator != i
        {
            effective.integrator = i;
            if i.is_implicit() {
                effective.substeps = 1;
            }
        }
        state.boost = Some((effective.substeps, effective.integrator));
        state.clean = 0;
    }
    unreachable!("the last attempt returns")
}

/// What [`refine`] works on.
struct Refine<'a> {
    particles: &'a mut Particles,
    connections: &'a Connections,
    settings: &'a SimSettings,
    external: &'a [Vec3],
    buffers: &'a mut StepBuffers,
    dt: f32,
    helper: bool,
}

/// Extra Newton iterations of an implicit step that strained a link past
/// [`ImplicitParams::newton_strain`](crate::sim::settings::ImplicitParams::newton_strain)
/// and by a fifth more than the last step left, each followed by the
/// contact `hook` and the check; an iteration that does not lower the
/// strain is undone. Then, if a Type 1 link is still strained past
/// [`ImplicitParams::strain_limit`](crate::sim::settings::ImplicitParams::strain_limit),
/// the links are shortened to it ([`limit_strain`]), followed by the hook
/// and the check; sweeps that stop with a link still past the bound and
/// less than half the worst excess taken off (links held stretched between
/// pins) are undone. Neither runs on a step whose solve held contacts.
/// Returns the last check's result.
fn refine<H: ContactHook>(
    mut r: Refine,
    state: &mut GuardState,
    mut hook: Option<&mut H>,
    mut checked: (Option<Divergence>, Option<f32>),
) -> (Option<Divergence>, Option<f32>) {
    if r.buffers.implicit.contacts.any() {
        // Its contacts were held inside the solve: a Newton iteration or
        // the strain limit, without them, would let go of them.
        return checked;
    }
    let params = r.settings.implicit;
    let trigger = params
        .newton_strain
        .max(1.2 * state.last_strain.unwrap_or(0.0));
    let guard = r.settings.guard;
    for _ in 0..params.newton_iterations {
        let Some(strain) = strain_after(checked, &r) else {
            break;
        };
        if strain.is_nan() || strain <= trigger {
            break;
        }
        state.newton_x.clone_from(&r.particles.positions);
        state.newton_v.clone_from(&r.particles.velocities);
        let Particles {
            positions,
            velocities,
            inverse_masses,
            ..
        } = &mut *r.particles;
        let dynamics = Dynamics {
            settings: r.settings,
            connections: r.connections,
            inverse_masses,
            external: r.external,
            workers: &r.buffers.workers,
        };
        newton_correction(&dynamics, positions, velocities, &mut r.buffers.implicit);
        resolve_last(&mut r, hook.as_deref_mut());
        let next = check_measured(r.particles, r.connections, &guard, r.helper);
        if !strain_after(next, &r).is_some_and(|s| s < strain) {
            r.particles.positions.clone_from(&state.newton_x);
            r.particles.velocities.clone_from(&state.newton_v);
            break;
        }
        checked = next;
    }
    let Some(strain) = strain_after(checked, &r) else {
        return checked;
    };
    let n = r.particles.positions.len();
    if strain > params.strain_limit
        && let Some(gamma) = r.buffers.implicit.step_gamma(n)
    {
        let p = &mut *r.particles;
        state.newton_x.clone_from(&p.positions);
        state.newton_v.clone_from(&p.velocities);
        let limited = limit_strain(
            &[&r.connections.structural, &r.connections.shear],
            &mut p.positions,
            &mut p.velocities,
            &p.inverse_masses,
            gamma,
            params.strain_limit,
            MAX_SWEEPS,
        );
        // Sweeps that stopped with a link still past the bound and took
        // less than half the worst excess off are up against links held
        // stretched between pinned or grabbed particles: their partial
        // moves would only crumple the cloth around them, so the step
        // stands as the solve left it.
        if limited.strain > 0.0 {
            let excess = |s: f32| s - params.strain_limit;
            let left = max_strain(r.connections.type1(), &p.positions);
            let halved = excess(left) <= 0.5 * excess(strain);
            if !halved {
                p.positions.clone_from(&state.newton_x);
                p.velocities.clone_from(&state.newton_v);
                return checked;
            }
        }
        r.buffers.implicit.moved_to(&p.positions);
        resolve_last(&mut r, hook);
        checked = check_measured(r.particles, r.connections, &guard, r.helper);
    }
    checked
}

/// The worst Type 1 strain (dimensionless) of the particles `checked` was
/// made of, measured if the check did not; `None` if it found non-finite
/// values.
fn strain_after(checked: (Option<Divergence>, Option<f32>), r: &Refine) -> Option<f32> {
    match checked {
        (Some(Divergence::NonFinite), _) => None,
        (_, Some(s)) => Some(s),
        _ => Some(max_strain(r.connections.type1(), &r.particles.positions)),
    }
}

/// The contact `hook` over the last substep again, after [`refine`] moved
/// the particles.
fn resolve_last<H: ContactHook>(r: &mut Refine, hook: Option<&mut H>) {
    let Some(hook) = hook else {
        return;
    };
    let n = r.settings.substeps.max(1) as f32;
    let sub = Substep {
        from: (n - 1.0) / n,
        to: 1.0,
        dt: r.dt / n,
    };
    let start = &r.buffers.substep_start;
    let p = &mut *r.particles;
    if start.len() == p.positions.len() {
        hook.resolve(
            sub,
            start,
            &mut p.positions,
            &mut p.velocities,
            &p.inverse_masses,
            &[],
        );
    }
}

/// The result of a step whose every retry tripped.
fn kept(
    state: &mut GuardState,
    effective: SimSettings,
    first: Divergence,
    recovered: bool,
) -> GuardedStep {
    state.clean = 0;
    GuardedStep {
        substeps: effective.substeps,
        integrator: effective.integrator,
        strain: None,
        report: Some(GuardReport::new(first, &effective, recovered)),
    }
}

/// Puts every particle whose position or velocity is not finite back at
/// its `good` position (the start of the last step) at rest, or at the
/// mean of the finite particles when there is no such position.
fn repair(particles: &mut Particles, good: &[Vec3]) {
    let finite: Vec<Vec3> = particles
        .positions
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    let centre = if finite.is_empty() {
        Vec3::ZERO
    } else {
        finite.iter().sum::<Vec3>() / finite.len() as f32
    };
    for (p, (x, v)) in particles
        .positions
        .iter_mut()
        .zip(&mut particles.velocities)
        .enumerate()
    {
        if !(x.is_finite() && v.is_finite()) {
            *x = good
                .get(p)
                .copied()
                .filter(|g| g.is_finite())
                .unwrap_or(centre);
            *v = Vec3::ZERO;
        }
    }
}

/// The last good state of a cloth and what the guard has changed.
#[derive(Clone, Debug, Default)]
pub struct GuardState {
    /// Positions (m) and velocities (m/s) at the start of the last step.
    pub(crate) good_x: Vec<Vec3>,
    pub(crate) good_v: Vec<Vec3>,
    /// The Type 1 strain the last clean step left (dimensionless).
    last_strain: Option<f32>,
    /// Steps the cloth has stayed above the bound without relaxing, with
    /// colliders near (see [`SNAGGED_STEPS`]).
    snagged: u32,
    /// The state before an extra Newton iteration or the strain limit's
    /// sweeps, to undo them.
    newton_x: Vec<Vec3>,
    newton_v: Vec<Vec3>,
    /// Substeps and integrator the guard moved the cloth to.
    pub(crate) boost: Option<(u32, Integrator)>,
    /// Clean steps since the boost last changed.
    pub(crate) clean: u32,
    /// Fixed steps that tripped the guard so far (saturating).
    pub(crate) trips: u32,
}

/// Fixed steps a cloth may stay strained above the guard's bound without
/// relaxing while it has colliders near, before a step without contacts
/// lets it off.
pub const SNAGGED_STEPS: u32 = 10;

/// The Type 1 strain (dimensionless) past which an implicit step that
/// raised its cloth's strain [`SPIKE_GROWTH`] times over is taken again in
/// twice the substeps.
pub const SPIKE_STRAIN: f32 = 0.15;

/// How many times the strain the last step left a spike must reach.
pub const SPIKE_GROWTH: f32 = 2.0;

/// Substeps a spike's retries go up to at most.
pub const SPIKE_SUBSTEPS: u32 = 8;

/// Smallest relative fall of the worst strain in a step that counts as
/// relaxing (dimensionless): a snagged cloth's trembles less than this.
const SNAG_CHANGE: f32 = 1e-3;

/// Clean fixed steps after which an adaptive cloth's boost halves.
pub const RELAX_AFTER: u32 = 10;

/// Clean fixed steps after which the boost of a cloth without adaptive
/// substeps first halves (1 s at 60 Hz); each later trip doubles it.
pub const RELAX_AFTER_FIXED: u32 = 60;

/// The most doublings of [`RELAX_AFTER_FIXED`] (about 17 min at 60 Hz).
const MAX_BACKOFF: u32 = 10;

impl GuardState {
    /// One clean fixed step. A boost is only needed through the transient
    /// that tripped it: after enough clean steps ([`RELAX_AFTER`] with
    /// `adaptive` substeps, else [`RELAX_AFTER_FIXED`] doubled for every
    /// trip after the first) the boosted substeps halve; the boost ends
    /// when they reach the configured substeps `floor` or the configured
    /// `integrator` is back.
    pub fn relax(&mut self, integrator: Integrator, floor: u32, adaptive: bool) {
        let Some((substeps, boosted)) = self.boost else {
            return;
        };
        self.clean += 1;
        let wait = if adaptive {
            RELAX_AFTER
        } else {
            RELAX_AFTER_FIXED << self.trips.saturating_sub(1).min(MAX_BACKOFF)
        };
        if self.clean < wait {
            return;
        }
        self.clean = 0;
        self.boost = if boosted != integrator {
            // A fallback integrator goes back to the configured one.
            None
        } else {
            (substeps / 2 > floor).then_some((substeps / 2, boosted))
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::connections::Link;

    #[test]
    fn a_trip_counts_only_beyond_the_start_and_what_pins_in_motion_can_cause() {
        let mut connections = Connections::default();
        connections.structural.push(Link {
            a: 0,
            b: 1,
            rest_length: 0.5,
        });
        let guard = GuardSettings::default();
        let limits = |len: f32, speed: f32, pin_speed: f32| {
            let x = [Vec3::ZERO, Vec3::X * len];
            let v = [Vec3::Z * pin_speed, Vec3::Y * speed];
            Limits::new((&x, &v, &[0.0, 1.0]), &connections, &guard, 0.1)
        };
        // Started within the bounds (strain 10 %, 1 m/s), pins still: every
        // trip counts.
        let calm = limits(0.55, 1.0, 0.0);
        assert!(calm.exceeded(Divergence::Strain(3.1)));
        assert!(calm.exceeded(Divergence::Speed(201.0)));
        assert!(calm.exceeded(Divergence::NonFinite));
        assert!(calm.exceeded(Divergence::NonFiniteInput));
        // Started over-stretched (strain 4) and fast (300 m/s): staying or
        // relaxing is not a divergence, growing 1.5× is.
        let wild = limits(2.5, 300.0, 0.0);
        assert!(!wild.exceeded(Divergence::Strain(4.0)));
        assert!(wild.exceeded(Divergence::Strain(6.5)));
        assert!(!wild.exceeded(Divergence::Speed(350.0)));
        assert!(wild.exceeded(Divergence::Speed(460.0)));
        // A pin carried at 50 m/s moves 5 m in the 0.1 s step: it may
        // stretch the 0.5 m link by 10 more and drag it to 100 m/s.
        let yanked = limits(0.55, 1.0, 50.0);
        assert!((yanked.strain - 13.0).abs() < 1e-4, "{yanked:?}");
        assert!(!yanked.exceeded(Divergence::Strain(12.0)));
        assert!(yanked.exceeded(Divergence::Strain(14.0)));
        assert_eq!(yanked.speed, 200.0);
        let flung = limits(0.55, 1.0, 150.0);
        assert_eq!(flung.speed, 300.0);
    }

    #[test]
    fn an_adaptive_boost_halves_every_few_clean_steps_down_to_the_floor() {
        let se = Integrator::SymplecticEuler;
        let mut state = GuardState {
            boost: Some((64, se)),
            ..GuardState::default()
        };
        let mut seen = Vec::new();
        for _ in 0..5 * RELAX_AFTER {
            state.relax(se, 10, true);
            seen.push(state.boost.map(|(s, _)| s));
        }
        let at = |k: u32| seen[(k * RELAX_AFTER - 1) as usize];
        assert_eq!(seen[0], Some(64));
        assert_eq!([at(1), at(2), at(3)], [Some(32), Some(16), None]);
        // A fallback integrator ends at once after the clean steps.
        state.boost = Some((40, Integrator::BackwardEuler));
        for _ in 0..RELAX_AFTER {
            state.relax(se, 10, true);
        }
        assert_eq!(state.boost, None);
    }

    #[test]
    fn a_fixed_boost_relaxes_later_after_every_trip() {
        let be = Integrator::BackwardEuler;
        // Clean steps until a boost of 4 substeps over a floor of 1 halves.
        let wait = |trips: u32| {
            let mut state = GuardState {
                boost: Some((4, be)),
                trips,
                ..GuardState::default()
            };
            (1..)
                .find(|_| {
                    state.relax(be, 1, false);
                    state.boost != Some((4, be))
                })
                .unwrap()
        };
        assert_eq!(wait(1), RELAX_AFTER_FIXED);
        assert_eq!(wait(2), 2 * RELAX_AFTER_FIXED);
        assert_eq!(wait(4), 8 * RELAX_AFTER_FIXED);
        assert_eq!(wait(400), RELAX_AFTER_FIXED << MAX_BACKOFF);
    }
}
