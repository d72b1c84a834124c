//! The watertight ray/triangle test of Woop, Benthin and Wald, split in three so that an accelerator
//! prepares the ray once ([`ShearedRay`]), decides each candidate triangle ([`watertight_decide`]) and
//! builds the full [`Hit`] of the closest one only ([`TriangleHit::hit`]).

use raylume_geometry::{Interval, Ray, Triangle, Vec2, Vec3A, gamma, is_plane_normal};

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

/// A decided ray/triangle hit: its distance and barycentrics. Cheap to keep while an accelerator
/// looks for a closer one; [`TriangleHit::hit`] makes the full record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// The ray parameter.
    pub t: f32,
    /// The barycentrics `(b0, b1, b2)` of the vertices.
    pub b: [f32; 3],
}

impl TriangleHit {
    /// The full hit record on `tri`, the triangle this hit was decided on: the point rebuilt from the
    /// barycentrics (its error bounded by the vertices' magnitude, not the ray's travel), and the unit
    /// normal ([`unit_normal`]; a decided hit's triangle has one).
    #[inline]
    pub fn hit(&self, tri: &Triangle) -> Hit {
        self.hit_with_normal(tri, unit_normal(tri).unwrap_or(Vec3A::Z))
    }

    /// [`TriangleHit::hit`] with the triangle's [`unit_normal`] given: accelerators that keep each
    /// triangle's normal pass it instead of forming it again.
    #[inline]
    pub fn hit_with_normal(&self, tri: &Triangle, normal: Vec3A) -> Hit {
        let [b0, b1, b2] = self.b;
        // Within the vertices' box, as the exact point is: rounding must not take it out.
        let point = (tri.p[0] * b0 + tri.p[1] * b1 + tri.p[2] * b2)
            .clamp(tri.p[0].min(tri.p[1]).min(tri.p[2]), tri.p[0].max(tri.p[1]).max(tri.p[2]));
        let error = ((tri.p[0] * b0).abs() + (tri.p[1] * b1).abs() + (tri.p[2] * b2).abs()) * gamma(7);
        Hit { t: self.t, point, normal, uv: Vec2::new(b1, b2), error }
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
    if !ray.is_canonical() {
        return crate::shapes::rescaled(ray, t_range, |ray, range| intersect_watertight(tri, ray, range));
    }
    let sheared = ShearedRay::new(ray)?;
    watertight_decide(tri, &sheared, t_range).map(|h| h.hit(tri))
}

/// Whether `ray` hits `tri` within `(0, t_max)`: [`watertight_hits`] on the canonical ray.
#[inline]
pub(crate) fn occludes(tri: &Triangle, ray: &Ray, t_max: f32) -> bool {
    let range = Interval::new(0.0, t_max);
    if !ray.is_canonical() {
        return crate::shapes::rescaled(ray, range, |ray, range| occludes(tri, ray, range.max).then_some(())).is_some();
    }
    ShearedRay::new(ray).is_some_and(|sheared| watertight_hits(tri, &sheared, range))
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

/// A bound on the rounding error of the edge function `p q - r s` computed in f32 from f32 inputs:
/// where the computed value exceeds it in magnitude, its sign is the exact sign. The absolute term
/// covers products that fall below the normal range.
#[inline(always)]
pub fn edge_error(pq: f32, rs: f32) -> f32 {
    (pq.abs() + rs.abs()) * gamma(3) + f32::MIN_POSITIVE
}

/// The edge function `p q - r s` with its exact sign: the f32 value where its error bound leaves no
/// doubt, else the value in f64 (where the products are exact) rounded to f32. It depends only on the
/// edge's two endpoints, and swapping them negates it exactly, so two triangles sharing an edge
/// classify every ray alike: the test is watertight.
#[inline(always)]
fn exact_edge(p: f32, q: f32, r: f32, s: f32) -> f32 {
    let (pq, rs) = (p * q, r * s);
    let e = pq - rs;
    if e.abs() > edge_error(pq, rs) { e } else { (p as f64 * q as f64 - r as f64 * s as f64) as f32 }
}

/// The decision; `REFINE` reports the distance to the vertices' plane computed in f64.
#[inline(always)]
fn decide<const REFINE: bool>(tri: &Triangle, ray: &ShearedRay, t_range: Interval) -> Option<TriangleHit> {
    let sz = ray.shear[2];
    let [ax, ay, a_z] = ray.transform(tri.p[0]);
    let [bx, by, b_z] = ray.transform(tri.p[1]);
    let [cx, cy, c_z] = ray.transform(tri.p[2]);
    let u = exact_edge(cx, by, cy, bx);
    let v = exact_edge(ax, cy, ay, cx);
    let w = exact_edge(bx, ay, by, ax);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let (az, bz, cz) = (sz * a_z, sz * b_z, sz * c_z);
    let inv = 1.0 / det;
    let t = (u * az + v * bz + w * cz) * inv;
    let delta_t = distance_error([ax, bx, cx], [ay, by, cy], [az, bz, cz], [u, v, w], inv);
    // Where `t` or its bound overflowed (or the bound is NaN), only the f64 plane distance decides.
    let bounded = t.is_finite() && delta_t.is_finite();
    // Out of the range even with the error of t.
    if bounded && (t - delta_t > t_range.max || t + delta_t < t_range.min) {
        return None;
    }
    // The plane through the vertices, in f64: a degenerate triangle (collinear in f32) has none.
    let n = tri.normal64();
    if !is_plane_normal(n) {
        return None;
    }
    let t = if bounded && t > delta_t {
        if REFINE { plane_distance64(tri, n, ray).map_or(t, |t| t as f32) } else { t }
    } else {
        // Too close to call in f32 (needles and tiny triangles far away have error bounds larger than
        // their distance): the distance to the vertices' plane in f64, whose bound is 2^29 times
        // smaller, decides; a ray leaving the surface (its origin offset past the f32 error box) is
        // then behind it.
        match plane_distance64(tri, n, ray) {
            Some(t) if t > plane_distance_error(tri, n, ray, t) => t as f32,
            _ => return None,
        }
    };
    if !t_range.contains(t) || t <= 0.0 {
        return None;
    }
    Some(TriangleHit { t, b: [u * inv, v * inv, w * inv] })
}

/// The distance [`watertight_decide`] reports for a hit it decides in f32 (every edge function beyond
/// its error bound, the f32 distance `t` beyond its own): the distance to the vertices' plane in f64,
/// or `t` where that is not finite. Accelerators that decide such hits in vector registers take the
/// reported distance from it, and so answer as the scalar test does.
#[inline]
pub fn decided_distance(tri: &Triangle, ray: &ShearedRay, t: f32) -> f32 {
    plane_distance64(tri, tri.normal64(), ray).map_or(t, |t| t as f32)
}

/// pbrt-v4's bound on the error of the distance `t = (u az + v bz + w cz) / det` the test forms in f32
/// from the sheared vertices and the edge functions: a hit closer than it may be the surface the ray
/// left. pbrt's relative terms assume no result falls below the normal range; the absolute terms
/// `2^-120` inside (which `|inv|` scales as it scales `t`) and `2^-140` outside cover those that do.
#[inline(always)]
fn distance_error(x: [f32; 3], y: [f32; 3], z: [f32; 3], e: [f32; 3], inv: f32) -> f32 {
    let max3 = |v: [f32; 3]| v[0].abs().max(v[1].abs()).max(v[2].abs());
    let (max_zt, max_xt, max_yt, max_e) = (max3(z), max3(x), max3(y), max3(e));
    let delta_z = gamma(3) * max_zt;
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let relative = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e);
    (relative + TINY_TERM * (1.0 + max_zt)) * inv.abs() + TINY_DISTANCE
}

/// The absolute term `2^-120` inside the triangle test's distance bound, scaled by `|1 / det|` as
/// the distance is: it covers the products below f32's normal range (vector kernels that form the
/// bound themselves use it too).
pub const TINY_TERM: f32 = f32::from_bits(7 << 23);
/// The absolute term `2^-140` added to the triangle test's distance bound: it covers a distance or a
/// bound that itself falls below f32's normal range.
pub const TINY_DISTANCE: f32 = f32::from_bits(1 << 9);

/// Whether the watertight test can hit `tri` at all: a triangle whose vertices are collinear (or
/// not finite) has no unit normal and is never hit, so accelerators may leave it out. The normal is
/// formed in f64, so huge and tiny triangles have one.
#[inline]
pub fn has_unit_normal(tri: &Triangle) -> bool {
    tri.has_plane()
}

/// The triangle's unit normal, formed in f64 so that neither huge nor tiny triangles over- or
/// underflow; `None` for degenerate (collinear in f32) triangles.
#[inline]
pub fn unit_normal(tri: &Triangle) -> Option<Vec3A> {
    let n = tri.normal64();
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    Some(Vec3A::new((n[0] / len) as f32, (n[1] / len) as f32, (n[2] / len) as f32))
}

/// The magnitudes `|e1| x |e2|` (each term of the cross product taken positive) that bound the
/// rounding of [`Triangle::normal64`]'s components.
#[inline(always)]
pub fn normal64_magnitude(tri: &Triangle) -> [f64; 3] {
    let [e1, e2] = tri.edges64();
    let (e1, e2) = ([e1[0].abs(), e1[1].abs(), e1[2].abs()], [e2[0].abs(), e2[1].abs(), e2[2].abs()]);
    [e1[1] * e2[2] + e1[2] * e2[1], e1[2] * e2[0] + e1[0] * e2[2], e1[0] * e2[1] + e1[1] * e2[0]]
}

/// The ray parameter where the ray meets the plane (normal `n`, [`Triangle::normal64`]) of the triangle's
/// vertices, computed in f64; `None` where the ray is parallel to the plane or the distance is not
/// finite in f32.
#[inline]
fn plane_distance64(tri: &Triangle, n: [f64; 3], ray: &ShearedRay) -> Option<f64> {
    let (q, d) = plane_offsets(tri, ray);
    let den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    let t = (n[0] * q[0] + n[1] * q[1] + n[2] * q[2]) / den;
    (den != 0.0 && (t as f32).is_finite()).then_some(t)
}

/// `p0 - o` and `d` in f64.
#[inline(always)]
fn plane_offsets(tri: &Triangle, ray: &ShearedRay) -> ([f64; 3], [f64; 3]) {
    let (p0, o) = (tri.p[0], ray.origin);
    (
        [p0.x as f64 - o.x as f64, p0.y as f64 - o.y as f64, p0.z as f64 - o.z as f64],
        [ray.dir.x as f64, ray.dir.y as f64, ray.dir.z as f64],
    )
}

/// A bound on the error of [`plane_distance64`]'s `t`: each of the normal, the offset and the dot
/// products carries a few f64 roundings, and a relative 2^-48 of the sums of magnitudes (those of the
/// normal's products included) bounds them all. Not rare: a ray leaving a triangle's surface tests it
/// again this way.
#[inline]
fn plane_distance_error(tri: &Triangle, n: [f64; 3], ray: &ShearedRay, t: f64) -> f64 {
    let (q, d) = plane_offsets(tri, ray);
    let nabs = normal64_magnitude(tri);
    let mag = |v: [f64; 3]| nabs[0] * v[0].abs() + nabs[1] * v[1].abs() + nabs[2] * v[2].abs();
    let den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    (mag(q) + t.abs() * mag(d)) / den.abs() / (1u64 << 48) as f64
}
