//! One intersection routine per shape.

use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Ray, Sphere, Triangle, Vec2, Vec3A};

use crate::{Hit, Intersect};

impl Intersect for Sphere {
    /// The careful quadratic of *Ray Tracing Gems* ch. 7: the discriminant is taken from the distance
    /// of the centre to the ray's line, and the roots from the form that avoids cancellation.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let f = ray.origin - self.center;
        let a = ray.dir.length_squared();
        let half_b = f.dot(ray.dir);
        let c = f.length_squared() - self.radius * self.radius;
        let closest = f - ray.dir * (half_b / a);
        let disc = a * (self.radius * self.radius - closest.length_squared());
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
        let point = ray.at(t);
        let normal = (point - self.center) / self.radius;
        Some(Hit { t, point, normal, uv: Vec2::ZERO })
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
    /// Möller–Trumbore, the course's choice. Degenerate triangles (zero area) never hit.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let e1 = self.p[1] - self.p[0];
        let e2 = self.p[2] - self.p[0];
        let pvec = ray.dir.cross(e2);
        let det = e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv_det = 1.0 / det;
        let tvec = ray.origin - self.p[0];
        let b1 = tvec.dot(pvec) * inv_det;
        if !(0.0..=1.0).contains(&b1) {
            return None;
        }
        let qvec = tvec.cross(e1);
        let b2 = ray.dir.dot(qvec) * inv_det;
        if b2 < 0.0 || b1 + b2 > 1.0 {
            return None;
        }
        let t = e2.dot(qvec) * inv_det;
        if !t_range.contains(t) {
            return None;
        }
        let normal = e1.cross(e2).normalize_or_zero();
        if normal == Vec3A::ZERO {
            return None;
        }
        Some(Hit { t, point: ray.at(t), normal, uv: Vec2::new(b1, b2) })
    }

    fn bounds(&self) -> Aabb {
        Triangle::bounds(self)
    }
}

impl Intersect for Plane {
    /// A ray parallel to the plane (or lying in it) never hits.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let denom = self.normal.dot(ray.dir);
        if denom == 0.0 {
            return None;
        }
        let t = self.normal.dot(self.point - ray.origin) / denom;
        if !t_range.contains(t) {
            return None;
        }
        Some(Hit { t, point: ray.at(t), normal: self.normal, uv: Vec2::ZERO })
    }

    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::NEG_INFINITY, Vec3A::INFINITY)
    }
}

impl Intersect for AaBox {
    /// The slab test; a ray starting inside gets the exit point. The normal is the one of the face hit.
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        let inv = ray.dir.recip();
        let (t0, t1) = self.bounds.hit_range(ray, inv, f32::NEG_INFINITY, f32::INFINITY)?;
        let t = if t_range.contains(t0) {
            t0
        } else if t_range.contains(t1) {
            t1
        } else {
            return None;
        };
        let point = ray.at(t);
        // The face hit is the one the point is closest to, relative to the box size.
        let size = self.bounds.diagonal().max(Vec3A::splat(f32::MIN_POSITIVE));
        let d_min = ((point - self.bounds.min) / size).abs();
        let d_max = ((self.bounds.max - point) / size).abs();
        let mut best = f32::INFINITY;
        let mut normal = Vec3A::X;
        for axis in 0..3 {
            let mut unit = Vec3A::ZERO;
            unit[axis] = 1.0;
            if d_min[axis] < best {
                best = d_min[axis];
                normal = -unit;
            }
            if d_max[axis] < best {
                best = d_max[axis];
                normal = unit;
            }
        }
        Some(Hit { t, point, normal, uv: Vec2::ZERO })
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
            return Some(Hit { t, point: ray.at(t), normal: n, uv: Vec2::ZERO });
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
