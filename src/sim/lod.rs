//! Level of detail as plain state: how often a cloth steps by its distance
//! from the nearest camera and whether any camera sees it ([`LodSettings`],
//! [`Detail`]), which fixed steps it then takes and how many it combines
//! (a pacer), and the rigid motion that keeps it on its moving pins
//! between them.
//!
//! A cloth at [`Detail::Every`]`(k)` takes one step of `k` fixed steps' time
//! (the implicit solve is stable at such steps); in the fixed steps between,
//! its pins still follow their anchors or skin, and its free particles are
//! carried with them by the rigid motion that best fits the pins' motion,
//! so it stays on a moving character at every level without stretching.

use bevy::math::{Mat3, Quat, Vec3, Vec4};
use bevy::reflect::Reflect;

use crate::error::ClothError;
use crate::sim::frame::Carry;

/// The most fixed steps a reduced cloth may combine into one step.
pub(crate) const MAX_EVERY: u32 = 16;

/// When a cloth steps less often ([module docs](self)). The plugin's
/// `ClothLod` (per cloth) and `ClothLodDefaults` (global) hold one.
///
/// ```
/// # use bevy_cloth::sim::lod::{Detail, LodSettings};
/// let lod = LodSettings::default();
/// assert_eq!(lod.detail(Some(5.0), true), Detail::Full);
/// assert_eq!(lod.detail(Some(30.0), true), Detail::Every(2));
/// assert_eq!(lod.detail(Some(90.0), true), Detail::Every(8));
/// assert_eq!(lod.detail(Some(5.0), false), Detail::Every(16));
/// assert_eq!(lod.detail(Some(150.0), true), Detail::Frozen);
/// assert_eq!(lod.detail(None, false), Detail::Full); // no camera
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct LodSettings {
    /// Whether the cloth's rate follows the cameras (on by default). Off,
    /// or with no active camera, it steps every fixed step.
    pub enabled: bool,
    /// Distance from the nearest camera, m, within which a cloth in view
    /// steps every fixed step (finite, > 0). Beyond it, the number of fixed
    /// steps it combines doubles each time the distance doubles: every 2nd
    /// from `near`, every 4th from `2·near`, … up to `max_every`.
    pub near: f32,
    /// Distance from every camera, m, beyond which the cloth is frozen: it
    /// does not step, and the time it misses is dropped (> `near`;
    /// `f32::INFINITY` never freezes).
    pub freeze: f32,
    /// The most fixed steps combined into one step (1 to 16),
    /// and the rate of a cloth no camera sees (within `freeze`). A
    /// combined step of `k` fixed steps is solved to a relative tolerance
    /// `k` times the cloth's
    /// [`ImplicitSettings::tolerance`](crate::sim::settings::ImplicitSettings::tolerance)
    /// (at most 0.1; the cloth is `k/2` to `k` times farther than `near`,
    /// or unseen), with the same
    /// [`max_iterations`](crate::sim::settings::ImplicitSettings::max_iterations).
    /// The rate is earned: it halves after a step past 10 % Type 1
    /// strain. By default 16: a cloth no camera sees steps every
    /// 16th fixed step (3.75 times a second at 60 Hz), and one in view at
    /// most every 8th (from `4·near`, 80 m; the default `freeze` is 100 m).
    pub max_every: u32,
}

impl Default for LodSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            near: 20.0,
            freeze: 100.0,
            max_every: 16,
        }
    }
}

impl LodSettings {
    /// Checks the distances and the rate: `near` finite and > 0, `freeze`
    /// > `near` (infinite allowed), `max_every` in `1..=MAX_EVERY`.
    pub fn validate(&self) -> Result<(), ClothError> {
        let near = self.near.is_finite() && self.near > 0.0;
        if near && self.freeze > self.near && (1..=MAX_EVERY).contains(&self.max_every) {
            Ok(())
        } else {
            Err(ClothError::InvalidLod {
                near: self.near,
                freeze: self.freeze,
                max_every: self.max_every,
            })
        }
    }

