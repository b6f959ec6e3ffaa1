//! Contacts held in the solve, on one particle whose answers can be worked
//! by hand: it rests, lets go, sticks within the friction cone and slides
//! outside it.

use super::*;
use crate::sim::integrate::implicit::contacts::{
    DEPENETRATION_SPEED, KAPPA, NO_BODY, SEPARATION_SPEED, STICK_SPEED,
};

/// Mass (kg) and step (s) of the tests.
const M: f32 = 0.01;
const H: f32 = 1.0 / 60.0;

/// Runs `f` with the dynamics of one particle of mass [`M`] under gravity
/// and the external force `push` (N), without air damping.
fn one_particle<R>(push: Vec3, f: impl FnOnce(&Dynamics) -> R) -> R {
    let settings = SimSettings {
        damping: 0.0,
        ..SimSettings::default()
    };
    let connections = Connections::default();
    let (w, external) = ([1.0 / M], [push]);
    f(&Dynamics {
        settings: &settings,
        connections: &connections,
        inverse_masses: &w,
        external: &external,
        workers: crate::sim::workers::Pool::none(),
    })
}

/// Runs `f` with the dynamics of particles of mass [`M`], each pushed by
/// `push` (N), without gravity or air damping.
fn weightless<R>(push: &[Vec3], f: impl FnOnce(&Dynamics) -> R) -> R {
    let settings = SimSettings {
        damping: 0.0,
        gravity: Vec3::ZERO,
        ..SimSettings::default()
    };
    let connections = Connections::default();
    let w = vec![1.0 / M; push.len()];
    f(&Dynamics {
        settings: &settings,
        connections: &connections,
        inverse_masses: &w,
        external: push,
        workers: crate::sim::workers::Pool::none(),
    })
}

/// A contact of `particle` with a still surface of outward `normal`, `gap`
/// m away (friction `mu`), in front of free body `body` (or [`NO_BODY`]).
fn touching(particle: u32, normal: Vec3, gap: f32, mu: f32, body: u32) -> SolveContact {
    SolveContact {
        particle,
        normal,
        gap,
        velocity: Vec3::ZERO,
        friction: mu,
        source: 0,
        body,
        edge: false,
    }
}

/// `steps` backward-Euler steps of one free particle on the floor `y = 0`
/// (friction `mu`, contact thickness 0) from `y`, at rest, under gravity
/// and the external force `push` (N), listing the contact before each
/// step as a caller would. Returns the end state and the last hold.
fn on_floor(y: f32, push: Vec3, mu: f32, steps: usize) -> (Vec3, Vec3, Hold) {
    one_particle(push, |dynamics| {
        let (mut x, mut v) = ([Vec3::new(0.0, y, 0.0)], [Vec3::ZERO]);
        let mut buffers = ImplicitBuffers::default();
        for _ in 0..steps {
            let gap = x[0].y;
            buffers.contacts.list.clear();
            let arriving = gap + H * v[0].y < 0.0;
            if gap <= 1e-4 || arriving {
                buffers.contacts.list.push(SolveContact {
                    particle: 0,
                    normal: Vec3::Y,
                    gap,
                    velocity: Vec3::ZERO,
                    friction: mu,
                    source: 0,
                    body: NO_BODY,
                    edge: false,
                });
            }
            backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        }
        (x[0], v[0], buffers.contacts.hold(0))
    })
}

#[test]
fn a_particle_at_rest_on_the_floor_stays_on_it_and_carries_its_weight() {
    let (x, v, hold) = on_floor(0.0, Vec3::ZERO, 0.5, 120);
    // κ = 1000: within g h² / κ of the surface.
    assert!(x.y.abs() < 9.81 * H * H / 1000.0 * 2.0, "{x}");
    assert!(v.length() < 1e-4, "{v}");
    assert_eq!(hold, Hold::Stick);
}

