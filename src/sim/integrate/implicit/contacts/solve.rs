//! A step's contacts in the solve: which it holds and how
//! ([`begin`](ContactBuffers::begin)), the terms it gives the solve
//! ([`emit`](ContactBuffers::emit)), their revision between passes
//! ([`revise`](ContactBuffers::revise)) and what is kept after it
//! ([`finish`](ContactBuffers::finish)).

use bevy::math::Vec3;

use super::*;

impl ContactBuffers {
    /// Decides how this step holds its contacts, once the forces at the
    /// start of the step are known (`force`, N, total on each particle; `x`,
    /// `v` the positions and velocities, m and m/s). `D = scale ·
    /// displacement` is what the step moves each particle besides `γ Δv`
    /// (m; backward Euler: `h v₀`); `α`, `β` as in the solve, `β = αγ`; `h`
    /// the step (s). Returns whether any contact is held;
    /// [`emit`](Self::emit) gives the solve its terms.
    pub(in crate::sim::integrate::implicit) fn begin(
        &mut self,
        inverse_masses: &[f32],
        force: &[Vec3],
        (x, v): (&[Vec3], &[Vec3]),
        (displacement, scale): (&[Vec3], f32),
        (alpha, beta, h): (f32, f32, f32),
    ) -> bool {
        let n = inverse_masses.len();
        self.held.clear();
        self.impulses.clear();
        self.changes.clear();
        self.separations.clear();
        self.factors = (alpha, beta, h);
        if self.list.is_empty() {
            self.clear();
            return false;
        }
        self.hold.resize(n, Hold::Free);
        self.load.resize(n, [0.0; 2]);
        self.count_touches(n);
        self.press_sheets();
        let gamma = beta / alpha;
        for (index, c) in self.list.iter().enumerate() {
            let p = c.particle as usize;
            let w = match inverse_masses.get(p) {
                Some(&w) if w > 0.0 => w,
                _ => continue,
            };
            let d = scale * displacement[p];
            let pressure = -force[p].dot(c.normal);
            let body = self
                .bodies
                .get(c.body as usize)
                .filter(|b| b.is_usable())
                .map(|b| (c.body, x[p] - b.centre, b));
            let reach = -c.gap - (d - h * c.velocity).dot(c.normal);
            // Outside and staying outside without the contact (its motion
            // and the forces carry it clear): not held. Unless it lies on a
            // fixed surface under a body, whose weight presses it within
            // the solve.
            let under_body = body.is_none() && self.touches[p].body && c.gap <= SHEET_GAP;
            if c.gap >= 0.0 && -reach - h * h * w * pressure >= 0.0 && !under_body {
                continue;
            }
            let relative = v[p] - c.velocity;
            let along = relative - relative.dot(c.normal) * c.normal;
            let speed = along.length();
            let load = self.load[p][c.edge as usize].max(pressure).max(0.0);
            // Sliding: Coulomb's force against the motion (`finish` stops
            // it rather than let it reverse). Otherwise held, by a damping
            // that lets it creep below the stick speed: a load past the
            // cone moves it faster than that, and it slides from the next
            // step on. On a free body the sliding force is a damping too,
            // `μ λ / speed`, which the solve holds in step with the body:
            // as an impulse fixed at the start of the step it would turn a
            // light body past the cloth, and back the next step.
            let friction = if speed > STICK_SPEED && body.is_none() {
                let kinetic = alpha * c.friction * load;
                Friction::Slide(kinetic / speed * along)
            } else {
                Friction::Hold(c.friction * load / speed.max(STICK_SPEED))
            };
            // Against a free body the spring takes the body's share of its
            // mass, up to [`BODY_STIFFENING`] times the particle's, so that
            // the body's weight does not press a spring sized for a particle
            // of cloth far into it (a 5 kg ball on 11 contacts of 0.8 g
            // particles: 0.16 mm rather than 1.6 mm). A particle squeezed
            // between a fixed surface and a body carries the body's weight
            // to that surface: its contact there takes the mass its load
            // stands for ([`LOAD_GRAVITY`]), as far, or sized for the
            // particle alone it would let a dish on a tablecloth sink into
            // the cloth's thickness and tip (a 0.9 kg bottle on a 2.5 cm
            // grid: 2.6 mm). A cloth pressed by a fixed surface alone (a
            // ball pushed into a hammock) keeps its spring: stiffened by
            // the cloth's tension, it would jolt the cloth as it lands.
            let stiffening = match body {
                Some((k, _, b)) => b.mass * w / self.counts[k as usize],
                None if self.touches[p].body => load * w / LOAD_GRAVITY,
                None => 1.0,
            }
            .clamp(1.0, BODY_STIFFENING);
            let k = stiffening * KAPPA / (w * gamma * gamma);
            // Against a free body pressing the particle onto a fixed
            // surface the spring takes as much of an overlap as its last
            // load explains (the depth at which it carries that load), and
            // the rest moves the body out (`separate.rs`). Against one the
            // cloth can give way to, it takes the overlap out at up to
            // DEPENETRATION_SPEED: out in one step, it would fling the body
            // (a light ball squeezed into the cloth by a heavy one).
            let gap = match body {
                Some(_) if self.touches[p].support != Vec3::ZERO => c.gap.max(-load / k),
                Some(_) => c.gap.max(-DEPENETRATION_SPEED * h),
                None => c.gap,
            };
            let reach = reach + c.gap - gap;
            self.held.push(Held {
                index,
                k,
                mass: 1.0 / w,
                start: x[p],
                gap,
                overlap: gap - c.gap,
                displacement: d,
                reach,
                body: body.map(|(k, r, _)| (k, r)),
                along,
                friction,
            });
        }
        self.forget_touches();
        self.any = !self.held.is_empty();
        self.any
    }

