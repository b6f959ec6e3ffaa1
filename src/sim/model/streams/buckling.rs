//! The Type 2 (buckling) streams: lengths, the `g` table and forces in
//! one AVX-512 pass where the CPU has it (`simd::buckling`), else in
//! three portable loops.

use super::{Soa, Stream, length_squared, pairs, window};
use crate::sim::model::choi_ko::{BucklingTable, MIN_LENGTH};
use crate::simd;

/// The Type 2 law's constants: the `g` table, `k_b` (N·m²) and `c_b` (N/m).
#[derive(Clone, Copy)]
pub(super) struct Buckling<'a> {
    pub table: &'a BucklingTable,
    pub kb: f32,
    pub cb: f32,
}

/// A Type 2 stream's pair forces, as [`pairs`] writes them: in one
/// AVX-512 pass where the CPU has it (`simd::buckling`), else in three
/// passes with `g` and `len` as scratch of the stream's slots.
#[inline(always)]
pub(super) fn buckling_pairs(
    s: &Stream,
    x: &Soa,
    pair: &mut Soa,
    law: Buckling,
    g: &mut [f32],
    len: &mut [f32],
) {
    if !one_pass(simd::level(), s, x, pair, law) {
        buckling_pairs_portable(s, x, pair, law, g, len);
    }
}

/// [`buckling_pairs`] by the one-pass kernel of `level`, if it has one.
fn one_pass(level: simd::Level, s: &Stream, x: &Soa, pair: &mut Soa, law: Buckling) -> bool {
    let m = s.slots();
    let (a, b) = s.ends();
    let [px, py, pz] = &mut pair.0;
    let slots = s.delta..s.delta + m;
    let out = [
        &mut px[slots.clone()],
        &mut py[slots.clone()],
        &mut pz[slots],
    ];
    let links = simd::buckling::Links {
        a: window(x, &a),
        b: window(x, &b),
        rest: &s.rest[..m],
        inv_rest: &s.inv_rest[..m],
    };
    let law = simd::buckling::Law {
        pieces: law.table.pieces(),
        kb: law.kb,
        cb: law.cb,
        min_length: MIN_LENGTH,
    };
    simd::buckling::pairs(level, law, links, out)
}

/// [`buckling_pairs`] in three loops: lengths and ratios, the table
/// lookups (which do not vectorise, so get a loop of their own), forces.
#[inline(always)]
fn buckling_pairs_portable(
    s: &Stream,
    x: &Soa,
    pair: &mut Soa,
    Buckling { table, kb, cb }: Buckling,
    g: &mut [f32],
    len: &mut [f32],
) {
    let m = s.slots();
    table_values(s, x, table, &mut g[..m], &mut len[..m]);
    let per_slot = [&g[..m], &len[..m], &s.inv_rest[..m]];
    // Buckling reads no velocities: hand it the positions.
    pairs(s, x, x, pair, per_slot, |d, _, r, [g, len, inv]| {
        buckling(d, r, len, inv, g, kb, cb)
    });
}

/// `ℓ` (m) and `g(ℓ/L)` of every slot of a Type 2 stream into `len` and
/// `g` (garbage in empty slots, which [`buckling`] ignores).
#[inline(always)]
fn table_values(s: &Stream, x: &Soa, table: &BucklingTable, g: &mut [f32], len: &mut [f32]) {
    let m = s.slots();
    let (a, b) = s.ends();
    let ([xa, ya, za], [xb, yb, zb]) = (window(x, &a), window(x, &b));
    let (g, len, inv) = (&mut g[..m], &mut len[..m], &s.inv_rest[..m]);
    // Lengths and ratios first, in SIMD ...
    for i in 0..m {
        let d = [xb[i] - xa[i], yb[i] - ya[i], zb[i] - za[i]];
        len[i] = length_squared(d).sqrt();
        g[i] = len[i] * inv[i];
    }
    // ... then the lookups.
    table.g_in_place(g);
}

