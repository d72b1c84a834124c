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
    let b = m.bounds_over(Interval::new(0.0, 1.0));
    assert_eq!(b, Aabb::new(v(-1.0, -1.0, -6.0), v(11.0, 1.0, -4.0)));
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
