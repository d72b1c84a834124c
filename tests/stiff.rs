//! Stiff and extreme cases of ../shared/robustness-cases.md, each with its measured figure printed.
//! Run in release mode (`cargo test --release --test stiff -- --nocapture` shows the figures).
//!
//! Implemented so far: T1, T6, T7, R1, S1, S3, PL1, B1, G3, X2. The rest of the catalogue (T4, T8,
//! R4, R5, S2, S4, B2, B3, B4, X1) and raylume's own cases are still to come.

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume::accel::{BvhBuild, BvhKernel, Grid, GridParams};
use raylume::geometry::{AaBox, Plane, Sphere, Triangle, offset_ray_origin, spawn_ray_to};
use raylume::intersect::{intersect_moller_trumbore, intersect_watertight};
use raylume::prelude::*;
use raylume::scene::procedural::icosphere;

const U: f64 = 1.0 / (1u64 << 24) as f64;

fn rng(seed: u64) -> Pcg32 {
    Pcg32::new(seed, 0xda3e_39cb_94b9_5bdb)
}

fn unif(r: &mut Pcg32) -> f32 {
    (r.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn unit_vector(r: &mut Pcg32) -> Vec3A {
    let (a, b) = (unif(r), unif(r));
    raylume::geometry::sampling::uniform_sphere(Vec2::new(a, b))
}

/// T1: rays from inside a closed icosphere at random directions, vertices, edge points and edge
/// midpoints must all hit it; Möller–Trumbore's leaks are counted for comparison.
#[test]
fn t1_watertight_closed_icosphere() {
    let (v, f) = icosphere(3);
    assert_eq!((v.len(), f.len()), (642, 1280));
    let tris: Vec<Triangle> =
        f.iter().map(|t| Triangle::new(v[t[0] as usize], v[t[1] as usize], v[t[2] as usize])).collect();
    let prims: Vec<Primitive> = tris.iter().map(|t| Primitive::Triangle(*t)).collect();
    let bvh = Bvh::new(prims.clone(), Interval::new(0.0, 0.0));
    // Both kernels: the eight-wide one where the CPU has AVX2, and the portable one.
    let portable = Bvh::with_kernel(prims, Interval::new(0.0, 0.0), BvhBuild::Sah, BvhKernel::Portable);
    // Edges for the edge-aimed rays.
    let edges: Vec<(u32, u32)> = f.iter().flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]).collect();
    let mut r = rng(1);
    let per_kind = 250_000;
    let (mut leaks, mut mt_leaks, mut worst_spread) = ([0usize; 4], [0usize; 4], 0.0f64);
    for kind in 0..4 {
        for i in 0..per_kind {
            let o = unit_vector(&mut r) * (0.5 * unif(&mut r).cbrt());
            let target = match kind {
                0 => o + unit_vector(&mut r),
                1 => v[(r.next_u32() as usize) % v.len()],
                _ => {
                    let (a, b) = edges[(r.next_u32() as usize) % edges.len()];
                    let s = if kind == 2 { unif(&mut r) } else { 0.5 };
                    v[a as usize] + (v[b as usize] - v[a as usize]) * s
                }
            };
            let ray = Ray::new(o, (target - o).normalize());
            if bvh.closest_hit(&ray, Interval::POSITIVE).is_none() {
                leaks[kind] += 1;
            }
            if i % 5 == 0 && portable.closest_hit(&ray, Interval::POSITIVE).is_none() {
                leaks[kind] += 1;
            }
            // Brute-force on a subset: every triangle reporting a hit agrees on t, and MT's leaks.
            if i % 25 == 0 {
                let ts: Vec<f64> = tris
                    .iter()
                    .filter_map(|t| intersect_watertight(t, &ray, Interval::POSITIVE))
                    .map(|h| h.t as f64)
                    .collect();
                if ts.len() > 1 {
                    let (lo, hi) = ts.iter().fold((f64::MAX, f64::MIN), |(a, b), &t| (a.min(t), b.max(t)));
                    worst_spread = worst_spread.max((hi - lo) / (U * hi));
                }
                if !tris.iter().any(|t| intersect_moller_trumbore(t, &ray, Interval::POSITIVE).is_some()) {
                    mt_leaks[kind] += 1;
                }
            }
        }
    }
    println!(
        "T1: watertight leaks {leaks:?} of {per_kind} per kind (random, vertex, edge, midpoint); \
         Möller–Trumbore leaks {mt_leaks:?} of {} per kind; worst multi-hit t spread {worst_spread:.1} u·t",
        per_kind / 25
    );
    assert_eq!(leaks, [0; 4]);
    assert!(worst_spread <= 8.0);
    assert!(mt_leaks[1] + mt_leaks[2] + mt_leaks[3] > 0, "the test must be able to see a leak");
}

/// T6: degenerate triangles never hit; near-degenerate ones never produce NaN or infinity.
#[test]
fn t6_degenerate_triangles_are_nan_free() {
    let down = |x: f32, y: f32| Ray::new(Vec3A::new(x, y, 1.0), -Vec3A::Z);
    let degenerate = [
        Triangle::new(Vec3A::ZERO, Vec3A::ONE, Vec3A::splat(2.0)),
        Triangle::new(Vec3A::ZERO, Vec3A::ZERO, Vec3A::X),
        Triangle::new(Vec3A::ONE, Vec3A::ONE, Vec3A::ONE),
    ];
    for t in &degenerate {
        for ray in [
            down(0.5, 0.5),
            down(1.0, 1.0),
            down(0.0, 0.0),
            Ray::new(Vec3A::new(-1.0, -1.0, -1.0), Vec3A::ONE.normalize()),
        ] {
            assert!(intersect_watertight(t, &ray, Interval::POSITIVE).is_none());
            assert!(intersect_moller_trumbore(t, &ray, Interval::POSITIVE).is_none());
        }
    }
    let mut r = rng(6);
    let (mut hits, mut bad) = (0, 0);
    for _ in 0..1_000_000 {
        let v0 = Vec3A::new(unif(&mut r), unif(&mut r), 0.0) * 4.0;
        let v1 = v0 + unit_vector(&mut r);
        let s = unif(&mut r);
        let h = 10f32.powf(-12.0 + 9.0 * unif(&mut r)) * (v1 - v0).length();
        let perp = (v1 - v0).cross(Vec3A::Z).normalize_or_zero();
        let v2 = v0.lerp(v1, s) + perp * h;
        let aim = v0.lerp(v1, unif(&mut r));
        let o = aim + unit_vector(&mut r) * 3.0;
        let ray = Ray::new(o, (aim - o).normalize());
        if let Some(hit) = intersect_watertight(&Triangle::new(v0, v1, v2), &ray, Interval::POSITIVE) {
            hits += 1;
            let ok = hit.t.is_finite()
                && hit.t > 0.0
                && hit.point.is_finite()
                && hit.normal.is_finite()
                && hit.uv.is_finite();
            let b = [1.0 - hit.uv.x - hit.uv.y, hit.uv.x, hit.uv.y];
            let inside = b.iter().all(|&x| x >= -4.0 * U as f32 && x <= 1.0 + 4.0 * U as f32);
            if !ok || !inside || (hit.normal.length() - 1.0).abs() > 1e-5 {
                bad += 1;
            }
        }
    }
    println!(
        "T6: 1e6 near-degenerate triangles: {hits} hits, {bad} with NaN, inf, t <= 0 or barycentrics outside [-4u, 1+4u]"
    );
    assert_eq!(bad, 0);
}

