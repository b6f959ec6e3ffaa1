//! Building the operator `A = M(1 + αc) − αD − βK` from the Jacobian's
//! blocks: the particle steps its streams hold, the blocks copied stream
//! by stream or placed one by one, and the inverted block diagonal (the
//! preconditioner).

use std::ops::Range;

#[cfg(test)]
use super::super::coarse::Coarse;
use super::{LANES, Operator, RankBlocks, SymBlocks, push_other, rank_block, sym_inverse, sym_of};
use crate::sim::model::jacobian::Block;
use crate::sim::model::streams::StreamBlocks;

/// The index steps `q − p` that at least a quarter of `n` particles'
/// pairs share, in `blocks` and in the force streams' blocks `streamed`,
/// most common first, at most 8: the streams of a cloth that is not a
/// grid. A mesh whose particles are numbered row by row (a subdivided
/// plane, a torn grid) has a grid's few steps; its other pairs, and every
/// pair of a mesh numbered otherwise, go through the pair list. The choice
/// only sets how `A` is stored: its products differ in rounding only.
fn common_steps<'a>(
    n: usize,
    blocks: &[Block],
    streamed: impl Iterator<Item = StreamBlocks<'a>>,
) -> Vec<usize> {
    let mut steps: Vec<(usize, usize)> = blocks
        .iter()
        .map(|b| (b.a.abs_diff(b.b) as usize, 1))
        .collect();
    steps.extend(streamed.map(|src| {
        let links = src
            .t
            .iter()
            .zip(src.s)
            .filter(|&(&t, &s)| t != 0.0 || s != 0.0);
        (src.delta, links.count())
    }));
    steps.retain(|&(d, _)| d > 0 && d < n);
    steps.sort_unstable();
    let mut counted: Vec<(usize, usize)> = Vec::new();
    for (d, links) in steps {
        match counted.last_mut() {
            Some((last, count)) if *last == d => *count += links,
            _ => counted.push((d, links)),
        }
    }
    counted.retain(|&(_, count)| 4 * count >= n);
    counted.sort_unstable_by(|p, q| q.1.cmp(&p.1).then(p.0.cmp(&q.0)));
    counted.truncate(8);
    counted.into_iter().map(|(d, _)| d).collect()
}

