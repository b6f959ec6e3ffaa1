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
//!    step: a cloth a kinematic grab stretched past the bound
//!    is not diverging, so it steps on, and relaxes once let go.
//! 3. **Retry.** A tripped step is undone and redone with twice the
//!    substeps, up to [`GuardSettings::retries`] times and at most
//!    [`GuardSettings::max_boost`] times the substeps the cloth asked for;
//!    the last retry switches to the [`GuardSettings::fallback`] integrator
//!    (backward Euler by default, stable at any step).
//! 4. **Strain spikes.** An implicit step that strained a Type 1 link past
//!    15 % and twice what the last step left
//!    did so because it was linearised where it started: a stiff or fine
//!    sheet let go horizontal pulls on its pins with no stiffness across
//!    its plane in the linearisation, and a 256×256 cotton sheet's first
//!    step stretched its corner links 21 %. The strain limit
//!    ([`ImplicitSettings::strain_limit`](crate::sim::settings::ImplicitSettings::strain_limit),
//!    after any Newton corrections) shortens such links again. A step it
//!    could not bring below the spike (turned off, or contacts held in the
//!    solve) is undone and redone in twice the substeps, up to
//!    8, quietly (no message: nothing diverged), and the
//!    boost relaxes as below.
//! 5. **Never frozen.** If the last retry still trips on a finite state
//!    (violent, not diverging), it is kept with the free particles' speeds
//!    clamped to the bound. If it is not finite, the free particles go back
//!    to the start of the step at rest (pinned ones keep their prescribed
//!    motion) and the fallback integrator stays in force, so the next step
//!    starts from a finite state with an integrator stable at any step: a
//!    cloth is held back for one step at most. A cloth whose worst link its
//!    contacts hold stretched past the bound, and not relaxing by
//!    0.1 % a step, for 10 steps (caught on
//!    a thin collider, a link through it) takes one step without contacts.
//!
//! The stronger setting stays in force for that cloth for a while (see
//! [`GuardState::relax`] and [`ClothStats`](crate::ClothStats)), a
//! [`ClothDiverged`](crate::plugin::step::events::ClothDiverged) message says what happened, and the plugin logs a
//! warning once per cloth.
//!
//! A boost is for the transient that tripped it (an impact, a violent
//! grab), so it does not last. With
//! [`AdaptiveSubsteps`](crate::sim::adaptive::AdaptiveSubsteps) on, the estimate
//! follows the cloth's state and the boost halves every 10
//! clean steps until the estimate alone decides again. Without it, the
//! configured substeps may simply be too few, so the guard probes: it
//! halves the boost after 60 clean steps, and every
//! further trip doubles that wait (up to 2¹⁰ times), so a cloth that keeps
//! tripping settles on its boost and pays a redone step ever more rarely.

mod check;
mod input;
mod state;
#[cfg(test)]
mod tests;

use bevy::math::Vec3;
use bevy::reflect::Reflect;

use crate::sim::connections::{Connections, max_strain};
use crate::sim::integrate::StepBuffers;
use crate::sim::integrate::refine::{Refine, refine};
use crate::sim::particles::Particles;
pub use crate::sim::settings::{Fallback, GuardSettings};
use crate::sim::settings::{Integrator, MAX_SUBSTEPS, SimSettings};
use crate::sim::step::{ContactHook, Substep, step_cloth_with};

pub(crate) use check::Limits;
pub(crate) use check::check_measured;
use check::{fastest, pinned_reach};
pub use input::StepInput;
use input::{finite_external, repair};
pub use state::GuardState;
use state::SNAG_CHANGE;
pub(crate) use state::{SNAGGED_STEPS, SPIKE_GROWTH, SPIKE_STRAIN, SPIKE_SUBSTEPS};

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

/// One fixed step of one cloth under the divergence guard of its settings
/// (module docs). [`StepInput`] says what is stepped. After the input's
/// repair, each attempt is [`step_cloth_with`] and, for an implicit
/// integrator, the refinement (Newton corrections, the strain limit); the
/// check classifies it as clean (kept), a strain spike (undone, redone in
/// more substeps) or diverged (undone and escalated: more substeps, then
/// the fallback integrator; on the last attempt clamped or held).
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
    let mut cleaned = Vec::new();
    let (external, mut input) = finite_external(external, &mut cleaned);
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
    let mut run = Attempts {
        particles,
        connections,
        settings,
        external,
        buffers,
        state,
        dt,
        hook,
        helper,
        effective,
        limits: None,
        tripped: None,
        input,
    };
    for attempt in 0..=guard.retries {
        let last = attempt == guard.retries;
        let (reason, strain) = run.attempt();
        match run.classify(reason, strain, last) {
            Verdict::Spike => {
                run.undo();
                run.effective.substeps *= 2;
                run.boosted();
            }
            Verdict::Clean => return run.accept(strain),
            Verdict::Diverged(reason) => {
                if run.tripped.is_none() {
                    run.state.trips = run.state.trips.saturating_add(1);
                }
                let first = *run.tripped.get_or_insert(run.input.unwrap_or(reason));
                if last {
                    return run.give_up(reason, first);
                }
                run.undo();
                run.escalate(attempt + 1 == guard.retries);
            }
        }
    }
    unreachable!("the last attempt returns")
}

