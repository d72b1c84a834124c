//! Geometry for raylume: [`Ray`], [`Aabb`], [`Interval`], the data of every shape raylume can
//! intersect, and sampling helpers.
//!
//! Everything here is small, `Copy` and built on [`glam`]. Intersection routines live in
//! `raylume-intersect`; this crate only says what a shape *is*.
//!
//! ```
//! use raylume_geometry::{Ray, Vec3A};
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
//! assert_eq!(ray.at(2.0), Vec3A::new(2.0, 0.0, 0.0));
//! ```

mod aabb;
mod ray;
pub mod sampling;
mod shapes;

pub use aabb::Aabb;
pub use glam::{Vec2, Vec3, Vec3A};
pub use ray::{Interval, Ray};
pub use shapes::{AaBox, Cone, MovingSphere, Plane, Sphere, Triangle, is_plane_normal};

/// Builds an orthonormal basis `(s, t)` such that `(s, t, n)` is right-handed, for a unit vector `n`.
///
/// Uses the branchless construction of Duff et al. (JCGT 2017), stable for every `n`.
///
/// ```
/// use raylume_geometry::{orthonormal_basis, Vec3A};
/// let n = Vec3A::new(0.0, 0.6, 0.8);
/// let (s, t) = orthonormal_basis(n);
/// assert!(s.dot(n).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && s.dot(t).abs() < 1e-6);
/// ```
#[inline]
pub fn orthonormal_basis(n: Vec3A) -> (Vec3A, Vec3A) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3A::new(b, sign + n.y * n.y * a, -n.y))
}

/// pbrt's `gamma(n)`: a bound on the relative error of `n` successive f32 operations,
/// `n u / (1 - n u)` with `u = 2^-24`.
///
/// ```
/// assert!(raylume_geometry::gamma(3) > 3.0 * f32::EPSILON / 2.0);
/// ```
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The origin of a ray leaving a surface at `p`: `p` moved along the normal `n` (pointing to the side
/// the ray leaves towards) just past the box `p ± error` that bounds the point's floating-point error,
/// then rounded away from `p` (pbrt-v4's `OffsetRayOrigin`). Combined with intersection routines that
/// reject hits within their own error bound, a ray leaving a surface never hits it again, at any
/// scene scale, and the offset stays as small as the error allows.
///
/// ```
/// use raylume_geometry::{offset_ray_origin, Vec3A};
/// let p = Vec3A::new(1e5, 0.0, 0.0);
/// let o = offset_ray_origin(p, Vec3A::splat(0.01), Vec3A::X);
/// assert!(o.x > p.x + 0.01 && o.y == 0.0 && o.z == 0.0);
/// ```
#[inline]
pub fn offset_ray_origin(p: Vec3A, error: Vec3A, n: Vec3A) -> Vec3A {
    let d = n.abs().dot(error);
    let offset = n * d;
    let mut o = p + offset;
    for a in 0..3 {
        if offset[a] > 0.0 {
            o[a] = o[a].next_up();
        } else if offset[a] < 0.0 {
            o[a] = o[a].next_down();
        }
    }
    o
}

/// The ray from a point on one surface to a point on another, both moved off their surfaces past
/// their error bounds (`n_from`, `n_to`: normals on the sides the ray leaves and arrives from), with
/// the parameter range that stops just short of the far end: pbrt-v4's `SpawnRayTo`. The direction is
/// not normalised: `t` runs from 0 to `1 - SHADOW_EPSILON`.
///
/// ```
/// use raylume_geometry::{spawn_ray_to, Vec3A};
/// let (ray, t_max) = spawn_ray_to(Vec3A::ZERO, Vec3A::splat(1e-7), Vec3A::Z, Vec3A::new(0.0, 0.0, 2.0), Vec3A::splat(1e-7), -Vec3A::Z);
/// assert!(ray.origin.z > 0.0 && ray.at(t_max).z < 2.0);
/// ```
#[inline]
pub fn spawn_ray_to(
    from: Vec3A,
    from_error: Vec3A,
    n_from: Vec3A,
    to: Vec3A,
    to_error: Vec3A,
    n_to: Vec3A,
) -> (Ray, f32) {
    const SHADOW_EPSILON: f32 = 1e-4;
    let o = offset_ray_origin(from, from_error, n_from);
    let t = offset_ray_origin(to, to_error, n_to);
    (Ray::new(o, t - o), 1.0 - SHADOW_EPSILON)
}
