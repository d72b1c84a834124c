//! The watertight ray/triangle test of Woop, Benthin and Wald, split in three so that an accelerator
//! prepares the ray once ([`ShearedRay`]), decides each candidate triangle ([`watertight_decide`]) and
//! builds the full [`Hit`] of the closest one only ([`TriangleHit::hit`]).

use raylume_geometry::{Interval, Ray, Triangle, Vec2, Vec3A, gamma};

use crate::Hit;

/// A ray prepared for watertight triangle tests: the permutation and shear that map it onto the
/// +z axis from the origin. Computed once per ray, it serves every triangle the ray meets.
///
/// ```
/// use raylume_geometry::{Interval, Ray, Triangle, Vec3A};
/// use raylume_intersect::{ShearedRay, watertight_decide};
/// let ray = Ray::new(Vec3A::new(0.25, 0.25, 1.0), -Vec3A::Z);
/// let sheared = ShearedRay::new(&ray).unwrap();
/// let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
/// let hit = watertight_decide(&tri, &sheared, Interval::POSITIVE).unwrap();
/// assert_eq!(hit.t, 1.0);
/// assert_eq!(hit.hit(&tri).point, Vec3A::new(0.25, 0.25, 0.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShearedRay {
    /// The ray's origin.
    pub origin: Vec3A,
    /// The ray's direction.
    pub dir: Vec3A,
    /// `[kx, ky, kz]`: `kz` is the axis where the direction is largest; `kx`, `ky` the other two,
    /// swapped when the direction along `kz` is negative so that the winding is kept.
    pub axes: [usize; 3],
    /// `[sx, sy, sz] = [d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz]]`.
    pub shear: [f32; 3],
}

impl ShearedRay {
    /// Prepares `ray`; `None` if its direction has no usable largest component (zero or not finite).
    #[inline]
    pub fn new(ray: &Ray) -> Option<Self> {
        // Without branches: rays in every direction would mispredict them.
        let d = ray.dir.to_array();
        let ad = d.map(f32::abs);
        let (x_over_y, x_over_z, y_over_z) =
            ((ad[0] > ad[1]) as usize, (ad[0] > ad[2]) as usize, (ad[1] > ad[2]) as usize);
        let kz = x_over_y * (2 - 2 * x_over_z) + (1 - x_over_y) * (2 - y_over_z);
        let (kx, ky) = ([1, 2, 0][kz], [2, 0, 1][kz]);
        let dz = d[kz];
        let (kx, ky) = if dz < 0.0 { (ky, kx) } else { (kx, ky) };
        if dz == 0.0 || !dz.is_finite() {
            return None;
        }
        let sz = 1.0 / dz;
        Some(Self { origin: ray.origin, dir: ray.dir, axes: [kx, ky, kz], shear: [d[kx] * sz, d[ky] * sz, sz] })
    }

    /// The vertex `p` in the ray's frame, as the test forms it: `(x, y)` sheared, `z` not yet scaled.
    #[inline]
    pub fn transform(&self, p: Vec3A) -> [f32; 3] {
        // Array indices: a `Vec3A` index is a match on the axis.
        let [kx, ky, kz] = self.axes.map(|k| k.min(2));
        let [sx, sy, _] = self.shear;
        let a = (p - self.origin).to_array();
        [a[kx] - sx * a[kz], a[ky] - sy * a[kz], a[kz]]
    }
}

/// A decided ray/triangle hit: its distance, barycentrics and the triangle's unit normal. Cheap to
/// keep while an accelerator looks for a closer one; [`TriangleHit::hit`] makes the full record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// The ray parameter.
    pub t: f32,
    /// The barycentrics `(b0, b1, b2)` of the vertices.
    pub b: [f32; 3],
    /// The unit geometric normal.
    pub normal: Vec3A,
}

impl TriangleHit {
    /// The full hit record on `tri`, the triangle this hit was decided on: the point rebuilt from the
    /// barycentrics (its error bounded by the vertices' magnitude, not the ray's travel).
    #[inline]
    pub fn hit(&self, tri: &Triangle) -> Hit {
        let [b0, b1, b2] = self.b;
        let point = tri.p[0] * b0 + tri.p[1] * b1 + tri.p[2] * b2;
        let error = ((tri.p[0] * b0).abs() + (tri.p[1] * b1).abs() + (tri.p[2] * b2).abs()) * gamma(7);
        Hit { t: self.t, point, normal: self.normal, uv: Vec2::new(b1, b2), error }
    }
}

