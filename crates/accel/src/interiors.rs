//! The insides of glass spheres: a ray that starts inside one (refracted into a glass ball, reflected
//! inside it, or a shadow ray from its inner surface) meets that sphere on its way out, and before
//! anything else but the few shapes that reach into the sphere.

use glam::DVec3;
use raylume_geometry::{Aabb, Interval, Plane, Ray, Sphere, Triangle, Vec3A};
use raylume_intersect::{Intersect, leaves_sphere_within};

use crate::PrimitiveHit;

/// Most sphere-primitive pairs [`Interiors::new`] examines; past it, no sphere's inside rays are
/// answered (its shadow rays still are).
const MOST_PAIRS: usize = 1 << 20;

/// Most shapes that may reach into a sphere whose inside rays [`Interiors::closest_hit`] answers.
const MOST_NEAR: usize = 8;

/// How far every other primitive must stay from a sphere (or be one of its near shapes), relative to
/// the scene's coordinates there: far more than the rounding of a point spawned inside the sphere, or
/// of a hit on the other primitive, can move either.
const CLEARANCE: f64 = 1.0 / 8192.0;

/// The spheres of a list of primitives that rays start inside (glass balls), by the sphere's own
/// routine on the canonical ray, as every accelerator runs it:
///
/// - [`Interiors::closest_hit`]: where no other primitive comes near the sphere but a few spheres and
///   planes (its *near* shapes), a ray that starts inside it (within the rounding of its surface)
///   finds its closest hit on it or on one of those, and an accelerator over the whole list reports
///   the same hit (no other primitive has a point inside);
/// - [`Interiors::occluded`]: a shadow ray from inside meets the sphere on its way out, and any-hit
///   queries are answered by any primitive met, so the accelerator's answer is the same: occluded.
///
/// ```
/// use raylume_accel::{Accelerator, BruteForce, Interiors};
/// use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
/// use raylume_intersect::Primitive;
/// let prims = vec![
///     Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 }),
///     Primitive::Sphere(Sphere { center: Vec3A::new(3.0, 0.0, 0.0), radius: 1.0 }),
/// ];
/// let interiors = Interiors::new(&prims, |_| true, Interval::new(0.0, 0.0));
/// let list = BruteForce::new(prims);
/// let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
/// let from_inside = interiors.closest_hit(&ray, Interval::POSITIVE, 0).unwrap();
/// assert_eq!(Some(from_inside), list.closest_hit(&ray, Interval::POSITIVE));
/// assert_eq!(from_inside.hit.t, 1.0);
/// // Towards a light beyond the second ball: occluded on the way out of the first.
/// assert!(interiors.occluded(&ray, 10.0, 0) && list.occluded(&ray, 10.0));
/// ```
#[derive(Clone, Debug, Default)]
pub struct Interiors {
    /// By primitive index, the place in `spheres` of the primitive's sphere if it was asked for, else
    /// `u32::MAX`; empty if none was.
    slots: Vec<u32>,
    spheres: Vec<Inside>,
    /// The near shapes of each sphere, with their primitive indices.
    near: Vec<(u32, Near)>,
}

/// A sphere rays start inside, and, if their hits are answered, how far from its centre a ray may
/// start to be taken as starting inside it, and the shapes near it.
#[derive(Clone, Copy, Debug)]
struct Inside {
    sphere: Sphere,
    /// The square of that distance (the radius and half the clearance); negative where the sphere's
    /// inside rays go to the accelerator.
    reach2: f64,
    /// The sphere's near shapes: `near[first..first + count]`.
    first: u32,
    count: u32,
}

/// A shape that reaches into a sphere, tested by its own routine as every accelerator tests it.
#[derive(Clone, Copy, Debug)]
enum Near {
    Sphere(Sphere),
    Plane(Plane),
}

