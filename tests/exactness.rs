//! Exactness of the intersection routines and the accelerators, judged against f64 references on the
//! same f32 inputs: hit-point error bounds and spawned rays that must not hit the surface they leave,
//! for every shape at scales 1e-6 to 1e6 and offsets up to 1e6; answers that scale exactly with the
//! length of the ray direction; watertight closed and open meshes for any direction length and
//! distance from the origin; extreme triangle and sphere sizes; answers that do not depend on the
//! accelerator, the query form or the order of the primitives (ties go to the lowest index); and
//! conservative bounds, so that no accelerator misses a hit its primitive reports.
//! Run in release mode (`cargo test --release --test exactness -- --nocapture` shows the figures).

use std::panic::{AssertUnwindSafe, catch_unwind};

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume::accel::{Accelerator, BruteForce, Bvh, BvhBuild, BvhKernel, Grid, GridParams, PrimitiveHit};
use raylume::geometry::{
    AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Ray, Sphere, Triangle, Vec3A, offset_ray_origin,
    orthonormal_basis,
};
use raylume::intersect::{Hit, Intersect, Primitive};
use raylume::scene::procedural::icosphere;

// ---------------------------------------------------------------------------------------------------
// Random numbers.

fn rng(seed: u64) -> Pcg32 {
    Pcg32::new(seed, 0xda3e_39cb_94b9_5bdb)
}