/// T7: grazing rays on the unit right triangle and on the plane z = 0: the exact hit is at t = 0.5.
#[test]
fn t7_grazing_and_parallel_rays() {
    let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let plane = Plane { point: Vec3A::ZERO, normal: Vec3A::Z };
    let mut table = Vec::new();
    for m in [1e-2f32, 1e-4, 1e-6, 1e-7, 1e-8] {
        let ray = Ray::new(Vec3A::new(0.0, 0.25, m / 2.0), Vec3A::new(1.0, 0.0, -m));
        for (name, hit) in [
            ("triangle", tri.intersect(&ray, Interval::POSITIVE)),
            ("plane", plane.intersect(&ray, Interval::POSITIVE)),
        ] {
            match hit {
                Some(h) => {
                    assert!(h.t.is_finite());
                    let err = (h.t - 0.5).abs();
                    if m >= 1e-4 {
                        assert!(err <= 1e-6, "{name} m={m}: t={}", h.t);
                    } else {
                        assert!(err <= 5e-4, "{name} m={m}: t={}", h.t);
                    }
                    table.push(format!("{name} m={m:e}: t={}", h.t));
                }
                None => {
                    assert!(m < 1e-4, "{name} must hit at m={m}");
                    table.push(format!("{name} m={m:e}: miss"));
                }
            }
        }
    }
    for ray in [Ray::new(Vec3A::new(0.0, 0.25, 0.1), Vec3A::X), Ray::new(Vec3A::new(-1.0, 0.25, 0.0), Vec3A::X)] {
        assert!(tri.intersect(&ray, Interval::POSITIVE).is_none());
        assert!(plane.intersect(&ray, Interval::POSITIVE).is_none());
    }
    println!("T7: {}", table.join("; "));
}

/// R1: rays leaving a triangle from its hit point, offset by raylume's spawn routine, never hit the
/// triangle again, at every size and translation; the offset stays within 512 ulps + 2^-15.
#[test]
fn r1_spawned_rays_never_rehit_their_surface() {
    let mut r = rng(11);
    let mut report = Vec::new();
    for s in [1e-3f32, 1.0, 1e3, 1e5] {
        for shift in [0.0f32, 1e3, 1e5] {
            let (mut rehits, mut spawned, mut worst_offset) = (0usize, 0usize, 0.0f64);
            for _ in 0..300 {
                let base = Vec3A::splat(shift) + unit_vector(&mut r) * shift * 0.1;
                let tri = Triangle::new(base, base + unit_vector(&mut r) * s, base + unit_vector(&mut r) * s);
                let n = tri.normal();
                if n.length() < 0.05 * s * s {
                    continue;
                }
                let n = n.normalize();
                let (b1, b2) = (unif(&mut r) * 0.8 + 0.1, unif(&mut r) * 0.8 + 0.1);
                let (b1, b2) = if b1 + b2 > 0.95 { (b1 * 0.5, b2 * 0.5) } else { (b1, b2) };
                let aim = tri.p[0] * (1.0 - b1 - b2) + tri.p[1] * b1 + tri.p[2] * b2;
                let side = if unif(&mut r) < 0.5 { 1.0 } else { -1.0 };
                let o = aim + (n * side + unit_vector(&mut r) * 0.5).normalize() * (10.0 * s);
                let Some(hit) = tri.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else {
                    continue;
                };
                let facing = if (o - hit.point).dot(hit.normal) > 0.0 { hit.normal } else { -hit.normal };
                let origin = offset_ray_origin(hit.point, hit.error, facing);
                let p_max = hit.point.abs().max_element() as f64;
                let ulp = (p_max as f32).max(f32::MIN_POSITIVE).to_bits();
                let ulp = (f32::from_bits(ulp + 1) - f32::from_bits(ulp)) as f64;
                worst_offset = worst_offset.max((origin - hit.point).length() as f64 / (512.0 * ulp + 1.0 / 32768.0));
                for _ in 0..1000 {
                    let mut d = unit_vector(&mut r);
                    if d.dot(facing) < 0.0 {
                        d = -d;
                    }
                    spawned += 1;
                    if tri.intersect(&Ray::new(origin, d), Interval::POSITIVE).is_some() {
                        rehits += 1;
                    }
                }
            }
            report.push(format!("S={s:e} T={shift:e}: {rehits}/{spawned}"));
            assert_eq!(rehits, 0, "S={s} T={shift}");
            assert!(worst_offset <= 1.0, "offset too large: {worst_offset} of the allowance");
        }
    }
    println!("R1: re-hits {}", report.join(", "));
}

/// S1: a sphere of radius 1e-3 at distance D: hit/miss agrees with f64 outside a 16 u D band, and t
/// within 16 u t.
#[test]
fn s1_small_sphere_far_away() {
    let mut r = rng(21);
    let mut report = Vec::new();
    for dist in [1.0f32, 10.0, 100.0, 1000.0] {
        let (mut wrong, mut worst_t) = (0usize, 0.0f64);
        for _ in 0..100_000 {
            let radius = 1e-3f32;
            let c = unit_vector(&mut r) * dist;
            let (s, t) = raylume::geometry::orthonormal_basis(c.normalize());
            let a = std::f32::consts::TAU * unif(&mut r);
            let rr = 1.05 * radius * unif(&mut r).sqrt();
            let aim = c + (s * a.cos() + t * a.sin()) * rr;
            let dir = if unif(&mut r) < 0.5 { aim.normalize() } else { aim * 3.7 };
            let ray = Ray::new(Vec3A::ZERO, dir);
            // f64 reference.
            let d = [dir.x as f64, dir.y as f64, dir.z as f64];
            let cc = [c.x as f64, c.y as f64, c.z as f64];
            let dd = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let dn = [d[0] / dd, d[1] / dd, d[2] / dd];
            let proj = cc[0] * dn[0] + cc[1] * dn[1] + cc[2] * dn[2];
            let perp2 = (cc[0] * cc[0] + cc[1] * cc[1] + cc[2] * cc[2]) - proj * proj;
            let l_ref = perp2.max(0.0).sqrt();
            let hit = Sphere { center: c, radius }.intersect(&ray, Interval::POSITIVE);
            let expect = l_ref < radius as f64;
            if (l_ref - radius as f64).abs() > 16.0 * U * dist as f64 {
                if hit.is_some() != expect {
                    wrong += 1;
                }
                if let Some(h) = hit {
                    let t_ref = (proj - (radius as f64 * radius as f64 - perp2).sqrt()) / dd;
                    worst_t = worst_t.max((h.t as f64 - t_ref).abs() / (U * t_ref));
                }
            }
        }
        report.push(format!("D={dist}: {wrong} wrong, worst dt error {worst_t:.1} u·t"));
        assert_eq!(wrong, 0, "D={dist}");
        assert!(worst_t <= 16.0, "D={dist}: {worst_t}");
    }
    println!("S1: {}", report.join("; "));
}

/// S3: from inside a huge sphere, exactly one hit: the exit, back-facing, at the right distance.
#[test]
fn s3_origin_inside_a_huge_sphere() {
    let mut r = rng(31);
    for (radius, frac) in [(1e5f32, 0.0f32), (1e5, 0.5), (1e5, 0.999), (1.0, 0.0)] {
        let sphere = Sphere { center: Vec3A::ZERO, radius };
        for _ in 0..10_000 {
            let o = unit_vector(&mut r) * radius * frac;
            let d = unit_vector(&mut r);
            let ray = Ray::new(o, d);
            let hit = sphere.intersect(&ray, Interval::POSITIVE).expect("the exit");
            assert!(!hit.front_face(&ray));
            let t_ref = sphere_roots64(o, d, radius).expect("the origin is inside").1;
            assert!(
                (hit.t as f64 - t_ref).abs() <= 8.0 * U * (o.length() as f64 + radius as f64),
                "r={radius} frac={frac}: t {} vs {t_ref} (o {o:?}, d {d:?})",
                hit.t
            );
        }
    }
    println!("S3: 40 000 rays from inside spheres of radius 1 and 1e5: every one found its exit");
}

