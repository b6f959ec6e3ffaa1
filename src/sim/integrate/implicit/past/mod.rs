//! The solve's starting guess from the last steps' solutions.
//!
//! A cloth in motion repeats much of its last steps' motion: it keeps
//! falling, keeps swinging, and a fold that flaps from one step to the
//! next flaps back. The velocity changes `Δv` (m/s) of the last few steps
//! span much of this step's, so the solve starts from the combination of
//! them closest to its solution in the energy norm of `A`:
//! `Δv₀ = W c` with `(WᵀAW) c = Wᵀb`, the columns of `W` the kept
//! solutions (a Galerkin projection, as in Fischer's projection method
//! for successive right-hand sides). Among the combinations it is the one
//! with the least error `(Δv − Δv₀)ᵀA(Δv − Δv₀)`, so it is never worse in
//! that norm than starting from zero or from the last solution alone.
//! It costs one product with `A` per kept solution. A conjugate gradient
//! from that guess may then also keep its directions `A`-orthogonal to the
//! kept solutions ([`Past::deflate`]), so that it never searches again
//! along what the guess solved. A cloth in several pieces takes the
//! combination with coefficients of its own on each piece ([`pieces`]).

use super::operator::{Operator, Soa, dot};
use crate::sim::settings::MAX_PAST_SOLUTIONS;
use pieces::Pieces;

mod pieces;

/// Most solutions kept.
const MOST: usize = MAX_PAST_SOLUTIONS as usize;

/// A kept solution whose part outside the span of those before it has
/// less than this share of its energy (dimensionless) adds nothing the
/// others do not: it is left out of the combination, which keeps the
/// small system well conditioned.
const INDEPENDENT: f64 = 1e-6;

/// Short solves in a row (each under a quarter of the cap) after which
/// the guess is no longer made: a solve is often short because it started
/// from the guess, and the next one, without it, would be long again.
const EASY_RUN: u32 = 30;

/// The last steps' solutions `Δv` (m/s), the newest overwriting the oldest,
/// and what the last guess made of them.
#[derive(Clone, Debug, Default)]
pub(super) struct Past {
    /// Room for the solutions, all made at the first one so that later
    /// steps allocate nothing; the first `filled` hold solutions.
    slots: Vec<Soa>,
    /// Their products with the last guess's `A` (N·s), as many slots.
    images: Vec<Soa>,
    /// `WᵀAW` of the last guess (kg·m²/s²).
    gram: [[f64; MOST]; MOST],
    filled: usize,
    /// Where the next one goes once every slot is filled.
    next: usize,
    /// Whether the solves are hard enough for the guess to pay
    /// ([`remember`](Self::remember)).
    hard: bool,
    /// Short solves since the last that was not.
    easy: u32,
    /// The cloth's pieces, and their small systems.
    pieces: Pieces,
    /// Whether the last guess combined the solutions piece by piece.
    by_piece: bool,
}

impl Past {
    /// Forgets every solution (a new particle count, a reset).
    pub fn clear(&mut self) {
        self.filled = 0;
        self.next = 0;
        self.hard = false;
        self.easy = 0;
        self.by_piece = false;
    }

    /// Whether the next solve is to start from the guess: the solves are
    /// hard and a solution is kept.
    pub fn wanted(&self) -> bool {
        self.hard && self.filled > 0
    }

    /// Keeps `dv`, the solution of a solve that took `iterations` of at
    /// most `cap`, among the last `keep` solutions (at most
    /// [`MAX_PAST_SOLUTIONS`]); a different `keep` than before starts
    /// over.
    ///
    /// The guess costs a product with `A` per kept solution: next to a
    /// solve of a few tens of iterations, about as much as it saves (on a
    /// 256×256 sheet falling from two corners, whose solves take 20 to 76
    /// iterations, it saves 2 a frame and costs 5 ms). So it is made
    /// only once a solve has taken four fifths of the cap, and until
    /// [`EASY_RUN`] solves in a row have taken less than a quarter of it.
    pub fn remember(&mut self, dv: &Soa, keep: usize, (iterations, cap): (u32, u32)) {
        let keep = keep.min(MOST);
        if self.slots.len() != keep {
            self.clear();
            self.slots.resize_with(keep, Soa::default);
            self.images.resize_with(keep, Soa::default);
        }
        let n = dv.0[0].len();
        if self.filled > 0 && self.slots[0].0[0].len() != n {
            self.clear();
        }
        if iterations < cap / 4 {
            self.easy = self.easy.saturating_add(1);
            if self.easy >= EASY_RUN {
                self.hard = false;
            }
        } else {
            self.easy = 0;
            if iterations >= (cap * 4).div_ceil(5) {
                self.hard = true;
            }
        }
        if keep == 0 {
            return;
        }
        if self.filled == 0 {
            for slot in self.slots.iter_mut().chain(&mut self.images) {
                slot.resize(n);
            }
            self.pieces.reserve(n);
        }
        self.slots[self.next].copy_from(dv);
        self.filled = (self.filled + 1).min(keep);
        self.next = (self.next + 1) % keep;
    }

