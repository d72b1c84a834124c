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

    /// Whether the ray can be traced: a finite origin, a time that is a number, and a direction
    /// whose largest component is a normal number below `2^127` in magnitude (from about 1.2e-38 to
    /// 1.7e38), so that [`Ray::canonical`]'s factor is representable. Accelerators return no hit for
    /// any other ray, after constant work.
    #[inline]
    pub fn is_valid(&self) -> bool {
        let largest = self.dir.abs().max_element();
        self.origin.is_finite()
            && self.dir.is_finite()
            && (f32::MIN_POSITIVE..MAX_DIRECTION).contains(&largest)
            && !self.time.is_nan()
    }

    /// The point at parameter `t` along the ray.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.dir * t
    }

    /// Whether the direction is canonical: its largest component has a magnitude in `[0.5, 1)`
    /// ([`Ray::canonical`]), as almost every unit direction's has. Routines given a canonical ray
    /// answer on it directly.
    #[inline(always)]
    pub fn is_canonical(&self) -> bool {
        self.dir.abs().max_element().to_bits() >> 23 == CANONICAL_EXPONENT
    }

    /// The ray with its direction scaled by a power of two so that its largest component has a
    /// magnitude in `[0.5, 1)`, and the factor `s` that takes its parameters back: a hit at `t` on the
    /// returned ray is at `t * s` on `self` (and a range `r` on `self` is `r.on_canonical(s)` on the
    /// returned ray). Both scalings are exact, so a query that answers on the canonical ray gives the
    /// same answer, bit for bit, for every direction `2^k d`: the intersection routines and the
    /// accelerators do so. `None` for a ray that is not [valid](Ray::is_valid).
    ///
    /// The range `[0.5, 1)` holds the largest component of every unit vector but those along an axis,
    /// so the rays of cameras and of the integrator are canonical as they are made.
    ///
    /// ```
    /// use raylume_geometry::{Ray, Vec3A};
    /// let ray = Ray::new(Vec3A::ZERO, Vec3A::new(0.0, 3.0 * 2f32.powi(-30), 0.0));
    /// let (canonical, s) = ray.canonical().unwrap();
    /// assert!(canonical.is_canonical() && !ray.is_canonical());
    /// assert_eq!(canonical.dir, Vec3A::new(0.0, 0.75, 0.0));
    /// assert_eq!(s, 2f32.powi(28));
    /// assert_eq!(canonical.at(2.0), ray.at(2.0 * s));
    /// assert!(Ray::new(Vec3A::ZERO, Vec3A::new(0.6, 0.8, 0.0)).is_canonical());
    /// ```
    #[inline(always)]
    pub fn canonical(&self) -> Option<(Ray, f32)> {
        if !self.is_valid() {
            return None;
        }
        let e = ((self.dir.abs().max_element().to_bits() >> 23) as i32) - CANONICAL_EXPONENT as i32;
        if e == 0 {
            return Some((*self, 1.0));
        }
        // The direction is 2^e times its canonical one, so the canonical ray's parameters are 2^e
        // times this ray's (`e` is in -125..=127 for a valid ray: 2^-e is representable).
        let factor = pow2(-e);
        Some((Ray { origin: self.origin, dir: self.dir * factor, time: self.time }, factor))
    }
}

/// The biased exponent of the largest component of a canonical direction: magnitudes in `[0.5, 1)`.
const CANONICAL_EXPONENT: u32 = 126;

/// `2^127`: a valid direction's largest component is below it.
const MAX_DIRECTION: f32 = f32::from_bits(254 << 23);

/// `2^k` for `k` in `-127..=127` (`2^-127` is subnormal, and exact).
#[inline]
fn pow2(k: i32) -> f32 {
    if k >= -126 { f32::from_bits(((k + 127) as u32) << 23) } else { f32::from_bits(1 << 22) }
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

    /// Both ends multiplied by `factor` (a power of two in [`Ray::canonical`]'s use, where it is exact).
    #[inline]
    pub fn scaled(self, factor: f32) -> Self {
        Self { min: self.min * factor, max: self.max * factor }
    }

    /// The interval on the canonical form of a ray whose parameters it measures, `s` being the factor
    /// [`Ray::canonical`] returned: both ends divided by `s` (exactly, a power of two).
    #[inline(always)]
    pub fn on_canonical(self, s: f32) -> Self {
        if s == 1.0 { self } else { self.scaled(1.0 / s) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every valid direction has a canonical form whose factor is exact and representable, from the
    /// smallest normal largest component to the largest one below `2^127`; directions beyond are not
    /// valid, and canonical directions are their own form.
    #[test]
    fn canonical_forms_cover_every_valid_direction() {
        for e in -126..=126 {
            for m in [1.0f32, 1.5, 1.999_999_9] {
                let dir = Vec3A::new(0.25 * m * 2f32.powi(e), -m * 2f32.powi(e), 0.0);
                let ray = Ray::new(Vec3A::new(1.0, 2.0, 3.0), dir);
                let (c, s) = ray.canonical().unwrap_or_else(|| panic!("2^{e} * {m}"));
                assert!(c.is_canonical(), "2^{e} * {m}");
                let power_of_two = (s.is_normal() && s.to_bits() & 0x7f_ffff == 0) || s == f32::from_bits(1 << 22);
                assert!(power_of_two, "2^{e} * {m}: factor {s}");
                assert_eq!(c.dir, dir * s, "2^{e} * {m}");
                assert_eq!(c.at(2.0), ray.at(2.0 * s), "2^{e} * {m}: parameters scale by the factor");
                assert!((0.5..1.0).contains(&c.dir.y.abs()), "2^{e} * {m}");
            }
        }
        let huge = Ray::new(Vec3A::ZERO, Vec3A::new(0.0, 2f32.powi(127), 0.0));
        assert!(!huge.is_valid() && huge.canonical().is_none());
        let unit = Ray::new(Vec3A::ZERO, Vec3A::new(0.6, 0.0, -0.8));
        assert_eq!(unit.canonical(), Some((unit, 1.0)));
        let nan_origin = Ray::new(Vec3A::new(f32::NAN, 0.0, 0.0), Vec3A::new(0.6, 0.0, -0.8));
        assert!(nan_origin.is_canonical() && nan_origin.canonical().is_none());
    }
}
