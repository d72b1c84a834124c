use std::ops::AddAssign;

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume_accel::Accelerator;
use raylume_camera::{Camera, CameraSample};
use raylume_geometry::{Vec2, Vec3};
use raylume_material::{FresnelMode, Material};
use rayon::prelude::*;

use crate::{Film, Integrator, World};

/// Settings of a render that do not belong to the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Maximum ray depth, counting the camera ray as 1 (the course's default is 4).
    pub max_depth: u32,
    /// Samples per pixel: 0 or 1 is one ray through the pixel centre; more are jittered over an
    /// `n x n` grid with `n = ceil(sqrt(spp))`.
    pub spp: u32,
    /// Seed of the random numbers (with the pixel, it decides every sample).
    pub seed: u64,
    /// Fresnel equations or Schlick's approximation.
    pub fresnel: FresnelMode,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            max_depth: 4,
            spp: 1,
            seed: 0,
            fresnel: FresnelMode::Exact,
        }
    }
}

impl RenderSettings {
    /// The side of the jittered grid of samples per pixel (1 for a single centre sample).
    pub fn strata(&self) -> u32 {
        if self.spp <= 1 {
            1
        } else {
            (self.spp as f64).sqrt().ceil() as u32
        }
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

/// Renders `world` through `camera` with `integrator`, in parallel over rows (on rayon's current
/// pool). Each pixel's samples depend only on the seed and the pixel, so the image is bit-identical
/// whatever the number of threads. `on_row` is called once per finished row (for progress bars).
pub fn render<A, M, C, I>(
    world: &World<A, M>,
    camera: &C,
    integrator: &I,
    settings: &RenderSettings,
    on_row: &(dyn Fn() + Sync),
) -> (Film, RayStats)
where
    A: Accelerator,
    M: Material,
    C: Camera,
    I: Integrator,
{
    let (w, h) = camera.resolution();
    let n = settings.strata();
    let inv = 1.0 / (n * n) as f32;
    let t_min = camera.t_min();
    let mut pixels = vec![Vec3::ZERO; w as usize * h as usize];
    let stats = pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .map(|(row, out)| {
            let mut stats = RayStats::default();
            // Row 0 of the film is the top; the camera counts y from the bottom.
            let y = h - 1 - row as u32;
            for (x, px) in out.iter_mut().enumerate() {
                let x = x as u32;
                let mut sum = Vec3::ZERO;
                if n == 1 {
                    let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let ray = camera.generate_ray(&CameraSample::at_film(film));
                    stats.camera += 1;
                    sum = integrator.radiance(world, &ray, t_min, &mut stats);
                } else {
                    let mut rng = pixel_rng(settings.seed, x, y, w);
                    for p in 0..n {
                        for q in 0..n {
                            let jitter = Vec2::new(uniform(&mut rng), uniform(&mut rng));
                            let film = Vec2::new(x as f32, y as f32)
                                + (Vec2::new(p as f32, q as f32) + jitter) / n as f32;
                            let ray = camera.generate_ray(&CameraSample::at_film(film));
                            stats.camera += 1;
                            sum += integrator.radiance(world, &ray, t_min, &mut stats);
                        }
                    }
                    sum *= inv;
                }
                *px = sum;
            }
            on_row();
            stats
        })
        .reduce(RayStats::default, |mut a, b| {
            a += b;
            a
        });
    (Film::from_pixels(w, h, pixels), stats)
}

/// A generator seeded by the render seed and the pixel only.
fn pixel_rng(seed: u64, x: u32, y: u32, width: u32) -> Pcg32 {
    let pixel = y as u64 * width as u64 + x as u64;
    Pcg32::new(splitmix(seed ^ splitmix(pixel)), 0x0a02_bdbf_7bb3_c0a7)
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform float in `[0, 1)` with 24 random bits.
#[inline]
fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}