    /// The detail of a cloth `distance` m from the camera nearest to it
    /// (`None`: no camera) that some camera sees (`seen`). Assumes valid
    /// settings.
    pub fn detail(&self, distance: Option<f32>, seen: bool) -> Detail {
        let Some(d) = distance.filter(|_| self.enabled) else {
            return Detail::Full;
        };
        if d > self.freeze {
            return Detail::Frozen;
        }
        let every = if seen {
            // 1 within `near`, then 2, 4, … as the distance doubles; a NaN
            // distance steps every fixed step.
            let mut every = 1;
            let mut reach = self.near;
            while d >= reach && every < self.max_every {
                every *= 2;
                reach *= 2.0;
            }
            every.min(self.max_every)
        } else {
            self.max_every
        };
        match every {
            0 | 1 => Detail::Full,
            k => Detail::Every(k),
        }
    }
}

/// How often a cloth steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum Detail {
    /// Every fixed step.
    #[default]
    Full,
    /// One step of `k` fixed steps' time every `k`th fixed step.
    Every(u32),
    /// Not at all; the time is dropped.
    Frozen,
}

/// A combined step that leaves a Type 1 link strained past this
/// (dimensionless) halves the steps the cloth may combine.
pub(crate) const LOD_STRAIN: f32 = 0.1;
/// Fixed steps a cloth must stay under [`LOD_STRAIN`] before the steps it
/// may combine double (half a second at 60 Hz).
pub(crate) const LOD_CALM_STEPS: u32 = 30;

/// Which fixed steps a cloth takes at its [`Detail`], and how many fixed
/// steps each combines.
///
/// A long step is less accurate where the cloth moves fast (a storm, a
/// flick, a fall from rest), so how many fixed steps it may combine is
/// earned: a new cloth starts at 1, the number doubles after every
/// [`LOD_CALM_STEPS`] fixed steps whose steps kept its strain under
/// [`LOD_STRAIN`], up to [`MAX_EVERY`], and halves after a step that did
/// not ([`stepped`](Self::stepped)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub(crate) struct Pacer {
    /// Fixed steps since its last step (dropped while frozen).
    waited: u32,
    /// Most fixed steps it may combine now, less one (so 0 by default).
    limit: u32,
    /// Calm fixed steps since the limit last changed.
    calm: u32,
}

impl Pacer {
    /// Most fixed steps the cloth may combine now.
    pub fn limit(&self) -> u32 {
        self.limit + 1
    }

    /// `detail` within what the cloth may combine now.
    #[cfg_attr(
        not(feature = "render"),
        allow(
            dead_code,
            reason = "the camera-based level of detail needs the render feature"
        )
    )]
    pub fn limited(&self, detail: Detail) -> Detail {
        match detail {
            Detail::Every(k) if k.min(self.limit()) <= 1 => Detail::Full,
            Detail::Every(k) => Detail::Every(k.min(self.limit())),
            other => other,
        }
    }

    /// After a step of `steps` fixed steps that left the cloth at `strain`
    /// (its largest Type 1 strain, dimensionless; NaN counts as too much).
    pub fn stepped(&mut self, steps: u32, strain: f32) {
        let calm = strain <= LOD_STRAIN; // false for NaN
        if !calm {
            let combined = self.limit().min(steps.max(1));
            self.limit = (combined / 2).max(1) - 1;
            self.calm = 0;
            return;
        }
        self.calm += steps.max(1);
        if self.calm >= LOD_CALM_STEPS {
            self.limit = (2 * self.limit() - 1).min(MAX_EVERY - 1);
            self.calm = 0;
        }
    }

    /// One fixed step at `detail` (already [`limited`](Self::limited)):
    /// how many fixed steps' time the cloth steps now (0: it skips this
    /// one). `clock` counts fixed steps and
    /// `phase` spreads cloths of the same rate over different fixed steps.
    /// A cloth back at [`Detail::Full`] catches up the steps it waited in
    /// one step.
    #[cfg_attr(
        not(feature = "render"),
        allow(
            dead_code,
            reason = "the camera-based level of detail needs the render feature"
        )
    )]
    pub fn tick(&mut self, detail: Detail, clock: u64, phase: u32) -> u32 {
        self.waited += 1;
        let due = match detail {
            Detail::Frozen => {
                self.waited = 0;
                return 0;
            }
            Detail::Full => true,
            Detail::Every(k) => {
                let k = k.clamp(1, MAX_EVERY);
                self.waited >= k || (clock + u64::from(phase)).is_multiple_of(u64::from(k))
            }
        };
        if due {
            std::mem::take(&mut self.waited)
        } else {
            0
        }
    }

    /// Fixed steps since the cloth's last step.
    pub fn waited(&self) -> u32 {
        self.waited
    }
}

