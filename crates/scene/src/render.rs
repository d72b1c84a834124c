use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use raylume_accel::{AccelKind, Accelerator, BruteForce, Bvh, BvhBuild, BvhKernel, Grid, GridParams};
use raylume_camera::{Camera, MotionBlur, Pinhole, ThinLens};
use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Sphere, Triangle, Vec3A};
use raylume_integrator::{
    Background, Centre, Film, Independent, Integrator, Jittered, Light, Profile, RayStats, RenderSettings, Sampler,
    Shading, Sobol, SoftShadows, Whitted, World, render,
};
use raylume_intersect::Primitive;
use raylume_material::Phong;

use crate::{LightShape, Scene, SceneError, Shape, Warning, limits, load_cubemap, p3f};

/// How to render a scene: the integrator's settings plus overrides of what the scene file says.
///
/// The defaults render a scene as the CLI does without flags: the scene's own `spp`, accelerator
/// hint and cubemap (looked for beside the scene file, then in its parent folder).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Depth, seed, Fresnel mode, light grid, crop; its `spp` is used only for a scene without
    /// `spp` when [`RenderOptions::spp`] is `None`.
    pub settings: RenderSettings,
    /// Samples per pixel; `None` takes the scene's `spp` (0 meaning one sample at the pixel
    /// centre), else `settings.spp`.
    pub spp: Option<u32>,
    /// Make what would be a warning (a missing cubemap) an error.
    pub strict: bool,
    /// The accelerator; `None` takes the scene's `accel` hint, else the BVH.
    pub accel: Option<AccelKind>,
    /// Overrides the scene's resolution (the vertical field of view is kept).
    pub resolution: Option<(u32, u32)>,
    /// Further folders searched for the scene's `env` cubemap, after the scene's folder
    /// ([`Scene::base_dir`], else the current one) and its parent.
    pub env_dirs: Vec<PathBuf>,
    /// Whether to use the scene's cubemap (false: escaping rays return the background colour).
    pub use_env: bool,
    /// Scale of every material's specular highlight (1 in the plain model).
    pub specular_scale: f32,
    /// Makes every light a square area light of this side (0: every light a point).
    pub area_light_size: Option<f32>,
    /// Overrides every reflective material's roughness.
    pub roughness: Option<f32>,
    /// Overrides the camera's aperture (p3f units: multiples of the pixel size).
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
}

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
    /// resolution, every override's range, the grid's density. [`Scene::check`] adds what needs the
    /// scene (its `spp`, the crop inside its image, the memory).
    ///
    /// ```
    /// use raylume_scene::RenderOptions;
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
        if let Some(spp) = self.spp.filter(|&n| n > limits::MAX_SPP) {
            return invalid(format!("spp {spp}: expected 0..={}", limits::MAX_SPP));
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
        check("grid density", Some(self.grid.k), "(0, 1000]", |k| k > 0.0 && k <= limits::MAX_GRID_K)?;
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
    /// Seconds spent building the accelerator.
    pub build_seconds: f64,
    /// Seconds spent tracing.
    pub render_seconds: f64,
    /// What the render left out (a cubemap that was not found), to be shown to the user.
    pub warnings: Vec<Warning>,
}

/// The primitives of a scene with their shading data, in one order.
pub struct Primitives {
    /// The primitives.
    pub primitives: Vec<Primitive>,
    /// Shading of each primitive.
    pub shading: Vec<Shading>,
    /// Vertex normals referenced by [`Shading::normals`].
    pub vertex_normals: Vec<[Vec3A; 3]>,
}

