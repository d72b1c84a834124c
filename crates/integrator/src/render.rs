use std::ops::AddAssign;

use raylume_accel::Accelerator;
use raylume_camera::{Camera, CameraSample};
use raylume_geometry::{Interval, Ray, Vec2, Vec3, Vec3A};
use raylume_material::{FresnelMode, Material};
use rayon::prelude::*;

use crate::sampler::{SampleSource, Sampler};
use crate::{BatchBuffers, Film, Integrator, Profile, World};

/// Deepest ray tree a render traces ([`RenderSettings::max_depth`]): the integrator recurses once
/// per level, and this many levels fit with a wide margin in the 2 MiB stack of a default thread.
pub const MAX_DEPTH: u32 = 256;
/// Most samples per pixel a render takes ([`RenderSettings::spp`]).
pub const MAX_SPP: u32 = 1 << 16;
/// Largest side of the grid of point lights that stands for an area light.
pub const MAX_LIGHT_GRID: u32 = 64;

/// Settings of a render that do not belong to the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Maximum ray depth, counting the camera ray as 1 (the course's default is 4).
    pub max_depth: u32,
    /// Samples per pixel: 0 or 1 is one ray through the pixel centre; more are jittered over an
    /// `n x n` grid with `n = ceil(sqrt(spp))`.
    pub spp: u32,
    /// Seed of the random numbers (with the pixel and the sample index, it decides every sample).
    pub seed: u64,
    /// Fresnel equations or Schlick's approximation.
    pub fresnel: FresnelMode,
    /// Side of the grid of point lights that stands for an area light when there is no
    /// antialiasing (the course's 4: 16 shadow rays per area light).
    pub light_grid: u32,
    /// Render only this part of the image: `[x0, y0, x1, y1)` in pixels, row 0 at the top.
    pub crop: Option<[u32; 4]>,
    /// The shading rules ([`Profile::Plain`]: the plain model). The scene API sets it from its
    /// render options' `profile`.
    pub profile: Profile,
    /// Adaptive depth control: a reflected or refracted ray whose colour would enter the pixel's
    /// with a weight below this (the product of the mirror colours' largest components, the
    /// Fresnel reflectances and the transmitted fractions along its way from the camera) is not
    /// traced, as with Rayshade's `cutoff` or POV-Ray's `adc_bailout`. Each ray left out changes its
    /// sample's colour by at most its weight times the brightest colour it could bring back (1, or
    /// the background's). 0, the default, traces every ray up to `max_depth`.
    pub min_weight: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            max_depth: 4,
            spp: 1,
            seed: 0,
            fresnel: FresnelMode::Exact,
            light_grid: 4,
            crop: None,
            profile: Profile::Plain,
            min_weight: 0.0,
        }
    }
}

impl RenderSettings {
    /// The side of the jittered grid of samples per pixel (1 for a single centre sample).
    pub fn strata(&self) -> u32 {
        if self.spp <= 1 { 1 } else { (self.spp as f64).sqrt().ceil() as u32 }
    }

    /// Whether the render antialiases (more than one sample per pixel).
    pub fn antialiasing(&self) -> bool {
        self.strata() > 1
    }

    /// Checks the settings against the limits ([`MAX_DEPTH`], [`MAX_SPP`], [`MAX_LIGHT_GRID`]) and
    /// the crop's order; the message names the setting and what it must be.
    ///
    /// ```
    /// use raylume_integrator::RenderSettings;
    /// assert!(RenderSettings::default().validate().is_ok());
    /// let deep = RenderSettings { max_depth: 5000, ..RenderSettings::default() };
    /// assert_eq!(deep.validate().unwrap_err(), "depth 5000: expected 1..=256");
    /// ```
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_DEPTH).contains(&self.max_depth) {
            return Err(format!("depth {}: expected 1..={MAX_DEPTH}", self.max_depth));
        }
        if self.spp > MAX_SPP {
            return Err(format!("spp {}: expected 0..={MAX_SPP}", self.spp));
        }
        if !(1..=MAX_LIGHT_GRID).contains(&self.light_grid) {
            return Err(format!("light grid {}: expected 1..={MAX_LIGHT_GRID}", self.light_grid));
        }
        if !(0.0..=1.0).contains(&self.min_weight) {
            return Err(format!("minimum weight {}: expected a number in [0, 1]", self.min_weight));
        }
        if let Some([x0, y0, x1, y1]) = self.crop {
            if x0 >= x1 || y0 >= y1 {
                return Err(format!("crop {x0} {y0} {x1} {y1}: expected X0 < X1 and Y0 < Y1"));
            }
        }
        Ok(())
    }
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayStats {
    /// Camera rays.
    pub camera: u64,
    /// Shadow rays.
    pub shadow: u64,
    /// Mirror and Fresnel reflection rays.
    pub reflection: u64,
    /// Refraction rays.
    pub refraction: u64,
}

