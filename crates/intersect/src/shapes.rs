//! One intersection routine per shape.

use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Ray, Sphere, Triangle, Vec2, Vec3A, gamma};

use glam::Vec4;

use crate::{Hit, Intersect, LaneRoots, RayLanes, intersect_watertight, sphere_roots};

/// The body of `intersect` or `occluded` of a shape whose `*_canonical` routine takes canonical rays:
/// that routine directly for a canonical ray, else on the ray rescaled (out of line).
macro_rules! on_canonical_ray {
    ($self:ident, intersect, $ray:ident, $t_range:ident) => {
        if $ray.is_canonical() {
            $self.intersect_canonical($ray, $t_range)
        } else {
            rescaled($ray, $t_range, |ray, range| $self.intersect_canonical(ray, range))
        }
    };
    ($self:ident, occluded, $ray:ident, $t_max:ident) => {
        if $ray.is_canonical() {
            $self.occluded_canonical($ray, $t_max)
        } else {
            rescaled($ray, Interval::new(0.0, $t_max), |ray, range| {
                $self.occluded_canonical(ray, range.max).then_some(())
            })
            .is_some()
        }
    };
}

impl Intersect for Sphere {
    /// The careful quadratic of *Ray Tracing Gems* ch. 7 (the discriminant from the distance of the
    /// centre to the ray's line, the roots from the form that avoids cancellation) on the canonical
    /// ray ([`Ray::canonical`]), so exact in `|d|`; in f64 for radii and distances beyond 1e15 (or below
    /// 1e-15), where f32 squares would overflow or underflow.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        on_canonical_ray!(self, intersect, ray, t_range)
    }

    #[inline(always)]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        match sphere_root(self.center, self.radius, ray, t_range) {
            Root::At(t) => sphere_hit_at(self.center, self.radius, ray, t),
            Root::Miss => None,
            Root::Wide => sphere_hit(self.center, self.radius, ray, t_range),
        }
    }

    /// The roots only: no point, no normal.
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        on_canonical_ray!(self, occluded, ray, t_max)
    }

    #[inline(always)]
    fn occluded_canonical(&self, ray: &Ray, t_max: f32) -> bool {
        let range = Interval::new(0.0, t_max);
        match sphere_root(self.center, self.radius, ray, range) {
            Root::At(_) => true,
            Root::Miss => false,
            Root::Wide => sphere_hit(self.center, self.radius, ray, range).is_some(),
        }
    }

    /// [`sphere_roots`]: the f32 routine's operations, lane by lane.
    #[inline(always)]
    fn lane_roots(&self, rays: &RayLanes, min: Vec4, max: Vec4) -> LaneRoots {
        sphere_roots(self, rays, min, max)
    }

    #[inline(always)]
    fn hit_at_root(&self, ray: &Ray, t: f32, _: Interval) -> Option<Hit> {
        sphere_hit_at(self.center, self.radius, ray, t)
    }

    #[inline]
    fn as_sphere(&self) -> Option<Sphere> {
        Some(*self)
    }

    fn bounds(&self) -> Aabb {
        let (c, r) = (v64(self.center), self.radius as f64);
        Aabb::from_f64([0, 1, 2].map(|k| c[k] - r), [0, 1, 2].map(|k| c[k] + r))
    }
}

/// The hit of a (canonical) ray on the sphere of `center` and `radius` at `t`, a root
/// [`sphere_root`] found: the point reprojected onto the sphere, so that its error scales with the
/// sphere, not the ray.
#[inline(always)]
pub(crate) fn sphere_hit_at(center: Vec3A, radius: f32, ray: &Ray, t: f32) -> Option<Hit> {
    let offset = ray.at(t) - center;
    let len = offset.length();
    // `len > 0 && len.is_finite()` on the bits: 1 ..= f32::MAX's.
    if len.to_bits().wrapping_sub(1) >= f32::MAX.to_bits() {
        return None;
    }
    let normal = offset / len;
    let point = center + normal * radius;
    let q = (center.abs() + (normal * radius).abs()) * gamma(5);
    Some(Hit { t, point, normal, uv: Vec2::ZERO, error: q + curve_depth(q, radius) })
}

