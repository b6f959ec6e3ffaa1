//! Adaptive substeps (opt-in): explicit integrators pick their substep count
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
//! | explicit Euler | `min(c/ω², 2/(ω + c))` |
//! | symplectic Euler | `(√(c² + 4ω²) − c)/ω²` |
//! | RK4 | `2.78/(ω + c)` |
//! | backward Euler, BDF2 | none |
//!
//! One pass over the links per fixed step, so it follows every change.

use bevy::prelude::Reflect;

use crate::connections::{ClothConnections, Link};
use crate::model::choi_ko::MIN_LENGTH;
use crate::settings::{ClothModel, ClothSettings, Integrator};

/// Opt-in adaptive substeps ([`ClothSettings::adaptive`]).
///
/// With it, an explicit integrator runs `max(substeps, n)` substeps, `n`
/// being the fewest that keep each substep within `safety` times its
/// stability bound (module docs); set [`ClothSettings::substeps`] to 1 to
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

/// The cloth's stiffest mode, as bounded by [`stiffest_mode`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StiffestMode {
    /// Upper bound on the highest angular frequency `ω_max` (rad/s).
    pub omega: f32,
    /// Upper bound on the damping rate `c` (1/s): absolute plus pair damping.
    pub damping: f32,
}

/// Bounds the stiffest mode of a cloth (module docs). `inverse_masses` in
/// 1/kg; `sums` is scratch, one entry per particle.
pub fn stiffest_mode(
    settings: &ClothSettings,
    connections: &ClothConnections,
    inverse_masses: &[f32],
    sums: &mut Vec<[f32; 2]>,
) -> StiffestMode {
    sums.clear();
    sums.resize(inverse_masses.len(), [0.0; 2]);
    let mut add = |links: &[Link], stiffness: &dyn Fn(&Link) -> f32, damping: f32| {
        for l in links {
            let (a, b) = (l.a as usize, l.b as usize);
            let (Some(&wa), Some(&wb)) = (inverse_masses.get(a), inverse_masses.get(b)) else {
                continue;
            };
            let k = stiffness(l);
            let cross = (wa * wb).sqrt();
            for (p, w) in [(a, wa), (b, wb)] {
                sums[p][0] += k * (w + cross);
                sums[p][1] += damping * (w + cross);
            }
        }
    };
    match settings.model {
        ClothModel::ChoiKo => {
            let p = &settings.choi_ko;
            let k = p.stiffness;
            let type2 = |l: &Link| {
                let rest = l.rest_length.max(MIN_LENGTH);
                let curve = 12.0 * std::f32::consts::PI.powi(2) * p.bending_rigidity;
                p.buckling_slope.max(curve / (rest * rest * rest))
            };
            for links in [
                &connections.structural,
                &connections.shear,
                &connections.crease,
            ] {
                add(links, &|_| k, p.pair_damping);
            }
            for links in [&connections.bend, &connections.bend_diagonal] {
                add(links, &type2, 0.0);
            }
        }
        ClothModel::Lander => {
            let p = &settings.lander;
            for (links, s) in [
                (&connections.structural, p.structural),
                (&connections.shear, p.shear),
                (&connections.bend, p.bend),
                (&connections.crease, p.structural),
            ] {
                add(links, &|_| s.stiffness, s.damping);
            }
        }
    }
    // A fold term pushes its hinge against its two ends: count it on all three.
    for t in &connections.fold {
        for p in [t.a, t.hinge, t.c] {
            if let (Some(s), Some(&w)) = (sums.get_mut(p as usize), inverse_masses.get(p as usize))
            {
                s[0] += 2.0 * t.stiffness * w;
            }
        }
    }
    let [omega2, pair] = sums
        .iter()
        .fold([0.0f32; 2], |[k, c], s| [k.max(s[0]), c.max(s[1])]);
    StiffestMode {
        omega: omega2.sqrt(),
        damping: settings.damping.max(0.0) + pair,
    }
}

/// The largest stable step (s) of `integrator` for a mode (module docs);
/// `None` if the integrator has no bound or the mode does not constrain it.
pub fn stable_step(integrator: Integrator, mode: StiffestMode) -> Option<f32> {
    let (w, c) = (mode.omega, mode.damping);
    if w.is_nan() || w <= 0.0 || !w.is_finite() || !c.is_finite() {
        return None;
    }
    match integrator {
        Integrator::ExplicitEuler => Some((c / (w * w)).min(2.0 / (w + c))),
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
pub fn substeps_for(
    settings: &ClothSettings,
    connections: &ClothConnections,
    inverse_masses: &[f32],
    dt: f32,
    sums: &mut Vec<[f32; 2]>,
) -> u32 {
    match settings.adaptive {
        Some(adaptive) if !settings.integrator.is_implicit() => {
            let mode = stiffest_mode(settings, connections, inverse_masses, sums);
            adaptive.substeps(settings.substeps, dt, settings.integrator, mode)
        }
        _ => settings.substeps.max(1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(inverse_masses: &[f32], k: f32) -> (ClothSettings, ClothConnections) {
        let mut s = ClothSettings::default();
        s.choi_ko.stiffness = k;
        s.choi_ko.pair_damping = 0.0;
        s.damping = 0.0;
        let mut c = ClothConnections::default();
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
        let mode = stiffest_mode(&s, &c, &[1.0 / m, 1.0 / m], &mut sums);
        assert!((mode.omega - (2.0 * k / m).sqrt()).abs() < 1e-2);
        // One end pinned: ω² = k/m.
        let mode = stiffest_mode(&s, &c, &[0.0, 1.0 / m], &mut sums);
        assert!((mode.omega - (k / m).sqrt()).abs() < 1e-2);
        // Both pinned: nothing moves, nothing bounds the step.
        let mode = stiffest_mode(&s, &c, &[0.0, 0.0], &mut sums);
        assert_eq!(mode.omega, 0.0);
        assert_eq!(stable_step(Integrator::Rk4, mode), None);
    }

    #[test]
    fn the_bound_covers_the_hanging_cloths_stiffest_mode() {
        // MODEL.md §6.4: ω_max = 3.6e3 rad/s, linearised at the hanging
        // equilibrium of 15×15 cotton, where many links are slack. The bound
        // counts every link, so it must lie above, but not absurdly.
        let cloth = crate::accuracy::scene(15);
        let s = ClothSettings::default();
        let mut sums = Vec::new();
        let mode = stiffest_mode(
            &s,
            &cloth.connections,
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
    fn stable_steps_match_model_6_4() {
        // ω = 3.6e3 rad/s, c = 2/s: the predicted column of MODEL.md §6.4.
        let mode = StiffestMode {
            omega: 3.6e3,
            damping: 2.0,
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
            damping: 0.0,
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
