//! Geometry for raylume: [`Ray`], [`Aabb`], [`Interval`], the data of every shape raylume can
//! intersect, and sampling helpers.
//!
//! Everything here is small, `Copy` and built on [`glam`]. Intersection routines live in
//! `raylume-intersect`; this crate only says what a shape *is*.
//!
//! ```
//! use raylume_geometry::{Ray, Vec3A};
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
//! assert_eq!(ray.at(2.0), Vec3A::new(2.0, 0.0, 0.0));
//! ```

mod aabb;
mod buffer;
mod ray;
pub mod sampling;
mod shapes;

pub use aabb::Aabb;
pub use buffer::LargeBuffer;
pub use glam::{Vec2, Vec3, Vec3A};
pub use ray::{Interval, Ray};
pub use shapes::{AaBox, Cone, MovingSphere, Plane, Sphere, Triangle, is_plane_normal};

/// Builds an orthonormal basis `(s, t)` such that `(s, t, n)` is right-handed, for a unit vector `n`.
///
/// Uses the branchless construction of Duff et al. (JCGT 2017), stable for every `n`.
///
/// ```
/// use raylume_geometry::{orthonormal_basis, Vec3A};
/// let n = Vec3A::new(0.0, 0.6, 0.8);
/// let (s, t) = orthonormal_basis(n);
/// assert!(s.dot(n).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && s.dot(t).abs() < 1e-6);
/// ```
#[inline]
pub fn orthonormal_basis(n: Vec3A) -> (Vec3A, Vec3A) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3A::new(b, sign + n.y * n.y * a, -n.y))
}

