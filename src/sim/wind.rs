//! Wind: aerodynamic forces per triangle, from the air's velocity relative
//! to the face (as Blender and NvCloth apply wind per face, not as a uniform
//! acceleration). In an app, the `ClothWind` resource wraps a [`Wind`];
//! with zero wind nothing runs.
//!
//! For a triangle of area `A` and unit normal `n` moving at `v_f` (the mean
//! of its corners) in air moving at `w`, let `v = w − v_f`, `v̂ = v/|v|` and
//! `cos θ = |n·v̂|`, with `n'` the normal turned to face the wind. Then
//! - drag (along the wind): `½ρ C_d A |v|² cos θ · v̂`,
//! - lift (across it, away from the face): `½ρ C_l A |v|² cos θ sin θ · l`,
//!   `l = (n' − cos θ·v̂)/sin θ`,
//!
//! each split equally over the triangle's corners. A face edge-on to the
//! wind (`cos θ = 0`) feels nothing; face-on it feels the full drag.
//! Gusts scale `w` by `1 + a·g(t)` with `g` a smooth, deterministic mix of
//! two sines of the fixed clock, in [−1, 1].

use bevy::math::Vec3;
use bevy::reflect::Reflect;
use bevy::reflect::std_traits::ReflectDefault;

use crate::sim::grid::Faces;

/// The air around a cloth.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_cloth::prelude::*;
/// /// A gusty 6 m/s breeze from the west, for every cloth.
/// fn breeze(mut commands: Commands) {
///     commands.insert_resource(ClothWind(Wind {
///         velocity: Vec3::new(6.0, 0.0, 0.0),
///         gust_amplitude: 0.4,
///         ..default()
///     }));
/// }
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Default)]
pub struct Wind {
    /// Mean air velocity in m/s (zero: no wind, no work).
    pub velocity: Vec3,
    /// Air density ρ in kg/m³.
    pub density: f32,
    /// Drag coefficient `C_d` (dimensionless).
    pub drag: f32,
    /// Lift coefficient `C_l` (dimensionless).
    pub lift: f32,
    /// Gust strength `a`: the wind speed swings by ±a of its mean (0 = steady).
    pub gust_amplitude: f32,
    /// Gust frequency in Hz.
    pub gust_frequency: f32,
}

impl Default for Wind {
    fn default() -> Self {
        Self {
            velocity: Vec3::ZERO,
            density: 1.2,
            drag: 1.2,
            lift: 0.4,
            gust_amplitude: 0.0,
            gust_frequency: 0.5,
        }
    }
}

impl Wind {
    /// The air velocity (m/s) at time `t` (s), gusts included.
    pub fn at(&self, t: f32) -> Vec3 {
        let phase = std::f32::consts::TAU * self.gust_frequency * t;
        let g = (phase.sin() + 0.5 * (2.3 * phase + 1.7).sin()) / 1.5;
        self.velocity * (1.0 + self.gust_amplitude * g)
    }

    /// Whether the wind does anything.
    pub fn blows(&self) -> bool {
        self.velocity != Vec3::ZERO && self.velocity.is_finite()
    }
}

/// Adds the wind forces (N) on every triangle of `cloth` (a grid or a mesh)
/// to `f`, for air moving at `air` m/s.
pub fn wind_forces(
    cloth: &impl Faces,
    wind: &Wind,
    air: Vec3,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) {
    face_forces(cloth, wind, air, (x, v), f, None);
}

/// The wind forces (N) on `cloth` as a fixed step of `dt` s feels them:
/// [`wind_forces`], each particle's scaled so that it cannot drive the
/// particle past the air's speed within the step, written into `f`.
///
/// The drag of a face pulls a light particle towards the air's velocity at
/// a rate `c = |F|/(m·|v|)` (1/s, `v` the air's velocity relative to the
/// face) that a storm makes large: 144 s⁻¹ for 0.15 kg/m² cotton face-on
/// to 30 m/s. Held constant over a step of `dt > 2/c`, the force would
/// overshoot the air's velocity and reverse, more each step. Scaling it by
/// `(1 − e^(−c·dt))/(c·dt)` gives the velocity change of a particle under a
/// drag `m·c·v` exactly, so it approaches the air's velocity and never
/// passes it, with any integrator; a gentle breeze (`c·dt ≪ 1`) is left as
/// it is.
/// `inverse_masses` in 1/kg; `scratch` holds one drag rate per particle.
pub(crate) fn step_wind_forces(
    cloth: &impl Faces,
    wind: &Wind,
    air: Vec3,
    (x, v, inverse_masses): (&[Vec3], &[Vec3], &[f32]),
    dt: f32,
    f: &mut [Vec3],
    scratch: &mut Vec<f32>,
) {
    f.fill(Vec3::ZERO);
    scratch.clear();
    scratch.resize(x.len(), 0.0);
    face_forces(cloth, wind, air, (x, v), f, Some(scratch));
    for ((f, &b), &w) in f.iter_mut().zip(scratch.iter()).zip(inverse_masses) {
        let cdt = b * w * dt;
        if cdt > 1e-4 {
            *f *= (1.0 - (-cdt).exp()) / cdt;
        }
    }
}