#[test]
fn a_particle_under_a_body_sinks_into_the_floor_a_tenth_as_far() {
    // A 0.5 kg body resting on a particle on the floor, fifty times the
    // particle's weight (a dish on a tablecloth). The particle's spring on
    // the floor alone would give way by `λ h² / (κ m)`, 0.14 mm, and a
    // dish on a few particles would sink into the cloth's thickness and
    // tip. Stiffened by the load it carries, it gives way a tenth as far.
    const BODY: f32 = 0.5;
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let (x, v) = one_particle(Vec3::ZERO, |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::ZERO]);
        // The body's underside (m) and its velocity (m/s).
        let (mut y, mut speed) = (0.0f32, 0.0f32);
        let mut buffers = ImplicitBuffers::default();
        for _ in 0..120 {
            let contacts = &mut buffers.contacts;
            contacts.list.clear();
            contacts.bodies.clear();
            contacts
                .list
                .push(touching(0, Vec3::Y, x[0].y, 0.5, NO_BODY));
            let mut on_body = touching(0, Vec3::NEG_Y, y - x[0].y, 0.5, 0);
            on_body.velocity = Vec3::Y * speed;
            contacts.list.push(on_body);
            let mut body = SolveBody::new(BODY, Vec3::Y * y);
            body.acceleration = gravity;
            contacts.bodies.push(body);
            backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
            // The solve's change, gravity included; a body it did not
            // move falls by its engine's gravity.
            let change = buffers.contacts.body_change(0)[0].y;
            speed += if change == 0.0 { gravity.y * H } else { change };
            y += H * speed;
        }
        (x[0], v[0])
    });
    let soft = (BODY + M) * 9.81 * H * H / (KAPPA * M);
    assert!(
        -x.y < 0.11 * soft,
        "it sinks {} mm, unstiffened {} mm",
        -1000.0 * x.y,
        1000.0 * soft
    );
    assert!(v.length() < 1e-4, "{v}");
}

#[test]
fn a_falling_particle_lands_on_the_floor_in_one_step() {
    // 3 m/s down from 1 cm: it would pass 4 cm through the floor.
    let settings = SimSettings::default();
    let connections = Connections::default();
    let w = [1.0 / M];
    let dynamics = Dynamics {
        settings: &settings,
        connections: &connections,
        inverse_masses: &w,
        external: &[],
        workers: crate::sim::workers::Pool::none(),
    };
    let (mut x, mut v) = ([Vec3::Y * 0.01], [Vec3::NEG_Y * 3.0]);
    let mut buffers = ImplicitBuffers::default();
    buffers.contacts.list.push(SolveContact {
        particle: 0,
        normal: Vec3::Y,
        gap: 0.01,
        velocity: Vec3::ZERO,
        friction: 0.0,
        source: 0,
        body: NO_BODY,
        edge: false,
    });
    backward_euler(&dynamics, &mut x, &mut v, H, &mut buffers);
    // It ends on the surface (to within 1/(1 + κ) of the 5 cm it would
    // have moved into it), with the velocity that took it there in the
    // step (the 1 cm it fell, over h).
    assert!(x[0].y.abs() < 0.05 / 1000.0 * 2.0, "{}", x[0]);
    assert!((v[0].y + 0.01 / H).abs() < 0.01, "{}", v[0]);
    // The next step stops it there.
    buffers.contacts.list[0].gap = x[0].y;
    backward_euler(&dynamics, &mut x, &mut v, H, &mut buffers);
    assert!(
        x[0].y.abs() < 1e-4 && v[0].y.abs() < 0.05,
        "{} {}",
        x[0],
        v[0]
    );
}

#[test]
fn a_particle_pulled_off_the_floor_is_let_go() {
    // Twice its weight upwards: it leaves with (2mg − mg)/m = g.
    let (x, v, hold) = on_floor(0.0, Vec3::Y * 2.0 * M * 9.81, 0.5, 30);
    assert_eq!(hold, Hold::Free);
    let t = 30.0 * H;
    assert!((v.y - 9.81 * t).abs() < 0.05 * 9.81 * t, "{v}");
    assert!(x.y > 0.4 * 9.81 * t * t, "{x}");
}

