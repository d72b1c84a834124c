//! Every intersection routine against analytic answers, plus properties over random rays.

use approx::assert_relative_eq;
use proptest::prelude::*;
use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Ray, Sphere, Triangle, Vec3A};
use raylume_intersect::{Intersect, Primitive};

fn v(x: f32, y: f32, z: f32) -> Vec3A {
    Vec3A::new(x, y, z)
}

#[test]
fn sphere_front_and_inside() {
    let s = Sphere { center: v(0.0, 0.0, -5.0), radius: 2.0 };
    let hit = s.intersect(&Ray::new(Vec3A::ZERO, -Vec3A::Z), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 3.0, max_relative = 1e-6);
    assert_relative_eq!(hit.normal.z, 1.0, max_relative = 1e-6);
    // From the centre: the exit point, with the outward normal.
    let hit = s.intersect(&Ray::new(v(0.0, 0.0, -5.0), Vec3A::X), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 2.0, max_relative = 1e-6);
    assert_relative_eq!(hit.normal.x, 1.0, max_relative = 1e-6);
    // A ray offset by 1 along y: t = 5 - sqrt(4 - 1).
    let hit = s.intersect(&Ray::new(v(0.0, 1.0, 0.0), -Vec3A::Z), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 5.0 - 3.0f32.sqrt(), max_relative = 1e-6);
    // Misses: beside it, behind the origin, beyond t_max.
    assert!(s.intersect(&Ray::new(v(0.0, 2.1, 0.0), -Vec3A::Z), Interval::POSITIVE).is_none());
    assert!(s.intersect(&Ray::new(Vec3A::ZERO, Vec3A::Z), Interval::POSITIVE).is_none());
    assert!(s.intersect(&Ray::new(Vec3A::ZERO, -Vec3A::Z), Interval::new(0.0, 2.9)).is_none());
    assert!(s.occluded(&Ray::new(Vec3A::ZERO, -Vec3A::Z), 3.5));
    assert!(!s.occluded(&Ray::new(Vec3A::ZERO, -Vec3A::Z), 2.5));
}

#[test]
fn small_sphere_far_away_is_hit_at_the_right_distance() {
    let s = Sphere { center: v(0.0, 0.0, 1e5), radius: 1e-2 };
    let hit = s.intersect(&Ray::new(Vec3A::ZERO, Vec3A::Z), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 1e5 - 1e-2, max_relative = 1e-6);
}

#[test]
fn moving_sphere_follows_the_ray_time() {
    let m =
        MovingSphere { center0: v(0.0, 0.0, -5.0), center1: v(10.0, 0.0, -5.0), radius: 1.0, time0: 0.0, time1: 1.0 };
    let ray = |t| Ray::with_time(Vec3A::ZERO, -Vec3A::Z, t);
    assert!(m.intersect(&ray(0.0), Interval::POSITIVE).is_some());
    assert!(m.intersect(&ray(1.0), Interval::POSITIVE).is_none());
    // The swept box, rounded outward by a few ulps for the interpolation of the centre.
    let b = m.bounds_over(Interval::new(0.0, 1.0));
    let exact = Aabb::new(v(-1.0, -1.0, -6.0), v(11.0, 1.0, -4.0));
    assert!(b.min.cmple(exact.min).all() && b.max.cmpge(exact.max).all(), "{b:?}");
    assert!((b.min - exact.min).abs().max_element() < 1e-5 && (b.max - exact.max).abs().max_element() < 1e-5);
}

