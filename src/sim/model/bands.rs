//! Parallel evaluation of a grid cloth's internal forces in row bands.
//!
//! The particles are cut into bands of `S = 2H` consecutive indices, with
//! `H` at least the reach of a grid link (`2·columns + 2` indices, the
//! (±2, ±2) diagonals). A link is evaluated by the band holding its first
//! particle `a`; its forces land within `H` indices of that band. So bands
//! `j` and `j + 2` never write to the same particle: all even bands run at
//! once, each on its own window of the force array, then all odd bands.
//!
//! Every particle's forces are added in an order fixed by the cloth (even
//! band, then odd band, families in order, links in order), so the result is
//! bitwise the same on one thread or many. It differs in the last bits from
//! the link-by-link order of [`internal_forces`](super::internal_forces).
//! Crease springs and fold terms, which may join any two particles, follow
//! on one thread.

use bevy::math::Vec3;

use super::kernel::Target;
use crate::sim::connections::Connections;
use crate::sim::settings::SimSettings;
use crate::sim::workers::Workers;

/// Bands per cloth at most (fewer for small cloths): enough to keep many
/// threads busy, few enough that each band amortises its task.
pub const MAX_BANDS: usize = 32;

/// Adds the internal forces (N) to `f` band by band, on `workers` when
/// given with more than one thread, otherwise on this thread.
///
/// Returns `false`, with `f` partly written, when the connections are not
/// laid out as [`Connections::grid`] builds them (no `columns`, or a
/// link reaching outside its band's window, as an unsorted family may); the
/// caller then starts over with [`internal_forces`](super::internal_forces).
pub fn internal_forces_banded(
    workers: Option<&dyn Workers>,
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) -> bool {
    banded_on(
        workers.filter(|w| w.threads() > 1),
        settings,
        connections,
        x,
        v,
        f,
    )
}

/// [`internal_forces_banded`] on `pool`, or on this thread for `None`.
fn banded_on(
    pool: Option<&dyn Workers>,
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) -> bool {
    let n = f.len();
    let columns = connections.columns as usize;
    if columns == 0 || n == 0 || x.len() != n || v.len() != n {
        return false;
    }
    // Half a band: at least a link's reach, and at most MAX_BANDS bands.
    let half = (2 * columns + 2).max(n.div_ceil(2 * MAX_BANDS));
    let families = [
        &connections.structural[..],
        &connections.shear,
        &connections.bend,
        &connections.bend_diagonal,
    ];
    // Band j owns the links with a ∈ [2jH, 2jH + 2H); `cuts` splits each
    // family into consecutive runs, one per band, so every link is taken
    // exactly once even if a family is not sorted.
    let bands = n.div_ceil(2 * half);
    let mut cuts = [[0usize; MAX_BANDS + 1]; 4];
    for (cut, fam) in cuts.iter_mut().zip(families) {
        for j in 1..bands {
            let at = fam.partition_point(|l| (l.a as usize) < 2 * half * j);
            cut[j] = at.max(cut[j - 1]);
        }
        cut[bands] = fam.len();
    }
    let mut inside = true;
    // Band j writes within [2jH − H, 2jH + 3H): the even bands' windows are
    // [0, 3H), [3H, 7H), …; the odd bands' [H, 5H), [5H, 9H), ….
    for parity in [0, 1] {
        let first = if parity == 0 { 3 * half } else { half };
        let jobs = windows(f, first, 4 * half)
            .skip(parity)
            .enumerate()
            .map(|(m, window)| (2 * m + parity, window))
            .filter(|&(j, _)| j < bands)
            .map(|(j, (base, window))| {
                let links = [0, 1, 2, 3].map(|k| &families[k][cuts[k][j]..cuts[k][j + 1]]);
                (links, Target { f: window, base })
            });
        inside &= run(pool, jobs, |(links, mut out)| {
            super::grid_forces(settings, links, x, v, &mut out)
        });
    }
    if inside {
        super::extra_forces(settings, connections, x, v, f);
    }
    inside
}

/// `f` cut into windows `[0, first)`, then `width` at a time; each with the
/// index of its first particle.
fn windows(
    f: &mut [Vec3],
    first: usize,
    width: usize,
) -> impl Iterator<Item = (usize, &mut [Vec3])> {
    let (head, tail) = f.split_at_mut(first.min(f.len()));
    let first_len = head.len();
    std::iter::once((0, head)).chain(
        tail.chunks_mut(width)
            .enumerate()
            .map(move |(m, w)| (first_len + m * width, w)),
    )
}