/// Ray/triangle intersection after Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection"
/// (JCGT 2013): the vertices are moved into a frame where the ray runs along +z from the origin, and
/// the 2D edge functions decide the hit. Each edge function depends only on its two endpoints, so a
/// ray through a shared edge or vertex of a closed mesh hits at least one of the triangles sharing
/// it and never passes between them; edge functions that round to zero are recomputed in f64.
/// Degenerate (zero-area) triangles never report a hit, and no hit carries a NaN.
///
/// The hit point is rebuilt from the barycentrics, which bounds its error by the vertices' magnitude
/// rather than the ray's travel.
///
/// ```
/// use raylume_geometry::{Interval, Ray, Triangle, Vec3A};
/// use raylume_intersect::intersect_watertight;
/// let t = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
/// // Exactly through the shared edge's midpoint of two triangles: the edge belongs to the triangle.
/// let ray = Ray::new(Vec3A::new(0.5, 0.5, 1.0), -Vec3A::Z);
/// assert!(intersect_watertight(&t, &ray, Interval::POSITIVE).is_some());
/// ```
#[inline]
pub fn intersect_watertight(tri: &Triangle, ray: &Ray, t_range: Interval) -> Option<Hit> {
    let sheared = ShearedRay::new(ray)?;
    watertight_decide(tri, &sheared, t_range).map(|h| h.hit(tri))
}

/// The decision of [`intersect_watertight`] for a prepared ray: whether the ray hits `tri` with `t`
/// in `t_range`, and where. Accelerators call it for every candidate and build the [`Hit`] of the
/// closest one only.
#[inline]
pub fn watertight_decide(tri: &Triangle, ray: &ShearedRay, t_range: Interval) -> Option<TriangleHit> {
    decide::<true>(tri, ray, t_range)
}

/// Whether [`watertight_decide`] finds a hit: the same decision, without refining the distance of
/// the hit (shadow rays need only the answer).
#[inline]
pub fn watertight_hits(tri: &Triangle, ray: &ShearedRay, t_range: Interval) -> bool {
    decide::<false>(tri, ray, t_range).is_some()
}

