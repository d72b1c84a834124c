//! A ray that starts inside a clear sphere finds, without the accelerator, the hit every accelerator
//! finds, and a shadow ray from inside any of the spheres is occluded where every accelerator says so:
//! rays spawned inside spheres as the integrator spawns them (refracted in, reflected inside), on
//! scenes where other shapes pass near the spheres, cut into them, or sit inside them, at small and
//! large scales.

use proptest::prelude::*;
use raylume_accel::{Accelerator, BruteForce, Bvh, Interiors, PrimitiveHit};
use raylume_geometry::{Interval, Plane, Ray, Sphere, Triangle, Vec3A, gamma, offset_ray_origin};
use raylume_intersect::Primitive;

const STILL: Interval = Interval { min: 0.0, max: 0.0 };

/// The ray spawned at `hit` of `ray` into the solid (a refraction entering it): from the hit point
/// offset inwards past its error, as the integrator offsets it, along `dir` turned inwards.
fn spawned_inside(ray: &Ray, hit: &PrimitiveHit, dir: Vec3A) -> Ray {
    let h = hit.hit;
    let outward = if h.normal.dot(ray.dir) < 0.0 { h.normal } else { -h.normal };
    let error = h.error + (ray.dir * h.t).abs() * gamma(16);
    let origin = offset_ray_origin(h.point, error, -outward);
    let dir = if dir.dot(outward) > 0.0 { -dir } else { dir };
    Ray::new(origin, dir.normalize())
}

/// Checks every ray spawned inside a sphere of `prims` by rays from `eye` through `targets`: where
/// the clear interiors answer, they answer as the brute-force list and the BVH do. Returns how many
/// they answered.
fn check(prims: &[Primitive], eye: Vec3A, targets: &[Vec3A], turns: &[Vec3A]) -> usize {
    let clear = Interiors::new(prims, |_| true, STILL);
    let list = BruteForce::new(prims.to_vec());
    let bvh = Bvh::new(prims.to_vec(), STILL);
    let mut answered = 0;
    for (&target, &turn) in targets.iter().zip(turns.iter().cycle()) {
        let ray = Ray::new(eye, target - eye);
        let Some(first) = list.closest_hit(&ray, Interval::POSITIVE) else { continue };
        if !matches!(prims[first.primitive as usize], Primitive::Sphere(_)) {
            continue;
        }
        let inside = spawned_inside(&ray, &first, turn);
        // A ray reflected inside at the point it leaves by, as the integrator spawns it.
        let mut rays = vec![inside];
        if let Some(exit) = list.closest_hit(&inside, Interval::POSITIVE)
            && exit.primitive == first.primitive
        {
            rays.push(spawned_inside(&inside, &exit, turn + inside.dir));
        }
        for r in rays {
            let expected = list.closest_hit(&r, Interval::POSITIVE);
            assert_eq!(bvh.closest_hit(&r, Interval::POSITIVE), expected);
            if let Some(found) = clear.closest_hit(&r, Interval::POSITIVE, first.primitive) {
                assert_eq!(Some(found), expected, "ray {r:?} inside primitive {}", first.primitive);
                answered += 1;
            }
            // Ranges that end short of the exit, about at it, or start past where the ray may meet
            // a near shape.
            if let Some(exit) = expected.map(|h| h.hit.t) {
                for range in [(0.0, 0.5), (0.0, 0.999), (0.0, 1.001), (0.5, f32::INFINITY), (1.001, f32::INFINITY)]
                    .map(|(a, b)| Interval::new(exit * a, exit * b))
                {
                    if let Some(found) = clear.closest_hit(&r, range, first.primitive) {
                        assert_eq!(Some(found), list.closest_hit(&r, range), "ray {r:?} within {range:?}");
                    }
                }
            }
            // Shadow rays from inside: towards the eye, and along the ray to lights short of where it
            // leaves the sphere, about there, and beyond.
            let to_eye = eye - r.origin;
            let exit = expected.map_or(1.0, |h| h.hit.t);
            let shadows = [(Ray::new(r.origin, to_eye.normalize()), to_eye.length())]
                .into_iter()
                .chain([0.5, 0.999, 1.001, 2.0].map(|f| (r, exit * f)));
            for (shadow, t_max) in shadows {
                let occluded = list.occluded(&shadow, t_max);
                assert_eq!(bvh.occluded(&shadow, t_max), occluded);
                if clear.occluded(&shadow, t_max, first.primitive) {
                    assert!(occluded, "{shadow:?} to {t_max}");
                }
            }
        }
    }
    answered
}