/// Runs `job` on every item, on `pool` if given, and tells whether all of
/// them returned `true`.
fn run<J: Send>(
    pool: Option<&dyn Workers>,
    jobs: impl Iterator<Item = J>,
    job: impl Fn(J) -> bool + Sync,
) -> bool {
    match pool {
        Some(pool) => {
            let job = &job;
            let boxed = jobs
                .map(|j| Box::new(move || job(j)) as Box<dyn FnOnce() -> bool + Send + '_>)
                .collect();
            pool.run_all(boxed)
        }
        None => jobs.map(job).fold(true, |all, ok| all & ok),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::connections::Link;
    use crate::sim::model::internal_forces;
    use crate::sim::model::tests::relative_difference;
    use crate::sim::settings::ClothModel;
    use crate::sim::workers::ScopedThreads;

    /// A `cols × rows` grid (m) bent into a wave and jittered, so links are
    /// stretched and compressed, with random velocities (m/s).
    fn deformed(cols: u32, rows: u32) -> (Connections, Vec<Vec3>, Vec<Vec3>) {
        let h = 0.05;
        let rest: Vec<Vec3> = (0..cols * rows)
            .map(|p| Vec3::new((p % cols) as f32 * h, 0.0, (p / cols) as f32 * h))
            .collect();
        let mut conn = Connections::grid(cols, rows, &rest);
        // A crease spring, which the bands leave to the serial tail.
        conn.crease.push(Link {
            a: 3,
            b: cols * rows - 2,
            rest_length: 0.1,
        });
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut unit = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        let x = rest
            .iter()
            .map(|&p| {
                let wave = Vec3::new(0.0, 0.3 * (7.0 * p.x).sin() * p.z, 0.0);
                0.9 * p + wave + Vec3::new(unit(), unit(), unit()) * 0.3 * h
            })
            .collect();
        let v = rest
            .iter()
            .map(|_| Vec3::new(unit(), unit(), unit()))
            .collect();
        (conn, x, v)
    }

    fn settings(model: ClothModel) -> SimSettings {
        let mut s = SimSettings::default().with_model(model);
        s.choi_ko.pair_damping = 0.5;
        s.choi_ko.bending_rigidity = 1e-3;
        s
    }

    #[test]
    fn bands_give_the_serial_forces_on_a_non_square_grid() {
        // 37 columns × 61 rows: 8 bands, windows cut mid-row.
        let (conn, x, v) = deformed(37, 61);
        let pool = ScopedThreads(3);
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let s = settings(model);
            let mut serial = vec![Vec3::ZERO; x.len()];
            internal_forces(&s, &conn, &x, &v, &mut serial);
            let mut banded = vec![Vec3::ZERO; x.len()];
            assert!(banded_on(
                Some(&pool as &dyn Workers),
                &s,
                &conn,
                &x,
                &v,
                &mut banded
            ));
            let diff = relative_difference(&serial, &banded);
            assert!(diff < 1e-5, "{model:?}: {diff}");
        }
    }

    #[test]
    fn bands_are_bitwise_the_same_on_one_thread_or_many() {
        let (conn, x, v) = deformed(64, 64);
        let s = settings(ClothModel::ChoiKo);
        let mut one = vec![Vec3::ZERO; x.len()];
        assert!(banded_on(None, &s, &conn, &x, &v, &mut one));
        for threads in [2, 3, 8] {
            let pool = ScopedThreads(threads);
            let mut many = vec![Vec3::ZERO; x.len()];
            assert!(banded_on(
                Some(&pool as &dyn Workers),
                &s,
                &conn,
                &x,
                &v,
                &mut many
            ));
            let same = one
                .iter()
                .zip(&many)
                .all(|(a, b)| a.to_array() == b.to_array());
            assert!(same, "{threads} threads differ from one");
        }
        // The order differs from the serial one, so the bits may too: the
        // test above shows that the comparison can fail.
        let mut serial = vec![Vec3::ZERO; x.len()];
        internal_forces(&s, &conn, &x, &v, &mut serial);
        assert!(relative_difference(&serial, &one) < 1e-5);
    }

    #[test]
    fn a_shuffled_family_is_caught_and_needs_no_bands() {
        let (mut conn, x, v) = deformed(30, 30);
        let s = settings(ClothModel::ChoiKo);
        let mut serial = vec![Vec3::ZERO; x.len()];
        internal_forces(&s, &conn, &x, &v, &mut serial);
        // Move the last compressed bend link (far down the grid, so with a
        // force outside the first band's window) to the front.
        let compressed = |l: &Link| x[l.a as usize].distance(x[l.b as usize]) < l.rest_length;
        let last = conn.bend.iter().rposition(compressed).unwrap();
        assert!(conn.bend[last].a > 600);
        let moved = conn.bend.remove(last);
        conn.bend.insert(0, moved);
        let mut banded = vec![Vec3::ZERO; x.len()];
        assert!(!banded_on(None, &s, &conn, &x, &v, &mut banded));
        // Hand-made connections without `columns` are refused up front.
        conn.columns = 0;
        assert!(!banded_on(None, &s, &conn, &x, &v, &mut banded));
        // Through `Dynamics` the fallback still gives the serial forces.
        let mut s = s;
        s.parallel = crate::sim::settings::Parallelism::On;
        s.gravity = Vec3::ZERO;
        s.damping = 0.0;
        let w = vec![1.0; x.len()];
        let d = crate::sim::model::Dynamics {
            settings: &s,
            connections: &conn,
            inverse_masses: &w,
            external: &[],
            workers: crate::sim::workers::Pool::none(),
        };
        let mut a = vec![Vec3::ZERO; x.len()];
        d.accelerations(&x, &v, &mut a);
        assert!(relative_difference(&serial, &a) < 1e-5);
    }
}
