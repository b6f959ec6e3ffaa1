//! What accuracy costs in time: the measurements behind the `accuracy`
//! example (and its test), as plain functions over the paper's scene.
//!
//! **Scene** (paper §6.1, MODEL.md §10.2): an `n × n`, 1 m cloth standing in
//! a vertical plane, pinned at its two top corners, at rest at its rest
//! lengths, then let go under gravity; no sphere.
//!
//! **Stability criterion** for a step `dt` (5 simulated seconds, at most
//! [`MAX_STEPS`] steps): every value finite, the largest Type 1 strain never
//! above the preset's bound, and the kinetic energy at the end at most 1 %
//! of its peak: neither diverging nor still oscillating.
//!
//! **Error**: RMS distance (m) of the particles after 1 simulated second
//! from an RK4 reference run at a step 50× below RK4's stable step.

use bevy::platform::time::Instant;
use std::f32::consts::FRAC_PI_2;
use std::hint::black_box;

use bevy::math::{Quat, Vec3};

use crate::plugin::spawn::builder::{ClothBuilder, ClothBundle};
use crate::plugin::spawn::material::ClothMaterial;
use crate::plugin::step::components::ClothStats;
use crate::sim::grid::GridCorner;
use crate::sim::integrate::StepBuffers;
use crate::sim::settings::{ClothModel, Integrator, SimSettings};
use crate::sim::step::step_cloth;

/// Simulated seconds of a stability trial.
pub const TRIAL_SECONDS: f32 = 5.0;
/// Most steps a stability trial may take; a step that would need more is
/// reported as below the search range rather than simulated.
pub const MAX_STEPS: usize = 4_000_000;
/// Kinetic energy at the end of a stable trial, at most this share of its peak.
pub const SETTLED_SHARE: f32 = 0.01;
/// The step search range, s.
pub const SEARCH: (f32, f32) = (1e-6, 0.2);

/// Parameter sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// MODEL.md §10, preset S: k = 3.6 N/m, c = 9.6 s⁻¹, 0.15 kg/m², no pair
    /// damping: reproduces the paper's step limits within about 20 %.
    Seed,
    /// MODEL.md §11: mid-weight cotton (k = 1000 N/m, c = 2 s⁻¹).
    Cotton,
}

impl Preset {
    /// Settings of this preset for `model` and `integrator` (one substep:
    /// the trials step the cloth themselves).
    pub fn settings(self, model: ClothModel, integrator: Integrator) -> SimSettings {
        let mut s = SimSettings::default()
            .with_model(model)
            .with_integrator(integrator, 1)
            .without_adaptive();
        if self == Preset::Seed {
            let k = 3.6;
            s.damping = 9.6;
            s.choi_ko.stiffness = k;
            s.choi_ko.shear_stiffness = k;
            s.choi_ko.buckling_slope = k;
            s.choi_ko.pair_damping = 0.0;
            for (spring, ks) in [
                (&mut s.lander.structural, k),
                (&mut s.lander.shear, k),
                (&mut s.lander.bend, 0.6 * k),
            ] {
                spring.stiffness = ks;
                spring.damping = 0.0;
            }
        }
        s
    }

    /// Largest Type 1 strain a stable run may show: the paper's soft cloth
    /// legitimately stretches about 110 % at its pins (MODEL.md §10).
    pub fn strain_bound(self) -> f32 {
        match self {
            Preset::Seed => 3.0,
            Preset::Cotton => 0.10,
        }
    }

    /// Name for output.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Seed => "seed",
            Preset::Cotton => "cotton",
        }
    }
}

/// The paper's scene with `grid × grid` particles (grids under 3 are taken
/// as 3, above 1024 as 1024).
pub fn scene(grid: u32) -> ClothBundle {
    let grid = grid.clamp(3, 1024);
    ClothBuilder::new(grid, grid)
        .size(1.0, 1.0)
        .material(ClothMaterial::Raw)
        .mass_per_area(0.15)
        .position(Vec3::new(0.0, 1.5, 0.0))
        .rotation(Quat::from_rotation_x(FRAC_PI_2))
        .pin_corner(GridCorner::TopLeft)
        .pin_corner(GridCorner::TopRight)
        .build()
        .expect("a 3×3 to 1024×1024 grid of 1 m is valid")
}

