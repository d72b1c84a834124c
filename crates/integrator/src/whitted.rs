#[cfg(doc)]
use raylume_accel::Interiors;
use raylume_accel::{Accelerator, PrimitiveHit};
use raylume_geometry::{Interval, Ray, Vec2, Vec3, Vec3A, offset_ray_origin, sampling::uniform_ball};
use raylume_intersect::Hit;
use raylume_material::{FresnelMode, Material, fresnel_refract, reflect, refract};

use crate::sampler::SampleSource;
use crate::{Integrator, Light, Profile, RayStats, RenderSettings, World};

/// How area lights are sampled; the const parameter of [`Whitted`].
pub struct SoftShadows;

impl SoftShadows {
    /// Every light is a point: one shadow ray each, and no code for area lights at all.
    pub const NONE: u8 = 0;
    /// Area lights as a fixed `N x N` grid of point lights of colour / N^2 (without antialiasing).
    pub const GRID: u8 = 1;
    /// Area lights sampled once per camera sample, stratified with the pixel samples (with antialiasing).
    pub const STRATIFIED: u8 = 2;
}

/// Whitted ray tracing as the course defines it: Blinn-Phong from each light not in shadow, then
/// mirror reflection for opaque specular surfaces (perturbed within a sphere of radius `roughness`
/// for rough ones), or Fresnel-weighted reflection and refraction for transmissive ones, up to a
/// maximum depth; the colour is clamped to [0, 1] at every level.
///
/// `SOFT` is one of the [`SoftShadows`] modes. It is a const parameter so that a scene without area
/// lights runs a loop in which the area-light code does not exist.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Whitted<const SOFT: u8> {
    max_depth: u32,
    fresnel: FresnelMode,
    grid: u32,
    profile: Profile,
    min_weight: f32,
}

impl Whitted<{ SoftShadows::NONE }> {
    /// The integrator for the given settings (depth and Fresnel mode), with point lights only.
    pub fn new(settings: &RenderSettings) -> Self {
        Self::with_soft_shadows(settings)
    }
}

impl<const SOFT: u8> Whitted<SOFT> {
    /// The integrator with the soft-shadow mode `SOFT`; a depth beyond [`crate::MAX_DEPTH`] is
    /// traced to that depth (the stack holds one frame per level).
    pub fn with_soft_shadows(settings: &RenderSettings) -> Self {
        Self {
            max_depth: settings.max_depth.clamp(1, crate::MAX_DEPTH),
            fresnel: settings.fresnel,
            grid: settings.light_grid.clamp(1, crate::MAX_LIGHT_GRID),
            profile: settings.profile,
            min_weight: settings.min_weight,
        }
    }

