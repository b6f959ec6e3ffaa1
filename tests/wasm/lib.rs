//! bevy_cloth's kernels (`src/simd/`) compiled on their own for
//! `wasm32-wasip1`, so that their unit tests, each kernel against its
//! scalar reference, run in a WebAssembly engine (V8, through node's WASI:
//! `run.mjs`) without building Bevy. With simd128 and without:
//!
//! ```sh
//! rustup target add wasm32-wasip1
//! export CARGO_TARGET_WASM32_WASIP1_RUNNER="node $PWD/tests/wasm/run.mjs"
//! CARGO_TARGET_WASM32_WASIP1_RUSTFLAGS="-C target-feature=+simd128" \
//!     cargo test --manifest-path tests/wasm/Cargo.toml --target wasm32-wasip1
//! cargo test --manifest-path tests/wasm/Cargo.toml --target wasm32-wasip1
//! ```

#![allow(
    unused_imports,
    unused_macros,
    dead_code,
    unfulfilled_lint_expectations,
    reason = "the crate's users of the kernels are not here, and its lint expectations hold there"
)]

#[path = "../../src/simd/mod.rs"]
pub mod simd;