/// The rigid motion that best carries the pinned particles (inverse mass
/// 0) of positions `x` (m) along their velocities `v` (m/s) over `dt` s, in
/// the least-squares sense: a translation for one pin, the best rotation
/// about their centre for more. `None` when no pin moves or a pin's motion
/// is not finite.
pub(crate) fn pin_carry(x: &[Vec3], v: &[Vec3], inverse_masses: &[f32], dt: f32) -> Option<Carry> {
    let pins = || {
        x.iter()
            .zip(v)
            .zip(inverse_masses)
            .filter(|(_, w)| **w == 0.0)
            .map(move |((&p, &u), _)| (p, p + u * dt))
    };
    let (mut count, mut from, mut to, mut moves) = (0.0f32, Vec3::ZERO, Vec3::ZERO, false);
    for (p, q) in pins() {
        count += 1.0;
        from += p;
        to += q;
        moves |= p != q;
    }
    if !moves || !(from.is_finite() && to.is_finite()) {
        return None;
    }
    let (from, to) = (from / count, to / count);
    // Σ (q − q̄)(p − p̄)ᵀ, whose rotational part is the best-fit turn.
    let spread = pins().fold(Mat3::ZERO, |a, (p, q)| {
        let (p, q) = (p - from, q - to);
        a + Mat3::from_cols(q * p.x, q * p.y, q * p.z)
    });
    Some(Carry::between(from, to, rotation_of(spread)))
}

/// Carries a cloth between its steps ([module docs](self)): its pins
/// (inverse mass 0) move along their velocities `v` (m/s) over `dt` s, and
/// its free particles with `carry`, the rigid motion that best fits theirs
/// ([`pin_carry`]), their velocities turned with it.
pub(crate) fn ride_pins(
    carry: &Carry,
    x: &mut [Vec3],
    v: &mut [Vec3],
    inverse_masses: &[f32],
    dt: f32,
) {
    for ((p, u), &w) in x.iter_mut().zip(v.iter_mut()).zip(inverse_masses) {
        if w == 0.0 {
            *p += *u * dt;
        } else {
            *p = carry.point(*p);
            *u = carry.vector(*u);
        }
    }
}

/// The rotation `R` closest to `a` (maximising `tr(Rᵀa)`), by the
/// iteration of Müller et al., "A Robust Method to Extract the Rotational
/// Part of Deformations" (MIG 2016), from the identity.
fn rotation_of(a: Mat3) -> Quat {
    let mut q = Quat::IDENTITY;
    for _ in 0..32 {
        let r = Mat3::from_quat(q);
        let axes = [
            (r.x_axis, a.x_axis),
            (r.y_axis, a.y_axis),
            (r.z_axis, a.z_axis),
        ];
        let torque: Vec3 = axes.iter().map(|(r, a)| r.cross(*a)).sum();
        let along: f32 = axes.iter().map(|(r, a)| r.dot(*a)).sum();
        let omega = torque / (along.abs() + 1e-12);
        let angle = omega.length();
        if !angle.is_finite() || angle < 1e-7 {
            break;
        }
        q = (Quat::from_axis_angle(omega / angle, angle) * q).normalize();
    }
    q
}

/// Whether the box `lo`–`hi` (m) reaches into the view bounded by
/// `planes`: each `(n, d)` keeps the points with `n·p + d > 0` (a camera
/// frustum's half-spaces).
#[cfg_attr(
    not(feature = "render"),
    allow(
        dead_code,
        reason = "the camera-based level of detail needs the render feature"
    )
)]
pub(crate) fn box_in_view(planes: &[Vec4], (lo, hi): (Vec3, Vec3)) -> bool {
    let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    planes.iter().all(|plane| {
        let n = plane.truncate();
        n.dot(centre) + plane.w + half.dot(n.abs()) > 0.0
    })
}