    /// Counts the contacts of each free body (each shows its share of the
    /// body's mass along the surface to sliding friction) and marks what
    /// each of the `n` particles touches: a body, or a fixed surface it
    /// lies on.
    fn count_touches(&mut self, n: usize) {
        self.counts.clear();
        self.counts.resize(self.bodies.len(), 0.0);
        self.touches.resize(n, Touches::default());
        for c in &self.list {
            let Some(touches) = self.touches.get_mut(c.particle as usize) else {
                continue;
            };
            if let Some(count) = self.counts.get_mut(c.body as usize) {
                *count += 1.0;
                touches.body = true;
            } else if c.body == NO_BODY && !c.edge && c.gap <= SHEET_GAP {
                touches.support = c.normal;
            }
        }
    }

    /// Clears what [`begin`](Self::begin) marked per particle (touches,
    /// holds, loads) for the next step.
    fn forget_touches(&mut self) {
        for c in &self.list {
            if let Some(touches) = self.touches.get_mut(c.particle as usize) {
                *touches = Touches::default();
            }
        }
        self.hold.fill(Hold::Free);
        self.load.fill([0.0; 2]);
    }

    /// Turns the contact of a body with a particle lying on a fixed surface
    /// (touching it, within [`SHEET_GAP`]: [`Touches::support`]) from the
    /// other side to that surface's normal, reversed (module docs).
    fn press_sheets(&mut self) {
        for c in self.list.iter_mut().filter(|c| c.body != NO_BODY) {
            let support = self.touches.get(c.particle as usize).map(|t| t.support);
            if let Some(support) = support.filter(|&s| c.normal.dot(s) < -SHEET_FACING) {
                c.normal = -support;
            }
        }
    }

    /// The solve's terms of the held contacts: each one's diagonal block
    /// `β k n nᵀ + α c (I − n nᵀ)` into `extra` (sorted by particle), the
    /// free bodies' terms into `coupling`, and its right-hand side, `α k
    /// reach n` less the friction's impulse at the start of the step (and
    /// its body's share), through `rhs`.
    pub(in crate::sim::integrate::implicit) fn emit(
        &mut self,
        extra: &mut Vec<(u32, [f32; 6])>,
        coupling: &mut Coupling,
        mut rhs: impl FnMut(usize, Vec3),
    ) {
        let (alpha, beta, h) = self.factors;
        extra.clear();
        self.links.clear();
        for held in &self.held {
            let c = &self.list[held.index];
            let p = c.particle as usize;
            // Holding, the damping's force at the start of the step is the
            // right-hand side's; its change is the block's.
            let (damping, kinetic) = match held.friction {
                Friction::Hold(damping) => (damping, alpha * damping * held.along),
                Friction::Slide(impulse) => (0.0, impulse),
            };
            let b = alpha * held.k * held.reach * c.normal - kinetic;
            rhs(p, b);
            let (s, t) = (beta * held.k, alpha * damping);
            let m = c.normal;
            // s n nᵀ + t (I − n nᵀ), as xx, yy, zz, xy, xz, yz.
            let block = [
                t + (s - t) * m.x * m.x,
                t + (s - t) * m.y * m.y,
                t + (s - t) * m.z * m.z,
                (s - t) * m.x * m.y,
                (s - t) * m.x * m.z,
                (s - t) * m.y * m.z,
            ];
            extra.push((p as u32, block));
            if let Some((body, r)) = held.body {
                self.links.push((body, p as u32, block, r, b));
            }
        }
        extra.sort_unstable_by_key(|e| e.0);
        self.links.sort_by_key(|l| l.0);
        coupling.build(&self.bodies, self.links.iter().copied(), h);
        coupling.rhs(rhs);
    }

