//! Force models as plain functions over slices. The folder imports the
//! foundations (`settings`, `connections`, `soa`, `simd`, `team`, `workers`) and
//! nothing that schedules or steps a cloth.
//!
//! - `choi_ko`: Type 1 tension-only springs and Type 2 buckling links.
//! - `lander`: two-sided damped springs (the paper's baseline).
//! - `Dynamics::accelerations`: paper eq. 5, `a = M⁻¹F + g − c·v`, with
//!   pinned particles (inverse mass 0) held at zero acceleration.

pub(crate) mod bands;
pub(crate) mod buckling;
pub(crate) mod choi_ko;
pub(crate) mod jacobian;
pub(crate) mod kernel;
pub(crate) mod lander;
pub(crate) mod streams;

use bevy::math::Vec3;

use crate::sim::connections::{Connections, Link};
use crate::sim::settings::{ClothModel, SimSettings, SpringSettings};
use crate::sim::workers::Pool;
use kernel::{Law, Target};

pub use bands::internal_forces_banded;
pub(crate) use choi_ko::BUCKLING_TABLE;
pub use streams::ForceStreams;

/// Adds the internal forces (N) of `settings.model` over `connections` to `f`,
/// on one thread, family by family.
///
/// Internal forces are sums of equal and opposite pair forces, so they add
/// up to zero over the cloth.
pub fn internal_forces(
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) {
    let mut out = Target { f, base: 0 };
    grid_forces(settings, grid_families(connections), x, v, &mut out);
    extra_forces(settings, connections, x, v, out.f);
}

/// [`internal_forces`] with the grid families evaluated by index step
/// (`streams`): the same forces, summed in another order, in about half
/// the time on a 15×15 cloth (6.6 → 3.0 µs).
pub fn internal_forces_streamed(
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
    streams: &mut ForceStreams,
) {
    sync_streams(settings, connections, x.len(), streams);
    streamed_forces(settings, connections, x, v, f, streams);
}

/// Brings `streams` up to date with the grid families of `connections`.
fn sync_streams(
    settings: &SimSettings,
    connections: &Connections,
    n: usize,
    streams: &mut ForceStreams,
) {
    let (laws, count) = grid_laws(settings, grid_families(connections));
    streams.sync(laws[..count].iter().map(|l| l.0), n);
}

/// [`internal_forces_streamed`] with streams already synced.
fn streamed_forces(
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
    streams: &mut ForceStreams,
) {
    let (laws, count) = grid_laws(settings, grid_families(connections));
    streams.pair_forces_synced(&laws[..count], x, v, f);
    extra_forces(settings, connections, x, v, f);
}

/// The four grid families: structural, shear, bend, bend diagonal.
fn grid_families(connections: &Connections) -> [&[Link]; 4] {
    [
        &connections.structural,
        &connections.shear,
        &connections.bend,
        &connections.bend_diagonal,
    ]
}

/// The forces of the four grid families (structural, shear, bend, bend
/// diagonal) into `out`; `false` if a link fell outside its window.
fn grid_forces(
    settings: &SimSettings,
    families: [&[Link]; 4],
    x: &[Vec3],
    v: &[Vec3],
    out: &mut Target,
) -> bool {
    let (laws, count) = grid_laws(settings, families);
    kernel::pair_forces(&laws[..count], x, v, out)
}

/// The force-law table: every family of links of `connections` with its
/// law under `settings.model`, in a fixed order (structural, shear, bend,
/// bend diagonal for Choi–Ko, then the crease springs). The forces, the
/// Jacobians ([`jacobian`]) and the stiffness estimate
/// ([`adaptive`](crate::sim::adaptive)) all read it.
///
/// | family | Choi–Ko | Lander |
/// |---|---|---|
/// | structural | `Tension { k, k_d }` | `Spring` (structural) |
/// | shear | `Tension { k_shear, k_d }` | `Spring` (shear) |
/// | bend, bend diagonal | `Buckling { k_b, c_b }` | `Spring` (bend); no diagonal |
/// | crease | `Tension { k, k_d }` | `Tension` (structural constants) |
pub(crate) fn laws<'a>(
    settings: &'a SimSettings,
    connections: &'a Connections,
) -> impl Iterator<Item = (&'a [Link], Law<'a>)> + Clone {
    let (grid, count) = grid_laws(settings, grid_families(connections));
    grid.into_iter()
        .take(count)
        .chain([(&connections.crease[..], crease_law(settings))])
}

