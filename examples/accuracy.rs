//! What accuracy costs in time (paper §6.1, MODEL.md §10): for every model ×
//! integrator, the time per step, the largest stable step on the paper's
//! scene, the error against a fine RK4 reference at common steps, and the
//! cost per simulated second. Headless.
//!
//! ```text
//! cargo run --release --example accuracy -- [--preset seed|cotton] [--grid N]
//!     [--json] [--reps K] [--plot accuracy.svg]
//! ```
//!
//! The stability criterion and the error measure are documented in
//! `bevy_cloth::lab::accuracy`. With `--preset seed` (MODEL.md §10, preset S) the
//! table also shows the paper's figures and the two ratios it reported.

use std::fmt::Write as _;

use bevy_cloth::lab::accuracy::{Plan, Preset, Row, StableStep, measure};
use bevy_cloth::prelude::*;

/// The paper's figures (Pentium 4, 3.2 GHz, 15×15): explicit Euler and RK4.
const SEED_EULER: (f64, f32) = (545.0, 2.0e-4); // µs per step, largest step (s)
const SEED_RK4: (f64, f32) = (2500.0, 1.29e-2);

struct Args {
    preset: Preset,
    grid: u32,
    json: bool,
    reps: usize,
    plot: Option<String>,
}

fn args() -> Args {
    let mut out = Args {
        preset: Preset::Seed,
        grid: 15,
        json: false,
        reps: 15,
        plot: Some("accuracy.svg".into()),
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--json" => out.json = true,
            "--preset" => match it.next().as_deref() {
                Some("seed") => out.preset = Preset::Seed,
                Some("cotton") => out.preset = Preset::Cotton,
                other => fail(&format!("--preset takes seed or cotton, not {other:?}")),
            },
            "--grid" => {
                out.grid = it
                    .next()
                    .and_then(|n| n.parse().ok())
                    .filter(|&n| n >= 3)
                    .unwrap_or_else(|| fail("--grid takes a number ≥ 3"))
            }
            "--reps" => {
                out.reps = it
                    .next()
                    .and_then(|n| n.parse().ok())
                    .filter(|&n| n >= 1)
                    .unwrap_or_else(|| fail("--reps takes a number ≥ 1"))
            }
            "--plot" => out.plot = it.next(),
            "--no-plot" => out.plot = None,
            other => fail(&format!("unknown argument {other}")),
        }
    }
    out
}

fn fail(message: &str) -> ! {
    eprintln!("accuracy: {message}");
    std::process::exit(2);
}

fn main() {
    let args = args();
    let plan = Plan {
        grid: args.grid,
        preset: args.preset,
        models: vec![ClothModel::ChoiKo, ClothModel::Lander],
        integrators: Integrator::ALL.to_vec(),
        reps: args.reps,
        steps: 200,
        bisections: 14,
        errors: true,
    };
    let rows = measure(&plan);
    if args.json {
        for row in &rows {
            println!("{}", row.to_json());
        }
    } else {
        print!("{}", table(&rows, &plan));
    }
    if let Some(path) = &args.plot {
        match std::fs::write(path, plot(&rows, &plan)) {
            Ok(()) => eprintln!("wrote {path}"),
            Err(e) => eprintln!("could not write {path}: {e}"),
        }
    }
}

fn stable_text(s: StableStep) -> String {
    match s {
        StableStep::Found(v) => format!("{v:.3e}"),
        StableStep::AtLeast(v) => format!("≥ {v:.1e}"),
        StableStep::Below(v) => format!("< {v:.1e}"),
    }
}

