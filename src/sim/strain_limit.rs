//! Strain limiting: Type 1 links stretched past a bound are shortened to it
//! by moving their particles, and the particles' velocities follow.
//!
//! An implicit step is linearised where it starts. A stiff or fine sheet let
//! go horizontal pulls on its pins with no stiffness across its plane in that
//! linearisation (a straight link under no tension has no transverse
//! stiffness), so at 256×256 its first step stretches the links at the pins
//! by a fifth, and the next ones more: far more than its forces allow.
//! Newton corrections re-linearise where the step ended, but from so far
//! away they can diverge. [`limit_strain`] projects such links back:
//! Gauss–Seidel sweeps over the Type 1 links, each link stretched past
//! `(1 + bound)` times its rest length shortened to just under that, its
//! particles moved in proportion to their inverse masses (a pinned particle
//! does not move), and each particle's velocity changed by its displacement
//! over the step, `Δv = Δx / h`, as backward Euler's `x₁ = x₀ + h v₁`
//! requires (`Δx / ⅔h` for BDF2). Moving particles along their links,
//! weighted by inverse mass, keeps the cloth's momentum. It is the strain
//! limiting of Provot (1995) applied after an implicit step.

use bevy::math::Vec3;

use crate::sim::connections::Link;

/// Most sweeps [`limit_strain`] takes in one step. A 256×256 sheet let go
/// horizontal needs up to about 100 in its first frames; one a sweep cannot
/// help (its links held stretched between pins) stops far sooner.
pub const MAX_SWEEPS: u32 = 200;

/// What [`limit_strain`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limited {
    /// Sweeps over the links taken.
    pub sweeps: u32,
    /// The largest Type 1 strain (dimensionless) past the bound that the
    /// last sweep found (and shortened); 0 when every link was within it.
    pub strain: f32,
}