#[test]
fn friction_holds_inside_its_cone_and_slides_by_coulomb_outside_it() {
    // μ m g = 0.049 N. A push of 0.04 N: held, creeping slower than the
    // stick speed.
    let mu = 0.5;
    let (x, v, hold) = on_floor(0.0, Vec3::X * 0.04, mu, 60);
    assert!(v.length() < STICK_SPEED, "{v}");
    assert!(x.x.abs() < 60.0 * H * STICK_SPEED, "{x}");
    assert_eq!(hold, Hold::Stick);
    // A push of 0.08 N: it slides at (0.08 − 0.049)/m = 3.1 m/s², after a
    // first step in which the holding damping lets it reach the stick
    // speed only.
    let (_, v, hold) = on_floor(0.0, Vec3::X * 0.08, mu, 61);
    let expected = (0.08 - mu * M * 9.81) / M * 60.0 * H;
    assert!(
        (v.x - expected).abs() < 0.02 * expected,
        "{v} vs {expected}"
    );
    assert_eq!(hold, Hold::Slide);
}

#[test]
fn a_step_without_contacts_after_a_slide_keeps_nothing_of_it() {
    // A particle sliding on the floor (0.08 N against μ m g = 0.049 N),
    // its history then forgotten (as the guard does to retry a step, or a
    // teleport) and a step taken with no contact listed: the step must be
    // what it is from fresh buffers. The last held step's right-hand-side
    // terms were kept and added to every such step, which threw a cloth
    // landing in gusts 100 m up.
    one_particle(Vec3::X * 0.08, |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::ZERO]);
        let mut buffers = ImplicitBuffers::default();
        for _ in 0..30 {
            buffers.contacts.list.clear();
            buffers
                .contacts
                .list
                .push(touching(0, Vec3::Y, x[0].y, 0.5, NO_BODY));
            backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        }
        assert_eq!(buffers.contacts.hold(0), Hold::Slide);
        x[0].y += 0.1;
        let (mut x_fresh, mut v_fresh) = (x, v);
        buffers.reset_history();
        buffers.contacts.list.clear();
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        let mut fresh = ImplicitBuffers::default();
        backward_euler(dynamics, &mut x_fresh, &mut v_fresh, H, &mut fresh);
        assert!(
            (v[0] - v_fresh[0]).length() < 1e-5,
            "{} vs {}",
            v[0],
            v_fresh[0]
        );
        assert!(
            (x[0] - x_fresh[0]).length() < 1e-6,
            "{} vs {}",
            x[0],
            x_fresh[0]
        );
    });
}

/// One particle falling at 3 m/s from 1 cm onto a surface, in one backward
/// Euler step: its position, velocity and the contact's impulse (N·s),
/// with a free body of `body_mass` kg behind the surface (infinite: none).
fn land_on(body_mass: f32) -> (Vec3, Vec3, Vec3) {
    // No air damping: gravity and the contact are the only forces.
    one_particle(Vec3::ZERO, |dynamics| {
        let (mut x, mut v) = ([Vec3::Y * 0.01], [Vec3::NEG_Y * 3.0]);
        let v0 = v[0];
        let mut buffers = ImplicitBuffers::default();
        buffers.contacts.list.push(SolveContact {
            particle: 0,
            normal: Vec3::Y,
            gap: 0.01,
            velocity: Vec3::ZERO,
            friction: 0.0,
            source: 7,
            body: if body_mass.is_finite() { 0 } else { NO_BODY },
            edge: false,
        });
        let body = SolveBody::new(body_mass, Vec3::NEG_Y * 0.1);
        buffers.contacts.bodies.push(body);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        let impulses: Vec<_> = buffers.contacts.impulses().collect();
        assert_eq!(impulses.len(), 1);
        assert_eq!(impulses[0].0.source, 7, "the contact's collider comes back");
        // Without the contact the step would change the momentum by m g h.
        let free = M * (v0 + dynamics.settings.gravity * H);
        let by_contact = M * v[0] - free;
        let impulse = impulses[0].1;
        assert!(
            (impulse - by_contact).length() <= 1e-3 * by_contact.length(),
            "the impulse {impulse} is the momentum the contact gave, {by_contact}"
        );
        (x[0], v[0], impulse)
    })
}