#[test]
fn triangle_barycentrics_edges_and_degenerates() {
    let t = Triangle::new(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
    let hit = t.intersect(&Ray::new(v(0.25, 0.5, 1.0), -Vec3A::Z), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 1.0, max_relative = 1e-6);
    assert_relative_eq!(hit.uv.x, 0.25, max_relative = 1e-6);
    assert_relative_eq!(hit.uv.y, 0.5, max_relative = 1e-6);
    assert_relative_eq!(hit.normal.z, 1.0, max_relative = 1e-6);
    // From behind: still hit (two-sided), same normal.
    let hit = t.intersect(&Ray::new(v(0.25, 0.25, -1.0), Vec3A::Z), Interval::POSITIVE).unwrap();
    assert!(!hit.front_face(&Ray::new(v(0.25, 0.25, -1.0), Vec3A::Z)));
    assert!(t.intersect(&Ray::new(v(0.6, 0.6, 1.0), -Vec3A::Z), Interval::POSITIVE).is_none());
    // Parallel to the plane of the triangle.
    assert!(t.intersect(&Ray::new(v(-1.0, 0.2, 0.0), Vec3A::X), Interval::POSITIVE).is_none());
    // Zero area: never a hit, never NaN.
    let flat = Triangle::new(v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0));
    assert!(flat.intersect(&Ray::new(v(1.0, 1.0, 1.0), -Vec3A::Z), Interval::POSITIVE).is_none());
    let point = Triangle::new(Vec3A::ONE, Vec3A::ONE, Vec3A::ONE);
    assert!(point.intersect(&Ray::new(v(1.0, 1.0, 2.0), -Vec3A::Z), Interval::POSITIVE).is_none());
}

#[test]
fn plane_hits_and_parallel_rays() {
    let p = Plane::from_points(v(0.0, -1.0, 0.0), v(0.0, -1.0, -1.0), v(-1.0, -1.0, 0.0)).unwrap();
    assert_relative_eq!(p.normal.y, 1.0, max_relative = 1e-6);
    let hit = p.intersect(&Ray::new(v(3.0, 1.0, 2.0), -Vec3A::Y), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 2.0, max_relative = 1e-6);
    assert!(p.intersect(&Ray::new(v(0.0, 1.0, 0.0), Vec3A::X), Interval::POSITIVE).is_none());
    assert!(p.intersect(&Ray::new(v(0.0, -1.0, 0.0), Vec3A::X), Interval::POSITIVE).is_none(), "in the plane");
    assert!(Plane::from_points(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0).is_none());
    assert!(!Primitive::Plane(p).bounds().is_finite());
}

#[test]
fn box_faces_inside_and_axis_parallel_rays() {
    let b = AaBox { bounds: Aabb::new(v(-1.0, -1.0, -1.0), v(1.0, 1.0, 1.0)) };
    let hit = b.intersect(&Ray::new(v(0.2, 0.3, 5.0), -Vec3A::Z), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 4.0, max_relative = 1e-6);
    assert_eq!(hit.normal, Vec3A::Z);
    let hit = b.intersect(&Ray::new(v(-5.0, 0.0, 0.0), Vec3A::X), Interval::POSITIVE).unwrap();
    assert_eq!(hit.normal, -Vec3A::X);
    // From inside: the exit face.
    let hit = b.intersect(&Ray::new(Vec3A::ZERO, Vec3A::Y), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 1.0, max_relative = 1e-6);
    assert_eq!(hit.normal, Vec3A::Y);
    // Diagonal hit on a corner region and a miss.
    let d = v(-1.0, -1.0, -1.0).normalize();
    let hit = b.intersect(&Ray::new(v(3.0, 3.0, 3.0), d), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 2.0 * 3.0f32.sqrt(), max_relative = 1e-5);
    assert!(b.intersect(&Ray::new(v(0.0, 1.5, 5.0), -Vec3A::Z), Interval::POSITIVE).is_none());
}

