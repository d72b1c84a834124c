//! The BVH returns the same closest hit and the same occlusion answers as the brute-force list.

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume_accel::{Accelerator, BruteForce, Bvh};
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

#[test]
fn bvh_matches_brute_force_on_random_scenes() {
    let mut rng = Pcg32::new(7, 11);
    for (scene_index, n) in [1usize, 2, 7, 40, 300, 2000].into_iter().enumerate() {
        let mut prims = random_scene(&mut rng, n);
        if scene_index % 2 == 0 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -12.0, 0.0), normal: Vec3A::Y }));
        }
        let brute = BruteForce::new(prims.clone());
        let bvh = Bvh::new(prims, Interval::new(0.0, 1.0));
        let mut hits = 0;
        for _ in 0..3000 {
            let o = point(&mut rng, 15.0);
            let d = (point(&mut rng, 10.0) - o).normalize();
            let ray = Ray::with_time(o, d, uniform(&mut rng));
            let a = brute.closest_hit(&ray, Interval::POSITIVE);
            let b = bvh.closest_hit(&ray, Interval::POSITIVE);
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    assert_eq!(a.primitive, b.primitive, "scene {n}: {ray:?}");
                    assert!((a.hit.t - b.hit.t).abs() <= 1e-6 * a.hit.t.abs().max(1.0));
                }
                _ => panic!("scene of {n}: brute {a:?} vs bvh {b:?} for {ray:?}"),
            }
            let t_max = uniform(&mut rng) * 30.0;
            assert_eq!(brute.occluded(&ray, t_max), bvh.occluded(&ray, t_max), "occlusion, scene {n}");
        }
        assert!(hits > 0, "the rays must hit something in scene {n}");
    }
}

#[test]
fn bvh_handles_many_coincident_primitives() {
    // Identical centroids cannot be split by position; the build must still terminate and be correct.
    let s = Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 });
    let bvh = Bvh::new(vec![s; 1000], Interval::new(0.0, 0.0));
    let hit = bvh.closest_hit(&Ray::new(Vec3A::new(0.0, 0.0, 5.0), -Vec3A::Z), Interval::POSITIVE).unwrap();
    assert!((hit.hit.t - 4.0).abs() < 1e-5);
    assert!(bvh.node_count() > 1);
}