/// Type 2, per metre of `d`: `f_b*(ℓ)/ℓ` while `ℓ < L` ([`type2_magnitude`]),
/// given `ℓ = |d|` (m), `1/L` (1/m) and `g = g(ℓ/L)` from the table.
///
/// [`type2_magnitude`]: crate::sim::model::choi_ko::type2_magnitude
#[inline(always)]
fn buckling(d: [f32; 3], rest: f32, len: f32, inv_rest: f32, g: f32, kb: f32, cb: f32) -> f32 {
    let len2 = length_squared(d);
    let fb = kb * (inv_rest * inv_rest) * g;
    let linear = cb * (len - rest);
    let mag = if linear > fb { linear } else { fb };
    // An empty slot's NaN rest length fails the first test.
    let compressed = len2 < rest * rest && len2 >= MIN_LENGTH * MIN_LENGTH;
    if compressed { mag / len } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::super::{FamilyStreams, LANES, scatter};
    use super::*;
    use crate::sim::connections::Link;
    use crate::sim::model::choi_ko::{BUCKLING_TABLE, type2_magnitude};
    use bevy::math::Vec3;

    /// A 20×20 grid's ±2 links, the top half stretched and the bottom half
    /// squeezed to 80–100 % with jitter: some sixteen-slot chunks have no
    /// compressed link, others a mix.
    fn squeezed_grid() -> (Vec<Vec3>, Vec<Link>) {
        let (cols, h) = (20, 0.05);
        let mut seed = 12345_u32;
        let mut jitter = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32
        };
        let x = (0..cols * cols)
            .map(|i| {
                let (c, r) = ((i % cols) as f32, (i / cols) as f32);
                let squeeze = if r < 10.0 { 1.1 } else { 0.8 + 0.2 * jitter() };
                Vec3::new(c * h * squeeze, r * h * squeeze, 0.01 * jitter())
            })
            .collect();
        let mut links = Vec::new();
        for a in 0..cols * cols {
            let link = |b: usize| Link {
                a: a as u32,
                b: b as u32,
                rest_length: 2.0 * h,
            };
            if a % cols + 2 < cols {
                links.push(link(a + 2));
            }
            if a / cols + 2 < cols {
                links.push(link(a + 2 * cols));
            }
        }
        (x, links)
    }

    #[test]
    fn type2_stream_forces_match_the_link_by_link_magnitudes() {
        let (x, links) = squeezed_grid();
        let mut family = FamilyStreams::default();
        family.sync(&links, x.len(), None);
        assert_eq!(family.streams.len(), 2, "one stream per step");
        let span = family.streams.iter().map(|s| s.lo + s.padded_span()).max();
        let mut xs = Soa::default();
        xs.resize(span.unwrap_or(0));
        scatter(&x, &mut xs);
        let (kb, cb) = (1e-3, 50.0);
        let law = Buckling {
            table: &BUCKLING_TABLE,
            kb,
            cb,
        };
        let (mut compressed, mut chunks_without) = (0, 0);
        for s in &family.streams {
            let m = s.slots();
            let (mut g, mut len) = (vec![0.0; m], vec![0.0; m]);
            let mut portable = s.pair.clone();
            buckling_pairs_portable(s, &xs, &mut portable, law, &mut g, &mut len);
            for i in 0..m {
                let (a, b) = (s.lo + i, s.lo + i + s.delta);
                let got = portable.get(s.delta + i);
                let want = if s.rest[i].is_nan() {
                    Vec3::ZERO
                } else {
                    let d = x[b] - x[a];
                    let (mag, _) = type2_magnitude(&BUCKLING_TABLE, d.length(), s.rest[i], kb, cb);
                    compressed += usize::from(mag != 0.0);
                    d * (mag / d.length())
                };
                let err = (got - want).length() / want.length().max(1e-6);
                assert!(err < 1e-5, "slot {i} of δ = {}: {got} vs {want}", s.delta);
            }
            chunks_without += (0..m / LANES)
                .filter(|c| (0..LANES).all(|j| portable.get(s.delta + c * LANES + j) == Vec3::ZERO))
                .count();
            for level in simd::Level::available() {
                let mut one = s.pair.clone();
                if !one_pass(level, s, &xs, &mut one, law) {
                    continue;
                }
                // The same operations: the same values (`==` takes −0 for 0).
                for (c, (p, q)) in one.0.iter().zip(&portable.0).enumerate() {
                    assert!(p.iter().zip(q).all(|(p, q)| p == q), "component {c}");
                }
            }
        }
        assert!(
            compressed > 100 && chunks_without > 3,
            "{compressed} compressed, {chunks_without} chunks without"
        );
    }
}