#[test]
fn cylinder_and_cone() {
    let cyl = Cone { base: v(0.0, 0.0, 0.0), base_radius: 1.0, apex: v(0.0, 2.0, 0.0), apex_radius: 1.0 };
    let hit = cyl.intersect(&Ray::new(v(5.0, 1.0, 0.0), -Vec3A::X), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 4.0, max_relative = 1e-5);
    assert_relative_eq!(hit.normal.x, 1.0, max_relative = 1e-5);
    // Above the cylinder's end: open caps, so a miss.
    assert!(cyl.intersect(&Ray::new(v(5.0, 2.5, 0.0), -Vec3A::X), Interval::POSITIVE).is_none());
    // Through the open end, along the axis: nothing to hit.
    assert!(cyl.intersect(&Ray::new(v(0.0, 5.0, 0.0), -Vec3A::Y), Interval::POSITIVE).is_none());
    // A cone of radius 1 at the base and 0 at height 2: at height 1 its radius is 0.5.
    let cone = Cone { base: Vec3A::ZERO, base_radius: 1.0, apex: v(0.0, 2.0, 0.0), apex_radius: 0.0 };
    let hit = cone.intersect(&Ray::new(v(5.0, 1.0, 0.0), -Vec3A::X), Interval::POSITIVE).unwrap();
    assert_relative_eq!(hit.t, 4.5, max_relative = 1e-5);
    // Its normal tilts up by atan(1/2).
    let expected = v(2.0, 1.0, 0.0).normalize();
    assert!((hit.normal - expected).length() < 1e-5, "{:?}", hit.normal);
    let b = cone.bounds();
    assert!(b.contains(v(1.0, 0.0, 0.0)) && b.contains(v(0.0, 2.0, 0.0)) && b.contains(v(0.0, 0.0, -1.0)));
}

fn finite_vec(range: f32) -> impl Strategy<Value = Vec3A> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
}

fn unit_vec() -> impl Strategy<Value = Vec3A> {
    finite_vec(1.0).prop_filter("non-zero", |d| d.length() > 1e-3).prop_map(|d| d.normalize())
}

proptest! {
    /// A sphere's hit point lies on the sphere, and a ray from outside aimed at the centre hits.
    #[test]
    fn sphere_hits_lie_on_the_surface(c in finite_vec(100.0), r in 0.01f32..50.0, o in finite_vec(100.0), d in unit_vec()) {
        let s = Sphere { center: c, radius: r };
        let ray = Ray::new(o, d);
        if let Some(hit) = s.intersect(&ray, Interval::POSITIVE) {
            prop_assert!(hit.t.is_finite() && hit.t >= 0.0);
            let dist = (hit.point - c).length();
            prop_assert!((dist - r).abs() <= 1e-4 * (r + (o - c).length()), "off by {}", dist - r);
            prop_assert!(hit.normal.is_finite());
        }
        if (o - c).length() > r * 1.01 {
            let aimed = Ray::new(o, (c - o).normalize());
            prop_assert!(s.intersect(&aimed, Interval::POSITIVE).is_some());
        }
    }

    /// A ray aimed at a point inside a triangle hits it there; the hit is never NaN.
    #[test]
    fn triangle_hits_the_point_aimed_at(a in finite_vec(10.0), b in finite_vec(10.0), c in finite_vec(10.0),
                                        u in 0.01f32..0.98, w in 0.01f32..0.98, o in finite_vec(20.0)) {
        let (u, w) = if u + w > 0.99 { (u * 0.5, w * 0.5) } else { (u, w) };
        let tri = Triangle::new(a, b, c);
        let n = tri.normal();
        prop_assume!(n.length() > 1e-2);
        let target = a * (1.0 - u - w) + b * u + c * w;
        let dir = target - o;
        prop_assume!(dir.length() > 1e-2 && (dir.normalize().dot(n.normalize())).abs() > 1e-2);
        let ray = Ray::new(o, dir.normalize());
        let hit = tri.intersect(&ray, Interval::POSITIVE);
        prop_assert!(hit.is_some());
        let hit = hit.unwrap();
        prop_assert!((hit.point - target).length() <= 1e-3 * (1.0 + target.length() + o.length()));
    }

    /// Box hits lie on the box's surface; rays from inside always hit.
    #[test]
    fn box_hits_lie_on_the_surface(lo in finite_vec(10.0), size in finite_vec(5.0), o in finite_vec(20.0), d in unit_vec()) {
        let b = Aabb::new(lo, lo + size.abs() + Vec3A::splat(0.01));
        let bx = AaBox { bounds: b };
        if let Some(hit) = bx.intersect(&Ray::new(o, d), Interval::POSITIVE) {
            let p = hit.point;
            let eps = 1e-4 * (1.0 + p.abs().max_element());
            let inside = p.cmpge(b.min - Vec3A::splat(eps)).all() && p.cmple(b.max + Vec3A::splat(eps)).all();
            let on_face = ((p - b.min).abs().min_element() <= eps) || ((b.max - p).abs().min_element() <= eps);
            prop_assert!(inside && on_face, "{p:?} not on {b:?}");
        }
        let centre = b.centroid();
        prop_assert!(bx.intersect(&Ray::new(centre, d), Interval::POSITIVE).is_some());
    }
}