fn unif(r: &mut Pcg32) -> f32 {
    (r.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn unif64(r: &mut Pcg32) -> f64 {
    (r.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

fn unit_vector(r: &mut Pcg32) -> Vec3A {
    let (a, b) = (unif(r), unif(r));
    raylume::geometry::sampling::uniform_sphere(raylume::geometry::Vec2::new(a, b))
}

/// A uniformly random unit vector in f64.
fn unit64_random(r: &mut Pcg32) -> D3 {
    let z = 1.0 - 2.0 * unif64(r);
    let phi = std::f64::consts::TAU * unif64(r);
    let s = (1.0 - z * z).max(0.0).sqrt();
    [s * phi.cos(), s * phi.sin(), z]
}

/// A random unit vector in the hemisphere around `n`.
fn hemisphere(r: &mut Pcg32, n: D3) -> D3 {
    let v = unit64_random(r);
    if dot(v, n) < 0.0 { mul(v, -1.0) } else { v }
}

/// A uniformly random rotation (from a random unit quaternion).
fn rotation(r: &mut Pcg32) -> glam::Mat3A {
    let q = glam::Quat::from_xyzw(unif(r) - 0.5, unif(r) - 0.5, unif(r) - 0.5, unif(r) - 0.5).normalize();
    glam::Mat3A::from_quat(q)
}

/// `2^k` in f32 (exact for the k used here).
fn pow2(k: i32) -> f32 {
    2f32.powi(k)
}

/// The spacing of f32 values around `x`.
fn ulp(x: f32) -> f32 {
    let a = x.abs().max(f32::MIN_POSITIVE);
    a.next_up() - a
}

// ---------------------------------------------------------------------------------------------------
// f64 vectors: references are computed in f64 from the f32 inputs.

type D3 = [f64; 3];

fn d3(v: Vec3A) -> D3 {
    [v.x as f64, v.y as f64, v.z as f64]
}

fn f3(v: D3) -> Vec3A {
    Vec3A::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn mul(a: D3, s: f64) -> D3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: D3, b: D3) -> D3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn len(a: D3) -> f64 {
    dot(a, a).sqrt()
}

fn unit(a: D3) -> D3 {
    mul(a, 1.0 / len(a))
}

fn at(o: D3, d: D3, t: f64) -> D3 {
    add(o, mul(d, t))
}

/// The reach of the box `± e` along the direction `n`: `sum |n_a| e_a`.
fn reach(n: D3, e: D3) -> f64 {
    (0..3).map(|a| n[a].abs() * e[a]).sum()
}

/// An orthonormal pair perpendicular to the unit vector `w`.
fn basis64(w: D3) -> (D3, D3) {
    let a = if w[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let u = unit(cross(w, a));
    (u, cross(w, u))
}

/// The real roots of `a t^2 + b t + c`, in increasing order.
fn quadratic64(a: f64, b: f64, c: f64) -> Vec<f64> {
    if a == 0.0 {
        return if b != 0.0 { vec![-c / b] } else { vec![] };
    }
    let disc = b * b - 4.0 * a * c;
    if disc.is_nan() || disc < 0.0 {
        return vec![];
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return vec![0.0];
    }
    let (t0, t1) = (q / a, c / q);
    if t0 <= t1 { vec![t0, t1] } else { vec![t1, t0] }
}

/// The two roots of the ray `o + t d` with the sphere of centre `c` and radius `r`, in f64.
fn sphere_roots64(c: D3, r: f64, o: D3, d: D3) -> Option<(f64, f64)> {
    let f = sub(o, c);
    let a = dot(d, d);
    let hb = dot(f, d);
    let closest = sub(f, mul(d, hb / a));
    let disc = a * (r * r - dot(closest, closest));
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let q = -(hb + disc.sqrt().copysign(hb));
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (t0, t1) = ((dot(f, f) - r * r) / q, q / a);
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

/// The parameter range in which the ray is inside the box, in f64.
fn slab64(min: D3, max: D3, o: D3, d: D3) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < min[a] || o[a] > max[a] {
                return None;
            }
        } else {
            let (t1, t2) = ((min[a] - o[a]) / d[a], (max[a] - o[a]) / d[a]);
            lo = lo.max(t1.min(t2));
            hi = hi.min(t1.max(t2));
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// The unnormalised normal of a triangle's f32 vertices, in f64.
fn normal64(tri: &Triangle) -> D3 {
    let p = tri.p.map(d3);
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}

/// The parameter where the ray meets the plane of the triangle's f32 vertices, in f64.
fn triangle_plane_t64(tri: &Triangle, o: D3, d: D3) -> Option<f64> {
    let n = normal64(tri);
    let den = dot(n, d);
    (den != 0.0).then(|| dot(n, sub(d3(tri.p[0]), o)) / den)
}

/// Where the ray meets the plane of the triangle's f32 vertices, in f64 (coordinates relative to the
/// first vertex), and the smallest barycentric of that point: negative outside the triangle.
fn crossing64(tri: &Triangle, o: D3, d: D3) -> Option<(f64, f64)> {
    let p0 = d3(tri.p[0]);
    let p = tri.p.map(|v| sub(d3(v), p0));
    let o = sub(o, p0);
    let n = cross(p[1], p[2]);
    let den = dot(n, d);
    if den == 0.0 || dot(n, n) == 0.0 {
        return None;
    }
    let t = -dot(n, o) / den;
    let x = at(o, d, t);
    let area = |a: D3, b: D3, c: D3| dot(cross(sub(b, a), sub(c, a)), n);
    let b = [area(x, p[1], p[2]), area(p[0], x, p[2]), area(p[0], p[1], x)];
    Some((t, b.iter().fold(f64::INFINITY, |m, &v| m.min(v)) / dot(n, n)))
}

/// A cone's lateral surface in f64: axis frame, height and radius slope.
struct Cone64 {
    base: D3,
    w: D3,
    u: D3,
    v: D3,
    h: f64,
    r0: f64,
    k: f64,
}

impl Cone64 {
    fn new(c: &Cone) -> Self {
        let base = d3(c.base);
        let axis = sub(d3(c.apex), base);
        let h = len(axis);
        let w = mul(axis, 1.0 / h);
        let (u, v) = basis64(w);
        let (r0, r1) = (c.base_radius as f64, c.apex_radius as f64);
        Self { base, w, u, v, h, r0, k: (r1 - r0) / h }
    }

    fn radius_at(&self, z: f64) -> f64 {
        self.r0 + self.k * z
    }

    /// The vector from the axis to `p`, and the height of `p` above the base.
    fn local(&self, p: D3) -> (D3, f64) {
        let rel = sub(p, self.base);
        let z = dot(rel, self.w);
        (sub(rel, mul(self.w, z)), z)
    }

    /// Distance from the axis minus the radius at that height.
    fn implicit(&self, p: D3) -> f64 {
        let (x, z) = self.local(p);
        len(x) - self.radius_at(z)
    }

    /// The signed distance from the lateral line of `p`'s meridian plane (positive outside).
    fn signed_distance(&self, p: D3) -> f64 {
        self.implicit(p) / (1.0 + self.k * self.k).sqrt()
    }

    /// The outward unit normal at the surface point nearest `p`.
    fn normal(&self, p: D3) -> D3 {
        let (x, _) = self.local(p);
        unit(sub(unit(x), mul(self.w, self.k)))
    }

    /// The surface point at height `z` and angle `phi`.
    fn point(&self, z: f64, phi: f64) -> D3 {
        let radial = add(mul(self.u, phi.cos()), mul(self.v, phi.sin()));
        add(add(self.base, mul(self.w, z)), mul(radial, self.radius_at(z)))
    }

    /// The crossings `(t, exiting)` of the ray with the lateral surface, for `t > 0`, in order.
    fn crossings(&self, o: D3, d: D3) -> Vec<(f64, bool)> {
        let (x0, z0) = self.local(o);
        let dz = dot(d, self.w);
        let dr = sub(d, mul(self.w, dz));
        let rz0 = self.radius_at(z0);
        let a = dot(dr, dr) - self.k * self.k * dz * dz;
        let b = 2.0 * (dot(x0, dr) - self.k * rz0 * dz);
        let c = dot(x0, x0) - rz0 * rz0;
        let mut out = Vec::new();
        for t in quadratic64(a, b, c) {
            let z = z0 + t * dz;
            if t.is_nan() || t <= 0.0 || !(0.0..=self.h).contains(&z) || self.radius_at(z) < 0.0 {
                continue;
            }
            let x = add(x0, mul(dr, t));
            out.push((t, dot(x, dr) - self.radius_at(z) * self.k * dz > 0.0));
        }
        out
    }
}

// ---------------------------------------------------------------------------------------------------
// Shapes and accelerators.

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Sphere,
    MovingSphere,
    Triangle,
    Plane,
    Box,
    Cone,
    Cylinder,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Sphere => "sphere",
            Kind::MovingSphere => "moving sphere",
            Kind::Triangle => "triangle",
            Kind::Plane => "plane",
            Kind::Box => "box",
            Kind::Cone => "cone",
            Kind::Cylinder => "cylinder",
        }
    }
}

/// A random shape of the kind, of size about `s`, around `centre`. Moving spheres move during [0, 1].
fn shape_at(kind: Kind, r: &mut Pcg32, s: f32, centre: Vec3A) -> Primitive {
    match kind {
        Kind::Sphere => Primitive::Sphere(Sphere { center: centre, radius: s }),
        Kind::MovingSphere => Primitive::MovingSphere(MovingSphere {
            center0: centre,
            center1: centre + unit_vector(r) * (2.0 * s * unif(r)),
            radius: s,
            time0: 0.0,
            time1: 1.0,
        }),
        Kind::Triangle => {
            let mut tri = Triangle::new(centre, centre + Vec3A::X * s, centre + Vec3A::Y * s);
            for _ in 0..20 {
                let t = Triangle::new(centre, centre + unit_vector(r) * s, centre + unit_vector(r) * s);
                if len(normal64(&t)) >= 0.1 * (s as f64).powi(2) {
                    tri = t;
                    break;
                }
            }
            Primitive::Triangle(tri)
        }
        Kind::Plane => Primitive::Plane(Plane { point: centre, normal: unit_vector(r) }),
        Kind::Box => {
            let half = Vec3A::new(0.2 + 0.8 * unif(r), 0.2 + 0.8 * unif(r), 0.2 + 0.8 * unif(r)) * s;
            Primitive::Box(AaBox { bounds: Aabb::new(centre - half, centre + half) })
        }
        Kind::Cone | Kind::Cylinder => {
            let w = unit_vector(r);
            let h = s * (0.5 + 1.5 * unif(r));
            let r0 = s * (0.3 + 0.7 * unif(r));
            let r1 = if kind == Kind::Cylinder { r0 } else { r0 * unif(r) };
            let (r0, r1) = if r.next_u32() % 2 == 0 { (r0, r1) } else { (r1, r0) };
            Primitive::Cone(Cone {
                base: centre - w * (h / 2.0),
                base_radius: r0,
                apex: centre + w * (h / 2.0),
                apex_radius: r1,
            })
        }
    }
}

const ACCEL_NAMES: [&str; 4] = ["brute force", "bvh portable", "bvh best kernel", "grid"];

/// One of the four accelerators under test (a few built per case: their sizes do not matter).
#[allow(clippy::large_enum_variant)]
enum AnyAccel {
    Brute(BruteForce<Primitive>),
    Bvh(Bvh<Primitive>),
    Grid(Grid<Primitive>),
}

impl AnyAccel {
    /// Accelerator `a` of [`ACCEL_NAMES`] over `prims`.
    fn build(a: usize, prims: &[Primitive], shutter: Interval) -> Self {
        let prims = prims.to_vec();
        match a {
            0 => AnyAccel::Brute(BruteForce::new(prims)),
            1 => AnyAccel::Bvh(Bvh::with_kernel(prims, shutter, BvhBuild::Sah, BvhKernel::Portable)),
            2 => AnyAccel::Bvh(Bvh::with_kernel(prims, shutter, BvhBuild::Sah, BvhKernel::best())),
            _ => AnyAccel::Grid(Grid::new(prims, shutter, GridParams::default())),
        }
    }

    fn all(prims: &[Primitive], shutter: Interval) -> Vec<AnyAccel> {
        (0..4).map(|a| Self::build(a, prims, shutter)).collect()
    }

    fn closest(&self, ray: &Ray) -> Option<PrimitiveHit> {
        match self {
            AnyAccel::Brute(x) => x.closest_hit(ray, Interval::POSITIVE),
            AnyAccel::Bvh(x) => x.closest_hit(ray, Interval::POSITIVE),
            AnyAccel::Grid(x) => x.closest_hit(ray, Interval::POSITIVE),
        }
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        match self {
            AnyAccel::Brute(x) => x.occluded(ray, t_max),
            AnyAccel::Bvh(x) => x.occluded(ray, t_max),
            AnyAccel::Grid(x) => x.occluded(ray, t_max),
        }
    }

    /// The batch query over `rays`.
    fn batch(&self, rays: &[Ray]) -> Vec<Option<PrimitiveHit>> {
        let mut hits = vec![None; rays.len()];
        match self {
            AnyAccel::Brute(x) => x.closest_hits(rays, Interval::POSITIVE, &mut hits),
            AnyAccel::Bvh(x) => x.closest_hits(rays, Interval::POSITIVE, &mut hits),
            AnyAccel::Grid(x) => x.closest_hits(rays, Interval::POSITIVE, &mut hits),
        }
        hits
    }
}

/// The closest hit among `prims` by each primitive's own routine: the smallest `t`, ties to the lowest
/// index; and how many primitives are hit at that `t`.
fn reference_closest(prims: &[Primitive], ray: &Ray) -> (Option<PrimitiveHit>, usize) {
    let (mut best, mut tied): (Option<PrimitiveHit>, usize) = (None, 0);
    for (i, p) in prims.iter().enumerate() {
        let Some(h) = p.intersect(ray, Interval::POSITIVE) else { continue };
        match best {
            Some(b) if h.t > b.hit.t => {}
            Some(b) if h.t == b.hit.t => tied += 1,
            _ => {
                best = Some(PrimitiveHit { hit: h, primitive: i as u32 });
                tied = 1;
            }
        }
    }
    (best, tied)
}

/// What identifies a closest hit bit for bit: primitive, t, and the surface coordinates.
fn key(h: &Option<PrimitiveHit>) -> Option<(u32, u32, u32, u32)> {
    h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.uv.x.to_bits(), h.hit.uv.y.to_bits()))
}

// ---------------------------------------------------------------------------------------------------
// 1. Hit-point error bounds and spawned rays.

/// A point of the surface of `prim` (of size `s`) and its outward normal, in f64.
fn surface_sample(prim: &Primitive, s: f32, r: &mut Pcg32) -> (D3, D3) {
    match prim {
        Primitive::Sphere(sp) => {
            let n = unit64_random(r);
            (add(d3(sp.center), mul(n, sp.radius as f64)), n)
        }
        Primitive::Box(b) => {
            let (min, max) = (d3(b.bounds.min), d3(b.bounds.max));
            let a = (r.next_u32() % 3) as usize;
            let mut p = [0, 1, 2].map(|k| min[k] + (max[k] - min[k]) * unif64(r));
            let mut n = [0.0; 3];
            if r.next_u32() % 2 == 0 {
                p[a] = max[a];
                n[a] = 1.0;
            } else {
                p[a] = min[a];
                n[a] = -1.0;
            }
            (p, n)
        }
        Primitive::Triangle(t) => {
            let (mut b1, mut b2) = (unif64(r), unif64(r));
            if b1 + b2 > 1.0 {
                (b1, b2) = (1.0 - b1, 1.0 - b2);
            }
            let p = t.p.map(d3);
            let x = add(p[0], add(mul(sub(p[1], p[0]), b1), mul(sub(p[2], p[0]), b2)));
            let n = unit(normal64(t));
            (x, if r.next_u32() % 2 == 0 { n } else { mul(n, -1.0) })
        }
        Primitive::Plane(pl) => {
            let n = unit(d3(pl.normal));
            let (u, v) = basis64(n);
            let (x, y) = ((2.0 * unif64(r) - 1.0) * s as f64, (2.0 * unif64(r) - 1.0) * s as f64);
            let p = add(d3(pl.point), add(mul(u, x), mul(v, y)));
            (p, if r.next_u32() % 2 == 0 { n } else { mul(n, -1.0) })
        }
        Primitive::Cone(c) => {
            let c64 = Cone64::new(c);
            let z = c64.h * (0.02 + 0.96 * unif64(r));
            let p = c64.point(z, std::f64::consts::TAU * unif64(r));
            (p, c64.normal(p))
        }
        Primitive::MovingSphere(_) => unreachable!("not sampled here"),
    }
}

/// A ray from outside at a random point of the surface.
fn outside_ray(prim: &Primitive, s: f32, r: &mut Pcg32) -> Ray {
    let (p, n) = surface_sample(prim, s, r);
    let o = at(p, hemisphere(r, n), s as f64 * 10f64.powf(0.3 + unif64(r)));
    let (o, p) = (f3(o), f3(p));
    Ray::new(o, (p - o).normalize())
}

/// A ray from inside a closed shape: in a random direction, or at a random point of the surface.
fn inside_ray(prim: &Primitive, s: f32, r: &mut Pcg32) -> Ray {
    let o = match prim {
        Primitive::Sphere(sp) => at(d3(sp.center), unit64_random(r), sp.radius as f64 * 0.9 * unif64(r).cbrt()),
        Primitive::Box(b) => {
            let (min, max) = (d3(b.bounds.min), d3(b.bounds.max));
            [0, 1, 2].map(|k| min[k] + (max[k] - min[k]) * (0.05 + 0.9 * unif64(r)))
        }
        Primitive::Cone(c) => {
            let c64 = Cone64::new(c);
            let z = c64.h * (0.05 + 0.9 * unif64(r));
            let phi = std::f64::consts::TAU * unif64(r);
            let radial = add(mul(c64.u, phi.cos()), mul(c64.v, phi.sin()));
            let rho = 0.9 * c64.radius_at(z) * unif64(r).sqrt();
            add(add(c64.base, mul(c64.w, z)), mul(radial, rho))
        }
        _ => unreachable!("closed shapes only"),
    };
    let o = f3(o);
    if r.next_u32() % 2 == 0 {
        Ray::new(o, f3(unit64_random(r)))
    } else {
        let (p, _) = surface_sample(prim, s, r);
        Ray::new(o, (f3(p) - o).normalize())
    }
}

/// Whether the exact surface passes through the box `hit.point ± hit.error`, judged in f64; and the
/// distance of the point from the surface over the box's reach towards it (for the report).
fn error_bound_holds(prim: &Primitive, h: &Hit) -> (bool, f64) {
    let (q, e) = (d3(h.point), d3(h.error).map(f64::abs));
    let ratio = |dist: f64, allowed: f64| if dist == 0.0 { 0.0 } else { dist / allowed };
    match prim {
        Primitive::Sphere(s) => {
            let (c, rad) = (d3(s.center), s.radius as f64);
            // The nearest and the farthest point of the box from the centre.
            let near: f64 = (0..3).map(|a| ((q[a] - c[a]).abs() - e[a]).max(0.0).powi(2)).sum::<f64>().sqrt();
            let far: f64 = (0..3).map(|a| ((q[a] - c[a]).abs() + e[a]).powi(2)).sum::<f64>().sqrt();
            let n = unit(sub(q, c));
            (near <= rad && rad <= far, ratio((len(sub(q, c)) - rad).abs(), reach(n, e)))
        }
        Primitive::Box(b) => {
            let (min, max) = (d3(b.bounds.min), d3(b.bounds.max));
            let meets = (0..3).all(|a| q[a] - e[a] <= max[a] && q[a] + e[a] >= min[a]);
            let not_interior = (0..3).any(|a| q[a] - e[a] <= min[a] || q[a] + e[a] >= max[a]);
            let axis = (0..3).max_by(|&i, &j| h.normal[i].abs().total_cmp(&h.normal[j].abs())).unwrap();
            let face = if h.normal[axis] > 0.0 { max[axis] } else { min[axis] };
            (meets && not_interior, ratio((q[axis] - face).abs(), e[axis]))
        }
        Primitive::Triangle(t) => {
            let n = unit(normal64(t));
            let dist = dot(n, sub(q, d3(t.p[0]))).abs();
            (dist <= reach(n, e), ratio(dist, reach(n, e)))
        }
        Primitive::Plane(p) => {
            let n = d3(p.normal);
            let dist = dot(n, sub(q, d3(p.point))).abs();
            (dist <= reach(n, e), ratio(dist, reach(n, e)))
        }
        Primitive::Cone(c) => {
            let c64 = Cone64::new(c);
            let n = c64.normal(q);
            let dist = c64.signed_distance(q).abs();
            let flat_ok = dist <= reach(n, e);
            // Or the implicit function changes sign over the box's corners.
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for corner in 0..8 {
                let p = [0, 1, 2].map(|a| if corner >> a & 1 == 0 { q[a] - e[a] } else { q[a] + e[a] });
                let g = c64.implicit(p);
                (lo, hi) = (lo.min(g), hi.max(g));
            }
            let z = dot(sub(q, c64.base), c64.w);
            let z_reach = reach(c64.w, e);
            let in_height = z >= -z_reach && z <= c64.h + z_reach;
            ((flat_ok || (lo <= 0.0 && hi >= 0.0)) && in_height, ratio(dist, reach(n, e)))
        }
        Primitive::MovingSphere(_) => unreachable!("not checked here"),
    }
}

/// Where a ray starting inside a closed shape first leaves it, by the f64 reference.
fn first_exit64(prim: &Primitive, o: D3, d: D3) -> Option<f64> {
    match prim {
        Primitive::Sphere(s) => sphere_roots64(d3(s.center), s.radius as f64, o, d).map(|r| r.1).filter(|&t| t > 0.0),
        Primitive::Box(b) => slab64(d3(b.bounds.min), d3(b.bounds.max), o, d).map(|r| r.1).filter(|&t| t > 0.0),
        Primitive::Cone(c) => Cone64::new(c).crossings(o, d).into_iter().find(|c| c.1).map(|c| c.0),
        _ => None,
    }
}

#[derive(Default)]
struct SpawnStats {
    rays: usize,
    hits: usize,
    inside_hits: usize,
    violations: usize,
    worst_ratio: f64,
    spawned: usize,
    outward_rehits: usize,
    inward_rehits: usize,
    /// The first error-bound failure and the first re-hit, for the report.
    bound_example: Option<String>,
    spawn_example: Option<String>,
}

/// Shapes of `kind` with sizes log-uniform in 1e-6..1e6 at offsets from the origin up to 1e6 (and at
/// most 1e5 sizes), hit by rays from outside and (closed shapes) from inside: checks every hit's error
/// bound, and with `spawn` the rays spawned from it.
fn error_and_spawn_cases(kind: Kind, cases: usize, spawn: Option<&mut Pcg32>) -> SpawnStats {
    let mut r = rng(1001 + kind as u64);
    let mut spawn = spawn;
    let mut st = SpawnStats::default();
    let closed = matches!(kind, Kind::Sphere | Kind::Box | Kind::Cone | Kind::Cylinder);
    for i in 0..cases {
        let le = -6.0 + 12.0 * unif(&mut r);
        let s = 10f32.powf(le);
        let (lo, hi) = (le - 1.0, (le + 5.0).min(6.0));
        let m = if i % 8 == 0 { 0.0 } else { 10f32.powf(lo + (hi - lo) * unif(&mut r)) };
        let centre = unit_vector(&mut r) * m;
        let prim = shape_at(kind, &mut r, s, centre);
        let inside = closed && i % 2 == 1;
        let ray = if inside { inside_ray(&prim, s, &mut r) } else { outside_ray(&prim, s, &mut r) };
        if !ray.dir.is_finite() || ray.dir == Vec3A::ZERO {
            continue;
        }
        st.rays += 1;
        let Some(h) = prim.intersect(&ray, Interval::POSITIVE) else { continue };
        st.hits += 1;
        st.inside_hits += inside as usize;
        let (ok, ratio) = error_bound_holds(&prim, &h);
        if !ok {
            st.violations += 1;
            st.bound_example.get_or_insert_with(|| format!("{prim:?} hit by {ray:?}: {h:?}"));
        }
        if ratio.is_finite() {
            st.worst_ratio = st.worst_ratio.max(ratio);
        } else if !ok {
            st.worst_ratio = f64::INFINITY;
        }
        let Some(rs) = spawn.as_deref_mut() else { continue };
        // Spawned rays: reflection-like ones back to the side the ray came from, transmission-like
        // ones through the surface, and random ones in both hemispheres.
        let d = unit(d3(ray.dir));
        let n_out = d3(h.normal);
        let n_arr = if dot(d, n_out) < 0.0 { n_out } else { mul(n_out, -1.0) };
        let n_through = mul(n_arr, -1.0);
        let mut spawns: Vec<(D3, D3)> = vec![(n_arr, sub(d, mul(n_arr, 2.0 * dot(d, n_arr))))];
        for _ in 0..3 {
            spawns.push((n_arr, hemisphere(rs, n_arr)));
        }
        spawns.push((n_through, d));
        spawns.push((n_through, unit(add(d, mul(n_through, unif64(rs))))));
        for _ in 0..3 {
            spawns.push((n_through, hemisphere(rs, n_through)));
        }
        let p = d3(h.point);
        for (side, dir) in spawns {
            // The side is the hit's own normal, flipped: as the integrator spawns its rays.
            let side32 = if dot(side, n_out) > 0.0 { h.normal } else { -h.normal };
            let dir32 = f3(dir);
            if dot(d3(dir32), side) <= 0.0 {
                continue;
            }
            let origin = offset_ray_origin(h.point, h.error, side32);
            let spawned = Ray::new(origin, dir32);
            st.spawned += 1;
            let Some(h2) = prim.intersect(&spawned, Interval::POSITIVE) else { continue };
            let outward = dot(side, n_out) > 0.0;
            if !closed || outward {
                // Off a flat surface, or out of a convex solid: nothing of the shape is ahead.
                st.outward_rehits += 1;
                st.spawn_example.get_or_insert_with(|| format!("{prim:?} hit at {h:?}, spawned {spawned:?}: {h2:?}"));
                continue;
            }
            // Into the solid: the hit must be the exit the f64 reference finds, not the start (a hit
            // nearer the start than half the distance to that exit, or with no exit ahead at all).
            let (o2, d2) = (d3(origin), d3(dir32));
            let near = len(sub(at(o2, d2, h2.t as f64), p));
            let exit = first_exit64(&prim, o2, d2).map(|t| len(sub(at(o2, d2, t), p)));
            if exit.is_none_or(|l| near < 0.5 * l) {
                st.inward_rehits += 1;
                st.spawn_example.get_or_insert_with(|| {
                    format!("{prim:?} hit at {h:?}, spawned {spawned:?}: {h2:?}, f64 exit at distance {exit:?}")
                });
            }
        }
    }
    st
}

const ERROR_KINDS: [Kind; 6] = [Kind::Sphere, Kind::Box, Kind::Triangle, Kind::Plane, Kind::Cone, Kind::Cylinder];

/// Hit points lie within their error bound of the exact surface (the f64 surface passes through the
/// box `point ± error`), for every shape at sizes 1e-6 to 1e6 and offsets up to 1e6, hit from outside
/// and (closed shapes) from inside.
#[test]
fn hit_points_lie_within_their_error_bounds() {
    let mut report = Vec::new();
    let (mut violations, mut examples) = (0, Vec::new());
    for kind in ERROR_KINDS {
        let st = error_and_spawn_cases(kind, 300_000, None);
        violations += st.violations;
        examples.extend(st.bound_example.clone());
        report.push(format!(
            "  {:<8} {} rays, {} hits ({} from inside): {} points outside their error box (worst |distance| / reach {:.3})",
            kind.name(),
            st.rays,
            st.hits,
            st.inside_hits,
            st.violations,
            st.worst_ratio
        ));
    }
    println!("hit-point error bounds (sizes 1e-6..1e6, offsets up to 1e6):\n{}", report.join("\n"));
    for e in &examples {
        println!("  first failure: {e}");
    }
    assert_eq!(violations, 0, "hit points farther from the surface than their error bound");
}

/// Rays spawned from hits (offset by the error bound along the hit's normal, flipped to the side they
/// leave towards: reflected, transmitted and random directions on both sides) never hit the surface at
/// their start: nothing of a flat surface or of a convex solid they leave outwards, and into a closed
/// solid only its far side; for every shape at sizes 1e-6 to 1e6 and offsets up to 1e6.
#[test]
fn spawned_rays_never_rehit_the_surface_they_leave() {
    let mut report = Vec::new();
    let (mut rehits, mut examples) = (0, Vec::new());
    let mut rs = rng(1101);
    for kind in ERROR_KINDS {
        let st = error_and_spawn_cases(kind, 100_000, Some(&mut rs));
        rehits += st.outward_rehits + st.inward_rehits;
        examples.extend(st.spawn_example.clone());
        report.push(format!(
            "  {:<8} {} hits ({} from inside), {} spawned rays: {} hits leaving a flat surface or a convex solid, \
             {} re-hits at the start going inwards",
            kind.name(),
            st.hits,
            st.inside_hits,
            st.spawned,
            st.outward_rehits,
            st.inward_rehits
        ));
    }
    println!("spawned rays (sizes 1e-6..1e6, offsets up to 1e6):\n{}", report.join("\n"));
    for e in &examples {
        println!("  first failure: {e}");
    }
    assert_eq!(rehits, 0, "spawned rays hit the surface they leave");
}

// ---------------------------------------------------------------------------------------------------
// 2. Homogeneity in |d|.

/// Counts of comparisons and of the properties that differ between a hit on `d` and on `2^k d`.
#[derive(Default, Clone, Copy)]
struct Scaled {
    compared: usize,
    hit_miss: usize,
    primitive: usize,
    t: usize,
    normal: usize,
    uv: usize,
    unrepresentable: usize,
}

impl Scaled {
    fn failures(&self) -> usize {
        self.hit_miss + self.primitive + self.t + self.normal + self.uv
    }

    /// Compares the hit on the direction `2^k d` with the hit `h0` on `d`.
    fn compare(&mut self, h0: Option<&Hit>, hk: Option<&Hit>, k: i32) {
        self.compared += 1;
        match (h0, hk) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                let expected = a.t * pow2(-k);
                if expected as f64 != a.t as f64 * 2f64.powi(-k) {
                    self.unrepresentable += 1;
                } else if b.t.to_bits() != expected.to_bits() {
                    self.t += 1;
                }
                if a.normal.to_array().map(f32::to_bits) != b.normal.to_array().map(f32::to_bits) {
                    self.normal += 1;
                }
                if a.uv.to_array().map(f32::to_bits) != b.uv.to_array().map(f32::to_bits) {
                    self.uv += 1;
                }
            }
            _ => self.hit_miss += 1,
        }
    }

    fn compare_accel(&mut self, h0: &Option<PrimitiveHit>, hk: &Option<PrimitiveHit>, k: i32) {
        if let (Some(a), Some(b)) = (h0, hk) {
            if a.primitive != b.primitive {
                self.compared += 1;
                self.primitive += 1;
                return;
            }
        }
        self.compare(h0.as_ref().map(|h| &h.hit), hk.as_ref().map(|h| &h.hit), k);
    }

    fn describe(&self) -> String {
        format!(
            "{} differ of {} (hit/miss {}, primitive {}, t {}, normal {}, uv {})",
            self.failures(),
            self.compared,
            self.hit_miss,
            self.primitive,
            self.t,
            self.normal,
            self.uv
        )
    }
}

