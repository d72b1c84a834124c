use std::path::PathBuf;

use raylume_accel::{AccelKind, GridParams};
use raylume_integrator::{Estimate, Film, Profile, RayStats, RenderSettings};
use raylume_scene::{SceneError, Warning};

use crate::limits;

/// How to render a scene: the integrator's settings plus overrides of what the scene file says.
///
/// The defaults render a scene as the CLI does without flags: the scene's own `spp`, accelerator
/// hint and cubemap (looked for beside the scene file, then in its parent folder).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Depth, seed, Fresnel mode, light grid, crop; its `spp` is used only for a scene without
    /// `spp` when [`RenderOptions::spp`] is `None`.
    pub settings: RenderSettings,
    /// Samples per pixel, 1 (the pixel centre) to [`limits::MAX_SPP`]; `None` takes the scene's
    /// `spp` (its 0 meaning one sample at the pixel centre), else `settings.spp`.
    pub spp: Option<u32>,
    /// Make what would be a warning (a missing cubemap) an error.
    pub strict: bool,
    /// The accelerator; `None` takes the scene's `accel` hint, else the BVH.
    pub accel: Option<AccelKind>,
    /// Overrides the scene's resolution (the vertical field of view is kept).
    pub resolution: Option<(u32, u32)>,
    /// Further folders searched for the scene's `env` cubemap, after the scene's folder
    /// ([`Scene::base_dir`](raylume_scene::Scene::base_dir), else the current one) and its parent.
    pub env_dirs: Vec<PathBuf>,
    /// Whether to use the scene's cubemap (false: escaping rays return the background colour).
    pub use_env: bool,
    /// Scale of every material's specular highlight (1 in the plain model).
    pub specular_scale: f32,
    /// Makes every light a square area light of this side (0: every light a point).
    pub area_light_size: Option<f32>,
    /// Overrides every reflective material's roughness.
    pub roughness: Option<f32>,
    /// Overrides the camera's aperture: the lens radius, in pixel sizes of the view plane
    /// ([`View::aperture`](raylume_camera::View::aperture)).
    pub aperture: Option<f32>,
    /// Overrides the camera's focal distance (a ratio of the view-plane distance).
    pub focal: Option<f32>,
    /// Overrides the shutter interval.
    pub shutter: Option<(f32, f32)>,
    /// How the uniform grid is sized, when it is the accelerator.
    pub grid: GridParams,
    /// The sampler of antialiased renders.
    pub sampler: SamplerKind,
    /// The shading rules (plain, or the course's reference renders'); it overrides `settings.profile`.
    /// The depth stays `settings.max_depth` (the course profile's images use [`Profile::default_depth`]).
    pub profile: Profile,
    /// The passes a render's samples are drawn in: each pass takes an equal share of the samples
    /// per pixel with its own seed, so the passes are independent estimates of the image and their
    /// spread estimates its error ([`RenderOutput::estimate`]). 1 draws all the samples as one
    /// stratified set, with no estimate. A render of `spp` samples takes at most `passes` passes,
    /// the split that draws the fewest samples in all (a jittered pass rounds its share up to a
    /// square: 16 samples are 4 passes of 2 x 2, 8 are 2 of 2 x 2), and of those the most passes; one
    /// sample per pixel (the pixel centre) is one pass. Budgeted renders draw passes of
    /// `spp / passes` samples (rounded up) over the pixel's area for as long as they go on.
    pub passes: u32,
    /// Render passes until this many seconds have gone (building the accelerator included): a pass
    /// is not started if it would end past the limit, except the first. `f64::INFINITY` renders
    /// until [`RenderScene::render_progressive`](crate::RenderScene::render_progressive)'s callback
    /// stops it.
    pub time_limit: Option<f64>,
    /// Render passes until the estimated RMSE of the image (linear RGB, [`Estimate::rmse`]) is at
    /// most this.
    pub noise_threshold: Option<f64>,
    /// Adaptive sampling: after [`ADAPTIVE_MIN_PASSES`] passes over every pixel, further passes
    /// cover only the pixels whose estimated error falls most from another pass, and their
    /// neighbours ([`Accumulator::noisy_pixels`](raylume_integrator::Accumulator::noisy_pixels)).
    /// Without a budget the render takes as many samples as the uniform render would, in all.
    pub adaptive: bool,
    /// Render only the passes `first..end` of the render's passes ([`RenderOptions::passes`], with
    /// the same seeds): a share of the samples for a render farm, whose pass images put together in
    /// order are the whole render's. Without a budget or adaptive sampling only.
    pub pass_range: Option<(u32, u32)>,
    /// Finish a render that was stopped, from the state a [`Recorder`](crate::Recorder) kept of it:
    /// only the rows and passes left are rendered, and the image is, bit for bit, the one the
    /// render would have made without stopping. The other options must be those of the render
    /// that stopped. Without a budget or adaptive sampling only.
    pub resume: Option<std::sync::Arc<crate::RenderState>>,
}

