//! Every accelerator returns the same closest hit and the same occlusion answers as the brute-force
//! list: on seeded random scenes, and as a property over random spheres, triangles, boxes and rays.

use proptest::prelude::*;
use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume_accel::{Accelerator, BruteForce, Bvh, BvhBuild, BvhKernel, Grid, GridParams, PrimitiveHit};
use raylume_geometry::{AaBox, Aabb, Interval, MovingSphere, Plane, Ray, Sphere, Triangle, Vec3A};
use raylume_intersect::Primitive;

fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn point(rng: &mut Pcg32, scale: f32) -> Vec3A {
    Vec3A::new(uniform(rng), uniform(rng), uniform(rng)) * (2.0 * scale) - Vec3A::splat(scale)
}

fn random_scene(rng: &mut Pcg32, n: usize) -> Vec<Primitive> {
    (0..n)
        .map(|i| match i % 5 {
            0 => Primitive::Sphere(Sphere { center: point(rng, 10.0), radius: 0.1 + uniform(rng) }),
            1 => {
                let c = point(rng, 10.0);
                Primitive::Triangle(Triangle::new(c, c + point(rng, 1.5), c + point(rng, 1.5)))
            }
            2 => {
                let c = point(rng, 10.0);
                Primitive::Box(AaBox { bounds: Aabb::new(c, c + point(rng, 1.0).abs() + Vec3A::splat(0.01)) })
            }
            3 => {
                let c = point(rng, 10.0);
                Primitive::MovingSphere(MovingSphere {
                    center0: c,
                    center1: c + point(rng, 2.0),
                    radius: 0.5,
                    time0: 0.0,
                    time1: 1.0,
                })
            }
            _ => Primitive::Triangle(Triangle::new(point(rng, 10.0), point(rng, 10.0), point(rng, 10.0))),
        })
        .collect()
}

/// `bvh`, once its invariants are checked ([`Bvh::validate`]).
fn checked<P>(bvh: Bvh<P>) -> Bvh<P> {
    assert_eq!(bvh.validate(), Ok(()));
    bvh
}

/// Every BVH build over random scenes (of each size, kernel and build method, with many coincident
/// primitives) keeps the hierarchy's invariants.
#[test]
fn bvhs_are_valid_on_random_scenes() {
    let still = Interval::new(0.0, 0.0);
    for seed in 0..12u64 {
        let mut rng = Pcg32::new(seed, 5);
        let n = [1, 2, 7, 40, 300, 3000][seed as usize % 6];
        let mut prims = random_scene(&mut rng, n);
        if seed % 4 == 3 {
            prims.extend(prims.clone());
            prims.push(Primitive::Plane(Plane { point: Vec3A::ZERO, normal: Vec3A::Y }));
        }
        for build in [BvhBuild::Sah, BvhBuild::Midpoint] {
            for kernel in [BvhKernel::Portable, BvhKernel::best()] {
                let bvh = Bvh::with_kernel(prims.clone(), Interval::new(0.0, 1.0), build, kernel);
                assert_eq!(bvh.validate(), Ok(()), "seed {seed}, {build:?}, {kernel:?}");
                let sphere = Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 });
                let tri = Primitive::Triangle(Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y));
                for same in [vec![sphere; 1 + 97 * seed as usize], vec![tri; 1 + 97 * seed as usize]] {
                    assert_eq!(Bvh::with_kernel(same, still, build, kernel).validate(), Ok(()));
                }
            }
        }
    }
}

/// Whether two closest hits agree: the same primitive at t within 1e-6 relative, or a tie between two
/// primitives hit at the same distance (both answers are right).
fn same_hit(prims: &[Primitive], ray: &Ray, a: Option<PrimitiveHit>, b: Option<PrimitiveHit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            let close = (a.hit.t - b.hit.t).abs() <= 1e-6 * a.hit.t.abs().max(1e-3);
            close
                && (a.primitive == b.primitive || {
                    use raylume_intersect::Intersect;
                    let ta = prims[a.primitive as usize].intersect(ray, Interval::POSITIVE).map(|h| h.t);
                    let tb = prims[b.primitive as usize].intersect(ray, Interval::POSITIVE).map(|h| h.t);
                    ta == tb
                })
        }
        _ => false,
    }
}

/// A query: the closest hit of a ray, and whether it is occluded before `t_max`.
type Query = Box<dyn Fn(&Ray, f32) -> (Option<PrimitiveHit>, bool)>;

/// Every accelerator over `prims`, by name.
fn all_accels(prims: &[Primitive], shutter: Interval) -> Vec<(&'static str, Query)> {
    let bvh = checked(Bvh::new(prims.to_vec(), shutter));
    let portable = checked(Bvh::with_kernel(prims.to_vec(), shutter, BvhBuild::Sah, BvhKernel::Portable));
    let mid = checked(Bvh::with_build(prims.to_vec(), shutter, BvhBuild::Midpoint));
    let grid = Grid::new(prims.to_vec(), shutter, GridParams::default());
    let grid_no_mailbox = Grid::new(prims.to_vec(), shutter, GridParams { k: 5.0, mailbox: false });
    vec![
        ("bvh", Box::new(move |r: &Ray, t: f32| (bvh.closest_hit(r, Interval::POSITIVE), bvh.occluded(r, t)))),
        (
            "bvh-portable",
            Box::new(move |r: &Ray, t: f32| (portable.closest_hit(r, Interval::POSITIVE), portable.occluded(r, t))),
        ),
        ("bvh-midpoint", Box::new(move |r: &Ray, t: f32| (mid.closest_hit(r, Interval::POSITIVE), mid.occluded(r, t)))),
        ("grid", Box::new(move |r: &Ray, t: f32| (grid.closest_hit(r, Interval::POSITIVE), grid.occluded(r, t)))),
        (
            "grid-k5-no-mailbox",
            Box::new(move |r: &Ray, t: f32| {
                (grid_no_mailbox.closest_hit(r, Interval::POSITIVE), grid_no_mailbox.occluded(r, t))
            }),
        ),
    ]
}

