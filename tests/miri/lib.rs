//! bevy_cloth's helper thread (`src/sim/team.rs`) compiled on its own, so
//! that Miri checks its unsafe code (the lifetime-erased job, the barriers,
//! the hand-over and the panic path) without building Bevy:
//!
//! ```sh
//! MIRIFLAGS=-Zmiri-ignore-leaks cargo +nightly miri test --manifest-path tests/miri/Cargo.toml
//! ```
//!
//! (The helper thread serves the process until it ends, by design: Miri
//! would otherwise report it as a thread left running.)

#![allow(dead_code, reason = "the solver's callers are not here")]

#[path = "../../src/sim/team.rs"]
pub mod team;

#[cfg(test)]
mod tests {
    use std::panic::{AssertUnwindSafe, catch_unwind};
    use std::sync::atomic::Ordering;

    use crate::team::{self, Claim, both, claim};

    /// The helper, once no other test holds it.
    fn the_helper() -> Claim {
        loop {
            if let Some(c) = claim() {
                return c;
            }
            std::thread::yield_now();
        }
    }

    #[test]
    fn both_halves_pass_every_barrier_and_agree_on_every_sum() {
        let helper = the_helper();
        for _ in 0..3 {
            let sums = helper.run(|team, part| {
                let mut sums = Vec::new();
                for k in 0..20u32 {
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
    }

    #[test]
    fn a_borrowed_job_sees_and_writes_the_callers_data() {
        let helper = the_helper();
        let mut halves = [vec![0u32; 8], vec![0u32; 8]];
        let [low, high] = &mut halves;
        let cells = [std::sync::Mutex::new(low), std::sync::Mutex::new(high)];
        helper.run(|team, part| {
            let mut mine = cells[part].lock().unwrap();
            for (i, x) in mine.iter_mut().enumerate() {
                *x = (part * 100 + i) as u32;
            }
            team.barrier(part);
        });
        drop(cells);
        assert_eq!(halves[1][7], 107);
        assert_eq!(halves[0][3], 3);
    }

    #[test]
    fn both_runs_each_closure_once_with_its_borrows() {
        let data = vec![1u64, 2, 3, 4];
        let (a, b) = both(
            || data[..2].iter().sum::<u64>(),
            || data[2..].iter().sum::<u64>(),
        );
        assert_eq!((a, b), (3, 7));
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
                    team.barrier(part);
                })
            }));
            assert!(outcome.is_err(), "half {panicking} panicked unseen");
            let total = helper.run(|team, part| team.sum(part, 0, 1.0));
            assert_eq!(total, 2.0);
        }
    }

    #[test]
    fn a_late_helper_is_left_alone_and_forgiven() {
        let helper = the_helper();
        team::LATE_BY.store(1000, Ordering::Relaxed);
        team::JUDGE.store(true, Ordering::Relaxed);
        helper.run(|team, part| team.barrier(part));
        team::JUDGE.store(false, Ordering::Relaxed);
        team::LATE_BY.store(0, Ordering::Relaxed);
        drop(helper);
        // Miri's clock is its own: the timing is checked natively only.
        if !cfg!(miri) {
            assert!(team::left_alone());
        }
        team::forgive();
        assert!(!team::left_alone());
    }

    #[test]
    fn wake_reaches_a_parked_helper() {
        let helper = the_helper();
        helper.run(|team, part| team.barrier(part));
        drop(helper);
        team::wake();
        let helper = the_helper();
        assert_eq!(helper.run(|team, part| team.sum(part, 1, 2.0)), 4.0);
    }
}
