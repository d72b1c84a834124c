//! Ray-primitive intersection for raylume: the [`Intersect`] trait, the [`Hit`] record, one routine per
//! shape of `raylume-geometry`, and the closed [`Primitive`] enum that dispatches among them statically.
//!
//! ```
//! use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
//! use raylume_intersect::Intersect;
//! let sphere = Sphere { center: Vec3A::new(0.0, 0.0, 5.0), radius: 1.0 };
//! let hit = sphere.intersect(&Ray::new(Vec3A::ZERO, Vec3A::Z), Interval::POSITIVE).unwrap();
//! assert!((hit.t - 4.0).abs() < 1e-6);
//! assert!(sphere.occluded(&Ray::new(Vec3A::ZERO, Vec3A::Z), 10.0));
//! ```

mod lanes;
mod primitive;
mod shapes;
mod watertight;

use glam::Vec4;
pub use lanes::{LaneRoots, RayLanes, SphereLanes, sphere_roots, spheres_roots};
pub use primitive::Primitive;
use raylume_geometry::{Aabb, Interval, Plane, Ray, Sphere, Triangle, Vec2, Vec3A};
pub use shapes::{intersect_moller_trumbore, leaves_sphere_within};
pub use watertight::{
    ShearedRay, TINY_DISTANCE, TINY_TERM, TriangleHit, decided_distance, edge_error, has_unit_normal,
    intersect_watertight, normal64_magnitude, unit_normal, watertight_decide, watertight_hits,
};

/// Where a ray meets a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The ray parameter of the hit.
    pub t: f32,
    /// The hit point.
    pub point: Vec3A,
    /// The unit geometric normal, pointing to the shape's outside (for triangles and planes: the side
    /// their winding makes positive). It is not flipped towards the ray; see [`Hit::front_face`].
    pub normal: Vec3A,
    /// Surface coordinates: barycentrics `(b1, b2)` for triangles, unused (zero) elsewhere.
    pub uv: Vec2,
    /// A bound on the absolute floating-point error of each coordinate of `point`: the exact surface
    /// passes through the box `point ± error`. Secondary rays start just outside it
    /// (`raylume_geometry::offset_ray_origin`).
    pub error: Vec3A,
}

impl Hit {
    /// Whether the ray arrived on the side the normal points to.
    #[inline]
    pub fn front_face(&self, ray: &Ray) -> bool {
        ray.dir.dot(self.normal) < 0.0
    }
}

/// A shape a ray can hit.
///
/// Implementors give the closest hit in a parameter interval and its bounds; the default methods
/// derive a shadow-ray query and the bounds over a shutter interval.
pub trait Intersect {
    /// The closest hit with `t` in `t_range`, if any.
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit>;

    /// Whether anything is hit with `t` in `(0, t_max)`: the query of shadow rays, which may stop
    /// at any hit rather than the closest one.
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.intersect(ray, Interval::new(0.0, t_max)).is_some()
    }

    /// [`Intersect::intersect`] for a canonical ray ([`Ray::canonical`]), as accelerators pass them:
    /// the same answer, without looking at the direction's scale.
    #[inline]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        self.intersect(ray, t_range)
    }

    /// [`Intersect::occluded`] for a canonical ray.
    #[inline]
    fn occluded_canonical(&self, ray: &Ray, t_max: f32) -> bool {
        self.occluded(ray, t_max)
    }

    /// The roots four canonical rays find on the shape, lane by lane, within their ranges
    /// `[min, max]`: each lane's as [`Intersect::intersect_canonical`] (or, from `min` zero,
    /// [`Intersect::occluded_canonical`]) finds it for that ray alone. By default every lane is left
    /// undecided, to the one-ray routines.
    #[inline]
    fn lane_roots(&self, rays: &RayLanes, min: Vec4, max: Vec4) -> LaneRoots {
        let _ = (rays, min, max);
        LaneRoots { t: Vec4::ZERO, hit: 0, undecided: 0b1111 }
    }

    /// The hit [`Intersect::intersect_canonical`] reports for `ray` within `t_range`, where
    /// [`Intersect::lane_roots`] found its root `t` in that range (shapes that find roots make the hit
    /// from it rather than search again).
    #[inline]
    fn hit_at_root(&self, ray: &Ray, t: f32, t_range: Interval) -> Option<Hit> {
        let _ = t;
        self.intersect_canonical(ray, t_range)
    }

    /// The bounds of the shape (infinite for unbounded shapes such as planes).
    fn bounds(&self) -> Aabb;

    /// The bounds of everything the shape covers during `shutter`; moving shapes override it.
    #[inline]
    fn bounds_over(&self, _shutter: Interval) -> Aabb {
        self.bounds()
    }

    /// The shape as a triangle, if it is one: accelerators store triangles in their own layout and
    /// test them with [`watertight_decide`], which gives the same answers as [`Intersect::intersect`].
    #[inline]
    fn as_triangle(&self) -> Option<Triangle> {
        None
    }

    /// The shape as a sphere, if it is one: accelerators test up to four spheres at once for one ray
    /// ([`spheres_roots`]), which gives the same answers as [`Intersect::intersect_canonical`].
    #[inline]
    fn as_sphere(&self) -> Option<Sphere> {
        None
    }

    /// The shape as an infinite plane, if it is one.
    #[inline]
    fn as_plane(&self) -> Option<Plane> {
        None
    }
}