/// Asserts that every accelerator answers `ray` as brute force does (closest hit, and occlusion
/// before `t_max`); returns whether the ray hits anything.
fn check_against_brute_force(
    prims: &[Primitive],
    brute: &BruteForce<Primitive>,
    accels: &[(&'static str, Query)],
    ray: &Ray,
    t_max: f32,
) -> bool {
    let expected = brute.closest_hit(ray, Interval::POSITIVE);
    let expected_occluded = brute.occluded(ray, t_max);
    for (name, query) in accels {
        let (got, occluded) = query(ray, t_max);
        assert!(same_hit(prims, ray, expected, got), "{name}: brute {expected:?} vs {got:?} for {ray:?}");
        assert_eq!(occluded, expected_occluded, "{name}: occlusion of {ray:?} before {t_max}");
    }
    expected.is_some()
}

#[test]
fn accelerators_match_brute_force_on_random_scenes() {
    let mut rng = Pcg32::new(7, 11);
    for (scene_index, n) in [1usize, 2, 7, 40, 300, 2000].into_iter().enumerate() {
        let mut prims = random_scene(&mut rng, n);
        if scene_index % 2 == 0 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -12.0, 0.0), normal: Vec3A::Y }));
        }
        let brute = BruteForce::new(prims.clone());
        let accels = all_accels(&prims, Interval::new(0.0, 1.0));
        let mut hits = 0;
        for _ in 0..3000 {
            let o = point(&mut rng, 15.0);
            let d = (point(&mut rng, 10.0) - o).normalize();
            let ray = Ray::with_time(o, d, uniform(&mut rng));
            let t_max = uniform(&mut rng) * 30.0;
            hits += check_against_brute_force(&prims, &brute, &accels, &ray, t_max) as usize;
        }
        assert!(hits > 0, "the rays must hit something in scene {n}");
    }
}

#[test]
fn grid_mailbox_tests_fewer_primitives() {
    let mut rng = Pcg32::new(3, 5);
    // Long thin triangles span many cells: the case mailboxing exists for.
    let prims: Vec<Primitive> = (0..500)
        .map(|_| {
            let c = point(&mut rng, 10.0);
            Primitive::Triangle(Triangle::new(c, c + point(&mut rng, 6.0), c + point(&mut rng, 0.3)))
        })
        .collect();
    let shutter = Interval::new(0.0, 0.0);
    let with = Grid::new(prims.clone(), shutter, GridParams { k: 8.0, mailbox: true });
    let without = Grid::new(prims.clone(), shutter, GridParams { k: 8.0, mailbox: false });
    let (mut a, mut b) = (0u64, 0u64);
    for _ in 0..2000 {
        let o = point(&mut rng, 15.0);
        let ray = Ray::new(o, (point(&mut rng, 10.0) - o).normalize());
        let x = with.closest_hit_tally(&ray, Interval::POSITIVE, &mut a);
        let y = without.closest_hit_tally(&ray, Interval::POSITIVE, &mut b);
        assert!(same_hit(&prims, &ray, x, y));
    }
    println!("primitives tested per ray: {:.2} with mailboxing, {:.2} without", a as f64 / 2000.0, b as f64 / 2000.0);
    assert!((a as f64) < 0.8 * b as f64, "mailboxing must save tests: {a} vs {b}");
}

