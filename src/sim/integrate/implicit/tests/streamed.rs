//! The set-up formed a stream at a time and the gathered products, against
//! the block list and the scattered product.

use super::*;
use crate::sim::model::streams::ForceStreams;

/// Forms the linearisation of a deformed 12×12 cloth both ways, link by
/// link ([`assemble`], [`k_times`], [`Operator::build`]) and by stream
/// ([`assemble_streamed`]), and checks that the forces, `K w`, the
/// operator's product and the coarse correction agree, for each model and
/// choice of blocks, with a crease spring and a link of an unusual step.
#[test]
fn the_streamed_linearisation_matches_the_block_list() {
    use crate::sim::model::jacobian::assemble_streamed;
    use crate::sim::settings::Type2Jacobian;
    let n = 144;
    let h = 1.0 / 60.0;
    let w: Vec<Vec3> = (0..n)
        .map(|i| Vec3::new((i as f32 * 0.9).sin(), 0.3, (i as f32 * 0.2).cos()))
        .collect();
    let close = |p: Vec3, q: Vec3, scale: f32| (p - q).length() <= 1e-4 * scale;
    let largest = |v: &[Vec3]| v.iter().map(|v| v.length()).fold(0.0, f32::max);
    let cases = [
        (ClothModel::ChoiKo, Type2Jacobian::Axial, true),
        (ClothModel::ChoiKo, Type2Jacobian::Full, false),
        (ClothModel::Lander, Type2Jacobian::Axial, false),
    ];
    for (model, type2, keep_slack) in cases {
        let (mut cloth, v, _) = deformed(12);
        let mut s = SimSettings::default().with_model(model);
        s.choi_ko.bending_rigidity = 0.05;
        s.implicit.type2_jacobian = type2;
        let conn = &mut cloth.connections;
        let bend = conn.bend[40];
        conn.crease.push(Link {
            rest_length: 0.7 * bend.rest_length,
            ..bend
        });
        conn.structural.push(Link {
            a: 3,
            b: 50,
            rest_length: 0.2,
        });
        let (conn, x) = (&cloth.connections, &cloth.particles.positions);
        let inverse_masses = &cloth.particles.inverse_masses;
        let (mut f0, mut blocks) = (vec![Vec3::ZERO; n], Vec::new());
        assemble(&s, conn, keep_slack, x, &v, &mut f0, &mut blocks);
        let mut kw0 = vec![Vec3::ZERO; n];
        k_times(&blocks, &w, &mut kw0);
        let (mut f1, mut kw1, mut others) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n], Vec::new());
        let mut streams = ForceStreams::default();
        let lin = (keep_slack, h, h * h);
        let out = (&mut f1[..], &mut kw1[..]);
        assemble_streamed(&s, conn, lin, x, &v, &w, out, &mut others, &mut streams);
        assert!(others.len() >= 2 && others.len() < 20, "{}", others.len());
        let (fs, ks) = (largest(&f0), largest(&kw0));
        for i in 0..n {
            assert!(
                close(f1[i], f0[i], fs),
                "{model:?} force {i}: {} vs {}",
                f1[i],
                f0[i]
            );
            assert!(
                close(kw1[i], kw0[i], ks),
                "{model:?} Kw {i}: {} vs {}",
                kw1[i],
                kw0[i]
            );
        }
        let (mut c0, mut c1) = (Coarse::default(), Coarse::default());
        assert!(c0.begin(12, inverse_masses, 1.1) && c1.begin(12, inverse_masses, 1.1));
        let (mut op0, mut op1) = (Operator::default(), Operator::default());
        op0.build(12, inverse_masses, 1.1, &blocks, h, h * h, Some(&mut c0));
        let terms = (&others[..], streams.blocks());
        op1.build_with(12, (inverse_masses, 1.1), terms, (h, h * h));
        c1.add_pairs(n, (&others[..], streams.blocks()), (h, h * h));
        assert!(c0.finish() && c1.finish());
        // Kept out of the streams, every streamed block goes to the pair list.
        let mut op2 = Operator::default();
        op2.list_only = true;
        let terms = (&others[..], streams.blocks());
        op2.build_with(0, (inverse_masses, 1.1), terms, (h, h * h));
        let d = soa(n, |i| w[i]);
        let products = [&mut op0, &mut op1, &mut op2].map(|op| {
            let (mut a, y) = (soa(n, |_| Vec3::ZERO), soa(n, |_| Vec3::ZERO));
            op.apply(&d, &mut a);
            (a, y)
        });
        let [(a0, mut y0), (a1, mut y1), (a2, _)] = products;
        c0.add(&d, &mut y0, &op0.free);
        c1.add(&d, &mut y1, &op1.free);
        let all = |s: &Soa| (0..n).map(|i| s.get(i)).collect::<Vec<_>>();
        let (a_scale, y_scale) = (largest(&all(&a0)), largest(&all(&y0)));
        for i in 0..n {
            let (p, q) = (a1.get(i), a0.get(i));
            assert!(close(p, q, a_scale), "{model:?} A d at {i}: {p} vs {q}");
            let p = a2.get(i);
            assert!(
                close(p, q, a_scale),
                "{model:?} A d without a grid at {i}: {p} vs {q}"
            );
            let (p, q) = (y1.get(i), y0.get(i));
            assert!(close(p, q, y_scale), "{model:?} coarse at {i}: {p} vs {q}");
        }
    }
}