/// Distance from `point` to the box `lo`–`hi`, m (0 inside).
#[cfg_attr(
    not(feature = "render"),
    allow(
        dead_code,
        reason = "the camera-based level of detail needs the render feature"
    )
)]
pub(crate) fn distance_to_box(point: Vec3, (lo, hi): (Vec3, Vec3)) -> f32 {
    (point - point.clamp(lo, hi)).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_halves_as_the_distance_doubles_and_freezes_beyond() {
        let lod = LodSettings {
            max_every: 8,
            ..LodSettings::default()
        };
        let at = |d: f32| lod.detail(Some(d), true);
        assert_eq!(at(0.0), Detail::Full);
        assert_eq!(at(19.9), Detail::Full);
        assert_eq!(at(20.0), Detail::Every(2));
        assert_eq!(at(39.9), Detail::Every(2));
        assert_eq!(at(40.0), Detail::Every(4));
        assert_eq!(at(80.0), Detail::Every(8));
        assert_eq!(at(99.0), Detail::Every(8));
        assert_eq!(at(100.5), Detail::Frozen);
        assert_eq!(at(f32::NAN), Detail::Full);
        assert_eq!(lod.detail(Some(1.0), false), Detail::Every(8));
        assert_eq!(lod.detail(Some(101.0), false), Detail::Frozen);
        let off = LodSettings {
            enabled: false,
            ..lod
        };
        assert_eq!(off.detail(Some(500.0), false), Detail::Full);
        let one = LodSettings {
            max_every: 1,
            ..lod
        };
        assert_eq!(one.detail(Some(50.0), false), Detail::Full);
    }

    #[test]
    fn bad_distances_and_rates_are_errors() {
        let good = LodSettings::default();
        assert!(good.validate().is_ok());
        let never = LodSettings {
            freeze: f32::INFINITY,
            ..good
        };
        assert!(never.validate().is_ok());
        for bad in [
            LodSettings { near: 0.0, ..good },
            LodSettings { near: -1.0, ..good },
            LodSettings {
                near: f32::NAN,
                ..good
            },
            LodSettings {
                near: f32::INFINITY,
                ..good
            },
            LodSettings {
                freeze: f32::NAN,
                ..good
            },
            LodSettings {
                freeze: -5.0,
                ..good
            },
            LodSettings {
                freeze: 10.0,
                ..good
            },
            LodSettings {
                max_every: 0,
                ..good
            },
            LodSettings {
                max_every: MAX_EVERY + 1,
                ..good
            },
        ] {
            assert!(
                matches!(bad.validate(), Err(ClothError::InvalidLod { .. })),
                "{bad:?}"
            );
        }
    }

    #[test]
    fn the_pacer_combines_the_steps_it_skips_and_drops_frozen_time() {
        let mut pacer = Pacer::default();
        // Every 4th fixed step, combining 4.
        let taken: Vec<u32> = (0..12)
            .map(|t| pacer.tick(Detail::Every(4), t, 1))
            .collect();
        assert_eq!(taken, [0, 0, 0, 4, 0, 0, 0, 4, 0, 0, 0, 4]);
        // Back to full: the waiting steps are caught up at once.
        assert_eq!(pacer.tick(Detail::Every(4), 12, 1), 0);
        assert_eq!(pacer.tick(Detail::Every(4), 13, 1), 0);
        assert_eq!(pacer.tick(Detail::Full, 14, 1), 3);
        assert_eq!(pacer.tick(Detail::Full, 15, 1), 1);
        // Frozen: nothing, and nothing owed afterwards.
        assert_eq!(pacer.tick(Detail::Every(4), 16, 1), 0);
        assert_eq!(pacer.tick(Detail::Frozen, 17, 1), 0);
        assert_eq!(pacer.tick(Detail::Frozen, 18, 1), 0);
        assert_eq!(pacer.tick(Detail::Full, 19, 1), 1);
        // Every fixed step's time is taken exactly once at a changing rate.
        let mut total = 0;
        for t in 0..1000u64 {
            let k = [2, 4, 8, 16][(t / 7 % 4) as usize];
            total += pacer.tick(Detail::Every(k), t, 3);
            assert!(pacer.waited() < 16);
        }
        assert_eq!(total + pacer.waited(), 1000);
    }

    #[test]
    fn a_cloth_earns_its_combined_steps_and_loses_them_when_it_stretches() {
        let mut pacer = Pacer::default();
        assert_eq!(pacer.limited(Detail::Every(8)), Detail::Full);
        let calm = |pacer: &mut Pacer, steps: u32| {
            for _ in 0..steps {
                pacer.stepped(1, 0.01);
            }
        };
        calm(&mut pacer, LOD_CALM_STEPS);
        assert_eq!(pacer.limited(Detail::Every(8)), Detail::Every(2));
        calm(&mut pacer, 2 * LOD_CALM_STEPS);
        assert_eq!(pacer.limited(Detail::Every(8)), Detail::Every(8));
        assert_eq!(pacer.limited(Detail::Every(2)), Detail::Every(2));
        assert_eq!(pacer.limited(Detail::Frozen), Detail::Frozen);
        // A step of 8 that over-stretches: at most 4 from now on.
        pacer.stepped(8, 0.3);
        assert_eq!(pacer.limit(), 4);
        pacer.stepped(4, f32::NAN);
        assert_eq!(pacer.limit(), 2);
        pacer.stepped(2, 0.2);
        pacer.stepped(1, 0.2);
        assert_eq!(pacer.limited(Detail::Every(8)), Detail::Full);
        // Combined steps count their fixed steps towards the calm.
        calm(&mut pacer, LOD_CALM_STEPS);
        assert_eq!(pacer.limit(), 2);
        for _ in 0..(LOD_CALM_STEPS / 2) {
            pacer.stepped(2, 0.0);
        }
        assert_eq!(pacer.limit(), 4);
        for _ in 0..100 {
            pacer.stepped(8, 0.0);
        }
        assert_eq!(pacer.limit(), MAX_EVERY);
    }

    #[test]
    fn pins_carry_the_cloth_rigidly() {
        let turn = Quat::from_rotation_y(0.3);
        let shift = Vec3::new(0.5, 0.1, -0.2);
        let dt = 1.0 / 60.0;
        // Three pins and a free particle.
        let x = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.0, 1.0, 0.5),
            Vec3::new(0.4, -0.6, 0.2),
        ];
        let w = [0.0, 0.0, 0.0, 1.0];
        let centre = (x[0] + x[1] + x[2]) / 3.0;
        let moved = |p: Vec3| centre + shift + turn * (p - centre);
        let v: Vec<Vec3> = x.iter().map(|&p| (moved(p) - p) / dt).collect();
        let carry = pin_carry(&x, &v, &w, dt).expect("the pins move");
        for &p in &x {
            assert!((carry.point(p) - moved(p)).length() < 1e-4, "{p}");
        }
        // One pin: a translation.
        let single = pin_carry(&x[..2], &[Vec3::X, Vec3::ZERO], &[0.0, 1.0], 0.5).unwrap();
        assert!((single.point(Vec3::Y) - Vec3::new(0.5, 1.0, 0.0)).length() < 1e-6);
        // Riding them: the pins reach their goals, the free particle is
        // carried and its velocity turned.
        let (mut y, mut u) = (x.clone(), v.clone());
        u[3] = Vec3::X;
        ride_pins(&carry, &mut y, &mut u, &w, dt);
        for i in 0..4 {
            assert!((y[i] - moved(x[i])).length() < 1e-4, "{i}");
        }
        assert!((u[3] - turn * Vec3::X).length() < 1e-4);
        // Still pins, no pins, or a NaN: nothing.
        assert_eq!(pin_carry(&x, &[Vec3::ZERO; 4], &w, dt), None);
        assert_eq!(pin_carry(&x, &v, &[1.0; 4], dt), None);
        let mut bad = v.clone();
        bad[0] = Vec3::NAN;
        assert_eq!(pin_carry(&x, &bad, &w, dt), None);
    }

    #[test]
    fn a_box_is_seen_when_it_reaches_into_every_half_space() {
        // The half-spaces x > 0 and y > 0.
        let planes = [Vec4::new(1.0, 0.0, 0.0, 0.0), Vec4::new(0.0, 1.0, 0.0, 0.0)];
        let seen = |lo: Vec3, hi: Vec3| box_in_view(&planes, (lo, hi));
        assert!(seen(Vec3::ONE, Vec3::splat(2.0)));
        assert!(seen(Vec3::splat(-1.0), Vec3::splat(0.5)));
        assert!(!seen(Vec3::new(-3.0, 1.0, 0.0), Vec3::new(-1.0, 2.0, 0.0)));
        assert_eq!(
            distance_to_box(Vec3::new(3.0, 0.5, 0.0), (Vec3::ZERO, Vec3::ONE)),
            2.0
        );
        assert_eq!(
            distance_to_box(Vec3::splat(0.5), (Vec3::ZERO, Vec3::ONE)),
            0.0
        );
    }
}
