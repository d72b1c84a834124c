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