/// PL1: planes never report NaN or infinite hits; parallel and in-plane rays miss.
#[test]
fn pl1_plane_nan_safety() {
    let mut r = rng(41);
    let plane = Plane { point: Vec3A::new(0.0, -2.0, 0.0), normal: Vec3A::Y };
    let mut bad = 0;
    for _ in 0..1_000_000 {
        let h = 10f32.powf(-6.0 + 9.0 * unif(&mut r)) * if unif(&mut r) < 0.5 { 1.0 } else { -1.0 };
        let m = match r.next_u32() % 5 {
            0 => 0.0,
            1 => -0.0,
            2 => 1e-40,
            _ => 10f32.powf(-30.0 + 30.0 * unif(&mut r)),
        } * if unif(&mut r) < 0.5 { 1.0 } else { -1.0 };
        let ray = Ray::new(Vec3A::new(0.0, -2.0 + h, 0.0), Vec3A::new(1.0, m, 0.0));
        if let Some(hit) = plane.intersect(&ray, Interval::POSITIVE) {
            if !hit.t.is_finite() || !hit.point.is_finite() || m == 0.0 {
                bad += 1;
            }
        }
    }
    assert!(plane.intersect(&Ray::new(Vec3A::new(0.0, -2.0, 0.0), Vec3A::X), Interval::POSITIVE).is_none());
    println!("PL1: 1e6 near-parallel rays: {bad} NaN, infinite or parallel hits");
    assert_eq!(bad, 0);
}

/// B1: rays lying in a box's faces (with +0 and -0 components), along an edge, through a corner, and
/// through flat and point boxes, all hit the conservative node test, the same for ±0 and subnormals.
#[test]
fn b1_slab_in_face_rays() {
    let unit = raylume::geometry::Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    let node_hit =
        |b: &raylume::geometry::Aabb, ray: &Ray| b.hit_range(ray, ray.dir.recip(), 0.0, f32::INFINITY).is_some();
    let mut hits = 0;
    for axis in 0..3 {
        for face in [0.0f32, 1.0] {
            for zero in [0.0f32, -0.0, 1e-40, -1e-40] {
                let travel = (axis + 1) % 3;
                let mut o = Vec3A::splat(0.5);
                o[axis] = face;
                o[travel] = -1.0;
                let mut d = Vec3A::ZERO;
                d[travel] = 1.0;
                d[axis] = zero;
                let ray = Ray::new(o, d);
                assert!(node_hit(&unit, &ray), "axis {axis} face {face} zero {zero}");
                hits += 1;
            }
        }
    }
    assert!(node_hit(&unit, &Ray::new(Vec3A::new(1.0, 1.0, -1.0), Vec3A::Z)), "along an edge");
    let corner_box = raylume::geometry::Aabb::new(Vec3A::ONE, Vec3A::splat(2.0));
    assert!(node_hit(&corner_box, &Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize())), "through the corner");
    let flat = raylume::geometry::Aabb::new(Vec3A::new(0.0, 0.0, 0.5), Vec3A::new(1.0, 1.0, 0.5));
    assert!(node_hit(&flat, &Ray::new(Vec3A::new(0.5, 0.5, 2.0), -Vec3A::Z)));
    assert!(
        node_hit(&flat, &Ray::new(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::new(1.0, 0.0, -0.0))),
        "in the flat box's plane"
    );
    let point = raylume::geometry::Aabb::from_point(Vec3A::splat(3.0));
    assert!(node_hit(&point, &Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize())));
    // And the box primitive in the BVH: a ray along an edge of a box finds it.
    let b = Primitive::Box(AaBox { bounds: unit });
    let bvh = Bvh::new(vec![b], Interval::new(0.0, 0.0));
    assert!(
        bvh.closest_hit(&Ray::new(Vec3A::new(1.0, 1.0, -1.0), Vec3A::new(-0.0, 0.0, 1.0)), Interval::POSITIVE)
            .is_some()
    );
    println!(
        "B1: {hits} of 24 in-face rays (±0 and ±subnormal components) hit the node test; edge, corner, flat and point boxes too"
    );
}

/// G3: a grid over a lattice of small spheres: rays along the diagonal and through lattice edges,
/// from outside and from the max face, find the same spheres as brute force.
#[test]
fn g3_grid_lattice_rays() {
    for scale in [1.0f32, 312.5] {
        let mut prims = Vec::new();
        for i in 0..64 {
            let c = i as f32 * scale;
            prims.push(Primitive::Sphere(Sphere { center: Vec3A::splat(c), radius: 0.05 * scale }));
            prims.push(Primitive::Sphere(Sphere { center: Vec3A::new(c, c, 0.0), radius: 0.05 * scale }));
        }
        let brute = BruteForce::new(prims.clone());
        let grid =
            Grid::new(prims, Interval::new(0.0, 0.0), GridParams { k: 64.0 * 64.0 * 64.0 / 128.0, mailbox: true });
        let rays = [
            Ray::new(Vec3A::splat(-1.0) * scale, Vec3A::ONE.normalize()),
            Ray::new(Vec3A::new(-1.0, -1.0, 0.0) * scale, Vec3A::new(1.0, 1.0, 0.0).normalize()),
            Ray::new(Vec3A::splat(63.0) * scale, -Vec3A::ONE.normalize()),
            Ray::new(Vec3A::new(63.0, 63.0, 0.0) * scale, Vec3A::new(-1.0, -1.0, -0.0).normalize()),
            Ray::new(Vec3A::new(31.0 * scale, 31.0 * scale, -10.0 * scale), Vec3A::Z),
        ];
        for ray in rays {
            let (a, b) = (brute.closest_hit(&ray, Interval::POSITIVE), grid.closest_hit(&ray, Interval::POSITIVE));
            assert_eq!(a.map(|h| (h.primitive, h.hit.t)), b.map(|h| (h.primitive, h.hit.t)), "scale {scale}, {ray:?}");
            assert_eq!(brute.occluded(&ray, f32::INFINITY), grid.occluded(&ray, f32::INFINITY));
        }
    }
    println!("G3: diagonal, lattice-edge, max-face and axis rays agree with brute force on a 64-per-axis lattice");
}

/// X2: rays with NaN or infinite parts, or no direction, return no hit from every accelerator, fast.
#[test]
fn x2_invalid_rays() {
    let mut r = rng(51);
    let prims: Vec<Primitive> = (0..10_000)
        .map(|_| {
            let c = unit_vector(&mut r) * 10.0 * unif(&mut r);
            Primitive::Triangle(Triangle::new(c, c + unit_vector(&mut r) * 0.2, c + unit_vector(&mut r) * 0.2))
        })
        .collect();
    let shutter = Interval::new(0.0, 0.0);
    let bvh = Bvh::new(prims.clone(), shutter);
    let grid = Grid::new(prims.clone(), shutter, GridParams::default());
    let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    let mut invalid = Vec::new();
    for i in 0..10_000 {
        let mut o = unit_vector(&mut r) * 20.0;
        let mut d = unit_vector(&mut r);
        match i % 4 {
            0 => o[i % 3] = specials[i % 3],
            1 => d[i % 3] = specials[(i / 3) % 3],
            2 => d = Vec3A::ZERO,
            _ => o = Vec3A::splat(f32::NAN),
        }
        invalid.push(Ray::new(o, d));
    }
    let valid: Vec<Ray> = (0..10_000).map(|_| Ray::new(unit_vector(&mut r) * 20.0, unit_vector(&mut r))).collect();
    let time = |rays: &[Ray]| {
        let start = std::time::Instant::now();
        let hits = rays
            .iter()
            .filter(|ray| bvh.closest_hit(ray, Interval::POSITIVE).is_some() || grid.occluded(ray, f32::INFINITY))
            .count();
        (hits, start.elapsed().as_secs_f64())
    };
    let (bad_hits, t_invalid) = time(&invalid);
    let (_, t_valid) = time(&valid);
    let brute = BruteForce::new(prims);
    assert!(invalid.iter().all(|ray| brute.closest_hit(ray, Interval::POSITIVE).is_none()));
    println!(
        "X2: 10 000 invalid rays: {bad_hits} hits, {:.2} ms (valid rays: {:.2} ms)",
        t_invalid * 1e3,
        t_valid * 1e3
    );
    assert_eq!(bad_hits, 0);
}