impl RayStats {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.shadow + self.reflection + self.refraction
    }
}

impl AddAssign for RayStats {
    fn add_assign(&mut self, o: Self) {
        self.camera += o.camera;
        self.shadow += o.shadow;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
    }
}

/// What a running render tells its caller and asks of it: [`row_done`](Observer::row_done) after each
/// finished image row (a progress bar), [`cancelled`](Observer::cancelled) before each task (a row,
/// or a band of eight rows where camera rays are gathered) is started: a render stops within one task
/// per thread of being cancelled.
///
/// `()` observes nothing; a closure `Fn()` is called per row; a [`CancelToken`] cancels; a pair
/// `(a, b)` does what both do.
///
/// ```
/// use std::sync::atomic::{AtomicUsize, Ordering};
/// use raylume_integrator::{CancelToken, Observer};
/// let rows = AtomicUsize::new(0);
/// let count = || {
///     rows.fetch_add(1, Ordering::Relaxed);
/// };
/// let cancel = CancelToken::new();
/// let both = (count, cancel.clone());
/// both.row_done();
/// assert_eq!(rows.load(Ordering::Relaxed), 1);
/// assert!(!both.cancelled());
/// cancel.cancel();
/// assert!(both.cancelled() && !().cancelled());
/// ```
pub trait Observer: Sync {
    /// Called once per finished image row.
    fn row_done(&self) {}

    /// Called with the pixels of finished rows (a row, or a band of rows where camera rays are
    /// gathered): `pixels` holds rows `first_row..` of the film (crop coordinates, row 0 at the top),
    /// `width` pixels each.
    fn rows_done(&self, _first_row: u32, _width: u32, _pixels: &[Vec3]) {}

    /// Whether the render is to stop; rows not started yet are then left out.
    fn cancelled(&self) -> bool {
        false
    }
}

impl Observer for () {}

impl<F: Fn() + Sync + ?Sized> Observer for F {
    fn row_done(&self) {
        self()
    }
}

impl<A: Observer, B: Observer> Observer for (A, B) {
    fn row_done(&self) {
        self.0.row_done();
        self.1.row_done();
    }

    fn rows_done(&self, first_row: u32, width: u32, pixels: &[Vec3]) {
        self.0.rows_done(first_row, width, pixels);
        self.1.rows_done(first_row, width, pixels);
    }

    fn cancelled(&self) -> bool {
        self.0.cancelled() || self.1.cancelled()
    }
}

/// A flag that cancels the renders it is given to as an [`Observer`], from any thread (a user's
/// stop button, a deadline); clones share the flag.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(std::sync::Arc<std::sync::atomic::AtomicBool>);

impl CancelToken {
    /// A token not cancelled yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Cancels every render observing this token (or a clone of it).
    pub fn cancel(&self) {
        self.0.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether [`cancel`](CancelToken::cancel) was called.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::Relaxed)
    }
}

impl Observer for CancelToken {
    fn cancelled(&self) -> bool {
        self.is_cancelled()
    }
}

/// Renders `world` through `camera` with `integrator`, taking each pixel's samples from `sampler`,
/// in parallel over rows (on rayon's current pool). Each sample depends only on the seed, the pixel
/// and its index, so the image is bit-identical whatever the number of threads, and a crop
/// (`settings.crop`) holds exactly the full image's pixels. `observer` hears of each finished row
/// and can cancel: the rows not started once [`Observer::cancelled`] says so stay black, so the
/// caller checks it after the render before using the image.
///
/// The lens and time dimensions are drawn only for cameras that use them ([`Camera::USES_LENS`],
/// [`Camera::USES_TIME`]): a pinhole render does no lens or shutter work at all.
pub fn render<A, M, C, S, I, O>(
    world: &World<A, M>,
    camera: &C,
    sampler: &S,
    integrator: &I,
    settings: &RenderSettings,
    observer: &O,
) -> (Film, RayStats)
where
    A: Accelerator,
    M: Material,
    C: Camera,
    S: Sampler,
    I: Integrator,
    O: Observer + ?Sized,
{
    render_pass(world, camera, sampler, integrator, settings, observer, None)
}

