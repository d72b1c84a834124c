//! Acceleration structures for raylume behind one [`Accelerator`] trait: [`BruteForce`] (the reference),
//! [`Bvh`] (a bounding volume hierarchy of four-child nodes, binned-SAH or the course's midpoint build) and
//! [`Grid`] (a uniform grid with 3D-DDA traversal and per-ray mailboxing).
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
mod factory;
mod grid;
mod interiors;

pub use brute::BruteForce;
pub use bvh::{Bvh, BvhBuild, BvhKernel};
pub use factory::{AccelVisitor, with_accelerator};
pub use grid::{Grid, GridParams};
pub use interiors::Interiors;
use raylume_geometry::{Aabb, Interval, Ray};
use raylume_intersect::Hit;

/// The closest hit found by an accelerator, with the index of the primitive hit (its position in the
/// slice the accelerator was built from). Where several primitives are hit at the same distance, the
/// one with the lowest index is reported, by every accelerator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimitiveHit {
    /// The hit.
    pub hit: Hit,
    /// Index of the primitive hit.
    pub primitive: u32,
}

impl PrimitiveHit {
    /// Whether this hit is to be reported rather than `other`: closer, or as close with a lower index.
    #[inline]
    pub fn beats(&self, other: &PrimitiveHit) -> bool {
        self.hit.t < other.hit.t || (self.hit.t == other.hit.t && self.primitive < other.primitive)
    }

    /// `candidate` if it [beats](PrimitiveHit::beats) `best` (or there is none), else `best`.
    #[inline]
    pub fn closer(mut best: Option<PrimitiveHit>, candidate: PrimitiveHit) -> Option<PrimitiveHit> {
        Self::keep_closer(&mut best, candidate);
        best
    }

    /// [`PrimitiveHit::closer`] in place: `best` becomes `candidate` if it beats it, and is left as it
    /// is otherwise (no copy of the hit it holds).
    ///
    /// ```
    /// use raylume_accel::PrimitiveHit;
    /// use raylume_geometry::{Vec2, Vec3A};
    /// use raylume_intersect::Hit;
    /// let hit = |t: f32| Hit { t, point: Vec3A::ZERO, normal: Vec3A::Z, uv: Vec2::ZERO, error: Vec3A::ZERO };
    /// let at = |t: f32, primitive: u32| PrimitiveHit { hit: hit(t), primitive };
    /// let mut best = None;
    /// PrimitiveHit::keep_closer(&mut best, at(2.0, 5));
    /// PrimitiveHit::keep_closer(&mut best, at(2.0, 3)); // as close, lower index: kept
    /// PrimitiveHit::keep_closer(&mut best, at(3.0, 0)); // farther: not kept
    /// assert_eq!(best.map(|b| b.primitive), Some(3));
    /// ```
    #[inline(always)]
    pub fn keep_closer(best: &mut Option<PrimitiveHit>, candidate: PrimitiveHit) {
        if best.as_ref().is_none_or(|b| candidate.beats(b)) {
            *best = Some(candidate);
        }
    }
}

/// A query on the canonical form of `ray` ([`Ray::canonical`]): the accelerators answer every
/// direction `2^k d` alike, bit for bit, with `t` scaled by `2^-k`. Unit directions are canonical
/// already: they go to the query as they are, and so does its answer; a rescaled ray's answer is
/// taken back by `back(answer, s)`.
#[inline(always)]
fn on_canonical<R>(
    ray: &Ray,
    t_range: Interval,
    query: impl FnOnce(&Ray, Interval) -> Option<R>,
    back: impl FnOnce(R, f32) -> R,
) -> Option<R> {
    if ray.is_canonical() {
        // The direction is finite and normal: the rest of `Ray::is_valid`.
        if !ray.origin.is_finite() || ray.time.is_nan() {
            return None;
        }
        return query(ray, t_range);
    }
    let (scaled, s) = rescale(ray)?;
    query(&scaled, t_range.on_canonical(s)).map(|r| back(r, s))
}

/// [`Ray::canonical`] out of line: the path of rays that are not canonical as they are made.
#[cold]
#[inline(never)]
fn rescale(ray: &Ray) -> Option<(Ray, f32)> {
    ray.canonical()
}

/// [`on_canonical`] for closest-hit queries.
#[inline(always)]
fn closest_on_canonical(
    ray: &Ray,
    t_range: Interval,
    query: impl FnOnce(&Ray, Interval) -> Option<PrimitiveHit>,
) -> Option<PrimitiveHit> {
    on_canonical(ray, t_range, query, |mut h, s| {
        h.hit.t *= s;
        h
    })
}