/// B2: rays aimed at f32 points exactly on the faces of small, distant boxes always pass the
/// conservative node test.
#[test]
fn b2_conservative_far_traversal() {
    let mut r = rng(61);
    let mut misses = 0;
    for _ in 0..1_000_000 {
        let size = 10f32.powf(-4.0 + 4.0 * unif(&mut r));
        let centre = unit_vector(&mut r) * 10f32.powf(2.0 + 3.0 * unif(&mut r));
        let b = raylume::geometry::Aabb::new(centre - Vec3A::splat(size), centre + Vec3A::splat(size));
        let axis = (r.next_u32() % 3) as usize;
        let mut target = b.min + (b.max - b.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
        target[axis] = if unif(&mut r) < 0.5 { b.min[axis] } else { b.max[axis] };
        let ray = Ray::new(Vec3A::ZERO, target.normalize());
        if b.hit_range(&ray, ray.dir.recip(), 0.0, f32::INFINITY).is_none() {
            misses += 1;
        }
    }
    println!("B2: 1e6 rays at points on far box faces: {misses} false misses");
    assert_eq!(misses, 0);
}

/// B3: the box primitive at edges, corners and from inside: t >= 0 and an axis-aligned unit normal
/// facing the ray (outward from inside).
#[test]
fn b3_box_edges_corners_inside() {
    let mut r = rng(71);
    let mut bad = 0;
    for i in 0..100_000 {
        let half = Vec3A::new(
            10f32.powf(-3.0 + 6.0 * unif(&mut r)),
            10f32.powf(-3.0 + 6.0 * unif(&mut r)),
            10f32.powf(-3.0 + 6.0 * unif(&mut r)),
        );
        let centre = unit_vector(&mut r) * 10f32.powf(5.0 * unif(&mut r));
        let b = AaBox { bounds: raylume::geometry::Aabb::new(centre - half, centre + half) };
        let pick = |r: &mut Pcg32, a: usize| if unif(r) < 0.5 { b.bounds.min[a] } else { b.bounds.max[a] };
        let (ray, inside) = match i % 4 {
            0 => {
                // An edge point: two coordinates on the bounds.
                let mut t =
                    b.bounds.min + (b.bounds.max - b.bounds.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
                let a = (r.next_u32() % 3) as usize;
                t[a] = pick(&mut r, a);
                t[(a + 1) % 3] = pick(&mut r, (a + 1) % 3);
                let o = t + unit_vector(&mut r).abs().max(Vec3A::splat(0.1)) * (half * 4.0) * (t - centre).signum();
                (Ray::new(o, (t - o).normalize()), false)
            }
            1 => {
                let t = Vec3A::new(pick(&mut r, 0), pick(&mut r, 1), pick(&mut r, 2));
                let o = t + (t - centre) * 3.0;
                (Ray::new(o, (t - o).normalize()), false)
            }
            _ => {
                let o =
                    b.bounds.min + (b.bounds.max - b.bounds.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
                (Ray::new(o, unit_vector(&mut r)), true)
            }
        };
        match b.intersect(&ray, Interval::POSITIVE) {
            Some(h) => {
                let axis_aligned = h.normal.abs().max_element() == 1.0 && h.normal.abs().min_element() == 0.0;
                let facing = if inside { h.normal.dot(ray.dir) > 0.0 } else { h.normal.dot(ray.dir) <= 0.0 };
                if h.t.is_nan() || h.t < 0.0 || !axis_aligned || !facing {
                    bad += 1;
                }
            }
            None => {
                // An origin that rounded onto a face is on the surface, not inside: a ray leaving through
                // that face meets the box at t = 0, which is no hit.
                let strictly_inside = ray.origin.cmpgt(b.bounds.min).all() && ray.origin.cmplt(b.bounds.max).all();
                if inside && strictly_inside {
                    bad += 1;
                }
            }
        }
    }
    println!("B3: 1e5 edge, corner and inside rays: {bad} with negative t, a bad normal or a missed exit");
    assert_eq!(bad, 0);
}

/// B4: +0 and -0 direction components give bit-identical answers from every accelerator.
#[test]
fn b4_signed_zero_invariance() {
    let mut r = rng(81);
    let mut mismatches = 0;
    for scene in 0..50 {
        let mut prims: Vec<Primitive> = (0..200)
            .map(|i| {
                let c = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 8.0;
                match i % 3 {
                    0 => Primitive::Sphere(Sphere { center: c, radius: 0.3 }),
                    1 => Primitive::Triangle(Triangle::new(c, c + Vec3A::X, c + Vec3A::Y)),
                    _ => Primitive::Box(AaBox { bounds: raylume::geometry::Aabb::new(c, c + Vec3A::splat(0.5)) }),
                }
            })
            .collect();
        if scene % 2 == 0 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -1.0, 0.0), normal: Vec3A::Y }));
        }
        let shutter = Interval::new(0.0, 0.0);
        let bvh = Bvh::new(prims.clone(), shutter);
        let grid = Grid::new(prims.clone(), shutter, GridParams::default());
        let brute = BruteForce::new(prims);
        for _ in 0..2000 {
            let o = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 10.0 - Vec3A::splat(1.0);
            let mut d = unit_vector(&mut r);
            let zeroed = (r.next_u32() % 3) as usize;
            d[zeroed] = 0.0;
            if r.next_u32() % 2 == 0 {
                d[(zeroed + 1) % 3] = 0.0;
            }
            if d == Vec3A::ZERO {
                continue;
            }
            let mut neg = d;
            for a in 0..3 {
                if neg[a] == 0.0 {
                    neg[a] = -0.0;
                }
            }
            let key = |h: Option<raylume::accel::PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits()));
            let a = (Ray::new(o, d), Ray::new(o, neg));
            let answers = [
                (key(brute.closest_hit(&a.0, Interval::POSITIVE)), key(brute.closest_hit(&a.1, Interval::POSITIVE))),
                (key(bvh.closest_hit(&a.0, Interval::POSITIVE)), key(bvh.closest_hit(&a.1, Interval::POSITIVE))),
                (key(grid.closest_hit(&a.0, Interval::POSITIVE)), key(grid.closest_hit(&a.1, Interval::POSITIVE))),
            ];
            if answers.iter().any(|(x, y)| x != y) || answers[0].0 != answers[1].0 || answers[0].0 != answers[2].0 {
                mismatches += 1;
            }
        }
    }
    println!(
        "B4: 50 scenes x 2000 axis-parallel rays: {mismatches} differences between +0 and -0 or between accelerators"
    );
    assert_eq!(mismatches, 0);
}

