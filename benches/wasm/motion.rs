//! The motion scene's fixed step in a WebAssembly engine: a 1 m N×N
//! cloth laid horizontal at 1 m, pinned at the two corners of one edge,
//! let go (it falls and swings), every default, in a headless `App`
//! (`MinimalPlugins`, `ClothPlugin`). Built for `wasm32-wasip1` and run
//! in V8 by node's WASI, or natively for the figure beside it:
//!
//! ```sh
//! rustup target add wasm32-wasip1
//! CARGO_TARGET_WASM32_WASIP1_RUSTFLAGS="-C target-feature=+simd128" \
//!     cargo build --release --manifest-path benches/wasm/Cargo.toml --target wasm32-wasip1
//! node tests/wasm/run.mjs benches/wasm/target/wasm32-wasip1/release/wasm_motion.wasm 16 32 64 128
//! cargo run --release --manifest-path benches/wasm/Cargo.toml -- 16 32 64 128
//! ```
//!
//! Printed per size, over 10 s of motion (600 fixed steps of 1/60 s): the
//! median, 95th percentile and largest fixed step (ms, the cloth's own
//! `ClothStats::step_micros`), the median whole frame (ms) and the mean
//! iterations of the solve.

use std::time::Instant;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cloth::prelude::*;

/// Sizes run unless the command line names others.
const SIZES: [u32; 4] = [16, 32, 64, 128];

/// Frames timed: 10 s at 60 Hz.
const FRAMES: usize = 600;

/// The `q` quantile of sorted `values`.
fn quantile(values: &[f64], q: f64) -> f64 {
    values[((values.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let sizes: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        SIZES.to_vec()
    } else {
        sizes
    };
    // The build's SIMD, fixed at compile time on wasm32 (natively the
    // kernels pick theirs at run time).
    let simd = if cfg!(target_feature = "simd128") {
        "simd128"
    } else if cfg!(target_arch = "wasm32") {
        "none"
    } else {
        "native"
    };
    println!(
        "| N | step median ms | step p95 ms | step max ms | frame median ms | mean iterations | SIMD |"
    );
    println!("|---|---|---|---|---|---|---|");
    for n in sizes {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, ClothPlugin::default()))
            .insert_resource(Time::<Fixed>::from_hz(60.0))
            .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
        let cloth = ClothBuilder::new(n, n)
            .size(1.0, 1.0)
            .position(Vec3::new(0.0, 1.0, 0.0))
            .pin(0)
            .pin(n - 1)
            .build()
            .expect("a valid cloth");
        let cloth = app.world_mut().spawn(cloth).id();
        app.update();
        let (mut step, mut frame, mut iterations) = (vec![], vec![], 0u64);
        for _ in 0..FRAMES {
            let start = Instant::now();
            app.update();
            frame.push(start.elapsed().as_secs_f64() * 1e3);
            let stats = app.world().get::<ClothStats>(cloth).expect("the cloth");
            assert!(stats.finite, "the cloth blew up");
            step.push(f64::from(stats.step_micros) / 1e3);
            iterations += u64::from(stats.solver_iterations);
        }
        step.sort_by(f64::total_cmp);
        frame.sort_by(f64::total_cmp);
        println!(
            "| {n} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {} |",
            quantile(&step, 0.5),
            quantile(&step, 0.95),
            quantile(&step, 1.0),
            quantile(&frame, 0.5),
            iterations as f64 / FRAMES as f64,
            simd,
        );
    }
}