impl Scene {
    /// The primitives the scene's objects make (polygons as triangle fans, meshes as triangles).
    pub fn primitives(&self) -> Primitives {
        let count = self.primitive_count();
        let mut out = Primitives {
            primitives: Vec::with_capacity(count),
            shading: Vec::with_capacity(count),
            vertex_normals: Vec::new(),
        };
        let none = u32::MAX;
        for o in &self.objects {
            let mut push = |p: Primitive, normals: u32| {
                out.primitives.push(p);
                out.shading.push(Shading { material: o.material, normals });
            };
            match &o.shape {
                Shape::Sphere { center, radius } => {
                    push(Primitive::Sphere(Sphere { center: *center, radius: *radius }), none)
                }
                Shape::MovingSphere { center0, center1, radius, time0, time1 } => push(
                    Primitive::MovingSphere(MovingSphere {
                        center0: *center0,
                        center1: *center1,
                        radius: *radius,
                        time0: *time0,
                        time1: *time1,
                    }),
                    none,
                ),
                Shape::Box { min, max } => push(Primitive::Box(AaBox { bounds: Aabb::new(*min, *max) }), none),
                Shape::Polygon(v) => {
                    for t in crate::triangulate(v) {
                        let [a, b, c] = t.map(|i| v[i as usize]);
                        push(Primitive::Triangle(Triangle::new(a, b, c)), none);
                    }
                }
                Shape::Patch(v) => {
                    let points: Vec<Vec3A> = v.iter().map(|p| p.0).collect();
                    for t in crate::triangulate(&points) {
                        let [a, b, c] = t.map(|i| v[i as usize]);
                        let index = out.vertex_normals.len() as u32;
                        out.vertex_normals.push([a.1, b.1, c.1].map(|n| n.normalize_or_zero()));
                        out.primitives.push(Primitive::Triangle(Triangle::new(a.0, b.0, c.0)));
                        out.shading.push(Shading { material: o.material, normals: index });
                    }
                }
                Shape::Plane([p0, p1, p2]) => {
                    if let Some(plane) = Plane::from_points(*p0, *p1, *p2) {
                        push(Primitive::Plane(plane), none);
                    }
                }
                Shape::Cone { base, base_radius, apex, apex_radius } => push(
                    Primitive::Cone(Cone {
                        base: *base,
                        base_radius: *base_radius,
                        apex: *apex,
                        apex_radius: *apex_radius,
                    }),
                    none,
                ),
                Shape::Mesh { vertices, triangles } => {
                    for t in triangles {
                        let [a, b, c] = t.map(|i| vertices[i as usize]);
                        push(Primitive::Triangle(Triangle::new(a, b, c)), none);
                    }
                }
            }
        }
        out
    }

    /// The accelerator `options` ask for, else the scene's hint, else the BVH.
    pub fn accel_kind(&self, options: &RenderOptions) -> AccelKind {
        options.accel.unwrap_or(match self.accel_hint {
            Some(0) => AccelKind::None,
            Some(1) => AccelKind::Grid,
            _ => AccelKind::Bvh,
        })
    }

    /// The scene as it will be rendered with `options`: its view, lights and materials with the
    /// overrides applied.
    fn prepared(&self, options: &RenderOptions) -> Result<Prepared, SceneError> {
        self.validate()?;
        options.validate()?;
        let mut view = self.view;
        if let Some((w, h)) = options.resolution {
            view.width = w;
            view.height = h;
        }
        view.aperture = options.aperture.unwrap_or(view.aperture);
        view.focal = options.focal.unwrap_or(view.focal);
        let lights = self
            .lights
            .iter()
            .map(|l| match (options.area_light_size, l.shape) {
                (Some(size), _) | (None, LightShape::Square(size)) => Light::square(l.position, l.color, size),
                (None, LightShape::Point) => Light::point(l.position, l.color),
                (None, LightShape::Parallelogram { ends, grid }) => {
                    let edges = ends.map(|e| e - l.position);
                    Light { position: l.position + (edges[0] + edges[1]) * 0.5, color: l.color, edges, grid }
                }
            })
            .collect();
        let materials = self
            .materials
            .iter()
            .map(|m| Phong {
                specular_scale: options.specular_scale * options.profile.specular_scale(self.lights.len()),
                roughness: options.roughness.unwrap_or(m.roughness),
                ..*m
            })
            .collect();
        let shutter = options.shutter.map_or_else(|| self.shutter(), |(t0, t1)| Interval::new(t0, t1));
        let spp = options.spp.or(self.spp_hint.map(|s| s.max(1))).unwrap_or(options.settings.spp);
        let settings = RenderSettings { spp, profile: options.profile, ..options.settings };
        settings.validate().map_err(SceneError::Invalid)?;
        if let Some([x0, y0, x1, y1]) = settings.crop {
            if x1 > view.width || y1 > view.height {
                return Err(SceneError::Invalid(format!(
                    "crop {x0} {y0} {x1} {y1}: expected pixels inside the {} x {} image",
                    view.width, view.height
                )));
            }
        }
        let pixels = view.width as u64 * view.height as u64;
        let bytes = limits::render_bytes(self.primitive_count() as u64, pixels);
        if bytes > limits::MAX_RENDER_BYTES {
            return Err(SceneError::Invalid(format!(
                "the render would take about {:.1} GiB ({} primitives, {} x {} pixels), more than the {} GiB allowed",
                bytes as f64 / (1u64 << 30) as f64,
                self.primitive_count(),
                view.width,
                view.height,
                limits::MAX_RENDER_BYTES >> 30
            )));
        }
        Ok(Prepared { view, lights, materials, shutter, settings })
    }