/// Whether a canonical ray that starts on `sphere`'s surface or inside it and heads inward by more than
/// a grazing angle certainly meets the sphere within `(0, t_max)`: a shadow ray leaving a glass ball
/// from its inner surface towards a light beyond it. `true` is the answer of the sphere's
/// [`Intersect::occluded_canonical`] on that ray, found without its roots; `false` says nothing.
///
/// The origin's distance from the centre is at most the radius and `2^-14` of it, the direction's
/// cosine with the line to the centre is above about `1/32`, and `t_max` reaches `2.5` radii along the
/// ray; then the line passes the centre within `0.9996` radii, the discriminant is positive for every
/// rounding of its terms (they err by about `2^-20` of the radius's square), the roots are not both
/// negative, and the larger one lies within `2.001` radii along the ray, so the routine finds a root
/// in the range.
///
/// ```
/// use raylume_geometry::{Ray, Sphere, Vec3A};
/// use raylume_intersect::{Intersect, leaves_sphere_within};
/// let ball = Sphere { center: Vec3A::ZERO, radius: 1.0 };
/// let ray = Ray::new(Vec3A::new(0.999_999, 0.0, 0.0), Vec3A::new(-0.8, 0.6, 0.0));
/// assert!(leaves_sphere_within(&ball, &ray, 100.0) && ball.occluded_canonical(&ray, 100.0));
/// // Short of the far side: the routine decides.
/// assert!(!leaves_sphere_within(&ball, &ray, 1.0));
/// ```
#[inline(always)]
pub fn leaves_sphere_within(sphere: &Sphere, ray: &Ray, t_max: f32) -> bool {
    let r2 = sphere.radius * sphere.radius;
    // Each coordinate rounded once, within 2^-24 of itself: the margins below are far wider.
    let f = ray.origin - sphere.center;
    let a = ray.dir.length_squared();
    let half_b = f.dot(ray.dir);
    sphere_radius_in_range(sphere.radius)
        && ray.is_canonical()
        && f.length_squared() <= r2 * (1.0 + 1.0 / 8192.0)
        && half_b < 0.0
        && half_b * half_b >= r2 * a * (1.0 / 1024.0)
        && t_max * t_max * a >= 6.25 * r2
}

/// Whether the f32 routine takes a sphere of this radius ([`sphere_root`]); beyond, f64 decides.
#[inline(always)]
pub(crate) fn sphere_radius_in_range(radius: f32) -> bool {
    (1e-15..=1e15).contains(&radius)
}

/// The first root of a sphere's quadratic within a range.
enum Root {
    /// At this ray parameter.
    At(f32),
    /// None in the range.
    Miss,
    /// Sizes beyond f32's squares: [`sphere_hit`] decides, in f64.
    Wide,
}

/// The first hit of a (canonical) ray on a sphere within `range`, in f32 with the squares that
/// cancel in f64.
#[inline(always)]
fn sphere_root(center: Vec3A, radius: f32, ray: &Ray, range: Interval) -> Root {
    if !sphere_radius_in_range(radius) {
        return Root::Wide;
    }
    let f = ray.origin - center;
    let a = ray.dir.length_squared();
    let half_b = f.dot(ray.dir);
    // |f|^2 - r^2 cancels when the origin is near the surface: form it in f64, where the squares of
    // f32 values are exact.
    let r2 = radius as f64 * radius as f64;
    let c = (sq64(f) - r2) as f32;
    // From outside, moving away: both roots are negative (as computed too: `q` is then negative and
    // `c` positive). With `c` finite and the radius in range, the discriminant is finite as well, so
    // the f64 path would not be taken either.
    if c > 0.0 && half_b > 0.0 && c < f32::INFINITY {
        return Root::Miss;
    }
    let closest = f - ray.dir * (half_b / a);
    let disc = a * (r2 - sq64(closest)) as f32;
    if disc.is_nan() || disc < 0.0 {
        return Root::Miss;
    }
    if disc == f32::INFINITY || c.abs() == f32::INFINITY {
        // Distances beyond f32's squares.
        return Root::Wide;
    }
    let q = -(half_b + disc.sqrt().copysign(half_b));
    let (t0, t1) = (c / q, q / a);
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    // Hits at t <= 0 are the surface the ray starts on, never reported. `t > 0 && range.contains(t)`
    // as three comparisons: a positive `t` is finite and at most `range.max` when at most `last`.
    let last = if range.max == f32::INFINITY { f32::MAX } else { range.max };
    let ahead = |t: f32| t > 0.0 && t >= range.min && t <= last;
    if ahead(t0) {
        Root::At(t0)
    } else if ahead(t1) {
        Root::At(t1)
    } else {
        Root::Miss
    }
}

