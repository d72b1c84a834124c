use std::ops::ControlFlow;
use std::time::Instant;

use raylume_accel::{AccelKind, AccelVisitor, Accelerator, Interiors, with_accelerator};
use raylume_camera::{Camera, MotionBlur, Pinhole, ThinLens};
use raylume_geometry::{AaBox, Aabb, Cone, Interval, MovingSphere, Plane, Sphere, Triangle, Vec3A};
use raylume_integrator::{
    Accumulator, Background, Centre, Estimate, Film, Independent, Integrator, Jittered, Light, Observer, RayStats,
    RenderSettings, Sampler, Shading, Sobol, SoftShadows, Whitted, World, render_pass,
};
use raylume_intersect::Primitive;
use raylume_material::Phong;

use raylume_scene::{AccelHint, Scene, SceneError, Shape, Warning};

use crate::options::ADAPTIVE_MIN_PASSES;
use crate::{Features, RenderOptions, RenderOutput, RenderScene, RenderState, SamplerKind, limits, load_cubemap};

/// The primitives of a scene with their shading data, in one order.
pub struct Primitives {
    /// The primitives.
    pub primitives: Vec<Primitive>,
    /// Shading of each primitive.
    pub shading: Vec<Shading>,
    /// Vertex normals referenced by [`Shading::normals`].
    pub vertex_normals: Vec<[Vec3A; 3]>,
}

impl RenderScene for Scene {
    fn primitives(&self) -> Primitives {
        let count = self.primitive_count();
        let mut out = Primitives {
            primitives: Vec::with_capacity(count),
            shading: Vec::with_capacity(count),
            vertex_normals: Vec::new(),
        };
        let none = None;
        for o in &self.objects {
            let mut push = |p: Primitive, normals: Option<u32>| {
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
                    for t in raylume_scene::triangulate(v) {
                        let [a, b, c] = t.map(|i| v[i as usize]);
                        push(Primitive::Triangle(Triangle::new(a, b, c)), none);
                    }
                }
                Shape::Patch(v) => {
                    let points: Vec<Vec3A> = v.iter().map(|p| p.0).collect();
                    for t in raylume_scene::triangulate(&points) {
                        let [a, b, c] = t.map(|i| v[i as usize]);
                        let index = out.vertex_normals.len() as u32;
                        out.vertex_normals.push([a.1, b.1, c.1].map(|n| n.normalize_or_zero()));
                        out.primitives.push(Primitive::Triangle(Triangle::new(a.0, b.0, c.0)));
                        out.shading.push(Shading { material: o.material, normals: Some(index) });
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
                Shape::Mesh { vertices, triangles, normals } if normals.is_empty() => {
                    for t in triangles {
                        let [a, b, c] = t.map(|i| vertices[i as usize]);
                        push(Primitive::Triangle(Triangle::new(a, b, c)), none);
                    }
                }
                Shape::Mesh { vertices, triangles, normals } => {
                    for (t, n) in triangles.iter().zip(normals) {
                        let [a, b, c] = t.map(|i| vertices[i as usize]);
                        let index = out.vertex_normals.len() as u32;
                        out.vertex_normals.push(n.map(|n| n.normalize_or_zero()));
                        out.primitives.push(Primitive::Triangle(Triangle::new(a, b, c)));
                        out.shading.push(Shading { material: o.material, normals: Some(index) });
                    }
                }
            }
        }
        out
    }

    fn accel_kind(&self, options: &RenderOptions) -> AccelKind {
        options.accel.unwrap_or(match self.accel_hint {
            Some(AccelHint::None) => AccelKind::None,
            Some(AccelHint::Grid) => AccelKind::Grid,
            Some(AccelHint::Bvh) | None => AccelKind::Bvh,
        })
    }

    fn check(&self, options: &RenderOptions) -> Result<(), SceneError> {
        self.prepared(options).map(|_| ())
    }

    fn features(&self, options: &RenderOptions) -> Result<Features, SceneError> {
        Ok(self.features_of(&self.prepared(options)?))
    }

    fn samples_per_pixel(&self, options: &RenderOptions) -> Result<u32, SceneError> {
        Ok(self.prepared(options)?.settings.spp)
    }

    fn render<O: Observer + ?Sized>(&self, options: &RenderOptions, observer: &O) -> Result<RenderOutput, SceneError> {
        self.render_passes(options, &Dyn(observer), None)
    }

    fn render_progressive<O: Observer + ?Sized>(
        &self,
        options: &RenderOptions,
        observer: &O,
        mut on_pass: impl FnMut(&Progress) -> ControlFlow<()>,
    ) -> Result<RenderOutput, SceneError> {
        self.render_passes(options, &Dyn(observer), Some(&mut on_pass))
    }
}

/// The steps of a render, private to this module.
trait Steps {
    fn prepared(&self, options: &RenderOptions) -> Result<Prepared, SceneError>;
    fn background(&self, options: &RenderOptions, warnings: &mut Vec<Warning>) -> Result<Background, SceneError>;
    fn features_of(&self, p: &Prepared) -> Features;
    fn render_passes(
        &self,
        options: &RenderOptions,
        observer: &dyn Observer,
        progressive: Option<OnPass>,
    ) -> Result<RenderOutput, SceneError>;
}

impl Steps for Scene {
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
        let lights = match options.area_light_size {
            // Every light becomes a square of this side centred on its position.
            Some(size) => self.lights.iter().map(|l| Light::square(l.position, l.color, size)).collect(),
            None => self.lights.clone(),
        };
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
        // The film and its accumulator hold the crop's pixels only (a farm's region is a crop).
        let [x0, y0, x1, y1] = settings.crop.unwrap_or([0, 0, view.width, view.height]);
        let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
        let bytes = limits::render_bytes(self.primitive_count() as u64, w as u64 * h as u64);
        let (allowed, what) = limits::render_bytes_allowed();
        if bytes > allowed {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            return Err(SceneError::Invalid(format!(
                "the render would take about {:.2} GiB ({} primitives, {w} x {h} pixels), more than the {:.2} GiB {what}",
                gib(bytes),
                self.primitive_count(),
                gib(allowed)
            )));
        }
        Ok(Prepared { view, lights, materials, shutter, settings })
    }