/// Shortens every link of `links` stretched past `(1 + bound)` times its
/// rest length to `(1 + 0.95 bound)` times it, sweep after sweep, until a
/// sweep finds none past the bound, `max_sweeps` were taken, or 8 sweeps
/// took less than a tenth off the worst excess (links held stretched
/// between pinned particles, which no sweep can help). `gamma` (s) is how a
/// position changes with its velocity at the end of the step (`h` for
/// backward Euler, `⅔h` for BDF2): velocities `v` (m/s) change by the
/// displacement of positions `x` (m) over `gamma`. Particles with inverse
/// mass `w` (1/kg) zero do not move; a link between two of them, or with a
/// non-finite length, is left as it is.
pub fn limit_strain(
    links: &[&[Link]],
    x: &mut [Vec3],
    v: &mut [Vec3],
    w: &[f32],
    gamma: f32,
    bound: f32,
    max_sweeps: u32,
) -> Limited {
    /// What a link past the bound is shortened to, as a fraction of the
    /// bound: far enough under it that the sweeps end below the bound
    /// rather than settle just above it where links pull against each
    /// other (after a 256×256 sheet's wildest first steps).
    const TARGET: f32 = 0.95;
    /// Sweeps over which the worst excess must fall by [`PROGRESS`].
    const WINDOW: u32 = 8;
    /// Least fraction of the worst excess [`WINDOW`] sweeps must take off.
    const PROGRESS: f32 = 0.1;
    let inv_gamma = 1.0 / gamma;
    let mut worst = 0.0_f32;
    let mut checkpoint = f32::INFINITY;
    let mut sweeps = 0;
    while sweeps < max_sweeps {
        sweeps += 1;
        worst = 0.0;
        for l in links.iter().flat_map(|f| f.iter()) {
            let (a, b) = (l.a as usize, l.b as usize);
            let d = x[b] - x[a];
            let len = d.length();
            if !len.is_finite() || len <= (1.0 + bound) * l.rest_length {
                continue;
            }
            let (wa, wb) = (w[a], w[b]);
            let sum = wa + wb;
            if sum <= 0.0 {
                continue;
            }
            worst = worst.max(len / l.rest_length - 1.0);
            let most = (1.0 + TARGET * bound) * l.rest_length;
            let corr = d * ((len - most) / (len * sum));
            x[a] += wa * corr;
            x[b] -= wb * corr;
            v[a] += wa * inv_gamma * corr;
            v[b] -= wb * inv_gamma * corr;
        }
        if worst == 0.0 {
            break;
        }
        if sweeps % WINDOW == 0 {
            if worst - bound > (1.0 - PROGRESS) * (checkpoint - bound) {
                break;
            }
            checkpoint = worst;
        }
    }
    Limited {
        sweeps,
        strain: worst,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain of `n` particles 0.1 m apart along x, particle 0 pinned.
    fn chain(n: u32) -> (Vec<Link>, Vec<Vec3>, Vec<f32>) {
        let x: Vec<Vec3> = (0..n).map(|i| Vec3::X * 0.1 * i as f32).collect();
        let links = (0..n - 1).map(|i| Link::from_rest(i, i + 1, &x)).collect();
        let mut w = vec![2.0; n as usize];
        w[0] = 0.0;
        (links, x, w)
    }

    fn strain(links: &[Link], x: &[Vec3]) -> f32 {
        crate::sim::connections::max_strain(links, x)
    }

    #[test]
    fn a_stretched_chain_is_brought_to_the_bound_and_its_pin_stays() {
        let (links, mut x, w) = chain(20);
        // The free end dragged 1 m down: the last link strains by 10×.
        x[19].y -= 1.0;
        let before = x.clone();
        let mut v = vec![Vec3::ZERO; 20];
        let got = limit_strain(&[&links], &mut x, &mut v, &w, 0.01, 0.05, MAX_SWEEPS);
        assert_eq!(got.strain, 0.0, "{got:?}");
        assert!(strain(&links, &x) <= 0.05 + 1e-6);
        assert_eq!(x[0], before[0], "a pinned particle does not move");
        for i in 0..20 {
            let dv = v[i] - (x[i] - before[i]) / 0.01;
            assert!(dv.length() < 1e-3, "velocity follows the displacement");
        }
    }

    #[test]
    fn it_conserves_momentum_between_free_particles() {
        // Two free particles of 1 kg and 3 kg, 0.1 m apart at rest, pulled to 0.3 m.
        let mut x = vec![Vec3::ZERO, Vec3::X * 0.1];
        let links = vec![Link::from_rest(0, 1, &x)];
        x[1] = Vec3::new(0.2, 0.2, 0.0);
        let w = [1.0, 1.0 / 3.0];
        let mut v = vec![Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.5, 0.0, 0.0)];
        let momentum = |v: &[Vec3]| v[0] / w[0] + v[1] / w[1];
        let centre = |x: &[Vec3]| x[0] / w[0] + x[1] / w[1];
        let (p0, c0) = (momentum(&v), centre(&x));
        limit_strain(&[&links], &mut x, &mut v, &w, 1.0 / 60.0, 0.1, 1);
        // Shortened to 95 % of the bound: 1.095 times its rest length.
        assert!(((x[1] - x[0]).length() - 0.1095).abs() < 1e-6);
        assert!((momentum(&v) - p0).length() < 1e-4);
        assert!((centre(&x) - c0).length() < 1e-6);
    }

    #[test]
    fn links_within_the_bound_and_between_pins_are_left_alone() {
        let (links, mut x, mut w) = chain(5);
        x[1].x += 0.004; // 4 % on the first link
        w[3] = 0.0;
        w[4] = 0.0;
        x[4].x += 0.05; // 50 % on the link between two pins
        let (x0, mut v) = (x.clone(), vec![Vec3::ONE; 5]);
        let got = limit_strain(
            &[&links[..2], &links[2..]],
            &mut x,
            &mut v,
            &w,
            0.01,
            0.05,
            10,
        );
        assert_eq!(x, x0);
        assert!(v.iter().all(|&v| v == Vec3::ONE));
        assert_eq!(
            got,
            Limited {
                sweeps: 1,
                strain: 0.0
            }
        );
    }

    #[test]
    fn a_chain_held_stretched_between_pins_stops_sweeping() {
        // 11 particles 0.1 m apart, both ends pinned 1.5 m apart: every
        // link must stay 50 % long, whatever a sweep does.
        let (links, mut x, mut w) = chain(11);
        x[10].x = 1.5;
        w[10] = 0.0;
        let mut v = vec![Vec3::ZERO; 11];
        let got = limit_strain(&[&links], &mut x, &mut v, &w, 0.01, 0.05, MAX_SWEEPS);
        assert!(got.sweeps < MAX_SWEEPS / 2, "{got:?}");
        assert!(got.strain > 0.45, "{got:?}");
        assert!(x.iter().chain(&v).all(|p| p.is_finite()));
        assert_eq!((x[0], x[10]), (Vec3::ZERO, Vec3::X * 1.5));
    }

    #[test]
    fn a_non_finite_position_is_skipped_not_spread() {
        let (links, mut x, w) = chain(4);
        x[2] = Vec3::NAN;
        let mut v = vec![Vec3::ZERO; 4];
        limit_strain(&[&links], &mut x, &mut v, &w, 0.01, 0.05, 5);
        assert!(x[3].is_finite() && x[1].is_finite() && v[1].is_finite());
    }
}
