//! Free bodies inside the implicit solve: a ball in a hammock, a plate on a
//! tablecloth.
//!
//! A body behind some of the held contacts ([`SolveBody`]) moves within
//! the step with the velocity change `ΔW = (ΔV, Δω)` (m/s, rad/s) that the
//! contacts' impulses and its own engine's acceleration (gravity) give it.
//! Contact `i`, at `rᵢ` (m) from the body's centre of mass, holds its
//! particle's velocity change `Δvᵢ` relative to the surface's,
//! `Δvᵢ − Jᵢ ΔW` with `Jᵢ ΔW = ΔV + Δω × rᵢ`, by the contact's block `Cᵢ`
//! (the normal spring and the holding friction, N·s/m) and gives its
//! particle the impulse `Pᵢ = bᵢ − Cᵢ(Δvᵢ − Jᵢ ΔW)` (N·s). The body takes the
//! opposite, so with `W` its mass and world inertia (6×6):
//!
//! ```text
//! (W + Σ JᵢᵀCᵢJᵢ) ΔW = W (a h, 0) − Σ Jᵢᵀ bᵢ + Σ JᵢᵀCᵢ Δvᵢ
//! ```
//!
//! Writing `K = W + Σ JᵀCJ`, `ΔW` is eliminated: the cloth's operator gains
//! `− Uᵀ K⁻¹ U` (`U Δv = Σ JᵢᵀCᵢ Δvᵢ`), a term of rank 6 per body that
//! keeps it symmetric and positive definite (a Schur complement), and each
//! contact's right-hand side gains `Cᵢ Jᵢ K⁻¹ (W (a h, 0) − Σ Jᵀ b)`. Every
//! contact of a body then sees the body move as one: pressed from all sides
//! in a pocket it does not give way to any of them, while a push from one
//! side moves it and turns it. A product costs one pass over the body's
//! contacts and a 6×6 product.

use std::ops::Range;

use bevy::math::{Mat3, Vec3};

use crate::sim::soa::Soa;

/// A free body behind some of the solve's contacts, moved within the step
/// (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveBody {
    /// Mass, kg (finite and positive).
    pub mass: f32,
    /// Centre of mass at the start of the step (world, m).
    pub centre: Vec3,
    /// Inverse inertia tensor at the start of the step (world,
    /// 1/(kg·m²)); zero for a body that does not turn.
    pub inverse_inertia: Mat3,
    /// The acceleration its own engine gives it over the step besides the
    /// cloth (m/s²): its gravity. The solve counts it so that a body
    /// resting on the cloth stays at rest, and the engine applies it.
    pub acceleration: Vec3,
}

impl SolveBody {
    /// A body of `mass` kg with its centre of mass at `centre` (world, m)
    /// that does not turn and feels no acceleration besides the cloth.
    pub fn new(mass: f32, centre: Vec3) -> Self {
        Self {
            mass,
            centre,
            inverse_inertia: Mat3::ZERO,
            acceleration: Vec3::ZERO,
        }
    }

    /// Whether the solve can move it: a finite, positive mass and a finite
    /// centre, inertia and acceleration.
    pub fn is_usable(&self) -> bool {
        self.mass.is_finite()
            && self.mass > 0.0
            && self.centre.is_finite()
            && self.inverse_inertia.is_finite()
            && self.acceleration.is_finite()
    }
}

/// A twist `(ΔV, Δω)` or a wrench `(f, τ)`, in f64.
type Six = [f64; 6];

/// `ΔV + Δω × r`: the velocity of the point at `r` (m) from the centre.
fn point_velocity(w: &Six, r: Vec3) -> Vec3 {
    let (v, o) = (
        Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32),
        Vec3::new(w[3] as f32, w[4] as f32, w[5] as f32),
    );
    v + o.cross(r)
}

/// `Jᵀ f = (f, r × f)`: the wrench of a force `f` at `r` (m).
fn wrench(f: Vec3, r: Vec3) -> Six {
    let t = r.cross(f);
    [f.x, f.y, f.z, t.x, t.y, t.z].map(f64::from)
}

fn add(a: &mut Six, b: &Six) {
    for (a, b) in a.iter_mut().zip(b) {
        *a += b;
    }
}

fn times(m: &[Six; 6], x: &Six) -> Six {
    m.map(|row| row.iter().zip(x).map(|(a, b)| a * b).sum())
}

/// `s x` for a symmetric 3×3 block `s` stored as xx, yy, zz, xy, xz, yz.
fn sym_times(s: &[f32; 6], x: Vec3) -> Vec3 {
    Vec3::new(
        s[0] * x.x + s[3] * x.y + s[4] * x.z,
        s[3] * x.x + s[1] * x.y + s[5] * x.z,
        s[4] * x.x + s[5] * x.y + s[2] * x.z,
    )
}