/// [`on_canonical`] for any-hit queries within `(0, t_max)`.
#[inline(always)]
fn occluded_on_canonical(ray: &Ray, t_max: f32, query: impl FnOnce(&Ray, f32) -> bool) -> bool {
    if t_max.is_nan() {
        return false;
    }
    on_canonical(ray, Interval::new(0.0, t_max), |ray, range| query(ray, range.max).then_some(()), |r, _| r).is_some()
}

/// Counts the work of a query. `()` counts nothing (the render path); `u64` counts primitive tests;
/// [`Counts`] counts primitive tests and node visits.
pub trait Tally {
    /// Records that one primitive was tested.
    fn tested(&mut self);

    /// Records that one node (BVH) or cell (grid) was visited.
    #[inline(always)]
    fn visited(&mut self) {}
}

/// Primitive tests and node (or cell) visits of the queries it was passed to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Primitives tested.
    pub tested: u64,
    /// Nodes or cells visited.
    pub visited: u64,
}

impl Tally for Counts {
    #[inline(always)]
    fn tested(&mut self) {
        self.tested += 1;
    }

    #[inline(always)]
    fn visited(&mut self) {
        self.visited += 1;
    }
}

impl Tally for () {
    #[inline(always)]
    fn tested(&mut self) {}
}

impl Tally for u64 {
    #[inline(always)]
    fn tested(&mut self) {
        *self += 1;
    }
}

/// Size figures of a built structure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccelStats {
    /// Nodes (BVH) or cells (grid).
    pub nodes: usize,
    /// Bytes of the structure, primitives included.
    pub bytes: usize,
    /// Primitives held.
    pub primitives: usize,
}

/// A structure that answers ray queries over a set of primitives.
///
/// Built once from the primitives, then shared read-only by every rendering thread. Implementors
/// write the tallying queries; the plain ones are those with a tally that counts nothing, so the
/// counting costs the render path nothing.
pub trait Accelerator: Sync + Send {
    /// The closest hit with `t` in `t_range`, counting primitive tests in `tally`.
    fn closest_hit_tally<T: Tally>(&self, ray: &Ray, t_range: Interval, tally: &mut T) -> Option<PrimitiveHit>;

    /// Whether any primitive is hit with `t` in `(0, t_max)`, counting primitive tests in `tally`.
    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool;

    /// The bounds of every bounded primitive.
    fn bounds(&self) -> Aabb;

    /// Size figures of the structure.
    fn stats(&self) -> AccelStats;

    /// The closest hit with `t` in `t_range`.
    #[inline]
    fn closest_hit(&self, ray: &Ray, t_range: Interval) -> Option<PrimitiveHit> {
        self.closest_hit_tally(ray, t_range, &mut ())
    }