/// The f64 unit normal of a triangle's f32 vertices.
fn normal64(t: &Triangle) -> [f64; 3] {
    let p = t.p.map(|v| v.to_array().map(f64::from));
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let c = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    [c[0] / l, c[1] / l, c[2] / l]
}

const U: f64 = 1.0 / (1u64 << 24) as f64;

/// The ray from `3 scale` away along `o` to the point of barycentrics `(1 - u - w, u, w)` of `tri`,
/// with `tri`'s f64 unit normal, the f64 direction, the cosine of incidence and the distance to the
/// plane in f64 (the reference `t`).
fn aimed_ray(tri: &Triangle, (u, w): (f32, f32), o: Vec3A, scale: f32) -> (Ray, [f64; 3], [f64; 3], f64, f64) {
    let target = tri.p[0] * (1.0 - u - w) + tri.p[1] * u + tri.p[2] * w;
    let origin = target + o.normalize_or(Vec3A::Z) * (3.0 * scale);
    let ray = Ray::new(origin, (target - origin).normalize());
    let n = normal64(tri);
    let d = ray.dir.to_array().map(f64::from);
    let cos: f64 = (0..3).map(|k| n[k] * d[k]).sum();
    let p0 = tri.p[0].to_array().map(f64::from);
    let o64 = ray.origin.to_array().map(f64::from);
    let t_ref = (0..3).map(|k| n[k] * (p0[k] - o64[k])).sum::<f64>() / cos;
    (ray, n, d, cos, t_ref)
}

fn log_uniform(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    (lo..hi).prop_map(|e| 10f32.powf(e))
}