/// `X` with `A X = B` for 6×6 matrices, by Gaussian elimination with
/// partial pivoting; `None` when `A` is singular.
fn solve6(mut a: [Six; 6], mut b: [Six; 6]) -> Option<[Six; 6]> {
    for col in 0..6 {
        let pivot = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() <= 1e-12 || a[pivot][col].is_nan() {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in 0..6 {
            if row == col {
                continue;
            }
            let f = a[row][col] / a[col][col];
            if f == 0.0 {
                continue;
            }
            let (pa, pb) = (a[col], b[col]);
            for k in 0..6 {
                a[row][k] -= f * pa[k];
                b[row][k] -= f * pb[k];
            }
        }
    }
    for row in 0..6 {
        let d = a[row][row];
        b[row] = b[row].map(|x| x / d);
    }
    Some(b)
}

/// One contact coupled to a body.
#[derive(Clone, Copy, Debug)]
struct Link {
    particle: u32,
    /// The contact's block `C` (N·s/m), as xx, yy, zz, xy, xz, yz.
    c: [f32; 6],
    /// From the body's centre to the particle, m.
    r: Vec3,
}

/// One body's part of the operator.
#[derive(Clone, Debug)]
struct Term {
    /// Index into the solve's bodies.
    body: u32,
    /// `K⁻¹` (module docs).
    inverse: [Six; 6],
    /// Its contacts in [`Coupling::links`].
    links: Range<usize>,
    /// `K⁻¹ (W (a h, 0) − Σ Jᵀ b)`: its velocity change for a cloth that
    /// does not move relative to the start of the step (m/s, rad/s).
    constant: Six,
    /// Its velocity change in the last solve (m/s, rad/s).
    change: Six,
}

/// The bodies' terms of a step's operator (module docs).
#[derive(Clone, Debug, Default)]
pub(super) struct Coupling {
    terms: Vec<Term>,
    links: Vec<Link>,
}

impl Coupling {
    /// Whether no body is coupled.
    pub(super) fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Forgets every body.
    pub(super) fn clear(&mut self) {
        self.terms.clear();
        self.links.clear();
    }

    /// Sets the terms of `bodies` from their contacts `(body, particle,
    /// C, r, b)` (sorted by body), for a step of `h` s: `C` the contact's
    /// block, `r` (m) from the body's centre to the particle, `b` (N·s) the
    /// contact's own right-hand side. A body whose `K` cannot be inverted
    /// is left out (its contacts then hold as fixed ones do).
    pub(super) fn build(
        &mut self,
        bodies: &[SolveBody],
        contacts: impl Iterator<Item = (u32, u32, [f32; 6], Vec3, Vec3)>,
        h: f32,
    ) {
        self.clear();
        let mut current: Option<(u32, usize, [Six; 6], Six)> = None;
        for (body, particle, c, r, b) in contacts {
            if current.is_some_and(|(k, ..)| k != body) {
                self.close(bodies, current.take(), h);
            }
            let (_, _, g, wb) =
                current.get_or_insert((body, self.links.len(), [[0.0; 6]; 6], [0.0; 6]));
            // G += Jᵀ C J, column by column: J eₖ is the point's velocity
            // for the unit twist eₖ.
            let columns: [Vec3; 6] = std::array::from_fn(|k| {
                let mut e = [0.0; 6];
                e[k] = 1.0;
                point_velocity(&e, r)
            });
            for (k, col) in columns.iter().enumerate() {
                let w = wrench(sym_times(&c, *col), r);
                for (row, x) in w.iter().enumerate() {
                    g[row][k] += x;
                }
            }
            add(wb, &wrench(b, r));
            self.links.push(Link { particle, c, r });
        }
        self.close(bodies, current, h);
    }

    /// Finishes the term of one body: `G = Σ JᵀCJ` and `Σ Jᵀb` over
    /// `links[start..]`.
    fn close(
        &mut self,
        bodies: &[SolveBody],
        current: Option<(u32, usize, [Six; 6], Six)>,
        h: f32,
    ) {
        let Some((body, start, g, wb)) = current else {
            return;
        };
        let links = start..self.links.len();
        let Some(b) = bodies.get(body as usize).filter(|b| b.is_usable()) else {
            self.links.truncate(start);
            return;
        };
        // K⁻¹ = (I + W⁻¹G)⁻¹ W⁻¹, which holds for a body that does not
        // turn (a zero inverse inertia) too.
        let mut winv = [[0.0; 6]; 6];
        let ii = b.inverse_inertia.to_cols_array_2d();
        for k in 0..3 {
            winv[k][k] = 1.0 / b.mass as f64;
            for j in 0..3 {
                winv[3 + k][3 + j] = ii[j][k] as f64;
            }
        }
        let mut a = [[0.0; 6]; 6];
        for row in 0..6 {
            for col in 0..6 {
                a[row][col] = (row == col) as u8 as f64
                    + (0..6).map(|k| winv[row][k] * g[k][col]).sum::<f64>();
            }
        }
        let Some(mut inverse) = solve6(a, winv) else {
            self.links.truncate(start);
            return;
        };
        // Symmetric, as `K⁻¹` is: the mean of it and its transpose.
        let transpose: [Six; 6] =
            std::array::from_fn(|row| std::array::from_fn(|col| inverse[col][row]));
        for (row, other) in inverse.iter_mut().zip(&transpose) {
            for (x, y) in row.iter_mut().zip(other) {
                *x = 0.5 * (*x + y);
            }
        }
        if inverse.iter().flatten().any(|x| !x.is_finite()) {
            self.links.truncate(start);
            return;
        }
        let push = b.mass as f64 * h as f64;
        let a = b.acceleration;
        let own: Six = [
            push * a.x as f64 - wb[0],
            push * a.y as f64 - wb[1],
            push * a.z as f64 - wb[2],
            -wb[3],
            -wb[4],
            -wb[5],
        ];
        let constant = times(&inverse, &own);
        self.terms.push(Term {
            body,
            inverse,
            links,
            constant,
            change: constant,
        });
    }

    /// Each coupled contact's extra right-hand side, `C J K⁻¹ (W (a h, 0)
    /// − Σ Jᵀ b)` (N·s), to `rhs(particle, term)`.
    pub(super) fn rhs(&self, mut rhs: impl FnMut(usize, Vec3)) {
        for term in &self.terms {
            for link in &self.links[term.links.clone()] {
                let u = point_velocity(&term.constant, link.r);
                rhs(link.particle as usize, sym_times(&link.c, u));
            }
        }
    }

    /// `U d = Σ JᵀC d` of one body's contacts.
    fn gather(&self, term: &Term, d: impl Fn(usize) -> Vec3) -> Six {
        let mut g = [0.0; 6];
        for link in &self.links[term.links.clone()] {
            add(
                &mut g,
                &wrench(sym_times(&link.c, d(link.particle as usize)), link.r),
            );
        }
        g
    }

    /// `out −= Uᵀ K⁻¹ U d` (filtered by `free`): the bodies' part of the
    /// operator's product.
    pub(super) fn apply(&self, d: &Soa, out: &mut Soa, free: &[f32]) {
        for term in &self.terms {
            let y = times(&term.inverse, &self.gather(term, |i| d.get(i)));
            for link in &self.links[term.links.clone()] {
                let i = link.particle as usize;
                let t = sym_times(&link.c, point_velocity(&y, link.r));
                out.set(i, out.get(i) - free[i] * t);
            }
        }
    }

    /// After the solve: each body's velocity change for the cloth's `dv`
    /// (m/s), `K⁻¹ (W (a h, 0) − Σ Jᵀ b + U Δv)`.
    pub(super) fn solved(&mut self, dv: impl Fn(usize) -> Vec3) {
        for k in 0..self.terms.len() {
            let u = self.gather(&self.terms[k], &dv);
            let term = &mut self.terms[k];
            let mut change = times(&term.inverse, &u);
            add(&mut change, &term.constant);
            term.change = change;
        }
    }

    /// The velocity change the last solve gave `body`: linear (m/s) and
    /// angular (rad/s); zero for a body not coupled.
    pub(super) fn change(&self, body: u32) -> [Vec3; 2] {
        self.terms
            .iter()
            .find(|t| t.body == body)
            .map_or([Vec3::ZERO; 2], |t| {
                let c = t.change.map(|x| x as f32);
                [Vec3::new(c[0], c[1], c[2]), Vec3::new(c[3], c[4], c[5])]
            })
    }

    /// The velocity change (m/s) the last solve gave the surface of `body`
    /// at `r` (m) from its centre; zero for a body not coupled.
    pub(super) fn surface_change(&self, body: u32, r: Vec3) -> Vec3 {
        self.terms
            .iter()
            .find(|t| t.body == body)
            .map_or(Vec3::ZERO, |t| point_velocity(&t.change, r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_six_by_six_solve_inverts_and_refuses_a_singular_matrix() {
        let mut a: [Six; 6] = std::array::from_fn(|k| {
            std::array::from_fn(|j| {
                if k == j {
                    4.0
                } else {
                    1.0 / (1.0 + (k + j) as f64)
                }
            })
        });
        let id: [Six; 6] = std::array::from_fn(|k| std::array::from_fn(|j| (k == j) as u8 as f64));
        let inv = solve6(a, id).unwrap();
        for row in 0..6 {
            for col in 0..6 {
                let p: f64 = (0..6).map(|k| a[row][k] * inv[k][col]).sum();
                assert!((p - id[row][col]).abs() < 1e-12, "{row} {col} {p}");
            }
        }
        a[5] = a[4];
        assert!(solve6(a, id).is_none());
    }
}