    /// The folders the scene's cubemap is looked for in with `options`.
    pub fn env_search_dirs(&self, options: &RenderOptions) -> Vec<PathBuf> {
        p3f::env_search_dirs(self.base_dir.as_deref(), &options.env_dirs)
    }

    /// What escaping rays see: the cubemap, if the scene has one that `options` use and it is
    /// found, else the background colour (with a warning, or an error under `strict`).
    fn background(&self, options: &RenderOptions, warnings: &mut Vec<Warning>) -> Result<Background, SceneError> {
        let env = match (&self.env, options.use_env) {
            (Some(name), true) => match crate::find_cubemap(name, &self.env_search_dirs(options)) {
                Ok(_) => Some(load_cubemap(name, &self.env_search_dirs(options))?),
                Err(why) if options.strict => {
                    return Err(SceneError::Environment { name: name.clone(), message: why });
                }
                Err(why) => {
                    warnings.push(Warning {
                        file: String::new(),
                        line: 0,
                        column: 0,
                        message: format!("environment map: {why}; escaping rays show the background colour"),
                    });
                    None
                }
            },
            _ => None,
        };
        Ok(Background { color: self.background, env })
    }

    /// Checks that rendering with `options` can start: the scene ([`Scene::validate`]), the
    /// settings and overrides against the [`limits`], the crop inside the image, and the memory the
    /// render would take. [`Scene::render`] does the same before any work.
    pub fn check(&self, options: &RenderOptions) -> Result<(), SceneError> {
        self.prepared(options).map(|_| ())
    }

    /// What rendering with `options` uses.
    pub fn features(&self, options: &RenderOptions) -> Result<Features, SceneError> {
        Ok(self.features_of(&self.prepared(options)?))
    }

    /// The samples per pixel a render with `options` takes (before the sampler rounds them).
    pub fn samples_per_pixel(&self, options: &RenderOptions) -> Result<u32, SceneError> {
        Ok(self.prepared(options)?.settings.spp)
    }

    fn features_of(&self, p: &Prepared) -> Features {
        let Prepared { view, lights, materials, shutter, settings } = p;
        let moving = self
            .objects
            .iter()
            .any(|o| matches!(o.shape, Shape::MovingSphere { center0, center1, .. } if center0 != center1));
        Features {
            antialiasing: settings.antialiasing(),
            area_lights: lights.iter().any(Light::is_area),
            depth_of_field: view.aperture > 0.0,
            fuzzy_reflections: materials.iter().any(|m| m.roughness > 0.0 && m.ks > 0.0 && m.transmittance == 0.0),
            motion_blur: moving && shutter.max > shutter.min,
            transmission: materials.iter().any(|m| m.transmittance > 0.0),
            lights: !lights.is_empty(),
        }
    }

    /// Renders the scene. `on_row` is called once per finished image row.
    ///
    /// The effects the scene and options use ([`Scene::features`]) choose one of a small set of
    /// monomorphised render loops (camera, sampler and soft-shadow mode are type parameters), so
    /// the work of an unused effect is absent from the loop rather than skipped per ray.
    pub fn render(&self, options: &RenderOptions, on_row: &(dyn Fn() + Sync)) -> Result<RenderOutput, SceneError> {
        self.render_passes(options, on_row, None)
    }