/// How far below a curved surface (radius of curvature `radius`, positive) a point displaced by up to
/// `q` per axis can be: `|q|^2 / 2r`, at most `|q|` (here the larger sum of `q`'s coordinates), on every axis, so that a ray spawned past the bound along
/// the normal starts off the surface even where the surface turns within the error box.
#[inline]
fn curve_depth(q: Vec3A, radius: f32) -> Vec3A {
    // The sum of the coordinates bounds |q| from above, without a square root.
    Vec3A::splat((q.length_squared() * (0.5 / radius)).min(q.element_sum()))
}

/// `|v|^2` in f64 (each square exact).
#[inline(always)]
fn sq64(v: Vec3A) -> f64 {
    let (x, y, z) = (v.x as f64, v.y as f64, v.z as f64);
    x * x + y * y + z * z
}

/// The hit of a ray (canonical) on the sphere of `center` and `radius`, within `range`, all in f64:
/// for sizes beyond f32's squares.
#[cold]
#[inline(never)]
fn sphere_hit(center: Vec3A, radius: f32, ray: &Ray, range: Interval) -> Option<Hit> {
    let (c, o, d, r) = (v64(center), v64(ray.origin), v64(ray.dir), radius as f64);
    let f = sub(o, c);
    let a = dot(d, d);
    let half_b = dot(f, d);
    let r2 = r * r;
    let cc = dot(f, f) - r2;
    let s = half_b / a;
    let closest = [f[0] - d[0] * s, f[1] - d[1] * s, f[2] - d[2] * s];
    let disc = a * (r2 - dot(closest, closest));
    if !(0.0..f64::INFINITY).contains(&disc) {
        return None;
    }
    let q = -(half_b + disc.sqrt().copysign(half_b));
    if q == 0.0 {
        return None;
    }
    let (t0, t1) = (cc / q, q / a);
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    // Hits at t <= 0 are the surface the ray starts on, never reported.
    let ahead = |t: f64| t as f32 > 0.0 && range.contains(t as f32);
    let t64 = if ahead(t0) {
        t0
    } else if ahead(t1) {
        t1
    } else {
        return None;
    };
    // The point reprojected onto the sphere in f64: its error is the final rounding, not the ray's travel.
    let offset = [f[0] + d[0] * t64, f[1] + d[1] * t64, f[2] + d[2] * t64];
    let len = dot(offset, offset).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let n = offset.map(|x| x / len);
    let point = Vec3A::new((c[0] + n[0] * r) as f32, (c[1] + n[1] * r) as f32, (c[2] + n[2] * r) as f32);
    let error = rounding_error(point, radius.abs()) + (center.abs() + Vec3A::splat(radius.abs())) * F64_SLOP;
    let normal = Vec3A::new(n[0] as f32, n[1] as f32, n[2] as f32);
    Some(Hit { t: t64 as f32, point, normal, uv: Vec2::ZERO, error })
}

impl Intersect for MovingSphere {
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        self.at(ray.time).intersect(ray, t_range)
    }

    #[inline]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        self.at(ray.time).intersect_canonical(ray, t_range)
    }

    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.at(ray.time).occluded(ray, t_max)
    }

    #[inline]
    fn occluded_canonical(&self, ray: &Ray, t_max: f32) -> bool {
        self.at(ray.time).occluded_canonical(ray, t_max)
    }

    fn bounds(&self) -> Aabb {
        self.at(self.time0).bounds()
    }

    /// The spheres at both ends of the shutter, and a margin for the rounding of the centre's
    /// interpolation at the instants between them.
    fn bounds_over(&self, shutter: Interval) -> Aabb {
        let (a, b) = (self.at(shutter.min), self.at(shutter.max));
        let margin = (a.center.abs().max(b.center.abs()) + (self.center1 - self.center0).abs()) * gamma(4);
        let grow = |s: Sphere| Sphere { center: s.center, radius: s.radius }.bounds();
        let boxed = grow(a).union(grow(b));
        let (lo, hi) = (boxed.min - margin, boxed.max + margin);
        Aabb::from_f64(lo.to_array().map(|x| x as f64), hi.to_array().map(|x| x as f64)).union(boxed)
    }
}