    /// The light arriving from `light` at `above` (a point offset off the surface; inside the glass
    /// primitive `inside`, if it is one). `known` is what a batch has found already for a point light,
    /// or for an area light sampled once per sample (its point drawn by the batch): the direction to it
    /// if it lights the point, else zero.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn direct<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        light: &Light,
        inside: Option<u32>,
        above: Vec3A,
        n: Vec3A,
        ns: Vec3A,
        wo: Vec3A,
        material: &M,
        time: f32,
        known: Option<Vec3A>,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        let unoccluded = |target: Vec3A, stats: &mut RayStats| -> Option<Vec3A> {
            let (ray, dist) = shadow_ray(above, n, target, time)?;
            stats.shadow += 1;
            let occluded =
                inside.is_some_and(|p| world.interiors.occluded(&ray, dist, p)) || world.accel.occluded(&ray, dist);
            (!occluded).then_some(ray.dir)
        };
        let point = SOFT == SoftShadows::NONE || !light.is_area();
        if point || (SOFT == SoftShadows::STRATIFIED && known.is_some()) {
            let lit = match known {
                Some(wi) => (wi != Vec3A::ZERO).then_some(wi),
                None => unoccluded(light.centre(), stats),
            };
            return match lit {
                Some(wi) => light.color * material.local(ns, wo, wi),
                None => Vec3::ZERO,
            };
        }
        if SOFT == SoftShadows::GRID {
            let g = if light.grid() > 0 { light.grid() } else { self.grid };
            let mut sum = Vec3::ZERO;
            for i in 0..g {
                for j in 0..g {
                    let u = (i as f32 + 0.5) / g as f32;
                    let v = (j as f32 + 0.5) / g as f32;
                    if let Some(wi) = unoccluded(area_point(light, Vec2::new(u, v)), stats) {
                        sum += material.local(ns, wo, wi);
                    }
                }
            }
            light.color * sum / (g * g) as f32
        } else {
            match unoccluded(area_point(light, sample.light()), stats) {
                Some(wi) => light.color * material.local(ns, wo, wi),
                None => Vec3::ZERO,
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn trace<const PRUNE: bool, A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        t_min: f32,
        depth: u32,
        weight: f32,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        let found = world.accel.closest_hit(ray, Interval::new(t_min, f32::INFINITY));
        self.shade::<PRUNE, _, _, _>(world, ray, found, depth, weight, sample, stats)
    }

    /// [`Whitted::shade`] as a call of its own, for the recursion.
    #[allow(clippy::too_many_arguments)]
    fn shade_found<const PRUNE: bool, A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        found: Option<PrimitiveHit>,
        depth: u32,
        weight: f32,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        self.shade::<PRUNE, _, _, _>(world, ray, found, depth, weight, sample, stats)
    }