/// The grid families of `settings.model` with their force laws: the first
/// `count` entries of the array (Lander's cloth has no diagonal bend).
pub(crate) fn grid_laws<'a>(
    settings: &'a SimSettings,
    [structural, shear, bend, bend_diagonal]: [&'a [Link]; 4],
) -> ([(&'a [Link], Law<'a>); 4], usize) {
    match settings.model {
        ClothModel::ChoiKo => {
            let p = &settings.choi_ko;
            let tension = Law::Tension {
                k: p.stiffness,
                kd: p.pair_damping,
            };
            let shearing = Law::Tension {
                k: p.shear_stiffness,
                kd: p.pair_damping,
            };
            let buckling = Law::Buckling {
                table: &BUCKLING_TABLE,
                kb: p.bending_rigidity,
                cb: p.buckling_slope,
            };
            let families = [
                (structural, tension),
                (shear, shearing),
                (bend, buckling),
                (bend_diagonal, buckling),
            ];
            (families, 4)
        }
        ClothModel::Lander => {
            let p = &settings.lander;
            let spring = |s: SpringSettings| Law::Spring {
                ks: s.stiffness,
                kd: s.damping,
            };
            let families = [
                (structural, spring(p.structural)),
                (shear, spring(p.shear)),
                (bend, spring(p.bend)),
                (bend_diagonal, spring(p.bend)),
            ];
            (families, 3)
        }
    }
}

/// The law of crease springs: tension only, with the Type 1 constants or
/// Lander's structural ones (stiffness N/m, axial damping N·s/m).
pub(crate) fn crease_law(settings: &SimSettings) -> Law<'static> {
    let (k, kd) = match settings.model {
        ClothModel::ChoiKo => (settings.choi_ko.stiffness, settings.choi_ko.pair_damping),
        ClothModel::Lander => {
            let s = settings.lander.structural;
            (s.stiffness, s.damping)
        }
    };
    Law::Tension { k, kd }
}

/// The forces of crease springs (Type 1 links of rest length L', MODEL.md
/// §9.1) and fold-direction terms, which may join any two particles.
fn extra_forces(
    settings: &SimSettings,
    connections: &Connections,
    x: &[Vec3],
    v: &[Vec3],
    f: &mut [Vec3],
) {
    let mut out = Target { f, base: 0 };
    let crease = crease_law(settings);
    kernel::pair_forces(&[(&connections.crease, crease)], x, v, &mut out);
    crate::sim::connections::fold_forces(&connections.fold, x, out.f);
}

/// Everything the acceleration of a cloth depends on besides its state.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Dynamics<'a> {
    /// Model, constants, gravity and damping.
    pub settings: &'a SimSettings,
    /// The pairs the internal forces act on.
    pub connections: &'a Connections,
    /// Inverse masses in 1/kg; 0 pins a particle.
    pub inverse_masses: &'a [f32],
    /// External forces in N held constant over the step (wind, grabs); empty
    /// for none, otherwise one per particle.
    pub external: &'a [Vec3],
    /// The threads the forces may be evaluated on in bands
    /// ([`Parallelism`](crate::sim::settings::Parallelism));
    /// [`Pool::none`] for this thread alone.
    pub workers: &'a Pool,
}