    /// After a solve, the contacts it got wrong, for the step to be solved
    /// again with them corrected:
    ///
    /// - a held contact with a fixed surface whose friction took more than
    ///   [`GRIP_LIMIT`] times its bound `μ λ` slides, with that bound, in
    ///   the direction its friction acted;
    /// - a contact with a free body whose spring ended up pulling (the
    ///   particle was leaving the body; held, it would pull the body along)
    ///   is let go;
    /// - a body whose contacts' holding friction, net across its weight
    ///   (its engine's acceleration), took more than [`GRIP_LIMIT`] times
    ///   its Coulomb bound `Σ μ λ` (a cloth pulled from under it faster than
    ///   friction can carry it) slides: each of its contacts past its own
    ///   bound `μ λ` takes that bound, in the direction its friction acted.
    ///   Held by a damping sized for creeping, the body would be carried
    ///   along with the cloth at any speed;
    /// - a contact with a body sliding with more than [`GRIP_LIMIT`] times
    ///   its bound (set in a pass with a larger normal force) takes its
    ///   bound.
    ///
    /// A body's friction is judged with the pulls of its contacts that let
    /// go, which that friction held back; in a pass that lets a contact of
    /// a body go, no contact with a fixed surface slides.
    ///
    /// `v` each particle's velocity at the end of the solve (m/s), `dv` the
    /// solve's `Δv` (m/s), `coupling` the free bodies' velocity changes, `γ`
    /// and `h` (s) as for [`finish`](Self::finish). Returns whether any
    /// contact changed.
    pub(in crate::sim::integrate::implicit) fn revise(
        &mut self,
        v: impl Fn(usize) -> Vec3,
        dv: impl Fn(usize) -> Vec3,
        coupling: &Coupling,
        (gamma, h): (f32, f32),
    ) -> bool {
        let alpha = self.factors.0;
        // Each held contact's normal force (N) and holding friction's
        // impulse (N·s); each body's net friction impulse and its bound.
        self.grips.clear();
        self.counts.clear();
        self.counts.resize(self.bodies.len(), 0.0);
        self.net.clear();
        self.net.resize(self.bodies.len(), Vec3::ZERO);
        for held in &self.held {
            let c = &self.list[held.index];
            let p = c.particle as usize;
            let moved = held
                .body
                .map_or(Vec3::ZERO, |(body, r)| coupling.surface_change(body, r));
            let force = held.force(c, dv(p) - moved, (gamma, h));
            let grip = match held.friction {
                Friction::Hold(damping) => {
                    let relative = v(p) - c.velocity - moved;
                    alpha * damping * (relative - relative.dot(c.normal) * c.normal)
                }
                Friction::Slide(_) => Vec3::ZERO,
            };
            if let Some((body, _)) = held.body {
                // A leaving particle's spring pulls the body its way, and
                // the friction under the body that holds it back is not
                // friction carrying the body: counted with that pull, it
                // adds up to what moves the body. (`grip` is the impulse
                // friction gives the body.)
                let pull = -alpha * force.min(0.0) * c.normal;
                self.net[body as usize] += grip + pull;
                self.counts[body as usize] += alpha * c.friction * force.max(0.0);
            }
            self.grips.push((force, grip));
        }
        // Friction along the body's weight is in part the support its
        // contacts' stiff holds carry of it at rest in a pocket; what is
        // across the weight is friction carrying the body along.
        for (net, body) in self.net.iter_mut().zip(&self.bodies) {
            let down = body.acceleration.normalize_or_zero();
            *net -= net.dot(down) * down;
        }
        // Where a contact lets go of a body, the cloth under the body was
        // held in this solve by the frictions its pull set up: a table's
        // contacts slide only once the step is solved without it.
        let leaving = self
            .held
            .iter()
            .zip(&self.grips)
            .any(|(held, &(force, _))| held.body.is_some() && force < 0.0);
        let list = &self.list;
        let (net, counts) = (&self.net, &self.counts);
        let mut changed = false;
        let mut grips = self.grips.iter();
        self.held.retain_mut(|held| {
            let &(force, grip) = grips.next().expect("one grip a held contact");
            let bound = alpha * list[held.index].friction * force;
            let Some((body, _)) = held.body else {
                if !leaving && force > 0.0 && grip.length() > GRIP_LIMIT * bound {
                    held.friction = Friction::Slide(grip * (bound / grip.length()));
                    changed = true;
                }
                return true;
            };
            if force < 0.0 {
                changed = true;
                return false;
            }
            let b = body as usize;
            match held.friction {
                Friction::Hold(_)
                    if net[b].length() > GRIP_LIMIT * counts[b] && grip.length() > bound =>
                {
                    held.friction = Friction::Slide(grip * (bound / grip.length()));
                    changed = true;
                }
                // Sliding, with a bound set by a pass whose normal force has
                // fallen since.
                Friction::Slide(kinetic) if kinetic.length() > GRIP_LIMIT * bound => {
                    held.friction = Friction::Slide(kinetic * (bound / kinetic.length()));
                    changed = true;
                }
                _ => {}
            }
            true
        });
        self.any = !self.held.is_empty();
        changed
    }