/// Passes over every pixel before adaptive sampling chooses pixels.
pub const ADAPTIVE_MIN_PASSES: u32 = 4;
/// Passes a render takes by default ([`RenderOptions::passes`]): enough for the error estimate,
/// few enough that each pass keeps a stratified set of samples.
pub const DEFAULT_PASSES: u32 = 4;

/// Which sampler draws the samples of antialiased renders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SamplerKind {
    /// The course's jittered (stratified) sampler.
    #[default]
    Jittered,
    /// Independent uniform random samples.
    Independent,
    /// Owen-scrambled Sobol points (a low-discrepancy sequence).
    Sobol,
}

impl RenderOptions {
    /// Checks the options that do not depend on a scene against the [`limits`]: the settings, the
    /// resolution, every override's range, the grid's density. [`RenderScene::check`](crate::RenderScene::check) adds what needs the
    /// scene (its `spp`, the crop inside its image, the memory).
    ///
    /// ```
    /// use raylume_render::RenderOptions;
    /// assert!(RenderOptions::default().validate().is_ok());
    /// let huge = RenderOptions { resolution: Some((100_000, 100_000)), ..RenderOptions::default() };
    /// assert!(huge.validate().unwrap_err().to_string().starts_with("resolution 100000 x 100000"));
    /// ```
    pub fn validate(&self) -> Result<(), SceneError> {
        let invalid = |m: String| Err(SceneError::Invalid(m));
        self.settings.validate().map_err(SceneError::Invalid)?;
        if let Some((w, h)) = self.resolution {
            let side = 1..=limits::MAX_RESOLUTION;
            if !side.contains(&w) || !side.contains(&h) || w as u64 * h as u64 > limits::MAX_PIXELS {
                return invalid(format!(
                    "resolution {w} x {h}: each side must be 1..={} and the image at most {} pixels",
                    limits::MAX_RESOLUTION,
                    limits::MAX_PIXELS
                ));
            }
        }
        if let Some(spp) = self.spp.filter(|&n| n == 0 || n > limits::MAX_SPP) {
            return invalid(format!("spp {spp}: expected 1..={} samples per pixel", limits::MAX_SPP));
        }
        let check = |name: &str, v: Option<f32>, range: &str, ok: fn(f32) -> bool| match v {
            Some(x) if !x.is_finite() || !ok(x) => invalid(format!("{name} {x}: expected {range}")),
            _ => Ok(()),
        };
        check("area light size", self.area_light_size, "a finite number >= 0", |x| x >= 0.0)?;
        check("roughness", self.roughness, "[0, 1]", |x| (0.0..=1.0).contains(&x))?;
        check("aperture", self.aperture, "a finite number >= 0", |x| x >= 0.0)?;
        check("focal distance", self.focal, "a finite number > 0", |x| x > 0.0)?;
        check("specular scale", Some(self.specular_scale), "a finite number >= 0", |x| x >= 0.0)?;
        self.grid.validate().map_err(SceneError::Invalid)?;
        if !(1..=limits::MAX_SPP).contains(&self.passes) {
            return invalid(format!("passes {}: expected 1..={}", self.passes, limits::MAX_SPP));
        }
        if let Some(t) = self.time_limit.filter(|t| t.is_nan() || *t <= 0.0) {
            return invalid(format!("time limit {t}: expected seconds > 0"));
        }
        if let Some((first, end)) = self.pass_range {
            let budget = self.time_limit.is_some() || self.noise_threshold.is_some() || self.adaptive;
            if first >= end || end > self.passes || budget {
                return invalid(format!(
                    "passes {first}..{end}: expected a range within 0..{} and no budget or adaptive sampling",
                    self.passes
                ));
            }
        }
        let budget = self.time_limit.is_some() || self.noise_threshold.is_some() || self.adaptive;
        if self.resume.is_some() && budget {
            return invalid("resuming a render: expected no budget or adaptive sampling".to_owned());
        }
        if let Some(e) = self.noise_threshold.filter(|e| !e.is_finite() || *e <= 0.0) {
            return invalid(format!("noise threshold {e}: expected an RMSE > 0"));
        }
        if let Some((t0, t1)) = self.shutter.filter(|(t0, t1)| !(t0.is_finite() && t1.is_finite() && t0 <= t1)) {
            return invalid(format!("shutter [{t0}, {t1}] is not an interval"));
        }
        Ok(())
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            settings: RenderSettings::default(),
            spp: None,
            strict: false,
            accel: None,
            resolution: None,
            env_dirs: Vec::new(),
            use_env: true,
            specular_scale: 1.0,
            area_light_size: None,
            roughness: None,
            aperture: None,
            focal: None,
            shutter: None,
            grid: GridParams::default(),
            sampler: SamplerKind::default(),
            profile: Profile::Plain,
            passes: DEFAULT_PASSES,
            time_limit: None,
            noise_threshold: None,
            adaptive: false,
            pass_range: None,
            resume: None,
        }
    }
}