/// A model on a large floor, as in the course's scenes: the grid tests the floor's triangles directly
/// and spans its lattice over the model only, and answers as brute force does, ties between the floor
/// and the triangles lying in it included.
#[test]
fn grid_over_a_floor_matches_brute_force() {
    let mut rng = Pcg32::new(17, 3);
    let (a, b, c, d) = (
        Vec3A::new(-20.0, -1.0, -20.0),
        Vec3A::new(20.0, -1.0, -20.0),
        Vec3A::new(20.0, -1.0, 20.0),
        Vec3A::new(-20.0, -1.0, 20.0),
    );
    let mut prims: Vec<Primitive> =
        tessellated_cube(Vec3A::new(0.0, 0.2, 0.0), 0.5, 6).into_iter().map(Primitive::Triangle).collect();
    prims.extend((0..200).map(|_| Primitive::Sphere(Sphere { center: point(&mut rng, 1.0), radius: 0.05 })));
    // Small triangles in the floor's plane, before and after it in index order: ties at one distance.
    prims.push(Primitive::Triangle(Triangle::new(
        Vec3A::new(-1.0, -1.0, -1.0),
        Vec3A::new(1.0, -1.0, -1.0),
        Vec3A::new(1.0, -1.0, 1.0),
    )));
    prims.extend([Triangle::new(a, b, c), Triangle::new(a, c, d), Triangle::new(a, b, c)].map(Primitive::Triangle));
    prims.push(Primitive::Triangle(Triangle::new(
        Vec3A::new(-1.0, -1.0, -1.0),
        Vec3A::new(1.0, -1.0, 1.0),
        Vec3A::new(-1.0, -1.0, 1.0),
    )));
    let still = Interval::new(0.0, 0.0);
    let grid = Grid::new(prims.clone(), still, GridParams::default());
    assert!(grid.resolution().iter().all(|&n| n >= 8), "a lattice over the model: {:?}", grid.resolution());
    let brute = BruteForce::new(prims.clone());
    let accels = all_accels(&prims, still);
    let mut hits = 0;
    for i in 0..4000 {
        let o = point(&mut rng, 6.0) + Vec3A::new(0.0, 5.0, 0.0);
        let target = if i % 2 == 0 {
            point(&mut rng, 1.2)
        } else {
            point(&mut rng, 10.0) * Vec3A::new(1.0, 0.0, 1.0) - Vec3A::Y
        };
        let ray = Ray::new(o, (target - o).normalize());
        hits += check_against_brute_force(&prims, &brute, &accels, &ray, uniform(&mut rng) * 20.0) as usize;
    }
    assert!(hits > 3000, "the rays must hit the model and the floor: {hits}");
}

fn arb_point(range: f32) -> impl Strategy<Value = Vec3A> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
}

fn arb_primitive() -> impl Strategy<Value = Primitive> {
    prop_oneof![
        (arb_point(8.0), 0.05f32..2.0).prop_map(|(c, r)| Primitive::Sphere(Sphere { center: c, radius: r })),
        (arb_point(8.0), arb_point(2.0), arb_point(2.0)).prop_map(|(a, b, c)| Primitive::Triangle(Triangle::new(
            a,
            a + b,
            a + c
        ))),
        (arb_point(8.0), arb_point(1.5))
            .prop_map(|(a, s)| Primitive::Box(AaBox { bounds: Aabb::new(a, a + s.abs() + Vec3A::splat(0.01)) })),
    ]
}

fn arb_ray() -> impl Strategy<Value = Ray> {
    (arb_point(12.0), arb_point(1.0), prop_oneof![Just(0u8), Just(1), Just(2), Just(3)]).prop_filter_map(
        "non-zero direction",
        |(o, d, axis)| {
            // Some rays run exactly along an axis (zero components), the rest anywhere.
            let d = match axis {
                1 => Vec3A::new(d.x, 0.0, 0.0),
                2 => Vec3A::new(0.0, -0.0, d.z),
                _ => d,
            };
            (d.length() > 1e-3).then(|| Ray::new(o, d.normalize()))
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// All accelerators agree with brute force on random scenes and rays.
    #[test]
    fn accelerators_agree_with_brute_force(prims in prop::collection::vec(arb_primitive(), 1..60),
                                           rays in prop::collection::vec(arb_ray(), 1..40),
                                           t_max in 0.1f32..40.0) {
        let brute = BruteForce::new(prims.clone());
        let accels = all_accels(&prims, Interval::new(0.0, 0.0));
        for ray in &rays {
            let expected = brute.closest_hit(ray, Interval::POSITIVE);
            let expected_occluded = brute.occluded(ray, t_max);
            for (name, query) in &accels {
                let (got, occluded) = query(ray, t_max);
                prop_assert!(same_hit(&prims, ray, expected, got), "{}: brute {:?} vs {:?} for {:?}", name, expected, got, ray);
                prop_assert_eq!(occluded, expected_occluded, "{}: occlusion for {:?}", name, ray);
            }
        }
    }
}

#[test]
fn bvh_handles_many_coincident_primitives() {
    // Identical centroids cannot be split by position; the build must still terminate and be correct.
    let s = Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 });
    let bvh = checked(Bvh::new(vec![s; 1000], Interval::new(0.0, 0.0)));
    let hit = bvh.closest_hit(&Ray::new(Vec3A::new(0.0, 0.0, 5.0), -Vec3A::Z), Interval::POSITIVE).unwrap();
    assert!((hit.hit.t - 4.0).abs() < 1e-5);
    assert!(bvh.node_count() > 1);
}

/// Closed meshes among other shapes: bundles of neighbouring rays (one origin, targets 0.05 apart,
/// as a view's pixels) and scattered ones get the answers of brute force, through shared edges and
/// vertices and through leaves of one and two triangle packets.
#[test]
fn closed_meshes_match_brute_force() {
    let mut rng = Pcg32::new(21, 5);
    let mut hits = 0;
    for n in [1usize, 9, 120, 1500] {
        let mut prims = random_scene(&mut rng, n);
        if n % 2 == 1 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -12.0, 0.0), normal: Vec3A::Y }));
        }
        for c in 0..3 {
            let centre = point(&mut rng, 8.0);
            let scale = 1.0 + 3.0 * uniform(&mut rng);
            prims.extend(tessellated_cube(centre, scale, 3 + c).into_iter().map(Primitive::Triangle));
        }
        let brute = BruteForce::new(prims.clone());
        let accels = all_accels(&prims, Interval::new(0.0, 1.0));
        for b in 0..600 {
            let o = point(&mut rng, 15.0);
            let aim = point(&mut rng, 10.0);
            for k in 0..4 {
                let target =
                    if b % 3 != 0 { aim + Vec3A::new(k as f32 * 0.05, 0.0, 0.0) } else { point(&mut rng, 10.0) };
                let ray = Ray::with_time(o, (target - o).normalize(), uniform(&mut rng));
                let t_max = uniform(&mut rng) * 30.0;
                hits += check_against_brute_force(&prims, &brute, &accels, &ray, t_max) as usize;
            }
        }
    }
    assert!(hits > 1000, "the rays must hit things: {hits}");
}