/// Every primitive routine answers the direction `2^k d` (k in -40..=40) exactly as `d`: the same
/// hit or miss, `t` times `2^-k` bit for bit, the same normal and uv bits.
#[test]
fn primitive_answers_scale_exactly_with_direction_length() {
    let mut r = rng(2001);
    let kinds = [Kind::Sphere, Kind::MovingSphere, Kind::Triangle, Kind::Plane, Kind::Box, Kind::Cone, Kind::Cylinder];
    let mut report = Vec::new();
    let mut failed = false;
    for kind in kinds {
        let (mut st, mut hits) = (Scaled::default(), 0);
        for i in 0..2000 {
            let s = 10f32.powf(-1.0 + 2.0 * unif(&mut r));
            let centre = unit_vector(&mut r) * (3.0 * unif(&mut r));
            let prim = shape_at(kind, &mut r, s, centre);
            let closed = !matches!(kind, Kind::Triangle | Kind::Plane);
            let o = if closed && i % 4 == 0 {
                centre
            } else {
                centre + unit_vector(&mut r) * (s * (2.0 + 6.0 * unif(&mut r)))
            };
            let aim = match &prim {
                // Over the triangle and a little beyond its edges.
                Primitive::Triangle(t) => {
                    let (b1, b2) = (1.2 * unif(&mut r) - 0.1, 1.2 * unif(&mut r) - 0.1);
                    let (b1, b2) = if b1 + b2 > 1.1 { (1.0 - b1, 1.0 - b2) } else { (b1, b2) };
                    t.p[0] + (t.p[1] - t.p[0]) * b1 + (t.p[2] - t.p[0]) * b2
                }
                _ => centre + unit_vector(&mut r) * (s * 1.2 * unif(&mut r)),
            };
            let d0 = (aim - o).normalize() * 10f32.powf(-1.0 + 2.0 * unif(&mut r));
            let time = unif(&mut r);
            let h0 = prim.intersect(&Ray::with_time(o, d0, time), Interval::POSITIVE);
            hits += h0.is_some() as usize;
            for k in -40..=40 {
                let hk = prim.intersect(&Ray::with_time(o, d0 * pow2(k), time), Interval::POSITIVE);
                st.compare(h0.as_ref(), hk.as_ref(), k);
            }
        }
        failed |= st.failures() > 0;
        report.push(format!("  {:<13} 2000 rays ({hits} hits) x 81 lengths: {}", kind.name(), st.describe()));
    }
    println!("primitive routines, direction scaled by 2^k, k in -40..=40:\n{}", report.join("\n"));
    assert!(!failed, "a primitive routine is not homogeneous in |d|");
}

