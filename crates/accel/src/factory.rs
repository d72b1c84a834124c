//! The one place where an accelerator chosen at run time ([`AccelKind`]) is built: the code that
//! uses it is handed the concrete type, so every query it makes stays statically dispatched.

use raylume_geometry::Interval;
use raylume_intersect::Intersect;

use crate::{AccelKind, Accelerator, BruteForce, Bvh, BvhBuild, BvhKernel, Grid, GridParams};

/// What to do with an accelerator whose type is chosen at run time: [`with_accelerator`] builds it
/// and calls [`visit`](AccelVisitor::visit) with the concrete type, so the code inside (a render
/// loop, a benchmark) is compiled once per accelerator, with no dynamic dispatch per ray (as
/// pbrt-v4's aggregate factory hands its render assembly a concrete aggregate).
///
/// ```
/// use raylume_accel::{AccelKind, AccelVisitor, Accelerator, GridParams, with_accelerator};
/// use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
/// use raylume_intersect::Primitive;
///
/// struct FirstHit(Ray);
/// impl AccelVisitor for FirstHit {
///     type Output = Option<u32>;
///     fn visit<A: Accelerator>(self, accel: A) -> Option<u32> {
///         accel.closest_hit(&self.0, Interval::POSITIVE).map(|h| h.primitive)
///     }
/// }
/// let prims = vec![Primitive::Sphere(Sphere { center: Vec3A::new(0.0, 0.0, 5.0), radius: 1.0 })];
/// let ray = Ray::new(Vec3A::ZERO, Vec3A::Z);
/// for kind in [AccelKind::None, AccelKind::Bvh, AccelKind::BvhMidpoint, AccelKind::Grid] {
///     let still = Interval::new(0.0, 0.0);
///     assert_eq!(with_accelerator(kind, prims.clone(), still, GridParams::default(), FirstHit(ray)), Some(0));
/// }
/// ```
pub trait AccelVisitor {
    /// What the visit returns.
    type Output;

    /// Uses the built accelerator.
    fn visit<A: Accelerator>(self, accel: A) -> Self::Output;
}

/// Builds the accelerator `kind` over `primitives` (moving ones bounded over `shutter`; `grid`
/// sizes the uniform grid) and hands it to `visitor`.
pub fn with_accelerator<P, V>(
    kind: AccelKind,
    primitives: Vec<P>,
    shutter: Interval,
    grid: GridParams,
    visitor: V,
) -> V::Output
where
    P: Intersect + Clone + Sync + Send,
    V: AccelVisitor,
{
    match kind {
        AccelKind::None => visitor.visit(BruteForce::with_boxes(primitives, shutter)),
        AccelKind::Bvh => visitor.visit(Bvh::with_kernel(primitives, shutter, BvhBuild::Sah, BvhKernel::best())),
        AccelKind::BvhPortable => {
            visitor.visit(Bvh::with_kernel(primitives, shutter, BvhBuild::Sah, BvhKernel::Portable))
        }
        AccelKind::BvhMidpoint => visitor.visit(Bvh::with_build(primitives, shutter, BvhBuild::Midpoint)),
        AccelKind::Grid => visitor.visit(Grid::new(primitives, shutter, grid)),
    }
}

impl AccelKind {
    /// The BVH kernel this kind asks for (`None` for the structures that are not a BVH of
    /// triangles); the BVH falls back to the portable kernel on CPUs without AVX2.
    ///
    /// ```
    /// use raylume_accel::{AccelKind, BvhKernel};
    /// assert_eq!(AccelKind::BvhPortable.kernel(), Some(BvhKernel::Portable));
    /// assert_eq!(AccelKind::Grid.kernel(), None);
    /// ```
    pub fn kernel(self) -> Option<BvhKernel> {
        match self {
            AccelKind::Bvh | AccelKind::BvhMidpoint => Some(BvhKernel::best()),
            AccelKind::BvhPortable => Some(BvhKernel::Portable),
            AccelKind::None | AccelKind::Grid => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use raylume_geometry::{Interval, Sphere, Vec3A};
    use raylume_intersect::Primitive;

    use super::*;

    /// The name of the accelerator type it is handed.
    struct TypeName;
    impl AccelVisitor for TypeName {
        type Output = &'static str;
        fn visit<A: Accelerator>(self, _: A) -> &'static str {
            std::any::type_name::<A>()
        }
    }

    #[test]
    fn each_kind_builds_its_structure() {
        let prims = vec![Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 })];
        let built =
            |kind| with_accelerator(kind, prims.clone(), Interval::new(0.0, 0.0), GridParams::default(), TypeName);
        assert!(built(AccelKind::None).contains("BruteForce"));
        assert!(built(AccelKind::Bvh).contains("Bvh"));
        assert!(built(AccelKind::BvhPortable).contains("Bvh"));
        assert!(built(AccelKind::BvhMidpoint).contains("Bvh"));
        assert!(built(AccelKind::Grid).contains("Grid"));
    }
}
