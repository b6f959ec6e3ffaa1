//! [`Fabric`]: what a cloth is made of, in physical units, so that the
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
//! In an app, the `ClothMaterial` component holds a cloth's fabric; a cloth
//! whose material is `ClothMaterial::Raw` uses the per-link constants of its
//! [`SimSettings`] as they are.

use bevy::reflect::Reflect;
use bevy::reflect::std_traits::ReflectDefault;

use crate::error::ClothError;
use crate::sim::settings::SimSettings;

/// Bending rigidity of a cylindrical bend per unit of Type 2 flexural
/// rigidity over spacing, `B h / k_b` (dimensionless; MODEL.md §11).
pub(crate) const BENDING_PER_LINK: f32 = 3.41;

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
    /// The strain at which the fabric tears (dimensionless, > 0): a Type 1
    /// link of a cloth with tearing on breaks when stretched by this
    /// fraction of its rest length (`ClothTearing`).
    pub tear_strain: f32,
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
        tear_strain: 0.15,
    };
    /// Light silk (60 g/m²): limp and flowing.
    pub const SILK: Self = Self {
        stretch: 2_000.0,
        shear: 2_000.0,
        bending: 2.0e-6,
        density: 0.06,
        damping: 1.0,
        stretch_damping: 0.04,
        tear_strain: 0.25,
    };
    /// Denim (400 g/m²): heavy, stiff, slow folds.
    pub const DENIM: Self = Self {
        stretch: 20_000.0,
        shear: 20_000.0,
        bending: 2.5e-4,
        density: 0.4,
        damping: 2.0,
        stretch_damping: 0.4,
        tear_strain: 0.3,
    };
    /// Leather (1 kg/m²): very heavy and stiff; it bends in broad curves.
    pub const LEATHER: Self = Self {
        stretch: 50_000.0,
        shear: 50_000.0,
        bending: 2.0e-3,
        density: 1.0,
        damping: 3.0,
        stretch_damping: 1.0,
        tear_strain: 0.5,
    };
    /// Paper (80 g/m²): nearly inextensible, stiff in bending, creases.
    pub const PAPER: Self = Self {
        stretch: 100_000.0,
        shear: 100_000.0,
        bending: 1.0e-3,
        density: 0.08,
        damping: 2.0,
        stretch_damping: 0.5,
        tear_strain: 0.03,
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
        if !(self.tear_strain.is_finite() && self.tear_strain > 0.0) {
            return Err(ClothError::InvalidTearing {
                name: "fabric.tear_strain",
                value: self.tear_strain,
            });
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
    pub fn apply(&self, settings: &mut SimSettings, spacing: f32) {
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
