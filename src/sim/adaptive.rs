//! Adaptive substeps (on by default): explicit integrators pick their substep count
//! from an estimate of the cloth's stiffest mode, so that changing stiffness
//! or mass at run time cannot push them past their stability bound.
//!
//! The estimate is Gershgorin's bound on the eigenvalues of `M⁻¹K`
//! (MODEL.md §6.4): for particle `i` with inverse mass `w_i` and links `l`
//! to particles `j` of stiffness `k_l` (N/m),
//!
//! `ω_max² ≤ max_i Σ_l k_l (w_i + √(w_i w_j))`,
//!
//! which for equal masses is the familiar `2Σk/m`. Every link counts as if
//! taut (Type 1) or in its stiffest branch (Type 2: `max(c_b, 12π²k_b/L³)`),
//! so the bound holds in any configuration; pinned particles (`w = 0`) do
//! not count. Pair damping adds a rate `c_pair` the same way, to the
//! absolute damping `c`. The substep then follows from the integrator's bound
//! (MODEL.md §6.1–§6.3), with `c = c_abs + c_pair`:
//!
//! | integrator | largest stable substep |
//! |---|---|
//! | explicit Euler | `min(max(c_abs/ω², min(r, c_abs/ω_u²)), 2/(ω + c))` |
//! | symplectic Euler | `(√(c² + 4ω²) − c)/ω²` |
//! | RK4 | `2.78/(ω + c)` |
//! | backward Euler, BDF2 | none |
//!
//! Explicit Euler is stable only while every mode's damping rate exceeds
//! `dt·ω²` of that mode (§6.1), so it needs to know which damping reaches
//! which stiffness. `c_abs/ω²` is always safe, but it is MODEL.md's
//! 1.5×10⁻⁷ s for cotton. The estimate splits the stiffness in two:
//!
//! - the axial stiffness of pair-damped links (Type 1, Lander's springs). Pair
//!   damping is proportional to it with the ratio `r = k_d/k` (s; the least
//!   over families), so those modes are stable for `dt ≤ r`;
//! - the rest, which only `c_abs` damps: each link's tension over its length
//!   `|f|/ℓ` (the transverse stiffness a stretched string has) at the current
//!   positions, the slope of buckled Type 2 links, and fold terms. Their
//!   Gershgorin bound `ω_u` asks `dt ≤ c_abs/ω_u²`.
//!
//! A mode whose `ω²` is `a` from the first part and `b` from the second is
//! damped at the rate `c_abs + r·a` at least, and `dt·(a + b) ≤ r·a + c_abs`
//! holds, so it is stable. The Type 2 pre-buckling clamp (slope `c_b`) is
//! left out of `ω_u`: it acts only within `12k_b/(L²c_b)` of the rest length
//! (3×10⁻⁷ m for cotton), too narrow for an oscillation to grow in. The
//! second part is a linearisation at the positions at the start of the fixed
//! step, so explicit Euler's substeps follow the tension; the safety factor
//! and the guard cover its change within the step. The pass that reads the
//! positions runs only for explicit Euler.
//!
//! One pass over the links per fixed step, so it follows every change.

use bevy::math::Vec3;

use crate::sim::connections::{Connections, Link};
use crate::sim::model::choi_ko::{MIN_LENGTH, type2_magnitude};
use crate::sim::model::kernel::Law;
use crate::sim::particles::Particles;
pub use crate::sim::settings::AdaptiveSubsteps;
use crate::sim::settings::{Integrator, SimSettings};

/// The cloth's stiffest mode, as bounded by [`stiffest_mode`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StiffestMode {
    /// Upper bound on the highest angular frequency `ω_max` (rad/s).
    pub omega: f32,
    /// Upper bound on the damping rate `c` (1/s): absolute plus pair damping.
    pub damping: f32,
    /// The absolute damping rate `c_abs` (1/s), which damps every mode.
    pub absolute: f32,
    /// Least ratio `r` of pair damping to axial stiffness (s) over the
    /// pair-damped families; 0 without pair damping.
    pub pair_ratio: f32,
    /// Upper bound on the frequency of the stiffness only `c_abs` damps
    /// (rad/s; module docs), at the positions the estimate was taken at.
    /// Only explicit Euler needs it; 0 for the other integrators.
    pub undamped_omega: f32,
}

/// Gershgorin sums of one particle: total stiffness, pair damping and the
/// stiffness only the absolute damping reaches (module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct ModeSums {
    stiffness: f32,
    damping: f32,
    undamped: f32,
}

