//! One intersection routine per shape.

use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Ray, Sphere, Triangle, Vec2, Vec3A, gamma};

use crate::{Hit, Intersect, intersect_watertight};

impl Intersect for Sphere {
    /// The careful quadratic of *Ray Tracing Gems* ch. 7: the discriminant is taken from the distance
    /// of the centre to the ray's line, and the roots from the form that avoids cancellation.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let f = ray.origin - self.center;
        let a = ray.dir.length_squared();
        let half_b = f.dot(ray.dir);
        // |f|^2 - r^2 cancels when the origin is near the surface: form it in f64, where the squares
        // of f32 values are exact.
        let r2 = self.radius as f64 * self.radius as f64;
        let c = (sq64(f) - r2) as f32;
        let closest = f - ray.dir * (half_b / a);
        let disc = a * (r2 - sq64(closest)) as f32;
        if disc < 0.0 || !disc.is_finite() {
            return None;
        }
        let q = -(half_b + disc.sqrt().copysign(half_b));
        let (mut t0, mut t1) = (c / q, q / a);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = if t_range.contains(t0) {
            t0
        } else if t_range.contains(t1) {
            t1
        } else {
            return None;
        };
        // Reproject the point onto the sphere: its error then scales with the sphere, not the ray.
        let offset = ray.at(t) - self.center;
        let len = offset.length();
        if len.is_nan() || len <= 0.0 {
            return None;
        }
        let normal = offset / len;
        let point = self.center + normal * self.radius;
        let error = (self.center.abs() + (normal * self.radius).abs()) * gamma(5);
        Some(Hit { t, point, normal, uv: Vec2::ZERO, error })
    }

    fn bounds(&self) -> Aabb {
        Aabb::new(self.center - Vec3A::splat(self.radius), self.center + Vec3A::splat(self.radius))
    }
}

impl Intersect for MovingSphere {
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        self.at(ray.time).intersect(ray, t_range)
    }

    fn bounds(&self) -> Aabb {
        self.at(self.time0).bounds()
    }

    fn bounds_over(&self, shutter: Interval) -> Aabb {
        self.at(shutter.min).bounds().union(self.at(shutter.max).bounds())
    }
}

impl Intersect for Triangle {
    /// The watertight test of Woop, Benthin and Wald ([`intersect_watertight`]).
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        intersect_watertight(self, ray, t_range)
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
    if !t_range.contains(t) {
        return None;
    }
    let normal = e1.cross(e2).normalize_or_zero();
    if normal == Vec3A::ZERO || !normal.is_finite() {
        return None;
    }
    Some(Hit { t, point: ray.at(t), normal, uv: Vec2::new(b1, b2), error: travel_error(ray, t, 7) })
}

impl Intersect for Plane {
    /// A ray parallel to the plane (or lying in it) never hits.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        // In f64: near-parallel rays make n.d cancel, and f32 would lose t there.
        let (n, d) = (self.normal.to_array().map(f64::from), ray.dir.to_array().map(f64::from));
        let denom = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        if denom == 0.0 {
            return None;
        }
        let offset = [0, 1, 2].map(|k| self.point[k] as f64 - ray.origin[k] as f64);
        let t = ((n[0] * offset[0] + n[1] * offset[1] + n[2] * offset[2]) / denom) as f32;
        if !t_range.contains(t) {
            return None;
        }
        let point = ray.at(t);
        let error = (ray.origin.abs() + self.point.abs() + (ray.dir * t).abs()) * gamma(7);
        Some(Hit { t, point, normal: self.normal, uv: Vec2::ZERO, error })
    }

    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::NEG_INFINITY, Vec3A::INFINITY)
    }
}