#[test]
fn a_contacts_impulse_is_the_momentum_it_gave_and_a_light_body_gives_way() {
    let (x_fixed, _, fixed) = land_on(f32::INFINITY);
    let (x_heavy, _, heavy) = land_on(1000.0 * M);
    let (x_light, _, light) = land_on(0.1 * M);
    // A body far heavier than the particle holds it as a fixed surface
    // does; one lighter than it is pushed along and takes little impulse.
    assert!(
        (heavy - fixed).length() < 0.01 * fixed.length(),
        "{heavy} {fixed}"
    );
    assert!(light.y > 0.0 && light.y < 0.2 * fixed.y, "{light} {fixed}");
    assert!(x_light.y < x_fixed.y - 0.01, "{x_light} {x_fixed}");
    assert!((x_heavy - x_fixed).length() < 1e-3);
}

/// One backward-Euler step of a particle resting on a surface and moving
/// along it at `speed` m/s, the surface a free body of `body_mass` kg that
/// does not turn (infinite: none; friction 0.5): the contact's impulse
/// along the surface (N·s).
fn rub(speed: f32, body_mass: f32) -> f32 {
    one_particle(Vec3::ZERO, |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::X * speed]);
        let mut buffers = ImplicitBuffers::default();
        let body = if body_mass.is_finite() { 0 } else { NO_BODY };
        buffers
            .contacts
            .list
            .push(touching(0, Vec3::Y, 0.0, 0.5, body));
        let body = SolveBody::new(body_mass, Vec3::NEG_Y * 0.1);
        buffers.contacts.bodies.push(body);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        let impulses: Vec<_> = buffers.contacts.impulses().collect();
        assert_eq!(impulses.len(), 1);
        -impulses[0].1.x
    })
}

#[test]
fn friction_never_drives_a_light_body_past_the_cloth() {
    // A body of a hundredth of the particle's mass (a small puck sliding
    // freely under the cloth) takes at most
    // the impulse that brings it to the particle's speed: more would fling
    // it past, and the cloth with it the next step.
    let light = 0.01 * M;
    for speed in [1.0, 0.5 * STICK_SPEED] {
        let fixed = rub(speed, f32::INFINITY);
        let given = rub(speed, light);
        assert!(
            fixed > 5.0 * light * speed,
            "a fixed surface takes more at {speed} m/s: {fixed} N·s"
        );
        assert!(
            given > 0.0 && given <= 1.001 * light * speed,
            "at {speed} m/s the light body took {given} N·s, at most {}",
            light * speed
        );
    }
}

/// One backward-Euler step, without gravity, of particles of mass [`M`]
/// at `x` (m), at rest, each pushed by `push` (N) and touching a free
/// body of `body_mass` kg at the origin along `normals`: the particles'
/// end positions, the body's velocity change (m/s, rad/s) and the
/// impulses the contacts gave.
fn press(
    x: &[Vec3],
    push: &[Vec3],
    normals: &[Vec3],
    body_mass: f32,
) -> (Vec<Vec3>, [Vec3; 2], Vec<Vec3>) {
    weightless(push, |dynamics| {
        let (mut x, mut v) = (x.to_vec(), vec![Vec3::ZERO; x.len()]);
        let mut buffers = ImplicitBuffers::default();
        for (i, &normal) in normals.iter().enumerate() {
            let contact = touching(i as u32, normal, 0.0, 0.0, 0);
            buffers.contacts.list.push(contact);
        }
        let mut body = SolveBody::new(body_mass, Vec3::ZERO);
        body.inverse_inertia =
            bevy::math::Mat3::from_diagonal(Vec3::splat(1.0 / (0.4 * body_mass * 0.01)));
        buffers.contacts.bodies.push(body);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        let impulses = buffers.contacts.impulses().map(|(_, j, _)| j).collect();
        (x, buffers.contacts.body_change(0), impulses)
    })
}

#[test]
fn a_light_body_pressed_from_both_sides_does_not_give_way() {
    // A body a tenth of a particle's mass between two particles pushed
    // into it with 1 N each: together it stays where it is, and neither
    // particle goes in further than its contact spring's give, `F/k`
    // (28 µm). Taken contact by contact (the body giving way to each push
    // by itself, each spring in series with half its mass), both would
    // sink 0.55 m into it.
    let x = [Vec3::NEG_X * 0.1, Vec3::X * 0.1];
    let push = [Vec3::X, Vec3::NEG_X];
    let (end, [linear, angular], impulses) = press(&x, &push, &[Vec3::NEG_X, Vec3::X], 0.1 * M);
    assert!(
        linear.length() < 1e-4 && angular.length() < 1e-3,
        "{linear} {angular}"
    );
    for (p, q) in end.iter().zip(&x) {
        assert!((p.x - q.x).abs() < 1e-4, "moved from {q} to {p}");
    }
    // Each contact took its push over the step.
    for j in impulses {
        assert!((j.length() - H).abs() < 1e-3 * H, "{j}");
    }
}

