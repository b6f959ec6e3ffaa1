//! The solve shared with the helper thread against the solve on one
//! thread, and the helper's barriers, sums and panics.

use std::panic::{AssertUnwindSafe, catch_unwind};

use super::*;
use crate::sim::team::{self, Claim, claim, lend_helper};

/// The helper, once no other test is using it (lent to the test in a build
/// without threads).
fn the_helper() -> Claim {
    for _ in 0..10_000 {
        if let Some(c) = lend_helper(claim) {
            return c;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    panic!("the helper thread stayed busy (or could not be spawned)");
}

/// Solves one backward-Euler step of a deformed `n × n` cloth pinned at
/// two corners, on one thread or sharing the iterations with the helper
/// (retried while another test holds it). Returns Δv and the solve's
/// iterations, residual and threads.
fn solve_on(n: u32, coarse_grid: bool, helper: bool) -> (Vec<Vec3>, u32, f32, u32) {
    solve_from(n, coarse_grid, helper, &[])
}

/// [`solve_on`], the solve starting from the past solutions `past` (as
/// after hard solves) if any are given.
fn solve_from(
    n: u32,
    coarse_grid: bool,
    helper: bool,
    past: &[Vec<Vec3>],
) -> (Vec<Vec3>, u32, f32, u32) {
    let helper_runs = crate::simd::level() > crate::simd::Level::Scalar;
    let (cloth, v, _) = deformed(n);
    let mut settings = SimSettings::default();
    settings.implicit.coarse_grid = coarse_grid;
    settings.implicit.helper_thread = helper;
    let h = 1.0 / 60.0;
    let (dynamics, mut buffers) = linearised(&settings, &cloth, &v, h);
    assert_eq!(buffers.coarse_active, coarse_grid);
    for i in 0..v.len() {
        buffers.rhs.set(i, h * buffers.force[i]);
    }
    buffers.rhs.filter(&buffers.op.free);
    let retry = helper && helper_runs && v.len() >= halves::MIN_PARTICLES && team::available();
    for _ in 0..1000 {
        buffers.reset_history();
        for w in past {
            let w = soa(w.len(), |i| w[i]);
            buffers.past.remember(&w, 4, (100, 100));
        }
        buffers.warm = !past.is_empty();
        solve(&dynamics, &mut buffers);
        if !retry || buffers.last_threads == 2 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    let dv = (0..v.len()).map(|i| buffers.dv.get(i)).collect();
    let b = &buffers;
    (dv, b.last_iterations, b.last_residual, b.last_threads)
}

/// Asserts that two solutions are the same to the bit.
fn assert_same_bits(alone: &[Vec3], shared: &[Vec3]) {
    for (i, (a, b)) in alone.iter().zip(shared).enumerate() {
        assert_eq!(
            a.to_array().map(f32::to_bits),
            b.to_array().map(f32::to_bits),
            "{i}"
        );
    }
}

/// 50×50 with the coarse grid (aggregates of 7×7, the last band one row
/// deep, the cut after the fourth band) and 46×46 without (the cut in the
/// middle): the same Δv to the bit, the same iterations and residual.
#[test]
fn the_helper_thread_changes_no_bit_of_the_solve() {
    for (n, coarse_grid) in [(50, true), (46, false)] {
        let (alone, iterations, residual, threads) = solve_on(n, coarse_grid, false);
        assert_eq!(threads, 1);
        assert!(iterations > 10, "{iterations} iterations: too easy a test");
        let (shared, iterations2, residual2, threads2) =
            lend_helper(|| solve_on(n, coarse_grid, true));
        // The shared solve needs the gathered product, which the portable
        // code (`BEVY_CLOTH_SIMD=scalar`) does not have: one thread there.
        let shares = crate::simd::level() > crate::simd::Level::Scalar;
        assert_eq!(
            threads2,
            if shares { 2 } else { 1 },
            "{n}×{n}: the helper was never free"
        );
        assert_eq!((iterations, residual), (iterations2, residual2));
        assert_same_bits(&alone, &shared);
    }
}

/// A solve that starts from the past solutions and deflates its
/// directions by them (both threads deflating their halves) gives the same
/// bits as on one thread.
#[test]
fn the_helper_thread_changes_no_bit_of_a_deflated_solve() {
    let (cold, cold_iterations, _, _) = solve_on(50, true, false);
    // The solution, disturbed, and a wiggle: a guess that helps but leaves
    // work to do.
    let disturbed = cold
        .iter()
        .enumerate()
        .map(|(i, &x)| x + 0.3 * x.length() * wiggle(5 * i))
        .collect();
    let waves = (0..cold.len()).map(|i| 0.01 * wiggle(i)).collect();
    let past = [disturbed, waves];
    let (alone, iterations, residual, threads) = solve_from(50, true, false, &past);
    assert_eq!(threads, 1);
    assert!(
        iterations > 10 && iterations != cold_iterations,
        "{iterations} iterations (cold {cold_iterations}): the past was not used, or too well"
    );
    let (shared, iterations2, residual2, threads2) =
        lend_helper(|| solve_from(50, true, true, &past));
    let shares = crate::simd::level() > crate::simd::Level::Scalar;
    assert_eq!(threads2, if shares { 2 } else { 1 });
    assert_eq!((iterations, residual), (iterations2, residual2));
    assert_same_bits(&alone, &shared);
}

/// What a build without threads does (`wasm32` in a browser; the host
/// built with `--cfg bevy_cloth_no_threads`, as CI runs this test): the
/// split solve, asked to share with the helper as by default, runs on the
/// calling thread alone and spawns nothing, and gives the two-thread result.
/// In a build with threads the single-thread solve is asked for instead.
#[test]
fn without_threads_the_split_solve_runs_here_with_the_two_thread_result() {
    let (alone, iterations, residual, threads) = solve_on(50, true, !team::THREADS);
    assert_eq!(threads, 1);
    if !team::THREADS {
        assert!(
            claim().is_none(),
            "a build without threads offered the helper"
        );
        let here = std::thread::current().id();
        let (a, b) = team::both(
            || std::thread::current().id(),
            || std::thread::current().id(),
        );
        assert_eq!((a, b), (here, here));
    }
    let (shared, iterations2, residual2, threads2) = lend_helper(|| solve_on(50, true, true));
    let shares = crate::simd::level() > crate::simd::Level::Scalar;
    assert_eq!(threads2, if shares { 2 } else { 1 });
    assert_eq!((iterations, residual), (iterations2, residual2));
    for (i, (a, b)) in alone.iter().zip(&shared).enumerate() {
        assert!(
            (*a - *b).length() <= 1e-6 * b.length().max(1e-3),
            "{i}: {a} vs {b}"
        );
    }
}

/// Below [`halves::MIN_PARTICLES`] the solve stays on one thread.
#[test]
fn a_small_cloth_solves_on_one_thread() {
    let (_, _, _, threads) = solve_on(40, true, true);
    assert_eq!(threads, 1);
}

#[test]
fn both_halves_pass_every_barrier_and_agree_on_every_sum() {
    let helper = the_helper();
    let sums = helper.run(|team, part| {
        let mut sums = Vec::new();
        for k in 0..2000u32 {
            let value = (part as f64 + 1.0) * k as f64;
            sums.push(team.sum(part, (k % 2) as usize, value));
            if k % 3 == 0 {
                team.barrier(part);
            }
            // Several at one barrier, alternating between slots 2–4 and 5–7.
            let mut many = [value, 2.0 * value, -value];
            team.sums(part, 2 + 3 * (k % 2) as usize, &mut many);
            assert_eq!(many, [3.0, 6.0, -3.0].map(|m| m * k as f64));
        }
        sums
    });
    for (k, s) in sums.iter().enumerate() {
        assert_eq!(*s, 3.0 * k as f64);
    }
}

#[test]
fn a_panic_in_either_half_reaches_the_caller_and_the_helper_lives_on() {
    let helper = the_helper();
    for panicking in [0, 1] {
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            helper.run(|team, part| {
                team.barrier(part);
                if part == panicking {
                    panic!("half {part} fails on purpose");
                }
                // The other half waits here until it sees the panic.
                team.barrier(part);
            })
        }));
        assert!(outcome.is_err(), "half {panicking} panicked unseen");
        let total = helper.run(|team, part| team.sum(part, 0, 1.0));
        assert_eq!(total, 2.0);
    }
}