/// A cluster of spheres, some apart, some touching or overlapping, with triangles near them and
/// through them, and a plane below; scaled by `scale` and moved by `offset`.
fn cluster(centres: &[(Vec3A, f32)], cuts: &[(Vec3A, Vec3A, Vec3A)], scale: f32, offset: Vec3A) -> Vec<Primitive> {
    let at = |p: Vec3A| p * scale + offset;
    let mut prims: Vec<Primitive> =
        centres.iter().map(|&(c, r)| Primitive::Sphere(Sphere { center: at(c), radius: r * scale })).collect();
    prims.extend(cuts.iter().map(|&(a, b, c)| Primitive::Triangle(Triangle::new(at(a), at(b), at(c)))));
    prims.push(Primitive::Plane(Plane { point: at(Vec3A::new(0.0, -3.0, 0.0)), normal: Vec3A::Y }));
    prims
}

fn arb_point(range: f32) -> impl Strategy<Value = Vec3A> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn rays_from_inside_spheres_hit_what_the_accelerators_hit(
        centres in prop::collection::vec((arb_point(2.0), 0.2f32..0.9), 1..8),
        cuts in prop::collection::vec((arb_point(2.5), arb_point(2.5), arb_point(2.5)), 0..4),
        scale in prop::sample::select(vec![1e-14f32, 1e-3, 1.0, 3e4, 1e14]),
        offset in arb_point(100.0),
        targets in prop::collection::vec(arb_point(2.0), 40),
        turns in prop::collection::vec(arb_point(1.0), 1..8),
    ) {
        let prims = cluster(&centres, &cuts, scale, offset * scale);
        let eye = Vec3A::new(0.0, 1.0, 12.0) * scale + offset * scale;
        let targets: Vec<Vec3A> = targets.iter().map(|&t| t * scale + offset * scale).collect();
        check(&prims, eye, &targets, &turns);
    }
}

/// A sphere apart from everything is answered alone; one that spheres or planes reach into (touching,
/// within the clearance, overlapping, inside it, crossing it) is answered with them, as the
/// accelerators answer; one that a triangle reaches, or more than eight shapes, is left to the
/// accelerator.
#[test]
fn spheres_are_answered_with_the_spheres_and_planes_near_them() {
    let ball = |x: f32, r: f32| Primitive::Sphere(Sphere { center: Vec3A::new(x, 0.0, 0.0), radius: r });
    let triangle_at = |z: f32| {
        Primitive::Triangle(Triangle::new(Vec3A::new(-5.0, -5.0, z), Vec3A::new(5.0, -5.0, z), Vec3A::new(0.0, 5.0, z)))
    };
    let plane_at = |z: f32| Primitive::Plane(Plane { point: Vec3A::new(0.0, 0.0, z), normal: Vec3A::Z });
    // Answered or not from the centre of the first sphere, along +x and up; where answered, as the list.
    let answered = |prims: &[Primitive]| {
        let interiors = Interiors::new(prims, |_| true, STILL);
        let list = BruteForce::new(prims.to_vec());
        let answers = [Vec3A::X, Vec3A::new(0.3, 0.1, 1.0).normalize()].map(|dir| {
            let ray = Ray::new(Vec3A::ZERO, dir);
            let found = interiors.closest_hit(&ray, Interval::POSITIVE, 0);
            if found.is_some() {
                assert_eq!(found, list.closest_hit(&ray, Interval::POSITIVE), "{prims:?} along {dir}");
            }
            found.is_some()
        });
        assert_eq!(answers[0], answers[1]);
        answers[0]
    };
    assert!(answered(&[ball(0.0, 1.0), ball(2.1, 1.0)]), "a neighbour 0.1 away");
    assert!(answered(&[ball(0.0, 1.0), triangle_at(1.01)]), "a triangle 0.01 away");
    assert!(answered(&[ball(0.0, 1.0), ball(2.0, 1.0)]), "touching");
    assert!(answered(&[ball(0.0, 1.0), ball(2.0 + 1e-5, 1.0)]), "within the clearance");
    assert!(answered(&[ball(0.0, 1.0), ball(1.5, 1.0)]), "overlapping");
    assert!(answered(&[ball(0.0, 1.0), ball(0.5, 0.1)]), "a bubble inside");
    assert!(answered(&[ball(0.0, 1.0), plane_at(0.9)]), "a plane through it");
    assert!(answered(&[ball(0.0, 1.0), plane_at(1.1)]), "a plane 0.1 away");
    assert!(!answered(&[ball(0.0, 1.0), triangle_at(0.5)]), "a triangle through it");
    assert!(!answered(&[ball(0.0, 1.0), triangle_at(1.0)]), "a triangle touching it");
    let crowded: Vec<Primitive> = (0..10).map(|k| ball(0.0, 1.0 + k as f32 * 0.05)).collect();
    assert!(!answered(&crowded), "nine spheres reaching into it");
    assert!(answered(&crowded[..9]), "eight");
    // Only the spheres asked for are examined.
    let none = Interiors::new(&[ball(0.0, 1.0)], |_| false, STILL);
    assert!(!none.answers_any());
}