#[test]
fn a_free_body_takes_the_momentum_its_contacts_give() {
    // One particle pushed into a body of twice its mass off its centre: the
    // body gains what the particle is given back, and turns.
    let x = [Vec3::new(-0.1, 0.05, 0.0)];
    let (_, [linear, angular], impulses) = press(&x, &[Vec3::X], &[Vec3::NEG_X], 2.0 * M);
    let given: Vec3 = impulses.iter().sum();
    let momentum = 2.0 * M * linear;
    assert!(
        (momentum + given).length() < 1e-3 * given.length(),
        "the body gained {momentum}, the particle was given {given}"
    );
    assert!(
        angular.z < 0.0,
        "a push above the centre turns it: {angular}"
    );
}

#[test]
fn a_particle_deep_inside_a_free_body_comes_out_at_a_bounded_speed() {
    // 5 cm inside a body of its own mass (its engine pushed the body into
    // the cloth): taken out in one step the two would part at 3 m/s; they
    // part at the depenetration speed.
    let (v, body) = weightless(&[Vec3::ZERO], |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::ZERO]);
        let mut buffers = ImplicitBuffers::default();
        buffers
            .contacts
            .list
            .push(touching(0, Vec3::Y, -0.05, 0.0, 0));
        let body = SolveBody::new(M, Vec3::NEG_Y * 0.1);
        buffers.contacts.bodies.push(body);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        (v, buffers.contacts.body_change(0))
    });
    let parting = (v[0] - body[0]).y;
    assert!(
        parting > 0.5 * DEPENETRATION_SPEED && parting <= 1.01 * DEPENETRATION_SPEED,
        "they part at {parting} m/s"
    );
}

#[test]
fn a_body_sunk_into_a_sheet_on_a_table_is_moved_out_without_speed() {
    // A particle lying on a table (its contact with it touching) under a
    // body of its own mass that its engine pushed 2 cm into it. The cloth
    // cannot give way: taken out as velocity in one step, the body would
    // leave at 1.2 m/s. The body is moved out
    // by its position instead, at the separation speed, and leaves at no
    // speed.
    let (v, body, separation) = weightless(&[Vec3::ZERO], |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::ZERO]);
        let mut buffers = ImplicitBuffers::default();
        let list = &mut buffers.contacts.list;
        list.push(touching(0, Vec3::Y, 0.0, 0.0, NO_BODY));
        list.push(touching(0, Vec3::NEG_Y, -0.02, 0.0, 0));
        buffers
            .contacts
            .bodies
            .push(SolveBody::new(M, Vec3::Y * 0.1));
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        (
            v,
            buffers.contacts.body_change(0),
            buffers.contacts.body_separation(0),
        )
    });
    assert!(v[0].length() < 1e-3, "the particle moves at {} m/s", v[0]);
    assert!(body[0].length() < 1e-3, "the body moves at {} m/s", body[0]);
    let expected = SEPARATION_SPEED * H;
    assert!(
        (separation - Vec3::Y * expected).length() < 1e-3 * expected,
        "the body moved {separation} m, not {expected} m up"
    );
}

