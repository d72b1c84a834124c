//! Render profiles: the plain shading model, or the rules the course's reference renders follow.

/// Which shading rules a render follows.
///
/// ```
/// use raylume_integrator::Profile;
/// assert_eq!(Profile::Plain.specular_scale(3), 1.0);
/// assert!((Profile::Course.specular_scale(3) - 0.8 / 3.0).abs() < 1e-6);
/// assert_eq!(Profile::Course.escape_weight(2), 1.0);
/// assert!((Profile::Course.escape_weight(3) - 1.0 / 1.4).abs() < 1e-6);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Profile {
    /// The model as the course's text describes it: Blinn-Phong with amplitude `Ks`, escaping rays
    /// see the background colour at every depth.
    #[default]
    Plain,
    /// The rules that reproduce the course's reference renders (`refimages/`):
    /// - the specular highlight of each light has amplitude [`Profile::COURSE_SPECULAR`]` * Ks / n`
    ///   for a scene of `n` lights (the diffuse term is not divided);
    /// - a ray that escapes at depth `d` (the camera ray is 1) returns the background colour divided
    ///   by `max(1, `[`Profile::COURSE_ESCAPE_FALLOFF`]` * (d - 1))`: full for camera rays and first
    ///   bounces, `1/1.4` at the second bounce, `1/2.1` at the third, and so on;
    /// - the maximum depth is [`Profile::COURSE_DEPTH`] (seven bounces).
    ///
    /// Everything else is the plain model: Blinn-Phong `N.H` with the material's exponent, no
    /// ambient term, opaque shadow rays, exact Fresnel, refraction weighted by `(1 - Kr) T`, colour
    /// clamped to [0, 1] at every level.
    Course,
}

impl Profile {
    /// The course profile's specular amplitude over all lights (each light gets this / light count).
    pub const COURSE_SPECULAR: f32 = 0.8;
    /// The course profile's divisor growth, per bounce, of the background seen by escaping rays.
    pub const COURSE_ESCAPE_FALLOFF: f32 = 0.7;
    /// The course profile's maximum ray depth, counting the camera ray as 1.
    pub const COURSE_DEPTH: u32 = 8;

    /// The factor of every material's specular highlight in a scene of `lights` lights.
    pub fn specular_scale(self, lights: usize) -> f32 {
        match self {
            Profile::Plain => 1.0,
            Profile::Course => Self::COURSE_SPECULAR / lights.max(1) as f32,
        }
    }

    /// The weight of the background colour returned by a ray that escapes at `depth` (camera ray: 1).
    #[inline]
    pub fn escape_weight(self, depth: u32) -> f32 {
        match self {
            Profile::Plain => 1.0,
            Profile::Course => 1.0 / (Self::COURSE_ESCAPE_FALLOFF * depth.saturating_sub(1) as f32).max(1.0),
        }
    }

    /// The maximum depth the profile's images are made with (the course's template: 4).
    pub fn default_depth(self) -> u32 {
        match self {
            Profile::Plain => 4,
            Profile::Course => Self::COURSE_DEPTH,
        }
    }
}