/// The forces (N) on every triangle into `f`, and with `drag`, each
/// particle's share of `|F|/|v|` (N·s/m) into it.
fn face_forces(
    cloth: &impl Faces,
    wind: &Wind,
    air: Vec3,
    (x, v): (&[Vec3], &[Vec3]),
    f: &mut [Vec3],
    mut drag: Option<&mut Vec<f32>>,
) {
    let half_rho = 0.5 * wind.density;
    for [a, b, c] in cloth.faces() {
        let (a, b, c) = (a as usize, b as usize, c as usize);
        let cross = (x[b] - x[a]).cross(x[c] - x[a]);
        let double_area = cross.length();
        if double_area < 1e-12 {
            continue;
        }
        let n = cross / double_area;
        let rel = air - (v[a] + v[b] + v[c]) / 3.0;
        let speed2 = rel.length_squared();
        if speed2 < 1e-12 {
            continue;
        }
        let dir = rel / speed2.sqrt();
        let facing = n.dot(dir);
        let n_wind = if facing < 0.0 { -n } else { n };
        let cos = facing.abs();
        let pressure = half_rho * 0.5 * double_area * speed2;
        let mut force = pressure * wind.drag * cos * dir;
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        if sin > 1e-6 {
            let across = (n_wind - cos * dir) / sin;
            force += pressure * wind.lift * cos * sin * across;
        }
        let share = force / 3.0;
        if share.is_finite() {
            f[a] += share;
            f[b] += share;
            f[c] += share;
            if let Some(drag) = drag.as_mut() {
                let slope = share.length() / speed2.sqrt();
                drag[a] += slope;
                drag[b] += slope;
                drag[c] += slope;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plugin::spawn::builder::ClothBuilder;

    fn total(wind: Vec3) -> Vec3 {
        // A horizontal 1 m² sheet (normal ±Y).
        let b = ClothBuilder::new(5, 5).build().unwrap();
        let w = Wind {
            velocity: wind,
            ..Default::default()
        };
        let mut f = vec![Vec3::ZERO; 25];
        let v = vec![Vec3::ZERO; 25];
        wind_forces(&b.cloth, &w, w.at(0.0), &b.particles.positions, &v, &mut f);
        f.iter().sum()
    }

    #[test]
    fn face_on_wind_pushes_with_the_drag_and_edge_on_wind_does_nothing() {
        // Face-on, 10 m/s up through a 1 m² sheet: ½·1.2·1.2·1·100 = 72 N.
        let up = total(Vec3::Y * 10.0);
        assert!((up - Vec3::Y * 72.0).length() < 1e-2, "{up}");
        // Edge-on: nothing.
        assert!(total(Vec3::X * 10.0).length() < 1e-4);
        // At 45°: drag ½ρC_dA|v|²cos along the wind, lift across it.
        let f = total(Vec3::new(1.0, 1.0, 0.0).normalize() * 10.0);
        assert!(f.y > 0.0 && f.length() > 1.0 && f.length() < 72.0, "{f}");
    }

    #[test]
    fn a_storm_cannot_push_a_particle_past_the_air_in_one_step() {
        // A free 1 m² sheet of 0.15 kg at rest, face-on to 30 m/s air.
        let b = ClothBuilder::new(5, 5).build().unwrap();
        let w = Wind {
            velocity: Vec3::Y * 30.0,
            ..Default::default()
        };
        let p = &b.particles;
        let v = vec![Vec3::ZERO; 25];
        let (mut raw, mut limited) = (vec![Vec3::ZERO; 25], vec![Vec3::ZERO; 25]);
        wind_forces(&b.cloth, &w, w.velocity, &p.positions, &v, &mut raw);
        let state = (&p.positions[..], &v[..], &p.inverse_masses[..]);
        let dt = 1.0 / 60.0;
        step_wind_forces(
            &b.cloth,
            &w,
            w.velocity,
            state,
            dt,
            &mut limited,
            &mut Vec::new(),
        );
        // Raw, the 648 N drag takes the sheet to 72 m/s in one step, past
        // the air; limited, it gets no further than the air's 30 m/s (under
        // the exact quadratic drag it would reach 21 m/s).
        let dv = |f: &[Vec3]| f.iter().sum::<Vec3>().y * dt / 0.15;
        assert!(dv(&raw) > 60.0, "{}", dv(&raw));
        assert!(
            dv(&limited) > 20.0 && dv(&limited) < 30.0,
            "{}",
            dv(&limited)
        );
        // A breeze on a heavy sheet is left as it is.
        let w = Wind {
            velocity: Vec3::Y * 0.5,
            ..Default::default()
        };
        raw.fill(Vec3::ZERO);
        wind_forces(&b.cloth, &w, w.velocity, &p.positions, &v, &mut raw);
        step_wind_forces(
            &b.cloth,
            &w,
            w.velocity,
            state,
            dt,
            &mut limited,
            &mut Vec::new(),
        );
        let (r, l) = (raw.iter().sum::<Vec3>().y, limited.iter().sum::<Vec3>().y);
        assert!((l / r - 1.0).abs() < 0.05, "{l} vs {r}");
    }

    #[test]
    fn gusts_swing_around_the_mean() {
        let w = Wind {
            velocity: Vec3::X * 10.0,
            gust_amplitude: 0.5,
            ..Default::default()
        };
        let speeds: Vec<f32> = (0..400).map(|k| w.at(k as f32 * 0.01).x).collect();
        let (lo, hi) = speeds
            .iter()
            .fold((f32::MAX, f32::MIN), |(lo, hi), &s| (lo.min(s), hi.max(s)));
        assert!(
            lo >= 5.0 - 1e-3 && hi <= 15.0 + 1e-3 && hi - lo > 5.0,
            "{lo}..{hi}"
        );
        assert!(!Wind::default().blows());
    }
}