    /// The colour along `ray` whose closest hit is `found`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn shade<const PRUNE: bool, A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        found: Option<PrimitiveHit>,
        depth: u32,
        weight: f32,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        match found {
            Some(found) => self.shade_surface::<PRUNE, _, _, _>(
                world,
                ray,
                &surface(world, ray, &found),
                depth,
                weight,
                |_| None,
                None,
                sample,
                stats,
            ),
            None => self.escape(world, ray, depth),
        }
    }

    /// Whether a ray whose colour enters the sample's with `weight` (the product of the weights on
    /// its way from the camera, at most 1 for the course's materials) is traced: with `PRUNE`, not
    /// if it is below [`RenderSettings::min_weight`]. A weight that is not a number is traced.
    /// Without `PRUNE` every ray is, and the weights passed along are not formed.
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn traces<const PRUNE: bool>(&self, weight: f32) -> bool {
        !PRUNE || !(weight < self.min_weight)
    }

    /// The colour seen along `ray` when it hits nothing.
    #[inline(always)]
    fn escape<A: Accelerator, M: Material>(&self, world: &World<A, M>, ray: &Ray, depth: u32) -> Vec3 {
        let bg = world.background.eval(ray.dir);
        // The course profile dims the background seen by deep reflections; plain returns it as is.
        if self.profile == Profile::Plain { bg } else { bg * self.profile.escape_weight(depth) }
    }

    /// The colour along `ray` whose closest hit is `surface`; `known(l)` is what a batch has found
    /// already for the point light `l` (see [`Whitted::direct`]), and `reflected` the closest hit of
    /// the mirror reflection if a batch has found it (only for a mirror that reflects exactly, see
    /// [`reflects_exactly`]).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn shade_surface<const PRUNE: bool, A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        surface: &Surface,
        depth: u32,
        weight: f32,
        known: impl Fn(usize) -> Option<Vec3A>,
        reflected: Option<Option<PrimitiveHit>>,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        let &Surface { hit, primitive, material, entering, n, ns, above } = surface;
        let material = &world.materials[material as usize];
        let wo = -ray.dir;

        let mut color = Vec3::ZERO;
        // Inside a glass solid, shadow rays meet its surface on their way out.
        let inside = (!entering && material.dielectric().is_some()).then_some(primitive);
        // The light the lights give, added to `color`: the first term of its sum, and the first
        // samples the surface draws. A dielectric's reflected and refracted rays find their closest
        // hits (which draw none) before the lights' shadow rays are traced: none of these queries
        // waits on another, and the processor overlaps them.
        macro_rules! add_direct {
            () => {
                for (l, light) in world.lights.iter().enumerate() {
                    color += self.direct(
                        world,
                        light,
                        inside,
                        above,
                        n,
                        ns,
                        wo,
                        material,
                        ray.time,
                        known(l),
                        sample,
                        stats,
                    );
                }
            };
        }
        if depth >= self.max_depth || material.dielectric().is_none() {
            add_direct!();
        }

        if depth < self.max_depth {
            if let Some(d) = material.dielectric() {
                // A ray leaving the solid uses the inverse index ratio.
                let eta = if entering { 1.0 / d.ior } else { d.ior };
                let cos_i = wo.dot(ns);
                // The exact equations share their terms with the refraction where the cosine is not
                // negative (a shading normal can face away from `wo`); otherwise each on its own.
                let (kr, refracted) = if self.fresnel == FresnelMode::Exact && cos_i >= 0.0 {
                    fresnel_refract(ray.dir, ns, cos_i, eta)
                } else {
                    let kr = self.fresnel.reflectance(cos_i.max(0.0), eta);
                    (kr, if kr < 1.0 { refract(ray.dir, ns, eta) } else { None })
                };
                let r = Ray::with_time(above, reflect(ray.dir, ns), ray.time);
                let all = Interval::new(0.0, f32::INFINITY);
                // The ray that goes (or stays) inside the solid: inside a glass sphere, its hit is on
                // the sphere or on the few shapes that reach into it (`Interiors`).
                macro_rules! closest_hit {
                    ($ray:expr, $goes_in:expr) => {
                        match $goes_in {
                            true => world
                                .interiors
                                .closest_hit($ray, all, primitive)
                                .or_else(|| world.accel.closest_hit($ray, all)),
                            false => world.accel.closest_hit($ray, all),
                        }
                    };
                }
                // A ray whose colour would be weighed by zero (as the reflection off glass of index 1
                // often is) adds exactly nothing, and is not traced.
                let kt = (1.0 - kr) * d.transmittance;
                let (wr, wt) = if PRUNE { (weight * kr, weight * kt) } else { (weight, weight) };
                let reflects = kr != 0.0 && self.traces::<PRUNE>(wr);
                match refracted.filter(|_| kr < 1.0 && kt != 0.0 && self.traces::<PRUNE>(wt)) {
                    Some(dir) if reflects => {
                        stats.reflection += 1;
                        stats.refraction += 1;
                        let below = offset_ray_origin(hit.point, hit.error, -n);
                        let t = Ray::with_time(below, dir, ray.time);
                        let (found_r, found_t) = (closest_hit!(&r, !entering), closest_hit!(&t, entering));
                        add_direct!();
                        color +=
                            kr * self.shade_found::<PRUNE, _, _, _>(world, &r, found_r, depth + 1, wr, sample, stats);
                        color +=
                            kt * self.shade_found::<PRUNE, _, _, _>(world, &t, found_t, depth + 1, wt, sample, stats);
                    }
                    Some(dir) => {
                        stats.refraction += 1;
                        let below = offset_ray_origin(hit.point, hit.error, -n);
                        let t = Ray::with_time(below, dir, ray.time);
                        let found_t = closest_hit!(&t, entering);
                        add_direct!();
                        color +=
                            kt * self.shade_found::<PRUNE, _, _, _>(world, &t, found_t, depth + 1, wt, sample, stats);
                    }
                    None if reflects => {
                        stats.reflection += 1;
                        let found_r = closest_hit!(&r, !entering);
                        add_direct!();
                        color +=
                            kr * self.shade_found::<PRUNE, _, _, _>(world, &r, found_r, depth + 1, wr, sample, stats);
                    }
                    None => add_direct!(),
                }
            } else {
                let mirror = material.mirror();
                let wm = if PRUNE { weight * mirror.max_element() } else { weight };
                if mirror != Vec3::ZERO && self.traces::<PRUNE>(wm) {
                    let mut dir = reflect(ray.dir, ns);
                    let roughness = material.roughness();
                    // Only rough materials draw fuzz samples; a mirror reflects exactly.
                    let fuzzed = if roughness > 0.0 { fuzz(dir, n, roughness, sample) } else { Some(dir) };
                    if let Some(d) = fuzzed {
                        dir = d;
                        stats.reflection += 1;
                        let r = Ray::with_time(above, dir, ray.time);
                        color += mirror
                            * match reflected {
                                Some(found) => {
                                    self.shade_found::<PRUNE, _, _, _>(world, &r, found, depth + 1, wm, sample, stats)
                                }
                                None => self.trace::<PRUNE, _, _, _>(world, &r, 0.0, depth + 1, wm, sample, stats),
                            };
                    }
                }
            }
        }
        color.clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// Whether [`Whitted::shade_surface`] reflects off `material` along the exact mirror direction