    /// What escaping rays see: the cubemap, if the scene has one that `options` use and it is
    /// found, else the background colour (with a warning, or an error under `strict`).
    fn background(&self, options: &RenderOptions, warnings: &mut Vec<Warning>) -> Result<Background, SceneError> {
        let env = match (&self.env, options.use_env) {
            (Some(name), true) => match raylume_scene::find_cubemap(name, &self.cubemap_dirs(&options.env_dirs)) {
                Ok(_) => Some(load_cubemap(name, &self.cubemap_dirs(&options.env_dirs))?),
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

    fn render_passes(
        &self,
        options: &RenderOptions,
        observer: &dyn Observer,
        progressive: Option<OnPass>,
    ) -> Result<RenderOutput, SceneError> {
        let started = Instant::now();
        let prepared = self.prepared(options)?;
        let mut features = self.features_of(&prepared);
        let plan = Plan::new(options, prepared.settings.spp);
        if plan.end_pass > plan.passes && !plan.adaptive && !plan.budget() {
            return Err(SceneError::Invalid(format!(
                "passes {}..{}: the render has {} passes of {} samples",
                plan.first_pass, plan.end_pass, plan.passes, plan.pass_spp
            )));
        }
        // Passes are independent only if each draws its own samples over the pixel's area.
        features.antialiasing |= plan.passes > 1 || plan.budget();
        let mut warnings = Vec::new();
        let background = self.background(options, &mut warnings)?;
        // With a cubemap, a scene of no objects shows the sky, as it may be meant to.
        if self.objects.is_empty() && background.env.is_none() {
            let message = "the scene has no objects: the image is its background colour";
            if options.strict {
                return Err(SceneError::Invalid(format!("{message} (an error when rendering strictly)")));
            }
            warnings.push(Warning { file: String::new(), line: 0, column: 0, message: message.to_owned() });
        }
        if self.lights.is_empty() && !self.objects.is_empty() {
            let message = "the scene has no lights: its surfaces show only what they reflect or transmit (the \
                           shading model has no ambient term)";
            if options.strict {
                return Err(SceneError::Invalid(format!("{message} (an error when rendering strictly)")));
            }
            warnings.push(Warning { file: String::new(), line: 0, column: 0, message: message.to_owned() });
        }
        let Prepared { view, lights, materials, shutter, settings } = prepared;
        let Primitives { primitives, shading, vertex_normals } = self.primitives();
        let kind = self.accel_kind(options);
        let build = Instant::now();
        let job = Job {
            view: &view,
            shutter,
            features,
            settings: &settings,
            observer,
            sampler: options.sampler,
            plan,
            started,
            resume: options.resume.as_deref(),
        };
        let mut go_on = |_: &Progress| ControlFlow::Continue(());
        let on_pass: OnPass = progressive.unwrap_or(&mut go_on);
        let glass = |i: usize| materials[shading[i].material as usize].transmittance > 0.0;
        let interiors = Interiors::new(&primitives, glass, shutter);
        let parts = WorldParts { materials, shading, vertex_normals, lights, interiors, background };
        let visitor = RenderWith { parts, build, job: &job, on_pass };
        let (rendered, build_seconds) = with_accelerator(kind, primitives, shutter, options.grid, visitor)?;
        let Rendered { accumulator, stats, seconds: render_seconds, samples_per_pass } = rendered;
        let samples = accumulator.passes().iter().map(|&k| k as u64).sum::<u64>() * samples_per_pass;
        let passes = accumulator.passes().iter().copied().max().unwrap_or(0);
        let (estimate, variance) = (accumulator.estimate(), accumulator.variance_film());
        let mean_samples_per_pixel = samples as f64 / accumulator.passes().len().max(1) as f64;
        Ok(RenderOutput {
            film: accumulator.into_film(),
            stats,
            accel: kind,
            features,
            samples_per_pixel: passes as u64 * samples_per_pass,
            mean_samples_per_pixel,
            passes,
            estimate,
            variance,
            build_seconds,
            render_seconds,
            warnings,
        })
    }
}

/// An observer of any size behind one `dyn Observer`, so the render loops are compiled once
/// whatever the caller observes with.
struct Dyn<'a, O: ?Sized>(&'a O);

impl<O: Observer + ?Sized> Observer for Dyn<'_, O> {
    fn row_done(&self) {
        self.0.row_done()
    }

    fn rows_done(&self, first_row: u32, width: u32, pixels: &[raylume_geometry::Vec3]) {
        self.0.rows_done(first_row, width, pixels)
    }

    fn cancelled(&self) -> bool {
        self.0.cancelled()
    }
}

/// A world without its accelerator.
struct WorldParts {
    materials: Vec<Phong>,
    shading: Vec<Shading>,
    vertex_normals: Vec<[Vec3A; 3]>,
    lights: Vec<Light>,
    interiors: Interiors,
    background: Background,
}

/// Renders a job once the accelerator is built: one monomorphised render loop per accelerator.
struct RenderWith<'a, 'p> {
    parts: WorldParts,
    build: Instant,
    job: &'a Job<'a>,
    on_pass: OnPass<'p>,
}

impl AccelVisitor for RenderWith<'_, '_> {
    /// What the passes made, and the seconds spent building the accelerator.
    type Output = Result<(Rendered, f64), SceneError>;