impl Operator {
    /// Builds `A` from the Jacobian `blocks` as `C = αD + βK`, the mass
    /// scale `1 + αc` and the inverse masses (1/kg, 0 pins); feeds every
    /// pair to `coarse` when given. `columns` is the grid's row length (0
    /// for none).
    #[cfg(test)]
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        &mut self,
        columns: usize,
        inverse_masses: &[f32],
        mass_scale: f32,
        blocks: &[Block],
        alpha: f32,
        beta: f32,
        coarse: Option<&mut Coarse>,
    ) {
        let masses = (inverse_masses, mass_scale);
        self.build_with(columns, masses, (blocks, std::iter::empty()), (alpha, beta));
        if let Some(coarse) = coarse {
            let n = inverse_masses.len();
            coarse.add_pairs(n, (blocks, std::iter::empty()), (alpha, beta));
        }
    }

    /// Builds `A` from the Jacobian `blocks` (as `C = αD + βK`) and from
    /// blocks `C` already formed by stream (`streamed`, from
    /// [`ForceStreams::blocks`](crate::sim::model::streams::ForceStreams::blocks)),
    /// given the inverse masses (1/kg, 0 pins) and the mass scale `1 + αc`.
    /// `columns` is the grid's row length (0 for none). The coarse grid
    /// takes the same pairs separately ([`Coarse::add_pairs`]).
    pub fn build_with<'a>(
        &mut self,
        columns: usize,
        (inverse_masses, mass_scale): (&[f32], f32),
        (blocks, streamed): (&[Block], impl Iterator<Item = StreamBlocks<'a>> + Clone),
        (alpha, beta): (f32, f32),
    ) {
        let n = inverse_masses.len();
        self.choose_steps(columns, n, blocks, streamed.clone());
        let mut diag = std::mem::take(&mut self.precond);
        diag.reset(n);
        self.others.clear();
        self.copy_streams(n, streamed, &mut diag);
        self.place_blocks(blocks, (alpha, beta), &mut diag);
        self.add_stream_diagonal(n, &mut diag);
        self.invert_diagonal(inverse_masses, mass_scale, &mut diag);
        self.precond = diag;
        self.tmp.resize(n);
    }

    /// Stage 1 of [`build_with`](Self::build_with): the particle steps the
    /// streams hold (a grid's neighbours along and across its `columns`,
    /// or a mesh's most common steps), the padding, and the streams sized
    /// for `n` particles.
    fn choose_steps<'a>(
        &mut self,
        columns: usize,
        n: usize,
        blocks: &[Block],
        streamed: impl Iterator<Item = StreamBlocks<'a>> + Clone,
    ) {
        self.deltas.clear();
        if columns > 0 {
            let c = columns;
            for d in [1, 2, c - 1, c, c + 1, 2 * c - 2, 2 * c, 2 * c + 2] {
                if d > 0 && d < n && !self.deltas.contains(&d) {
                    self.deltas.push(d);
                }
            }
        } else if !self.list_only {
            // Chosen again when the particles or the force streams change
            // (a tear), not as a buckling link's block comes and goes.
            let key = (n, streamed.clone().count());
            if self.common.0 != key {
                self.common = (key, common_steps(n, blocks, streamed));
            }
            self.deltas.extend_from_slice(&self.common.1);
        }
        self.pad = self
            .deltas
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .next_multiple_of(LANES);
        let pad = self.pad;
        self.streams
            .resize_with(self.deltas.len(), RankBlocks::default);
        // The streams are zeroed where no stream of blocks is copied (below):
        // zeroing them all first, then copying, took ~25 µs a 64×64 step.
        for s in &mut self.streams {
            s.resize(pad + n + LANES);
        }
        for c in &mut self.padded.0 {
            c.clear();
            c.resize(n + 2 * pad + LANES, 0.0);
        }
    }

    /// Stage 2: blocks formed by stream first, each filling an empty stream
    /// of the operator (a second one with the same step goes to `others`,
    /// its blocks added to `diag`); the rest of every stream zeroed.
    fn copy_streams<'a>(
        &mut self,
        n: usize,
        streamed: impl Iterator<Item = StreamBlocks<'a>>,
        diag: &mut SymBlocks,
    ) {
        let pad = self.pad;
        let mut filled: [Option<Range<usize>>; 8] = Default::default();
        for src in streamed {
            // Slots past the last particle hold no link.
            let m = src.t.len().min(n.saturating_sub(src.lo + src.delta));
            let block = |i: usize| sym_of(src.t[i], src.s[i], src.u.map(|u| u[i]));
            let k = self.deltas.iter().position(|&d| d == src.delta);
            match k.filter(|&k| filled[k].is_none()) {
                Some(k) => {
                    let own = &mut self.streams[k];
                    let at = pad + src.lo..pad + src.lo + m;
                    filled[k] = Some(at.clone());
                    own.t[at.clone()].copy_from_slice(&src.t[..m]);
                    own.s[at.clone()].copy_from_slice(&src.s[..m]);
                    for (own, u) in own.u.iter_mut().zip(src.u) {
                        own[at.clone()].copy_from_slice(&u[..m]);
                    }
                }
                None => {
                    for i in (0..m).filter(|&i| src.t[i] != 0.0 || src.s[i] != 0.0) {
                        let (p, q) = (src.lo + i, src.lo + i + src.delta);
                        push_other(&mut self.others, diag, (p, q), block(i));
                    }
                }
            }
        }
        for (s, filled) in self.streams.iter_mut().zip(filled) {
            s.zero_outside(filled.unwrap_or(0..0));
        }
    }

    /// Stage 3: the listed `blocks` (ranked with Rayleigh damping `alpha`,
    /// `beta`) into a free slot of the stream of their step, or into
    /// `others` (added to `diag`); which streams have transverse terms.
    fn place_blocks(&mut self, blocks: &[Block], (alpha, beta): (f32, f32), diag: &mut SymBlocks) {
        let pad = self.pad;
        for blk in blocks {
            let Some((t, s, u)) = rank_block(blk, alpha, beta) else {
                continue;
            };
            let c = sym_of(t, s, u);
            let (p, q) = (blk.a.min(blk.b) as usize, blk.a.max(blk.b) as usize);
            let k = self.deltas.iter().position(|&d| d == q - p);
            match k.filter(|&k| self.streams[k].is_free(pad + p)) {
                Some(k) => self.streams[k].set(pad + p, t, s, u),
                None => push_other(&mut self.others, diag, (p, q), c),
            }
        }
        for s in &mut self.streams {
            s.transverse = s.t.iter().any(|&t| t != 0.0);
        }
    }

    /// Stage 4: the streams' blocks on the diagonal, both ends, a stream at
    /// a time, then the extra diagonal blocks.
    fn add_stream_diagonal(&self, n: usize, diag: &mut SymBlocks) {
        let pad = self.pad;
        for (&delta, s) in self.deltas.iter().zip(&self.streams) {
            let m = n - delta;
            let (t, sc) = (&s.t[pad..pad + m], &s.s[pad..pad + m]);
            let [ux, uy, uz] = s.u.each_ref().map(|u| &u[pad..pad + m]);
            for end in [0, delta] {
                let [dxx, dyy, dzz, dxy, dxz, dyz] =
                    diag.0.each_mut().map(|c| &mut c[end..end + m]);
                for i in 0..m {
                    let c = sym_of(t[i], sc[i], [ux[i], uy[i], uz[i]]);
                    dxx[i] += c[0];
                    dyy[i] += c[1];
                    dzz[i] += c[2];
                    dxy[i] += c[3];
                    dxz[i] += c[4];
                    dyz[i] += c[5];
                }
            }
        }
        for &(i, c) in &self.extra {
            if (i as usize) < n {
                diag.add(i as usize, &c);
            }
        }
    }

    /// Stage 5: the masses (`mass_scale / w` for the inverse masses `w`,
    /// 1/kg) added to the diagonal, which becomes its inverse (identity on
    /// the pinned rows): the preconditioner.
    fn invert_diagonal(&mut self, inverse_masses: &[f32], mass_scale: f32, diag: &mut SymBlocks) {
        let n = inverse_masses.len();
        self.mass.resize(n, 0.0);
        self.free.resize(n, 0.0);
        for (i, &w) in inverse_masses.iter().enumerate() {
            let free = w != 0.0;
            let m = if free { mass_scale / w } else { 0.0 };
            self.mass[i] = m;
            self.free[i] = if free { 1.0 } else { 0.0 };
            let mut s = diag.get(i);
            for d in &mut s[..3] {
                *d += m;
            }
            let inv = if free {
                sym_inverse(s)
            } else {
                [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
            };
            for (c, v) in diag.0.iter_mut().zip(inv) {
                c[i] = v;
            }
        }
    }
}