impl Intersect for Triangle {
    /// The watertight test of Woop, Benthin and Wald ([`intersect_watertight`]).
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        intersect_watertight(self, ray, t_range)
    }

    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        crate::watertight::occludes(self, ray, t_max)
    }

    #[inline]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let sheared = crate::ShearedRay::new(ray)?;
        crate::watertight_decide(self, &sheared, t_range).map(|h| h.hit(self))
    }

    #[inline]
    fn occluded_canonical(&self, ray: &Ray, t_max: f32) -> bool {
        crate::ShearedRay::new(ray)
            .is_some_and(|sheared| crate::watertight_hits(self, &sheared, Interval::new(0.0, t_max)))
    }

    #[inline]
    fn as_triangle(&self) -> Option<Triangle> {
        Some(*self)
    }

    fn bounds(&self) -> Aabb {
        Triangle::bounds(self)
    }
}

/// Möller–Trumbore ray/triangle intersection, the course's choice, kept for comparison: it is not
/// watertight (rays through shared edges and vertices can pass between triangles). Degenerate
/// triangles never hit and no hit carries a NaN.
#[inline]
pub fn intersect_moller_trumbore(tri: &Triangle, ray: &Ray, t_range: Interval) -> Option<Hit> {
    let e1 = tri.p[1] - tri.p[0];
    let e2 = tri.p[2] - tri.p[0];
    let pvec = ray.dir.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = ray.origin - tri.p[0];
    let b1 = tvec.dot(pvec) * inv_det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let b2 = ray.dir.dot(qvec) * inv_det;
    if !(b2 >= 0.0 && b1 + b2 <= 1.0) {
        return None;
    }
    let t = e2.dot(qvec) * inv_det;
    if !t_range.contains(t) || t <= 0.0 {
        return None;
    }
    let normal = e1.cross(e2).normalize_or_zero();
    if normal == Vec3A::ZERO || !normal.is_finite() {
        return None;
    }
    Some(Hit { t, point: ray.at(t), normal, uv: Vec2::new(b1, b2), error: travel_error(ray, t, 7) })
}

impl Intersect for Plane {
    #[inline]
    fn as_plane(&self) -> Option<Plane> {
        Some(*self)
    }

    /// A ray parallel to the plane (or lying in it) never hits.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        on_canonical_ray!(self, intersect, ray, t_range)
    }

    #[inline]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        plane_hit(self, ray, t_range)
    }

    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        on_canonical_ray!(self, occluded, ray, t_max)
    }

    /// The distance only: no point.
    #[inline]
    fn occluded_canonical(&self, ray: &Ray, t_max: f32) -> bool {
        plane_distance(self, ray, Interval::new(0.0, t_max)).is_some()
    }

    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::NEG_INFINITY, Vec3A::INFINITY)
    }
}

/// The distance along a canonical ray to a plane, if it lies in `t_range` and beyond 0.
#[inline(always)]
fn plane_distance(plane: &Plane, ray: &Ray, t_range: Interval) -> Option<f32> {
    // In f64: near-parallel rays make n.d cancel, and f32 would lose t there.
    let (n, d) = (v64(plane.normal), v64(ray.dir));
    let denom = dot(n, d);
    if denom == 0.0 {
        return None;
    }
    let t = (dot(n, sub(v64(plane.point), v64(ray.origin))) / denom) as f32;
    (t_range.contains(t) && t > 0.0).then_some(t)
}

/// [`Plane`]'s intersection on a canonical ray.
#[inline]
fn plane_hit(plane: &Plane, ray: &Ray, t_range: Interval) -> Option<Hit> {
    let t = plane_distance(plane, ray, t_range)?;
    let point = ray.at(t);
    let error = (ray.origin.abs() + plane.point.abs() + (ray.dir * t).abs()) * gamma(7);
    Some(Hit { t, point, normal: plane.normal, uv: Vec2::ZERO, error })
}

