//! Sampling helpers: maps from the unit square to disks and spheres.

use glam::{Vec2, Vec3A};

/// Maps a point of `[0,1)^2` to the unit disk with Shirley and Chiu's concentric mapping, which keeps
/// strata compact and areas uniform.
///
/// ```
/// use raylume_geometry::{sampling::concentric_disk, Vec2};
/// assert!(concentric_disk(Vec2::new(0.9, 0.1)).length() <= 1.0);
/// assert_eq!(concentric_disk(Vec2::splat(0.5)), Vec2::ZERO);
/// ```
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    Vec2::new(theta.cos(), theta.sin()) * r
}

/// Maps a point of `[0,1)^2` to a uniformly distributed unit vector (`u.x` sets the height, `u.y`
/// the angle around z).
///
/// ```
/// use raylume_geometry::{sampling::uniform_sphere, Vec2};
/// assert!((uniform_sphere(Vec2::new(0.3, 0.8)).length() - 1.0).abs() < 1e-6);
/// ```
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3A {
    let z = 1.0 - 2.0 * u.x;
    let r_xy = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3A::new(r_xy * phi.cos(), r_xy * phi.sin(), z)
}

/// Maps a point of `[0,1)^3` to a uniformly distributed point in the unit ball.
///
/// ```
/// use raylume_geometry::{sampling::uniform_ball, Vec3A};
/// assert!(uniform_ball(Vec3A::new(0.3, 0.7, 0.99)).length() <= 1.0 + 1e-6);
/// ```
#[inline]
pub fn uniform_ball(u: Vec3A) -> Vec3A {
    uniform_sphere(Vec2::new(u.x, u.y)) * u.z.cbrt()
}