/// Every accelerator, by single and by batch queries, answers the direction `2^k d` (k in -40..=40)
/// exactly as `d` on a scene of every kind of primitive: the same primitive, `t` times `2^-k` bit for
/// bit, the same normal and uv bits.
#[test]
fn accelerator_answers_scale_exactly_with_direction_length() {
    let mut r = rng(2002);
    let kinds = [Kind::Sphere, Kind::MovingSphere, Kind::Triangle, Kind::Box, Kind::Cone, Kind::Cylinder];
    let mut prims: Vec<Primitive> = (0..240)
        .map(|i| {
            let c = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 20.0 - Vec3A::splat(10.0);
            let s = 10f32.powf(-0.7 + unif(&mut r));
            shape_at(kinds[i % kinds.len()], &mut r, s, c)
        })
        .collect();
    prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -12.0, 0.0), normal: Vec3A::Y }));
    prims.push(Primitive::Plane(Plane {
        point: Vec3A::new(0.0, 0.0, -15.0),
        normal: Vec3A::new(0.1, 0.2, 1.0).normalize(),
    }));
    let shutter = Interval::new(0.0, 1.0);
    let accels = AnyAccel::all(&prims, shutter);
    // Groups of 64 rays: coherent ones from a common origin outside, and scattered ones inside.
    let mut groups: Vec<Vec<Ray>> = Vec::new();
    for g in 0..32 {
        let o = unit_vector(&mut r) * 30.0;
        let aim = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 16.0 - Vec3A::splat(8.0);
        groups.push(
            (0..64)
                .map(|_| {
                    let time = unif(&mut r);
                    if g % 2 == 0 {
                        let jitter = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 6.0 - Vec3A::splat(3.0);
                        let d = (aim + jitter - o).normalize() * 10f32.powf(unif(&mut r) - 0.5);
                        Ray::with_time(o, d, time)
                    } else {
                        let p = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 20.0 - Vec3A::splat(10.0);
                        Ray::with_time(p, unit_vector(&mut r) * 10f32.powf(unif(&mut r) - 0.5), time)
                    }
                })
                .collect(),
        );
    }
    let mut report = Vec::new();
    let mut failed = false;
    for (a, accel) in accels.iter().enumerate() {
        let (mut single, mut batch, mut hits) = (Scaled::default(), Scaled::default(), 0);
        for rays in &groups {
            let s0: Vec<_> = rays.iter().map(|ray| accel.closest(ray)).collect();
            let b0 = accel.batch(rays);
            hits += s0.iter().filter(|h| h.is_some()).count();
            for k in (-40..=40).filter(|&k| k != 0) {
                let scaled: Vec<Ray> =
                    rays.iter().map(|ray| Ray::with_time(ray.origin, ray.dir * pow2(k), ray.time)).collect();
                for (ray, h0) in scaled.iter().zip(&s0) {
                    single.compare_accel(h0, &accel.closest(ray), k);
                }
                for (hk, h0) in accel.batch(&scaled).iter().zip(&b0) {
                    batch.compare_accel(h0, hk, k);
                }
            }
        }
        failed |= single.failures() + batch.failures() > 0;
        report.push(format!(
            "  {:<15} {} rays ({hits} hits) x 80 lengths: single {}; batch {}",
            ACCEL_NAMES[a],
            groups.len() * 64,
            single.describe(),
            batch.describe()
        ));
    }
    println!(
        "accelerators on {} primitives (every kind), direction scaled by 2^k, k in -40..=40 (best kernel {:?}):\n{}",
        prims.len(),
        BvhKernel::best(),
        report.join("\n")
    );
    assert!(!failed, "an accelerator is not homogeneous in |d|");
}

// ---------------------------------------------------------------------------------------------------
// 3. Watertight meshes.