impl Intersect for AaBox {
    /// The slab test. A ray from outside hits where it enters; a ray from inside (or starting on a
    /// face and going in) hits where it leaves. The normal is the face's, outward, chosen from the
    /// slab that decided the entry or the exit, so it always agrees with the ray's direction (ties at
    /// edges and corners go to the lowest axis); the point is put exactly on that face.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        on_canonical_ray!(self, intersect, ray, t_range)
    }

    #[inline]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        box_hit(self, ray, t_range)
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// [`AaBox`]'s intersection on a canonical ray.
#[inline]
fn box_hit(aabox: &AaBox, ray: &Ray, t_range: Interval) -> Option<Hit> {
    let inv = ray.dir.recip();
    let (t0, t1) = aabox.bounds.hit_range(ray, inv, f32::NEG_INFINITY, f32::INFINITY)?;
    // A ray starting on a face (or an edge) and leaving through it meets the box at t = 0: no hit.
    let entering = t0 > 0.0 && t_range.contains(t0);
    let t = if entering {
        t0
    } else if t1 > 0.0 && t_range.contains(t1) {
        t1
    } else {
        return None;
    };
    let t_lo = (aabox.bounds.min - ray.origin) * inv;
    let t_hi = (aabox.bounds.max - ray.origin) * inv;
    let parallel = ray.dir.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE)) | t_lo.is_nan_mask() | t_hi.is_nan_mask();
    let near = Vec3A::select(parallel, Vec3A::NEG_INFINITY, t_lo.min(t_hi));
    let far = Vec3A::select(parallel, Vec3A::INFINITY, t_lo.max(t_hi));
    let mut face = 0;
    for a in 1..3 {
        if (entering && near[a] > near[face]) || (!entering && far[a] < far[face]) {
            face = a;
        }
    }
    let positive = ray.dir[face] > 0.0;
    let outward = if entering { !positive } else { positive };
    let mut normal = Vec3A::ZERO;
    normal[face] = if outward { 1.0 } else { -1.0 };
    let mut point = ray.at(t);
    point[face] = if outward { aabox.bounds.max[face] } else { aabox.bounds.min[face] };
    // The face coordinate is exact; a one-ulp bound still makes spawned rays start off the face.
    let mut error = travel_error(ray, t, 3);
    error[face] = (point[face].abs() * gamma(1)).max(f32::MIN_POSITIVE);
    // The other coordinates lie in the box's extent exactly; rounding must not take them out.
    let point = point.clamp(aabox.bounds.min, aabox.bounds.max);
    Some(Hit { t, point, normal, uv: Vec2::ZERO, error })
}

impl Intersect for Cone {
    /// The NFF cone: the lateral surface between the two caps, which are open. In f64, in the frame
    /// of the cone's axis, on the canonical ray; the point is reprojected onto the surface, so its
    /// error is the final rounding to f32.
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        on_canonical_ray!(self, intersect, ray, t_range)
    }

    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        cone_hit(self, ray, t_range)
    }

    fn bounds(&self) -> Aabb {
        let (base, apex) = (v64(self.base), v64(self.apex));
        let axis = sub(apex, base);
        let h = dot(axis, axis).sqrt();
        if !(h > 0.0 && h.is_finite()) {
            return Cone::bounds(self);
        }
        // Extent of a disc of radius r with unit normal w along each world axis: r sqrt(1 - w_i^2),
        // with a margin for the f64 roundings of the hit points.
        let e = axis.map(|a| (1.0 - (a / h) * (a / h)).max(0.0).sqrt());
        let slop = (base.iter().chain(&apex).fold(0.0f64, |m, x| m.max(x.abs()))
            + self.base_radius.abs().max(self.apex_radius.abs()) as f64
            + h)
            * F64_SLOP as f64;
        let ends = [(base, self.base_radius.abs() as f64), (apex, self.apex_radius.abs() as f64)];
        let lo = [0, 1, 2].map(|k| ends.iter().map(|(c, r)| c[k] - e[k] * r).fold(f64::INFINITY, f64::min) - slop);
        let hi = [0, 1, 2].map(|k| ends.iter().map(|(c, r)| c[k] + e[k] * r).fold(f64::NEG_INFINITY, f64::max) + slop);
        Aabb::from_f64(lo, hi)
    }
}

