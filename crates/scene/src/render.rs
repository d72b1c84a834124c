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

use crate::{Scene, SceneError, Shape, load_cubemap, p3f};

/// How to render a scene: the integrator's settings plus overrides of what the scene file says.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Depth, samples, seed, Fresnel mode, light grid, crop.
    pub settings: RenderSettings,
    /// The accelerator; `None` takes the scene's `accel` hint, else the BVH.
    pub accel: Option<AccelKind>,
    /// Overrides the scene's resolution (the vertical field of view is kept).
    pub resolution: Option<(u32, u32)>,
    /// Folders searched, in order, for the scene's `env` cubemap.
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

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            settings: RenderSettings::default(),
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
                    for i in 1..v.len().saturating_sub(1) {
                        push(Primitive::Triangle(Triangle::new(v[0], v[i], v[i + 1])), none);
                    }
                }
                Shape::Patch(v) => {
                    for i in 1..v.len().saturating_sub(1) {
                        let normals = [v[0].1, v[i].1, v[i + 1].1].map(|n| n.normalize_or_zero());
                        let index = out.vertex_normals.len() as u32;
                        out.vertex_normals.push(normals);
                        let mut push = |p: Primitive, normals: u32| {
                            out.primitives.push(p);
                            out.shading.push(Shading { material: o.material, normals });
                        };
                        push(Primitive::Triangle(Triangle::new(v[0].0, v[i].0, v[i + 1].0)), index);
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
    fn prepared(
        &self,
        options: &RenderOptions,
    ) -> Result<(raylume_camera::View, Vec<Light>, Vec<Phong>, Interval), SceneError> {
        let mut view = self.view;
        if let Some((w, h)) = options.resolution {
            if w == 0
                || h == 0
                || w > p3f::MAX_RESOLUTION
                || h > p3f::MAX_RESOLUTION
                || w as u64 * h as u64 > p3f::MAX_PIXELS
            {
                return Err(SceneError::Invalid(format!(
                    "resolution {w} x {h}: each side must be 1..={} and the image at most {} pixels",
                    p3f::MAX_RESOLUTION,
                    p3f::MAX_PIXELS
                )));
            }
            view.width = w;
            view.height = h;
        }
        let check = |name: &str, v: Option<f32>, ok: fn(f32) -> bool| match v {
            Some(x) if !x.is_finite() || !ok(x) => Err(SceneError::Invalid(format!("{name} {x} is out of range"))),
            _ => Ok(()),
        };
        check("area light size", options.area_light_size, |x| x >= 0.0)?;
        check("roughness", options.roughness, |x| (0.0..=1.0).contains(&x))?;
        check("aperture", options.aperture, |x| x >= 0.0)?;
        check("focal distance", options.focal, |x| x > 0.0)?;
        view.aperture = options.aperture.unwrap_or(view.aperture);
        view.focal = options.focal.unwrap_or(view.focal);
        let lights = self
            .lights
            .iter()
            .map(|l| Light { position: l.position, color: l.color, size: options.area_light_size.unwrap_or(l.size) })
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
        let shutter = match options.shutter {
            Some((t0, t1)) if t0.is_finite() && t1.is_finite() && t0 <= t1 => Interval::new(t0, t1),
            Some((t0, t1)) => return Err(SceneError::Invalid(format!("shutter [{t0}, {t1}] is not an interval"))),
            None => self.shutter(),
        };
        Ok((view, lights, materials, shutter))
    }

    /// What rendering with `options` uses.
    pub fn features(&self, options: &RenderOptions) -> Result<Features, SceneError> {
        let (view, lights, materials, shutter) = self.prepared(options)?;
        Ok(self.features_of(&view, &lights, &materials, shutter, &options.settings))
    }

    fn features_of(
        &self,
        view: &raylume_camera::View,
        lights: &[Light],
        materials: &[Phong],
        shutter: Interval,
        settings: &RenderSettings,
    ) -> Features {
        let moving = self
            .objects
            .iter()
            .any(|o| matches!(o.shape, Shape::MovingSphere { center0, center1, .. } if center0 != center1));
        Features {
            antialiasing: settings.antialiasing(),
            area_lights: lights.iter().any(|l| l.size > 0.0),
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
    /// let (scene, _) = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap();
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
        if passes.is_empty() || passes.contains(&0) {
            return Err(SceneError::Invalid("progressive passes need at least one sample each".to_owned()));
        }
        self.render_passes(options, &|| {}, Some((passes, on_pass)))
    }

    fn render_passes(
        &self,
        options: &RenderOptions,
        on_row: &(dyn Fn() + Sync),
        progressive: Option<(&[u32], OnPass)>,
    ) -> Result<RenderOutput, SceneError> {
        let (view, lights, materials, shutter) = self.prepared(options)?;
        let mut features = self.features_of(&view, &lights, &materials, shutter, &options.settings);
        features.antialiasing |= progressive.is_some();
        let env = match (&self.env, options.use_env) {
            (Some(name), true) => Some(load_cubemap(name, &options.env_dirs)?),
            _ => None,
        };
        let background = Background { color: self.background, env };
        let Primitives { primitives, shading, vertex_normals } = self.primitives();
        let kind = self.accel_kind(options);
        let build = Instant::now();
        let passes = [options.settings.spp];
        let settings = RenderSettings { profile: options.profile, ..options.settings };
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
        Ok(RenderOutput { film, stats, accel: kind, features, build_seconds, render_seconds })
    }
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