#[test]
fn a_cloth_pulled_from_under_a_body_carries_it_no_faster_than_friction() {
    // A 0.4 kg body resting on four particles (friction 0.3), which are
    // pulled sideways with 3 N each, 5 m/s in a step for a free particle:
    // friction gives the body `μ g h` = 4.9 cm/s along, no more. Held by
    // the friction sized for creeping, it would be carried at 0.45 m/s.
    const BODY: f32 = 0.4;
    const MU: f32 = 0.3;
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let x: Vec<Vec3> = (0..4)
        .map(|i| Vec3::new(0.1 * (i % 2) as f32, -0.05, 0.1 * (i / 2) as f32))
        .collect();
    // Each particle held up against its share of the body's weight.
    let push = vec![Vec3::X * 3.0 - gravity * BODY / 4.0; 4];
    let (v, [linear, _]) = weightless(&push, |dynamics| {
        let (mut x, mut v) = (x.clone(), vec![Vec3::ZERO; 4]);
        let mut buffers = ImplicitBuffers::default();
        for i in 0..4 {
            buffers
                .contacts
                .list
                .push(touching(i, Vec3::NEG_Y, 0.0, MU, 0));
        }
        let mut body = SolveBody::new(BODY, Vec3::new(0.05, 0.0, 0.05));
        body.acceleration = gravity;
        buffers.contacts.bodies.push(body);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        (v, buffers.contacts.body_change(0))
    });
    let coulomb = MU * 9.81 * H;
    assert!(
        (linear.x - coulomb).abs() < 0.05 * coulomb,
        "the body gained {} m/s along, friction allows {coulomb}",
        linear.x
    );
    // The particles slide on under it.
    assert!(v.iter().all(|v| v.x > 3.0), "{v:?}");
    assert!(linear.y.abs() < 0.02, "the body rests: {linear}");
}

#[test]
fn a_particle_sliding_one_way_and_pulled_the_other_slides_the_other_way() {
    // Sliding at 0.1 m/s along -X on the floor (μ 0.5), then pulled along
    // +X with 1 N (100 g): in the step it turns and slides on along +X at
    // `(F/m − μ g) h` and more, with friction against that. It does not
    // stop where it was.
    let mu = 0.5;
    let v = one_particle(Vec3::ZERO, |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::NEG_X * 0.1]);
        let mut buffers = ImplicitBuffers::default();
        let contact = touching(0, Vec3::Y, 0.0, mu, NO_BODY);
        // One step sliding, so that the next one starts sliding.
        buffers.contacts.list.push(contact);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        assert_eq!(buffers.contacts.hold(0), Hold::Slide);
        let external = [Vec3::X];
        let pulled = Dynamics {
            external: &external,
            ..*dynamics
        };
        backward_euler(&pulled, &mut x, &mut v, H, &mut buffers);
        v[0]
    });
    let least = (1.0 / M - mu * 9.81) * H - 0.1;
    assert!(
        v.x > 0.9 * least,
        "it slides at {} m/s, at least {least}",
        v.x
    );
}

#[test]
fn a_body_is_handed_the_impulse_the_solve_gave_it_when_a_squeezed_particle_stops() {
    // A particle sliding along -X on the floor (μ 0.5) under a 0.2 kg body
    // (μ 0.5) pressed a hair into it, then pulled along +X with 0.4 N: its
    // sliding on the floor reverses, and the floor's friction stops it
    // after the solve. The body's impulse is still the momentum the solve
    // gave it, not its holding friction's stiffness times that stop.
    const BODY: f32 = 0.2;
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let (given, gained) = one_particle(Vec3::ZERO, |dynamics| {
        let (mut x, mut v) = ([Vec3::ZERO], [Vec3::NEG_X * 0.1]);
        let mut buffers = ImplicitBuffers::default();
        let mut step = |dynamics: &Dynamics, buffers: &mut ImplicitBuffers| {
            buffers.contacts.list.clear();
            buffers.contacts.bodies.clear();
            buffers
                .contacts
                .list
                .push(touching(0, Vec3::Y, 0.0, 0.5, NO_BODY));
            buffers
                .contacts
                .list
                .push(touching(0, Vec3::NEG_Y, -3e-4, 0.5, 0));
            let mut body = SolveBody::new(BODY, Vec3::Y * 0.05);
            body.acceleration = gravity;
            buffers.contacts.bodies.push(body);
            backward_euler(dynamics, &mut x, &mut v, H, buffers);
        };
        step(dynamics, &mut buffers);
        assert_eq!(buffers.contacts.hold(0), Hold::Slide);
        let external = [Vec3::X * 0.4];
        let pulled = Dynamics {
            external: &external,
            ..*dynamics
        };
        step(&pulled, &mut buffers);
        let given: Vec3 = -buffers
            .contacts
            .impulses()
            .filter(|(c, ..)| c.body == 0)
            .map(|(_, j, _)| j)
            .sum::<Vec3>();
        let [linear, _] = buffers.contacts.body_change(0);
        (given, BODY * (linear - gravity * H))
    });
    assert!(
        (given - gained).length() <= 0.01 * gained.length() + 1e-4,
        "the body is handed {given} N·s, the solve gave it {gained}"
    );
}