/// (an opaque mirror that is not rough), drawing no samples for it.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn reflects_exactly<M: Material>(material: &M) -> bool {
    // Shading fuzzes only where `roughness > 0.0` holds: a NaN roughness reflects exactly too.
    material.dielectric().is_none() && material.mirror() != Vec3::ZERO && !(material.roughness() > 0.0)
}

/// Whether the batch's mirror reflections are traced together: when every surface of the batch
/// lies in one plane (the same geometric normal, bit for bit) and reflects exactly, the reflections
/// are as coherent as the camera rays (those of a mirrored camera). Reflections off curved surfaces
/// diverge, and gain nothing from being gathered; the check stops at the first surface that differs.
#[inline]
fn planar_mirror<A: Accelerator, M: Material>(
    world: &World<A, M>,
    surfaces: &[Option<Surface>],
    traces: impl Fn(f32) -> bool,
) -> bool {
    let mut plane = None;
    for s in surfaces.iter().flatten() {
        let n = s.n.to_array().map(f32::to_bits);
        let material = &world.materials[s.material as usize];
        if *plane.get_or_insert(n) != n || !reflects_exactly(material) || !traces(material.mirror().max_element()) {
            return false;
        }
    }
    plane.is_some()
}

/// Where a ray meets a surface, as shading sees it.
#[derive(Clone, Copy, Debug)]
struct Surface {
    hit: Hit,
    /// Index of the primitive hit.
    primitive: u32,
    /// Index into the world's materials.
    material: u32,
    /// Whether the ray meets the surface's outside.
    entering: bool,
    /// The geometric normal on the side the ray came from.
    n: Vec3A,
    /// The shading normal on that side.
    ns: Vec3A,
    /// The hit point offset off the surface on that side: where shadow rays and reflections start.
    above: Vec3A,
}

/// The surface `ray` meets at its closest hit `found`.
#[inline(always)]
fn surface<A: Accelerator, M: Material>(world: &World<A, M>, ray: &Ray, found: &PrimitiveHit) -> Surface {
    let hit = found.hit;
    let shading = world.shading[found.primitive as usize];
    let entering = hit.front_face(ray);
    let n = if entering { hit.normal } else { -hit.normal };
    let ns = if let Some(index) = shading.normals {
        let vn = world.vertex_normals[index as usize];
        let b = hit.uv;
        let s = (vn[0] * (1.0 - b.x - b.y) + vn[1] * b.x + vn[2] * b.y).normalize_or_zero();
        if s == Vec3A::ZERO {
            n
        } else if s.dot(n) < 0.0 {
            -s
        } else {
            s
        }
    } else {
        n
    };
    let hit = Hit { error: spawn_error(&hit, ray), ..hit };
    let above = offset_ray_origin(hit.point, hit.error, n);
    Surface { hit, primitive: found.primitive, material: shading.material, entering, n, ns, above }
}