/// The surface of a cube split into `n x n` squares per face, two triangles each; every vertex is
/// computed from its lattice point, so faces share their edges exactly.
fn tessellated_cube(centre: Vec3A, half: f32, n: u32) -> Vec<Triangle> {
    let at = |p: [u32; 3]| centre + (Vec3A::new(p[0] as f32, p[1] as f32, p[2] as f32) * (2.0 / n as f32) - 1.0) * half;
    let mut tris = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: u32, dj: u32| {
                        let mut p = [0; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = i + di;
                        p[(axis + 2) % 3] = j + dj;
                        at(p)
                    };
                    let (a, b, c, d) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
                    tris.push(Triangle::new(a, b, c));
                    tris.push(Triangle::new(a, c, d));
                }
            }
        }
    }
    tris
}

/// A tile of `side x side` rays from `origin` (jittered by up to `lens` for a thin lens) through a
/// grid of targets `spacing` apart around `aim`: the rays `closest_hits` and `occluded_each` take
/// together.
fn tile(rng: &mut Pcg32, origin: Vec3A, aim: Vec3A, spacing: f32, lens: f32, side: usize) -> Vec<Ray> {
    (0..side * side)
        .map(|i| {
            let (x, y) = ((i % side) as f32, (i / side) as f32);
            let o = origin + Vec3A::new(uniform(rng) - 0.5, uniform(rng) - 0.5, 0.0) * lens;
            let target = aim + Vec3A::new(x * spacing, y * spacing, (x - y) * spacing * 0.3);
            Ray::with_time(o, (target - o).normalize(), uniform(rng))
        })
        .collect()
}

/// The batch queries answer every ray as the single-ray ones do, on closed meshes among other
/// shapes: tiles of neighbouring rays (one origin, or a lens's), tiles wide enough to straddle
/// leaves and the mesh's silhouette, batches longer and shorter than a packet, and incoherent
/// batches (directions of mixed signs, axis-parallel rays) that take the single-ray path.
#[test]
fn batches_match_single_rays() {
    let mut rng = Pcg32::new(5, 77);
    let mut hits = 0;
    for n in [0usize, 7, 300] {
        let mut prims = random_scene(&mut rng, n);
        if n == 7 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -12.0, 0.0), normal: Vec3A::Y }));
        }
        for c in 0..3 {
            let centre = point(&mut rng, 6.0);
            prims.extend(
                tessellated_cube(centre, 1.0 + 3.0 * uniform(&mut rng), 4 + 3 * c).into_iter().map(Primitive::Triangle),
            );
        }
        let shutter = Interval::new(0.0, 1.0);
        let bvh = checked(Bvh::new(prims.clone(), shutter));
        let portable = checked(Bvh::with_kernel(prims.clone(), shutter, BvhBuild::Sah, BvhKernel::Portable));
        let grid = Grid::new(prims.clone(), shutter, GridParams::default());
        for b in 0..120 {
            let origin = point(&mut rng, 18.0);
            let aim = point(&mut rng, 6.0);
            let spacing = [0.002, 0.05, 0.4][b % 3];
            let lens = if b % 4 == 0 { 0.5 } else { 0.0 };
            let side = [8, 5, 11][b % 3];
            let mut rays = tile(&mut rng, origin, aim, spacing, lens, side);
            if b % 10 == 0 {
                // An incoherent batch, with rays along the axes.
                rays.push(Ray::new(origin, Vec3A::X));
                rays.push(Ray::new(origin, -Vec3A::Y));
                rays.push(Ray::new(origin, (aim - origin).normalize() * Vec3A::new(1.0, -1.0, 1.0)));
            }
            let t_range = if b % 5 == 0 { Interval::new(0.5, 25.0) } else { Interval::POSITIVE };
            let t_max = uniform(&mut rng) * 40.0;
            let mut got = vec![None; rays.len()];
            let mut occluded = vec![false; rays.len()];
            for (name, accel) in [("bvh", &bvh as &dyn BatchQueries), ("bvh-portable", &portable), ("grid", &grid)] {
                accel.batch_closest(&rays, t_range, &mut got);
                accel.batch_occluded(&rays, t_max, &mut occluded);
                for (i, ray) in rays.iter().enumerate() {
                    let expected = accel.single_closest(ray, t_range);
                    assert!(
                        same_hit(&prims, ray, expected, got[i]),
                        "{name}: single {expected:?} vs batch {:?} for {ray:?}",
                        got[i]
                    );
                    assert_eq!(
                        occluded[i],
                        accel.single_occluded(ray, t_max),
                        "{name}: occlusion of {ray:?} before {t_max}"
                    );
                    hits += got[i].is_some() as usize;
                }
            }
        }
    }
    assert!(hits > 5000, "the rays must hit things: {hits}");
}