    /// Groups the cloth's `n` particles by the pieces `links` (particle
    /// pairs: every pair `A` couples) join, for a guess
    /// [`by_piece`](Self::guess); kept while the links' `generation` and
    /// `n` stay the same.
    pub fn find_pieces(
        &mut self,
        links: impl Iterator<Item = (u32, u32)>,
        n: usize,
        generation: Option<u64>,
    ) {
        self.pieces.find(links, n, generation);
    }

    /// Writes into `dv` the combination of the kept solutions closest to
    /// the solution of `A Δv = b` in `A`'s energy norm, each first filtered
    /// by the step's free particles; keeps their products with `A` for
    /// [`deflate`](Self::deflate). With `by_piece`, and the cloth in
    /// several pieces ([`find_pieces`](Self::find_pieces)), each piece
    /// takes a combination of its own. False, with `dv` untouched, when
    /// none is kept, their length is not `b`'s, or none adds anything.
    pub fn guess(&mut self, op: &mut Operator, b: &Soa, dv: &mut Soa, by_piece: bool) -> bool {
        let k = self.filled;
        let n = b.0[0].len();
        let (solutions, images) = (&mut self.slots[..k], &mut self.images[..k]);
        self.by_piece = false;
        if k == 0 || solutions.iter().any(|w| w.0[0].len() != n) {
            return false;
        }
        for (w, image) in solutions.iter_mut().zip(images.iter_mut()) {
            w.filter(&op.free);
            op.apply(w, image);
        }
        if by_piece && self.pieces.count(n) > 1 {
            self.by_piece = self.pieces.guess(solutions, images, b, dv);
            return self.by_piece;
        }
        // The Gram matrix WᵀAW and Wᵀb, in f64.
        let mut wb = [0.0_f64; MOST];
        for j in 0..k {
            for (i, w) in solutions.iter().enumerate() {
                self.gram[i][j] = dot(w, &images[j]);
            }
            wb[j] = dot(&solutions[j], b);
        }
        let Some(c) = solve_gram(&self.gram, &wb, k) else {
            return false;
        };
        dv.zero();
        add_combination(dv.0.each_mut().map(|c| &mut c[..]), 0, solutions, &c, 1.0);
        true
    }

    /// Takes from `y` (m/s) its part along the kept solutions `W` in
    /// `A`'s energy norm, `y −= W (WᵀAW)⁻¹ (AW)ᵀ y`, with the `A` and
    /// solutions of the last [`guess`](Self::guess): a conjugate gradient
    /// that starts from that guess and takes its directions so deflated
    /// never searches again along what the guess already solved (Saad,
    /// Yeung, Erhel and Guyomarc'h's deflated conjugate gradient). `k` dot
    /// products (by `dot`, so that a solve that sums in halves sums these
    /// so too) and `k` updates; piece by piece after a guess that was.
    pub fn deflate(&mut self, y: &mut Soa, dot: impl Fn(&Soa, &Soa) -> f64) {
        let k = self.filled;
        if self.by_piece {
            self.pieces.deflate(&self.slots[..k], &self.images[..k], y);
            return;
        }
        let mut ay = [0.0_f64; MOST];
        for (ay, image) in ay.iter_mut().zip(self.images()) {
            *ay = dot(image, y);
        }
        self.take_along(&ay[..k], y.0.each_mut().map(|c| &mut c[..]), 0);
    }

    /// The kept solutions' products with `A` (N·s), as many as are kept,
    /// for a split solve's [`take_along`](Self::take_along) (after a guess
    /// of the whole cloth, not [`by_piece`](Self::guess)).
    pub fn images(&self) -> &[Soa] {
        debug_assert!(!self.by_piece, "a split solve deflates the whole cloth");
        &self.images[..self.filled]
    }