#[test]
fn the_solve_shares_its_iterations_while_that_is_faster() {
    use std::time::Duration;
    let mut choice = halves::Choice::default();
    let us = Duration::from_micros;
    // Shared first, then alone, each timed once.
    assert!(choice.share());
    choice.record(2, us(1000), 50); // 20 µs per iteration
    assert!(!choice.share());
    choice.record(1, us(1200), 50); // 24 µs
    // Then shared, but alone one solve in 30, and a solve of fewer than
    // four iterations says nothing.
    let picks: Vec<bool> = (0..60).map(|_| choice.share()).collect();
    assert_eq!(picks.iter().filter(|&&p| !p).count(), 2, "{picks:?}");
    choice.record(2, us(10), 2);
    assert!(choice.share());
    // Sharing slows down (28 µs, averaged in): alone wins.
    for _ in 0..10 {
        choice.record(2, us(1400), 50);
    }
    let picks: Vec<bool> = (0..60).map(|_| choice.share()).collect();
    assert_eq!(picks.iter().filter(|&&p| p).count(), 2, "{picks:?}");
    // Alone is far slower (48 µs): shared but one solve in 240.
    for _ in 0..20 {
        choice.record(2, us(1000), 50);
    }
    choice.record(1, us(2400), 50);
    choice.record(1, us(2400), 50);
    choice.record(1, us(2400), 50);
    let picks: Vec<bool> = (0..480).map(|_| choice.share()).collect();
    assert_eq!(picks.iter().filter(|&&p| !p).count(), 2, "{picks:?}");
}