/// One link's share of the sums: `k` is its stiffest axial slope (N/m), `d`
/// its pair damping (N·s/m), `u` its undamped stiffness (N/m).
fn add_link(sums: &mut [ModeSums], w: &[f32], l: &Link, k: f32, d: f32, u: f32) {
    let (a, b) = (l.a as usize, l.b as usize);
    let (Some(&wa), Some(&wb)) = (w.get(a), w.get(b)) else {
        return;
    };
    let cross = (wa * wb).sqrt();
    for (p, wp) in [(a, wa), (b, wb)] {
        let s = &mut sums[p];
        s.stiffness += k * (wp + cross);
        s.damping += d * (wp + cross);
        s.undamped += u * (wp + cross);
    }
}

/// Length (m) of link `l` at `x`, if both ends exist and are finite.
fn length(x: &[Vec3], l: &Link) -> Option<f32> {
    let d = *x.get(l.b as usize)? - *x.get(l.a as usize)?;
    let len = d.length();
    len.is_finite().then_some(len)
}

/// Bounds the stiffest mode of a cloth at positions `x` (m; module docs).
/// `inverse_masses` in 1/kg; `sums` is scratch, one entry per particle.
pub fn stiffest_mode(
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    inverse_masses: &[f32],
    sums: &mut Vec<ModeSums>,
) -> StiffestMode {
    sums.clear();
    sums.resize(inverse_masses.len(), ModeSums::default());
    let w = inverse_masses;
    // Only explicit Euler needs the undamped part; the others skip its pass.
    let split = settings.integrator == Integrator::ExplicitEuler;
    let x = if split { x } else { &[] };
    // Tension over length: the transverse stiffness of a stretched link.
    let geometric =
        |l: &Link, len: f32, k: f32| (k * (len - l.rest_length)).abs() / len.max(MIN_LENGTH);
    let mut ratio = f32::INFINITY;
    let mut damped = |k: f32, d: f32| {
        if k > 0.0 {
            ratio = ratio.min(d.max(0.0) / k);
        }
    };
    // The force-law table: the stretching families first, then the
    // buckling ones.
    let laws = crate::sim::model::laws(settings, connections);
    for (links, law) in laws.clone() {
        let (k, kd, tension_only) = match law {
            Law::Tension { k, kd } => (k, kd, true),
            Law::Spring { ks, kd } => (ks, kd, false),
            Law::Buckling { .. } => continue,
        };
        if !links.is_empty() {
            damped(k, kd);
        }
        for l in links {
            // A slack tension-only link has no geometric stiffness.
            let len = length(x, l).filter(|&len| !tension_only || len > l.rest_length);
            let u = len.map_or(0.0, |len| geometric(l, len, k));
            add_link(sums, w, l, k, kd, u);
        }
    }
    for (links, law) in laws {
        let Law::Buckling { table, kb, cb } = law else {
            continue;
        };
        let curve = 12.0 * std::f32::consts::PI.powi(2) * kb;
        for l in links {
            let rest = l.rest_length.max(MIN_LENGTH);
            let stiffest = cb.max(curve / (rest * rest * rest));
            // Its push over its length, plus its slope once buckled.
            let u = length(x, l).map_or(0.0, |len| {
                let (f, slope) = type2_magnitude(table, len, rest, kb, cb);
                let slope = if slope == cb { 0.0 } else { slope.abs() };
                f.abs() / len.max(MIN_LENGTH) + slope
            });
            add_link(sums, w, l, stiffest, 0.0, u);
        }
    }
    // A fold term pushes its hinge against its two ends: count it on all three.
    for t in &connections.fold {
        for p in [t.a, t.hinge, t.c] {
            if let (Some(s), Some(&w)) = (sums.get_mut(p as usize), w.get(p as usize)) {
                s.stiffness += 2.0 * t.stiffness * w;
                s.undamped += 2.0 * t.stiffness * w;
            }
        }
    }
    let max = sums.iter().fold(ModeSums::default(), |m, s| ModeSums {
        stiffness: m.stiffness.max(s.stiffness),
        damping: m.damping.max(s.damping),
        undamped: m.undamped.max(s.undamped),
    });
    let absolute = settings.damping.max(0.0);
    StiffestMode {
        omega: max.stiffness.sqrt(),
        damping: absolute + max.damping,
        absolute,
        pair_ratio: if ratio.is_finite() { ratio } else { 0.0 },
        undamped_omega: max.undamped.sqrt(),
    }
}