    fn visit<A: Accelerator>(self, accel: A) -> Self::Output {
        let WorldParts { materials, shading, vertex_normals, lights, interiors, background } = self.parts;
        let world = World { accel, materials, shading, vertex_normals, lights, interiors, background };
        let build_seconds = self.build.elapsed().as_secs_f64();
        Ok((self.job.with_camera(&world, self.on_pass)?, build_seconds))
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
    observer: &'a dyn Observer,
    sampler: SamplerKind,
    plan: Plan,
    /// When the render was asked for (the time limit counts from here).
    started: Instant,
    /// Where a render that stopped is resumed from.
    resume: Option<&'a RenderState>,
}

/// How a render's samples are split into passes, and when it stops.
#[derive(Clone, Copy, Debug)]
struct Plan {
    /// Samples per pixel of each pass (before the sampler rounds them).
    pass_spp: u32,
    /// Passes of a render without a budget (with adaptive sampling: the samples of this many
    /// passes over the whole image).
    passes: u32,
    /// The passes rendered, `first_pass..end_pass` ([`RenderOptions::pass_range`]).
    first_pass: u32,
    end_pass: u32,
    time_limit: Option<f64>,
    noise_threshold: Option<f64>,
    adaptive: bool,
}

impl Plan {
    fn new(options: &RenderOptions, spp: u32) -> Self {
        let (time_limit, noise_threshold) = (options.time_limit, options.noise_threshold);
        let budget = time_limit.is_some() || noise_threshold.is_some();
        // What the sampler draws for `m` samples asked: a jittered sampler rounds up to a square.
        let drawn = |m: u32| match options.sampler {
            SamplerKind::Jittered => RenderSettings { spp: m, ..RenderSettings::default() }.strata().pow(2),
            SamplerKind::Independent | SamplerKind::Sobol => m,
        };
        // A fixed render splits its samples into at most `passes` passes, as evenly as the sampler
        // allows: the split that draws the fewest samples in all, and of those the most passes.
        // Budgeted renders draw passes of `spp / passes` for as long as they go on.
        let passes = if budget {
            options.passes
        } else {
            (2..=options.passes.min(spp))
                .min_by_key(|&k| (k as u64 * drawn(spp.div_ceil(k)) as u64, std::cmp::Reverse(k)))
                .unwrap_or(1)
        };
        let (first_pass, end_pass) = options.pass_range.unwrap_or((0, passes));
        Self {
            pass_spp: spp.div_ceil(passes).max(1),
            passes,
            first_pass,
            end_pass,
            time_limit,
            noise_threshold,
            adaptive: options.adaptive,
        }
    }

