use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Ray, Sphere, Triangle};

use glam::Vec4;

use crate::{Hit, Intersect, LaneRoots, RayLanes};

/// Every shape raylume renders, as one closed enum so the per-ray path dispatches with a `match`
/// (static dispatch, no boxing) rather than through a vtable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// A sphere.
    Sphere(Sphere),
    /// A moving sphere (motion blur).
    MovingSphere(MovingSphere),
    /// A triangle (polygons and meshes are made of them).
    Triangle(Triangle),
    /// An infinite plane (unbounded: accelerators keep it outside their structure).
    Plane(Plane),
    /// An axis-aligned box.
    Box(AaBox),
    /// A cone or cylinder without caps.
    Cone(Cone),
}

macro_rules! dispatch {
    ($self:expr, $s:ident => $e:expr) => {
        match $self {
            Primitive::Sphere($s) => $e,
            Primitive::MovingSphere($s) => $e,
            Primitive::Triangle($s) => $e,
            Primitive::Plane($s) => $e,
            Primitive::Box($s) => $e,
            Primitive::Cone($s) => $e,
        }
    };
}

impl Intersect for Primitive {
    #[inline]
    fn intersect(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        dispatch!(self, s => s.intersect(ray, t_range))
    }

    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        dispatch!(self, s => s.occluded(ray, t_max))
    }

    #[inline]
    fn intersect_canonical(&self, ray: &Ray, t_range: Interval) -> Option<Hit> {
        dispatch!(self, s => s.intersect_canonical(ray, t_range))
    }

    #[inline]
    fn occluded_canonical(&self, ray: &Ray, t_max: f32) -> bool {
        dispatch!(self, s => s.occluded_canonical(ray, t_max))
    }

    #[inline(always)]
    fn lane_roots(&self, rays: &RayLanes, min: Vec4, max: Vec4) -> LaneRoots {
        dispatch!(self, s => s.lane_roots(rays, min, max))
    }

    #[inline(always)]
    fn hit_at_root(&self, ray: &Ray, t: f32, t_range: Interval) -> Option<Hit> {
        dispatch!(self, s => s.hit_at_root(ray, t, t_range))
    }

    fn bounds(&self) -> Aabb {
        dispatch!(self, s => Intersect::bounds(s))
    }

    fn bounds_over(&self, shutter: Interval) -> Aabb {
        dispatch!(self, s => s.bounds_over(shutter))
    }

    #[inline]
    fn as_triangle(&self) -> Option<Triangle> {
        match self {
            Primitive::Triangle(t) => Some(*t),
            _ => None,
        }
    }

    #[inline]
    fn as_sphere(&self) -> Option<Sphere> {
        match self {
            Primitive::Sphere(s) => Some(*s),
            _ => None,
        }
    }

    #[inline]
    fn as_plane(&self) -> Option<Plane> {
        match self {
            Primitive::Plane(p) => Some(*p),
            _ => None,
        }
    }
}

impl Primitive {
    /// Whether the primitive has finite bounds (planes do not).
    pub fn is_bounded(&self) -> bool {
        !matches!(self, Primitive::Plane(_))
    }
}
