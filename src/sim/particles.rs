//! [`Particles`]: the state of a cloth's particles as parallel arrays.

use bevy::math::Vec3;
use bevy::reflect::Reflect;

/// Positions, velocities and masses of a cloth's particles (structure of
/// arrays, indexed by `p = row·cols + column` as `u32` elsewhere).
///
/// Positions are in **world space**, metres; velocities in m/s; masses in kg.
/// A particle is pinned when its inverse mass is 0: the integrators give it
/// zero acceleration, so it keeps its velocity (0 for a fixed pin, the
/// anchor's velocity for an anchored one).
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
pub struct Particles {
    /// World-space positions in m.
    pub positions: Vec<Vec3>,
    /// Velocities in m/s.
    pub velocities: Vec<Vec3>,
    /// Inverse masses in 1/kg; 0 for pinned particles.
    pub inverse_masses: Vec<f32>,
    /// Masses in kg, kept so that an unpinned particle gets its mass back.
    pub masses: Vec<f32>,
}

impl Particles {
    /// Particles at rest at `positions` (m) with masses `masses` (kg, > 0).
    pub fn new(positions: Vec<Vec3>, masses: Vec<f32>) -> Self {
        debug_assert_eq!(positions.len(), masses.len());
        Self {
            velocities: vec![Vec3::ZERO; positions.len()],
            inverse_masses: masses.iter().map(|m| 1.0 / m).collect(),
            positions,
            masses,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Pins particle `i` where it is, at rest. Returns `false` if `i` is out
    /// of range.
    ///
    /// ```
    /// # use bevy::prelude::*;
    /// # use bevy_cloth::prelude::*;
    /// /// Nail the cloth's first particle where it is; free it again with `unpin`.
    /// fn nail(mut cloths: Query<&mut ClothParticles>) {
    ///     for mut particles in &mut cloths {
    ///         particles.pin(0);
    ///     }
    /// }
    /// ```
    pub fn pin(&mut self, i: usize) -> bool {
        if i >= self.len() {
            return false;
        }
        self.inverse_masses[i] = 0.0;
        self.velocities[i] = Vec3::ZERO;
        true
    }

    /// Frees particle `i`, restoring its mass. Returns `false` if `i` is out
    /// of range.
    pub fn unpin(&mut self, i: usize) -> bool {
        if i >= self.len() {
            return false;
        }
        self.inverse_masses[i] = 1.0 / self.masses[i];
        true
    }

    /// Whether particle `i` is pinned (`false` when out of range).
    pub fn is_pinned(&self, i: usize) -> bool {
        self.inverse_masses.get(i) == Some(&0.0)
    }

    /// Kinetic energy `Σ ½ m v²` of the free particles in J.
    pub fn kinetic_energy(&self) -> f32 {
        self.velocities
            .iter()
            .zip(&self.inverse_masses)
            .zip(&self.masses)
            .filter(|((_, w), _)| **w != 0.0)
            .map(|((v, _), m)| 0.5 * m * v.length_squared())
            .sum()
    }

    /// Speed of the fastest free particle, m/s (0 when none is free; NaN
    /// when a free velocity is not finite).
    pub fn max_speed(&self) -> f32 {
        let mut fastest = 0.0f32;
        for (v, w) in self.velocities.iter().zip(&self.inverse_masses) {
            if *w != 0.0 {
                let s = v.length_squared();
                if !s.is_finite() {
                    return f32::NAN;
                }
                fastest = fastest.max(s);
            }
        }
        fastest.sqrt()
    }

    /// Whether every position and velocity is finite.
    pub fn is_finite(&self) -> bool {
        self.positions
            .iter()
            .chain(&self.velocities)
            .all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pin_and_unpin_toggle_the_inverse_mass() {
        let mut p = Particles::new(vec![Vec3::ZERO, Vec3::X], vec![0.5, 2.0]);
        p.velocities[1] = Vec3::Y;
        assert!(p.pin(1));
        assert!(p.is_pinned(1) && p.velocities[1] == Vec3::ZERO);
        assert_eq!(p.kinetic_energy(), 0.0);
        assert!(p.unpin(1));
        assert_eq!(p.inverse_masses[1], 0.5);
        assert!(!p.pin(2) && !p.unpin(7) && !p.is_pinned(9));
    }
}