/// The decision; `REFINE` computes the hit's distance on the vertices' plane in f64.
#[inline(always)]
fn decide<const REFINE: bool>(tri: &Triangle, ray: &ShearedRay, t_range: Interval) -> Option<TriangleHit> {
    let sz = ray.shear[2];
    let [ax, ay, a_z] = ray.transform(tri.p[0]);
    let [bx, by, b_z] = ray.transform(tri.p[1]);
    let [cx, cy, c_z] = ray.transform(tri.p[2]);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // On an edge within f32 rounding: decide it in f64, where these products are exact.
        let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
        u = f(cx, by, cy, bx);
        v = f(ax, cy, ay, cx);
        w = f(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let (az, bz, cz) = (sz * a_z, sz * b_z, sz * c_z);
    let inv = 1.0 / det;
    // t in f64 from the exact products: the same t whatever the order of the vertices.
    let t = ((u as f64 * az as f64 + v as f64 * bz as f64 + w as f64 * cz as f64) / (u as f64 + v as f64 + w as f64))
        as f32;
    if !t_range.contains(t) {
        return None;
    }
    // pbrt-v4's bound on the error of t: a hit closer than it may be the surface the ray left.
    let max_zt = az.abs().max(bz.abs()).max(cz.abs());
    let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
    let max_yt = ay.abs().max(by.abs()).max(cy.abs());
    let delta_z = gamma(3) * max_zt;
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = u.abs().max(v.abs()).max(w.abs());
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv.abs();
    if delta_t.is_nan() || t <= delta_t {
        // Too close to call in f32: needles and tiny triangles far away have error bounds larger than
        // their distance. Decide again in f64, whose bound is 2^29 times smaller; a ray leaving the
        // surface (its origin offset past the f32 error box) is then behind it, exactly.
        return watertight_f64(tri, ray, t_range);
    }
    let normal = unit_normal(tri)?;
    // The hit is decided; its distance is refined on the plane through the vertices, in f64, where
    // the differences and cross products of f32 coordinates are (nearly) exact. This keeps t at a few
    // ulps even for large triangles seen at grazing angles, where the sheared coordinates lose it.
    let t = if REFINE { refined_distance(tri, ray, t_range, t) } else { t };
    Some(TriangleHit { t, b: [u * inv, v * inv, w * inv], normal })
}

/// Whether the watertight test can hit `tri` at all: a triangle without a unit normal (zero area in
/// f32, or a cross product that overflows) is never hit, so accelerators may leave it out.
#[inline]
pub fn has_unit_normal(tri: &Triangle) -> bool {
    unit_normal(tri).is_some()
}

/// The triangle's unit normal; `None` for degenerate triangles.
#[inline]
fn unit_normal(tri: &Triangle) -> Option<Vec3A> {
    let normal = tri.normal().normalize_or_zero();
    (normal != Vec3A::ZERO && normal.is_finite()).then_some(normal)
}

/// The distance of a hit that [`watertight_decide`] accepted at `t` within `t_range`, as it reports it:
/// the distance to the plane through the vertices, computed in f64, when that is within the range;
/// else `t`. Accelerators that decide hits by the same operations in vector registers refine the
/// accepted ones with it.
#[inline]
pub fn refined_distance(tri: &Triangle, ray: &ShearedRay, t_range: Interval, t: f32) -> f32 {
    plane_distance64(tri, ray).filter(|t| t_range.contains(*t)).unwrap_or(t)
}

/// The ray parameter where the ray meets the plane of the triangle's vertices, computed in f64.
#[inline]
fn plane_distance64(tri: &Triangle, ray: &ShearedRay) -> Option<f32> {
    let p = tri.p.map(|v| [v.x as f64, v.y as f64, v.z as f64]);
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let (o, d) = (
        [ray.origin.x as f64, ray.origin.y as f64, ray.origin.z as f64],
        [ray.dir.x as f64, ray.dir.y as f64, ray.dir.z as f64],
    );
    let den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    let num = n[0] * (p[0][0] - o[0]) + n[1] * (p[0][1] - o[1]) + n[2] * (p[0][2] - o[2]);
    let t = (num / den) as f32;
    (den != 0.0 && t.is_finite()).then_some(t)
}

/// The watertight test carried out entirely in f64 (exact differences and products of f32 inputs),
/// with pbrt-v4's t bound for f64 roundings: the fallback for hits too close to call in f32.
#[cold]
fn watertight_f64(tri: &Triangle, ray: &ShearedRay, t_range: Interval) -> Option<TriangleHit> {
    let g = |n: f64| n * (f64::EPSILON * 0.5) / (1.0 - n * (f64::EPSILON * 0.5));
    let d = ray.dir.to_array().map(f64::from);
    let o = ray.origin.to_array().map(f64::from);
    let [kx, ky, kz] = ray.axes;
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let rel = |v: Vec3A| {
        let p = v.to_array().map(f64::from);
        let q = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        (q[kx] - sx * q[kz], q[ky] - sy * q[kz], sz * q[kz])
    };
    let (ax, ay, az) = rel(tri.p[0]);
    let (bx, by, bz) = rel(tri.p[1]);
    let (cx, cy, cz) = rel(tri.p[2]);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let t = (u * az + v * bz + w * cz) / det;
    let (max_zt, max_xt, max_yt) = (
        az.abs().max(bz.abs()).max(cz.abs()),
        ax.abs().max(bx.abs()).max(cx.abs()),
        ay.abs().max(by.abs()).max(cy.abs()),
    );
    let (delta_z, delta_x, delta_y) = (g(3.0) * max_zt, g(5.0) * (max_xt + max_zt), g(5.0) * (max_yt + max_zt));
    let delta_e = 2.0 * (g(2.0) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = u.abs().max(v.abs()).max(w.abs());
    let delta_t = 3.0 * (g(3.0) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) / det.abs();
    if t.is_nan() || t <= delta_t || !t_range.contains(t as f32) || (t as f32) <= 0.0 {
        return None;
    }
    let normal = unit_normal(tri)?;
    Some(TriangleHit { t: t as f32, b: [(u / det) as f32, (v / det) as f32, (w / det) as f32], normal })
}
