//! Reflection, refraction and the Fresnel reflectance of dielectrics.

use raylume_geometry::Vec3A;

/// Which formula gives the Fresnel reflectance of dielectrics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FresnelMode {
    /// The exact Fresnel equations for unpolarised light (the mean of `Rs` and `Rp`).
    #[default]
    Exact,
    /// Schlick's approximation.
    Schlick,
}

impl FresnelMode {
    /// The reflectance for cosine of incidence `cos_i` (>= 0) and index ratio `eta = n_i / n_t`.
    #[inline]
    pub fn reflectance(self, cos_i: f32, eta: f32) -> f32 {
        match self {
            FresnelMode::Exact => fresnel_dielectric(cos_i, eta),
            FresnelMode::Schlick => schlick(cos_i, eta),
        }
    }
}

/// The mirror direction of `d` (pointing at the surface) about the unit normal `n`. Of a unit `d` it
/// is unit to within the rounding of its terms, and is not normalised again: a chain of mirror
/// bounces waits on no square root for its directions (pbrt's `Reflect` does the same).
///
/// ```
/// use raylume_material::reflect;
/// use raylume_geometry::Vec3A;
/// let r = reflect(Vec3A::new(1.0, -1.0, 0.0), Vec3A::Y);
/// assert_eq!(r, Vec3A::new(1.0, 1.0, 0.0));
/// ```
#[inline]
pub fn reflect(d: Vec3A, n: Vec3A) -> Vec3A {
    d - n * (2.0 * d.dot(n))
}

/// The refracted direction of the unit direction `d` (pointing at the surface) through a surface with
/// unit normal `n` facing the incoming side, for index ratio `eta = n_i / n_t` (Snell's law);
/// `None` on total internal reflection. With equal indices (`eta == 1`), `d` itself. Like
/// [`reflect`]'s, the direction is unit to within the rounding of its terms and not normalised again.
///
/// ```
/// use raylume_material::refract;
/// use raylume_geometry::Vec3A;
/// // Straight through at normal incidence.
/// assert_eq!(refract(-Vec3A::Y, Vec3A::Y, 1.0 / 1.5), Some(-Vec3A::Y));
/// // Beyond the critical angle from glass to air: total internal reflection.
/// let grazing = Vec3A::new(0.9, -(1.0f32 - 0.81).sqrt(), 0.0);
/// assert_eq!(refract(grazing, Vec3A::Y, 1.5), None);
/// ```
#[inline]
pub fn refract(d: Vec3A, n: Vec3A, eta: f32) -> Option<Vec3A> {
    if eta == 1.0 {
        // Equal indices on both sides: the light goes on as it came.
        return Some(d);
    }
    let cos_i = (-d.dot(n)).min(1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(d * eta + n * (eta * cos_i - cos_t))
}

/// The exact Fresnel reflectance of a dielectric interface for unpolarised light: `(Rs + Rp) / 2`.
///
/// `cos_i` is the cosine of the angle of incidence (>= 0), `eta = n_i / n_t` the index ratio.
/// Returns 1 under total internal reflection, and exactly 0 for equal indices (`eta == 1`).
///
/// ```
/// use raylume_material::fresnel_dielectric;
/// // Brewster's angle for glass: Rp = 0, so the reflectance is Rs / 2.
/// let theta_b = 1.5f32.atan();
/// let r = fresnel_dielectric(theta_b.cos(), 1.0 / 1.5);
/// let rs = ((theta_b.cos() - 1.5 * (theta_b.sin() / 1.5).asin().cos())
///     / (theta_b.cos() + 1.5 * (theta_b.sin() / 1.5).asin().cos())).powi(2);
/// assert!((r - rs / 2.0).abs() < 1e-5);
/// ```
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    if eta == 1.0 {
        // Equal indices on both sides: nothing is reflected.
        return 0.0;
    }
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    // With n_i = eta and n_t = 1 (only the ratio matters).
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (eta * cos_t - cos_i) / (eta * cos_t + cos_i);
    0.5 * (rs * rs + rp * rp)
}

/// The exact Fresnel reflectance and the refracted direction together, sharing the terms they have
/// in common: bit for bit `(fresnel_dielectric(cos_i, eta), refract(d, n, eta))`, the direction
/// `None` under total internal reflection (where the reflectance is 1).
///
/// `d` is the unit direction pointing at the surface, `n` the unit normal facing the incoming side,
/// `cos_i` the cosine of incidence as `(-d).dot(n)` gives it, which must be at least 0 (not NaN):
/// [`refract`] takes its cosine from `d` and `n`, and only a non-negative one is the same as
/// [`fresnel_dielectric`]'s clamped one.
///
/// ```
/// use raylume_material::{fresnel_dielectric, fresnel_refract, refract};
/// use raylume_geometry::Vec3A;
/// let d = Vec3A::new(0.6, -0.8, 0.0);
/// let (kr, dir) = fresnel_refract(d, Vec3A::Y, (-d).dot(Vec3A::Y), 1.0 / 1.5);
/// assert_eq!((kr, dir), (fresnel_dielectric(0.8, 1.0 / 1.5), refract(d, Vec3A::Y, 1.0 / 1.5)));
/// ```
#[inline]
pub fn fresnel_refract(d: Vec3A, n: Vec3A, cos_i: f32, eta: f32) -> (f32, Option<Vec3A>) {
    debug_assert!(cos_i >= 0.0, "the cosine of incidence {cos_i} is negative or NaN");
    if eta == 1.0 {
        // Equal indices on both sides: nothing is reflected, and the light goes on as it came.
        return (0.0, Some(d));
    }
    // `clamp(0, 1)` of a non-negative cosine, and `refract`'s `min(1)`.
    let cos_i = cos_i.min(1.0);
    // 1 - cos^2 >= 0 here: `refract`'s `max(0)` changes nothing.
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return (1.0, None);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (eta * cos_t - cos_i) / (eta * cos_t + cos_i);
    (0.5 * (rs * rs + rp * rp), Some(d * eta + n * (eta * cos_i - cos_t)))
}

/// Schlick's approximation of the Fresnel reflectance, `R0 + (1 - R0)(1 - cos)^5`, where the cosine
/// is taken on the side of the lower index (so total internal reflection gives 1).
#[inline]
pub fn schlick(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let cos = if eta > 1.0 {
        // Leaving the denser medium: use the transmitted angle.
        let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
        if sin2_t >= 1.0 {
            return 1.0;
        }
        (1.0 - sin2_t).sqrt()
    } else {
        cos_i
    };
    r0 + (1.0 - r0) * (1.0 - cos).powi(5)
}