/// The largest stable step (s) of `integrator` for a mode (module docs);
/// `None` if the integrator has no bound or the mode does not constrain it.
pub(crate) fn stable_step(integrator: Integrator, mode: StiffestMode) -> Option<f32> {
    let (w, c) = (mode.omega, mode.damping);
    if w.is_nan() || w <= 0.0 || !w.is_finite() || !c.is_finite() {
        return None;
    }
    match integrator {
        Integrator::ExplicitEuler => {
            let (c_abs, u) = (mode.absolute, mode.undamped_omega);
            let undamped = if u > 0.0 {
                c_abs / (u * u)
            } else {
                f32::INFINITY
            };
            let split = mode.pair_ratio.min(undamped);
            Some((c_abs / (w * w)).max(split).min(2.0 / (w + c)))
        }
        Integrator::SymplecticEuler => Some(((c * c + 4.0 * w * w).sqrt() - c) / (w * w)),
        Integrator::Rk4 => Some(2.78 / (w + c)),
        Integrator::BackwardEuler | Integrator::Bdf2 => None,
    }
}

impl AdaptiveSubsteps {
    /// The substeps (≥ `floor`) that keep a step of `dt` seconds within the
    /// bound, capped at [`AdaptiveSubsteps::max_substeps`].
    pub fn substeps(&self, floor: u32, dt: f32, integrator: Integrator, mode: StiffestMode) -> u32 {
        let floor = floor.max(1);
        let Some(bound) = stable_step(integrator, mode) else {
            return floor;
        };
        let step = bound * self.safety.clamp(f32::MIN_POSITIVE, 1.0);
        let needed = (dt / step).ceil();
        let needed = if needed.is_finite() {
            needed.min(u32::MAX as f32) as u32
        } else {
            u32::MAX
        };
        needed.min(self.max_substeps.max(1)).max(floor)
    }
}

