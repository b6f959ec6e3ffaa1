//! [`ClothMaterial`]: what a cloth is made of, in physical units, so that the
//! same material behaves the same at any resolution.
//!
//! A [`Fabric`] gives the sheet's properties per unit width, independent of
//! how finely it is divided. The model's per-link constants follow from
//! them and the particle spacing `h` (m) of the cloth:
//!
//! | fabric | unit | link constant |
//! |---|---|---|
//! | [`stretch`](Fabric::stretch) | N/m | Type 1 links along the grid: `k = stretch` |
//! | [`shear`](Fabric::shear) | N/m | diagonal Type 1 links: `k = shear` |
//! | [`bending`](Fabric::bending) | N·m | Type 2 links: `k_b = bending · h / 3.41` (N·m²) |
//! | [`density`](Fabric::density) | kg/m² | particle masses, lumped by area |
//! | [`damping`](Fabric::damping) | s⁻¹ | the absolute damping `c` |
//! | [`stretch_damping`](Fabric::stretch_damping) | N·s/m | axial pair damping `k_d` of the Type 1 links |
//!
//! The spring constants need no scaling: a square lattice of springs `k_s`
//! along its edges and `k_d` across its diagonals is a sheet with 2-D
//! stiffness `C₁₁ = k_s + k_d`, `C₁₂ = k_d` and shear modulus `G = k_d`
//! (all N/m) whatever its spacing. Bending does: a cylindrical bend of
//! curvature `κ` stores `½ k_b L κ²` in each Type 2 link (MODEL.md §3.2), and
//! summing the axial and diagonal links over a unit area gives a sheet of
//! rigidity `B = 3.41 k_b / h` (MODEL.md §11), so `k_b = B·h/3.41`. The
//! buckling ramp `c_b` is set to the stretch stiffness, as the paper does,
//! and Lander's springs get `stretch`, `shear` and 0.6 × `stretch`.
//!
//! **What stays the same across resolutions, and what does not.** Stretch,
//! shear, weight and damping do, and so does bending once a Type 2 link has
//! buckled. Below buckling a Type 2 link is the linear ramp `c_b(ℓ − L)`
//! (MODEL.md §3.5), which resists a bend of curvature `κ` only from
//! `κ* ≈ √(288 k_b / (c_b L⁵))` on; with `k_b ∝ h` and `L = 2h` that onset
//! grows as `1/h²`. On a 1 m cloth of 15×15 cotton it is 0.02 m⁻¹ (a bend
//! of 45 m radius), on 61×61 0.4 m⁻¹ (2.5 m radius): a fine cloth meets less
//! resistance in very gentle bends, such as a short stiff strip held out
//! flat (a paper cantilever droops further at 61 particles across than at
//! 15). Drapes, folds and hanging cloth bend far more sharply than that and
//! look the same (tested: the bottom edges of a cloth hanging from two
//! corners, 15×15 against 61×61, within 2 cm for cotton, silk and leather).
//!
//! A cloth whose material is [`ClothMaterial::Raw`] uses the per-link
//! constants of its [`ClothSettings`] as they are.

use bevy::prelude::{
    Changed, Component, DetectChanges, Query, Ref, Reflect, ReflectComponent, ReflectDefault,
};

use crate::error::ClothError;
use crate::grid::Cloth;
use crate::particles::ClothParticles;
use crate::settings::ClothSettings;

/// Bending rigidity of a cylindrical bend per unit of Type 2 flexural
/// rigidity over spacing, `B h / k_b` (dimensionless; MODEL.md §11).
pub const BENDING_PER_LINK: f32 = 3.41;

/// A cloth's properties per unit width, independent of its resolution
/// (module docs). Each preset's figures are typical of the fabric rather
/// than measured on one.
///
/// The presets give shear the stretch stiffness (equal spring constants
/// along and across the grid, as MODEL.md §11 recommends). Real fabrics
/// shear far more easily, and a lower [`shear`](Self::shear) shows it, but
/// the implicit solve then needs more iterations: on a 128×128 cotton
/// cloth, shear at half the stretch took about 90 conjugate-gradient
/// iterations a step against 28, and at a fifth it reached the limit of
/// 100.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Default)]
pub struct Fabric {
    /// Stretch stiffness along the threads, N/m: the force per metre of
    /// width that a unit strain of the grid's links along the threads takes.
    pub stretch: f32,
    /// Shear stiffness, N/m: the in-plane shear modulus per unit width
    /// (the diagonal links' spring constant).
    pub shear: f32,
    /// Bending rigidity `B`, N·m: the moment per metre of width that a unit
    /// curvature takes.
    pub bending: f32,
    /// Areal density, kg/m².
    pub density: f32,
    /// Absolute damping `c`, s⁻¹: air and internal friction on every
    /// particle's velocity (free-fall terminal speed `|g|/c`).
    pub damping: f32,
    /// Axial damping of the stretch links, N·s/m.
    pub stretch_damping: f32,
}