/// What a stability trial saw.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Trial {
    /// Whether every value stayed finite.
    pub finite: bool,
    /// Largest Type 1 strain seen.
    pub peak_strain: f32,
    /// Largest kinetic energy seen, J.
    pub peak_kinetic: f32,
    /// Kinetic energy at the end, J.
    pub end_kinetic: f32,
    /// Simulated seconds.
    pub seconds: f32,
}

impl Trial {
    /// Whether the run meets the stability criterion (module docs).
    pub fn stable(&self, strain_bound: f32) -> bool {
        self.finite
            && self.peak_strain <= strain_bound
            && self.end_kinetic <= SETTLED_SHARE * self.peak_kinetic
    }
}

/// Runs the scene for [`TRIAL_SECONDS`] at step `dt` (s), stopping early
/// once it is non-finite or past 10× the strain bound.
pub fn trial(grid: u32, settings: &SimSettings, dt: f32, strain_bound: f32) -> Trial {
    let mut cloth = scene(grid);
    let mut buffers = StepBuffers::new(cloth.particles.len());
    let mut stats = ClothStats::default();
    let mut out = Trial {
        finite: true,
        ..Default::default()
    };
    let steps = (TRIAL_SECONDS / dt).round() as usize;
    for k in 0..steps {
        step_cloth(
            &mut cloth.particles,
            &cloth.connections,
            settings,
            &[],
            &mut buffers,
            dt,
        );
        stats.measure(&cloth.particles, &cloth.connections);
        out.seconds = (k + 1) as f32 * dt;
        if !stats.finite || !stats.max_strain.is_finite() || !stats.kinetic_energy.is_finite() {
            out.finite = false;
            break;
        }
        out.peak_strain = out.peak_strain.max(stats.max_strain);
        out.peak_kinetic = out.peak_kinetic.max(stats.kinetic_energy);
        out.end_kinetic = stats.kinetic_energy;
        if stats.max_strain > 10.0 * strain_bound {
            break;
        }
    }
    out
}

/// The largest stable step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StableStep {
    /// Found by bisection, s.
    Found(f32),
    /// Stable even at the top of [`SEARCH`].
    AtLeast(f32),
    /// Unstable at the bottom of [`SEARCH`], or that step would need more
    /// than [`MAX_STEPS`] steps.
    Below(f32),
}

impl StableStep {
    /// The value in s (the bound for `AtLeast`/`Below`).
    pub fn seconds(self) -> f32 {
        match self {
            StableStep::Found(s) | StableStep::AtLeast(s) | StableStep::Below(s) => s,
        }
    }
}