/// What a render uses, derived from the scene and the options before rendering; each effect not
/// used is left out of the render loop that runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// More than one sample per pixel.
    pub antialiasing: bool,
    /// Some light has a size.
    pub area_lights: bool,
    /// The camera has an aperture.
    pub depth_of_field: bool,
    /// Some reflective material is rough.
    pub fuzzy_reflections: bool,
    /// Some sphere moves during a shutter interval of non-zero length.
    pub motion_blur: bool,
    /// Some material transmits light.
    pub transmission: bool,
    /// The scene has lights.
    pub lights: bool,
}

impl std::fmt::Display for Features {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names = [
            (self.antialiasing, "antialiasing"),
            (self.area_lights, "soft shadows"),
            (self.depth_of_field, "depth of field"),
            (self.fuzzy_reflections, "fuzzy reflections"),
            (self.motion_blur, "motion blur"),
            (self.transmission, "refraction"),
        ];
        let used: Vec<&str> = names.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect();
        if used.is_empty() { write!(f, "none") } else { write!(f, "{}", used.join(", ")) }
    }
}

/// A rendered image and what it took.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image.
    pub film: Film,
    /// Rays traced by kind.
    pub stats: RayStats,
    /// The accelerator used.
    pub accel: AccelKind,
    /// The effects the render used.
    pub features: Features,
    /// Samples each pixel got: what the sampler drew (a jittered sampler rounds up to a square),
    /// summed over the passes; with adaptive sampling, what the most sampled pixels got.
    pub samples_per_pixel: u64,
    /// Samples per pixel over the whole image (below `samples_per_pixel` with adaptive sampling).
    pub mean_samples_per_pixel: f64,
    /// The passes rendered (with adaptive sampling, the passes of the most sampled pixels).
    pub passes: u32,
    /// The image's estimated error, from the spread of its passes (`None` with one pass).
    pub estimate: Option<Estimate>,
    /// The estimated variance of each pixel's value, per channel (`None` with one pass).
    pub variance: Option<Film>,
    /// Seconds spent building the accelerator.
    pub build_seconds: f64,
    /// Seconds spent tracing.
    pub render_seconds: f64,
    /// What the render left out (a cubemap that was not found), to be shown to the user.
    pub warnings: Vec<Warning>,
}