/// Shadow rays from neighbouring points to one light, each with its own end (the light's distance,
/// short of it, past it, or NaN), are answered by `occluded_each_within` as the single-ray query
/// answers each: patches of points on closed meshes among other shapes and a plane, lights on every
/// side (so some batches mix the directions' signs), batches longer and shorter than a packet.
#[test]
fn shadow_batches_with_their_own_ends_match_single_rays() {
    let mut rng = Pcg32::new(12, 5);
    let (mut occluded_count, mut total) = (0, 0);
    for n in [0usize, 9, 200] {
        let mut prims = random_scene(&mut rng, n);
        if n == 9 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -12.0, 0.0), normal: Vec3A::Y }));
        }
        for c in 0..3 {
            let centre = point(&mut rng, 6.0);
            prims.extend(
                tessellated_cube(centre, 1.0 + 3.0 * uniform(&mut rng), 4 + 3 * c).into_iter().map(Primitive::Triangle),
            );
        }
        let shutter = Interval::new(0.0, 1.0);
        let bvh = checked(Bvh::new(prims.clone(), shutter));
        let portable = checked(Bvh::with_kernel(prims.clone(), shutter, BvhBuild::Sah, BvhKernel::Portable));
        let grid = Grid::new(prims.clone(), shutter, GridParams::default());
        for b in 0..100 {
            let light = point(&mut rng, 20.0);
            let centre = point(&mut rng, 8.0);
            let spread = [0.01, 0.3, 3.0][b % 3];
            let count = [64, 37, 130][b % 3];
            let mut rays = Vec::new();
            let mut ends = Vec::new();
            for i in 0..count {
                let from = centre + point(&mut rng, spread);
                let to_light = light - from;
                let dist = to_light.length();
                rays.push(Ray::with_time(from, to_light / dist, uniform(&mut rng)));
                ends.push(match i % 7 {
                    0 => dist * 0.5,
                    1 => dist * 2.0,
                    2 if b % 4 == 0 => f32::NAN,
                    _ => dist,
                });
            }
            let mut occluded = vec![false; count];
            for (name, accel) in [("bvh", &bvh as &dyn BatchQueries), ("bvh-portable", &portable), ("grid", &grid)] {
                accel.batch_occluded_within(&rays, &ends, &mut occluded);
                for (i, ray) in rays.iter().enumerate() {
                    assert_eq!(occluded[i], accel.single_occluded(ray, ends[i]), "{name}: {ray:?} before {}", ends[i]);
                    occluded_count += occluded[i] as usize;
                    total += 1;
                }
            }
        }
    }
    assert!(occluded_count > total / 10 && occluded_count < total * 9 / 10, "{occluded_count} of {total} occluded");
}

/// The batch and single-ray queries of an accelerator, as an object.
trait BatchQueries {
    fn batch_closest(&self, rays: &[Ray], t_range: Interval, hits: &mut [Option<PrimitiveHit>]);
    fn batch_occluded(&self, rays: &[Ray], t_max: f32, occluded: &mut [bool]);
    fn batch_occluded_within(&self, rays: &[Ray], t_max: &[f32], occluded: &mut [bool]);
    fn single_closest(&self, ray: &Ray, t_range: Interval) -> Option<PrimitiveHit>;
    fn single_occluded(&self, ray: &Ray, t_max: f32) -> bool;
}

impl<A: Accelerator> BatchQueries for A {
    fn batch_closest(&self, rays: &[Ray], t_range: Interval, hits: &mut [Option<PrimitiveHit>]) {
        self.closest_hits(rays, t_range, hits)
    }
    fn batch_occluded(&self, rays: &[Ray], t_max: f32, occluded: &mut [bool]) {
        self.occluded_each(rays, t_max, occluded)
    }
    fn batch_occluded_within(&self, rays: &[Ray], t_max: &[f32], occluded: &mut [bool]) {
        self.occluded_each_within(rays, t_max, occluded)
    }
    fn single_closest(&self, ray: &Ray, t_range: Interval) -> Option<PrimitiveHit> {
        self.closest_hit(ray, t_range)
    }
    fn single_occluded(&self, ray: &Ray, t_max: f32) -> bool {
        Accelerator::occluded(self, ray, t_max)
    }
}