    fn budget(&self) -> bool {
        self.time_limit.is_some() || self.noise_threshold.is_some()
    }
}

/// How a render splits its samples into passes ([`RenderOptions::passes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassSplit {
    /// The passes of a render without a budget or adaptive sampling; `None` when a budget or
    /// adaptive sampling decides.
    pub passes: Option<u32>,
    /// Samples per pixel each pass draws (a jittered pass rounds its share up to a square).
    pub samples_per_pass: u32,
}

/// How a render with `options` draws `spp` samples per pixel (the scene's, as
/// [`RenderScene::samples_per_pixel`] gives them).
///
/// ```
/// use raylume_render::{pass_split, PassSplit, RenderOptions};
/// let split = pass_split(&RenderOptions::default(), 16);
/// assert_eq!(split, PassSplit { passes: Some(4), samples_per_pass: 4 });
/// assert_eq!(pass_split(&RenderOptions::default(), 1).passes, Some(1));
/// ```
pub fn pass_split(options: &RenderOptions, spp: u32) -> PassSplit {
    let plan = Plan::new(options, spp);
    let antialiasing = spp > 1 || plan.passes > 1 || plan.budget();
    let samples_per_pass = match (antialiasing, options.sampler) {
        (false, _) => 1,
        (true, SamplerKind::Jittered) => {
            RenderSettings { spp: plan.pass_spp, ..RenderSettings::default() }.strata().pow(2)
        }
        (true, SamplerKind::Independent | SamplerKind::Sobol) => plan.pass_spp,
    };
    let passes = (!plan.budget() && !plan.adaptive).then_some(plan.passes);
    PassSplit { passes, samples_per_pass }
}

/// What [`RenderScene::render_progressive`] hands out after each pass.
#[derive(Debug)]
pub struct Progress<'a> {
    /// The image so far: each pixel's mean over its passes.
    pub film: &'a Film,
    /// Samples per pixel so far (what the samplers drew, after rounding; with adaptive sampling,
    /// what the most sampled pixels got).
    pub samples_per_pixel: u64,
    /// Samples per pixel so far over the whole image.
    pub mean_samples_per_pixel: f64,
    /// Seconds spent rendering so far (building the accelerator excluded).
    pub seconds: f64,
    /// Index of the pass just finished.
    pub pass: usize,
    /// Pixels the pass just finished rendered (all of them but with adaptive sampling).
    pub pixels_rendered: usize,
    /// The image's estimated error so far (from the second pass on).
    pub estimate: Option<Estimate>,
    /// The per-pixel statistics of the passes so far: the per-pixel variance, pass counts.
    pub accumulator: &'a Accumulator,
    /// The image of the pass just finished alone (black where an adaptive pass left pixels out).
    pub pass_film: &'a Film,
}

/// After each pass: `Continue` lets the render go on (as its plan and budgets say), `Break` stops it.
type OnPass<'a> = &'a mut dyn FnMut(&Progress) -> ControlFlow<()>;

