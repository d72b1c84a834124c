//! Shapes tested by four rays at once, lane by lane, with the very operations of their one-ray
//! routines in their order: each lane's answer is bit for bit the one its ray gets alone. Packets of
//! coherent rays use them where several rays meet a shape's box.

use glam::{DVec4, Vec4};
use raylume_geometry::{Ray, Sphere, Vec3A};

use crate::shapes::sphere_radius_in_range;

/// Four canonical rays ([`Ray::is_canonical`]), lane by lane: their origins and directions by axis.
#[derive(Clone, Copy, Debug)]
pub struct RayLanes {
    /// The origins' `x`, `y` and `z`, one lane per ray.
    pub origin: [Vec4; 3],
    /// The directions' `x`, `y` and `z`, one lane per ray.
    pub dir: [Vec4; 3],
}

impl RayLanes {
    /// The lanes of up to four rays; missing lanes repeat the first ray.
    ///
    /// ```
    /// use raylume_geometry::{Ray, Vec3A};
    /// use raylume_intersect::RayLanes;
    /// let rays = [Ray::new(Vec3A::ZERO, Vec3A::X), Ray::new(Vec3A::ONE, -Vec3A::Z)];
    /// let lanes = RayLanes::new(&rays);
    /// assert_eq!(lanes.origin[0].to_array(), [0.0, 1.0, 0.0, 0.0]);
    /// assert_eq!(lanes.dir[2].to_array(), [0.0, -1.0, 0.0, 0.0]);
    /// ```
    #[inline(always)]
    pub fn new(rays: &[Ray]) -> Self {
        let lane = |i: usize| rays.get(i).unwrap_or(&rays[0]);
        let by_axis = |v: fn(&Ray) -> Vec3A| {
            let (a, b, c, d) = (v(lane(0)), v(lane(1)), v(lane(2)), v(lane(3)));
            [0, 1, 2].map(|k| Vec4::new(a[k], b[k], c[k], d[k]))
        };
        Self { origin: by_axis(|r| r.origin), dir: by_axis(|r| r.dir) }
    }
}

/// What a shape's one-ray routine finds for each of four rays: the lanes `hit` whose ray meets it at
/// `t` (in that lane), and the lanes `undecided` that only the one-ray routine decides (sizes beyond
/// f32's squares); every other lane misses.
#[derive(Clone, Copy, Debug)]
pub struct LaneRoots {
    /// The distance of each hit lane's root.
    pub t: Vec4,
    /// Bit `l`: lane `l`'s ray meets the shape at `t[l]`.
    pub hit: u32,
    /// Bit `l`: lane `l`'s ray is left to the one-ray routine.
    pub undecided: u32,
}

/// The first root of `sphere` for each canonical ray of `rays` within its range `[min, max]`
/// (lane by lane), as [`Intersect::intersect_canonical`](crate::Intersect::intersect_canonical) and
/// [`Intersect::occluded_canonical`](crate::Intersect::occluded_canonical) find it for that ray alone
/// (the occlusion test's range is `[0, t_max]`). Every lane is undecided for a radius outside the range
/// the f32 routine takes. [`Intersect::hit_at_root`](crate::Intersect::hit_at_root) makes a hit lane's
/// [`Hit`](crate::Hit).
///
/// ```
/// use glam::Vec4;
/// use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
/// use raylume_intersect::{Intersect, RayLanes, sphere_roots};
/// let sphere = Sphere { center: Vec3A::new(0.0, 0.0, -5.0), radius: 1.0 };
/// let rays = [Ray::new(Vec3A::ZERO, -Vec3A::Z), Ray::new(Vec3A::X * 3.0, -Vec3A::Z)];
/// let roots = sphere_roots(&sphere, &RayLanes::new(&rays), Vec4::ZERO, Vec4::INFINITY);
/// assert_eq!(roots.hit & 0b11, 0b01);
/// assert_eq!(roots.t.x, sphere.intersect_canonical(&rays[0], Interval::POSITIVE).unwrap().t);
/// ```
#[inline(always)]
pub fn sphere_roots(sphere: &Sphere, rays: &RayLanes, min: Vec4, max: Vec4) -> LaneRoots {
    if !sphere_radius_in_range(sphere.radius) {
        return LaneRoots { t: Vec4::ZERO, hit: 0, undecided: 0b1111 };
    }
    let c = sphere.center;
    let center = [Vec4::splat(c.x), Vec4::splat(c.y), Vec4::splat(c.z)];
    roots(rays.origin, rays.dir, center, Vec4::splat(sphere.radius), min, max, 0b1111)
}