/// [`render`] of only the pixels `active` marks (one flag per pixel of the image or its crop, top
/// row first; `None` renders all): the pass of an adaptive render, which gives more samples to the
/// pixels that need them. The pixels left out are black, and each pixel rendered is the same, bit
/// for bit, as in a render of all of them.
pub fn render_pass<A, M, C, S, I, O>(
    world: &World<A, M>,
    camera: &C,
    sampler: &S,
    integrator: &I,
    settings: &RenderSettings,
    observer: &O,
    active: Option<&[bool]>,
) -> (Film, RayStats)
where
    A: Accelerator,
    M: Material,
    C: Camera,
    S: Sampler,
    I: Integrator,
    O: Observer + ?Sized,
{
    let (w, h) = camera.resolution();
    let [x0, y0, x1, y1] =
        settings.crop.map_or([0, 0, w, h], |[x0, y0, x1, y1]| [x0.min(w), y0.min(h), x1.min(w), y1.min(h)]);
    let (cw, ch) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
    let spp = sampler.samples_per_pixel();
    let inv = 1.0 / spp as f32;
    let t_min = camera.t_min();
    let mut film = Film::black(cw, ch);
    if cw == 0 || ch == 0 {
        return (film, RayStats::default());
    }
    let pixels = film.pixels_mut();
    if let Some(mask) = active {
        assert_eq!(mask.len(), pixels.len(), "one flag per pixel of the image or crop");
    }
    // One row per task: rows differ a lot in cost (an object in the middle of the frame), and rayon
    // can only hand an idle thread a task that has not started. Where the accelerator gathers
    // coherent rays, a band of TILE rows per task, traced in square tiles.
    let band = if world.accel.gathers_coherent_rays() { TILE } else { 1 };
    let stats = pixels
        .par_chunks_mut(cw as usize * band)
        .with_max_len(1)
        .enumerate()
        .map(|(task, out)| {
            let mut stats = RayStats::default();
            if observer.cancelled() {
                return stats;
            }
            let first = task * band * cw as usize;
            let mask = active.map(|m| &m[first..first + out.len()]);
            if mask.is_some_and(|m| !m.contains(&true)) {
                for _ in 0..out.len() / cw as usize {
                    observer.row_done();
                }
                return stats;
            }
            if band > 1 {
                let first_row = y0 + (task * band) as u32;
                let rows = (x0, first_row, cw as usize);
                gathered_band(world, camera, sampler, integrator, rows, out, mask, &mut stats);
                for _ in 0..out.len() / cw as usize {
                    observer.row_done();
                }
                observer.rows_done((task * band) as u32, cw, out);
                return stats;
            }
            let row = task;
            // Row 0 of the film is the top; the camera counts y from the bottom.
            let y = h - 1 - (y0 + row as u32);
            for (i, px) in out.iter_mut().enumerate() {
                if mask.is_some_and(|m| !m[i]) {
                    continue;
                }
                let x = x0 + i as u32;
                let mut sum = Vec3::ZERO;
                for index in 0..spp {
                    let mut src = sampler.begin(x, y, index);
                    let film = Vec2::new(x as f32, y as f32) + src.film();
                    let lens = if C::USES_LENS { src.lens() } else { Vec2::splat(0.5) };
                    let time = if C::USES_TIME { src.time() } else { 0.0 };
                    let ray = camera.generate_ray(&CameraSample { film, lens, time });
                    stats.camera += 1;
                    sum += integrator.radiance(world, &ray, t_min, &mut src, &mut stats);
                }
                *px = if spp == 1 { sum } else { sum * inv };
            }
            observer.row_done();
            observer.rows_done(row as u32, cw, out);
            stats
        })
        .reduce(RayStats::default, |mut a, b| {
            a += b;
            a
        });
    (film, stats)
}

/// Camera rays of neighbouring samples gathered in one query of the accelerator.
const GATHER: usize = 64;
/// The side of the square tiles whose camera rays are gathered.
const TILE: usize = 8;

