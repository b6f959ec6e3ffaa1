//! Research tools, outside the game-facing API: the measurements behind
//! `docs/validation.md` and `docs/performance.md`.
//!
//! - [`accuracy`]: what accuracy costs in time, every model × integrator
//!   on Sato & Yoshida's hanging-cloth scene (stable step, µs per step,
//!   error against a fine reference);
//! - [`compare`]: the same scripted pull on Choi–Ko's and Lander's cloth.
//!
//! A game does not need these; they are public so that the `accuracy`
//! example, the benches and the tests can share them. They may import any
//! module; outside tests, no module imports them.

pub mod accuracy;
pub mod compare;