impl Dynamics<'_> {
    /// Overwrites `out` with the external forces (N), or zeros if there are none.
    fn external_forces(&self, out: &mut [Vec3]) {
        if self.external.len() == out.len() {
            out.copy_from_slice(self.external);
        } else {
            out.fill(Vec3::ZERO);
        }
    }

    /// Writes the accelerations (m/s²) at state `(x, v)` into `out`:
    /// `a_i = w_i (F_int + F_ext)_i + g − c·v_i` for free particles, 0 for
    /// pinned ones (`w_i = 0`), so a pin keeps whatever velocity it was given.
    #[cfg(test)]
    pub fn accelerations(&self, x: &[Vec3], v: &[Vec3], out: &mut [Vec3]) {
        self.accelerations_inner(None, x, v, out);
    }

    /// [`accelerations`](Self::accelerations) with the single-threaded
    /// forces evaluated by index step ([`streams`]) in `streams`, the cache
    /// kept for this cloth between calls.
    #[cfg(test)]
    pub fn accelerations_with(
        &self,
        streams: &mut ForceStreams,
        x: &[Vec3],
        v: &[Vec3],
        out: &mut [Vec3],
    ) {
        self.sync_streams(streams, x.len());
        self.accelerations_inner(Some(streams), x, v, out);
    }

    /// Whether `n` particles are evaluated in bands
    /// ([`Parallelism::banded`](crate::sim::settings::Parallelism::banded)).
    fn banded(&self, n: usize) -> bool {
        self.settings.parallel.banded(n, self.workers.threads())
    }

    /// Brings `streams` up to date for [`accelerations_synced`]
    /// (Self::accelerations_synced) on `n` particles.
    pub(crate) fn sync_streams(&self, streams: &mut ForceStreams, n: usize) {
        if !self.banded(n) {
            sync_streams(self.settings, self.connections, n, streams);
        }
    }

    /// [`accelerations_with`](Self::accelerations_with) with `streams`
    /// synced since the connections last changed: one comparison of the
    /// links per step rather than per evaluation.
    pub(crate) fn accelerations_synced(
        &self,
        streams: &mut ForceStreams,
        x: &[Vec3],
        v: &[Vec3],
        out: &mut [Vec3],
    ) {
        self.accelerations_inner(Some(streams), x, v, out);
    }

    fn accelerations_inner(
        &self,
        streams: Option<&mut ForceStreams>,
        x: &[Vec3],
        v: &[Vec3],
        out: &mut [Vec3],
    ) {
        let banded = self.banded(out.len());
        if let (Some(streams), false) = (streams, banded) {
            // Everything else first, so that the streams' last pass turns
            // the sum into accelerations; with nothing else, the streams
            // start from zero without reading `out`.
            let c = self.connections;
            let alone =
                self.external.len() != out.len() && c.crease.is_empty() && c.fold.is_empty();
            if !alone {
                self.external_forces(out);
                extra_forces(self.settings, c, x, v, out);
            }
            let (laws, count) = grid_laws(self.settings, grid_families(c));
            let accel = streams::Accel {
                inverse_masses: self.inverse_masses,
                gravity: self.settings.gravity,
                damping: self.settings.damping,
                from_zero: alone,
            };
            streams.accelerations_synced(&laws[..count], x, v, &accel, out);
            return;
        }
        self.external_forces(out);
        let pool = self.workers.get();
        if !(banded
            && bands::internal_forces_banded(pool, self.settings, self.connections, x, v, out))
        {
            if banded {
                // Not a layout the bands can split: start over on one thread.
                self.external_forces(out);
            }
            internal_forces(self.settings, self.connections, x, v, out)
        }
        let g = self.settings.gravity.to_array();
        let c = self.settings.damping;
        // Component by component over flat arrays, which vectorises.
        let out: &mut [f32] = bytemuck::cast_slice_mut(out);
        let v: &[f32] = bytemuck::cast_slice(v);
        let rows = out.chunks_exact_mut(3).zip(v.chunks_exact(3));
        for ((a, v), &w) in rows.zip(self.inverse_masses) {
            for k in 0..3 {
                a[k] = if w == 0.0 {
                    0.0
                } else {
                    w * a[k] + g[k] - c * v[k]
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny deterministic generator (xorshift) so the tests need no crate.
    struct Rng(u64);
    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        }
        fn vec(&mut self, scale: f32) -> Vec3 {
            Vec3::new(self.unit(), self.unit(), self.unit()) * scale
        }
    }

    /// Rest positions (m) of a flat `n × n` grid of spacing `h` (m), and
    /// its connections.
    fn flat_grid(n: u32, h: f32) -> (Vec<Vec3>, Connections) {
        let rest: Vec<Vec3> = (0..n * n)
            .map(|p| Vec3::new((p % n) as f32 * h, 0.0, (p / n) as f32 * h))
            .collect();
        let conn = Connections::grid(n, n, &rest);
        (rest, conn)
    }

    #[test]
    fn internal_forces_sum_to_zero_on_a_random_deformed_grid() {
        let h = 0.1;
        let (rest, conn) = flat_grid(9, h);
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        // Perturb by up to half a spacing so links are both stretched and compressed.
        let x: Vec<Vec3> = rest.iter().map(|&p| p + rng.vec(0.5 * h)).collect();
        let v: Vec<Vec3> = rest.iter().map(|_| rng.vec(1.0)).collect();
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let mut s = SimSettings::default().with_model(model);
            // Make the Type 2 links matter as much as Type 1 ones.
            s.choi_ko.bending_rigidity = 1.0;
            let mut f = vec![Vec3::ZERO; x.len()];
            internal_forces(&s, &conn, &x, &v, &mut f);
            let total: Vec3 = f.iter().sum();
            let scale: f32 = f.iter().map(|v| v.length()).sum();
            assert!(scale > 1.0, "{model:?}: forces too small to test ({scale})");
            assert!(
                total.length() < 1e-5 * scale,
                "{model:?}: net {total} of {scale}"
            );
        }
    }

    /// The largest difference between two force arrays, relative to the
    /// largest force (also used by the bands' tests).
    pub(super) fn relative_difference(p: &[Vec3], q: &[Vec3]) -> f32 {
        let scale = p.iter().map(|f| f.length()).fold(0.0, f32::max);
        // `f32::max` drops NaN: count a NaN difference as infinite.
        let diff = p.iter().zip(q).map(|(a, b)| {
            let d = (*a - *b).length();
            if d.is_nan() { f32::INFINITY } else { d }
        });
        diff.fold(0.0, f32::max) / scale
    }

    #[test]
    fn streamed_forces_match_the_pair_kernel_and_follow_edits_of_the_links() {
        let h = 0.1;
        let (rest, mut conn) = flat_grid(11, h);
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let x: Vec<Vec3> = rest.iter().map(|&p| p + rng.vec(0.5 * h)).collect();
        let v: Vec<Vec3> = rest.iter().map(|_| rng.vec(1.0)).collect();
        let mut streams = ForceStreams::default();
        let mut check = |s: &SimSettings, conn: &Connections, what: &str| {
            let mut want = vec![Vec3::ZERO; x.len()];
            internal_forces(s, conn, &x, &v, &mut want);
            let mut got = vec![Vec3::ONE; x.len()];
            internal_forces_streamed(s, conn, &x, &v, &mut got, &mut streams);
            for f in &mut got {
                *f -= Vec3::ONE;
            }
            let err = relative_difference(&want, &got);
            assert!(err < 1e-5, "{what}: relative difference {err}");
        };
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            let mut s = SimSettings::default().with_model(model);
            s.choi_ko.bending_rigidity = 1.0;
            s.choi_ko.pair_damping = 0.5;
            check(&s, &conn, &format!("{model:?}"));
            s.choi_ko.pair_damping = 0.0;
            check(&s, &conn, &format!("{model:?} undamped"));
        }
        let s = SimSettings {
            choi_ko: crate::sim::settings::ChoiKoSettings {
                bending_rigidity: 1.0,
                ..Default::default()
            },
            ..Default::default()
        };
        // A crease shortens Type 2 rest lengths in place; the streams must
        // see it on the next call.
        for l in conn.bend.iter_mut().step_by(3) {
            l.rest_length *= 0.5;
        }
        conn.structural[7].rest_length *= 0.8;
        check(&s, &conn, "rest lengths edited in place");
        // Links the streams cannot hold: reversed ends, a repeated pair,
        // an odd step, and a family with one link removed.
        let first = conn.shear[0];
        conn.shear.push(Link {
            a: first.b,
            b: first.a,
            ..first
        });
        conn.structural.push(Link::from_rest(3, 40, &rest));
        conn.bend.remove(5);
        conn.structural.swap(0, 9);
        check(&s, &conn, "odd links");
    }

    #[test]
    fn streams_trust_links_of_one_generation_and_compare_them_on_a_new_one() {
        let h = 0.1;
        let (rest, mut conn) = flat_grid(11, h);
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let x: Vec<Vec3> = rest.iter().map(|&p| p + rng.vec(0.5 * h)).collect();
        let v = vec![Vec3::ZERO; x.len()];
        let s = SimSettings::default();
        let mut streams = ForceStreams::default();
        let error = |conn: &Connections, streams: &mut ForceStreams| {
            let mut want = vec![Vec3::ZERO; x.len()];
            internal_forces(&s, conn, &x, &v, &mut want);
            let mut got = vec![Vec3::ZERO; x.len()];
            internal_forces_streamed(&s, conn, &x, &v, &mut got, streams);
            relative_difference(&want, &got)
        };
        streams.set_links_generation(Some(1));
        assert!(error(&conn, &mut streams) < 1e-5);
        // Edited in place under the same generation: the streams trust the
        // links they were built from and do not look at them.
        for l in &mut conn.structural {
            l.rest_length *= 0.9;
        }
        assert!(error(&conn, &mut streams) > 1e-2, "the links were compared");
        // A new generation: compared, and rebuilt.
        streams.set_links_generation(Some(2));
        assert!(error(&conn, &mut streams) < 1e-5);
        // Other lists under the same generation: compared too.
        let mut other = conn.clone();
        other.structural[3].rest_length *= 0.5;
        assert!(error(&other, &mut streams) < 1e-5);
        // Without a generation, every call compares.
        streams.set_links_generation(None);
        other.structural[4].rest_length *= 0.5;
        assert!(error(&other, &mut streams) < 1e-5);
    }

    #[test]
    fn pinned_particles_get_no_acceleration_and_free_ones_gravity() {
        let rest = [Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0)];
        let conn = Connections::default();
        let settings = SimSettings::default();
        let d = Dynamics {
            settings: &settings,
            connections: &conn,
            inverse_masses: &[0.0, 1.0, 2.0],
            external: &[Vec3::ZERO, Vec3::ZERO, Vec3::X],
            workers: crate::sim::workers::Pool::none(),
        };
        let v = [Vec3::ONE, Vec3::ZERO, Vec3::Y];
        let mut a = [Vec3::NAN; 3];
        d.accelerations(&rest, &v, &mut a);
        assert_eq!(a[0], Vec3::ZERO);
        assert_eq!(a[1], settings.gravity);
        let want = Vec3::X * 2.0 + settings.gravity - settings.damping * Vec3::Y;
        assert!((a[2] - want).length() < 1e-6);
    }

    #[test]
    fn streamed_accelerations_match_the_link_by_link_ones() {
        let h = 0.1;
        let (rest, grid) = flat_grid(13, h);
        // The grid alone (the streams start from zero forces); with a
        // structural link of a step no stream has (the pair kernel adds it
        // first); with a crease link and external forces on top.
        let mut stray = grid.clone();
        stray.structural.push(Link::from_rest(3, 50, &rest));
        let mut creased = grid.clone();
        creased.crease.push(Link::from_rest(0, 30, &rest));
        let mut rng = Rng(0x0bad_5eed_1234_5678);
        let x: Vec<Vec3> = rest.iter().map(|&p| p + rng.vec(0.4 * h)).collect();
        let v: Vec<Vec3> = rest.iter().map(|_| rng.vec(1.0)).collect();
        let external: Vec<Vec3> = rest.iter().map(|_| rng.vec(2.0)).collect();
        // Two pins and uneven masses.
        let w: Vec<f32> = (0..rest.len())
            .map(|i| {
                if i == 0 || i == 12 {
                    0.0
                } else {
                    1.0 + rng.unit()
                }
            })
            .collect();
        let mut streams = ForceStreams::default();
        let cases = [(&grid, &[][..]), (&stray, &[]), (&creased, &external[..])];
        for model in [ClothModel::ChoiKo, ClothModel::Lander] {
            for (case, &(conn, external)) in cases.iter().enumerate() {
                let mut s = SimSettings::default().with_model(model);
                s.choi_ko.bending_rigidity = 1.0;
                s.damping = 0.3;
                let d = Dynamics {
                    settings: &s,
                    connections: conn,
                    inverse_masses: &w,
                    external,
                    workers: crate::sim::workers::Pool::none(),
                };
                let mut want = vec![Vec3::ZERO; x.len()];
                d.accelerations(&x, &v, &mut want);
                let mut got = vec![Vec3::NAN; x.len()];
                d.accelerations_with(&mut streams, &x, &v, &mut got);
                assert_eq!(
                    (got[0], got[12]),
                    (Vec3::ZERO, Vec3::ZERO),
                    "{model:?}, case {case}: pins"
                );
                let err = relative_difference(&want, &got);
                assert!(
                    err < 1e-5,
                    "{model:?}, case {case}: relative difference {err}"
                );
            }
        }
    }
}