/// S2: huge spheres seen from just above their surface: t within 8 u (|o - c| + r) of f64.
#[test]
fn s2_large_sphere_origin_near_surface() {
    let mut r = rng(91);
    let mut worst = 0.0f64;
    let mut checked = 0;
    for radius in [1e2f32, 1e4, 1e6] {
        for h in [1e-2f32, 1.0, 1e2] {
            let sphere = Sphere { center: Vec3A::ZERO, radius };
            for _ in 0..20_000 {
                let up = unit_vector(&mut r);
                let o = up * (radius + h);
                let (s, t) = raylume::geometry::orthonormal_basis(up);
                let lateral = (s * (unif(&mut r) - 0.5) + t * (unif(&mut r) - 0.5)) * (6.0 * h);
                let target = up * radius + lateral;
                let d = (target - o).normalize();
                let cos = -d.dot(up);
                let bound = 8.0 * U * (o.length() as f64 + radius as f64);
                let hit = sphere.intersect(&Ray::new(o, d), Interval::POSITIVE);
                if let Some(h) = hit {
                    assert!(h.t.is_finite() && h.t >= 0.0);
                }
                if cos < 0.1 || (h as f64) < bound {
                    continue;
                }
                let Some((t_ref, _)) = sphere_roots64(o, d, radius) else { continue };
                let got = hit.expect("a ray aimed at a huge sphere below hits it").t as f64;
                worst = worst.max((got - t_ref).abs() / (U * (o.length() as f64 + radius as f64)));
                checked += 1;
            }
        }
    }
    println!("S2: {checked} rays: worst t error {worst:.2} u·(|o-c|+r)");
    assert!(worst <= 8.0);
}

/// S4: a grid of parallel rays over a sphere, and exactly tangent rays: hit iff inside the disc
/// outside a thin band; no NaN.
#[test]
fn s4_tangent_and_silhouette_rays() {
    let mut r = rng(101);
    let mut wrong = 0;
    for radius in [1.0f32, 3.0] {
        for _ in 0..20 {
            let c = unit_vector(&mut r) * 1e3 * unif(&mut r);
            let w = unit_vector(&mut r);
            let (s, t) = raylume::geometry::orthonormal_basis(w);
            let sphere = Sphere { center: c, radius };
            let band = 8.0 * U * (radius as f64).powi(2) * (c.length() as f64 / radius as f64).max(1.0);
            let mut offsets: Vec<(f32, f32)> = Vec::new();
            for i in 0..21 {
                for j in 0..21 {
                    offsets.push((radius * (i as f32 / 10.0 - 1.0), radius * (j as f32 / 10.0 - 1.0)));
                }
            }
            for k in 10..=24 {
                let e = 2f32.powi(-k);
                offsets.push((radius * (1.0 + e), 0.0));
                offsets.push((radius * (1.0 - e), 0.0));
            }
            offsets.push((radius, 0.0));
            for (x, y) in offsets {
                let o = c + s * x + t * y - w * (8.0 * radius);
                let ray = Ray::new(o, w);
                let hit = sphere.intersect(&ray, Interval::POSITIVE);
                if let Some(h) = hit {
                    assert!(h.t.is_finite() && h.point.is_finite() && h.normal.is_finite());
                }
                // The f64 offset of the actual f32 ray from the centre.
                let oc = (o - c).to_array().map(f64::from);
                let w64 = w.to_array().map(f64::from);
                let along: f64 = (0..3).map(|a| oc[a] * w64[a]).sum();
                let d2: f64 = (0..3).map(|a| (oc[a] - along * w64[a]).powi(2)).sum();
                let r2 = (radius as f64).powi(2);
                if (d2 - r2).abs() > band && hit.is_some() != (d2 < r2) {
                    wrong += 1;
                }
            }
        }
    }
    println!("S4: 21x21 grids and tangent rays over 40 spheres: {wrong} misclassified outside the band, no NaN");
    assert_eq!(wrong, 0);
}

/// R4: shadow rays between two facing surfaces are never falsely occluded by either end, and an
/// occluder between them is always found.
#[test]
fn r4_shadow_rays_between_surfaces() {
    let mut r = rng(111);
    let mut report = Vec::new();
    for h in [1e-3f32, 1.0, 1e3] {
        for shift in [0.0f32, 1e4] {
            let base = Vec3A::splat(shift);
            let size = h.max(1.0) * 4.0;
            let a = Triangle::new(
                base + Vec3A::new(-size, -size, 0.0),
                base + Vec3A::new(size, -size, 0.0),
                base + Vec3A::new(0.0, size, 0.0),
            );
            let b = Triangle::new(
                base + Vec3A::new(-size, -size, h),
                base + Vec3A::new(0.0, size, h),
                base + Vec3A::new(size, -size, h),
            );
            let mid = Triangle::new(
                base + Vec3A::new(-size, -size, h / 2.0),
                base + Vec3A::new(size, -size, h / 2.0),
                base + Vec3A::new(0.0, size, h / 2.0),
            );
            let (mut false_occlusions, mut missed) = (0, 0);
            let prims = vec![Primitive::Triangle(a), Primitive::Triangle(b)];
            let with_mid = vec![Primitive::Triangle(a), Primitive::Triangle(b), Primitive::Triangle(mid)];
            let (plain, blocked) = (BruteForce::new(prims), BruteForce::new(with_mid));
            for _ in 0..10_000 {
                let point = |r: &mut Pcg32, z: f32| {
                    let (u, v) = (unif(r) * 0.5, unif(r) * 0.5);
                    base + Vec3A::new((u - v) * size, (u + v) * size - size * 0.5, z)
                };
                let (pa, pb) = (point(&mut r, 0.0), point(&mut r, h));
                // Both ends come from hits, so their error bounds are those of the routine.
                let hit_a = a.intersect(&Ray::new(pa + Vec3A::Z * (h * 0.5), -Vec3A::Z), Interval::POSITIVE);
                let hit_b = b.intersect(&Ray::new(pb - Vec3A::Z * (h * 0.5), Vec3A::Z), Interval::POSITIVE);
                let (Some(ha), Some(hb)) = (hit_a, hit_b) else { continue };
                let (ray, dist) = spawn_ray_to(ha.point, ha.error, Vec3A::Z, hb.point, hb.error, -Vec3A::Z);
                if plain.occluded(&ray, dist) {
                    false_occlusions += 1;
                }
                if !blocked.occluded(&ray, dist) {
                    missed += 1;
                }
            }
            report.push(format!("h={h:e} T={shift:e}: {false_occlusions} false, {missed} missed"));
            // ulp of the coordinates; surfaces closer than a few ulps are not distinct in f32.
            let ulp = (shift.max(size) as f64) * U * 2.0;
            if h as f64 >= 16.0 * ulp {
                assert_eq!(false_occlusions, 0, "h={h} T={shift}");
            }
            if h as f64 >= 4096.0 * ulp {
                assert_eq!(missed, 0, "h={h} T={shift}");
            }
        }
    }
    println!(
        "R4 (surfaces closer than 16 ulps of their coordinates are not distinct in f32 and not asserted): {}",
        report.join(", ")
    );
}

/// Own case O1: the same lit sphere on a floor, rendered at scales 1e-4 to 1e6 (camera, lights and
/// geometry scaled together), gives the same picture: no acne, no light leaking, at any scale.
#[test]
fn o1_images_are_scale_invariant() {
    let render = |k: f32| {
        let scene = SceneBuilder::new()
            .camera(Vec3A::new(0.0, 1.5, 5.0) * k, Vec3A::new(0.0, 0.5, 0.0) * k, Vec3A::Y, 40.0, 64, 48)
            .background(Vec3::new(0.2, 0.3, 0.5))
            .light(Vec3A::new(3.0, 5.0, 4.0) * k, Vec3::ONE)
            .material(Phong {
                diffuse: Vec3::splat(0.8),
                kd: 0.9,
                specular: Vec3::ONE,
                ks: 0.3,
                shine: 30.0,
                ..Phong::default()
            })
            .plane([Vec3A::ZERO, Vec3A::new(0.0, 0.0, -k), Vec3A::new(-k, 0.0, 0.0)])
            .sphere(Vec3A::new(0.0, 1.0, 0.0) * k, k)
            .triangle(Vec3A::new(1.2, 0.0, 1.0) * k, Vec3A::new(2.2, 0.0, 1.0) * k, Vec3A::new(1.7, 1.0, 1.0) * k)
            .build()
            .unwrap();
        scene.render(&RenderOptions::default(), &|| {}).unwrap().film
    };
    let reference = render(1.0);
    let mut report = Vec::new();
    for k in [1e-4f32, 1e-2, 1e2, 1e4, 1e6] {
        let film = render(k);
        let differing = film
            .pixels()
            .iter()
            .zip(reference.pixels())
            .filter(|(a, b)| (**a - **b).abs().max_element() > 0.02)
            .count();
        report.push(format!("scale {k:e}: {differing} pixels differ"));
        // A pixel or two on silhouettes may round differently; acne would darken hundreds.
        assert!(differing <= 4, "scale {k}: {differing} pixels differ from scale 1");
    }
    println!("O1: {} (of {} pixels)", report.join(", "), 64 * 48);
}

