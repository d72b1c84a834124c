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
pub use shapes::{AaBox, Cone, MovingSphere, Plane, Sphere, Triangle};

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

/// Moves a point off a surface along its normal by a few hundred units in the last place of its
/// coordinates, so a ray leaving from there cannot hit the surface it left (Wächter and Binder,
/// *Ray Tracing Gems* ch. 6). The offset scales with the coordinates' magnitude, so it works at every
/// scene scale; near the origin, where ULPs vanish, a small fixed offset takes over.
///
/// `p` should be the hit point computed as accurately as the primitive allows (from barycentrics, or
/// reprojected onto a sphere); `n` is the geometric normal on the side the ray leaves towards.
///
/// ```
/// use raylume_geometry::{offset_ray_origin, Vec3A};
/// let p = Vec3A::new(1e5, 0.0, 0.0);
/// let o = offset_ray_origin(p, Vec3A::X);
/// assert!(o.x > p.x && o.y == 0.0 && o.z == 0.0);
/// ```
#[inline]
pub fn offset_ray_origin(p: Vec3A, n: Vec3A) -> Vec3A {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let mut out = [0.0f32; 3];
    for a in 0..3 {
        let offset = (INT_SCALE * n[a]) as i32;
        let bits = p[a].to_bits() as i32;
        let moved =
            f32::from_bits((if p[a] < 0.0 { bits.wrapping_sub(offset) } else { bits.wrapping_add(offset) }) as u32);
        out[a] = if p[a].abs() < ORIGIN { p[a] + FLOAT_SCALE * n[a] } else { moved };
    }
    Vec3A::from_array(out)
}