/// The box around a hit's point that rays leaving it start past: the point's own error, and the
/// uncertainty of where along `ray` the hit lies. A point reprojected onto its surface is exact to
/// that surface's scale, but which of two surfaces less than the ray's rounding apart (nearly
/// coincident spheres) the ray met first is decided only to within `t |d|` times a few ulps; a
/// ray leaving the point must start outside both.
#[inline(always)]
fn spawn_error(hit: &Hit, ray: &Ray) -> Vec3A {
    hit.error + (ray.dir * hit.t).abs() * raylume_geometry::gamma(SPAWN_ULPS)
}

/// The ulps of a root's ray parameter that [`spawn_error`] allows for.
const SPAWN_ULPS: i32 = 16;

/// The shadow ray from `above` (off a surface of normal `n`) to `target` and the distance to it, if
/// the target is on the side `n` points to.
#[inline(always)]
fn shadow_ray(above: Vec3A, n: Vec3A, target: Vec3A, time: f32) -> Option<(Ray, f32)> {
    let to_light = target - above;
    let dist = to_light.length();
    let wi = to_light / dist;
    if dist == 0.0 || n.dot(wi) <= 0.0 {
        return None;
    }
    Some((Ray::with_time(above, wi, time), dist))
}

/// The point of the area `light` at `u` in `[0, 1)^2` across its edges.
#[inline(always)]
fn area_point(light: &Light, u: Vec2) -> Vec3A {
    let [e0, e1] = light.edges();
    let corner = light.centre() - (e0 + e1) * 0.5;
    corner + e0 * u.x + e1 * u.y
}

/// What [`Integrator::radiances_after`] keeps from one batch of samples to the next, so that a
/// render loop that makes one per task allocates nothing per batch.
#[derive(Debug, Default)]
pub struct BatchBuffers {
    /// Each sample's surface, if its camera ray hit one.
    surfaces: Vec<Option<Surface>>,
    /// The shadow rays to one light, their ends, and the samples they belong to, in their first slots
    /// (one slot per sample).
    rays: Vec<Ray>,
    ends: Vec<f32>,
    owners: Vec<u32>,
    answers: Vec<bool>,
    /// At `l * count + i` (`count` samples): the direction from sample `i`'s surface to the light `l`
    /// (its centre, or the point the sample drew on it) if that light reaches it, else zero (slots of
    /// area lights as grids, and past the batch, hold stale values).
    lit: Vec<Vec3A>,
    /// The mirror reflections of a batch whose surfaces lie in one plane, in their first slots (one
    /// per sample with a surface, in the samples' order), and their closest hits.
    reflections: Vec<Ray>,
    reflection_hits: Vec<Option<PrimitiveHit>>,
}

/// Makes `buffer` at least `len` long (with `fill`), never shorter: its slots are written before
/// they are read.
#[inline]
fn grow<T: Clone>(buffer: &mut Vec<T>, len: usize, fill: T) {
    if buffer.len() < len {
        buffer.resize(len, fill);
    }
}

/// Tries to draw a fuzzy reflection direction at most this many times before absorbing the ray.
const FUZZ_TRIES: u32 = 8;

/// The mirror direction `dir` perturbed by a uniform point of the ball of radius `roughness`,
/// normalised (the course's fuzzy reflection). A direction that falls below the surface (normal `n`)
/// is drawn again, up to [`FUZZ_TRIES`] times; if all fall below, the reflection is absorbed
/// (`None`), so no light ever leaks from under the surface.
#[inline]
pub fn fuzz<S: SampleSource>(dir: Vec3A, n: Vec3A, roughness: f32, sample: &mut S) -> Option<Vec3A> {
    for _ in 0..FUZZ_TRIES {
        let d = (dir + uniform_ball(sample.uniform3()) * roughness).normalize_or_zero();
        if d.dot(n) > 0.0 {
            return Some(d);
        }
    }
    None
}