/// Own case O2: triangles of side 1e-6 and 1e6, seen from proportional distances, are hit at the
/// f64 distance.
#[test]
fn o2_tiny_and_huge_triangles() {
    let mut r = rng(121);
    for side in [1e-6f32, 1e-3, 1.0, 1e3, 1e6] {
        for _ in 0..10_000 {
            let a = unit_vector(&mut r) * side;
            let tri = Triangle::new(a, a + unit_vector(&mut r) * side, a + unit_vector(&mut r) * side);
            if tri.normal().length() < 0.1 * side * side {
                continue;
            }
            let centroid = (tri.p[0] + tri.p[1] + tri.p[2]) / 3.0;
            let o = centroid + unit_vector(&mut r) * (5.0 * side);
            let ray = Ray::new(o, (centroid - o).normalize());
            if tri.normal().normalize().dot(ray.dir).abs() < 0.05 {
                continue;
            }
            let hit = tri
                .intersect(&ray, Interval::POSITIVE)
                .unwrap_or_else(|| panic!("side {side}: a ray at the centroid must hit"));
            let t_ref = (centroid - o).length();
            assert!((hit.t - t_ref).abs() <= 1e-4 * t_ref, "side {side}: t {} vs {t_ref}", hit.t);
        }
    }
    println!("O2: rays at the centroids of triangles of side 1e-6 to 1e6 all hit, t within 1e-4 relative");
}

/// A uniformly random rotation (from a random unit quaternion).
fn rotation(r: &mut Pcg32) -> glam::Mat3A {
    let q = glam::Quat::from_xyzw(unif(r) - 0.5, unif(r) - 0.5, unif(r) - 0.5, unif(r) - 0.5).normalize();
    glam::Mat3A::from_quat(q)
}

/// T4: tiny right triangles and needles, hit through the centroid at the f64 distance; points just
/// outside an edge are missed; never NaN, never t <= 0.
#[test]
fn t4_tiny_and_needle_triangles() {
    let mut r = rng(131);
    let (mut wrong, mut total, mut worst_t) = (0usize, 0usize, 0.0f64);
    // Needles missed, by w/l decade (1e-6, 1e-5, ... 1e-2): the f32 t bound alone would reject the
    // thinnest; the f64 re-check decides them.
    let (mut needle_misses, mut needles) = ([0usize; 5], [0usize; 5]);
    for i in 0..200_000 {
        let rot = rotation(&mut r);
        if i % 2 == 0 {
            let s = 10f32.powf(-5.0 + 7.0 * unif(&mut r));
            let l = 10f32.powf(-2.0 + 5.0 * unif(&mut r));
            if (s / l) < 1e-5 {
                continue;
            }
            let c = rot * Vec3A::new(0.0, 0.0, -l);
            let (e1, e2) = (rot * Vec3A::new(s, 0.0, 0.0), rot * Vec3A::new(0.0, s, 0.0));
            let tri = Triangle::new(c, c + e1, c + e2);
            // The centroid; and 1e-3 of s beyond the hypotenuse, which f32 can only resolve when the
            // triangle spans many ulps of its position (s/L >= 1e-2).
            let mut targets = vec![c + (e1 + e2) / 3.0];
            if s / l >= 1e-2 {
                targets.push(c + (e1 + e2) * (0.5 + 1e-3));
            }
            for target in targets {
                // Classified against the f64 reference on the same f32 ray.
                let ray = Ray::new(Vec3A::ZERO, target.normalize());
                let Some((t_ref, margin)) = reference_triangle_hit(&tri, &ray) else { continue };
                if margin.abs() < 1e-9 {
                    continue;
                }
                total += 1;
                let hit = tri.intersect(&ray, Interval::POSITIVE);
                if let Some(h) = hit {
                    assert!(h.t.is_finite() && h.t > 0.0);
                    let e = (h.t as f64 - t_ref).abs() / (U * t_ref);
                    worst_t = worst_t.max(e);
                }
                if hit.is_some() != (margin > 0.0) {
                    wrong += 1;
                }
            }
        } else {
            let len = 10f32.powf(4.0 * unif(&mut r));
            let ratio = 10f32.powf(-6.0 + 5.0 * unif(&mut r));
            let w = len * ratio;
            let c = rot * Vec3A::new(0.0, 0.0, -3.0 * len);
            let (a, b) = (rot * Vec3A::new(len, 0.0, 0.0), rot * Vec3A::new(len, w, 0.0));
            let tri = Triangle::new(c, c + a, c + b);
            let ray = Ray::new(Vec3A::ZERO, (c + (a + b) / 3.0).normalize());
            let Some((_, margin)) = reference_triangle_hit(&tri, &ray) else { continue };
            if margin < 1e-3 {
                continue;
            }
            let decade = ((ratio.log10() + 6.0) as usize).min(4);
            needles[decade] += 1;
            match tri.intersect(&ray, Interval::POSITIVE) {
                Some(h) => assert!(h.t.is_finite() && h.t > 0.0),
                None => needle_misses[decade] += 1,
            }
        }
    }
    println!(
        "T4: {total} rays at tiny right triangles (s/L >= 1e-5): {wrong} misclassified against f64, worst dt error {worst_t:.1} u·t; \
         needles through the centroid missed, by w/l decade 1e-6..1e-2: {needle_misses:?} of {needles:?}"
    );
    assert_eq!(wrong, 0);
    assert!(worst_t <= 8.0);
    assert_eq!(needle_misses, [0; 5], "needles down to w/l = 1e-6 are hit");
}

/// T8: hit or miss does not depend on the order of the vertices, for rays aimed at points on and
/// within 2 ulps of the edges.
#[test]
fn t8_vertex_order_invariance() {
    let mut r = rng(141);
    let (mut mismatches, mut worst_dt) = (0usize, 0u32);
    for _ in 0..250_000 {
        let scale = 10f32.powf(-3.0 + 6.0 * unif(&mut r));
        let shift = unit_vector(&mut r) * 1e5 * unif(&mut r);
        let v = [0, 1, 2].map(|_| shift + unit_vector(&mut r) * scale);
        let (a, b) = (r.next_u32() as usize % 3, unif(&mut r));
        let mut target = v[a].lerp(v[(a + 1) % 3], b);
        let k = (r.next_u32() % 3) as usize;
        for _ in 0..(r.next_u32() % 3) {
            target[k] = if unif(&mut r) < 0.5 { target[k].next_up() } else { target[k].next_down() };
        }
        let o = target + unit_vector(&mut r) * (3.0 * scale);
        let ray = Ray::new(o, (target - o).normalize());
        let orders = [[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1]];
        let hits: Vec<Option<f32>> = orders
            .iter()
            .map(|o| {
                intersect_watertight(&Triangle::new(v[o[0]], v[o[1]], v[o[2]]), &ray, Interval::POSITIVE).map(|h| h.t)
            })
            .collect();
        if hits.iter().any(|h| h.is_some() != hits[0].is_some()) {
            mismatches += 1;
        } else if let Some(t0) = hits[0] {
            for t in hits.iter().flatten() {
                worst_dt = worst_dt.max((t.to_bits() as i64 - t0.to_bits() as i64).unsigned_abs() as u32);
            }
        }
    }
    println!(
        "T8: 250 000 near-edge rays, 4 vertex orders: {mismatches} hit/miss mismatches, worst dt error {worst_dt} ulps"
    );
    assert_eq!(mismatches, 0);
    assert!(worst_dt <= 2, "{worst_dt} ulps");
}

