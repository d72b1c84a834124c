//! Measures naive intersection routines against raylume's on cases of ../shared/robustness-cases.md
//! and prints the Markdown table of docs/ROBUSTNESS.md.
//!
//! `cargo run --release --example robustness > docs/ROBUSTNESS-table.md`
//!
//! The naive variants are the textbook ones: Möller–Trumbore with `|det| < 1e-6`, the quadratic
//! `b^2 - 4ac` for spheres, a slab test with `f32::min`/`max`, a plane test with `t < tmin || t > tmax`,
//! and a fixed `p + 1e-4 n` spawn offset. The full pass criteria live in `tests/stiff.rs`.

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume::geometry::{Aabb, Plane, Sphere, Triangle, offset_ray_origin};
use raylume::intersect::intersect_watertight;
use raylume::prelude::*;
use raylume::scene::procedural::icosphere;

fn unif(r: &mut Pcg32) -> f32 {
    (r.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn unit_vector(r: &mut Pcg32) -> Vec3A {
    let z = 1.0 - 2.0 * unif(r);
    let phi = std::f32::consts::TAU * unif(r);
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3A::new(s * phi.cos(), s * phi.sin(), z)
}

/// Möller–Trumbore as it is usually written: an absolute determinant epsilon, no NaN guards.
#[allow(clippy::manual_range_contains)]
fn naive_triangle(t: &Triangle, ray: &Ray) -> Option<f32> {
    let (e1, e2) = (t.p[1] - t.p[0], t.p[2] - t.p[0]);
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-6 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - t.p[0];
    let u = s.dot(p) * inv;
    if u < 0.0 || u > 1.0 {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0).then_some(t)
}

/// The textbook quadratic.
fn naive_sphere(s: &Sphere, ray: &Ray) -> Option<f32> {
    let oc = ray.origin - s.center;
    let a = ray.dir.dot(ray.dir);
    let b = 2.0 * oc.dot(ray.dir);
    let c = oc.dot(oc) - s.radius * s.radius;
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let t0 = (-b - disc.sqrt()) / (2.0 * a);
    let t1 = (-b + disc.sqrt()) / (2.0 * a);
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        Some(t1)
    } else {
        None
    }
}

/// A slab test with `f32::min`/`max` and no widening.
fn naive_slab(b: &Aabb, ray: &Ray) -> bool {
    let inv = ray.dir.recip();
    let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
    for a in 0..3 {
        let lo = (b.min[a] - ray.origin[a]) * inv[a];
        let hi = (b.max[a] - ray.origin[a]) * inv[a];
        t0 = t0.max(lo.min(hi));
        t1 = t1.min(lo.max(hi));
    }
    t0 <= t1
}

/// A plane test whose range check lets NaN and infinity through (as written on purpose).
#[allow(clippy::manual_range_contains)]
fn naive_plane(p: &Plane, ray: &Ray) -> Option<f32> {
    let t = p.normal.dot(p.point - ray.origin) / p.normal.dot(ray.dir);
    if t < 0.0 || t > f32::INFINITY { None } else { Some(t) }
}

struct Row {
    case: &'static str,
    setup: String,
    naive: String,
    raylume: String,
}

fn main() {
    let mut rows = Vec::new();
    let mut r = Pcg32::new(2026, 11);

    // T1: rays from inside a closed icosphere at its vertices and edges.
    {
        let (v, f) = icosphere(3);
        let tris: Vec<Triangle> =
            f.iter().map(|t| Triangle::new(v[t[0] as usize], v[t[1] as usize], v[t[2] as usize])).collect();
        let (mut naive, mut ours, n) = (0, 0, 20_000);
        for i in 0..n {
            let o = unit_vector(&mut r) * 0.5 * unif(&mut r).cbrt();
            let t = &f[(r.next_u32() as usize) % f.len()];
            let target =
                if i % 2 == 0 { v[t[0] as usize] } else { v[t[0] as usize].lerp(v[t[1] as usize], unif(&mut r)) };
            let ray = Ray::new(o, (target - o).normalize());
            naive += !tris.iter().any(|t| naive_triangle(t, &ray).is_some()) as usize;
            ours += !tris.iter().any(|t| intersect_watertight(t, &ray, Interval::POSITIVE).is_some()) as usize;
        }
        rows.push(Row {
            case: "T1 watertight icosphere",
            setup: format!("{n} rays from inside a closed level-3 icosphere at vertices and edge points"),
            naive: format!("{naive} leaks ({:.1} %)", 100.0 * naive as f64 / n as f64),
            raylume: format!("{ours} leaks"),
        });
    }
    // T4: tiny triangles at unit distance.
    {
        let (mut naive, mut ours, n) = (0, 0, 10_000);
        for _ in 0..n {
            let s = 10f32.powf(-5.0 + 2.0 * unif(&mut r));
            let c = Vec3A::new(0.0, 0.0, -1.0);
            let tri = Triangle::new(c, c + Vec3A::X * s, c + Vec3A::Y * s);
            let ray = Ray::new(Vec3A::ZERO, (c + Vec3A::new(s, s, 0.0) / 3.0).normalize());
            naive += naive_triangle(&tri, &ray).is_none() as usize;
            ours += tri.intersect(&ray, Interval::POSITIVE).is_none() as usize;
        }
        rows.push(Row {
            case: "T4 tiny triangles",
            setup: format!("{n} rays at the centroids of triangles of side 1e-5..1e-3 at distance 1"),
            naive: format!("{naive} misses ({:.1} %)", 100.0 * naive as f64 / n as f64),
            raylume: format!("{ours} misses"),
        });
    }
    // T7: grazing rays.
    {
        let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        let show = |hit: Option<f32>| hit.map_or("miss".to_owned(), |t| format!("{t}"));
        let (mut naive, mut ours) = (Vec::new(), Vec::new());
        for m in [1e-2f32, 1e-4, 1e-6, 1e-8] {
            let ray = Ray::new(Vec3A::new(0.0, 0.25, m / 2.0), Vec3A::new(1.0, 0.0, -m));
            naive.push(format!("{m:e}: {}", show(naive_triangle(&tri, &ray))));
            ours.push(format!("{m:e}: {}", show(tri.intersect(&ray, Interval::POSITIVE).map(|h| h.t))));
        }
        rows.push(Row {
            case: "T7 grazing rays",
            setup: "slope m onto the unit right triangle; exact t = 0.5".to_owned(),
            naive: naive.join("; "),
            raylume: ours.join("; ") + " (misses below 1e-6 are allowed: the conservative t check)",
        });
    }
    // R1: self-intersection with a fixed offset.
    for (s, shift) in [(1.0f32, 1e5f32), (1e3, 0.0), (1e5, 1e5)] {
        let (mut naive, mut ours, mut spawned) = (0, 0, 0);
        for _ in 0..100 {
            let base = Vec3A::splat(shift);
            let tri = Triangle::new(base, base + unit_vector(&mut r) * s, base + unit_vector(&mut r) * s);
            let Some(n) = tri.normal().try_normalize() else { continue };
            let aim = (tri.p[0] + tri.p[1] + tri.p[2]) / 3.0;
            let o = aim + n * (10.0 * s);
            let Some(hit) = tri.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else { continue };
            let naive_origin = hit.point + n * 1e-4;
            let our_origin = offset_ray_origin(hit.point, hit.error, n);
            for _ in 0..200 {
                let mut d = unit_vector(&mut r);
                if d.dot(n) < 0.0 {
                    d = -d;
                }
                spawned += 1;
                naive += naive_triangle(&tri, &Ray::new(naive_origin, d)).is_some() as usize;
                ours += tri.intersect(&Ray::new(our_origin, d), Interval::POSITIVE).is_some() as usize;
            }
        }
        rows.push(Row {
            case: "R1 self-intersection",
            setup: format!("{spawned} rays spawned from triangles of size {s:e} at offset {shift:e}"),
            naive: format!("p + 1e-4 n: {naive} re-hits ({:.1} %)", 100.0 * naive as f64 / spawned.max(1) as f64),
            raylume: format!("{ours} re-hits"),
        });
    }
    // S1: small sphere far away.
    for dist in [10.0f32, 1000.0] {
        let (mut naive, mut ours, n) = (0, 0, 20_000);
        for _ in 0..n {
            let c = unit_vector(&mut r) * dist;
            let sphere = Sphere { center: c, radius: 1e-3 };
            let (a, b) = raylume::geometry::orthonormal_basis(c.normalize());
            let ang = std::f32::consts::TAU * unif(&mut r);
            let rr = 0.9e-3 * unif(&mut r).sqrt();
            let ray = Ray::new(Vec3A::ZERO, (c + (a * ang.cos() + b * ang.sin()) * rr).normalize());
            naive += naive_sphere(&sphere, &ray).is_none() as usize;
            ours += sphere.intersect(&ray, Interval::POSITIVE).is_none() as usize;
        }
        rows.push(Row {
            case: "S1 small sphere far away",
            setup: format!("{n} rays into 0.9 r of a sphere of radius 1e-3 at distance {dist}"),
            naive: format!("{naive} misses ({:.1} %)", 100.0 * naive as f64 / n as f64),
            raylume: format!("{ours} misses"),
        });
    }
    // S2: huge sphere seen from just above.
    {
        let (mut naive_err, mut our_err) = (0.0f64, 0.0f64);
        let radius = 1e2f32;
        for _ in 0..20_000 {
            let up = unit_vector(&mut r);
            let o = up * (radius + 100.0);
            let d = (-up + unit_vector(&mut r) * 0.3).normalize();
            let sphere = Sphere { center: Vec3A::ZERO, radius };
            let (o64, d64) = (o.to_array().map(f64::from), d.to_array().map(f64::from));
            let od: f64 = (0..3).map(|a| o64[a] * d64[a]).sum();
            let oo: f64 = (0..3).map(|a| o64[a] * o64[a]).sum();
            let dd: f64 = (0..3).map(|a| d64[a] * d64[a]).sum();
            let disc = od * od - dd * (oo - (radius as f64).powi(2));
            if disc < 0.0 {
                continue;
            }
            let t_ref = (-od - disc.sqrt()) / dd;
            let unit = 2f64.powi(-24) * (o.length() as f64 + radius as f64);
            if let Some(t) = naive_sphere(&sphere, &Ray::new(o, d)) {
                naive_err = naive_err.max((t as f64 - t_ref).abs() / unit);
            }
            if let Some(h) = sphere.intersect(&Ray::new(o, d), Interval::POSITIVE) {
                our_err = our_err.max((h.t as f64 - t_ref).abs() / unit);
            }
        }
        rows.push(Row {
            case: "S2 huge sphere, origin near it",
            setup: "radius 100, origin 100 above the surface, 20 000 rays".to_owned(),
            naive: format!("worst t error {naive_err:.1} u(o-c+r)"),
            raylume: format!("worst {our_err:.1} u(o-c+r)"),
        });
    }
    // B1: rays lying in a box's faces.
    {
        let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        let (mut naive, mut ours, mut n) = (0, 0, 0);
        for axis in 0..3 {
            for face in [0.0f32, 1.0] {
                for zero in [0.0f32, -0.0] {
                    let travel = (axis + 1) % 3;
                    let mut o = Vec3A::splat(0.5);
                    o[axis] = face;
                    o[travel] = -1.0;
                    let mut d = Vec3A::ZERO;
                    d[travel] = 1.0;
                    d[axis] = zero;
                    let ray = Ray::new(o, d);
                    n += 1;
                    naive += naive_slab(&b, &ray) as usize;
                    ours += b.hit_range(&ray, ray.dir.recip(), 0.0, f32::INFINITY).is_some() as usize;
                }
            }
        }
        rows.push(Row {
            case: "B1 in-face rays",
            setup: format!("{n} rays lying in the faces of [0,1]^3, ±0 components"),
            naive: format!("{naive}/{n} hit"),
            raylume: format!("{ours}/{n} hit"),
        });
    }
    // B2: far boxes, rays at points on their faces.
    {
        let (mut naive, mut ours, n) = (0, 0, 100_000);
        for _ in 0..n {
            let size = 1e-3;
            let c = unit_vector(&mut r) * 1e4;
            let b = Aabb::new(c - Vec3A::splat(size), c + Vec3A::splat(size));
            let mut t = b.min + (b.max - b.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
            let a = (r.next_u32() % 3) as usize;
            t[a] = b.min[a];
            let ray = Ray::new(Vec3A::ZERO, t.normalize());
            naive += !naive_slab(&b, &ray) as usize;
            ours += b.hit_range(&ray, ray.dir.recip(), 0.0, f32::INFINITY).is_none() as usize;
        }
        rows.push(Row {
            case: "B2 conservative traversal",
            setup: format!("{n} rays at points on faces of 1e-3 boxes at distance 1e4"),
            naive: format!("{naive} false misses ({:.1} %)", 100.0 * naive as f64 / n as f64),
            raylume: format!("{ours} false misses"),
        });
    }
    // PL1: near-parallel rays and planes.
    {
        let plane = Plane { point: Vec3A::ZERO, normal: Vec3A::Y };
        let (mut naive, mut ours, n) = (0, 0, 100_000);
        for i in 0..n {
            let m = if i % 2 == 0 { 0.0 } else { 10f32.powf(-45.0 + 10.0 * unif(&mut r)) };
            let ray = Ray::new(Vec3A::new(0.0, 1.0, 0.0), Vec3A::new(1.0, -m, 0.0));
            naive += naive_plane(&plane, &ray).is_some_and(|t| !t.is_finite()) as usize;
            ours += plane.intersect(&ray, Interval::POSITIVE).is_some_and(|h| !h.t.is_finite()) as usize;
        }
        rows.push(Row {
            case: "PL1 plane NaN safety",
            setup: format!("{n} parallel and near-parallel rays (slopes 0, subnormal)"),
            naive: format!("{naive} hits at t = inf or NaN"),
            raylume: format!("{ours}"),
        });
    }

    println!("| case | setup | naive routine | raylume |");
    println!("|---|---|---|---|");
    for row in rows {
        println!("| {} | {} | {} | {} |", row.case, row.setup, row.naive, row.raylume);
    }
}
