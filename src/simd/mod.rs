//! The crate's one place for CPU-specific code: the only module that names
//! `std::arch`. Everything else calls the safe functions here.
//!
//! - [`level`] is the instruction set the kernels use, detected once per
//!   process: AVX-512F, AVX2 with FMA, or none ([`Level::Scalar`], the code
//!   every other CPU gets: ARM, older x86-64). On wasm32 it is fixed when
//!   the crate is compiled: [`Level::Simd128`] in a build with
//!   `-C target-feature=+simd128` (a wasm engine cannot be asked at run
//!   time), else [`Level::Scalar`].
//! - The environment variable `BEVY_CLOTH_SIMD` caps it: `scalar`,
//!   `simd128`, `avx2` or `avx512` (read once, at the first step).
//!   `BEVY_CLOTH_SIMD=scalar cargo test` runs the whole suite on the
//!   portable code.
//! - `multiversion!` compiles a function of plain Rust once per level and
//!   runs the build for a given level: the compiler vectorises it as wide
//!   as the CPU allows. The results are the same at every level: plain
//!   Rust neither fuses nor reorders floating-point operations.
//! - The hand-written kernels ([`table`], [`buckling`], [`gather`]) each
//!   have a safe entry point, a scalar reference, and a unit test per level
//!   against that reference.
//!
//! It imports nothing else of the crate.

use std::sync::OnceLock;

pub mod buckling;
pub mod gather;
pub mod table;

/// The environment variable that caps [`level`]: `scalar`, `simd128`,
/// `avx2` or `avx512`.
pub const SIMD_ENV: &str = "BEVY_CLOTH_SIMD";

/// An instruction set the kernels are built for, narrowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// Portable code (what the compiler makes of it for the target's
    /// baseline: SSE2 on x86-64).
    Scalar,
    /// wasm32's 128-bit SIMD, four `f32` lanes, in a build with
    /// `-C target-feature=+simd128` (where the compiler also vectorises
    /// the portable code with it).
    Simd128,
    /// AVX2 with FMA, eight `f32` lanes.
    Avx2,
    /// AVX-512F, sixteen `f32` lanes.
    Avx512,
}

impl Level {
    /// The widest level this CPU runs.
    pub fn detected() -> Level {
        if cfg!(all(target_arch = "wasm32", target_feature = "simd128")) {
            return Level::Simd128;
        }
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Level::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Level::Avx2;
            }
        }
        Level::Scalar
    }

    /// Whether this build on this CPU runs the level: the portable code
    /// everywhere, [`Level::Simd128`] in a wasm32 build with it, the x86-64
    /// levels where the CPU has them.
    fn runs_here(self) -> bool {
        match self {
            Level::Scalar => true,
            Level::Simd128 => cfg!(all(target_arch = "wasm32", target_feature = "simd128")),
            Level::Avx2 | Level::Avx512 => {
                cfg!(target_arch = "x86_64") && self <= Level::detected()
            }
        }
    }

    /// Every level this CPU runs, narrowest first (for tests that compare
    /// each with [`Level::Scalar`]).
    #[cfg(test)]
    pub fn available() -> Vec<Level> {
        Level::ALL.into_iter().filter(|l| l.runs_here()).collect()
    }

    /// Every level, narrowest first.
    const ALL: [Level; 4] = [Level::Scalar, Level::Simd128, Level::Avx2, Level::Avx512];

    /// The widest level this CPU runs that is no wider than `cap`.
    fn capped(cap: Level) -> Level {
        let runs = Level::ALL
            .into_iter()
            .filter(|l| l.runs_here() && *l <= cap);
        runs.max().unwrap_or(Level::Scalar)
    }

    /// The level named by `text` (`scalar`, `simd128`, `avx2`, `avx512`),
    /// if any.
    pub fn parse(text: &str) -> Option<Level> {
        match text.trim().to_ascii_lowercase().as_str() {
            "scalar" | "none" | "off" => Some(Level::Scalar),
            "simd128" => Some(Level::Simd128),
            "avx2" => Some(Level::Avx2),
            "avx512" | "avx512f" => Some(Level::Avx512),
            _ => None,
        }
    }
}

/// The level the kernels use: the widest this CPU runs, capped by
/// `BEVY_CLOTH_SIMD` ([`SIMD_ENV`]); fixed at the first call.
pub fn level() -> Level {
    static LEVEL: OnceLock<Level> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let cap = std::env::var(SIMD_ENV)
            .ok()
            .and_then(|v| Level::parse(&v))
            .unwrap_or(Level::Avx512);
        Level::capped(cap)
    })
}

