use raylume_geometry::{Aabb, Interval, Ray, Vec3A};
use raylume_intersect::Intersect;

use crate::bvh::{BoxRay, FewShapes};
use crate::{AccelStats, Accelerator, PrimitiveHit, Tally};

/// Tests every primitive: the reference for correctness, and the fastest choice for a handful of them.
///
/// [`BruteForce::new`] runs each primitive's own routine on every ray. [`BruteForce::with_boxes`]
/// first tests the primitives' boxes, four at a time, and runs the routine of those whose box the ray
/// meets: no hierarchy, every primitive still considered by every ray, and the same answers (a
/// primitive's hits lie inside its box), for a fraction of the work on scenes of more than a few shapes.
///
/// ```
/// use raylume_accel::{Accelerator, BruteForce};
/// use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
/// use raylume_intersect::Primitive;
/// let prims: Vec<Primitive> = (0..40)
///     .map(|i| Primitive::Sphere(Sphere { center: Vec3A::new(i as f32 * 3.0, 0.0, 10.0), radius: 1.0 }))
///     .collect();
/// let ray = Ray::new(Vec3A::new(9.0, 0.0, 0.0), Vec3A::Z);
/// let exhaustive = BruteForce::new(prims.clone());
/// let boxed = BruteForce::with_boxes(prims, Interval::new(0.0, 0.0));
/// assert_eq!(boxed.closest_hit(&ray, Interval::POSITIVE), exhaustive.closest_hit(&ray, Interval::POSITIVE));
/// assert_eq!(boxed.closest_hit(&ray, Interval::POSITIVE).unwrap().primitive, 3);
/// ```
#[derive(Clone, Debug)]
pub struct BruteForce<P> {
    prims: Vec<P>,
    /// With [`BruteForce::with_boxes`]: the boxes of each four primitives in turn, slot `i` of node
    /// `k` holding primitive `4 k + i`'s.
    boxes: Option<Vec<FewShapes>>,
}

impl<P: Intersect> BruteForce<P> {
    /// A list over `prims`, each tested by its own routine on every ray.
    pub fn new(prims: Vec<P>) -> Self {
        Self { prims, boxes: None }
    }

    /// A list over `prims` that tests each primitive's box first, four at a time (moving primitives
    /// bounded over `shutter`, which holds every ray's time). A primitive without a finite box (a
    /// plane) is always tested.
    pub fn with_boxes(prims: Vec<P>, shutter: Interval) -> Self {
        let everywhere = Aabb::new(Vec3A::NEG_INFINITY, Vec3A::INFINITY);
        let box_of = |p: &P| {
            let b = p.bounds_over(shutter);
            if b.is_finite() && !b.is_empty() { b } else { everywhere }
        };
        let boxes = prims.chunks(FewShapes::MAX).map(|chunk| FewShapes::new(chunk.iter().map(box_of))).collect();
        Self { prims, boxes: Some(boxes) }
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
            let mut test = |i: usize, t_range: &mut Interval| {
                tally.tested();
                if let Some(hit) = self.prims[i].intersect_canonical(ray, *t_range) {
                    *t_range = t_range.with_max(hit.t);
                    PrimitiveHit::keep_closer(&mut best, PrimitiveHit { hit, primitive: i as u32 });
                }
            };
            match &self.boxes {
                None => (0..self.prims.len()).for_each(|i| test(i, &mut t_range)),
                Some(boxes) => {
                    let box_ray = BoxRay::new(ray);
                    for (k, node) in boxes.iter().enumerate() {
                        node.closest_prepared(&box_ray, &mut t_range, |slot, t_range| {
                            test(FewShapes::MAX * k + slot, t_range)
                        });
                    }
                }
            }
            best
        })
    }

    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        crate::occluded_on_canonical(ray, t_max, |ray, t_max| {
            let mut test = |i: usize| {
                tally.tested();
                self.prims[i].occluded_canonical(ray, t_max)
            };
            match &self.boxes {
                None => (0..self.prims.len()).any(test),
                Some(boxes) => {
                    let box_ray = BoxRay::new(ray);
                    boxes
                        .iter()
                        .enumerate()
                        .any(|(k, node)| node.any_prepared(&box_ray, t_max, |slot| test(FewShapes::MAX * k + slot)))
                }
            }
        })
    }

    fn bounds(&self) -> Aabb {
        self.prims.iter().map(Intersect::bounds).filter(Aabb::is_finite).fold(Aabb::EMPTY, Aabb::union)
    }

    fn stats(&self) -> AccelStats {
        let boxes = self.boxes.as_ref().map_or(0, |b| std::mem::size_of_val(b.as_slice()));
        AccelStats {
            nodes: self.boxes.as_ref().map_or(0, Vec::len),
            bytes: std::mem::size_of_val(self.prims.as_slice()) + boxes,
            primitives: self.prims.len(),
        }
    }
}