    /// After the solve: a kinetic friction that would have reversed a
    /// particle's sliding stops it instead (`x`, `v` at the end of the step,
    /// m and m/s); each held contact's force `λ` (module docs), and its
    /// hold for the next step. `dv` the solve's `Δv` (m/s), `coupling`
    /// the free bodies' velocity changes, `γ` as in [`begin`](Self::begin),
    /// `h` the step (s).
    pub(in crate::sim::integrate::implicit) fn finish(
        &mut self,
        (x, v): (&mut [Vec3], &mut [Vec3]),
        dv: impl Fn(usize) -> Vec3,
        coupling: &Coupling,
        (gamma, h): (f32, f32),
    ) {
        let alpha = self.factors.0;
        self.stops.clear();
        self.changes.clear();
        self.changes
            .extend((0..self.bodies.len() as u32).map(|b| coupling.change(b)));
        for held in &self.held {
            let c = self.list[held.index];
            let p = c.particle as usize;
            // The surface moved with the body's velocity change too.
            let moved = held
                .body
                .map_or(Vec3::ZERO, |(body, r)| coupling.surface_change(body, r));
            let force = held.force(&c, dv(p) - moved, (gamma, h));
            // A body's friction is what the solve gave it: a particle that
            // another contact stopped after the solve (squeezed between a
            // table and a plate) does not drag the body by its holding
            // damping's stiffness times that stop.
            let solved = match held.body {
                Some(_) => v[p] - stopped(&self.stops, p),
                None => v[p],
            };
            let relative = solved - c.velocity - moved;
            let mut along = relative - relative.dot(c.normal) * c.normal;
            // The spring's impulse `α λ n` and the friction's: the damping's
            // on the final sliding velocity, or Coulomb's.
            let mut impulse = alpha * force * c.normal;
            match held.friction {
                Friction::Hold(damping) => impulse -= alpha * damping * along,
                Friction::Slide(kinetic) => impulse -= kinetic,
            }
            if let Friction::Slide(kinetic) = held.friction
                && along.dot(kinetic) < 0.0
            {
                // The particle ends sliding against the way it was going,
                // and friction, fixed against the old way, pushed it on.
                // Coulomb's law with the slip the rest of the step gave it:
                // it stops if friction can take that out, and slides on
                // with friction against it otherwise (the cloth pulled it
                // the other way).
                let free = along + kinetic / held.mass;
                let stop = kinetic.length() / held.mass;
                let end = if free.length() <= stop {
                    Vec3::ZERO
                } else {
                    free - stop * free.normalize()
                };
                let change = end - along;
                impulse += held.mass * change;
                v[p] += change;
                x[p] += gamma * change;
                self.stops.push((p as u32, change));
                along = end;
            }
            self.impulses.push((held.index as u32, impulse, held.start));
            if let Some((body, _)) = held.body {
                let depth = held.overlap.min(SEPARATION_SPEED * h);
                if depth > 0.0 {
                    self.overlaps.push((
                        body,
                        Overlap {
                            normal: c.normal,
                            depth,
                        },
                    ));
                }
            }
            if force <= 0.0 {
                // The spring held the particle back: it was leaving.
                continue;
            }
            // A particle squeezed between a surface and a body has two
            // contacts: the larger load, and sliding if either slides.
            let load = &mut self.load[p][c.edge as usize];
            *load = load.max(force);
            self.hold[p] = if along.length() < STICK_SPEED && self.hold[p] != Hold::Slide {
                Hold::Stick
            } else {
                Hold::Slide
            };
        }
        self.separate();
    }

    /// Each body's shift out of its contacts' overlaps ([`push_out`]), into
    /// `separations`.
    fn separate(&mut self) {
        self.separations.clear();
        self.separations.resize(self.bodies.len(), Vec3::ZERO);
        if self.overlaps.is_empty() {
            return;
        }
        self.overlaps.sort_unstable_by_key(|o| o.0);
        for group in self.overlaps.chunk_by(|a, b| a.0 == b.0) {
            let body = group[0].0 as usize;
            let Some(out) = self.separations.get_mut(body) else {
                continue;
            };
            self.scratch.clear();
            self.scratch.extend(group.iter().map(|o| o.1));
            *out = push_out(&self.scratch, &mut self.pushes);
        }
        self.overlaps.clear();
    }
}