/// A helper whose core other threads have taken starts its half late: the
/// shared solve still gives the single-thread bits; and a run in which the
/// calling thread mostly waited leaves the helper alone (claims fail, the
/// work runs here) until its backoff ends.
#[test]
fn a_late_helper_changes_no_bit_and_is_left_alone() {
    use std::sync::atomic::Ordering;
    let shares = crate::simd::level() > crate::simd::Level::Scalar;
    let (alone, iterations, residual, _) = solve_on(50, true, false);
    team::LATE_BY.store(2000, Ordering::Relaxed);
    let (late, iterations2, residual2, threads) = lend_helper(|| solve_on(50, true, true));
    // Judged: a run of ~0 µs of work that waited 2 ms for the helper.
    let helper = the_helper();
    team::JUDGE.store(true, Ordering::Relaxed);
    helper.run(|team, part| team.barrier(part));
    team::JUDGE.store(false, Ordering::Relaxed);
    team::LATE_BY.store(0, Ordering::Relaxed);
    drop(helper);
    let left_alone = team::left_alone();
    let refused = lend_helper(claim).is_none();
    team::forgive();
    assert_eq!((iterations, residual), (iterations2, residual2));
    for (i, (a, b)) in alone.iter().zip(&late).enumerate() {
        let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
        assert_eq!(bits(a), bits(b), "{i}");
    }
    if team::available() {
        assert_eq!(threads, if shares { 2 } else { 1 }, "the late solve");
        assert!(
            left_alone,
            "a helper 2 ms late on an empty run is left alone"
        );
        assert!(refused, "claims fail while it is left alone");
    }
}
