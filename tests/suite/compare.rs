//! Seed §6.2: after the same pull and release, how much do Choi–Ko's and
//! Lander's cloths still move, and how wrinkled do they stay?

use bevy_cloth::lab::compare::pull_and_release;
use bevy_cloth::prelude::*;

#[test]
fn lander_and_choi_ko_after_the_same_pull() {
    let choi = pull_and_release(ClothModel::ChoiKo);
    let lander = pull_and_release(ClothModel::Lander);
    for (name, r) in [("Choi–Ko", &choi), ("Lander", &lander)] {
        eprintln!(
            "{name}: kinetic {:.2e} / {:.2e} / {:.2e} J, mean speed {:.2e} / {:.2e} / {:.2e} m/s at 1/2/5 s, \
             wrinkle {:.4} rad, peak strain {:.2} %",
            r.kinetic[0],
            r.kinetic[1],
            r.kinetic[2],
            r.speed[0],
            r.speed[1],
            r.speed[2],
            r.wrinkle,
            100.0 * r.peak_strain
        );
        assert!(r.finite);
    }
    // What the README states. Wrinkles: the paper's claim holds.
    assert!(lander.wrinkle > 2.0 * choi.wrinkle);
    // Oscillation: only in part. Lander's cloth moves more 2 s after the
    // release, Choi–Ko's more at 1 s (it swings back harder from a pull
    // that strained Lander's twice as much); by 5 s the absolute damping
    // (c = 2 s⁻¹) has settled both.
    assert!(lander.kinetic[1] > choi.kinetic[1]);
    assert!(choi.kinetic[0] > lander.kinetic[0]);
    assert!(lander.peak_strain > 1.5 * choi.peak_strain);
    for r in [&choi, &lander] {
        assert!(r.kinetic[2] < 1e-3 * r.kinetic[0]);
    }
}