/// The pixels `out` of a band of rows (the first, `first_row`, counted from the top of the image;
/// `width` pixels each, from column `x0`), tile by tile, with their camera rays' first hits found
/// [`GATHER`] samples at a time ([`Accelerator::closest_hits`]): each sample then goes on with its
/// own numbers, the batch's shadow rays traced together where the integrator does so
/// ([`Integrator::radiances_after`]), and each pixel sums its samples in the order of the one-by-one
/// loop, so the image is the same, bit for bit. Pixels `mask` leaves out are skipped.
#[allow(clippy::too_many_arguments)]
fn gathered_band<A, M, C, S, I>(
    world: &World<A, M>,
    camera: &C,
    sampler: &S,
    integrator: &I,
    (x0, first_row, width): (u32, u32, usize),
    out: &mut [Vec3],
    mask: Option<&[bool]>,
    stats: &mut RayStats,
) where
    A: Accelerator,
    M: Material,
    C: Camera,
    S: Sampler,
    I: Integrator,
{
    let h = camera.resolution().1;
    let spp = sampler.samples_per_pixel();
    let t_min = camera.t_min();
    let range = Interval::new(t_min, f32::INFINITY);
    // The samples are summed into `out`: written once first, as a page of a new film read before it
    // is written is mapped twice.
    out.fill(Vec3::ZERO);
    // The batch's camera rays and pixels in their first `sources.len()` slots.
    let mut rays = [Ray::new(Vec3A::ZERO, Vec3A::ZERO); GATHER];
    let mut pixels = [0usize; GATHER];
    let mut sources = Vec::with_capacity(GATHER);
    let mut hits = [None; GATHER];
    let mut colors = [Vec3::ZERO; GATHER];
    let mut buffers = BatchBuffers::default();
    let mut trace = |rays: &[Ray], pixels: &[usize], sources: &mut Vec<S::Source>, out: &mut [Vec3]| {
        let n = sources.len();
        let (rays, pixels, hits, colors) = (&rays[..n], &pixels[..n], &mut hits[..n], &mut colors[..n]);
        world.accel.closest_hits(rays, range, hits);
        integrator.radiances_after(world, rays, t_min, hits, sources, colors, &mut buffers, stats);
        for (&i, color) in pixels.iter().zip(colors.iter()) {
            out[i] += *color;
        }
        sources.clear();
    };
    let rows = out.len() / width;
    for tile in (0..width).step_by(TILE) {
        for r in 0..rows {
            // The camera counts y from the bottom.
            let y = h - 1 - (first_row + r as u32);
            for c in tile..(tile + TILE).min(width) {
                if mask.is_some_and(|m| !m[r * width + c]) {
                    continue;
                }
                let x = x0 + c as u32;
                for index in 0..spp {
                    let mut src = sampler.begin(x, y, index);
                    let film = Vec2::new(x as f32, y as f32) + src.film();
                    let lens = if C::USES_LENS { src.lens() } else { Vec2::splat(0.5) };
                    let time = if C::USES_TIME { src.time() } else { 0.0 };
                    let k = sources.len();
                    rays[k] = camera.generate_ray(&CameraSample { film, lens, time });
                    pixels[k] = r * width + c;
                    sources.push(src);
                    if k + 1 == GATHER {
                        trace(&rays, &pixels, &mut sources, out);
                    }
                }
            }
        }
    }
    if !sources.is_empty() {
        trace(&rays, &pixels, &mut sources, out);
    }
    let rendered = mask.map_or(out.len(), |m| m.iter().filter(|&&a| a).count());
    stats.camera += rendered as u64 * spp as u64;
    if spp != 1 {
        let inv = 1.0 / spp as f32;
        for px in out.iter_mut() {
            *px *= inv;
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use raylume_accel::BruteForce;
    use raylume_camera::{Pinhole, View};
    use raylume_geometry::{Sphere, Vec3, Vec3A};
    use raylume_intersect::Primitive;
    use raylume_material::Phong;

    use super::*;
    use crate::{Background, CancelToken, Centre, Light, Whitted, World};

    fn lit_sphere() -> (World<BruteForce<Primitive>, Phong>, View) {
        let prims = vec![Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 })];
        let world = World::new(
            BruteForce::new(prims),
            vec![Phong::default()],
            vec![0],
            vec![Light::point(Vec3A::new(0.0, 0.0, 10.0), Vec3::ONE)],
            Background::color(Vec3::ONE),
        );
        let view = View {
            from: Vec3A::new(0.0, 0.0, 5.0),
            at: Vec3A::ZERO,
            up: Vec3A::Y,
            angle_deg: 45.0,
            hither: 0.0,
            width: 8,
            height: 6,
            aperture: 0.0,
            focal: 1.0,
        };
        (world, view)
    }

    #[test]
    fn rows_are_reported_and_a_cancelled_render_traces_nothing() {
        let (world, view) = lit_sphere();
        let settings = RenderSettings::default();
        let camera = Pinhole::new(&view);
        let rows = AtomicUsize::new(0);
        let count = || {
            rows.fetch_add(1, Ordering::Relaxed);
        };
        let (_, stats) = render(&world, &camera, &Centre::new(0), &Whitted::new(&settings), &settings, &count);
        assert_eq!((rows.load(Ordering::Relaxed), stats.camera), (6, 48));
        let boxed: &(dyn Fn() + Sync) = &count;
        render(&world, &camera, &Centre::new(0), &Whitted::new(&settings), &settings, boxed);
        assert_eq!(rows.load(Ordering::Relaxed), 12, "a closure behind a reference to dyn Fn observes too");

        let cancel = CancelToken::new();
        cancel.cancel();
        let (film, stats) = render(&world, &camera, &Centre::new(0), &Whitted::new(&settings), &settings, &cancel);
        assert_eq!(stats.camera, 0);
        assert!(film.pixels().iter().all(|&p| p == Vec3::ZERO), "rows not started stay black");
    }
}
