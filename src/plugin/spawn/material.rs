//! [`ClothMaterial`]: the fabric of a cloth entity, and the system that
//! gives its particles the fabric's density when it changes.

use bevy::prelude::{
    Changed, Component, DetectChanges, Query, Ref, Reflect, ReflectComponent, ReflectDefault,
};

use crate::error::ClothError;
use crate::plugin::step::components::{Cloth, ClothParticles};
use crate::sim::material::Fabric;
use crate::sim::particles::Particles;
use crate::sim::settings::SimSettings;

/// What a cloth is made of: a [`Fabric`] (cotton unless you choose), or the
/// raw per-link constants of its [`SimSettings`].
///
/// Every [`Cloth`] has one; [`ClothBuilder::material`](crate::ClothBuilder::material)
/// sets it and the masses that go with it.
/// Changing it on a live cloth changes its stiffness, bending and damping
/// at the next step, and its masses to the new density.
///
/// ```
/// use bevy_cloth::prelude::*;
/// // A denim cloth: its constants follow from the fabric at any resolution.
/// let jeans = ClothBuilder::new(40, 40).material(ClothMaterial::DENIM).build().unwrap();
/// // A stiffer-than-denim custom fabric.
/// let canvas = ClothMaterial::Fabric(Fabric { bending: 6e-4, ..Fabric::DENIM });
/// assert!(canvas.validate().is_ok());
/// ```
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub enum ClothMaterial {
    /// Physical properties; the constants follow from them and the spacing.
    Fabric(Fabric),
    /// The per-link constants and damping of the cloth's [`SimSettings`]
    /// (or [`ClothSettingsDefaults`](crate::ClothSettingsDefaults)), as given: for
    /// reproducing a paper's constants or tuning by hand.
    Raw,
}

impl ClothMaterial {
    /// [`Fabric::COTTON`].
    pub const COTTON: Self = Self::Fabric(Fabric::COTTON);
    /// [`Fabric::SILK`].
    pub const SILK: Self = Self::Fabric(Fabric::SILK);
    /// [`Fabric::DENIM`].
    pub const DENIM: Self = Self::Fabric(Fabric::DENIM);
    /// [`Fabric::LEATHER`].
    pub const LEATHER: Self = Self::Fabric(Fabric::LEATHER);
    /// [`Fabric::PAPER`].
    pub const PAPER: Self = Self::Fabric(Fabric::PAPER);

    /// The fabric, unless raw.
    pub fn fabric(&self) -> Option<&Fabric> {
        match self {
            Self::Fabric(f) => Some(f),
            Self::Raw => None,
        }
    }

    /// Checks the fabric ([`Fabric::validate`]); raw is always valid here
    /// (its constants are checked with the settings).
    pub fn validate(&self) -> Result<(), ClothError> {
        self.fabric().map_or(Ok(()), Fabric::validate)
    }

    /// `settings` with this material's constants for a grid of spacing
    /// `spacing` m: a copy with the fabric applied, or `settings` itself
    /// when raw.
    pub fn settings<'a>(
        &self,
        settings: &'a SimSettings,
        spacing: f32,
    ) -> std::borrow::Cow<'a, SimSettings> {
        match self {
            Self::Fabric(fabric) => {
                let mut own = settings.clone();
                fabric.apply(&mut own, spacing);
                std::borrow::Cow::Owned(own)
            }
            Self::Raw => std::borrow::Cow::Borrowed(settings),
        }
    }
}

impl Default for ClothMaterial {
    fn default() -> Self {
        Self::COTTON
    }
}

/// Run condition of [`apply_density`]: a material changed after its cloth
/// was spawned.
pub(crate) fn materials_changed(
    materials: Query<Ref<ClothMaterial>, Changed<ClothMaterial>>,
) -> bool {
    materials.iter().any(|m| m.last_changed() != m.added())
}

/// [`ClothSystems::Prepare`](crate::ClothSystems::Prepare): a cloth whose
/// fabric changed takes the new fabric's density: every mass is scaled so
/// the cloth weighs `density × area` (pins stay pins).
pub(crate) fn apply_density(
    _main: crate::plugin::step::schedule::MainThread,
    mut cloths: Query<(&Cloth, Ref<ClothMaterial>, &mut ClothParticles), Changed<ClothMaterial>>,
) {
    for (cloth, material, mut particles) in &mut cloths {
        let Some(fabric) = material.fabric() else {
            continue;
        };
        if material.last_changed() == material.added() || fabric.validate().is_err() {
            continue;
        }
        let total: f32 = particles.masses.iter().sum();
        let scale = fabric.density * cloth.area() / total;
        if !(scale.is_finite() && scale > 0.0) || scale == 1.0 {
            continue;
        }
        let Particles {
            masses,
            inverse_masses,
            ..
        } = &mut particles.0;
        for (m, w) in masses.iter_mut().zip(inverse_masses.iter_mut()) {
            *m *= scale;
            if *w != 0.0 {
                *w = 1.0 / *m;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cotton_at_15x15_has_the_bending_of_model_section_11() {
        // k_b = B·h/3.41 = 2.4e-5 · (1/14) / 3.41 ≈ 5.0e-7 N·m².
        let base = SimSettings::default();
        let s = ClothMaterial::COTTON.settings(&base, 1.0 / 14.0);
        assert!((s.choi_ko.bending_rigidity - 5.03e-7).abs() < 1e-9);
        assert_eq!(s.choi_ko.stiffness, 5000.0);
        assert_eq!(s.choi_ko.shear_stiffness, 5000.0);
        assert_eq!(s.damping, 1.5);
        // Halving the spacing halves k_b and keeps the springs.
        let fine = ClothMaterial::COTTON.settings(&base, 0.5 / 14.0);
        assert!((fine.choi_ko.bending_rigidity - 0.5 * s.choi_ko.bending_rigidity).abs() < 1e-12);
        assert_eq!(fine.choi_ko.stiffness, s.choi_ko.stiffness);
        // Raw leaves the settings as they are.
        let raw = ClothMaterial::Raw.settings(&base, 0.01);
        assert_eq!(*raw, base);
    }

    #[test]
    fn presets_validate_and_bad_fabrics_do_not() {
        for (name, fabric) in Fabric::PRESETS {
            assert!(fabric.validate().is_ok(), "{name}");
            let mut s = SimSettings::default();
            fabric.apply(&mut s, 0.02);
            assert!(s.validate().is_ok(), "{name}");
        }
        let bad = |f: Fabric| ClothMaterial::Fabric(f).validate().unwrap_err();
        assert!(matches!(
            bad(Fabric {
                stretch: 0.0,
                ..Fabric::COTTON
            }),
            ClothError::InvalidStiffness { .. }
        ));
        assert!(matches!(
            bad(Fabric {
                density: f32::NAN,
                ..Fabric::COTTON
            }),
            ClothError::InvalidMass(_)
        ));
        assert!(matches!(
            bad(Fabric {
                damping: -1.0,
                ..Fabric::COTTON
            }),
            ClothError::InvalidDamping { .. }
        ));
        assert!(ClothMaterial::Raw.validate().is_ok());
    }
}