/// Defines `fn $name(level: Level, args…)` that runs `$inner(args…)`
/// compiled for `level` (capped at what the CPU runs): AVX-512F, AVX2 with
/// FMA, or the target's baseline (on wasm32 the one build, with simd128
/// where the crate is compiled with it). `$inner` must be `#[inline(always)]`, so
/// that its body is compiled into each build; the compiler then vectorises
/// it as wide as the level allows, with the same results at every level
/// (plain Rust neither fuses nor reorders floating-point operations).
/// `unsafe fn` defines an unsafe function of an unsafe `$inner`.
///
/// ```ignore
/// multiversion! {
///     /// The solve, compiled for the CPU.
///     fn pcg_at(params: &ImplicitSettings, buffers: &mut ImplicitBuffers) -> (u32, f32) = pcg_inner;
/// }
/// let (iterations, residual) = pcg_at(simd::level(), params, buffers);
/// ```
macro_rules! multiversion {
    ($(#[$attr:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $inner:path;) => {
        $(#[$attr])*
        $vis fn $name(level: $crate::simd::Level, $($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                fn avx512($($arg: $ty),*) $(-> $ret)? {
                    $inner($($arg),*)
                }
                #[target_feature(enable = "avx2,fma")]
                fn avx2($($arg: $ty),*) $(-> $ret)? {
                    $inner($($arg),*)
                }
                match level.min($crate::simd::Level::detected()) {
                    // SAFETY: the CPU has AVX-512F (`detected`).
                    $crate::simd::Level::Avx512 => return unsafe { avx512($($arg),*) },
                    // SAFETY: the CPU has AVX2 and FMA (`detected`).
                    $crate::simd::Level::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::simd::Level::Simd128 | $crate::simd::Level::Scalar => {}
                }
            }
            let _ = level;
            $inner($($arg),*)
        }
    };
    ($(#[$attr:meta])* $vis:vis unsafe fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? = $inner:path;) => {
        $(#[$attr])*
        $vis unsafe fn $name(level: $crate::simd::Level, $($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                unsafe fn avx512($($arg: $ty),*) $(-> $ret)? {
                    // SAFETY: the caller's.
                    unsafe { $inner($($arg),*) }
                }
                #[target_feature(enable = "avx2,fma")]
                unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
                    // SAFETY: the caller's.
                    unsafe { $inner($($arg),*) }
                }
                match level.min($crate::simd::Level::detected()) {
                    // SAFETY: the CPU has AVX-512F (`detected`); the rest
                    // is the caller's.
                    $crate::simd::Level::Avx512 => return unsafe { avx512($($arg),*) },
                    // SAFETY: the CPU has AVX2 and FMA (`detected`); the
                    // rest is the caller's.
                    $crate::simd::Level::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::simd::Level::Simd128 | $crate::simd::Level::Scalar => {}
                }
            }
            let _ = level;
            // SAFETY: the caller's.
            unsafe { $inner($($arg),*) }
        }
    };
}
pub(crate) use multiversion;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_parse_and_order() {
        assert_eq!(Level::parse("scalar"), Some(Level::Scalar));
        assert_eq!(Level::parse(" AVX2 "), Some(Level::Avx2));
        assert_eq!(Level::parse("avx512"), Some(Level::Avx512));
        assert_eq!(Level::parse("Simd128"), Some(Level::Simd128));
        assert_eq!(Level::parse("sse9"), None);
        assert!(Level::Scalar < Level::Simd128 && Level::Avx2 < Level::Avx512);
        assert_eq!(Level::available()[0], Level::Scalar);
        assert!(level() <= Level::detected());
        assert!(Level::available().contains(&level()));
    }

    #[test]
    fn a_cap_gives_the_widest_level_this_build_runs_below_it() {
        let widest = *Level::available().last().unwrap();
        assert_eq!(widest, Level::detected());
        assert_eq!(Level::capped(Level::Scalar), Level::Scalar);
        assert_eq!(Level::capped(Level::Avx512), widest);
        // A cap this build cannot run falls to the next level it can.
        let below = Level::capped(Level::Simd128);
        assert!(below <= Level::Simd128 && below.runs_here());
        assert_eq!(
            below == Level::Simd128,
            cfg!(all(target_arch = "wasm32", target_feature = "simd128"))
        );
    }

    #[inline(always)]
    fn saxpy(a: f32, x: &[f32], y: &mut [f32]) {
        for (y, x) in y.iter_mut().zip(x) {
            *y += a * x;
        }
    }

    multiversion! {
        fn saxpy_at(a: f32, x: &[f32], y: &mut [f32]) = saxpy;
    }

    #[test]
    fn a_multiversioned_function_gives_the_same_sums_at_every_level() {
        let x: Vec<f32> = (0..1000).map(|i| (i as f32 * 0.37).sin()).collect();
        let mut reference = vec![0.5f32; 1000];
        saxpy(1.7, &x, &mut reference);
        for level in Level::available() {
            let mut y = vec![0.5f32; 1000];
            saxpy_at(level, 1.7, &x, &mut y);
            assert_eq!(y, reference, "{level:?}");
        }
    }
}
