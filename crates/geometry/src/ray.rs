use glam::Vec3A;

/// A ray: an origin, a direction and the instant it samples (for motion blur).
///
/// The direction is not required to be unit length by the intersection routines, but raylume's
/// cameras and integrator always produce unit directions, so `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3A,
    /// Where the ray goes.
    pub dir: Vec3A,
    /// The time the ray samples within the camera's shutter.
    pub time: f32,
}

impl Ray {
    /// A ray at time 0.
    #[inline]
    pub fn new(origin: Vec3A, dir: Vec3A) -> Self {
        Self { origin, dir, time: 0.0 }
    }

    /// A ray at the given time.
    #[inline]
    pub fn with_time(origin: Vec3A, dir: Vec3A, time: f32) -> Self {
        Self { origin, dir, time }
    }

    /// Whether the ray can be traced: finite origin and direction, and a direction that is not zero.
    /// Accelerators return no hit for any other ray, after constant work.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite() && self.dir.is_finite() && self.dir != Vec3A::ZERO && !self.time.is_nan()
    }

    /// The point at parameter `t` along the ray.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.dir * t
    }
}

/// A closed interval of ray parameters `[min, max]` in which hits are accepted.
///
/// ```
/// use raylume_geometry::Interval;
/// let i = Interval::new(0.0, 10.0);
/// assert!(i.contains(0.0) && i.contains(10.0) && !i.contains(10.5));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// The smallest accepted parameter.
    pub min: f32,
    /// The largest accepted parameter.
    pub max: f32,
}

impl Interval {
    /// Every parameter from 0 to infinity.
    pub const POSITIVE: Interval = Interval { min: 0.0, max: f32::INFINITY };

    /// The interval `[min, max]`.
    #[inline]
    pub const fn new(min: f32, max: f32) -> Self {
        Self { min, max }
    }

    /// Whether `t` is finite and lies in the interval (false for NaN and infinities, so a division
    /// by zero never reports a hit at infinity).
    #[inline]
    pub fn contains(&self, t: f32) -> bool {
        t >= self.min && t <= self.max && t.is_finite()
    }

    /// The same interval with its upper end lowered to `max` (used to prune by the closest hit so far).
    #[inline]
    pub fn with_max(self, max: f32) -> Self {
        Self { min: self.min, max }
    }
}