impl<const SOFT: u8> Integrator for Whitted<SOFT> {
    fn radiance<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        t_min: f32,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        match self.prunes() {
            true => self.trace::<true, _, _, _>(world, ray, t_min, 1, 1.0, sample, stats),
            false => self.trace::<false, _, _, _>(world, ray, t_min, 1, 1.0, sample, stats),
        }
    }

    fn radiance_after<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        _t_min: f32,
        first: Option<PrimitiveHit>,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        match self.prunes() {
            true => self.shade::<true, _, _, _>(world, ray, first, 1, 1.0, sample, stats),
            false => self.shade::<false, _, _, _>(world, ray, first, 1, 1.0, sample, stats),
        }
    }

    /// The shadow rays of the whole batch traced together, light by light
    /// ([`Accelerator::occluded_each_within`]): to each point light, and to the point each sample draws
    /// on an area light sampled once per sample (drawn in the order shading would draw it). Area lights
    /// as grids of points are traced ray by ray.
    fn radiances_after<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        rays: &[Ray],
        _t_min: f32,
        firsts: &[Option<PrimitiveHit>],
        samples: &mut [S],
        colors: &mut [Vec3],
        buffers: &mut BatchBuffers,
        stats: &mut RayStats,
    ) {
        match self.prunes() {
            true => self.batch::<true, _, _, _>(world, rays, firsts, samples, colors, buffers, stats),
            false => self.batch::<false, _, _, _>(world, rays, firsts, samples, colors, buffers, stats),
        }
    }
}

impl<const SOFT: u8> Whitted<SOFT> {
    /// Whether rays below [`RenderSettings::min_weight`] are left out. With a minimum of 0 the code
    /// that does not weigh rays runs, and traces every ray that adds anything.
    #[inline]
    fn prunes(&self) -> bool {
        self.min_weight > 0.0
    }