/// What the guard makes of an attempt.
enum Verdict {
    /// A spike of strain the linearisation made: redo it in more substeps.
    Spike,
    /// Nothing beyond the limits: keep it.
    Clean,
    /// A divergence beyond the limits: undo it and escalate, or give up.
    Diverged(Divergence),
}

/// The guard's attempts at one fixed step: what [`step_guarded`] took, the
/// settings of the current attempt, and what the attempts found.
struct Attempts<'a, H: ContactHook> {
    particles: &'a mut Particles,
    connections: &'a Connections,
    /// The cloth's own settings.
    settings: &'a SimSettings,
    external: &'a [Vec3],
    buffers: &'a mut StepBuffers,
    state: &'a mut GuardState,
    dt: f32,
    hook: Option<&'a mut H>,
    helper: bool,
    /// The settings of the current attempt (boosted substeps, fallback).
    effective: SimSettings,
    /// How far strain and speed may go from the start, once needed.
    limits: Option<Limits>,
    /// What tripped the first attempt that tripped.
    tripped: Option<Divergence>,
    /// Non-finite input the step repaired.
    input: Option<Divergence>,
}

impl<H: ContactHook> Attempts<'_, H> {
    /// Steps the cloth with the current settings, refines an implicit
    /// step ([`refine`]) and checks the result: what tripped, and the
    /// Type 1 strain if the check measured it.
    fn attempt(&mut self) -> (Option<Divergence>, Option<f32>) {
        let used = step_cloth_with(
            self.particles,
            self.connections,
            &self.effective,
            self.external,
            self.buffers,
            self.dt,
            self.hook.as_deref_mut(),
        );
        self.effective.substeps = used;
        let guard = &self.settings.guard;
        let checked = check_measured(self.particles, self.connections, guard, self.helper);
        if !self.effective.integrator.is_implicit() {
            return checked;
        }
        let strain = strain_after(checked, self.particles, self.connections);
        let (hook, effective, dt) = (&mut self.hook, &self.effective, self.dt);
        let moved = refine(
            Refine {
                particles: &mut *self.particles,
                connections: self.connections,
                settings: effective,
                external: self.external,
                buffers: &mut *self.buffers,
            },
            &mut self.state.undo,
            self.state.last_strain,
            strain,
            |p, start| resolve_last(hook.as_deref_mut(), effective, dt, p, start),
        );
        if moved {
            check_measured(self.particles, self.connections, guard, self.helper)
        } else {
            checked
        }
    }

    /// Whether the attempt is a strain spike to take again in more
    /// substeps (not on the `last` attempt), clean, or diverged.
    fn classify(&mut self, reason: Option<Divergence>, strain: Option<f32>, last: bool) -> Verdict {
        // A spike of strain the step's linearisation made rather than its
        // forces (a stiff or fine sheet let go horizontal pulls on its pins
        // with no stiffness across its plane), beyond what its pins' own
        // motion can cause (a grab lifting a particle): the step is taken
        // again in twice the substeps, quietly, as a boost that relaxes.
        let state = &*self.state;
        let spike = matches!(strain, Some(now)
        if now > SPIKE_STRAIN
            && now > SPIKE_GROWTH * state.last_strain.unwrap_or(0.0)
            && now > SPIKE_STRAIN + pinned_reach(
                fastest(&state.good_v, &self.particles.inverse_masses, true),
                self.connections,
                self.dt,
            ));
        let implicit = self.effective.integrator.is_implicit();
        if spike
            && reason.is_none()
            && implicit
            && !last
            && self.effective.substeps < SPIKE_SUBSTEPS.min(MAX_SUBSTEPS)
        {
            return Verdict::Spike;
        }
        let guard = &self.settings.guard;
        let diverged = reason.filter(|&r| {
            let start = (
                &state.good_x[..],
                &state.good_v[..],
                &self.particles.inverse_masses[..],
            );
            self.limits
                .get_or_insert_with(|| Limits::new(start, self.connections, guard, self.dt))
                .exceeded(r)
        });
        diverged.map_or(Verdict::Clean, Verdict::Diverged)
    }

    /// Keeps a clean attempt that left `strain`: reports what tripped
    /// earlier attempts (or the repaired input), relaxes a boost after a
    /// clean step, and counts the steps the cloth stays snagged.
    fn accept(self, strain: Option<f32>) -> GuardedStep {
        let Self {
            settings,
            state,
            effective,
            hook,
            tripped,
            input,
            ..
        } = self;
        let report = match (tripped, input) {
            (Some(first), _) => Some(GuardReport::new(first, &effective, true)),
            (None, Some(input)) => Some(GuardReport::new(input, &effective, true)),
            (None, None) => {
                let base = settings.substeps.max(1);
                state.relax(settings.integrator, base, settings.adaptive.is_some());
                None
            }
        };
        // Caught: stretched far past any rest, and the worst link does
        // not relax while contacts act on it (it may tremble).
        let held = hook.is_some()
            && matches!((strain, state.last_strain), (Some(now), Some(last))
                if now > settings.guard.max_strain && now - last >= -SNAG_CHANGE * now);
        state.snagged = if held { state.snagged + 1 } else { 0 };
        state.last_strain = strain;
        GuardedStep {
            substeps: effective.substeps,
            integrator: effective.integrator,
            strain,
            report,
        }
    }

    /// Undoes the attempt: the contacts' effects, the particles back at the
    /// start of the step, the solve's history forgotten.
    fn undo(&mut self) {
        if let Some(hook) = self.hook.as_mut() {
            hook.undo();
        }
        self.particles.positions.clone_from(&self.state.good_x);
        self.particles.velocities.clone_from(&self.state.good_v);
        self.buffers.implicit.reset_history();
    }

    /// The current substeps and integrator become the cloth's boost.
    fn boosted(&mut self) {
        let effective = &self.effective;
        self.state.boost = Some((effective.substeps, effective.integrator));
        self.state.clean = 0;
    }

    /// More substeps for the next attempt, up to the boost limit (and the
    /// adaptive cap of an explicit integrator); the fallback integrator on
    /// the `last_retry`, or as soon as no more substeps may be added.
    fn escalate(&mut self, last_retry: bool) {
        let (settings, guard) = (self.settings, &self.settings.guard);
        let mut cap = crate::sim::adaptive::substeps_for(
            settings,
            self.connections,
            self.particles,
            self.dt,
            &mut self.buffers.mode_sums,
        )
        .saturating_mul(guard.max_boost.max(1))
        .min(MAX_SUBSTEPS);
        let effective = &mut self.effective;
        if let Some(adaptive) = settings.adaptive
            && !effective.integrator.is_implicit()
        {
            cap = cap.min(adaptive.max_substeps.max(1));
        }
        let doubled = effective.substeps.saturating_mul(2).min(cap);
        let stuck = doubled <= effective.substeps;
        effective.substeps = doubled.max(effective.substeps);
        if (stuck || last_retry)
            && let Fallback::Integrator(i) = guard.fallback
            && effective.integrator != i
        {
            effective.integrator = i;
            if i.is_implicit() {
                effective.substeps = 1;
            }
        }
        self.boosted();
    }

    /// The last attempt still diverged (`reason`; `first` tripped first).
    /// Violent motion rather than a blow-up is kept, with every free speed
    /// clamped to the limit. A state not finite even so is undone: the free
    /// particles stay at the start of the step, at rest, and the next step
    /// starts from there with the fallback integrator.
    fn give_up(mut self, reason: Divergence, first: Divergence) -> GuardedStep {
        let guard = self.settings.guard;
        if reason != Divergence::NonFinite {
            let max_speed = self
                .limits
                .map_or(guard.max_speed, |l| l.speed.min(guard.max_speed));
            let p = &mut *self.particles;
            for (v, &w) in p.velocities.iter_mut().zip(&p.inverse_masses) {
                if w != 0.0 {
                    *v = v.clamp_length_max(max_speed);
                }
            }
            return kept(self.state, self.effective, first, false);
        }
        self.undo();
        let p = &mut *self.particles;
        for (v, &w) in p.velocities.iter_mut().zip(&p.inverse_masses) {
            if w != 0.0 {
                *v = Vec3::ZERO;
            }
        }
        if let Fallback::Integrator(i) = guard.fallback {
            self.effective.integrator = i;
            self.effective.substeps = 1;
            self.state.boost = Some((1, i));
        }
        kept(self.state, self.effective, first, false)
    }
}

/// The worst Type 1 strain (dimensionless) of the particles `checked` was
/// made of, measured if the check did not; `None` if it found non-finite
/// values.
fn strain_after(
    checked: (Option<Divergence>, Option<f32>),
    particles: &Particles,
    connections: &Connections,
) -> Option<f32> {
    match checked {
        (Some(Divergence::NonFinite), _) => None,
        (_, Some(s)) => Some(s),
        _ => Some(max_strain(connections.type1(), &particles.positions)),
    }
}

/// The contact `hook` over the last substep of a step of `dt` s under
/// `settings` again, after [`refine`] moved the particles from the
/// substep's `start` (m).
fn resolve_last<H: ContactHook>(
    hook: Option<&mut H>,
    settings: &SimSettings,
    dt: f32,
    p: &mut Particles,
    start: &[Vec3],
) {
    let Some(hook) = hook else {
        return;
    };
    let n = settings.substeps.max(1) as f32;
    let sub = Substep {
        from: (n - 1.0) / n,
        to: 1.0,
        dt: dt / n,
    };
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