/// R5: the hit point's error bound holds: the exact surface passes through `point ± error`, and the
/// bound is not absurdly large.
#[test]
fn r5_hit_point_error_bound_is_valid() {
    let mut r = rng(151);
    let (mut violations, mut too_large) = (0usize, 0usize);
    for i in 0..1_000_000 {
        let s = 10f32.powf(-3.0 + 6.0 * unif(&mut r));
        let shift = unit_vector(&mut r) * 1e5 * unif(&mut r);
        if i % 2 == 0 {
            let tri = Triangle::new(shift, shift + unit_vector(&mut r) * s, shift + unit_vector(&mut r) * s);
            let n = tri.normal();
            if n.length() < 0.05 * s * s {
                continue;
            }
            let (b1, b2) = (unif(&mut r) * 0.5, unif(&mut r) * 0.5);
            let aim = tri.p[0] * (1.0 - b1 - b2) + tri.p[1] * b1 + tri.p[2] * b2;
            let o = aim + unit_vector(&mut r) * (10.0 * s);
            let Some(h) = tri.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else { continue };
            // f64 distance from the point to the plane through the f32 vertices.
            let n64 = normal64(&tri);
            let p0 = tri.p[0].to_array().map(f64::from);
            let dist: f64 = (0..3).map(|a| (h.point[a] as f64 - p0[a]) * n64[a]).sum::<f64>().abs();
            let allowed: f64 = (0..3).map(|a| n64[a].abs() * h.error[a] as f64).sum();
            if dist > allowed {
                violations += 1;
            }
            let reach: f64 =
                tri.p.iter().map(|v| v.abs().to_array().iter().map(|&x| x as f64).sum::<f64>()).sum::<f64>() + s as f64;
            if h.error.max_element() as f64 > 12.0 * U * reach {
                too_large += 1;
            }
        } else {
            let sphere = Sphere { center: shift, radius: s };
            let o = shift + unit_vector(&mut r) * (s * (1.5 + 10.0 * unif(&mut r)));
            let aim = shift + unit_vector(&mut r) * (s * 0.5);
            let Some(h) = sphere.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else { continue };
            let pc = (0..3).map(|a| (h.point[a] as f64 - shift[a] as f64).powi(2)).sum::<f64>().sqrt();
            let n = h.normal.to_array().map(f64::from);
            let allowed: f64 = (0..3).map(|a| n[a].abs() * h.error[a] as f64).sum();
            if (pc - s as f64).abs() > allowed {
                violations += 1;
            }
        }
    }
    println!(
        "R5: 1e6 triangle and sphere hits: {violations} points outside their error bound, {too_large} bounds over 12 u·reach"
    );
    assert_eq!(violations, 0);
    assert_eq!(too_large, 0);
}

/// The unit normal of a triangle's f32 vertices, computed in f64.
fn normal64(tri: &Triangle) -> [f64; 3] {
    let p = tri.p.map(|v| v.to_array().map(f64::from));
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let c = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    [c[0] / l, c[1] / l, c[2] / l]
}

/// The f64 intersection of a ray with the plane of a triangle's f32 vertices: the distance, and the
/// smallest barycentric (positive inside, negative outside).
fn reference_triangle_hit(tri: &Triangle, ray: &Ray) -> Option<(f64, f64)> {
    let p = tri.p.map(|v| v.to_array().map(f64::from));
    let o = ray.origin.to_array().map(f64::from);
    let d = ray.dir.to_array().map(f64::from);
    let n = normal64(tri);
    let den: f64 = (0..3).map(|a| n[a] * d[a]).sum();
    if den == 0.0 {
        return None;
    }
    let t = (0..3).map(|a| n[a] * (p[0][a] - o[a])).sum::<f64>() / den;
    let x = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
    // Signed areas of the sub-triangles, projected on the normal.
    let area = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2]
    };
    let total = area(p[0], p[1], p[2]);
    let b = [area(x, p[1], p[2]), area(p[0], x, p[2]), area(p[0], p[1], x)];
    let margin = b.iter().fold(f64::INFINITY, |m, &v| m.min(v)) / total;
    (t > 0.0).then_some((t, margin))
}

/// X1: adversarial scenes (log-uniform sizes, clusters, duplicates, coincident and flat triangles,
/// primitives on split planes and cell boundaries, infinite planes): BVH, midpoint BVH and grid
/// return brute force's closest hit bit for bit, and the same occlusion answers.
#[test]
fn x1_accelerators_on_adversarial_scenes() {
    let mut r = rng(161);
    let mut mismatches = 0usize;
    let mut rays_traced = 0usize;
    for scene in 0..200 {
        let n = 1 + (r.next_u32() % 400) as usize;
        let mut prims = Vec::with_capacity(n + 2);
        let cluster = unit_vector(&mut r) * 10.0;
        for i in 0..n {
            let size = 10f32.powf(-4.0 + 8.0 * unif(&mut r)).min(50.0);
            // Centres on a coarse lattice (split planes and cell boundaries) half the time.
            let c = if i % 2 == 0 { (unit_vector(&mut r) * 8.0).round() } else { cluster + unit_vector(&mut r) * size };
            let p = match i % 5 {
                0 => Primitive::Sphere(Sphere { center: c, radius: size }),
                1 => Primitive::Triangle(Triangle::new(c, c + Vec3A::X * size, c + Vec3A::Y * size)),
                2 => Primitive::Box(AaBox { bounds: raylume::geometry::Aabb::new(c, c + Vec3A::splat(size)) }),
                3 => Primitive::Triangle(Triangle::new(
                    c,
                    c + unit_vector(&mut r) * size,
                    c + unit_vector(&mut r) * size,
                )),
                _ => prims.last().copied().unwrap_or(Primitive::Sphere(Sphere { center: c, radius: size })),
            };
            prims.push(p);
        }
        for _ in 0..(scene % 3) {
            prims.push(Primitive::Plane(Plane {
                point: Vec3A::new(0.0, -20.0 - unif(&mut r), 0.0),
                normal: unit_vector(&mut r),
            }));
        }
        let shutter = Interval::new(0.0, 0.0);
        let brute = BruteForce::new(prims.clone());
        let bvh = Bvh::new(prims.clone(), shutter);
        let portable = Bvh::with_kernel(prims.clone(), shutter, BvhBuild::Sah, BvhKernel::Portable);
        let mid = Bvh::with_build(prims.clone(), shutter, BvhBuild::Midpoint);
        let grid = Grid::new(prims, shutter, GridParams::default());
        let bounds = bvh.bounds();
        for k in 0..50 {
            let o = match k % 4 {
                0 => unit_vector(&mut r) * 40.0,
                1 => (unit_vector(&mut r) * 8.0).round(),
                2 => bounds.max,
                _ => bounds.min + bounds.diagonal() * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)),
            };
            let mut d = if k % 3 == 0 { Vec3A::X } else { unit_vector(&mut r) };
            if k % 6 == 1 {
                d = Vec3A::new(0.0, -0.0, 1.0);
            }
            let ray = Ray::new(o, if k % 2 == 0 { -d } else { d });
            rays_traced += 1;
            let key = |h: Option<raylume::accel::PrimitiveHit>| h.map(|h| h.hit.t.to_bits());
            let expected = key(brute.closest_hit(&ray, Interval::POSITIVE));
            let occluded = brute.occluded(&ray, 30.0);
            let got = [
                (key(bvh.closest_hit(&ray, Interval::POSITIVE)), bvh.occluded(&ray, 30.0)),
                (key(portable.closest_hit(&ray, Interval::POSITIVE)), portable.occluded(&ray, 30.0)),
                (key(mid.closest_hit(&ray, Interval::POSITIVE)), mid.occluded(&ray, 30.0)),
                (key(grid.closest_hit(&ray, Interval::POSITIVE)), grid.occluded(&ray, 30.0)),
            ];
            // Ties between primitives at the same t are allowed, so t is compared bit for bit.
            mismatches += got.iter().filter(|g| **g != (expected, occluded)).count();
        }
    }
    println!(
        "X1: 200 adversarial scenes, {rays_traced} rays, 4 accelerators (BVH in both kernels): {mismatches} answers differ from brute force"
    );
    assert_eq!(mismatches, 0);
}