/// A lat-long sphere of radius 1: `n_lat` bands of `n_lon` quads (split in two), the poles shared.
fn latlong_sphere(n_lon: usize, n_lat: usize) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let mut v = vec![Vec3A::Z, -Vec3A::Z];
    for i in 1..n_lat {
        let theta = std::f32::consts::PI * i as f32 / n_lat as f32;
        for j in 0..n_lon {
            let phi = std::f32::consts::TAU * j as f32 / n_lon as f32;
            v.push(Vec3A::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    let ring = |i: usize, j: usize| (2 + (i - 1) * n_lon + j % n_lon) as u32;
    let mut f = Vec::new();
    for j in 0..n_lon {
        f.push([0, ring(1, j), ring(1, j + 1)]);
        f.push([1, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
        for i in 1..n_lat - 1 {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            f.push([a, c, d]);
            f.push([a, d, b]);
        }
    }
    (v, f)
}

/// The square [-1, 1]^2 at z = 0, as `n` x `n` quads split in two.
fn tessellated_square(n: usize) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    let v = (0..=n)
        .flat_map(|i| {
            (0..=n).map(move |j| Vec3A::new(-1.0 + 2.0 * i as f32 / n as f32, -1.0 + 2.0 * j as f32 / n as f32, 0.0))
        })
        .collect();
    let mut f = Vec::new();
    for i in 0..n {
        for j in 0..n {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (v, f)
}

/// A mesh placed in the scene, with its adjacency.
struct Mesh {
    v: Vec<Vec3A>,
    f: Vec<[u32; 3]>,
    /// The faces around each vertex.
    star: Vec<Vec<usize>>,
    /// Edges `(a, b)` between inner vertices.
    inner_edges: Vec<(u32, u32)>,
    /// Vertices whose faces all have inner vertices only: the mesh surrounds them and their faces.
    inner_vertices: Vec<u32>,
    /// Faces whose three vertices have edges with two faces each: the mesh surrounds them.
    inner_faces: Vec<bool>,
}

impl Mesh {
    fn new(v: Vec<Vec3A>, f: Vec<[u32; 3]>) -> Self {
        let mut star = vec![Vec::new(); v.len()];
        let mut edges = std::collections::HashMap::new();
        for (i, t) in f.iter().enumerate() {
            for k in 0..3 {
                star[t[k] as usize].push(i);
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        let mut boundary = vec![false; v.len()];
        for (&(a, b), &n) in &edges {
            if n != 2 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
        }
        let inner_faces: Vec<bool> = f.iter().map(|t| t.iter().all(|&i| !boundary[i as usize])).collect();
        let deep: Vec<bool> = star.iter().map(|faces| faces.iter().all(|&i| inner_faces[i])).collect();
        let mut inner_edges: Vec<(u32, u32)> =
            edges.keys().filter(|&&(a, b)| deep[a as usize] && deep[b as usize]).copied().collect();
        inner_edges.sort_unstable();
        let inner_vertices = (0..v.len() as u32).filter(|&i| deep[i as usize]).collect();
        Self { v, f, star, inner_edges, inner_vertices, inner_faces }
    }

    /// Whether the exact line of the ray (its f32 origin and direction) crosses the mesh ahead, in a
    /// face the mesh surrounds (so not within rounding of an open mesh's rim).
    fn crossed_by(&self, ray: &Ray) -> bool {
        let (o, d) = (d3(ray.origin), d3(ray.dir));
        (0..self.f.len()).any(|i| {
            self.inner_faces[i] && crossing64(&self.triangle(i), o, d).is_some_and(|(t, m)| t > 0.0 && m >= -1e-12)
        })
    }

    fn triangle(&self, i: usize) -> Triangle {
        let t = self.f[i];
        Triangle::new(self.v[t[0] as usize], self.v[t[1] as usize], self.v[t[2] as usize])
    }

    /// Whether every face around the vertices `vs` faces the ray direction `dir` clearly, all from the
    /// same side: the ray then cannot pass by them without a hit.
    fn seen_clearly(&self, vs: &[u32], dir: D3) -> bool {
        let d = unit(dir);
        let cos: Vec<f64> = vs
            .iter()
            .flat_map(|&v| self.star[v as usize].iter())
            .map(|&i| {
                let n = normal64(&self.triangle(i));
                if len(n) == 0.0 { 0.0 } else { dot(unit(n), d) }
            })
            .collect();
        cos.iter().all(|&c| c >= 0.2) || cos.iter().all(|&c| c <= -0.2)
    }
}

/// Rays at closed meshes (an icosphere and a lat-long sphere, from inside, and from outside at vertices
/// and edges they see clearly) and at a tessellated square (at inner vertices and edges), with
/// direction lengths 2^k for k in -40..=40 and the meshes up to 1e6 from the origin, never pass
/// through: whenever the exact line of the ray crosses the mesh (f64 reference), every accelerator
/// finds a hit, and the any-hit query agrees.
#[test]
fn meshes_are_watertight_for_any_direction_length_and_distance() {
    let mut r = rng(3001);
    let bases = [
        ("icosphere(3)", icosphere(3), true),
        ("lat-long 32x16", latlong_sphere(32, 16), true),
        ("square 8x8", tessellated_square(8), false),
    ];
    let distances = [0.0f32, 1e2, 1e4, 1e6];
    let groups: [(i32, i32); 5] = [(-40, -25), (-24, -9), (-8, 8), (9, 24), (25, 40)];
    let mut report = Vec::new();
    let mut total_leaks = [0usize; 4];
    let mut total_rays = 0usize;
    for (name, (v0, f0), closed) in &bases {
        for &dist in &distances {
            let rot = rotation(&mut r);
            let centre = unit_vector(&mut r) * dist;
            let mesh = Mesh::new(v0.iter().map(|&p| centre + rot * p).collect(), f0.clone());
            let prims: Vec<Primitive> = (0..mesh.f.len()).map(|i| Primitive::Triangle(mesh.triangle(i))).collect();
            let accels = AnyAccel::all(&prims, Interval::new(0.0, 0.0));
            let mut leaks = [[0usize; 4]; 5];
            let mut rays_in_group = [0usize; 5];
            let mut skipped = 0usize;
            for k in -40..=40 {
                let g = groups.iter().position(|&(lo, hi)| (lo..=hi).contains(&k)).unwrap();
                let scale = pow2(k);
                let mut rays: Vec<Ray> = Vec::new();
                let edge_point = |r: &mut Pcg32, edges: &[(u32, u32)], mid: bool| {
                    let (a, b) = edges[r.next_u32() as usize % edges.len()];
                    let s = if mid { 0.5 } else { unif(r) };
                    ((a, b), mesh.v[a as usize] + (mesh.v[b as usize] - mesh.v[a as usize]) * s)
                };
                if *closed {
                    let all_edges = &mesh.inner_edges;
                    for kind in 0..4 {
                        for _ in 0..16 {
                            let o = centre + unit_vector(&mut r) * (0.5 * unif(&mut r).cbrt());
                            let dir = match kind {
                                0 => unit_vector(&mut r),
                                1 => (mesh.v[r.next_u32() as usize % mesh.v.len()] - o).normalize(),
                                _ => (edge_point(&mut r, all_edges, kind == 3).1 - o).normalize(),
                            };
                            rays.push(Ray::new(o, dir * scale));
                        }
                    }
                    // From outside, at vertices and edge points whose faces face the origin clearly.
                    for kind in 0..2 {
                        let mut made = 0;
                        for _ in 0..200 {
                            if made == 16 {
                                break;
                            }
                            let o = centre + unit_vector(&mut r) * (2.0 + 3.0 * unif(&mut r));
                            let (vs, target) = if kind == 0 {
                                let i = r.next_u32() % mesh.v.len() as u32;
                                (vec![i], mesh.v[i as usize])
                            } else {
                                let ((a, b), p) = edge_point(&mut r, all_edges, false);
                                (vec![a, b], p)
                            };
                            let dir = (target - o).normalize();
                            if mesh.seen_clearly(&vs, d3(dir)) {
                                rays.push(Ray::new(o, dir * scale));
                                made += 1;
                            }
                        }
                    }
                } else {
                    for kind in 0..3 {
                        let mut made = 0;
                        for _ in 0..200 {
                            if made == 24 {
                                break;
                            }
                            let (vs, target) = if kind == 0 {
                                let i = mesh.inner_vertices[r.next_u32() as usize % mesh.inner_vertices.len()];
                                (vec![i], mesh.v[i as usize])
                            } else {
                                let ((a, b), p) = edge_point(&mut r, &mesh.inner_edges, kind == 2);
                                (vec![a, b], p)
                            };
                            let o = target + unit_vector(&mut r) * (0.5 + 2.5 * unif(&mut r));
                            let dir = (target - o).normalize();
                            if mesh.seen_clearly(&vs, d3(dir)) {
                                rays.push(Ray::new(o, dir * scale));
                                made += 1;
                            }
                        }
                    }
                }
                for ray in &rays {
                    // Only rays whose exact line crosses the mesh away from its rim must hit (f32
                    // rounding of the targets may take a few to the rim of the square, or past it).
                    if !mesh.crossed_by(ray) {
                        skipped += 1;
                        continue;
                    }
                    rays_in_group[g] += 1;
                    for (a, accel) in accels.iter().enumerate() {
                        if accel.closest(ray).is_none() || !accel.occluded(ray, f32::INFINITY) {
                            leaks[g][a] += 1;
                        }
                    }
                }
            }
            let rays: usize = rays_in_group.iter().sum();
            total_rays += rays;
            for g in &leaks {
                for a in 0..4 {
                    total_leaks[a] += g[a];
                }
            }
            let cells: Vec<String> = groups
                .iter()
                .zip(&leaks)
                .zip(&rays_in_group)
                .map(|((&(lo, hi), l), n)| format!("k {lo}..{hi}: {}/{}/{}/{} of {n}", l[0], l[1], l[2], l[3]))
                .collect();
            report.push(format!(
                "  {name:<15} D={dist:<5e} {rays} rays ({skipped} left out: their exact line misses the mesh); leaks {}",
                cells.join(", ")
            ));
        }
    }
    println!(
        "watertight meshes, |d| = 2^k, leaks (no closest hit, or not occluded) as {} / {} / {} / {}:\n{}\n  total {total_rays} rays: leaks {total_leaks:?}",
        ACCEL_NAMES[0],
        ACCEL_NAMES[1],
        ACCEL_NAMES[2],
        ACCEL_NAMES[3],
        report.join("\n")
    );
    assert_eq!(total_leaks, [0; 4], "rays passed through a watertight mesh");
}

// ---------------------------------------------------------------------------------------------------
// 4. Extreme sizes.

/// Right triangles with legs 2^e (e in -60..=60, step 4), a few legs from the ray origin, are hit
/// through interior points by the primitive routine and by every accelerator, at the f64 distance
/// within 1e-5 relative.
#[test]
fn extreme_triangle_sizes_are_hit_at_the_right_distance() {
    let mut r = rng(4001);
    let mut tri_lines = Vec::new();
    let (mut tri_failures, mut tri_rays, mut worst_tri) = ([0usize; 5], 0usize, 0.0f64);
    for e in (-60..=60).step_by(4) {
        let leg = pow2(e);
        let rot = rotation(&mut r);
        let o = unit_vector(&mut r) * (leg * unif(&mut r));
        // Six triangles around the origin, one on each side, none in front of another.
        let tris: Vec<Triangle> = [Vec3A::X, -Vec3A::X, Vec3A::Y, -Vec3A::Y, Vec3A::Z, -Vec3A::Z]
            .iter()
            .map(|&axis| {
                let a = rot * axis;
                let (s, t) = orthonormal_basis(a);
                let p0 = o + a * (3.0 * leg) - (s + t) * (leg / 3.0);
                Triangle::new(p0, p0 + s * leg, p0 + t * leg)
            })
            .collect();
        let prims: Vec<Primitive> = tris.iter().map(|t| Primitive::Triangle(*t)).collect();
        let accels: Vec<Option<AnyAccel>> = (0..4)
            .map(|a| catch_unwind(AssertUnwindSafe(|| AnyAccel::build(a, &prims, Interval::new(0.0, 0.0)))).ok())
            .collect();
        let mut failures = [0usize; 5];
        let mut rays = 0;
        for (j, tri) in tris.iter().enumerate() {
            for q in 0..50 {
                let (b1, b2) = (0.05 + 0.45 * unif(&mut r), 0.05 + 0.45 * unif(&mut r));
                let target = tri.p[0] + (tri.p[1] - tri.p[0]) * b1 + (tri.p[2] - tri.p[0]) * b2;
                let dir = if q % 2 == 0 { target - o } else { (target - o).normalize() };
                let ray = Ray::new(o, dir);
                let Some(t_ref) = triangle_plane_t64(tri, d3(o), d3(dir)) else { continue };
                rays += 1;
                let rel = |t: f32| (t as f64 - t_ref).abs() / t_ref;
                let own = catch_unwind(AssertUnwindSafe(|| tri.intersect(&ray, Interval::POSITIVE))).ok().flatten();
                match own {
                    Some(h) if rel(h.t) <= 1e-5 => {}
                    _ => failures[0] += 1,
                }
                if let Some(h) = own {
                    worst_tri = worst_tri.max(rel(h.t));
                }
                for (a, accel) in accels.iter().enumerate() {
                    let found = accel
                        .as_ref()
                        .and_then(|acc| catch_unwind(AssertUnwindSafe(|| acc.closest(&ray))).ok().flatten());
                    if !found.is_some_and(|h| h.primitive == j as u32 && rel(h.hit.t) <= 1e-5) {
                        failures[a + 1] += 1;
                    }
                }
            }
        }
        tri_rays += rays;
        for a in 0..5 {
            tri_failures[a] += failures[a];
        }
        if failures.iter().any(|&f| f > 0) {
            let panicked: Vec<&str> = (0..4).filter(|&a| accels[a].is_none()).map(|a| ACCEL_NAMES[a]).collect();
            tri_lines.push(format!(
                "e={e}: {failures:?} of {rays}{}",
                if panicked.is_empty() { String::new() } else { format!(" (build panicked: {})", panicked.join(", ")) }
            ));
        }
    }
    println!(
        "extreme triangles, legs 2^e for e in -60..=60 step 4: {tri_rays} rays through interior points; missed or t off by > 1e-5 \
         (routine, {}, {}, {}, {}): {tri_failures:?}; worst relative t error {worst_tri:.2e}",
        ACCEL_NAMES[0], ACCEL_NAMES[1], ACCEL_NAMES[2], ACCEL_NAMES[3]
    );
    if !tri_lines.is_empty() {
        println!("  by size: {}", tri_lines.join("; "));
    }
    assert_eq!(tri_failures, [0; 5], "extreme triangles missed");
}

/// Spheres of radius 10^e (e in -30..=30), seen from 1.25 to 3 radii away and from inside, are hit by
/// the ray through the centre (with a unit direction and with one as long as the distance) at the
/// f64 distance within 1e-5 relative; the sphere routine never returns NaN, for these rays and for
/// random rays around the spheres.
#[test]
fn extreme_sphere_sizes_are_hit_at_the_right_distance_without_nan() {
    let mut r = rng(4002);
    let mut sphere_lines = Vec::new();
    let (mut sphere_wrong, mut sphere_rays, mut nans, mut worst_sphere) = (0usize, 0usize, 0usize, 0.0f64);
    for e in -30..=30 {
        let radius = 10f64.powi(e) as f32;
        let mut wrong = [0usize; 4];
        for (mode, wrong) in wrong.iter_mut().enumerate() {
            let outside = mode < 2;
            for _ in 0..100 {
                let dist = radius * if outside { 1.25 + 1.75 * unif(&mut r) } else { 0.8 * unif(&mut r) };
                let o = unit_vector(&mut r) * (2.0 * radius * unif(&mut r));
                let c = o + unit_vector(&mut r) * dist;
                let dir = if mode % 2 == 0 { c - o } else { (c - o).normalize() };
                if dir == Vec3A::ZERO {
                    continue;
                }
                let ray = Ray::new(o, dir);
                let Some((t0, t1)) = sphere_roots64(d3(c), radius as f64, d3(o), d3(dir)) else { continue };
                let t_ref = if outside { t0 } else { t1 };
                if t_ref.is_nan() || t_ref <= 0.0 {
                    continue;
                }
                sphere_rays += 1;
                let h = Sphere { center: c, radius }.intersect(&ray, Interval::POSITIVE);
                if let Some(h) = h {
                    if h.t.is_nan() || h.point.is_nan() || h.normal.is_nan() || h.error.is_nan() {
                        nans += 1;
                    }
                    let rel = (h.t as f64 - t_ref).abs() / t_ref;
                    worst_sphere = worst_sphere.max(if rel.is_nan() { f64::INFINITY } else { rel });
                }
                if !h.is_some_and(|h| (h.t as f64 - t_ref).abs() <= 1e-5 * t_ref) {
                    *wrong += 1;
                }
            }
        }
        // Random rays near and through the sphere: never NaN.
        for _ in 0..200 {
            let c = unit_vector(&mut r) * (radius * 3.0 * unif(&mut r));
            let o = unit_vector(&mut r) * (radius * 4.0 * unif(&mut r));
            let d = unit_vector(&mut r) * 10f32.powf(-3.0 + 6.0 * unif(&mut r));
            if let Some(h) = (Sphere { center: c, radius }).intersect(&Ray::new(o, d), Interval::POSITIVE) {
                if h.t.is_nan() || h.point.is_nan() || h.normal.is_nan() || h.error.is_nan() {
                    nans += 1;
                }
            }
        }
        sphere_wrong += wrong.iter().sum::<usize>();
        if wrong.iter().any(|&w| w > 0) {
            sphere_lines.push(format!("e={e}: {wrong:?}"));
        }
    }
    println!(
        "extreme spheres, radius 10^e for e in -30..=30: {sphere_rays} rays through the centre, {sphere_wrong} missed or t off by > 1e-5 \
         (worst relative t error {worst_sphere:.2e}); {nans} hits with NaN"
    );
    if !sphere_lines.is_empty() {
        println!(
            "  by size, [outside |d|~D, outside unit d, inside |d|~D, inside unit d] of 100 each: {}",
            sphere_lines.join("; ")
        );
    }
    assert_eq!(sphere_wrong, 0, "extreme spheres missed or hit at the wrong distance");
    assert_eq!(nans, 0, "the sphere routine returned NaN");
}

// ---------------------------------------------------------------------------------------------------
// 5. Order-independent answers.

/// Rays at shared vertices and edges of an icosphere, of fans of triangles (coplanar and not) and of
/// duplicated triangles: every accelerator, by single and by batch queries, returns the closest hit
/// of the primitives' own routines with ties to the lowest index (primitive, t and uv bits); and
/// permuting the primitives gives the same t bits (and the same primitive, mapped back, when it is
/// the only one at that t).
#[test]
fn closest_hits_do_not_depend_on_accelerator_query_or_primitive_order() {
    let mut r = rng(5001);
    // Scene A: an icosphere, rays from outside at vertices and edge midpoints it shows clearly, and
    // from inside at vertices and midpoints.
    let (v, f) = icosphere(3);
    let centre = Vec3A::new(3.0, -2.0, 5.0);
    let rot = rotation(&mut r);
    let ico = Mesh::new(v.iter().map(|&p| centre + rot * (p * 2.0)).collect(), f);
    let ico_prims: Vec<Primitive> = (0..ico.f.len()).map(|i| Primitive::Triangle(ico.triangle(i))).collect();
    let mut ico_groups: Vec<Vec<Ray>> = Vec::new();
    for g in 0..120 {
        let outside = g % 2 == 0;
        let o = if outside {
            centre + unit_vector(&mut r) * 8.0
        } else {
            centre + unit_vector(&mut r) * (0.6 * unif(&mut r))
        };
        let mut rays = Vec::new();
        while rays.len() < 64 {
            let (vs, target) = if r.next_u32() % 2 == 0 {
                let i = r.next_u32() % ico.v.len() as u32;
                (vec![i], ico.v[i as usize])
            } else {
                let (a, b) = ico.inner_edges[r.next_u32() as usize % ico.inner_edges.len()];
                (vec![a, b], (ico.v[a as usize] + ico.v[b as usize]) * 0.5)
            };
            let dir = (target - o).normalize();
            if !outside || ico.seen_clearly(&vs, d3(dir)) {
                rays.push(Ray::new(o, dir));
            }
        }
        ico_groups.push(rays);
    }

    // Scene B: an 8 x 8 lattice of clusters: coplanar fans (spokes along the axes included), fans that
    // are not flat, and duplicated triangles (identical, and with their vertices rotated or reversed).
    let mut fan_prims: Vec<Primitive> = Vec::new();
    let mut keypoints: Vec<Vec<Vec3A>> = Vec::new();
    for cluster in 0..64 {
        let base = Vec3A::new((cluster % 8) as f32 * 10.0, (cluster / 8) as f32 * 10.0, (r.next_u32() % 3) as f32);
        let mut points = vec![base];
        match cluster % 3 {
            0 | 1 => {
                let m = [4usize, 6, 8, 12][r.next_u32() as usize % 4];
                let flat = cluster % 3 == 0;
                let ring: Vec<Vec3A> = (0..m)
                    .map(|i| {
                        let rho = 2.0;
                        if flat && m % 4 == 0 && (4 * i) % m == 0 {
                            // Exactly along the axes.
                            [Vec3A::X, Vec3A::Y, -Vec3A::X, -Vec3A::Y][4 * i / m] * rho + base
                        } else {
                            let th = std::f32::consts::TAU * (i as f32 + 0.2 * (unif(&mut r) - 0.5)) / m as f32;
                            let z = if flat { 0.0 } else { unif(&mut r) - 0.5 };
                            base + Vec3A::new(th.cos() * rho, th.sin() * rho, z)
                        }
                    })
                    .collect();
                let start = r.next_u32() as usize % m;
                for i in 0..m {
                    let (a, b) = (ring[(start + i) % m], ring[(start + i + 1) % m]);
                    fan_prims.push(Primitive::Triangle(Triangle::new(base, a, b)));
                }
                for p in &ring {
                    points.push(base + (*p - base) * 0.25);
                    points.push(base + (*p - base) * 0.5);
                }
            }
            _ => {
                let t = Triangle::new(
                    base + Vec3A::new(-1.5, -1.0, 0.0),
                    base + Vec3A::new(1.5, -1.25, 0.25),
                    base + Vec3A::new(0.25, 1.5, -0.25),
                );
                let [a, b, c] = t.p;
                for tri in [t, t, Triangle::new(b, c, a), Triangle::new(a, c, b), t] {
                    fan_prims.push(Primitive::Triangle(tri));
                }
                points = vec![a, (a + b) * 0.5, (b + c) * 0.5, a * 0.25 + b * 0.25 + c * 0.5, (a + b + c) / 3.0];
            }
        }
        keypoints.push(points);
    }
    let mut fan_groups: Vec<Vec<Ray>> = Vec::new();
    for g in 0..120 {
        let rays = keypoints
            .iter()
            .map(|points| {
                let p = points[r.next_u32() as usize % points.len()];
                match g % 3 {
                    0 => {
                        let o = Vec3A::new(-20.0, -20.0, 50.0) + unit_vector(&mut r) * 5.0;
                        Ray::new(o, (p - o).normalize())
                    }
                    1 => {
                        let o = Vec3A::new(90.0, 90.0, -50.0) + unit_vector(&mut r) * 5.0;
                        Ray::new(o, (p - o).normalize())
                    }
                    // Straight down through the point: exactly through shared vertices and axis spokes.
                    _ => Ray::new(Vec3A::new(p.x, p.y, 20.0), Vec3A::new(0.0, 0.0, -1.0)),
                }
            })
            .collect();
        fan_groups.push(rays);
    }

    let mut report = Vec::new();
    let mut failed = false;
    for (name, prims, groups) in
        [("icosphere", &ico_prims, &ico_groups), ("fans and duplicates", &fan_prims, &fan_groups)]
    {
        let accels = AnyAccel::all(prims, Interval::new(0.0, 0.0));
        let mut perm: Vec<usize> = (0..prims.len()).collect();
        for i in (1..perm.len()).rev() {
            perm.swap(i, r.next_u32() as usize % (i + 1));
        }
        let permuted: Vec<Primitive> = perm.iter().map(|&i| prims[i]).collect();
        let permuted_accels = AnyAccel::all(&permuted, Interval::new(0.0, 0.0));
        let (mut rays, mut hits, mut tie_rays) = (0usize, 0usize, 0usize);
        let (mut single, mut batch, mut tie_breaks, mut perm_diff) =
            ([0usize; 4], [0usize; 4], [0usize; 4], [0usize; 4]);
        for group in groups.iter() {
            let reference: Vec<_> = group.iter().map(|ray| reference_closest(prims, ray)).collect();
            for (a, accel) in accels.iter().enumerate() {
                let batched = accel.batch(group);
                for ((ray, (want, tied)), b) in group.iter().zip(&reference).zip(&batched) {
                    let got = accel.closest(ray);
                    let wrong_tie = |h: &Option<PrimitiveHit>| {
                        *tied > 1 && h.map(|h| h.hit.t) == want.map(|h| h.hit.t) && key(h) != key(want)
                    };
                    if key(&got) != key(want) {
                        single[a] += 1;
                        tie_breaks[a] += wrong_tie(&got) as usize;
                    }
                    if key(b) != key(want) {
                        batch[a] += 1;
                        tie_breaks[a] += wrong_tie(b) as usize;
                    }
                    let moved = permuted_accels[a].closest(ray);
                    let same_t = moved.map(|h| h.hit.t.to_bits()) == want.map(|h| h.hit.t.to_bits());
                    let same_prim =
                        *tied != 1 || moved.map(|h| perm[h.primitive as usize] as u32) == want.map(|h| h.primitive);
                    if !same_t || !same_prim {
                        perm_diff[a] += 1;
                    }
                }
            }
            rays += group.len();
            hits += reference.iter().filter(|(h, _)| h.is_some()).count();
            tie_rays += reference.iter().filter(|(_, n)| *n > 1).count();
        }
        failed |= single.iter().chain(&batch).chain(&perm_diff).any(|&n| n > 0);
        report.push(format!(
            "  {name}: {} primitives, {rays} rays ({hits} hits, {tie_rays} with several primitives at the closest t); \
             differing from the reference (single / batch / of which lost ties / permuted):",
            prims.len()
        ));
        for a in 0..4 {
            report.push(format!(
                "    {:<15} {} / {} / {} / {}",
                ACCEL_NAMES[a], single[a], batch[a], tie_breaks[a], perm_diff[a]
            ));
        }
    }
    println!("closest hits at shared vertices and edges, ties to the lowest index:\n{}", report.join("\n"));
    assert!(!failed, "answers depend on the accelerator, the query form or the primitive order");
}

// ---------------------------------------------------------------------------------------------------
// 6. Conservative bounds.

/// Whether the f64 point `p` lies in `b`, allowing only the f64 reference's own rounding (`tol`).
fn inside_box64(b: &Aabb, p: D3, tol: f64) -> bool {
    (0..3).all(|a| p[a] >= b.min[a] as f64 - tol && p[a] <= b.max[a] as f64 + tol)
}

/// How far `p` lies outside `b`, in f32 ulps of the coordinate.
fn excess_ulps(b: &Aabb, p: D3) -> f64 {
    (0..3)
        .map(|a| {
            let over = (p[a] - b.max[a] as f64).max(b.min[a] as f64 - p[a]).max(0.0);
            over / ulp(p[a] as f32) as f64
        })
        .fold(0.0, f64::max)
}

/// A sphere whose centre plus or minus its radius is not an f32: centre coordinates in [2^23, 2^24)
/// (spacing 1) and a radius with a fraction in [0.1, 0.45], so the sums round towards the centre.
fn rounding_sphere(r: &mut Pcg32) -> (Vec3A, f32) {
    let coord = |r: &mut Pcg32| {
        let v = (1u32 << 23) as f32 + (r.next_u32() % 1_000_000) as f32;
        if r.next_u32() % 2 == 0 { v } else { -v }
    };
    let c = Vec3A::new(coord(r), coord(r), coord(r));
    let radius = (5 + r.next_u32() % 500) as f32 + 0.1 + 0.35 * unif(r);
    (c, radius)
}

/// A cone (or cylinder) with a random tilt, base up to 1e7 from the origin.
fn tilted_cone(r: &mut Pcg32, cylinder: bool) -> Cone {
    let base = unit_vector(r) * 10f32.powf(7.0 * unif(r));
    let size = (base.length() * 10f32.powf(-5.0 + 4.0 * unif(r))).max(1e-3);
    let axis = unit_vector(r) * (size * (0.5 + 2.0 * unif(r)));
    let r0 = size * (0.2 + unif(r));
    let r1 = if cylinder { r0 } else { r0 * unif(r) };
    Cone { base, base_radius: r0, apex: base + axis, apex_radius: r1 }
}

/// The f64 reference point nearest the reported `t` of a hit on `prim` by `ray`, if any.
fn exact_hit_point(prim: &Primitive, ray: &Ray, t: f32) -> Option<D3> {
    let (o, d) = (d3(ray.origin), d3(ray.dir));
    let nearest = |ts: &[f64]| ts.iter().copied().min_by(|a, b| (a - t as f64).abs().total_cmp(&(b - t as f64).abs()));
    let t_ref = match prim {
        Primitive::Sphere(s) => {
            let (t0, t1) = sphere_roots64(d3(s.center), s.radius as f64, o, d)?;
            nearest(&[t0, t1])
        }
        Primitive::MovingSphere(m) => {
            let (c0, c1) = (d3(m.center0), d3(m.center1));
            let f = (ray.time as f64 - m.time0 as f64) / (m.time1 as f64 - m.time0 as f64);
            let (t0, t1) = sphere_roots64(add(c0, mul(sub(c1, c0), f)), m.radius as f64, o, d)?;
            nearest(&[t0, t1])
        }
        Primitive::Box(b) => {
            let (lo, hi) = slab64(d3(b.bounds.min), d3(b.bounds.max), o, d)?;
            nearest(&[lo, hi])
        }
        Primitive::Cone(c) => {
            let ts: Vec<f64> = Cone64::new(c).crossings(o, d).iter().map(|c| c.0).collect();
            nearest(&ts)
        }
        _ => None,
    }?;
    Some(at(o, d, t_ref))
}

/// Hit points lie inside the bounds of the primitive hit: the reported point (exactly) and the f64
/// reference point of the ray on the exact surface (up to the f64 rounding of the reference), for
/// spheres (general ones and ones whose centre plus radius rounds in f32), moving spheres over the
/// shutter, triangles, boxes and tilted cones and cylinders.
#[test]
fn hit_points_lie_inside_primitive_bounds() {
    let mut r = rng(6001);
    let shutter = Interval::new(0.0, 1.0);
    let names = ["sphere", "rounding sphere", "moving sphere", "triangle", "box", "cone", "cylinder"];
    let mut report = Vec::new();
    let mut failed = false;
    for (kind, name) in names.iter().enumerate() {
        let (mut hits, mut reported_out, mut exact_out, mut checked_exact, mut worst) =
            (0usize, 0usize, 0usize, 0usize, 0.0f64);
        for _ in 0..5000 {
            let prim = match kind {
                0 => {
                    let c = unit_vector(&mut r) * 10f32.powf(7.0 * unif(&mut r));
                    let radius = (c.length() * 10f32.powf(-5.0 + 4.0 * unif(&mut r))).max(1e-3);
                    Primitive::Sphere(Sphere { center: c, radius })
                }
                1 => {
                    let (center, radius) = rounding_sphere(&mut r);
                    Primitive::Sphere(Sphere { center, radius })
                }
                2 => {
                    let (center0, radius) = rounding_sphere(&mut r);
                    let step = Vec3A::new(
                        (r.next_u32() % 2001) as f32 - 1000.0,
                        (r.next_u32() % 2001) as f32 - 1000.0,
                        (r.next_u32() % 2001) as f32 - 1000.0,
                    );
                    Primitive::MovingSphere(MovingSphere {
                        center0,
                        center1: center0 + step,
                        radius,
                        time0: 0.0,
                        time1: 1.0,
                    })
                }
                3 => {
                    let c = unit_vector(&mut r) * 10f32.powf(7.0 * unif(&mut r));
                    let s = (c.length() * 10f32.powf(-5.0 + 4.0 * unif(&mut r))).max(1e-3);
                    Primitive::Triangle(Triangle::new(c, c + unit_vector(&mut r) * s, c + unit_vector(&mut r) * s))
                }
                4 => {
                    let c = unit_vector(&mut r) * 10f32.powf(7.0 * unif(&mut r));
                    let s = (c.length() * 10f32.powf(-5.0 + 4.0 * unif(&mut r))).max(1e-3);
                    let half = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * s + Vec3A::splat(0.01 * s);
                    Primitive::Box(AaBox { bounds: Aabb::new(c - half, c + half) })
                }
                5 => Primitive::Cone(tilted_cone(&mut r, false)),
                _ => Primitive::Cone(tilted_cone(&mut r, true)),
            };
            let bounds = prim.bounds_over(shutter);
            for q in 0..20 {
                let time = match q % 4 {
                    0 => 0.0,
                    1 => 1.0,
                    _ => unif(&mut r),
                };
                // A target on the surface, near the extremes along the axes half of the time.
                let (target, n, size) = match &prim {
                    Primitive::Sphere(_) | Primitive::MovingSphere(_) => {
                        let (c, radius) = match &prim {
                            Primitive::Sphere(s) => (d3(s.center), s.radius as f64),
                            Primitive::MovingSphere(m) => (d3(m.center_at(time)), m.radius as f64),
                            _ => unreachable!(),
                        };
                        let n = if q % 2 == 0 {
                            let mut e = [0.0; 3];
                            e[(r.next_u32() % 3) as usize] = if r.next_u32() % 2 == 0 { 1.0 } else { -1.0 };
                            unit(add(e, mul(unit64_random(&mut r), 0.05 * unif64(&mut r))))
                        } else {
                            unit64_random(&mut r)
                        };
                        (at(c, n, radius), n, radius)
                    }
                    Primitive::Triangle(t) => {
                        let (mut b1, mut b2) = (unif64(&mut r), unif64(&mut r));
                        if b1 + b2 > 1.0 {
                            (b1, b2) = (1.0 - b1, 1.0 - b2);
                        }
                        if q % 2 == 0 {
                            // Near a vertex.
                            let (e1, e2) = (1e-3 * b1, 1e-3 * b2);
                            (b1, b2) = match r.next_u32() % 3 {
                                0 => (e1, e2),
                                1 => (1.0 - e1 - e2, e2),
                                _ => (e1, 1.0 - e1 - e2),
                            };
                        }
                        let p = t.p.map(d3);
                        let x = add(p[0], add(mul(sub(p[1], p[0]), b1), mul(sub(p[2], p[0]), b2)));
                        let n = unit(normal64(t));
                        (x, if r.next_u32() % 2 == 0 { n } else { mul(n, -1.0) }, len(sub(p[1], p[0])))
                    }
                    Primitive::Box(b) => {
                        let (min, max) = (d3(b.bounds.min), d3(b.bounds.max));
                        let a = (r.next_u32() % 3) as usize;
                        let mut p = [0, 1, 2].map(|k| {
                            let u = unif64(&mut r);
                            let u =
                                if q % 2 == 0 { if u < 0.5 { u * 1e-3 } else { 1.0 - (1.0 - u) * 1e-3 } } else { u };
                            min[k] + (max[k] - min[k]) * u
                        });
                        let mut n = [0.0; 3];
                        if r.next_u32() % 2 == 0 {
                            (p[a], n[a]) = (max[a], 1.0);
                        } else {
                            (p[a], n[a]) = (min[a], -1.0);
                        }
                        (p, n, len(sub(max, min)))
                    }
                    Primitive::Cone(c) => {
                        let c64 = Cone64::new(c);
                        let p = if q % 2 == 0 {
                            // Near the point of a rim that is extreme along an axis.
                            let z = if r.next_u32() % 2 == 0 {
                                c64.h * 1e-4 * unif64(&mut r)
                            } else {
                                c64.h * (1.0 - 1e-4 * unif64(&mut r))
                            };
                            let mut e = [0.0; 3];
                            e[(r.next_u32() % 3) as usize] = if r.next_u32() % 2 == 0 { 1.0 } else { -1.0 };
                            let radial = sub(e, mul(c64.w, dot(e, c64.w)));
                            if len(radial) < 1e-6 {
                                c64.point(z, 0.0)
                            } else {
                                let radial = unit(radial);
                                let phi = dot(radial, c64.v).atan2(dot(radial, c64.u)) + 1e-3 * (unif64(&mut r) - 0.5);
                                c64.point(z, phi)
                            }
                        } else {
                            c64.point(c64.h * unif64(&mut r), std::f64::consts::TAU * unif64(&mut r))
                        };
                        (p, c64.normal(p), c64.h + c64.r0)
                    }
                    Primitive::Plane(_) => unreachable!("no planes here"),
                };
                let o = at(target, hemisphere(&mut r, n), size * (1.0 + 9.0 * unif64(&mut r)));
                let (o32, t32) = (f3(o), f3(target));
                let ray = Ray::with_time(o32, (t32 - o32).normalize(), time);
                let Some(h) = prim.intersect(&ray, Interval::POSITIVE) else { continue };
                hits += 1;
                if !bounds.contains(h.point) {
                    reported_out += 1;
                    worst = worst.max(excess_ulps(&bounds, d3(h.point)));
                }
                if let Some(p) = exact_hit_point(&prim, &ray, h.t) {
                    checked_exact += 1;
                    let magnitude = d3(ray.origin).iter().chain(&p).fold(0.0f64, |m, x| m.max(x.abs()));
                    if !inside_box64(&bounds, p, magnitude * 2f64.powi(-45)) {
                        exact_out += 1;
                        worst = worst.max(excess_ulps(&bounds, p));
                    }
                }
            }
        }
        failed |= reported_out + exact_out > 0;
        report.push(format!(
            "  {name:<15} {hits} hits: {reported_out} reported points and {exact_out} of {checked_exact} exact points outside the bounds \
             (worst {worst:.2} ulps)"
        ));
    }
    println!("hit points inside bounds() (bounds_over([0, 1]) for moving spheres):\n{}", report.join("\n"));
    assert!(!failed, "hit points outside their primitive's bounds");
}

/// Rays skimming spheres (general and rounding ones), tilted cones and cylinders, and boxes within a
/// few ulps of their silhouettes and of their bounds' faces: whenever the primitives' own routines
/// find a hit, every accelerator finds the same one (primitive and t bits), and the any-hit query
/// agrees.
#[test]
fn accelerators_find_every_hit_of_skimming_rays() {
    let mut r = rng(6002);
    let mut report = Vec::new();
    let mut failed = false;
    for (scene, far) in [("near the origin", false), ("up to 1e7 from the origin", true)] {
        let mut prims: Vec<Primitive> = Vec::new();
        for i in 0..200 {
            let spot = |r: &mut Pcg32| {
                if far {
                    unit_vector(r) * 10f32.powf(7.0 * unif(r))
                } else {
                    Vec3A::new(unif(r), unif(r), unif(r)) * 200.0 - Vec3A::splat(100.0)
                }
            };
            let size = |r: &mut Pcg32, c: Vec3A| {
                if far { (c.length() * 10f32.powf(-5.0 + 3.0 * unif(r))).max(1e-2) } else { 0.5 + 4.0 * unif(r) }
            };
            prims.push(match i % 5 {
                0 => {
                    let c = spot(&mut r);
                    Primitive::Sphere(Sphere { center: c, radius: size(&mut r, c) })
                }
                1 => {
                    if far {
                        let (center, radius) = rounding_sphere(&mut r);
                        Primitive::Sphere(Sphere { center, radius })
                    } else {
                        let c = spot(&mut r);
                        Primitive::Sphere(Sphere { center: c, radius: 0.3 + 0.1 * (r.next_u32() % 30) as f32 + 0.013 })
                    }
                }
                2 | 3 => {
                    let base = spot(&mut r);
                    let s = size(&mut r, base);
                    let axis = unit_vector(&mut r) * (s * (0.5 + 2.0 * unif(&mut r)));
                    let r0 = s * (0.2 + unif(&mut r));
                    let r1 = if i % 5 == 3 { r0 } else { r0 * unif(&mut r) };
                    Primitive::Cone(Cone { base, base_radius: r0, apex: base + axis, apex_radius: r1 })
                }
                _ => {
                    let c = spot(&mut r);
                    let s = size(&mut r, c);
                    let half = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * s + Vec3A::splat(0.05 * s);
                    Primitive::Box(AaBox { bounds: Aabb::new(c - half, c + half) })
                }
            });
        }
        let accels = AnyAccel::all(&prims, Interval::new(0.0, 0.0));
        let (mut rays, mut own_hits, mut hits) = (0usize, 0usize, 0usize);
        let (mut missed, mut not_occluded) = ([0usize; 4], [0usize; 4]);
        for prim in &prims {
            for q in 0..60 {
                // A point just off the silhouette (or the bounds' face), and a direction along it.
                let k_ulps = (r.next_u32() % 9) as f64 - 4.0 + 0.5 * unif64(&mut r);
                let (p, dir, size) = match prim {
                    Primitive::Sphere(s) => {
                        let (c, rad) = (d3(s.center), s.radius as f64);
                        let u = ulp(s.center.abs().max_element().max(s.radius)) as f64;
                        if q % 2 == 0 {
                            let w = unit64_random(&mut r);
                            let (a, b) = basis64(w);
                            let phi = std::f64::consts::TAU * unif64(&mut r);
                            let side = add(mul(a, phi.cos()), mul(b, phi.sin()));
                            (at(c, side, rad + k_ulps * u), w, rad)
                        } else {
                            let a = (r.next_u32() % 3) as usize;
                            let sign = if r.next_u32() % 2 == 0 { 1.0 } else { -1.0 };
                            let mut p = c;
                            p[a] += sign * (rad + k_ulps * u);
                            let mut w = unit64_random(&mut r);
                            w[a] = if q % 4 == 1 { 0.0 } else { 1e-7 * (unif64(&mut r) - 0.5) };
                            (p, unit(w), rad)
                        }
                    }
                    Primitive::Cone(c) => {
                        let c64 = Cone64::new(c);
                        let u = ulp(c.base.abs().max_element().max(c.apex.abs().max_element())) as f64;
                        if q % 2 == 0 {
                            let p = c64.point(c64.h * unif64(&mut r), std::f64::consts::TAU * unif64(&mut r));
                            let n = c64.normal(p);
                            let t = unit64_random(&mut r);
                            let t = unit(sub(t, mul(n, dot(t, n))));
                            (at(p, n, k_ulps * u), t, c64.h + c64.r0)
                        } else {
                            // At a rim's extreme along an axis, along the bounds' face there.
                            let a = (r.next_u32() % 3) as usize;
                            let sign = if r.next_u32() % 2 == 0 { 1.0 } else { -1.0 };
                            let z = if r.next_u32() % 2 == 0 { 0.0 } else { c64.h };
                            let mut e = [0.0; 3];
                            e[a] = sign;
                            let radial = sub(e, mul(c64.w, dot(e, c64.w)));
                            let rim = add(c64.base, mul(c64.w, z));
                            let mut p = if len(radial) > 1e-9 { at(rim, unit(radial), c64.radius_at(z)) } else { rim };
                            p[a] += sign * k_ulps * u;
                            let mut w = unit64_random(&mut r);
                            w[a] = if q % 4 == 1 { 0.0 } else { 1e-7 * (unif64(&mut r) - 0.5) };
                            (p, unit(w), c64.h + c64.r0)
                        }
                    }
                    Primitive::Box(b) => {
                        let (min, max) = (d3(b.bounds.min), d3(b.bounds.max));
                        let u = ulp(b.bounds.min.abs().max(b.bounds.max.abs()).max_element()) as f64;
                        let a = (r.next_u32() % 3) as usize;
                        let mut p = [0, 1, 2].map(|k| {
                            let v = unif64(&mut r);
                            let v = if v < 0.5 { v * 1e-3 } else { 1.0 - (1.0 - v) * 1e-3 };
                            min[k] + (max[k] - min[k]) * v
                        });
                        p[a] = if r.next_u32() % 2 == 0 { max[a] + k_ulps * u } else { min[a] - k_ulps * u };
                        let mut w = unit64_random(&mut r);
                        w[a] = if q % 4 == 1 { 0.0 } else { 1e-7 * (unif64(&mut r) - 0.5) };
                        (p, unit(w), len(sub(max, min)))
                    }
                    _ => unreachable!("spheres, cones and boxes only"),
                };
                let o = f3(at(p, dir, -3.0 * size));
                let ray = Ray::new(o, f3(dir));
                if !ray.dir.is_finite() || ray.dir == Vec3A::ZERO {
                    continue;
                }
                rays += 1;
                let own = prim.intersect(&ray, Interval::POSITIVE);
                own_hits += own.is_some() as usize;
                let (want, _) = reference_closest(&prims, &ray);
                let Some(want) = want else { continue };
                hits += 1;
                for (a, accel) in accels.iter().enumerate() {
                    let got = accel.closest(&ray);
                    if got.map(|h| (h.primitive, h.hit.t.to_bits())) != Some((want.primitive, want.hit.t.to_bits())) {
                        missed[a] += 1;
                    }
                    if !accel.occluded(&ray, f32::INFINITY) {
                        not_occluded[a] += 1;
                    }
                }
            }
        }
        failed |= missed.iter().chain(&not_occluded).any(|&n| n > 0);
        report.push(format!(
            "  {scene}: {} primitives, {rays} skimming rays, {own_hits} hit the primitive they skim, {hits} hit something; \
             missed or different (closest / any-hit): {}",
            prims.len(),
            (0..4).map(|a| format!("{} {}/{}", ACCEL_NAMES[a], missed[a], not_occluded[a])).collect::<Vec<_>>().join(", ")
        ));
    }
    println!("skimming rays, accelerators against the primitives' own routines:\n{}", report.join("\n"));
    assert!(!failed, "an accelerator missed a hit its primitive reports");
}
