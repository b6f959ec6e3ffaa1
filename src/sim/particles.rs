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
///
/// Each pin has owners ([`PinOwner`]): the builder, an anchor, a grab, a
/// skin, the player's pointer or the game. A particle stays pinned while
/// any owner holds it, so one letting go ([`release_pin`](Self::release_pin):
/// a grab released, an anchor detached) leaves another's pin in place.
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
    /// Who holds each pinned particle: a [`PinOwner`] bit set (empty for a
    /// free particle, or one whose inverse mass was written directly).
    pins: Vec<u8>,
}

/// Who pinned a particle ([`Particles::pin_by`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Reflect)]
pub enum PinOwner {
    /// The cloth's builder (`ClothBuilder::pin`, a mesh's pin attribute).
    Builder,
    /// An anchor (`ClothAnchors`).
    Anchor,
    /// A kinematic grab (`ClothGrabs`).
    Grab,
    /// A skin, for its particles of freedom 0 (`ClothSkin`).
    Skin,
    /// The player's pointer (`ClothPicking`'s secondary button).
    Picking,
    /// Game code ([`Particles::pin`]).
    Game,
}

impl PinOwner {
    fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// What a seam sums of the particles it joins ([`Particles::sew`]).
#[derive(Clone)]
struct Joined {
    /// Mass, kg.
    mass: f32,
    /// Mass times position, kg·m.
    mx: Vec3,
    /// Momentum, kg·m/s.
    mv: Vec3,
    /// Position (m) and velocity (m/s) of the first pinned particle.
    held: Option<(Vec3, Vec3)>,
    /// Pin owners.
    pins: u8,
}

impl Particles {
    /// Particles at rest at `positions` (m) with masses `masses` (kg, > 0).
    pub fn new(positions: Vec<Vec3>, masses: Vec<f32>) -> Self {
        debug_assert_eq!(positions.len(), masses.len());
        Self {
            velocities: vec![Vec3::ZERO; positions.len()],
            inverse_masses: masses.iter().map(|m| 1.0 / m).collect(),
            pins: vec![0; positions.len()],
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

    /// Pins particle `i` where it is, at rest, for the game
    /// ([`PinOwner::Game`]). Returns `false` if `i` is out of range.
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
        self.pin_by(i, PinOwner::Game)
    }

    /// Pins particle `i` where it is, at rest, for `owner` (it may hold a
    /// pin others hold too). A particle pinned with no owner (its inverse
    /// mass written as 0 directly) counts as the game's. Returns `false` if
    /// `i` is out of range.
    pub fn pin_by(&mut self, i: usize, owner: PinOwner) -> bool {
        if i >= self.len() {
            return false;
        }
        self.pins.resize(self.len(), 0);
        if self.pins[i] == 0 && self.inverse_masses[i] == 0.0 {
            self.pins[i] = PinOwner::Game.bit();
        }
        self.pins[i] |= owner.bit();
        self.inverse_masses[i] = 0.0;
        self.velocities[i] = Vec3::ZERO;
        true
    }

    /// Lets go of `owner`'s pin of particle `i`: it gets its mass back
    /// (keeping its velocity, m/s) if no other owner holds it, and stays
    /// pinned otherwise. A particle `owner` does not hold is left as it is.
    /// Returns whether `i` is pinned afterwards (`false` when out of range).
    pub fn release_pin(&mut self, i: usize, owner: PinOwner) -> bool {
        if !self.is_pinned_by(i, owner) {
            return self.is_pinned(i);
        }
        self.pins[i] &= !owner.bit();
        if self.pins[i] == 0 {
            self.inverse_masses[i] = 1.0 / self.masses[i];
        }
        self.is_pinned(i)
    }

    /// Frees particle `i` from every owner's pin, restoring its mass (its
    /// velocity, m/s, is kept). An anchor or a skin pins its particle again
    /// at its next step; detach the anchor to free it for good. Returns
    /// `false` if `i` is out of range.
    pub fn unpin(&mut self, i: usize) -> bool {
        if i >= self.len() {
            return false;
        }
        if let Some(pins) = self.pins.get_mut(i) {
            *pins = 0;
        }
        self.inverse_masses[i] = 1.0 / self.masses[i];
        true
    }

    /// Whether `owner` holds a pin of particle `i` (`false` when out of
    /// range).
    pub fn is_pinned_by(&self, i: usize, owner: PinOwner) -> bool {
        self.pins.get(i).is_some_and(|&b| b & owner.bit() != 0) && self.is_pinned(i)
    }

    /// Whether particle `i` is pinned (`false` when out of range).
    pub fn is_pinned(&self, i: usize) -> bool {
        self.inverse_masses.get(i) == Some(&0.0)
    }

    /// Joins the particles `seam` sews together (`Seam`):
    /// each joined particle has the sum of their masses and their pins; a
    /// free one sits at their mass-weighted mean position with their
    /// mass-weighted mean velocity (their momentum kept), a pinned one where
    /// its first pinned particle was. Particles of another count than the
    /// seam's are left alone.
    pub(crate) fn sew(&mut self, seam: &crate::sim::sew::Seam) {
        let n = self.len();
        if seam.map.len() != n || self.velocities.len() != n || self.masses.len() != n {
            return;
        }
        self.pins.resize(n, 0);
        let mut joined: Vec<Joined> = (0..n)
            .map(|i| {
                let (m, x, v) = (self.masses[i], self.positions[i], self.velocities[i]);
                let pinned = self.inverse_masses[i] == 0.0;
                let pins = if pinned && self.pins[i] == 0 {
                    PinOwner::Game.bit()
                } else {
                    self.pins[i]
                };
                Joined {
                    mass: m,
                    mx: m * x,
                    mv: m * v,
                    held: pinned.then_some((x, v)),
                    pins,
                }
            })
            .collect();
        seam.merge(&mut joined, |kept, other| {
            kept.mass += other.mass;
            kept.mx += other.mx;
            kept.mv += other.mv;
            kept.held = kept.held.or(other.held);
            kept.pins |= other.pins;
        });
        self.positions.clear();
        self.velocities.clear();
        self.masses.clear();
        self.inverse_masses.clear();
        self.pins.clear();
        for j in joined {
            let (x, v) = j.held.unwrap_or((j.mx / j.mass, j.mv / j.mass));
            self.positions.push(x);
            self.velocities.push(v);
            self.masses.push(j.mass);
            self.inverse_masses
                .push(if j.held.is_some() { 0.0 } else { 1.0 / j.mass });
            self.pins.push(if j.held.is_some() { j.pins } else { 0 });
        }
    }

    /// Appends a copy of particle `i` at its position and velocity that
    /// takes `share` (dimensionless, clamped to (0, 1)) of its mass, and
    /// returns the copy's index (`None` when `i` is out of range): the
    /// split of a particle a tear passes. The copy keeps the pins of the
    /// builder, the game, an anchor and a skin; a grab's or the pointer's
    /// pin holds the original only, so the copy is free of it.
    pub fn push_copy(&mut self, i: usize, share: f32) -> Option<u32> {
        if i >= self.len() || self.velocities.len() != self.len() {
            return None;
        }
        self.pins.resize(self.len(), 0);
        let share = if share.is_finite() {
            share.clamp(1e-6, 1.0 - 1e-6)
        } else {
            0.5
        };
        let mass = self.masses[i];
        let held = if self.pins[i] == 0 && self.inverse_masses[i] == 0.0 {
            PinOwner::Game.bit()
        } else {
            self.pins[i]
        };
        let kept = held & !(PinOwner::Grab.bit() | PinOwner::Picking.bit());
        self.masses[i] = mass * (1.0 - share);
        if self.inverse_masses[i] != 0.0 {
            self.inverse_masses[i] = 1.0 / self.masses[i];
        }
        let copy = self.len() as u32;
        self.positions.push(self.positions[i]);
        self.velocities.push(self.velocities[i]);
        self.masses.push(mass * share);
        self.inverse_masses
            .push(if kept != 0 { 0.0 } else { 1.0 / (mass * share) });
        self.pins.push(kept);
        Some(copy)
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

    #[test]
    fn a_pin_stays_while_any_owner_holds_it() {
        let mut p = Particles::new(vec![Vec3::ZERO; 3], vec![0.5; 3]);
        assert!(p.pin_by(0, PinOwner::Builder) && p.pin_by(0, PinOwner::Grab));
        assert!(p.release_pin(0, PinOwner::Grab), "the builder's pin stays");
        assert!(p.is_pinned_by(0, PinOwner::Builder) && !p.is_pinned_by(0, PinOwner::Grab));
        // Letting go of a pin one does not hold changes nothing.
        assert!(p.release_pin(0, PinOwner::Anchor));
        assert!(!p.release_pin(0, PinOwner::Builder));
        assert_eq!(p.inverse_masses[0], 2.0);
        // A released particle keeps its velocity.
        p.pin_by(1, PinOwner::Anchor);
        p.velocities[1] = Vec3::X;
        assert!(!p.release_pin(1, PinOwner::Anchor));
        assert_eq!(p.velocities[1], Vec3::X);
        // `unpin` frees it from every owner.
        p.pin_by(2, PinOwner::Skin);
        p.pin(2);
        assert!(p.unpin(2) && !p.is_pinned(2) && !p.is_pinned_by(2, PinOwner::Skin));
        assert!(!p.pin_by(3, PinOwner::Game) && !p.release_pin(3, PinOwner::Game));
    }

    #[test]
    fn a_copy_takes_its_share_of_the_mass_and_the_lasting_pins() {
        let mut p = Particles::new(vec![Vec3::ZERO, Vec3::X], vec![0.4, 0.8]);
        p.velocities[1] = Vec3::Y;
        assert_eq!(p.push_copy(1, 0.25), Some(2));
        assert!((p.masses[1] - 0.6).abs() < 1e-6 && (p.masses[2] - 0.2).abs() < 1e-6);
        assert!((p.inverse_masses[2] - 5.0).abs() < 1e-4);
        assert_eq!((p.velocities[2], p.positions[2]), (Vec3::Y, Vec3::X));
        // A grabbed particle's copy is free; a builder's pin holds both.
        p.pin_by(0, PinOwner::Grab);
        let free = p.push_copy(0, 0.5).unwrap() as usize;
        assert!(!p.is_pinned(free) && (p.masses[free] - 0.2).abs() < 1e-7);
        p.pin_by(1, PinOwner::Builder);
        let held = p.push_copy(1, 0.5).unwrap() as usize;
        assert!(p.is_pinned_by(held, PinOwner::Builder) && p.is_pinned(1));
        assert_eq!(p.push_copy(9, 0.5), None);
        let total: f32 = p.masses.iter().sum();
        assert!((total - 1.2).abs() < 1e-6);
    }

    #[test]
    fn a_pin_written_into_the_inverse_mass_counts_as_the_game_s() {
        let mut p = Particles::new(vec![Vec3::ZERO; 2], vec![0.5; 2]);
        p.inverse_masses[0] = 0.0;
        p.pin_by(0, PinOwner::Grab);
        assert!(p.release_pin(0, PinOwner::Grab));
        assert!(p.is_pinned_by(0, PinOwner::Game));
        // Resized by hand past its owners: still answers, never panics.
        p.positions.push(Vec3::Y);
        p.velocities.push(Vec3::ZERO);
        p.masses.push(1.0);
        p.inverse_masses.push(1.0);
        assert!(!p.is_pinned_by(2, PinOwner::Game) && !p.release_pin(2, PinOwner::Game));
        assert!(p.pin_by(2, PinOwner::Anchor) && p.is_pinned_by(2, PinOwner::Anchor));
    }
}