/// Batches agree with single rays at tiny and huge scales and far from the origin, where the packet's
/// interval arithmetic overflows or underflows: closed meshes scaled by 1e-5 to 1e5 and moved by 1e3
/// times their size, rays from a point and from a lens, grazing tiles included.
#[test]
fn batches_match_single_rays_at_extreme_scales() {
    let mut rng = Pcg32::new(9, 31);
    let mut hits = 0;
    for scale in [1e-5f32, 1e-2, 1e3, 1e5] {
        let offset = Vec3A::new(1e3, -2e3, 5e2) * scale;
        let mut prims = Vec::new();
        for c in 0..3 {
            let centre = offset + point(&mut rng, 6.0) * scale;
            prims.extend(
                tessellated_cube(centre, scale * (1.0 + 2.0 * uniform(&mut rng)), 5 + 2 * c)
                    .into_iter()
                    .map(Primitive::Triangle),
            );
        }
        let bvh = checked(Bvh::new(prims.clone(), Interval::new(0.0, 0.0)));
        let portable =
            checked(Bvh::with_kernel(prims.clone(), Interval::new(0.0, 0.0), BvhBuild::Sah, BvhKernel::Portable));
        for b in 0..60 {
            let origin = offset + point(&mut rng, 20.0) * scale;
            let aim = offset + point(&mut rng, 6.0) * scale;
            let spacing = [0.001, 0.05, 0.5][b % 3] * scale;
            let lens = if b % 2 == 0 { 0.3 * scale } else { 0.0 };
            let mut rays = tile(&mut rng, origin, aim, spacing, lens, 8);
            if b % 6 == 0 {
                // Grazing: rays nearly in the plane of a face.
                let d = Vec3A::new(1.0, 1e-4 * uniform(&mut rng), 0.5 - uniform(&mut rng)).normalize();
                rays.iter_mut().for_each(|r| r.dir = (d + r.dir * 1e-3).normalize());
            }
            let mut got = vec![None; rays.len()];
            let mut occluded = vec![false; rays.len()];
            bvh.closest_hits(&rays, Interval::POSITIVE, &mut got);
            let t_max = 30.0 * scale;
            bvh.occluded_each(&rays, t_max, &mut occluded);
            for (i, ray) in rays.iter().enumerate() {
                let expected = bvh.closest_hit(ray, Interval::POSITIVE);
                assert!(
                    same_hit(&prims, ray, expected, got[i]),
                    "scale {scale}: single {expected:?} vs batch {:?}",
                    got[i]
                );
                assert_eq!(occluded[i], bvh.occluded(ray, t_max), "scale {scale}: occlusion of {ray:?}");
                // The portable kernel's single rays too (the batches above walk its tree).
                assert!(same_hit(&prims, ray, expected, portable.closest_hit(ray, Interval::POSITIVE)));
                assert_eq!(occluded[i], portable.occluded(ray, t_max), "scale {scale}: portable occlusion of {ray:?}");
                hits += got[i].is_some() as usize;
            }
        }
    }
    assert!(hits > 2000, "the rays must hit things: {hits}");
}

/// The shapes other than triangles answer a packet bit for bit as they answer each of its rays:
/// spheres, boxes and moving spheres among closed meshes and on their own, at sizes of 1e-4 and 1e4
/// far from the origin as well as 1, each shape also held twice (a tie its lower
/// index wins), rays in tiles from a point and from a lens, with and without a minimum distance,
/// shadow rays to one light from a patch of points.
#[test]
fn other_shapes_answer_packets_as_single_rays_bit_for_bit() {
    let mut rng = Pcg32::new(41, 3);
    let (mut hits, mut ties, mut occluded_count) = (0, 0, 0);
    for n in [3usize, 12, 60] {
        let mut prims: Vec<Primitive> =
            random_scene(&mut rng, 5 * n).into_iter().filter(|p| !matches!(p, Primitive::Triangle(_))).collect();
        let twins: Vec<Primitive> = prims.iter().step_by(2).cloned().collect();
        let twin_ids = prims.len() as u32..(prims.len() + twins.len()) as u32;
        prims.extend(twins);
        if n != 12 {
            let centre = point(&mut rng, 6.0);
            prims.extend(tessellated_cube(centre, 2.0, 6).into_iter().map(Primitive::Triangle));
        }
        // Tiny far from the origin, as it is, and huge.
        let (scale, offset) = match n {
            3 => (1e-4, Vec3A::new(3e3, -1e3, 2e3)),
            60 => (1e4, Vec3A::new(-2e4, 5e4, 1e4)),
            _ => (1.0, Vec3A::ZERO),
        };
        let at = |p: Vec3A| offset + p * scale;
        let prims: Vec<Primitive> = prims.iter().map(|p| moved(p, scale, offset)).collect();
        for kernel in [BvhKernel::Portable, BvhKernel::best()] {
            for build in [BvhBuild::Sah, BvhBuild::Midpoint] {
                let bvh = checked(Bvh::with_kernel(prims.clone(), Interval::new(0.0, 1.0), build, kernel));
                for b in 0..40 {
                    let origin = at(point(&mut rng, 18.0));
                    let aim = at(point(&mut rng, 8.0));
                    let (spacing, lens) = ([0.002, 0.05, 0.4][b % 3] * scale, [0.0, 0.3][b % 2] * scale);
                    let rays = tile(&mut rng, origin, aim, spacing, lens, 8);
                    let t_range =
                        if b % 4 == 1 { Interval::new(3.0 * scale, 40.0 * scale) } else { Interval::POSITIVE };
                    let mut got = vec![None; rays.len()];
                    bvh.closest_hits(&rays, t_range, &mut got);
                    for (ray, got) in rays.iter().zip(&got) {
                        let expected = bvh.closest_hit(ray, t_range);
                        let bits = |h: Option<PrimitiveHit>| {
                            h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.point.to_array().map(f32::to_bits)))
                        };
                        assert_eq!(bits(*got), bits(expected), "{kernel:?} {build:?}: {ray:?} in {t_range:?}");
                        hits += got.is_some() as usize;
                        ties += got.is_some_and(|h| twin_ids.contains(&h.primitive)) as usize;
                    }
                    // Shadow rays from a patch of points towards one light, each with its own end.
                    let light = at(point(&mut rng, 20.0));
                    let from = point(&mut rng, 8.0);
                    let (mut shadow, mut ends) = (Vec::new(), Vec::new());
                    for i in 0..64 {
                        let p = at(from + point(&mut rng, [0.01, 0.3, 2.0][b % 3]));
                        shadow.push(Ray::new(p, (light - p).normalize()));
                        ends.push((light - p).length() * [1.0, 0.5, 2.0][i % 3]);
                    }
                    let mut occluded = vec![false; shadow.len()];
                    bvh.occluded_each_within(&shadow, &ends, &mut occluded);
                    for ((ray, &t), &o) in shadow.iter().zip(&ends).zip(&occluded) {
                        assert_eq!(o, bvh.occluded(ray, t), "{kernel:?} {build:?}: occlusion of {ray:?} before {t}");
                        occluded_count += o as usize;
                    }
                }
            }
        }
    }
    assert!(hits > 4_000 && occluded_count > 2_500, "the rays must hit things: {hits} hits, {occluded_count} occluded");
    assert_eq!(ties, 0, "a shape held twice is reported under its lower index");
}

