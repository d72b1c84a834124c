use raylume_geometry::{Aabb, Interval, Ray};
use raylume_intersect::Intersect;

use crate::{Accelerator, PrimitiveHit};

/// Tests every primitive: the reference for correctness, and the fastest choice for a handful of them.
#[derive(Clone, Debug)]
pub struct BruteForce<P> {
    prims: Vec<P>,
}

impl<P: Intersect> BruteForce<P> {
    /// A list over `prims`.
    pub fn new(prims: Vec<P>) -> Self {
        Self { prims }
    }

    /// The primitives, in build order.
    pub fn primitives(&self) -> &[P] {
        &self.prims
    }
}

impl<P: Intersect + Sync + Send> Accelerator for BruteForce<P> {
    fn closest_hit(&self, ray: &Ray, mut t_range: Interval) -> Option<PrimitiveHit> {
        let mut best = None;
        for (i, p) in self.prims.iter().enumerate() {
            if let Some(hit) = p.intersect(ray, t_range) {
                t_range = t_range.with_max(hit.t);
                best = Some(PrimitiveHit { hit, primitive: i as u32 });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.prims.iter().any(|p| p.occluded(ray, t_max))
    }

    fn bounds(&self) -> Aabb {
        self.prims.iter().map(Intersect::bounds).filter(Aabb::is_finite).fold(Aabb::EMPTY, Aabb::union)
    }
}