proptest! {
    /// Watertight triangles, at scales 1e-3..1e4 and offsets up to 1e5: a ray aimed inside hits at the
    /// f64 plane distance within 4 u t, the point lies on the plane within its error bound, and
    /// nothing is NaN.
    #[test]
    fn watertight_hits_match_f64(a in finite_vec(1.0), b in finite_vec(1.0), c in finite_vec(1.0), scale in log_uniform(-3.0, 4.0),
                                 shift in finite_vec(1e5), u in 0.05f32..0.9, w in 0.05f32..0.9, o in finite_vec(1.0)) {
        let (u, w) = if u + w > 0.95 { (u * 0.5, w * 0.5) } else { (u, w) };
        let tri = Triangle::new(shift + a * scale, shift + b * scale, shift + c * scale);
        prop_assume!(tri.normal().length() > 1e-2 * scale * scale);
        let (ray, n, d, cos, t_ref) = aimed_ray(&tri, (u, w), o, scale);
        prop_assume!(cos.abs() > 0.05);
        let (p0, o64) = (tri.p[0].to_array().map(f64::from), ray.origin.to_array().map(f64::from));
        // Whether the f32 ray (its origin and direction rounded) passes inside, by f64 barycentrics.
        let x = [o64[0] + t_ref * d[0], o64[1] + t_ref * d[1], o64[2] + t_ref * d[2]];
        let p = tri.p.map(|v| v.to_array().map(f64::from));
        let area = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
            let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            (e1[1] * e2[2] - e1[2] * e2[1]) * n[0] + (e1[2] * e2[0] - e1[0] * e2[2]) * n[1] + (e1[0] * e2[1] - e1[1] * e2[0]) * n[2]
        };
        let total = area(p[0], p[1], p[2]);
        let margin = [area(x, p[1], p[2]), area(p[0], x, p[2]), area(p[0], p[1], x)].iter().fold(f64::INFINITY, |m, &v| m.min(v)) / total;
        let hit = tri.intersect(&ray, Interval::POSITIVE);
        // Rays within 1e-5 of an edge (relative to the triangle) may go either way.
        if margin < -1e-5 {
            prop_assert!(hit.is_none(), "the f32 ray passes outside by {margin:e}");
        }
        prop_assume!(margin > 1e-5);
        prop_assert!(hit.is_some(), "the f32 ray passes inside by {margin:e}");
        let h = hit.unwrap();
        prop_assert!(h.t.is_finite() && h.point.is_finite() && h.normal.is_finite() && h.error.is_finite());
        prop_assert!((h.t as f64 - t_ref).abs() <= 4.0 * U * t_ref, "t {} vs {}", h.t, t_ref);
        let dist: f64 = (0..3).map(|k| (h.point[k] as f64 - p0[k]) * n[k]).sum::<f64>().abs();
        let allowed: f64 = (0..3).map(|k| n[k].abs() * h.error[k] as f64).sum();
        prop_assert!(dist <= allowed, "point {dist:e} off the plane, bound {allowed:e}");
    }

    /// Triangles of 2^-56..2^-40 near the origin, whose edge functions times sheared distances fall
    /// below f32's normal range: a range ending or starting 1e-4 t before or after the f64 plane
    /// distance keeps or loses the hit accordingly, and the ray sent back from the hit (spawned past its
    /// error bound) does not hit the triangle again.
    #[test]
    fn tiny_triangles_keep_their_ranges(a in finite_vec(1.0), b in finite_vec(1.0), c in finite_vec(1.0), exp in -56i32..-40,
                                        u in 0.05f32..0.9, w in 0.05f32..0.9, o in finite_vec(1.0)) {
        let scale = 2f32.powi(exp);
        let (u, w) = if u + w > 0.95 { (u * 0.5, w * 0.5) } else { (u, w) };
        prop_assume!((b - a).cross(c - a).length() > 1e-2);
        let tri = Triangle::new(a * scale, b * scale, c * scale);
        let (ray, _, _, cos, t_ref) = aimed_ray(&tri, (u, w), o, scale);
        prop_assume!(cos.abs() > 0.05);
        let Some(h) = tri.intersect(&ray, Interval::POSITIVE) else {
            // Aimed well inside, but the rounded ray may pass an edge of a tiny triangle.
            return Ok(());
        };
        prop_assert!((h.t as f64 - t_ref).abs() <= 4.0 * U * t_ref, "t {} vs {}", h.t, t_ref);
        let at = |k: f64| (t_ref * k) as f32;
        prop_assert!(tri.intersect(&ray, Interval::new(0.0, at(1.0 + 1e-4))).is_some());
        prop_assert!(tri.intersect(&ray, Interval::new(at(1.0 - 1e-4), f32::INFINITY)).is_some());
        prop_assert!(tri.intersect(&ray, Interval::new(0.0, at(1.0 - 1e-4))).is_none());
        prop_assert!(tri.intersect(&ray, Interval::new(at(1.0 + 1e-4), f32::INFINITY)).is_none());
        // Sent back from the hit point moved off the surface past its error bound, on the side it came from.
        let side = if h.normal.dot(ray.dir) < 0.0 { h.normal } else { -h.normal };
        let back = Ray::new(raylume_geometry::offset_ray_origin(h.point, h.error, side), -ray.dir);
        prop_assert!(tri.intersect(&back, Interval::POSITIVE).is_none(), "the ray leaving the hit hits again");
    }

    /// Two triangles sharing an edge: a ray through any f32 point of the edge hits at least one.
    #[test]
    fn watertight_never_leaks_on_a_shared_edge(a in finite_vec(10.0), b in finite_vec(10.0), c in finite_vec(10.0), e in finite_vec(10.0),
                                               s in 0.0f32..1.0, o in finite_vec(20.0)) {
        let (t1, t2) = (Triangle::new(a, b, c), Triangle::new(b, a, e));
        prop_assume!(t1.normal().length() > 1e-3 && t2.normal().length() > 1e-3);
        let target = a.lerp(b, s);
        prop_assume!((target - o).length() > 1e-2);
        let ray = Ray::new(o, (target - o).normalize());
        // Only rays that pass between the two faces (not grazing the shared edge's plane pair).
        let h1 = raylume_intersect::intersect_watertight(&t1, &ray, Interval::POSITIVE);
        let h2 = raylume_intersect::intersect_watertight(&t2, &ray, Interval::POSITIVE);
        let (n1, n2) = (t1.normal().normalize(), t2.normal().normalize());
        let crossing = n1.dot(ray.dir).signum() == n2.dot(ray.dir).signum() && n1.dot(ray.dir).abs() > 1e-3 && n2.dot(ray.dir).abs() > 1e-3;
        // Rays that start behind the edge relative to the surface see it at t <= 0.
        let ahead = (target - o).dot(ray.dir) > 1e-3;
        if crossing && ahead && (n1.dot(n2) > -0.9) {
            prop_assert!(h1.is_some() || h2.is_some(), "leak through the shared edge");
        }
    }

    /// The shadow-ray test answers exactly as the closest-hit decision, on any ray range, including
    /// rays aimed at edges and vertices.
    #[test]
    fn watertight_hits_agrees_with_decide(a in finite_vec(10.0), b in finite_vec(10.0), c in finite_vec(10.0), o in finite_vec(20.0),
                                          aim in finite_vec(10.0), at_edge in 0usize..4, s in 0.0f32..1.0, t_max in 0.0f32..40.0) {
        use raylume_intersect::{ShearedRay, watertight_decide, watertight_hits};
        let tri = Triangle::new(a, b, c);
        let target = if at_edge < 3 { tri.p[at_edge].lerp(tri.p[(at_edge + 1) % 3], s) } else { aim };
        let Some(dir) = (target - o).try_normalize() else { return Ok(()) };
        let Some(sheared) = ShearedRay::new(&Ray::new(o, dir)) else { return Ok(()) };
        for range in [Interval::POSITIVE, Interval::new(0.0, t_max)] {
            prop_assert_eq!(watertight_hits(&tri, &sheared, range), watertight_decide(&tri, &sheared, range).is_some());
        }
    }

    /// The ray's frame: `kz` is the axis of the largest |direction| (ties to the later axis), `kx`
    /// and `ky` follow it cyclically and swap when the direction along `kz` is negative, so that the
    /// sheared triangle keeps its winding; directions with many equal or zero components included.
    #[test]
    fn sheared_ray_frame(d in prop::array::uniform3(prop_oneof![Just(0.0f32), Just(1.0), Just(-1.0), -2.0f32..2.0])) {
        use raylume_intersect::ShearedRay;
        let dir = Vec3A::from_array(d);
        let sheared = ShearedRay::new(&Ray::new(Vec3A::ZERO, dir));
        let a = dir.abs();
        let kz = if a.x > a.y { if a.x > a.z { 0 } else { 2 } } else if a.y > a.z { 1 } else { 2 };
        if d[kz] == 0.0 {
            prop_assert!(sheared.is_none());
            return Ok(());
        }
        let s = sheared.unwrap();
        let (kx, ky) = if d[kz] < 0.0 { ((kz + 2) % 3, (kz + 1) % 3) } else { ((kz + 1) % 3, (kz + 2) % 3) };
        prop_assert_eq!(s.axes, [kx, ky, kz]);
        prop_assert!((0..3).all(|k| a[kz] >= a[k]));
        let sz = 1.0 / d[kz];
        prop_assert_eq!(s.shear, [d[kx] * sz, d[ky] * sz, sz]);
    }

    /// Sphere hits lie on the sphere within their error bound, at any scale and offset.
    #[test]
    fn sphere_points_within_error_bound(c in finite_vec(1e5), r in log_uniform(-3.0, 5.0), o in finite_vec(1.0), aim in finite_vec(1.0)) {
        let sphere = Sphere { center: c, radius: r };
        let origin = c + o.normalize_or(Vec3A::X) * (r * 3.0);
        let target = c + aim * (r * 0.5);
        let ray = Ray::new(origin, (target - origin).normalize_or(Vec3A::X));
        if let Some(h) = sphere.intersect(&ray, Interval::POSITIVE) {
            prop_assert!(h.t.is_finite() && h.t >= 0.0 && h.error.is_finite());
            let pc: f64 = (0..3).map(|k| (h.point[k] as f64 - c[k] as f64).powi(2)).sum::<f64>().sqrt();
            let allowed: f64 = (0..3).map(|k| (h.normal[k] as f64).abs() * h.error[k] as f64).sum();
            prop_assert!((pc - r as f64).abs() <= allowed + 1e-12, "{:e} off, bound {:e}", pc - r as f64, allowed);
        }
    }

    /// Planes: any hit has a finite t matching f64 within 4 u t, for every kind of direction.
    #[test]
    fn plane_hits_match_f64(n in finite_vec(1.0), p in finite_vec(1e3), o in finite_vec(1e3), d in finite_vec(1.0), zero in 0usize..4) {
        let Some(normal) = n.try_normalize() else { return Ok(()) };
        let plane = Plane { point: p, normal };
        let mut d = d;
        if zero < 3 {
            d[zero] = if zero == 1 { -0.0 } else { 0.0 };
        }
        let ray = Ray::new(o, d);
        if let Some(h) = plane.intersect(&ray, Interval::POSITIVE) {
            prop_assert!(h.t.is_finite() && h.point.is_finite());
            let (n64, d64) = (normal.to_array().map(f64::from), d.to_array().map(f64::from));
            let den: f64 = (0..3).map(|k| n64[k] * d64[k]).sum();
            let num: f64 = (0..3).map(|k| n64[k] * (p[k] as f64 - o[k] as f64)).sum();
            let t_ref = num / den;
            prop_assert!((h.t as f64 - t_ref).abs() <= 4.0 * U * t_ref.abs(), "t {} vs {}", h.t, t_ref);
        }
    }

    /// Cones and cylinders: no NaN, and hits lie on the lateral surface between the caps.
    #[test]
    fn cone_hits_lie_on_the_surface(base in finite_vec(5.0), axis in finite_vec(3.0), r0 in 0.0f32..2.0, r1 in 0.0f32..2.0,
                                    o in finite_vec(10.0), d in finite_vec(1.0)) {
        prop_assume!(axis.length() > 0.1 && r0 + r1 > 0.05);
        let cone = Cone { base, base_radius: r0, apex: base + axis, apex_radius: r1 };
        let Some(dir) = d.try_normalize() else { return Ok(()) };
        if let Some(h) = cone.intersect(&Ray::new(o, dir), Interval::POSITIVE) {
            prop_assert!(h.t.is_finite() && h.point.is_finite() && h.normal.is_finite());
            let w = axis.normalize();
            let along = (h.point - base).dot(w);
            prop_assert!(along >= -1e-3 && along <= axis.length() + 1e-3);
            let radial = ((h.point - base) - w * along).length();
            let expected = r0 + (r1 - r0) * along / axis.length();
            prop_assert!((radial - expected).abs() <= 1e-3 * (1.0 + o.length()), "radius {radial} vs {expected}");
        }
    }

    /// A moving sphere at the ray's time is the sphere at that time.
    #[test]
    fn moving_sphere_is_the_sphere_at_the_ray_time(c0 in finite_vec(10.0), c1 in finite_vec(10.0), time in 0.0f32..1.0,
                                                   o in finite_vec(30.0), d in finite_vec(1.0)) {
        let m = MovingSphere { center0: c0, center1: c1, radius: 1.0, time0: 0.0, time1: 1.0 };
        let Some(dir) = d.try_normalize() else { return Ok(()) };
        let ray = Ray::with_time(o, dir, time);
        prop_assert_eq!(m.intersect(&ray, Interval::POSITIVE), m.at(time).intersect(&ray, Interval::POSITIVE));
        let b = m.bounds_over(Interval::new(0.0, 1.0));
        prop_assert!(b.contains(m.center_at(time)));
    }
}