/// `p` scaled by `scale` about the origin, then moved by `offset`.
fn moved(p: &Primitive, scale: f32, offset: Vec3A) -> Primitive {
    let at = |v: Vec3A| offset + v * scale;
    match *p {
        Primitive::Sphere(s) => Primitive::Sphere(Sphere { center: at(s.center), radius: s.radius * scale }),
        Primitive::MovingSphere(m) => Primitive::MovingSphere(MovingSphere {
            center0: at(m.center0),
            center1: at(m.center1),
            radius: m.radius * scale,
            ..m
        }),
        Primitive::Box(b) => Primitive::Box(AaBox { bounds: Aabb::new(at(b.bounds.min), at(b.bounds.max)) }),
        Primitive::Triangle(t) => Primitive::Triangle(Triangle::new(at(t.p[0]), at(t.p[1]), at(t.p[2]))),
        other => other,
    }
}

/// The list that tests boxes first answers every ray bit for bit as the list that runs every
/// primitive's routine: random scenes of every shape, moving spheres over the shutter, planes and
/// degenerate triangles (always tested), rays in every direction, with their times, ranges and
/// shadow ends.
#[test]
fn boxed_list_answers_as_the_exhaustive_one_bit_for_bit() {
    let mut rng = Pcg32::new(77, 8);
    let (mut hits, mut occluded_count) = (0, 0);
    for n in [1usize, 5, 17, 90] {
        let mut prims = random_scene(&mut rng, n);
        prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -11.0, 0.0), normal: Vec3A::Y }));
        let p = point(&mut rng, 5.0);
        prims.push(Primitive::Triangle(Triangle::new(p, p + Vec3A::X, p + 2.0 * Vec3A::X)));
        let shutter = Interval::new(0.0, 1.0);
        let (exhaustive, boxed) = (BruteForce::new(prims.clone()), BruteForce::with_boxes(prims.clone(), shutter));
        for _ in 0..3000 {
            let mut ray =
                Ray::new(point(&mut rng, 20.0), point(&mut rng, 1.0) * [1.0, 1e-3, 8.0][rng.next_u32() as usize % 3]);
            ray.time = uniform(&mut rng);
            let t_range = if rng.next_u32() % 3 == 0 { Interval::new(2.0, 30.0) } else { Interval::POSITIVE };
            let bits = |h: Option<PrimitiveHit>| {
                h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.point.to_array().map(f32::to_bits)))
            };
            let expected = exhaustive.closest_hit(&ray, t_range);
            assert_eq!(bits(boxed.closest_hit(&ray, t_range)), bits(expected), "{ray:?} in {t_range:?}");
            let t_max = 40.0 * uniform(&mut rng);
            let occluded = exhaustive.occluded(&ray, t_max);
            assert_eq!(boxed.occluded(&ray, t_max), occluded, "{ray:?} before {t_max}");
            hits += expected.is_some() as usize;
            occluded_count += occluded as usize;
        }
    }
    assert!(hits > 3000 && occluded_count > 2000, "the rays must hit things: {hits} hits, {occluded_count} occluded");
}