#[test]
fn a_contact_letting_go_of_a_body_does_not_make_it_slide() {
    // A 0.5 kg body resting on four particles on the floor, and a fifth
    // particle at its side, pulled away from it with 5 N in the second
    // step. Held in that step's first solve, the particle's spring pulls
    // the body along +X and the friction under the body holds it back,
    // past three times its Coulomb bound. The particle is let go; the
    // frictions it set up are not the body's to slide by: with it gone,
    // nothing moves the body along.
    const BODY: f32 = 0.5;
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let mut x: Vec<Vec3> = (0..4)
        .map(|i| {
            Vec3::new(
                0.1 * (i % 2) as f32 - 0.05,
                0.0,
                0.1 * (i / 2) as f32 - 0.05,
            )
        })
        .collect();
    x.push(Vec3::new(0.1, 0.01, 0.0));
    let mut v = vec![Vec3::ZERO; 5];
    let mut buffers = ImplicitBuffers::default();
    let mut step = |pull: f32| {
        let mut push = vec![Vec3::ZERO; 5];
        push[4] = Vec3::X * pull;
        weightless(&push, |dynamics| {
            let contacts = &mut buffers.contacts;
            contacts.list.clear();
            contacts.bodies.clear();
            // Each pressed a hair into what it touches.
            for i in 0..4 {
                contacts
                    .list
                    .push(touching(i, Vec3::Y, -1e-4, 0.5, NO_BODY));
                contacts.list.push(touching(i, Vec3::NEG_Y, -1e-4, 0.2, 0));
            }
            contacts.list.push(touching(4, Vec3::X, -1e-4, 0.2, 0));
            let mut body = SolveBody::new(BODY, Vec3::new(0.0, 0.01, 0.0));
            body.acceleration = gravity;
            contacts.bodies.push(body);
            backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
            buffers.contacts.body_change(0)[0]
        })
    };
    step(0.0);
    let linear = step(5.0);
    assert!(
        linear.x.abs() < 1e-3,
        "the body moves along at {} m/s",
        linear.x
    );
}

#[test]
fn a_body_presses_a_particle_lying_on_the_floor_against_the_floor() {
    // A particle of a tablecloth slides along the floor at 5 m/s under the
    // rim of a 0.5 kg plate tipped a millimetre into the cloth's thickness:
    // the rim's nearest point faces the particle half sideways. A cloth
    // lying on a table can only be pressed against it: the plate is lifted
    // out of the cloth and dragged by friction (μ 0.2), `μ g h` = 3.3 cm/s
    // and not much more, rather than pushed along by the oncoming cloth.
    const BODY: f32 = 0.5;
    let gravity = Vec3::new(0.0, -9.81, 0.0);
    let (x, v) = ([Vec3::ZERO], [Vec3::Z * 5.0]);
    let [linear, _] = one_particle(Vec3::ZERO, |dynamics| {
        let (mut x, mut v) = (x, v);
        let mut buffers = ImplicitBuffers::default();
        let contacts = &mut buffers.contacts;
        contacts.list.push(touching(0, Vec3::Y, 0.0, 0.5, NO_BODY));
        let rim = Vec3::new(0.0, -0.6, -0.8);
        contacts.list.push(touching(0, rim, -1e-3, 0.2, 0));
        let mut body = SolveBody::new(BODY, Vec3::new(0.0, 0.01, 0.1));
        body.acceleration = gravity;
        contacts.bodies.push(body);
        backward_euler(dynamics, &mut x, &mut v, H, &mut buffers);
        buffers.contacts.body_change(0)
    });
    let coulomb = 0.2 * 9.81 * H;
    assert!(
        linear.z.abs() < 1.5 * coulomb,
        "the plate is pushed along at {} m/s, friction allows {coulomb}",
        linear.z
    );
}