impl Job<'_> {
    fn with_camera<A: Accelerator>(&self, world: &World<A, Phong>, on_pass: OnPass) -> Result<Rendered, SceneError> {
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
    ) -> Result<Rendered, SceneError> {
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

    /// Renders passes, each with its own seed, and accumulates them per pixel, until the plan or
    /// `on_pass` says stop or the observer cancels.
    fn go<A: Accelerator, C: Camera, S: Sampler, I: Integrator>(
        &self,
        world: &World<A, Phong>,
        camera: &C,
        make_sampler: impl Fn(u64, u32) -> S,
        integrator: &I,
        on_pass: OnPass,
    ) -> Result<Rendered, SceneError> {
        let start = Instant::now();
        let plan = self.plan;
        let (w, h) = camera.resolution();
        let [x0, y0, x1, y1] = self.settings.crop.unwrap_or([0, 0, w, h]);
        let (cw, ch) = (x1.min(w).saturating_sub(x0), y1.min(h).saturating_sub(y0));
        let pixels = cw as usize * ch as usize;
        let (mut accumulator, first_pass) = match self.resume {
            Some(state) => {
                if !state.fits(cw, ch) || !(plan.first_pass..plan.end_pass).contains(&state.next_pass) {
                    return Err(SceneError::Invalid(format!(
                        "resuming a render: the state is of another render (expected {cw} x {ch} pixels and a pass from {} to {})",
                        plan.first_pass,
                        plan.end_pass - 1
                    )));
                }
                (state.accumulator.clone(), state.next_pass)
            }
            None => (Accumulator::new(cw, ch), plan.first_pass),
        };
        // The rows of the first pass that the stopped render finished are not rendered again.
        let partial = self.resume.and_then(|s| s.partial.as_ref());
        let left: Option<Vec<bool>> =
            partial.map(|p| p.rows_done.iter().flat_map(|&done| std::iter::repeat_n(!done, cw as usize)).collect());
        let mut stats = RayStats::default();
        let mut active: Option<Vec<bool>> = None;
        // A new accumulator's counts are all zero: not read, so that their pages are mapped only as
        // the first pass writes them.
        let mut pixel_passes = match self.resume {
            Some(_) => accumulator.passes().iter().map(|&k| k as u64).sum::<u64>(),
            None => 0,
        };
        let mut samples_per_pass = 0u64;
        for pass in first_pass as usize.. {
            // Pass 0 keeps the seed, so a one-pass render is the plain render.
            let seed = if pass == 0 {
                self.settings.seed
            } else {
                raylume_integrator::sampler::splitmix(self.settings.seed.wrapping_add(pass as u64))
            };
            let settings = RenderSettings { spp: plan.pass_spp, seed, ..*self.settings };
            let sampler = make_sampler(seed, plan.pass_spp);
            samples_per_pass = sampler.samples_per_pixel() as u64;
            let pass_start = Instant::now();
            let mask = active.as_deref();
            let resumed = if pass == first_pass as usize { partial.zip(left.as_deref()) } else { None };
            let (mut film, s) = match resumed {
                Some((_, left)) => {
                    render_pass(world, camera, &sampler, integrator, &settings, self.observer, Some(left))
                }
                None => render_pass(world, camera, &sampler, integrator, &settings, self.observer, mask),
            };
            if self.observer.cancelled() {
                return Err(SceneError::Cancelled);
            }
            if let Some((done, left)) = resumed {
                let pixels = film.pixels().iter().zip(done.film.pixels()).zip(left);
                let joined = pixels.map(|((&new, &old), &rendered)| if rendered { new } else { old }).collect();
                film = Film::from_pixels(cw, ch, joined);
            }
            let pass_seconds = pass_start.elapsed().as_secs_f64();
            stats += s;
            // A pixel's first pass is the image itself: it is not copied.
            let film = accumulator.add_film(film, mask);
            let rendered = mask.map_or(pixels, |m| m.iter().filter(|&&a| a).count());
            pixel_passes += rendered as u64;
            let image = accumulator.image();
            let estimate = accumulator.estimate();
            let most = accumulator.passes().iter().copied().max().unwrap_or(0) as u64;
            let progress = Progress {
                film: image,
                samples_per_pixel: most * samples_per_pass,
                mean_samples_per_pixel: (pixel_passes * samples_per_pass) as f64 / pixels.max(1) as f64,
                seconds: start.elapsed().as_secs_f64(),
                pass,
                pixels_rendered: rendered,
                estimate,
                accumulator: &accumulator,
                pass_film: film.as_ref().unwrap_or(image),
            };
            if on_pass(&progress).is_break() || (most + 1) * samples_per_pass > limits::MAX_SPP as u64 {
                break;
            }
            if plan.noise_threshold.is_some_and(|e| estimate.is_some_and(|est| est.rmse <= e)) {
                break;
            }
            let uniform_passes = pass as u32 + 1 < ADAPTIVE_MIN_PASSES.max(2);
            let next = if plan.adaptive && !uniform_passes { accumulator.noisy_pixels() } else { None };
            let next_pixels = next.as_ref().map_or(pixels, |m| m.iter().filter(|&&a| a).count());
            if next_pixels == 0 {
                break;
            }
            if let Some(limit) = plan.time_limit {
                let expected = pass_seconds * next_pixels as f64 / rendered.max(1) as f64;
                if self.started.elapsed().as_secs_f64() + expected > limit {
                    break;
                }
            } else if !plan.budget() {
                let done = if plan.adaptive {
                    pixel_passes >= plan.passes as u64 * pixels as u64
                } else {
                    pass + 1 >= plan.end_pass as usize
                };
                if done {
                    break;
                }
            }
            active = next;
        }
        Ok(Rendered { accumulator, stats, seconds: start.elapsed().as_secs_f64(), samples_per_pass })
    }
}

/// What the passes of a render made.
struct Rendered {
    accumulator: Accumulator,
    stats: RayStats,
    seconds: f64,
    samples_per_pass: u64,
}