impl Fabric {
    /// Mid-weight cotton (150 g/m²): 2.5 cm bending length, stretches under
    /// 1 % when it hangs.
    pub const COTTON: Self = Self {
        stretch: 5_000.0,
        shear: 5_000.0,
        bending: 2.4e-5,
        density: 0.15,
        damping: 1.5,
        stretch_damping: 0.1,
    };
    /// Light silk (60 g/m²): limp and flowing.
    pub const SILK: Self = Self {
        stretch: 2_000.0,
        shear: 2_000.0,
        bending: 2.0e-6,
        density: 0.06,
        damping: 1.0,
        stretch_damping: 0.04,
    };
    /// Denim (400 g/m²): heavy, stiff, slow folds.
    pub const DENIM: Self = Self {
        stretch: 20_000.0,
        shear: 20_000.0,
        bending: 2.5e-4,
        density: 0.4,
        damping: 2.0,
        stretch_damping: 0.4,
    };
    /// Leather (1 kg/m²): very heavy and stiff; it bends in broad curves.
    pub const LEATHER: Self = Self {
        stretch: 50_000.0,
        shear: 50_000.0,
        bending: 2.0e-3,
        density: 1.0,
        damping: 3.0,
        stretch_damping: 1.0,
    };
    /// Paper (80 g/m²): nearly inextensible, stiff in bending, creases.
    pub const PAPER: Self = Self {
        stretch: 100_000.0,
        shear: 100_000.0,
        bending: 1.0e-3,
        density: 0.08,
        damping: 2.0,
        stretch_damping: 0.5,
    };

    /// Every preset with its name, for menus and tables.
    pub const PRESETS: [(&'static str, Self); 5] = [
        ("cotton", Self::COTTON),
        ("silk", Self::SILK),
        ("denim", Self::DENIM),
        ("leather", Self::LEATHER),
        ("paper", Self::PAPER),
    ];

    /// Checks every property: stiffnesses, rigidity and density finite and
    /// positive, dampings finite and non-negative.
    pub fn validate(&self) -> Result<(), ClothError> {
        for (name, value) in [
            ("fabric.stretch", self.stretch),
            ("fabric.shear", self.shear),
            ("fabric.bending", self.bending),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ClothError::InvalidStiffness { name, value });
            }
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(ClothError::InvalidMass(self.density));
        }
        for (name, value) in [
            ("fabric.damping", self.damping),
            ("fabric.stretch_damping", self.stretch_damping),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ClothError::InvalidDamping { name, value });
            }
        }
        Ok(())
    }

    /// Writes the per-link constants of this fabric on a grid of spacing
    /// `spacing` m (module docs) into `settings`: both models' constants
    /// and the absolute damping.
    pub fn apply(&self, settings: &mut ClothSettings, spacing: f32) {
        let ck = &mut settings.choi_ko;
        ck.stiffness = self.stretch;
        ck.shear_stiffness = self.shear;
        ck.bending_rigidity = self.bending * spacing / BENDING_PER_LINK;
        ck.buckling_slope = self.stretch;
        ck.pair_damping = self.stretch_damping;
        let lander = &mut settings.lander;
        lander.structural.stiffness = self.stretch;
        lander.shear.stiffness = self.shear;
        lander.bend.stiffness = 0.6 * self.stretch;
        for spring in [&mut lander.structural, &mut lander.shear, &mut lander.bend] {
            spring.damping = self.stretch_damping;
        }
        settings.damping = self.damping;
    }
}

impl Default for Fabric {
    fn default() -> Self {
        Self::COTTON
    }
}

/// What a cloth is made of: a [`Fabric`] (cotton unless you choose), or the
/// raw per-link constants of its [`ClothSettings`].
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
    /// The per-link constants and damping of the cloth's [`ClothSettings`]
    /// (or [`ClothDefaults`](crate::ClothDefaults)), as given: for
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
        settings: &'a ClothSettings,
        spacing: f32,
    ) -> std::borrow::Cow<'a, ClothSettings> {
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
    _main: crate::schedule::MainThread,
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
        let ClothParticles {
            masses,
            inverse_masses,
            ..
        } = &mut *particles;
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
        let base = ClothSettings::default();
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
            let mut s = ClothSettings::default();
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