fn table(rows: &[Row], plan: &Plan) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "preset {}, {}×{} grid, the paper's scene (hanging from two corners), f32",
        plan.preset.name(),
        plan.grid,
        plan.grid
    );
    let _ = writeln!(
        out,
        "stable: finite, Type 1 strain ≤ {:.0} %, kinetic energy after 5 s ≤ 1 % of its peak",
        plan.preset.strain_bound() * 100.0
    );
    let _ = writeln!(
        out,
        "error: RMS particle distance after 1 s from RK4 at 1/50 of its stable step\n"
    );
    let _ = writeln!(
        out,
        "{:<8} {:<17} {:>10} {:>12} {:>16}   errors (dt → m)",
        "model", "integrator", "µs/step", "stable dt", "ms per sim. s"
    );
    for summary in rows.iter().filter(|r| r.error.is_none()) {
        let errors: Vec<String> = rows
            .iter()
            .filter(|r| {
                r.error.is_some() && r.model == summary.model && r.integrator == summary.integrator
            })
            .map(|r| format!("{:.0e}→{:.1e}", r.dt, r.error.unwrap_or(f32::NAN)))
            .collect();
        let _ = writeln!(
            out,
            "{:<8} {:<17} {:>10.2} {:>12} {:>16.3}   {}",
            format!("{:?}", summary.model),
            summary.integrator.name(),
            summary.us_per_step,
            stable_text(summary.max_stable_dt),
            summary.cost_per_sim_second() / 1e3,
            errors.join(" ")
        );
    }
    if plan.preset == Preset::Seed {
        let find = |i: Integrator| {
            rows.iter()
                .find(|r| r.error.is_none() && r.model == ClothModel::ChoiKo && r.integrator == i)
        };
        if let (Some(euler), Some(rk4)) = (find(Integrator::ExplicitEuler), find(Integrator::Rk4)) {
            let _ = writeln!(out, "\nseed §6.1 (Pentium 4) vs measured, Choi–Ko:");
            let _ = writeln!(out, "{:<34} {:>12} {:>12}", "", "seed", "measured");
            let _ = writeln!(
                out,
                "{:<34} {:>12.1} {:>12.2}",
                "explicit Euler µs/step", SEED_EULER.0, euler.us_per_step
            );
            let _ = writeln!(
                out,
                "{:<34} {:>12.1} {:>12.2}",
                "RK4 µs/step", SEED_RK4.0, rk4.us_per_step
            );
            let _ = writeln!(
                out,
                "{:<34} {:>12.2} {:>12.2}",
                "cost per step RK4 / Euler",
                SEED_RK4.0 / SEED_EULER.0,
                rk4.us_per_step / euler.us_per_step
            );
            let _ = writeln!(
                out,
                "{:<34} {:>12.2e} {:>12.2e}",
                "explicit Euler stable dt (s)",
                SEED_EULER.1,
                euler.max_stable_dt.seconds()
            );
            let _ = writeln!(
                out,
                "{:<34} {:>12.2e} {:>12.2e}",
                "RK4 stable dt (s)",
                SEED_RK4.1,
                rk4.max_stable_dt.seconds()
            );
            let _ = writeln!(
                out,
                "{:<34} {:>12.1} {:>12.1}",
                "stable step RK4 / Euler",
                SEED_RK4.1 / SEED_EULER.1,
                rk4.max_stable_dt.seconds() / euler.max_stable_dt.seconds()
            );
        }
    }
    out
}

/// Error against cost per simulated second, log–log, one curve per
/// model × integrator, as a self-contained SVG.
fn plot(rows: &[Row], plan: &Plan) -> String {
    let points: Vec<(&Row, f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            let e = r.error? as f64;
            (e > 0.0).then(|| (r, (r.cost_per_sim_second() / 1e3).log10(), e.log10()))
        })
        .collect();
    let (w, h, m) = (900.0, 560.0, 70.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(_, x, y) in &points {
        x0 = x0.min(x.floor());
        x1 = x1.max(x.ceil());
        y0 = y0.min(y.floor());
        y1 = y1.max(y.ceil());
    }
    if points.is_empty() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let sx = |x: f64| m + (x - x0) / (x1 - x0).max(1e-9) * (w - 2.0 * m - 170.0);
    let sy = |y: f64| h - m - (y - y0) / (y1 - y0).max(1e-9) * (h - 2.0 * m);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="13"><rect width="100%" height="100%" fill="white"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{m}" y="30" font-size="16">Error after 1 s vs cost per simulated second — preset {}, {}×{}</text>"#,
        plan.preset.name(),
        plan.grid,
        plan.grid
    );
    for d in x0 as i32..=x1 as i32 {
        let x = sx(d as f64);
        let _ = writeln!(
            s,
            r##"<line x1="{x}" y1="{}" x2="{x}" y2="{}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">1e{d}</text>"##,
            m,
            h - m,
            h - m + 18.0
        );
    }
    for d in y0 as i32..=y1 as i32 {
        let y = sy(d as f64);
        let _ = writeln!(
            s,
            r##"<line x1="{m}" y1="{y}" x2="{}" y2="{y}" stroke="#ddd"/><text x="{}" y="{}" text-anchor="end">1e{d}</text>"##,
            w - m - 170.0,
            m - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">computation per simulated second (ms, log)</text>"#,
        (w - 170.0) / 2.0,
        h - 20.0
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(18 {}) rotate(-90)" text-anchor="middle">RMS error after 1 s (m, log)</text>"#,
        h / 2.0
    );
    let colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e"];
    let mut legend = 0;
    for model in [ClothModel::ChoiKo, ClothModel::Lander] {
        for (i, integrator) in Integrator::ALL.iter().enumerate() {
            let curve: Vec<(f64, f64)> = points
                .iter()
                .filter(|(r, ..)| r.model == model && r.integrator == *integrator)
                .map(|&(_, x, y)| (sx(x), sy(y)))
                .collect();
            if curve.is_empty() {
                continue;
            }
            let dash = if model == ClothModel::Lander {
                r#" stroke-dasharray="6 4""#
            } else {
                ""
            };
            let path: Vec<String> = curve
                .iter()
                .map(|(x, y)| format!("{x:.1},{y:.1}"))
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2"{dash}/>"#,
                path.join(" "),
                colours[i]
            );
            for (x, y) in &curve {
                let _ = writeln!(
                    s,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="3" fill="{}"/>"#,
                    colours[i]
                );
            }
            let ly = m + 20.0 * legend as f64;
            let _ = writeln!(
                s,
                r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{}" stroke-width="2"{dash}/><text x="{}" y="{}">{:?} {}</text>"#,
                w - m - 150.0,
                w - m - 125.0,
                colours[i],
                w - m - 120.0,
                ly + 4.0,
                model,
                integrator.name()
            );
            legend += 1;
        }
    }
    s.push_str("</svg>\n");
    s
}