/// The largest `dt` in [`SEARCH`] that meets the criterion: from the top of
/// the range down by factors of 4 to the first stable step (so a trial only
/// gets as long as the integrator needs), then `iterations` halvings of the
/// bracket in log space. Assumes stability is monotonic in `dt`, which holds
/// for every integrator here on this scene.
pub fn max_stable_dt(
    grid: u32,
    preset: Preset,
    model: ClothModel,
    integrator: Integrator,
    iterations: u32,
) -> StableStep {
    let settings = preset.settings(model, integrator);
    let bound = preset.strain_bound();
    let ok = |dt: f32| trial(grid, &settings, dt, bound).stable(bound);
    let floor = SEARCH.0.max(TRIAL_SECONDS / MAX_STEPS as f32);
    let mut hi = SEARCH.1;
    if ok(hi) {
        return StableStep::AtLeast(hi);
    }
    let mut lo = hi / 4.0;
    loop {
        if lo < floor {
            return StableStep::Below(hi.min(floor));
        }
        if ok(lo) {
            break;
        }
        hi = lo;
        lo /= 4.0;
    }
    for _ in 0..iterations {
        let mid = (lo * hi).sqrt();
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    StableStep::Found(lo)
}

/// Median wall-clock time of one step in µs: `reps` timed runs of `steps`
/// steps each, after one untimed warm-up run, on the scene at step `dt`.
pub fn micros_per_step(
    grid: u32,
    settings: &SimSettings,
    dt: f32,
    steps: usize,
    reps: usize,
) -> f64 {
    let mut cloth = scene(grid);
    let mut buffers = StepBuffers::new(cloth.particles.len());
    let mut times = Vec::with_capacity(reps);
    for rep in 0..=reps {
        let start = Instant::now();
        for _ in 0..steps {
            step_cloth(
                &mut cloth.particles,
                &cloth.connections,
                settings,
                &[],
                &mut buffers,
                dt,
            );
        }
        black_box(&cloth.particles.positions);
        if rep > 0 {
            times.push(start.elapsed().as_secs_f64() * 1e6 / steps as f64);
        }
        // Keep timing the same regime: restart from rest if it ran away.
        if !cloth.particles.is_finite() {
            cloth = scene(grid);
        }
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Particle positions (m) after `seconds` of the scene at step `dt`, or
/// `None` if they left the finite numbers.
pub fn positions_after(
    grid: u32,
    settings: &SimSettings,
    dt: f32,
    seconds: f32,
) -> Option<Vec<Vec3>> {
    let mut cloth = scene(grid);
    let mut buffers = StepBuffers::new(cloth.particles.len());
    for _ in 0..(seconds / dt).round() as usize {
        step_cloth(
            &mut cloth.particles,
            &cloth.connections,
            settings,
            &[],
            &mut buffers,
            dt,
        );
    }
    cloth
        .particles
        .is_finite()
        .then_some(cloth.particles.0.positions)
}

/// RMS distance between two position sets, m.
pub fn rms_distance(a: &[Vec3], b: &[Vec3]) -> f32 {
    (a.iter()
        .zip(b)
        .map(|(p, q)| p.distance_squared(*q))
        .sum::<f32>()
        / a.len() as f32)
        .sqrt()
}

/// One line of the accuracy table.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// Force model.
    pub model: ClothModel,
    /// Integrator.
    pub integrator: Integrator,
    /// Particles per side.
    pub grid: u32,
    /// Preset.
    pub preset: Preset,
    /// The step of this row, s.
    pub dt: f32,
    /// Median µs per step at `dt`.
    pub us_per_step: f64,
    /// Largest stable step.
    pub max_stable_dt: StableStep,
    /// RMS error after 1 s against the reference, m (`None`: not measured).
    pub error: Option<f32>,
}

impl Row {
    /// µs of computation per simulated second at this row's step.
    pub fn cost_per_sim_second(&self) -> f64 {
        self.us_per_step / self.dt as f64
    }

    /// The row as one JSON object (one line).
    pub fn to_json(&self) -> String {
        let model = match self.model {
            ClothModel::ChoiKo => "choi_ko",
            ClothModel::Lander => "lander",
        };
        let (bound_kind, bound) = match self.max_stable_dt {
            StableStep::Found(s) => ("found", s),
            StableStep::AtLeast(s) => ("at_least", s),
            StableStep::Below(s) => ("below", s),
        };
        let error = self.error.map_or("null".to_string(), |e| format!("{e:e}"));
        format!(
            "{{\"model\":\"{model}\",\"integrator\":\"{}\",\"grid\":{},\"preset\":\"{}\",\"dt\":{:e},\"us_per_step\":{:.4},\"max_stable_dt\":{:e},\"max_stable_dt_kind\":\"{bound_kind}\",\"error\":{error},\"cost_per_sim_second\":{:.4}}}",
            self.integrator.name(),
            self.grid,
            self.preset.name(),
            self.dt,
            self.us_per_step,
            bound,
            self.cost_per_sim_second(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_serialise_to_one_json_line() {
        let row = Row {
            model: ClothModel::ChoiKo,
            integrator: Integrator::Rk4,
            grid: 15,
            preset: Preset::Seed,
            dt: 0.01,
            us_per_step: 12.5,
            max_stable_dt: StableStep::Found(0.0128),
            error: None,
        };
        let json = row.to_json();
        assert!(!json.contains('\n'));
        assert!(json.starts_with("{\"model\":\"choi_ko\",\"integrator\":\"rk4\",\"grid\":15"));
        assert!(
            json.contains("\"error\":null") && json.contains("\"cost_per_sim_second\":1250.0000")
        );
    }

    #[test]
    fn the_criterion_separates_settling_from_ringing() {
        let settled = Trial {
            finite: true,
            peak_strain: 0.02,
            peak_kinetic: 1.0,
            end_kinetic: 1e-4,
            seconds: 5.0,
        };
        assert!(settled.stable(0.1));
        assert!(
            !Trial {
                end_kinetic: 0.5,
                ..settled
            }
            .stable(0.1)
        );
        assert!(
            !Trial {
                peak_strain: 0.2,
                ..settled
            }
            .stable(0.1)
        );
        assert!(
            !Trial {
                finite: false,
                ..settled
            }
            .stable(0.1)
        );
    }
}

/// Steps at which errors are measured (those at or below an integrator's
/// stable step), s.
pub const ERROR_STEPS: [f32; 9] = [
    1e-4,
    2e-4,
    5e-4,
    1e-3,
    2e-3,
    5e-3,
    1e-2,
    1.0 / 60.0,
    1.0 / 30.0,
];

/// How much to measure.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Particles per side.
    pub grid: u32,
    /// Parameters.
    pub preset: Preset,
    /// Models to measure.
    pub models: Vec<ClothModel>,
    /// Integrators to measure.
    pub integrators: Vec<Integrator>,
    /// Timed runs per figure (the median is reported).
    pub reps: usize,
    /// Steps per timed run.
    pub steps: usize,
    /// Bisection halvings for the stable step.
    pub bisections: u32,
    /// Whether to measure errors against a reference.
    pub errors: bool,
}

/// Measures `plan`: for every model × integrator, a summary row at its
/// largest stable step (error `None`) followed by one row per
/// [`ERROR_STEPS`] entry it is stable at, with its error after 1 s.
pub fn measure(plan: &Plan) -> Vec<Row> {
    let mut rows = Vec::new();
    for &model in &plan.models {
        let reference = plan.errors.then(|| {
            let rk4 = max_stable_dt(
                plan.grid,
                plan.preset,
                model,
                Integrator::Rk4,
                plan.bisections,
            )
            .seconds();
            let dt = rk4 / 50.0;
            let settings = plan.preset.settings(model, Integrator::Rk4);
            // No error column if the reference itself does not stay finite.
            positions_after(plan.grid, &settings, dt, 1.0)
        });
        let reference = reference.flatten();
        for &integrator in &plan.integrators {
            let settings = plan.preset.settings(model, integrator);
            let stable = max_stable_dt(plan.grid, plan.preset, model, integrator, plan.bisections);
            let limit = stable.seconds();
            let row = |dt: f32, error: Option<f32>| Row {
                model,
                integrator,
                grid: plan.grid,
                preset: plan.preset,
                dt,
                us_per_step: micros_per_step(plan.grid, &settings, dt, plan.steps, plan.reps),
                max_stable_dt: stable,
                error,
            };
            rows.push(row(limit, None));
            if let Some(reference) = &reference {
                for dt in ERROR_STEPS
                    .into_iter()
                    .filter(|&dt| dt <= limit || matches!(stable, StableStep::AtLeast(_)))
                {
                    let error = positions_after(plan.grid, &settings, dt, 1.0)
                        .map(|x| rms_distance(&x, reference));
                    if error.is_some() {
                        rows.push(row(dt, error));
                    }
                }
            }
        }
    }
    rows
}