impl Interiors {
    /// The spheres of `prims` among those `wanted` picks (by index), and the near shapes of those
    /// whose inside rays are answered, moving primitives taken over `shutter`. Examines every pair of
    /// a wanted sphere and another primitive, unless there are more than about a million pairs: then
    /// no sphere's inside rays are answered.
    pub fn new<P: Intersect>(prims: &[P], wanted: impl Fn(usize) -> bool, shutter: Interval) -> Self {
        let candidates: Vec<usize> =
            (0..prims.len()).filter(|&i| wanted(i) && prims[i].as_sphere().is_some_and(|s| s.radius > 0.0)).collect();
        if candidates.is_empty() {
            return Self::default();
        }
        let examine = candidates.len().saturating_mul(prims.len()) <= MOST_PAIRS;
        let mut slots = vec![u32::MAX; prims.len()];
        let mut spheres = Vec::with_capacity(candidates.len());
        let mut near = Vec::new();
        for i in candidates {
            let Some(sphere) = prims[i].as_sphere() else { continue };
            let first = near.len();
            let mut answered = examine;
            for (j, other) in prims.iter().enumerate() {
                if !answered {
                    break;
                }
                if j == i || apart(&sphere, other, shutter) {
                    continue;
                }
                let shape = match (other.as_sphere(), other.as_plane()) {
                    (Some(s), _) => Some(Near::Sphere(s)),
                    (_, Some(p)) => Some(Near::Plane(p)),
                    _ => None,
                };
                match shape {
                    Some(shape) if near.len() - first < MOST_NEAR => near.push((j as u32, shape)),
                    _ => answered = false,
                }
            }
            if !answered {
                near.truncate(first);
            }
            let reach = sphere.radius as f64 + 0.5 * CLEARANCE * scale(&sphere);
            slots[i] = spheres.len() as u32;
            let (first, count) = (first as u32, (near.len() - first) as u32);
            spheres.push(Inside { sphere, reach2: if answered { reach * reach } else { -1.0 }, first, count });
        }
        Self { slots, spheres, near }
    }

    /// The closest hit within `t_range` of `ray`, which starts inside primitive `inside` (a spawned
    /// ray, within the rounding of its surface), if that primitive is a sphere whose inside rays are
    /// answered, the ray starts within half the clearance of it, and meets it: the answer of an
    /// accelerator over the whole list (the closest of the sphere's hit and its near shapes', the
    /// lowest index on a tie). `None` where the accelerator must be asked.
    #[inline(always)]
    pub fn closest_hit(&self, ray: &Ray, t_range: Interval, inside: u32) -> Option<PrimitiveHit> {
        let &Inside { sphere, reach2, first, count } = self.sphere(inside)?;
        // A NaN origin is not inside either.
        let starts_inside = ray.origin.as_dvec3().distance_squared(sphere.center.as_dvec3()) <= reach2;
        if !starts_inside {
            return None;
        }
        if count == 0 && ray.is_canonical() && ray.origin.is_finite() && !ray.time.is_nan() {
            // A clear sphere: its own hit, as it is (`closest_on_canonical`'s check of a canonical ray,
            // written here: through it, beside the near shapes' loop, the query compiles longer).
            return sphere.intersect_canonical(ray, t_range).map(|hit| PrimitiveHit { hit, primitive: inside });
        }
        crate::closest_on_canonical(ray, t_range, |ray, t_range| {
            let mut best = Some(PrimitiveHit { hit: sphere.intersect_canonical(ray, t_range)?, primitive: inside });
            for &(primitive, shape) in &self.near[first as usize..(first + count) as usize] {
                // Each shape's first hit in the whole range: within a smaller one, the same or none.
                let hit = match shape {
                    Near::Sphere(s) => s.intersect_canonical(ray, t_range),
                    Near::Plane(p) => p.intersect_canonical(ray, t_range),
                };
                if let Some(hit) = hit {
                    PrimitiveHit::keep_closer(&mut best, PrimitiveHit { hit, primitive });
                }
            }
            best
        })
    }