/// Up to four spheres, lane by lane, for one ray to test them all at once ([`spheres_roots`]).
#[derive(Clone, Copy, Debug)]
pub struct SphereLanes {
    /// The centres' `x`, `y` and `z`, one lane per sphere.
    pub center: [Vec4; 3],
    /// The radii.
    pub radius: Vec4,
    /// Bit `l`: lane `l` holds a sphere.
    pub used: u32,
}

impl SphereLanes {
    /// The lanes of the first four of `spheres`.
    ///
    /// ```
    /// use raylume_geometry::{Sphere, Vec3A};
    /// use raylume_intersect::SphereLanes;
    /// let lanes = SphereLanes::new(&[Sphere { center: Vec3A::X, radius: 0.5 }]);
    /// assert_eq!((lanes.center[0].x, lanes.radius.x, lanes.used), (1.0, 0.5, 0b1));
    /// ```
    pub fn new(spheres: &[Sphere]) -> Self {
        let spheres = &spheres[..spheres.len().min(4)];
        let lane = |f: fn(&Sphere) -> f32| {
            let mut v = [0.0; 4];
            for (x, s) in v.iter_mut().zip(spheres) {
                *x = f(s);
            }
            Vec4::from_array(v)
        };
        Self {
            center: [lane(|s| s.center.x), lane(|s| s.center.y), lane(|s| s.center.z)],
            radius: lane(|s| s.radius),
            used: (1 << spheres.len()) - 1,
        }
    }

    /// The sphere of lane `lane` (below four), as it was given.
    ///
    /// ```
    /// use raylume_geometry::{Sphere, Vec3A};
    /// use raylume_intersect::SphereLanes;
    /// let s = Sphere { center: Vec3A::new(1.0, 2.0, 3.0), radius: 0.5 };
    /// assert_eq!(SphereLanes::new(&[s, s]).sphere(1), s);
    /// ```
    #[inline(always)]
    pub fn sphere(&self, lane: usize) -> Sphere {
        let [x, y, z] = self.center.map(|c| c.to_array()[lane]);
        Sphere { center: Vec3A::new(x, y, z), radius: self.radius.to_array()[lane] }
    }
}

/// The first root of each sphere of `spheres` for the canonical `ray` within `[min, max]`, lane by
/// lane, as [`Intersect::intersect_canonical`](crate::Intersect::intersect_canonical) and
/// [`Intersect::occluded_canonical`](crate::Intersect::occluded_canonical) find it for that sphere
/// alone; a sphere whose radius the f32 routine does not take is undecided. Lanes without a sphere
/// are neither hit nor undecided.
///
/// ```
/// use raylume_geometry::{Interval, Ray, Sphere, Vec3A};
/// use raylume_intersect::{Intersect, SphereLanes, spheres_roots};
/// let spheres = [
///     Sphere { center: Vec3A::new(0.0, 0.0, -5.0), radius: 1.0 },
///     Sphere { center: Vec3A::new(3.0, 0.0, -5.0), radius: 1.0 },
/// ];
/// let ray = Ray::new(Vec3A::ZERO, -Vec3A::Z);
/// let roots = spheres_roots(&SphereLanes::new(&spheres), &ray, 0.0, f32::INFINITY);
/// assert_eq!((roots.hit, roots.undecided), (0b01, 0));
/// assert_eq!(roots.t.x, spheres[0].intersect_canonical(&ray, Interval::POSITIVE).unwrap().t);
/// ```
#[inline(always)]
pub fn spheres_roots(spheres: &SphereLanes, ray: &Ray, min: f32, max: f32) -> LaneRoots {
    let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
    let r = spheres.radius;
    // The radii the f32 routine takes (`sphere_radius_in_range`), lane by lane.
    let in_range = (r.cmpge(Vec4::splat(1e-15)) & r.cmple(Vec4::splat(1e15))).bitmask();
    let used = spheres.used;
    let LaneRoots { t, hit, undecided } = roots(
        splat(ray.origin),
        splat(ray.dir),
        spheres.center,
        r,
        Vec4::splat(min),
        Vec4::splat(max),
        used & in_range,
    );
    LaneRoots { t, hit: hit & in_range & used, undecided: (undecided | !in_range) & used }
}