/// The substeps a cloth runs for a step of `dt` seconds: `settings.substeps`,
/// raised by [`AdaptiveSubsteps`] when enabled for an explicit integrator.
pub(crate) fn substeps_for(
    settings: &SimSettings,
    connections: &Connections,
    particles: &Particles,
    dt: f32,
    sums: &mut Vec<ModeSums>,
) -> u32 {
    match settings.adaptive {
        Some(adaptive) if !settings.integrator.is_implicit() => {
            let (x, w) = (&particles.positions, &particles.inverse_masses);
            let mode = stiffest_mode(settings, connections, x, w, sums);
            adaptive.substeps(settings.substeps, dt, settings.integrator, mode)
        }
        _ => settings.substeps.max(1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(inverse_masses: &[f32], k: f32) -> (SimSettings, Connections) {
        let mut s = SimSettings::default();
        s.choi_ko.stiffness = k;
        s.choi_ko.pair_damping = 0.0;
        s.damping = 0.0;
        let mut c = Connections::default();
        c.structural.push(Link {
            a: 0,
            b: 1,
            rest_length: 1.0,
        });
        assert_eq!(inverse_masses.len(), 2);
        (s, c)
    }

    #[test]
    fn the_bound_is_exact_for_a_free_and_a_pinned_pair() {
        let (k, m) = (1000.0_f32, 0.01_f32);
        let mut sums = Vec::new();
        // Two free masses: ω² = k(1/m + 1/m) = 2k/m.
        let (s, c) = pair(&[1.0 / m, 1.0 / m], k);
        let x = [Vec3::ZERO, Vec3::X];
        let mode = stiffest_mode(&s, &c, &x, &[1.0 / m, 1.0 / m], &mut sums);
        assert!((mode.omega - (2.0 * k / m).sqrt()).abs() < 1e-2);
        // One end pinned: ω² = k/m.
        let mode = stiffest_mode(&s, &c, &x, &[0.0, 1.0 / m], &mut sums);
        assert!((mode.omega - (k / m).sqrt()).abs() < 1e-2);
        // Both pinned: nothing moves, nothing bounds the step.
        let mode = stiffest_mode(&s, &c, &x, &[0.0, 0.0], &mut sums);
        assert_eq!(mode.omega, 0.0);
        assert_eq!(stable_step(Integrator::Rk4, mode), None);
    }

    #[test]
    fn the_bound_covers_the_hanging_cloths_stiffest_mode() {
        // MODEL.md §6.4: ω_max = 3.6e3 rad/s, linearised at the hanging
        // equilibrium of 15×15 cotton, where many links are slack. The bound
        // counts every link, so it must lie above, but not absurdly.
        let cloth = crate::lab::accuracy::scene(15);
        let s = SimSettings::default();
        let mut sums = Vec::new();
        let mode = stiffest_mode(
            &s,
            &cloth.connections,
            &cloth.particles.positions,
            &cloth.particles.inverse_masses,
            &mut sums,
        );
        assert!(
            mode.omega > 3.6e3 && mode.omega < 3.0 * 3.6e3,
            "{}",
            mode.omega
        );
        // Cotton's pair damping adds to the absolute damping.
        assert!(mode.damping > s.damping, "{}", mode.damping);
    }

    #[test]
    fn explicit_euler_counts_pair_damping_only_against_axial_stiffness() {
        let (k, kd, c, m) = (1000.0_f32, 0.05_f32, 0.5_f32, 0.01_f32);
        let w = [1.0 / m, 1.0 / m];
        let (mut s, conn) = pair(&w, k);
        s.choi_ko.pair_damping = kd;
        s.damping = c;
        s.integrator = Integrator::ExplicitEuler;
        let mut sums = Vec::new();
        let euler = |x: &[Vec3], s: &SimSettings, sums: &mut Vec<ModeSums>| {
            let mode = stiffest_mode(s, &conn, x, &w, sums);
            (mode, stable_step(Integrator::ExplicitEuler, mode).unwrap())
        };
        // At rest length nothing is undamped: the axial mode's ratio r = k_d/k.
        let (mode, step) = euler(&[Vec3::ZERO, Vec3::X], &s, &mut sums);
        assert_eq!(mode.undamped_omega, 0.0);
        assert!((step - kd / k).abs() < 1e-3 * kd / k, "{step}");
        // Stretched 10%, the transverse mode (ω² = 2(f/ℓ)/m) sees only c,
        // and c/ω² = 2.75e-5 s is now below r = 5e-5 s.
        let (mode, step) = euler(&[Vec3::ZERO, 1.1 * Vec3::X], &s, &mut sums);
        let transverse = 2.0 * k * 0.1 / 1.1 / m;
        assert!((mode.undamped_omega.powi(2) / transverse - 1.0).abs() < 1e-3);
        assert!((step - c / transverse).abs() < 1e-3 * step, "{step}");
        // Without pair damping only c/ω² is left: MODEL.md §6.1.
        s.choi_ko.pair_damping = 0.0;
        let (mode, step) = euler(&[Vec3::ZERO, Vec3::X], &s, &mut sums);
        assert!(
            (step - c / mode.omega.powi(2)).abs() < 1e-3 * step,
            "{step}"
        );
        // Symplectic Euler's bound does not depend on the split.
        let symplectic = stable_step(Integrator::SymplecticEuler, mode).unwrap();
        assert!((symplectic - 2.0 / (2.0 * k / m).sqrt()).abs() < 1e-2 * symplectic);
    }

    #[test]
    fn stable_steps_match_model_6_4() {
        // ω = 3.6e3 rad/s, c = 2/s: the predicted column of MODEL.md §6.4.
        let mode = StiffestMode {
            omega: 3.6e3,
            damping: 2.0,
            absolute: 2.0,
            ..Default::default()
        };
        let close = |i, want: f32| {
            let got = stable_step(i, mode).unwrap();
            assert!((got - want).abs() < 0.03 * want, "{i:?}: {got} vs {want}");
        };
        close(Integrator::ExplicitEuler, 1.5e-7);
        close(Integrator::SymplecticEuler, 5.55e-4);
        close(Integrator::Rk4, 7.7e-4);
        assert_eq!(stable_step(Integrator::Bdf2, mode), None);
    }

    #[test]
    fn substeps_scale_with_the_root_of_stiffness_and_respect_floor_and_cap() {
        let a = AdaptiveSubsteps {
            safety: 1.0,
            max_substeps: 1000,
        };
        let mode = |omega| StiffestMode {
            omega,
            ..Default::default()
        };
        let dt = 1.0 / 60.0;
        let i = Integrator::SymplecticEuler;
        // 2/ω per substep: ω = 1190 needs 9.9, so 10.
        assert_eq!(a.substeps(1, dt, i, mode(1190.0)), 10);
        // ×100 stiffness is ×10 ω and ×10 substeps.
        assert_eq!(a.substeps(1, dt, i, mode(11_900.0)), 100);
        assert_eq!(a.substeps(40, dt, i, mode(1190.0)), 40);
        assert_eq!(a.substeps(1, dt, i, mode(1e9)), 1000);
        assert_eq!(a.substeps(3, dt, Integrator::BackwardEuler, mode(1e9)), 3);
    }
}