/// A ray that starts outside a clear sphere (not a spawned one) is left to the accelerator: a shape
/// between it and the sphere would be hit first. A shadow ray that does not meet the sphere is left
/// to the accelerator too.
#[test]
fn rays_starting_outside_are_left_to_the_accelerator() {
    let prims = [
        Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 }),
        Primitive::Sphere(Sphere { center: Vec3A::new(-3.0, 0.0, 0.0), radius: 0.5 }),
    ];
    let clear = Interiors::new(&prims, |_| true, STILL);
    let from_outside = Ray::new(Vec3A::new(-5.0, 0.0, 0.0), Vec3A::X);
    assert_eq!(clear.closest_hit(&from_outside, Interval::POSITIVE, 0), None);
    assert_eq!(BruteForce::new(prims.to_vec()).closest_hit(&from_outside, Interval::POSITIVE).unwrap().primitive, 1);
    let from_inside = Ray::new(Vec3A::new(0.5, 0.0, 0.0), -Vec3A::X);
    assert_eq!(clear.closest_hit(&from_inside, Interval::POSITIVE, 0).unwrap().hit.t, 1.5);
    assert!(clear.occluded(&from_inside, 1.6, 0));
    assert!(!clear.occluded(&from_inside, 1.4, 0), "the light inside the sphere");
    assert!(clear.occluded(&from_outside, 10.0, 1), "the second sphere, met from outside");
    let first_only = Interiors::new(&prims, |i| i == 0, STILL);
    assert!(!first_only.occluded(&from_outside, 10.0, 1), "not a sphere asked for");
}

/// On seeded clusters like the course's glass balls (four spheres nearly touching above a terrain of
/// triangles), most rays spawned inside are answered, and as the accelerators answer.
#[test]
fn glass_balls_above_a_terrain() {
    let centres = [
        (Vec3A::new(-0.8, 0.8, 1.20821), 0.17),
        (Vec3A::new(-0.661196, 0.661196, 0.930598), 0.169),
        (Vec3A::new(-0.749194, 0.98961, 0.930598), 0.168),
        (Vec3A::new(-0.98961, 0.749194, 0.930598), 0.167),
    ];
    let mut prims: Vec<Primitive> =
        centres.iter().map(|&(center, radius)| Primitive::Sphere(Sphere { center, radius })).collect();
    for i in 0..8 {
        for j in 0..8 {
            let p =
                |x: f32, y: f32| Vec3A::new(x / 4.0 - 1.0, y / 4.0 - 1.0, 0.3 * ((x * 1.3).sin() + (y * 0.7).cos()));
            let (x, y) = (i as f32, j as f32);
            prims.push(Primitive::Triangle(Triangle::new(p(x, y), p(x + 1.0, y), p(x + 1.0, y + 1.0))));
            prims.push(Primitive::Triangle(Triangle::new(p(x, y), p(x + 1.0, y + 1.0), p(x, y + 1.0))));
        }
    }
    let eye = Vec3A::new(-1.6, 1.6, 1.7);
    let targets: Vec<Vec3A> = (0..4000)
        .map(|k| {
            let (u, v) = ((k % 64) as f32 / 64.0, (k / 64) as f32 / 64.0);
            Vec3A::new(-1.1 + 0.6 * u, 0.5 + 0.6 * v, 0.75 + 0.5 * ((k * 7) % 13) as f32 / 13.0)
        })
        .collect();
    let turns = [Vec3A::new(0.3, -0.2, 0.1), Vec3A::new(-0.5, 0.4, -0.6), Vec3A::new(0.05, 0.9, -0.3)];
    let answered = check(&prims, eye, &targets, &turns);
    assert!(answered > 1000, "{answered} rays answered inside the balls");
}