    /// [`Integrator::radiances_after`], its rays weighed if `PRUNE`.
    #[allow(clippy::too_many_arguments)]
    fn batch<const PRUNE: bool, A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        rays: &[Ray],
        firsts: &[Option<PrimitiveHit>],
        samples: &mut [S],
        colors: &mut [Vec3],
        buffers: &mut BatchBuffers,
        stats: &mut RayStats,
    ) {
        let count = rays.len();
        assert!(firsts.len() == count && samples.len() == count && colors.len() == count, "one of each per ray");
        let lights = world.lights.len();
        let BatchBuffers { surfaces, rays: shadow, ends, owners, answers, lit, reflections, reflection_hits } = buffers;
        surfaces.clear();
        surfaces.extend(rays.iter().zip(firsts).map(|(ray, first)| first.map(|f| surface(world, ray, &f))));
        // Every slot is written below (those of area lights are never read): the buffers only grow,
        // and the shadow rays of a light fill their first slots.
        grow(lit, count * lights, Vec3A::ZERO);
        grow(shadow, count, Ray::new(Vec3A::ZERO, Vec3A::ZERO));
        grow(ends, count, 0.0);
        grow(owners, count, 0);
        // The lights whose shadow rays the batch traces: all but area lights as grids (only with grids
        // is a light looked at).
        let batched = |l: usize| SOFT != SoftShadows::GRID || !world.lights[l].is_area();
        for (l, light) in world.lights.iter().enumerate() {
            if !batched(l) {
                continue;
            }
            let area = SOFT != SoftShadows::NONE && light.is_area();
            let centre = light.centre();
            let lit = &mut lit[l * count..(l + 1) * count];
            let mut slots = shadow.iter_mut().zip(ends.iter_mut()).zip(owners.iter_mut());
            let mut traced = 0;
            let each = surfaces.iter().zip(rays).zip(lit.iter_mut()).zip(samples.iter_mut());
            for (i, (((s, ray), dir), sample)) in each.enumerate() {
                *dir = Vec3A::ZERO;
                // Shading draws each area light's point first, light by light: drawn here in that order.
                if let Some(s) = s
                    && let Some((r, dist)) = shadow_ray(
                        s.above,
                        s.n,
                        if area { area_point(light, sample.light()) } else { centre },
                        ray.time,
                    )
                {
                    let Some(((ray_slot, end_slot), owner_slot)) = slots.next() else {
                        unreachable!("a slot per sample")
                    };
                    (*ray_slot, *end_slot, *owner_slot) = (r, dist, i as u32);
                    traced += 1;
                }
            }
            let (shadow, ends, owners) = (&shadow[..traced], &ends[..traced], &owners[..traced]);
            answers.clear();
            answers.resize(traced, false);
            world.accel.occluded_each_within(shadow, ends, answers);
            stats.shadow += traced as u64;
            for ((&i, &occluded), ray) in owners.iter().zip(answers.iter()).zip(shadow.iter()) {
                if !occluded {
                    lit[i as usize] = ray.dir;
                }
            }
        }
        // The mirror reflections shading would trace one by one (the same rays, from the same
        // numbers), found together.
        let gathered = 1 < self.max_depth && planar_mirror(world, surfaces, |w| self.traces::<PRUNE>(w));
        if gathered {
            grow(reflections, count, Ray::new(Vec3A::ZERO, Vec3A::ZERO));
            grow(reflection_hits, count, None);
            let mut mirrored = 0;
            for (s, ray) in surfaces.iter().zip(rays) {
                if let Some(s) = s {
                    reflections[mirrored] = Ray::with_time(s.above, reflect(ray.dir, s.ns), ray.time);
                    mirrored += 1;
                }
            }
            let all = Interval::new(0.0, f32::INFINITY);
            world.accel.closest_hits(&reflections[..mirrored], all, &mut reflection_hits[..mirrored]);
        }
        let mut found = reflection_hits.iter();
        let samples = rays.iter().zip(surfaces.iter()).zip(samples).zip(colors.iter_mut());
        for (i, (((ray, s), sample), color)) in samples.enumerate() {
            *color = match s {
                Some(s) => {
                    let known = |l: usize| batched(l).then(|| lit[l * count + i]);
                    let reflected = if gathered { found.next().copied() } else { None };
                    self.shade_surface::<PRUNE, _, _, _>(world, ray, s, 1, 1.0, known, reflected, sample, stats)
                }
                None => self.escape(world, ray, 1),
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{Jittered, Sampler};

    #[test]
    fn fuzzy_directions_never_go_below_the_surface() {
        let n = Vec3A::Y;
        let sampler = Jittered::new(1, 4);
        let mut absorbed = 0;
        for i in 0..20_000u32 {
            let mut src = sampler.begin(i % 97, i / 97, i % 16);
            // Grazing mirror directions with the largest roughness: the hardest case.
            let dir = Vec3A::new(1.0, 0.01 + (i % 10) as f32 * 0.01, 0.0).normalize();
            match fuzz(dir, n, 1.0, &mut src) {
                Some(d) => {
                    assert!(d.dot(n) > 0.0);
                    assert!((d.length() - 1.0).abs() < 1e-5);
                }
                None => absorbed += 1,
            }
        }
        // Resampling keeps almost every grazing reflection: a fraction of a percent is absorbed.
        assert!(absorbed < 200, "{absorbed} absorbed");
    }

    #[test]
    fn zero_roughness_is_never_asked_for_fuzz_and_small_roughness_stays_near_the_mirror() {
        let sampler = Jittered::new(2, 2);
        let dir = Vec3A::new(0.3, 0.8, 0.1).normalize();
        for i in 0..1000 {
            let mut src = sampler.begin(i, 0, 0);
            let d = fuzz(dir, Vec3A::Y, 0.05, &mut src).unwrap();
            assert!(d.dot(dir) > (0.05f32).atan().cos() - 1e-4);
        }
    }
}