/// The one-ray routine's roots (`sphere_root` in f32, with the squares that cancel in f64), lane by
/// lane: rays from `origin` along `dir` on spheres of `center` and `radius`, within `[min, max]`.
/// Where every lane of `lanes` passes clear of its sphere, no lane hits and none is undecided.
#[inline(always)]
fn roots(
    [ox, oy, oz]: [Vec4; 3],
    [dx, dy, dz]: [Vec4; 3],
    [cx, cy, cz]: [Vec4; 3],
    radius: Vec4,
    min: Vec4,
    max: Vec4,
    lanes: u32,
) -> LaneRoots {
    let (fx, fy, fz) = (ox - cx, oy - cy, oz - cz);
    // `dot` as glam forms it: (x x' + y y') + z z'.
    let a = dx * dx + dy * dy + dz * dz;
    let half_b = fx * dx + fy * dy + fz * dz;
    let s = half_b / a;
    // From the centre to the ray's closest point, as the discriminant forms it.
    let p = [fx - dx * s, fy - dy * s, fz - dz * s];
    // Its square in f32 is within 2^-21 of the f64 one (and the radius's within 2^-24): above the
    // radius's by 2^-18, the f64 discriminant is negative by at least 2^-19 r^2, a normal f32 for the
    // radii taken, so no lane of `lanes` is real.
    let above = radius * radius * Vec4::splat(1.0 + CLEAR_MARGIN);
    let clear = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).cmpgt(above);
    // Likewise outside the sphere by that margin (with a square below f32's largest, so that `c`
    // below is finite) and moving away: `leaving`.
    let f2 = fx * fx + fy * fy + fz * fz;
    let away = f2.cmpgt(above) & f2.cmplt(Vec4::splat(f32::MAX / 2.0)) & half_b.cmpgt(Vec4::ZERO);
    if (clear | away).bitmask() & lanes == lanes {
        return LaneRoots { t: Vec4::ZERO, hit: 0, undecided: 0 };
    }
    let r = radius.as_dvec4();
    let r2 = r * r;
    let c = (sq64([fx, fy, fz]) - r2).as_vec4();
    // From outside, moving away: a miss before the discriminant.
    let leaving = c.cmpgt(Vec4::ZERO) & half_b.cmpgt(Vec4::ZERO) & c.cmplt(Vec4::INFINITY);
    let disc = a * (r2 - sq64(p)).as_vec4();
    // Not NaN and not negative.
    let real = disc.cmpge(Vec4::ZERO);
    let wide = disc.cmpeq(Vec4::INFINITY) | c.abs().cmpeq(Vec4::INFINITY);
    let q = -(half_b + disc.sqrt().copysign(half_b));
    let (t0, t1) = (c / q, q / a);
    let ordered = t0.cmple(t1);
    let (t0, t1) = (Vec4::select(ordered, t0, t1), Vec4::select(ordered, t1, t0));
    let last = Vec4::select(max.cmpeq(Vec4::INFINITY), Vec4::splat(f32::MAX), max);
    let ahead = |t: Vec4| t.cmpgt(Vec4::ZERO) & t.cmpge(min) & t.cmple(last);
    let (first, second) = (ahead(t0), ahead(t1));
    let t = Vec4::select(first, t0, t1);
    let considered = (!leaving).bitmask() & real.bitmask();
    let undecided = considered & wide.bitmask();
    LaneRoots { t, hit: considered & !undecided & (first | second).bitmask(), undecided }
}

/// How far above the squared radius the f32 square of a ray's distance from a sphere's centre lies
/// where [`roots`] takes the ray to pass clear of it.
const CLEAR_MARGIN: f32 = 1.0 / (1 << 18) as f32;

