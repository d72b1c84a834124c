//! Acceleration structures for raylume behind one [`Accelerator`] trait: [`BruteForce`] (the reference)
//! and [`Bvh`] (a binned-SAH bounding volume hierarchy).
//!
//! ```
//! use raylume_accel::{Accelerator, BruteForce};
//! use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
//! use raylume_intersect::Primitive;
//! let prims = vec![
//!     Primitive::Sphere(Sphere { center: Vec3A::new(0.0, 0.0, 5.0), radius: 1.0 }),
//!     Primitive::Sphere(Sphere { center: Vec3A::new(0.0, 0.0, 9.0), radius: 1.0 }),
//! ];
//! let list = BruteForce::new(prims);
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::Z);
//! let closest = list.closest_hit(&ray, Interval::POSITIVE).unwrap();
//! assert_eq!(closest.primitive, 0);
//! assert!(list.occluded(&ray, 100.0));
//! ```

mod brute;
mod bvh;

pub use brute::BruteForce;
pub use bvh::Bvh;
use raylume_geometry::{Aabb, Interval, Ray};
use raylume_intersect::Hit;

/// The closest hit found by an accelerator, with the index of the primitive hit (its position in the
/// slice the accelerator was built from).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimitiveHit {
    /// The hit.
    pub hit: Hit,
    /// Index of the primitive hit.
    pub primitive: u32,
}

/// A structure that answers ray queries over a set of primitives.
///
/// Built once from the primitives, then shared read-only by every rendering thread.
pub trait Accelerator: Sync + Send {
    /// The closest hit with `t` in `t_range`.
    fn closest_hit(&self, ray: &Ray, t_range: Interval) -> Option<PrimitiveHit>;

    /// Whether any primitive is hit with `t` in `(0, t_max)` (shadow rays: stops at the first hit).
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool;

    /// The bounds of every bounded primitive.
    fn bounds(&self) -> Aabb;
}

/// Which accelerator to build, chosen at run time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum AccelKind {
    /// A plain list: every primitive is tested by every ray.
    None,
    /// A bounding volume hierarchy (binned SAH).
    #[default]
    Bvh,
    /// A uniform grid (not yet built: falls back to the BVH).
    Grid,
}