/// Own case O3: moving spheres seen at the very start and end of the shutter are found by every
/// accelerator (their bounds cover the whole motion).
#[test]
fn o3_moving_spheres_at_shutter_ends() {
    let mut r = rng(171);
    let prims: Vec<Primitive> = (0..300)
        .map(|_| {
            let c = unit_vector(&mut r) * 10.0;
            Primitive::MovingSphere(raylume::geometry::MovingSphere {
                center0: c,
                center1: c + unit_vector(&mut r) * 5.0,
                radius: 0.3,
                time0: 0.0,
                time1: 1.0,
            })
        })
        .collect();
    let shutter = Interval::new(0.0, 1.0);
    let brute = BruteForce::new(prims.clone());
    let bvh = Bvh::new(prims.clone(), shutter);
    let grid = Grid::new(prims.clone(), shutter, GridParams::default());
    let mut found = 0;
    for (i, p) in prims.iter().enumerate() {
        let Primitive::MovingSphere(m) = p else { unreachable!() };
        for time in [0.0f32, 1.0, 0.5] {
            let c = m.center_at(time);
            let o = c + unit_vector(&mut r) * 30.0;
            let ray = Ray::with_time(o, (c - o).normalize(), time);
            let e = brute.closest_hit(&ray, Interval::POSITIVE).map(|h| h.hit.t.to_bits());
            assert_eq!(bvh.closest_hit(&ray, Interval::POSITIVE).map(|h| h.hit.t.to_bits()), e, "sphere {i} at {time}");
            assert_eq!(
                grid.closest_hit(&ray, Interval::POSITIVE).map(|h| h.hit.t.to_bits()),
                e,
                "sphere {i} at {time}"
            );
            found += e.is_some() as usize;
        }
    }
    println!("O3: 900 rays at moving spheres at t = 0, 0.5 and 1: BVH and grid agree with brute force ({found} hits)");
    assert_eq!(found, 900);
}

/// Own case O4: a scene far from the origin (offset 1e6) renders like the same scene at the origin,
/// up to the f32 resolution there: no acne, no holes.
#[test]
fn o4_scene_far_from_the_origin() {
    let render = |shift: Vec3A| {
        let scene = SceneBuilder::new()
            .camera(shift + Vec3A::new(0.0, 1.5, 5.0), shift + Vec3A::new(0.0, 0.5, 0.0), Vec3A::Y, 40.0, 64, 48)
            .background(Vec3::new(0.2, 0.3, 0.5))
            .light(shift + Vec3A::new(3.0, 5.0, 4.0), Vec3::ONE)
            .material(Phong { diffuse: Vec3::splat(0.8), kd: 0.9, ..Phong::default() })
            .plane([shift, shift + Vec3A::new(0.0, 0.0, -1.0), shift + Vec3A::new(-1.0, 0.0, 0.0)])
            .sphere(shift + Vec3A::new(0.0, 1.0, 0.0), 1.0)
            .build()
            .unwrap();
        scene.render(&RenderOptions::default(), &|| {}).unwrap().film
    };
    let reference = render(Vec3A::ZERO);
    let mut report = Vec::new();
    for shift in [1e3f32, 1e4, 1e5] {
        let film = render(Vec3A::new(shift, 0.0, shift));
        // Away from edges (where f32 quantisation at the offset may move a silhouette or a shadow by a
        // fraction of a pixel), no lit pixel may darken.
        let flat = |x: u32, y: u32| {
            let c = reference.pixel(x, y);
            [(0i32, 1i32), (1, 0), (0, -1), (-1, 0)].iter().all(|&(dx, dy)| {
                let (nx, ny) = ((x as i32 + dx).clamp(0, 63) as u32, (y as i32 + dy).clamp(0, 47) as u32);
                (reference.pixel(nx, ny) - c).abs().max_element() < 0.1
            })
        };
        let black = (0..48u32)
            .flat_map(|y| (0..64u32).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let (got, want) = (film.pixel(x, y).max_element(), reference.pixel(x, y).max_element());
                // Lit pixels only: at the terminator N.L is near zero and tiny values vary relatively.
                flat(x, y) && want > 0.05 && got < 0.5 * want
            })
            .count();
        report.push(format!("offset {shift:e}: {black} darkened pixels"));
        assert_eq!(black, 0, "offset {shift}");
    }
    println!("O4: {} (acne would darken lit pixels)", report.join(", "));
}

/// Own case O5: rays leaving spheres and boxes (R1 covers triangles) at scales 1e-4 to 1e6, offset
/// by their hit's error bound, never hit the surface they left.
#[test]
fn o5_spheres_and_boxes_never_rehit_themselves() {
    let mut r = rng(181);
    let mut report = Vec::new();
    for scale in [1e-4f32, 1.0, 1e3, 1e6] {
        let (mut rehits, mut spawned) = (0usize, 0usize);
        for i in 0..200 {
            let centre = unit_vector(&mut r) * scale * 3.0;
            let prim = if i % 2 == 0 {
                Primitive::Sphere(Sphere { center: centre, radius: scale })
            } else {
                Primitive::Box(AaBox {
                    bounds: raylume::geometry::Aabb::new(centre - Vec3A::splat(scale), centre + Vec3A::splat(scale)),
                })
            };
            let o = centre + unit_vector(&mut r) * (scale * 10.0);
            let aim = centre + unit_vector(&mut r) * (scale * 0.5);
            let Some(hit) = prim.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else { continue };
            let n = if hit.normal.dot(o - hit.point) > 0.0 { hit.normal } else { -hit.normal };
            let origin = offset_ray_origin(hit.point, hit.error, n);
            for _ in 0..1000 {
                let mut d = unit_vector(&mut r);
                if d.dot(n) < 0.0 {
                    d = -d;
                }
                spawned += 1;
                // Leaving a convex solid outwards: nothing of it can be hit.
                if prim.intersect(&Ray::new(origin, d), Interval::POSITIVE).is_some() {
                    rehits += 1;
                }
            }
        }
        report.push(format!("scale {scale:e}: {rehits}/{spawned}"));
        assert_eq!(rehits, 0, "scale {scale}");
    }
    println!("O5: re-hits of spheres and boxes {}", report.join(", "));
}

/// The two roots `(near, far)` of a ray (origin `o`, direction `d`) with the sphere of radius `r`
/// centred at the origin, in f64 from the f32 inputs; `None` if the ray misses it.
fn sphere_roots64(o: Vec3A, d: Vec3A, r: f32) -> Option<(f64, f64)> {
    let (o64, d64) = (o.to_array().map(f64::from), d.to_array().map(f64::from));
    let od: f64 = (0..3).map(|a| o64[a] * d64[a]).sum();
    let oo: f64 = (0..3).map(|a| o64[a] * o64[a]).sum();
    let dd: f64 = (0..3).map(|a| d64[a] * d64[a]).sum();
    let disc = od * od - dd * (oo - (r as f64).powi(2));
    (disc >= 0.0).then(|| ((-od - disc.sqrt()) / dd, (-od + disc.sqrt()) / dd))
}