/// `|v|^2` of each lane in f64 (each square exact), summed as the one-ray routine sums it.
#[inline(always)]
fn sq64([x, y, z]: [Vec4; 3]) -> DVec4 {
    let (x, y, z) = (x.as_dvec4(), y.as_dvec4(), z.as_dvec4());
    x * x + y * y + z * z
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;
    use raylume_geometry::Interval;

    use super::*;
    use crate::Intersect;

    /// A coordinate at one of several scales, often near the sphere.
    fn arb_scale() -> impl Strategy<Value = f32> {
        prop_oneof![Just(1.0f32), Just(1e-6), Just(1e-3), Just(1e3), Just(1e6), Just(1e-16), Just(1e16)]
    }

    fn arb_v(range: f32) -> impl Strategy<Value = Vec3A> {
        prop::array::uniform3(-range..range).prop_map(Vec3A::from_array)
    }

    /// The bits of a hit: its distance, point, normal and error.
    fn bits(h: Option<crate::Hit>) -> Option<[u32; 10]> {
        h.map(|h| {
            let [px, py, pz] = h.point.to_array().map(f32::to_bits);
            let [nx, ny, nz] = h.normal.to_array().map(f32::to_bits);
            let [ex, ey, ez] = h.error.to_array().map(f32::to_bits);
            [h.t.to_bits(), px, py, pz, nx, ny, nz, ex, ey, ez]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// Each lane's root, and the hit made from it, is the one-ray routine's, bit for bit, for
        /// closest-hit ranges and occlusion ranges: rays from inside and outside, grazing, leaving,
        /// starting on the surface, at scales from 1e-16 to 1e16 (radii beyond the f32 routine's range
        /// are left undecided).
        #[test]
        fn lanes_answer_as_each_ray_alone(
            scale in arb_scale(),
            centre in arb_v(4.0),
            radius in 0.05f32..3.0,
            rays in prop::collection::vec((arb_v(8.0), arb_v(1.0), 0usize..4), 4),
            min in prop_oneof![Just(0.0f32), 0.0f32..4.0],
            max in prop_oneof![Just(f32::INFINITY), 0.0f32..20.0],
        ) {
            let sphere = Sphere { center: centre * scale, radius: radius * scale };
            let rays: Vec<Ray> = rays
                .iter()
                .filter_map(|&(o, d, kind)| {
                    let o = match kind {
                        // On the surface, and inside.
                        0 => sphere.center + (o.try_normalize()? * sphere.radius),
                        1 => sphere.center + o * 0.1 * sphere.radius,
                        _ => o * scale,
                    };
                    // Aimed at the sphere, or not.
                    let d = if kind == 3 { sphere.center + d * sphere.radius - o } else { d };
                    Ray::new(o, d).canonical().map(|(r, _)| r)
                })
                .collect();
            prop_assume!(!rays.is_empty());
            let lanes = RayLanes::new(&rays);
            let (min, max) = (min * scale, max * scale);
            let roots = sphere_roots(&sphere, &lanes, Vec4::splat(min), Vec4::splat(max));
            let occluding = sphere_roots(&sphere, &lanes, Vec4::ZERO, Vec4::splat(max));
            for (l, ray) in rays.iter().enumerate() {
                let range = Interval::new(min, max);
                let expected = sphere.intersect_canonical(ray, range);
                if roots.undecided & (1 << l) == 0 {
                    let got = (roots.hit & (1 << l) != 0)
                        .then(|| sphere.hit_at_root(ray, roots.t.to_array()[l], range))
                        .flatten();
                    prop_assert_eq!(bits(got), bits(expected), "lane {} of {:?}", l, ray);
                }
                if occluding.undecided & (1 << l) == 0 {
                    prop_assert_eq!(occluding.hit & (1 << l) != 0, sphere.occluded_canonical(ray, max), "lane {}", l);
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// One ray's roots on four spheres at once are each sphere's own, bit for bit (the hit made
        /// from each too), for closest-hit and occlusion ranges, one to four spheres, at scales from
        /// 1e-16 to 1e16, the ray starting on or inside one of them; radii beyond the f32 routine's
        /// range are undecided, lanes without a sphere neither hit nor undecided.
        #[test]
        fn one_ray_answers_four_spheres_as_each_alone(
            scale in arb_scale(),
            spheres in prop::collection::vec((arb_v(4.0), prop_oneof![0.05f32..3.0, Just(1e-17f32), Just(1e17f32)]), 1..=4),
            (o, d, kind) in (arb_v(8.0), arb_v(1.0), 0usize..4),
            min in prop_oneof![Just(0.0f32), 0.0f32..4.0],
            max in prop_oneof![Just(f32::INFINITY), 0.0f32..20.0],
        ) {
            let spheres: Vec<Sphere> =
                spheres.iter().map(|&(c, r)| Sphere { center: c * scale, radius: r * scale }).collect();
            let s0 = spheres[0];
            let o = match kind {
                0 => match o.try_normalize() { Some(n) => s0.center + n * s0.radius, None => o * scale },
                1 => s0.center + o * 0.1 * s0.radius,
                _ => o * scale,
            };
            let d = if kind == 3 { s0.center + d * s0.radius - o } else { d };
            let Some((ray, _)) = Ray::new(o, d).canonical() else { return Ok(()) };
            let lanes = SphereLanes::new(&spheres);
            let (min, max) = (min * scale, max * scale);
            let roots = spheres_roots(&lanes, &ray, min, max);
            let occluding = spheres_roots(&lanes, &ray, 0.0, max);
            prop_assert_eq!((roots.hit | roots.undecided) >> spheres.len(), 0);
            for (l, sphere) in spheres.iter().enumerate() {
                let range = Interval::new(min, max);
                let in_range = (1e-15..=1e15).contains(&sphere.radius);
                prop_assert_eq!(roots.undecided & (1 << l) != 0, !in_range || roots.undecided & (1 << l) != 0);
                if roots.undecided & (1 << l) == 0 {
                    let got = (roots.hit & (1 << l) != 0)
                        .then(|| sphere.hit_at_root(&ray, roots.t.to_array()[l], range))
                        .flatten();
                    prop_assert_eq!(bits(got), bits(sphere.intersect_canonical(&ray, range)), "sphere {}", l);
                } else {
                    prop_assert!(!in_range || roots.hit & (1 << l) == 0);
                }
                if occluding.undecided & (1 << l) == 0 {
                    prop_assert_eq!(occluding.hit & (1 << l) != 0, sphere.occluded_canonical(&ray, max), "sphere {}", l);
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// Where a ray passes all four spheres within 2^-16 of their radii (grazing each, or starting
        /// on each), each lane is still that sphere's own answer: the test that takes every lane to
        /// pass clear of its sphere, or to leave it, says so only where the ray does.
        #[test]
        fn rays_grazing_every_sphere_answer_as_each_alone(
            scale in arb_scale(),
            (o, d) in (arb_v(8.0), arb_v(1.0)),
            spheres in prop::collection::vec((0.05f32..3.0, -3.0f32..6.0, arb_v(1.0), -64i32..64, any::<bool>()), 4),
        ) {
            let Some((ray, _)) = Ray::new(o * scale, d).canonical() else { return Ok(()) };
            let ulp = 1.0 / (1 << 22) as f32;
            let spheres: Vec<Sphere> = spheres
                .iter()
                .filter_map(|&(radius, t, side, k, starts_on)| {
                    let radius = radius * scale;
                    let off = (1.0 + k as f32 * ulp) * radius;
                    let center = if starts_on {
                        // The ray starts `off` from the centre, mostly on the side its direction leaves by.
                        ray.origin - (ray.dir + side * 0.5).try_normalize()? * off
                    } else {
                        // The ray passes `off` from the centre at distance `t * radius` along it.
                        let across = ray.dir.cross(side).try_normalize()?;
                        ray.at(t * radius / ray.dir.length()) + across * off
                    };
                    Some(Sphere { center, radius })
                })
                .collect();
            prop_assume!(!spheres.is_empty());
            let lanes = SphereLanes::new(&spheres);
            for max in [f32::INFINITY, 2.0 * scale] {
                let roots = spheres_roots(&lanes, &ray, 0.0, max);
                for (l, sphere) in spheres.iter().enumerate() {
                    let range = Interval::new(0.0, max);
                    if roots.undecided & (1 << l) == 0 {
                        let got = (roots.hit & (1 << l) != 0)
                            .then(|| sphere.hit_at_root(&ray, roots.t.to_array()[l], range))
                            .flatten();
                        prop_assert_eq!(bits(got), bits(sphere.intersect_canonical(&ray, range)), "sphere {}", l);
                    }
                }
            }
        }
    }

    /// Radii beyond the f32 routine's range leave every lane to the one-ray routine.
    #[test]
    fn radii_beyond_f32_squares_are_undecided() {
        let rays = [Ray::new(Vec3A::ZERO, Vec3A::new(0.0, 0.0, -0.75))];
        for radius in [1e-16f32, 1e16] {
            let sphere = Sphere { center: Vec3A::new(0.0, 0.0, -3.0 * radius), radius };
            let roots = sphere_roots(&sphere, &RayLanes::new(&rays), Vec4::ZERO, Vec4::INFINITY);
            assert_eq!((roots.hit, roots.undecided), (0, 0b1111));
        }
    }
}