    /// Renders progressively: one pass per entry of `passes` (samples per pixel), each with its own
    /// seed, accumulated into one image weighted by samples. After each pass `on_pass` gets the image so
    /// far and the time spent; it returns [`ControlFlow::Break`] to stop there (a time budget). The
    /// passes always sample the pixel area (antialiasing on), so every pass estimates the same image.
    ///
    /// ```
    /// use std::ops::ControlFlow;
    /// use raylume_scene::{p3f, RenderOptions, DEFAULT_SCENE};
    /// let scene = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
    /// let options = RenderOptions { resolution: Some((16, 10)), ..RenderOptions::default() };
    /// let mut seen = Vec::new();
    /// let out = scene.render_progressive(&options, &[1, 3, 4, 8], &mut |p| {
    ///     seen.push(p.samples_per_pixel);
    ///     if p.samples_per_pixel >= 8 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    /// }).unwrap();
    /// assert_eq!(seen, [1, 5, 9]); // 3 and 8 round up to 4 and 9 jittered samples
    /// assert_eq!(out.film.width(), 16);
    /// ```
    pub fn render_progressive(
        &self,
        options: &RenderOptions,
        passes: &[u32],
        on_pass: &mut dyn FnMut(&Progress) -> ControlFlow<()>,
    ) -> Result<RenderOutput, SceneError> {
        if passes.is_empty() || passes.iter().any(|&n| n == 0 || n > limits::MAX_SPP) {
            return Err(SceneError::Invalid(format!("progressive passes need 1..={} samples each", limits::MAX_SPP)));
        }
        self.render_passes(options, &|| {}, Some((passes, on_pass)))
    }

    fn render_passes(
        &self,
        options: &RenderOptions,
        on_row: &(dyn Fn() + Sync),
        progressive: Option<(&[u32], OnPass)>,
    ) -> Result<RenderOutput, SceneError> {
        let prepared = self.prepared(options)?;
        let mut features = self.features_of(&prepared);
        features.antialiasing |= progressive.is_some();
        let mut warnings = Vec::new();
        let background = self.background(options, &mut warnings)?;
        let Prepared { view, lights, materials, shutter, settings } = prepared;
        let Primitives { primitives, shading, vertex_normals } = self.primitives();
        let kind = self.accel_kind(options);
        let build = Instant::now();
        let passes = [settings.spp];
        let job = Job {
            view: &view,
            shutter,
            features,
            settings: &settings,
            on_row,
            sampler: options.sampler,
            passes: progressive.as_ref().map_or(&passes[..], |p| p.0),
        };
        let mut ignore = |_: &Progress| ControlFlow::Continue(());
        let on_pass: OnPass = match progressive {
            Some(p) => p.1,
            None => &mut ignore,
        };
        // One monomorphised path per accelerator: the world is generic over it.
        macro_rules! run {
            ($accel:expr) => {{
                let world = World { accel: $accel, materials, shading, vertex_normals, lights, background };
                let b = build.elapsed().as_secs_f64();
                let (f, s, r) = job.with_camera(&world, on_pass);
                (f, s, b, r)
            }};
        }
        let (film, stats, build_seconds, render_seconds) = match kind {
            AccelKind::None => run!(BruteForce::new(primitives)),
            AccelKind::Bvh => run!(Bvh::new(primitives, shutter)),
            AccelKind::BvhPortable => run!(Bvh::with_kernel(primitives, shutter, BvhBuild::Sah, BvhKernel::Portable)),
            AccelKind::BvhMidpoint => run!(Bvh::with_build(primitives, shutter, BvhBuild::Midpoint)),
            AccelKind::Grid => run!(Grid::new(primitives, shutter, options.grid)),
        };
        Ok(RenderOutput { film, stats, accel: kind, features, build_seconds, render_seconds, warnings })
    }
}

/// The scene with a render's overrides applied.
struct Prepared {
    view: raylume_camera::View,
    lights: Vec<Light>,
    materials: Vec<Phong>,
    shutter: Interval,
    settings: RenderSettings,
}

/// One render's choices, turned into types one decision at a time.
struct Job<'a> {
    view: &'a raylume_camera::View,
    shutter: Interval,
    features: Features,
    settings: &'a RenderSettings,
    on_row: &'a (dyn Fn() + Sync),
    sampler: SamplerKind,
    /// Samples per pixel of each pass (one pass for a plain render).
    passes: &'a [u32],
}

/// What [`Scene::render_progressive`] hands out after each pass.
#[derive(Debug)]
pub struct Progress<'a> {
    /// The image so far: the sample-weighted mean of all passes.
    pub film: &'a Film,
    /// Samples per pixel so far.
    pub samples_per_pixel: u32,
    /// Seconds spent rendering so far (building the accelerator excluded).
    pub seconds: f64,
    /// Index of the pass just finished.
    pub pass: usize,
}

type OnPass<'a> = &'a mut dyn FnMut(&Progress) -> ControlFlow<()>;