/// Triangles answer a packet bit for bit as they answer each of its rays, however a packet's rays
/// are grouped at a leaf: a floor of two large triangles under closed meshes (leaves of one to eight
/// triangles, most rays of a tile meeting the same ones), each triangle also held twice (a tie its
/// lower index wins), at sizes of 1e-4 and 1e4 far from the origin as well as 1; tiles from a point
/// and from a lens, with and without a minimum distance; then shadow rays that start exactly on the
/// tile's hits (the triangle they leave is too close to call in f32) towards one light, each with its
/// own end; and rays aimed exactly at the meshes' vertices, where edge functions are too close to call.
#[test]
fn triangle_packets_answer_as_single_rays_bit_for_bit() {
    let mut rng = Pcg32::new(23, 9);
    let (mut hits, mut ties, mut occluded_count) = (0, 0, 0);
    for (scale, offset) in [(1.0, Vec3A::ZERO), (1e-4, Vec3A::new(3e3, -1e3, 2e3)), (1e4, Vec3A::new(-2e4, 5e4, 1e4))] {
        let at = |p: Vec3A| offset + p * scale;
        let mut tris = vec![
            Triangle::new(Vec3A::new(-30.0, -8.0, -30.0), Vec3A::new(30.0, -8.0, -30.0), Vec3A::new(30.0, -8.0, 30.0)),
            Triangle::new(Vec3A::new(-30.0, -8.0, -30.0), Vec3A::new(30.0, -8.0, 30.0), Vec3A::new(-30.0, -8.0, 30.0)),
        ];
        for c in 0..3 {
            tris.extend(tessellated_cube(point(&mut rng, 6.0), 1.0 + 2.0 * uniform(&mut rng), [1, 3, 6][c]));
        }
        let vertices: Vec<Vec3A> = tris[2..].iter().flat_map(|t| t.p).map(at).collect();
        let mut prims: Vec<Primitive> = tris.into_iter().map(Primitive::Triangle).collect();
        let twins: Vec<Primitive> = prims.iter().step_by(3).cloned().collect();
        let twin_ids = prims.len() as u32..(prims.len() + twins.len()) as u32;
        prims.extend(twins);
        let prims: Vec<Primitive> = prims.iter().map(|p| moved(p, scale, offset)).collect();
        for kernel in [BvhKernel::Portable, BvhKernel::best()] {
            let bvh = checked(Bvh::with_kernel(prims.clone(), Interval::new(0.0, 1.0), BvhBuild::Sah, kernel));
            for b in 0..60 {
                let origin = at(point(&mut rng, 18.0) + Vec3A::new(0.0, 20.0, 0.0));
                let aim = at(point(&mut rng, 6.0));
                let (spacing, lens) = ([0.002, 0.05, 0.4][b % 3] * scale, [0.0, 0.3][b % 2] * scale);
                let rays = tile(&mut rng, origin, aim, spacing, lens, 8);
                let t_range = if b % 4 == 1 { Interval::new(3.0 * scale, 40.0 * scale) } else { Interval::POSITIVE };
                let mut got = vec![None; rays.len()];
                bvh.closest_hits(&rays, t_range, &mut got);
                let bits = |h: Option<PrimitiveHit>| {
                    h.map(|h| {
                        let v = |v: Vec3A| v.to_array().map(f32::to_bits);
                        (
                            h.primitive,
                            h.hit.t.to_bits(),
                            v(h.hit.point),
                            v(h.hit.normal),
                            h.hit.uv.to_array().map(f32::to_bits),
                        )
                    })
                };
                for (ray, got) in rays.iter().zip(&got) {
                    let expected = bvh.closest_hit(ray, t_range);
                    assert_eq!(bits(*got), bits(expected), "{kernel:?}: {ray:?} in {t_range:?}");
                    hits += got.is_some() as usize;
                    ties += got.is_some_and(|h| twin_ids.contains(&h.primitive)) as usize;
                }
                let light = at(point(&mut rng, 20.0) + Vec3A::new(0.0, 30.0, 0.0));
                let (mut shadow, mut ends) = (Vec::new(), Vec::new());
                for (i, h) in got.iter().flatten().enumerate() {
                    shadow.push(Ray::new(h.hit.point, (light - h.hit.point).normalize()));
                    ends.push((light - h.hit.point).length() * [1.0, 0.5, 2.0][i % 3]);
                }
                // From the light through a run of the meshes' vertices.
                let start = rng.next_u32() as usize % vertices.len();
                for (i, &v) in vertices.iter().cycle().skip(start).take(64).enumerate() {
                    let ray = Ray::new(light, (v - light).normalize());
                    let end = (v - light).length() * [2.0, 1.0, 0.999][i % 3];
                    let expected = bvh.closest_hit(&ray, Interval::POSITIVE);
                    let mut one = [None];
                    bvh.closest_hits(&[ray; 4], Interval::POSITIVE, &mut [None; 4]);
                    bvh.closest_hits(std::slice::from_ref(&ray), Interval::POSITIVE, &mut one);
                    assert_eq!(bits(one[0]), bits(expected), "{kernel:?}: {ray:?}");
                    shadow.push(ray);
                    ends.push(end);
                }
                let aimed = &shadow[shadow.len() - 64..];
                let mut got = vec![None; aimed.len()];
                bvh.closest_hits(aimed, Interval::POSITIVE, &mut got);
                for (ray, got) in aimed.iter().zip(&got) {
                    assert_eq!(bits(*got), bits(bvh.closest_hit(ray, Interval::POSITIVE)), "{kernel:?}: {ray:?}");
                }
                let mut occluded = vec![false; shadow.len()];
                bvh.occluded_each_within(&shadow, &ends, &mut occluded);
                for ((ray, &t), &o) in shadow.iter().zip(&ends).zip(&occluded) {
                    assert_eq!(o, bvh.occluded(ray, t), "{kernel:?}: occlusion of {ray:?} before {t}");
                    occluded_count += o as usize;
                }
            }
        }
    }
    assert!(
        hits > 15_000 && occluded_count > 2_000,
        "the rays must hit things: {hits} hits, {occluded_count} occluded"
    );
    assert_eq!(ties, 0, "a triangle held twice is reported under its lower index");
}
