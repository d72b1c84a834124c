//! Materials and lights for raylume: the course's [`Phong`] material (the p3f `f` entity), the
//! [`Material`] trait the integrator shades with, the [`Light`]s of a scene, and the optics of
//! dielectrics: [`reflect`], [`refract`], the exact
//! [`fresnel_dielectric`] equations and [`schlick`]'s approximation.
//!
//! ```
//! use raylume_material::{fresnel_dielectric, schlick};
//! // Glass (n = 1.5) at normal incidence reflects 4 %.
//! assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
//! assert!((schlick(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
//! ```

mod light;
mod optics;

pub use light::{Light, LightShape};
pub use optics::{FresnelMode, fresnel_dielectric, fresnel_refract, reflect, refract, schlick};
use raylume_geometry::{Vec3, Vec3A};

/// A surface's response to light, as the Whitted integrator uses it.
pub trait Material: Sync + Send {
    /// Light reflected towards `wo` from a light in direction `wi` of unit colour, at a point with
    /// unit normal `n` facing `wo` (all unit vectors pointing away from the surface).
    fn local(&self, n: Vec3A, wo: Vec3A, wi: Vec3A) -> Vec3;

    /// The colour weight of the mirror-reflected ray of an opaque surface (zero: none is traced).
    fn mirror(&self) -> Vec3;

    /// The dielectric behaviour, if the surface transmits light.
    fn dielectric(&self) -> Option<Dielectric>;

    /// Radius of the sphere that perturbs mirror reflections (0: a perfect mirror).
    fn roughness(&self) -> f32 {
        0.0
    }
}

/// How a transmissive surface splits light between reflection and refraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Fraction of the refracted light that is transmitted (p3f `T`).
    pub transmittance: f32,
    /// Index of refraction of the inside relative to vacuum.
    pub ior: f32,
}

/// The course's material: Blinn-Phong local illumination plus mirror reflection and refraction.
///
/// ```
/// use raylume_material::{Material, Phong};
/// use raylume_geometry::{Vec3, Vec3A};
/// let m = Phong { diffuse: Vec3::ONE, kd: 0.5, ..Phong::default() };
/// // A light straight above a diffuse surface gives Kd * diffuse.
/// let c = m.local(Vec3A::Z, Vec3A::Z, Vec3A::Z);
/// assert!((c - Vec3::splat(0.5)).length() < 1e-6);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    /// Diffuse colour.
    pub diffuse: Vec3,
    /// Diffuse coefficient.
    pub kd: f32,
    /// Specular colour.
    pub specular: Vec3,
    /// Specular coefficient (also the weight of mirror reflection).
    pub ks: f32,
    /// Blinn-Phong exponent.
    pub shine: f32,
    /// Transmittance: 0 for opaque.
    pub transmittance: f32,
    /// Index of refraction.
    pub ior: f32,
    /// Scale of the specular highlight (1 in the plain model; see the README on the course's images).
    pub specular_scale: f32,
    /// Fuzziness of mirror reflections in `[0, 1]` (0: a perfect mirror).
    pub roughness: f32,
}

impl Default for Phong {
    fn default() -> Self {
        Self {
            diffuse: Vec3::ONE,
            kd: 1.0,
            specular: Vec3::ZERO,
            ks: 0.0,
            shine: 1.0,
            transmittance: 0.0,
            ior: 1.0,
            specular_scale: 1.0,
            roughness: 0.0,
        }
    }
}

impl Material for Phong {
    #[inline]
    fn local(&self, n: Vec3A, wo: Vec3A, wi: Vec3A) -> Vec3 {
        let n_dot_l = n.dot(wi);
        if n_dot_l <= 0.0 {
            return Vec3::ZERO;
        }
        let mut c = self.diffuse * (self.kd * n_dot_l);
        if self.ks > 0.0 {
            // `(wi + wo).normalize_or_zero()`, its test `rcp.is_finite() && rcp > 0` on the bits.
            let h = wi + wo;
            let rcp = h.length_recip();
            let h = if rcp.to_bits().wrapping_sub(1) < f32::MAX.to_bits() { h * rcp } else { Vec3A::ZERO };
            let n_dot_h = n.dot(h).max(0.0);
            c += self.specular * (self.ks * self.specular_scale * n_dot_h.powf(self.shine));
        }
        c
    }

    #[inline]
    fn mirror(&self) -> Vec3 {
        if self.transmittance > 0.0 { Vec3::ZERO } else { self.specular * self.ks }
    }

    #[inline]
    fn dielectric(&self) -> Option<Dielectric> {
        (self.transmittance > 0.0).then_some(Dielectric { transmittance: self.transmittance, ior: self.ior })
    }
    #[inline]
    fn roughness(&self) -> f32 {
        self.roughness
    }
}