proptest! {
    /// A ray from on or just inside a sphere (or just outside it) that `leaves_sphere_within` says
    /// meets the sphere is occluded by the sphere's own routine: spheres at scales 1e-14..1e14, centres
    /// up to 1e3 radii away from the origin of coordinates, origins from 1/4096 of the radius inside
    /// the surface to 40/4096 outside it, every direction, and ends from 1.5 to 4 radii along the ray and beyond.
    #[test]
    fn rays_leaving_a_sphere_are_occluded_by_it(scale in -14i32..=14, offset in finite_vec(1e3), r in 0.5f32..2.0,
                                                 at in unit_vec(), depth in prop_oneof![-1.0f32..0.5, 0.5f32..40.0], seed in 0u32..1000) {
        let unit = 10f32.powi(scale);
        let radius = r * unit;
        let sphere = Sphere { center: offset * unit, radius };
        let origin = sphere.center + at * (radius * (1.0 + depth / 4096.0));
        let from_centre = (0..3).map(|k| (origin[k] as f64 - sphere.center[k] as f64).powi(2)).sum::<f64>().sqrt();
        // Within the band the test allows, by a margin: heading well inwards, such rays are decided.
        let in_band = from_centre <= radius as f64 * (1.0 + 1.0 / 32768.0);
        for k in 0..64u32 {
            // Directions spread over the sphere of directions, many near grazing the surface.
            let h = (seed.wrapping_mul(2654435761) ^ k.wrapping_mul(40503)) as f32 / u32::MAX as f32;
            let phi = k as f32 * 2.399_963;
            let cos = if k % 4 == 0 { (h - 0.5) * 0.1 } else { 2.0 * h - 1.0 };
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let (u, w) = at.any_orthonormal_pair();
            let dir = (-at * cos + (u * phi.cos() + w * phi.sin()) * sin).normalize();
            let Some((ray, _)) = Ray::new(origin, dir).canonical() else { continue };
            let reach = radius / ray.dir.length();
            for t_max in [1.5, 1.9, 2.0, 2.05, 2.5, 2.6, 4.0].map(|k| k * reach).into_iter().chain([f32::INFINITY]) {
                let decided = raylume_intersect::leaves_sphere_within(&sphere, &ray, t_max);
                if decided {
                    prop_assert!(sphere.occluded_canonical(&ray, t_max),
                        "said to leave within {t_max:e}: {ray:?} from {:e} of the radius", depth / 4096.0);
                }
                // Not vacuous: rays heading well inwards from the band, to a light past the sphere.
                prop_assert!(decided || !(in_band && cos > 0.05 && t_max >= 2.6 * reach), "undecided: {ray:?}");
            }
        }
    }
}