    /// The second half of [`deflate`](Self::deflate) on the particles
    /// from `start` on that `y` holds: `y −= W (WᵀAW)⁻¹ ay`, `ay` the
    /// products `(AW)ᵀy` (kg·m²/s²) summed over every particle, one per
    /// kept solution as [`images`](Self::images) lists them.
    pub fn take_along(&self, ay: &[f64], y: [&mut [f32]; 3], start: usize) {
        let k = self.filled.min(ay.len());
        let mut b = [0.0_f64; MOST];
        b[..k].copy_from_slice(&ay[..k]);
        if let Some(mu) = solve_gram(&self.gram, &b, k) {
            add_combination(y, start, &self.slots[..k], &mu, -1.0);
        }
    }
}

/// `out += sign · Σ c_j w_j` over `out`'s particles, the first of them
/// particle `start` of the `w_j`.
fn add_combination(mut out: [&mut [f32]; 3], start: usize, w: &[Soa], c: &[f64; MOST], sign: f32) {
    for (w, &c) in w.iter().zip(c) {
        let c = sign * c as f32;
        if c == 0.0 {
            continue;
        }
        for (x, w) in out.iter_mut().zip(&w.0) {
            let w = &w[start..start + x.len()];
            for (x, &w) in x.iter_mut().zip(w) {
                *x += c * w;
            }
        }
    }
}

/// Solves `G c = b` for the first `k` rows and columns of the symmetric
/// `G` by Cholesky, leaving out (with `c = 0`) each column that is nearly
/// a combination of those before it ([`INDEPENDENT`]). `None` if none is
/// left or the result is not finite.
fn solve_gram(g: &[[f64; MOST]; MOST], b: &[f64; MOST], k: usize) -> Option<[f64; MOST]> {
    let sym = |i: usize, j: usize| 0.5 * (g[i][j] + g[j][i]);
    let mut l = [[0.0_f64; MOST]; MOST];
    let mut kept = [false; MOST];
    for j in 0..k {
        let diagonal = sym(j, j);
        let pivot = diagonal - (0..j).map(|m| l[j][m] * l[j][m]).sum::<f64>();
        if !(diagonal > 0.0 && pivot > INDEPENDENT * diagonal && pivot.is_finite()) {
            continue;
        }
        kept[j] = true;
        l[j][j] = pivot.sqrt();
        for i in j + 1..k {
            let s = sym(i, j) - (0..j).map(|m| l[i][m] * l[j][m]).sum::<f64>();
            l[i][j] = s / l[j][j];
        }
    }
    if !kept.iter().any(|&k| k) {
        return None;
    }
    // L y = b, then Lᵀ c = y, over the kept columns (a left-out column's
    // entries of L are zero, and its y and c stay zero).
    let mut y = [0.0_f64; MOST];
    for i in (0..k).filter(|&i| kept[i]) {
        y[i] = (b[i] - (0..i).map(|m| l[i][m] * y[m]).sum::<f64>()) / l[i][i];
    }
    let mut c = [0.0_f64; MOST];
    for i in (0..k).rev().filter(|&i| kept[i]) {
        c[i] = (y[i] - (i + 1..k).map(|m| l[m][i] * c[m]).sum::<f64>()) / l[i][i];
    }
    c.iter().all(|c| c.is_finite()).then_some(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gram_solve_leaves_out_dependent_columns() {
        // Columns 0 and 2 equal: the second is left out, and c solves the rest.
        let mut g = [[0.0; MOST]; MOST];
        let rows = [[4.0, 1.0, 4.0], [1.0, 3.0, 1.0], [4.0, 1.0, 4.0]];
        for (i, row) in rows.iter().enumerate() {
            g[i][..3].copy_from_slice(row);
        }
        let mut b = [0.0; MOST];
        b[..3].copy_from_slice(&[6.0, 7.0, 6.0]);
        let c = solve_gram(&g, &b, 3).unwrap();
        assert!(
            (c[0] - 1.0).abs() < 1e-12 && (c[1] - 2.0).abs() < 1e-12,
            "{c:?}"
        );
        assert_eq!(c[2], 0.0);
        // Nothing independent: no guess.
        assert!(solve_gram(&[[0.0; MOST]; MOST], &b, 2).is_none());
    }
}
