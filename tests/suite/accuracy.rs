//! The accuracy example's measurements reproduce the paper's stable-step
//! ratio (paper §6.1, MODEL.md §10) on preset S, and its JSON lines parse.
//! The cost ratio is printed, not asserted: times belong in benches.

use bevy_cloth::lab::accuracy::{Plan, Preset, StableStep, measure, micros_per_step};
use bevy_cloth::prelude::*;

/// The paper: RK4 costs 2.5 / 0.545 = 4.59× explicit Euler per step and
/// takes a 1.29e-2 / 2.0e-4 = 64.5× larger step.
const PAPER_COST_RATIO: f64 = 2500.0 / 545.0;
const PAPER_STEP_RATIO: f32 = 1.29e-2 / 2.0e-4;

#[test]
fn the_paper_s_preset_reproduces_its_stable_step_ratio_within_25_percent() {
    let plan = Plan {
        grid: 15,
        preset: Preset::Seed,
        models: vec![ClothModel::ChoiKo],
        integrators: vec![Integrator::ExplicitEuler, Integrator::Rk4],
        reps: 7,
        steps: 150,
        bisections: 10,
        errors: false,
    };
    let rows = measure(&plan);
    assert_eq!(rows.len(), 2);
    for row in &rows {
        let json: serde_json::Value = serde_json::from_str(&row.to_json()).expect("valid JSON");
        for key in [
            "model",
            "integrator",
            "grid",
            "dt",
            "us_per_step",
            "max_stable_dt",
            "error",
            "cost_per_sim_second",
        ] {
            assert!(json.get(key).is_some(), "missing {key} in {json}");
        }
        assert_eq!(json["grid"], 15);
        assert!(matches!(row.max_stable_dt, StableStep::Found(_)), "{row:?}");
    }
    let (euler, rk4) = (&rows[0], &rows[1]);
    // The cost ratio from interleaved pairs of short timings, so a burst of
    // load hits both sides of a pair alike; the median pair ratio is
    // printed beside the paper's.
    let settings = |i| Preset::Seed.settings(ClothModel::ChoiKo, i);
    let (es, rs) = (
        settings(Integrator::ExplicitEuler),
        settings(Integrator::Rk4),
    );
    let (edt, rdt) = (euler.max_stable_dt.seconds(), rk4.max_stable_dt.seconds());
    let mut ratios: Vec<f64> = (0..15)
        .map(|_| micros_per_step(15, &rs, rdt, 100, 1) / micros_per_step(15, &es, edt, 100, 1))
        .collect();
    ratios.sort_by(f64::total_cmp);
    let cost = ratios[ratios.len() / 2];
    let step = rk4.max_stable_dt.seconds() / euler.max_stable_dt.seconds();
    eprintln!(
        "cost per step RK4/Euler {cost:.2} (paper {PAPER_COST_RATIO:.2}); stable step RK4/Euler {step:.1} (paper {PAPER_STEP_RATIO:.1}); \
         Euler {:.3e} s, RK4 {:.3e} s",
        euler.max_stable_dt.seconds(),
        rk4.max_stable_dt.seconds()
    );
    assert!(
        (step / PAPER_STEP_RATIO - 1.0).abs() <= 0.25,
        "step ratio {step}"
    );
}