/// On a grid 3 particles wide the shear step `columns − 1` is the bend
/// step 2 (and `columns + 1` the diagonal bend's `2·columns − 2`): the
/// second stream of a step goes to the pair list, and the product is still
/// the block list's.
#[test]
fn streams_of_one_step_share_the_operator() {
    use crate::sim::model::jacobian::assemble_streamed;
    let mut cloth = ClothBuilder::new(3, 20).pin(0).pin(2).build().unwrap();
    let n = 60;
    for (i, x) in cloth.particles.positions.iter_mut().enumerate() {
        let s = i as f32;
        *x += 0.02 * Vec3::new((s * 1.3).sin(), (s * 0.7).cos(), (s * 2.1).sin());
    }
    let v: Vec<Vec3> = (0..n)
        .map(|i| Vec3::splat((i as f32 * 0.4).cos()))
        .collect();
    let mut s = SimSettings::default();
    s.choi_ko.bending_rigidity = 0.05;
    let (conn, x) = (&cloth.connections, &cloth.particles.positions);
    let inverse_masses = &cloth.particles.inverse_masses;
    let h = 1.0 / 60.0;
    let (mut f0, mut blocks) = (vec![Vec3::ZERO; n], Vec::new());
    assemble(&s, conn, true, x, &v, &mut f0, &mut blocks);
    let (mut f1, mut kw1, mut others) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n], Vec::new());
    let mut streams = ForceStreams::default();
    let out = (&mut f1[..], &mut kw1[..]);
    assemble_streamed(
        &s,
        conn,
        (true, h, h * h),
        x,
        &v,
        &v,
        out,
        &mut others,
        &mut streams,
    );
    let steps: Vec<usize> = streams.blocks().map(|b| b.delta).collect();
    assert!(steps.iter().filter(|&&d| d == 2).count() == 2, "{steps:?}");
    let (mut op0, mut op1) = (Operator::default(), Operator::default());
    op0.build(3, inverse_masses, 1.1, &blocks, h, h * h, None);
    let terms = (&others[..], streams.blocks());
    op1.build_with(3, (inverse_masses, 1.1), terms, (h, h * h));
    let d = soa(n, wiggle);
    let (mut a0, mut a1) = (soa(n, |_| Vec3::ZERO), soa(n, |_| Vec3::ZERO));
    op0.apply(&d, &mut a0);
    op1.apply(&d, &mut a1);
    let scale = (0..n).map(|i| a0.get(i).length()).fold(0.0, f32::max);
    assert!(scale > 0.0);
    for i in 0..n {
        let (p, q) = (a1.get(i), a0.get(i));
        assert!((p - q).length() <= 1e-5 * scale, "{i}: {p} vs {q}");
    }
}

/// The products by gathered streams (AVX-512 or AVX2, where the CPU has
/// them) and by scattered ones (every other CPU) agree on a pinned,
/// deformed cloth with a pair outside the streams.
#[test]
fn the_gathered_and_scattered_products_agree() {
    let (cloth, _, mut blocks) = deformed(12);
    blocks.push(stray_block(1.0e3));
    let w = &cloth.particles.inverse_masses;
    let h = 1.0 / 60.0;
    let mut op = Operator::default();
    op.build(12, w, 1.1, &blocks, h, h * h, None);
    let d = soa(144, wiggle);
    let (mut a, mut b) = (soa(144, |_| Vec3::ZERO), soa(144, |_| Vec3::ZERO));
    op.apply_portable(&d, &mut b);
    let scale = (0..144).map(|i| b.get(i).length()).fold(0.0, f32::max);
    assert!(scale > 0.0);
    let mut check = |product: &dyn Fn(&mut Operator, &mut Soa)| {
        product(&mut op, &mut a);
        for i in 0..144 {
            let (p, q) = (a.get(i), b.get(i));
            assert!((p - q).length() <= 1e-5 * scale, "{i}: {p} vs {q}");
        }
        assert_eq!(a.get(0), Vec3::ZERO, "a pinned row is filtered");
    };
    check(&|op, out| op.apply(&d, out));
    for level in crate::simd::Level::available() {
        check(&|op, out| op.apply_at(level, &d, out));
    }
}