impl Intersect for AaBox {
    /// The slab test. A ray from outside hits where it enters; a ray from inside (or starting on a
    /// face and going in) hits where it leaves. The normal is the face's, outward, chosen from the
    /// slab that decided the entry or the exit, so it always agrees with the ray's direction (ties at
    /// edges and corners go to the lowest axis); the point is put exactly on that face.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let inv = ray.dir.recip();
        let (t0, t1) = self.bounds.hit_range(ray, inv, f32::NEG_INFINITY, f32::INFINITY)?;
        let entering = t0 > 0.0 && t_range.contains(t0);
        let t = if entering {
            t0
        } else if t_range.contains(t1) {
            t1
        } else {
            return None;
        };
        let t_lo = (self.bounds.min - ray.origin) * inv;
        let t_hi = (self.bounds.max - ray.origin) * inv;
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
        point[face] = if outward { self.bounds.max[face] } else { self.bounds.min[face] };
        // The face coordinate is exact; a one-ulp bound still makes spawned rays start off the face.
        let mut error = travel_error(ray, t, 3);
        error[face] = (point[face].abs() * gamma(1)).max(f32::MIN_POSITIVE);
        Some(Hit { t, point, normal, uv: Vec2::ZERO, error })
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }
}

impl Intersect for Cone {
    /// The NFF cone: the lateral surface between the two caps, which are open.
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let axis_v = self.apex - self.base;
        let height = axis_v.length();
        if height == 0.0 || !height.is_finite() {
            return None;
        }
        let w = axis_v / height;
        let (u, v) = raylume_geometry::orthonormal_basis(w);
        let to_local = |p: Vec3A| Vec3A::new(p.dot(u), p.dot(v), p.dot(w));
        let o = to_local(ray.origin - self.base);
        let d = to_local(ray.dir);
        let k = (self.apex_radius - self.base_radius) / height;
        let r0 = self.base_radius;
        let rz = r0 + k * o.z;
        let a = d.x * d.x + d.y * d.y - k * k * d.z * d.z;
        let b = 2.0 * (o.x * d.x + o.y * d.y - k * rz * d.z);
        let c = o.x * o.x + o.y * o.y - rz * rz;
        let roots = solve_quadratic(a, b, c)?;
        for t in roots {
            if !t_range.contains(t) {
                continue;
            }
            let z = o.z + t * d.z;
            if !(0.0..=height).contains(&z) {
                continue;
            }
            let lp = o + d * t;
            let local_n = Vec3A::new(lp.x, lp.y, -k * (r0 + k * z));
            let n = (u * local_n.x + v * local_n.y + w * local_n.z).normalize_or_zero();
            if n == Vec3A::ZERO {
                continue;
            }
            return Some(Hit { t, point: ray.at(t), normal: n, uv: Vec2::ZERO, error: travel_error(ray, t, 9) });
        }
        None
    }

    fn bounds(&self) -> Aabb {
        Cone::bounds(self)
    }
}

/// The real roots of `a t^2 + b t + c = 0` in increasing order, computed without cancellation.
#[inline]
fn solve_quadratic(a: f32, b: f32, c: f32) -> Option<[f32; 2]> {
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let t = -c / b;
        return Some([t, t]);
    }
    let disc = (b as f64) * (b as f64) - 4.0 * (a as f64) * (c as f64);
    if disc < 0.0 || !disc.is_finite() {
        return None;
    }
    let q = -0.5 * (b as f64 + disc.sqrt().copysign(b as f64));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { ((q / a as f64) as f32, (c as f64 / q) as f32) };
    Some(if t0 <= t1 { [t0, t1] } else { [t1, t0] })
}

/// The error bound of a point computed as `o + t d` with `t` carrying `n` roundings.
#[inline]
fn travel_error(ray: &Ray, t: f32, n: i32) -> Vec3A {
    (ray.origin.abs() + (ray.dir * t).abs()) * gamma(n)
}

/// `|v|^2` in f64 (each square exact).
#[inline]
fn sq64(v: Vec3A) -> f64 {
    let (x, y, z) = (v.x as f64, v.y as f64, v.z as f64);
    x * x + y * y + z * z
}
