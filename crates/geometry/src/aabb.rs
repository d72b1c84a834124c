use glam::Vec3A;

use crate::Ray;

/// An axis-aligned bounding box. The empty box has `min = +inf`, `max = -inf`.
///
/// ```
/// use raylume_geometry::{Aabb, Vec3A};
/// let b = Aabb::from_point(Vec3A::ZERO).union_point(Vec3A::ONE);
/// assert_eq!(b.diagonal(), Vec3A::ONE);
/// assert!(Aabb::EMPTY.is_empty());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: Vec3A,
    /// The corner with the largest coordinates.
    pub max: Vec3A,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The box that contains nothing; the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb { min: Vec3A::INFINITY, max: Vec3A::NEG_INFINITY };

    /// The box with the given corners.
    #[inline]
    pub fn new(min: Vec3A, max: Vec3A) -> Self {
        Self { min, max }
    }

    /// The degenerate box around one point.
    #[inline]
    pub fn from_point(p: Vec3A) -> Self {
        Self { min: p, max: p }
    }

    /// The smallest box containing all `points`.
    pub fn from_points(points: impl IntoIterator<Item = Vec3A>) -> Self {
        points.into_iter().fold(Self::EMPTY, Self::union_point)
    }

    /// The box `[min, max]` computed in f64, rounded outward to f32: it contains every point of the
    /// f64 box, so bounds formed this way are conservative.
    ///
    /// ```
    /// use raylume_geometry::Aabb;
    /// // 1e7 + 0.3 rounds down to 1e7 in f32; the box still reaches past it.
    /// let b = Aabb::from_f64([1e7 - 0.3; 3], [1e7 + 0.3; 3]);
    /// assert!(b.max.x as f64 >= 1e7 + 0.3 && (b.min.x as f64) <= 1e7 - 0.3);
    /// ```
    #[inline]
    pub fn from_f64(min: [f64; 3], max: [f64; 3]) -> Self {
        let down = |x: f64| {
            let f = x as f32;
            if f as f64 > x { f.next_down() } else { f }
        };
        let up = |x: f64| {
            let f = x as f32;
            if (f as f64) < x { f.next_up() } else { f }
        };
        Self { min: Vec3A::from_array(min.map(down)), max: Vec3A::from_array(max.map(up)) }
    }

    /// The smallest box containing both boxes.
    #[inline]
    pub fn union(self, other: Aabb) -> Self {
        Self { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// The smallest box containing this box and `p`.
    #[inline]
    pub fn union_point(self, p: Vec3A) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    /// Whether the box contains nothing.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// Whether every coordinate is finite (infinite planes have no finite bounds).
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// `max - min`.
    #[inline]
    pub fn diagonal(&self) -> Vec3A {
        self.max - self.min
    }

    /// The centre of the box.
    #[inline]
    pub fn centroid(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// The surface area, 0 for an empty box.
    #[inline]
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.diagonal();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// The index of the longest axis (0 = x, 1 = y, 2 = z).
    #[inline]
    pub fn longest_axis(&self) -> usize {
        let d = self.diagonal();
        if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        }
    }

    /// Whether `p` lies inside or on the box.
    #[inline]
    pub fn contains(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The parameter range `[t0, t1]` in which the ray is inside the box, clipped to
    /// `[t_min, t_max]`, or `None` if the ray misses it.
    ///
    /// `inv_dir` is `1 / ray.dir` (infinite for zero components). The test is conservative, so a
    /// traversal using it never misses what the primitive test would hit:
    /// - a direction component of `+0`, `-0` or a subnormal (the ray parallel to a slab) gives no
    ///   constraint when the origin lies in the slab, faces included, and a miss otherwise, the same
    ///   for every sign;
    /// - a `0 * inf` NaN (origin exactly on a face, subnormal direction) widens the range instead of
    ///   poisoning it;
    /// - the far end is widened by pbrt's `1 + 2 gamma(3)` for the rounding of the subtraction and
    ///   the product.
    ///
    /// ```
    /// use raylume_geometry::{Aabb, Ray, Vec3A};
    /// let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    /// // A ray lying in the face x = 0, with a direction of -0 along x: still inside.
    /// let r = Ray::new(Vec3A::new(0.0, 0.5, -1.0), Vec3A::new(-0.0, 0.0, 1.0));
    /// assert!(b.hit_range(&r, r.dir.recip(), 0.0, f32::INFINITY).is_some());
    /// ```
    #[inline]
    pub fn hit_range(&self, ray: &Ray, inv_dir: Vec3A, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let t_lo = (self.min - ray.origin) * inv_dir;
        let t_hi = (self.max - ray.origin) * inv_dir;
        let t_lo = Vec3A::select(t_lo.is_nan_mask(), Vec3A::NEG_INFINITY, t_lo);
        let t_hi = Vec3A::select(t_hi.is_nan_mask(), Vec3A::INFINITY, t_hi);
        let mut t_near = t_lo.min(t_hi);
        let mut t_far = t_lo.max(t_hi);
        // Zero and subnormal components: the ray runs along the slab (subnormals as zeros, so the
        // answer is the same for +0, -0 and their tiny neighbours).
        let parallel = ray.dir.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE));
        if parallel.any() {
            let inside = ray.origin.cmpge(self.min) & ray.origin.cmple(self.max);
            t_near = Vec3A::select(parallel, Vec3A::select(inside, Vec3A::NEG_INFINITY, Vec3A::INFINITY), t_near);
            t_far = Vec3A::select(parallel, Vec3A::select(inside, Vec3A::INFINITY, Vec3A::NEG_INFINITY), t_far);
        }
        let t0 = t_near.max_element().max(t_min);
        let t1 = (t_far.min_element() * (1.0 + 2.0 * GAMMA3)).min(t_max);
        (t0 <= t1).then_some((t0, t1))
    }
}

/// pbrt's `gamma(3)`: the relative error bound of three floating-point operations.
const GAMMA3: f32 = (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