/// pbrt's `gamma(n)`: a bound on the relative error of `n` successive f32 operations,
/// `n u / (1 - n u)` with `u = 2^-24`.
///
/// ```
/// assert!(raylume_geometry::gamma(3) > 3.0 * f32::EPSILON / 2.0);
/// ```
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let nu = n as f32 * (f32::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// The origin of a ray leaving a surface at `p`: `p` moved along the normal `n` (pointing to the side
/// the ray leaves towards) just past the box `p ± error` that bounds the point's floating-point error,
/// then rounded away from `p` (pbrt-v4's `OffsetRayOrigin`). Combined with intersection routines that
/// reject hits within their own error bound, a ray leaving a surface never hits it again, at any
/// scene scale, and the offset stays as small as the error allows.
///
/// ```
/// use raylume_geometry::{offset_ray_origin, Vec3A};
/// let p = Vec3A::new(1e5, 0.0, 0.0);
/// let o = offset_ray_origin(p, Vec3A::splat(0.01), Vec3A::X);
/// assert!(o.x > p.x + 0.01 && o.y == 0.0 && o.z == 0.0);
/// ```
#[inline]
pub fn offset_ray_origin(p: Vec3A, error: Vec3A, n: Vec3A) -> Vec3A {
    let d = n.abs().dot(error);
    let offset = n * d;
    next_along(p + offset, offset)
}

/// Each coordinate of `o` moved to the next float up where `offset` is positive (`f32::next_up`),
/// down where it is negative (`f32::next_down`), and left as it is elsewhere.
#[inline(always)]
fn next_along(o: Vec3A, offset: Vec3A) -> Vec3A {
    // A coordinate of magnitude in [2^-100, 2^100] moves to the next float by adding or taking off
    // its magnitude times (1 + 2^-23) 2^-24: between half an ulp and an ulp of it, so the sum rounds
    // to the neighbour (half an ulp below a power of two, where the spacing halves). Other
    // coordinates take the bit steps.
    let magnitude = o.abs();
    let plain = offset.cmpeq(Vec3A::ZERO)
        | (magnitude.cmpge(Vec3A::splat(STEP_LOW)) & magnitude.cmple(Vec3A::splat(STEP_HIGH)));
    if plain.all() {
        let step = magnitude * STEP_SCALE;
        return Vec3A::select(
            offset.cmpgt(Vec3A::ZERO),
            o + step,
            Vec3A::select(offset.cmplt(Vec3A::ZERO), o - step, o),
        );
    }
    step_along(o, offset)
}

/// The smallest magnitude [`next_along`] steps by a product: the product stays normal.
const STEP_LOW: f32 = 1.0 / (1u128 << 100) as f32;
/// The largest magnitude [`next_along`] steps by a product.
const STEP_HIGH: f32 = (1u128 << 100) as f32;
/// `(1 + 2^-23) 2^-24`: a coordinate's magnitude times this is more than half its ulp and at most
/// its ulp (with the product's rounding).
const STEP_SCALE: f32 = (1.0 + f32::EPSILON) / (1u32 << 24) as f32;

/// [`next_along`] by the bits, for any coordinates.
#[cold]
#[inline(never)]
fn step_along(mut o: Vec3A, offset: Vec3A) -> Vec3A {
    for a in 0..3 {
        if offset[a] > 0.0 {
            o[a] = o[a].next_up();
        } else if offset[a] < 0.0 {
            o[a] = o[a].next_down();
        }
    }
    o
}

/// The ray from a point on one surface to a point on another, both moved off their surfaces past
/// their error bounds (`n_from`, `n_to`: normals on the sides the ray leaves and arrives from), with
/// the parameter range that stops just short of the far end: pbrt-v4's `SpawnRayTo`. The direction is
/// not normalised: `t` runs from 0 to `1 - SHADOW_EPSILON`.
///
/// ```
/// use raylume_geometry::{spawn_ray_to, Vec3A};
/// let (ray, t_max) = spawn_ray_to(Vec3A::ZERO, Vec3A::splat(1e-7), Vec3A::Z, Vec3A::new(0.0, 0.0, 2.0), Vec3A::splat(1e-7), -Vec3A::Z);
/// assert!(ray.origin.z > 0.0 && ray.at(t_max).z < 2.0);
/// ```
#[inline]
pub fn spawn_ray_to(
    from: Vec3A,
    from_error: Vec3A,
    n_from: Vec3A,
    to: Vec3A,
    to_error: Vec3A,
    n_to: Vec3A,
) -> (Ray, f32) {
    const SHADOW_EPSILON: f32 = 1e-4;
    let o = offset_ray_origin(from, from_error, n_from);
    let t = offset_ray_origin(to, to_error, n_to);
    (Ray::new(o, t - o), 1.0 - SHADOW_EPSILON)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `x.next_up()` for a positive offset, `x.next_down()` for a negative one, else `x`.
    fn reference(x: f32, offset: f32) -> f32 {
        if offset > 0.0 {
            x.next_up()
        } else if offset < 0.0 {
            x.next_down()
        } else {
            x
        }
    }

    /// Checks [`next_along`] on `x` in every lane, with every kind of offset, against `f32::next_up`
    /// and `f32::next_down`.
    fn check(x: f32) {
        for offset in [1.0, -1.0, 0.0, -0.0, f32::from_bits(1), -f32::MAX, f32::NAN] {
            // The other lanes hold ordinary values, or ones that need the bit steps.
            for other in [0.75, 0.0, f32::INFINITY] {
                for lane in 0..3 {
                    let (mut o, mut offsets) = (Vec3A::splat(other), Vec3A::splat(1.0));
                    o[lane] = x;
                    offsets[lane] = offset;
                    let got = next_along(o, offsets)[lane];
                    let want = reference(x, offset);
                    assert_eq!(got.to_bits(), want.to_bits(), "x {x:e} ({:#x}), offset {offset}", x.to_bits());
                }
            }
        }
    }

    #[test]
    fn stepping_to_the_next_float_agrees_with_next_up_and_next_down() {
        let special =
            [0.0, f32::from_bits(1), f32::MIN_POSITIVE, STEP_LOW, STEP_HIGH, f32::MAX, f32::INFINITY, f32::NAN];
        for x in special {
            for x in [x, -x, x.next_up(), x.next_down(), -x.next_up(), -x.next_down()] {
                check(x);
            }
        }
        // Every float of the binades at the ends of the products' range and around 1, and a spread
        // of bit patterns over every exponent.
        let binades = [STEP_LOW / 2.0, STEP_LOW, 0.5, 1.0, STEP_HIGH / 2.0, STEP_HIGH];
        for start in binades {
            for x in (0..1u32 << 23).step_by(61).map(|i| f32::from_bits(start.to_bits() + i)) {
                check(x);
                check(-x);
            }
        }
        for x in (0..400_000u32).map(|i| f32::from_bits(i.wrapping_mul(0x9e37_79b9))) {
            check(x);
        }
    }

    /// Every f32 (slow: run with `--ignored`).
    #[test]
    #[ignore]
    fn stepping_to_the_next_float_agrees_for_every_float() {
        for bits in 0..=u32::MAX {
            let x = f32::from_bits(bits);
            for offset in [1.0, -1.0, 0.0] {
                let got = next_along(Vec3A::new(x, 1.0, -1.0), Vec3A::new(offset, 0.0, 0.0)).x;
                assert_eq!(got.to_bits(), reference(x, offset).to_bits(), "x {x:e} ({bits:#x}), offset {offset}");
            }
        }
    }
}