impl Job<'_> {
    fn with_camera<A: Accelerator>(&self, world: &World<A, Phong>, on_pass: OnPass) -> (Film, RayStats, f64) {
        let open = self.shutter.min;
        match (self.features.depth_of_field, self.features.motion_blur) {
            (false, false) => self.with_sampler(world, &Pinhole::new(self.view).at_time(open), on_pass),
            (true, false) => self.with_sampler(world, &ThinLens::new(self.view).at_time(open), on_pass),
            (false, true) => self.with_sampler(world, &MotionBlur::new(Pinhole::new(self.view), self.shutter), on_pass),
            (true, true) => self.with_sampler(world, &MotionBlur::new(ThinLens::new(self.view), self.shutter), on_pass),
        }
    }

    fn with_sampler<A: Accelerator, C: Camera>(
        &self,
        world: &World<A, Phong>,
        camera: &C,
        on_pass: OnPass,
    ) -> (Film, RayStats, f64) {
        let s = self.settings;
        let strata = |spp: u32| RenderSettings { spp, ..*s }.strata();
        let stratified = Whitted::<{ SoftShadows::STRATIFIED }>::with_soft_shadows(s);
        match (self.features.antialiasing, self.features.area_lights, self.sampler) {
            (false, false, _) => self.go(world, camera, |seed, _| Centre::new(seed), &Whitted::new(s), on_pass),
            (false, true, _) => self.go(
                world,
                camera,
                |seed, _| Centre::new(seed),
                &Whitted::<{ SoftShadows::GRID }>::with_soft_shadows(s),
                on_pass,
            ),
            (true, false, SamplerKind::Jittered) => {
                self.go(world, camera, |seed, spp| Jittered::new(seed, strata(spp)), &Whitted::new(s), on_pass)
            }
            (true, true, SamplerKind::Jittered) => {
                self.go(world, camera, |seed, spp| Jittered::new(seed, strata(spp)), &stratified, on_pass)
            }
            (true, false, SamplerKind::Independent) => {
                self.go(world, camera, Independent::new, &Whitted::new(s), on_pass)
            }
            (true, true, SamplerKind::Independent) => self.go(world, camera, Independent::new, &stratified, on_pass),
            (true, false, SamplerKind::Sobol) => self.go(world, camera, Sobol::new, &Whitted::new(s), on_pass),
            (true, true, SamplerKind::Sobol) => self.go(world, camera, Sobol::new, &stratified, on_pass),
        }
    }

    /// Renders every pass with its own seed and accumulates them, weighted by samples.
    fn go<A: Accelerator, C: Camera, S: Sampler, I: Integrator>(
        &self,
        world: &World<A, Phong>,
        camera: &C,
        make_sampler: impl Fn(u64, u32) -> S,
        integrator: &I,
        on_pass: OnPass,
    ) -> (Film, RayStats, f64) {
        let start = Instant::now();
        let (mut acc, mut total, mut stats) = (None::<Film>, 0u32, RayStats::default());
        for (pass, &spp) in self.passes.iter().enumerate() {
            // Pass 0 keeps the seed, so a one-pass render is the plain render.
            let seed =
                if pass == 0 { self.settings.seed } else { splitmix(self.settings.seed.wrapping_add(pass as u64)) };
            let settings = RenderSettings { spp, seed, ..*self.settings };
            let sampler = make_sampler(seed, spp);
            let n = sampler.samples_per_pixel();
            let (film, s) = render(world, camera, &sampler, integrator, &settings, self.on_row);
            stats += s;
            acc = Some(match acc {
                None => film,
                Some(prev) => {
                    let (wa, wb) = (total as f32 / (total + n) as f32, n as f32 / (total + n) as f32);
                    let pixels = prev.pixels().iter().zip(film.pixels()).map(|(a, b)| *a * wa + *b * wb).collect();
                    Film::from_pixels(film.width(), film.height(), pixels)
                }
            });
            total += n;
            let film = acc.as_ref().expect("a pass was rendered");
            let progress = Progress { film, samples_per_pixel: total, seconds: start.elapsed().as_secs_f64(), pass };
            if on_pass(&progress).is_break() {
                break;
            }
        }
        let film = acc.unwrap_or_else(|| Film::from_pixels(0, 0, Vec::new()));
        (film, stats, start.elapsed().as_secs_f64())
    }
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
