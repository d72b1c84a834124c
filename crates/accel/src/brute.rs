use raylume_geometry::{Aabb, Interval, Ray};
use raylume_intersect::Intersect;

use crate::{AccelStats, Accelerator, PrimitiveHit, Tally};

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
    fn closest_hit_tally<T: Tally>(&self, ray: &Ray, t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        crate::closest_on_canonical(ray, t_range, |ray, mut t_range| {
            let mut best = None;
            for (i, p) in self.prims.iter().enumerate() {
                tally.tested();
                if let Some(hit) = p.intersect_canonical(ray, t_range) {
                    t_range = t_range.with_max(hit.t);
                    PrimitiveHit::keep_closer(&mut best, PrimitiveHit { hit, primitive: i as u32 });
                }
            }
            best
        })
    }

    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        crate::occluded_on_canonical(ray, t_max, |ray, t_max| {
            self.prims.iter().any(|p| {
                tally.tested();
                p.occluded_canonical(ray, t_max)
            })
        })
    }

    fn bounds(&self) -> Aabb {
        self.prims.iter().map(Intersect::bounds).filter(Aabb::is_finite).fold(Aabb::EMPTY, Aabb::union)
    }

    fn stats(&self) -> AccelStats {
        AccelStats { nodes: 0, bytes: std::mem::size_of_val(self.prims.as_slice()), primitives: self.prims.len() }
    }
}