    /// Whether `ray` (a shadow ray from inside primitive `inside`) meets that primitive within
    /// `(0, t_max)`, if it is one of the spheres: then every accelerator answers that it is occluded.
    /// `false` says nothing of the other primitives.
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_max: f32, inside: u32) -> bool {
        let Some(Inside { sphere, .. }) = self.sphere(inside) else { return false };
        // Most such rays head well into the sphere towards a light beyond it: no roots needed.
        if leaves_sphere_within(sphere, ray, t_max) && !ray.time.is_nan() {
            return true;
        }
        crate::occluded_on_canonical(ray, t_max, |ray, t_max| sphere.occluded_canonical(ray, t_max))
    }

    /// Whether the closest hits of rays inside any of the spheres are answered.
    pub fn answers_any(&self) -> bool {
        self.spheres.iter().any(|s| s.reach2 >= 0.0)
    }

    /// The sphere of primitive `index`, if it was asked for.
    #[inline(always)]
    fn sphere(&self, index: u32) -> Option<&Inside> {
        self.spheres.get(*self.slots.get(index as usize)? as usize)
    }
}

/// The size the clearance of `sphere` is relative to: its radius or its centre's largest coordinate.
fn scale(sphere: &Sphere) -> f64 {
    sphere.center.as_dvec3().abs().max_element().max(sphere.radius as f64)
}

/// Whether `other` stays farther than the clearance from `sphere`'s surface on the outside.
fn apart<P: Intersect>(sphere: &Sphere, other: &P, shutter: Interval) -> bool {
    let c = sphere.center.as_dvec3();
    let r = sphere.radius as f64;
    let scale = scale(sphere);
    let far = |distance: f64, extent: f64| distance > r + CLEARANCE * scale.max(extent);
    // A gap along one axis between the box and the centre: the box's distance is no smaller.
    let gap = |b: &Aabb, extent: f64| {
        let (lo, hi) = (b.min.as_dvec3() - c, c - b.max.as_dvec3());
        (0..3).any(|k| far(lo[k], extent) || far(hi[k], extent))
    };
    if let Some(t) = other.as_triangle() {
        // The vertices' box holds every point of the triangle.
        let b = Aabb::new(t.p[0].min(t.p[1]).min(t.p[2]), t.p[0].max(t.p[1]).max(t.p[2]));
        let extent = b.min.abs().max(b.max.abs()).max_element() as f64;
        return gap(&b, extent) || far(triangle_distance(c, &t), extent);
    }
    if let Some(plane) = other.as_plane() {
        let (p, n) = (plane.point.as_dvec3(), plane.normal.as_dvec3());
        return far((c - p).dot(n).abs() / n.length(), p.abs().max_element());
    }
    let bounds = other.bounds_over(shutter);
    if bounds.is_empty() {
        // Nothing can be hit.
        return true;
    }
    if !bounds.is_finite() {
        return false;
    }
    let extent = bounds.min.abs().max(bounds.max.abs()).max_element() as f64;
    if gap(&bounds, extent) || far(box_distance(c, &bounds), extent) {
        return true;
    }
    if let Some(s) = other.as_sphere() {
        return far(c.distance(s.center.as_dvec3()) - s.radius as f64, extent);
    }
    false
}

/// The distance from `p` to the box `b` (zero inside).
fn box_distance(p: DVec3, b: &Aabb) -> f64 {
    (b.min.as_dvec3() - p).max(p - b.max.as_dvec3()).max(DVec3::ZERO).length()
}

/// The distance from `p` to the triangle `t` (its closest point by the regions of its vertices,
/// edges and face, as in Ericson's *Real-Time Collision Detection*, 5.1.5).
fn triangle_distance(p: DVec3, t: &Triangle) -> f64 {
    let [a, b, c] = t.p.map(Vec3A::as_dvec3);
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length();
    }
    let along = |from: DVec3, dir: DVec3, s: f64| p.distance(from + dir * s);
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return along(a, ab, d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return along(a, ac, d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return along(b, c - b, (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.is_nan() || denom <= 0.0 {
        // A degenerate triangle: taken as reaching the sphere.
        return 0.0;
    }
    let (v, w) = (vb / denom, vc / denom);
    p.distance(a + ab * v + ac * w)
}