    /// Whether any primitive is hit with `t` in `(0, t_max)` (shadow rays: stops at the first hit).
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.occluded_tally(ray, t_max, &mut ())
    }

    /// The closest hit of each of `rays` with `t` in `t_range`, into `hits`: `hits[i]` is
    /// [`closest_hit`](Accelerator::closest_hit) of `rays[i]`. Structures that share work between rays
    /// travelling together override it: pass coherent rays (the primary rays of a tile) in runs.
    ///
    /// ```
    /// use raylume_accel::{Accelerator, Bvh};
    /// use raylume_geometry::{Interval, Ray, Triangle, Vec3A};
    /// use raylume_intersect::Primitive;
    /// let wall = Triangle::new(Vec3A::new(-9.0, -9.0, 5.0), Vec3A::new(9.0, -9.0, 5.0), Vec3A::new(0.0, 9.0, 5.0));
    /// let bvh = Bvh::new(vec![Primitive::Triangle(wall)], Interval::new(0.0, 0.0));
    /// let rays: Vec<Ray> = (0..16).map(|i| Ray::new(Vec3A::ZERO, Vec3A::new(0.01 * i as f32, 0.02, 1.0))).collect();
    /// let mut hits = vec![None; rays.len()];
    /// bvh.closest_hits(&rays, Interval::POSITIVE, &mut hits);
    /// assert!(hits.iter().zip(&rays).all(|(h, r)| *h == bvh.closest_hit(r, Interval::POSITIVE)));
    /// ```
    ///
    /// # Panics
    /// If `hits` is not as long as `rays`.
    fn closest_hits(&self, rays: &[Ray], t_range: Interval, hits: &mut [Option<PrimitiveHit>]) {
        assert_eq!(rays.len(), hits.len(), "one answer per ray");
        closest_ray_by_ray(self, rays, t_range, hits);
    }

    /// Whether [`closest_hits`](Accelerator::closest_hits) answers runs of coherent rays (a camera's
    /// neighbouring pixels) with less work than one query each, so that a renderer gains by
    /// gathering them: false by default; a BVH over bounded shapes walks them as packets.
    fn gathers_coherent_rays(&self) -> bool {
        false
    }

    /// Whether each of `rays` is occluded within `(0, t_max)`, into `occluded`: `occluded[i]` is
    /// [`occluded`](Accelerator::occluded) of `rays[i]`. Overridden like
    /// [`closest_hits`](Accelerator::closest_hits).
    ///
    /// # Panics
    /// If `occluded` is not as long as `rays`.
    fn occluded_each(&self, rays: &[Ray], t_max: f32, occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one answer per ray");
        for (ray, o) in rays.iter().zip(occluded) {
            *o = self.occluded(ray, t_max);
        }
    }

    /// Whether each of `rays` is occluded within `(0, t_max[i])`, into `occluded`: `occluded[i]` is
    /// [`occluded`](Accelerator::occluded) of `rays[i]` and `t_max[i]` (shadow rays from neighbouring
    /// points to one light, each ending at the light). Overridden like
    /// [`closest_hits`](Accelerator::closest_hits).
    ///
    /// ```
    /// use raylume_accel::{Accelerator, Bvh};
    /// use raylume_geometry::{Interval, Ray, Triangle, Vec3A};
    /// use raylume_intersect::Primitive;
    /// let wall = Triangle::new(Vec3A::new(-9.0, -9.0, 5.0), Vec3A::new(9.0, -9.0, 5.0), Vec3A::new(0.0, 9.0, 5.0));
    /// let bvh = Bvh::new(vec![Primitive::Triangle(wall)], Interval::new(0.0, 0.0));
    /// let rays: Vec<Ray> = (1..17).map(|i| Ray::new(Vec3A::ZERO, Vec3A::new(0.01 * i as f32, 0.02, 1.0))).collect();
    /// let t_max: Vec<f32> = (0..16).map(|i| i as f32).collect();
    /// let mut occluded = vec![false; rays.len()];
    /// bvh.occluded_each_within(&rays, &t_max, &mut occluded);
    /// assert!(occluded.iter().zip(&rays).zip(&t_max).all(|((o, r), t)| *o == bvh.occluded(r, *t)));
    /// assert_eq!((occluded[4], occluded[6]), (false, true));
    /// ```
    ///
    /// # Panics
    /// If `t_max` or `occluded` is not as long as `rays`.
    fn occluded_each_within(&self, rays: &[Ray], t_max: &[f32], occluded: &mut [bool]) {
        assert!(rays.len() == t_max.len() && rays.len() == occluded.len(), "one end and one answer per ray");
        occluded_ray_by_ray(self, rays, t_max, occluded);
    }
}

/// [`Accelerator::closest_hits`] by single-ray queries: the default, and the BVH's answer for runs it
/// cannot walk as packets.
fn closest_ray_by_ray<A: Accelerator + ?Sized>(
    accel: &A,
    rays: &[Ray],
    t_range: Interval,
    hits: &mut [Option<PrimitiveHit>],
) {
    for (ray, hit) in rays.iter().zip(hits) {
        *hit = accel.closest_hit(ray, t_range);
    }
}

/// [`Accelerator::occluded_each_within`] by single-ray queries: the BVH's answer for runs it cannot
/// walk as packets.
fn occluded_ray_by_ray<A: Accelerator + ?Sized>(accel: &A, rays: &[Ray], t_max: &[f32], occluded: &mut [bool]) {
    for ((ray, &t_max), o) in rays.iter().zip(t_max).zip(occluded) {
        *o = accel.occluded(ray, t_max);
    }
}

/// Which accelerator to build, chosen at run time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum AccelKind {
    /// A plain list: every primitive is considered by every ray, its box first ([`BruteForce::with_boxes`]).
    None,
    /// A bounding volume hierarchy built with binned SAH, with the fastest kernel the CPU runs
    /// ([`BvhKernel::best`]).
    #[default]
    Bvh,
    /// The same hierarchy with the portable kernel ([`BvhKernel::Portable`]), as on CPUs without AVX2.
    BvhPortable,
    /// The course's BVH: midpoint splits of the largest axis, leaves of at most 2 primitives.
    BvhMidpoint,
    /// A uniform grid with mailboxing.
    Grid,
}