/// The hit of a ray (canonical) on the lateral surface of `cone`, within `range`.
#[inline]
fn cone_hit(cone: &Cone, ray: &Ray, range: Interval) -> Option<Hit> {
    let (base, apex) = (v64(cone.base), v64(cone.apex));
    let axis = sub(apex, base);
    let height = dot(axis, axis).sqrt();
    if !(height > 0.0 && height.is_finite()) {
        return None;
    }
    let w = axis.map(|a| a / height);
    let (u, v) = basis64(w);
    let local = |p: [f64; 3]| [dot(p, u), dot(p, v), dot(p, w)];
    let o = local(sub(v64(ray.origin), base));
    let d = local(v64(ray.dir));
    let (r0, k) = (cone.base_radius as f64, (cone.apex_radius as f64 - cone.base_radius as f64) / height);
    let rz = r0 + k * o[2];
    let a = d[0] * d[0] + d[1] * d[1] - k * k * d[2] * d[2];
    let b = 2.0 * (o[0] * d[0] + o[1] * d[1] - k * rz * d[2]);
    let c = o[0] * o[0] + o[1] * o[1] - rz * rz;
    for t in solve_quadratic(a, b, c)? {
        if !range.contains(t as f32) || t as f32 <= 0.0 {
            continue;
        }
        let z = o[2] + t * d[2];
        if !(0.0..=height).contains(&z) {
            continue;
        }
        // Reproject onto the surface at this height.
        let radius = r0 + k * z;
        let (x, y) = (o[0] + t * d[0], o[1] + t * d[1]);
        let rho = (x * x + y * y).sqrt();
        if !(rho > 0.0 && rho.is_finite()) {
            continue;
        }
        let (x, y) = (x * (radius.abs() / rho), y * (radius.abs() / rho));
        let world = |lx: f64, ly: f64, lz: f64| [0, 1, 2].map(|i| u[i] * lx + v[i] * ly + w[i] * lz);
        let p = world(x, y, z);
        let n = world(x, y, -k * radius);
        let len = dot(n, n).sqrt();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let point = Vec3A::new((base[0] + p[0]) as f32, (base[1] + p[1]) as f32, (base[2] + p[2]) as f32);
        let normal = Vec3A::new((n[0] / len) as f32, (n[1] / len) as f32, (n[2] / len) as f32);
        let magnitude = cone.base.abs() + Vec3A::splat((radius.abs() + z.abs()) as f32);
        let error = rounding_error(point, radius.abs() as f32) + magnitude * F64_SLOP;
        return Some(Hit { t: t as f32, point, normal, uv: Vec2::ZERO, error });
    }
    None
}

/// The error bound of a point of a curved surface (radius of curvature `radius`) rounded from f64 to
/// f32: half an ulp per coordinate, and the [depth](curve_depth) that rounding can reach below the
/// surface.
#[inline]
fn rounding_error(point: Vec3A, radius: f32) -> Vec3A {
    let q = point.abs() * gamma(1);
    q + curve_depth(q, radius)
}

/// A bound on the relative error of the few dozen f64 operations behind a hit point (each within
/// 2^-53), for the error bound of points computed in f64 and rounded to f32.
const F64_SLOP: f32 = 1.0 / (1u64 << 44) as f32;

/// `query` (a routine that takes canonical rays) on the canonical form of `ray`
/// ([`Ray::canonical`]), its answer's `t` taken back: every routine answers alike for directions
/// `2^k d`. Out of line: accelerators pass canonical rays, so this is the path of direct calls only.
#[inline(never)]
pub(crate) fn rescaled<R: Rescale>(
    ray: &Ray,
    t_range: Interval,
    query: impl FnOnce(&Ray, Interval) -> Option<R>,
) -> Option<R> {
    let (ray, s) = ray.canonical()?;
    query(&ray, t_range.on_canonical(s)).map(|r| r.rescale(s))
}

/// An answer whose ray parameter scales back from a canonical ray.
pub(crate) trait Rescale {
    /// The answer with its parameter multiplied by `s`.
    fn rescale(self, s: f32) -> Self;
}

impl Rescale for Hit {
    #[inline(always)]
    fn rescale(self, s: f32) -> Self {
        Hit { t: self.t * s, ..self }
    }
}

impl Rescale for () {
    #[inline(always)]
    fn rescale(self, _: f32) -> Self {}
}

/// [`raylume_geometry::orthonormal_basis`] in f64.
#[inline]
fn basis64(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let sign = 1.0f64.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    ([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]], [b, sign + n[1] * n[1] * a, -n[1]])
}

#[inline(always)]
fn v64(v: Vec3A) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

#[inline(always)]
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The real roots of `a t^2 + b t + c = 0` in increasing order, computed without cancellation.
#[inline]
fn solve_quadratic(a: f64, b: f64, c: f64) -> Option<[f64; 2]> {
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let t = -c / b;
        return Some([t, t]);
    }
    let disc = b * b - 4.0 * a * c;
    if !(0.0..f64::INFINITY).contains(&disc) {
        return None;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    Some(if t0 <= t1 { [t0, t1] } else { [t1, t0] })
}

/// The error bound of a point computed as `o + t d` with `t` carrying `n` roundings.
#[inline]
fn travel_error(ray: &Ray, t: f32, n: i32) -> Vec3A {
    (ray.origin.abs() + (ray.dir * t).abs()) * gamma(n)
}
