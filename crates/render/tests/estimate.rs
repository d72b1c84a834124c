//! The error estimate against truths it does not see: a black triangle on a white background, where
//! each camera sample is 0 or 1 and a pixel's value is the fraction of its area the triangle leaves
//! uncovered. That fraction is found by quadrature, so the exact image is known, and with
//! independent samples so is each pixel's variance, `p (1 - p) / n`.

use raylume_camera::{Camera, CameraSample, Pinhole};
use raylume_geometry::{Vec2, Vec3A};
use raylume_integrator::{Film, metrics};
use raylume_render::{RenderOptions, RenderScene, SamplerKind};
use raylume_scene::{Scene, p3f};

const SCENE: &str = "\
bclr 1 1 1
v
from 0 0 5
at 0 0 0
up 0 1 0
angle 40
hither 0.01
resolution 96 72
f 0 0 0 0 0 0 0 0 1 0 1
p 3
-1.5 -1.2 0
1.7 -0.5 0
-0.3 1.4 0
";

const TRIANGLE: [[f64; 2]; 3] = [[-1.5, -1.2], [1.7, -0.5], [-0.3, 1.4]];

fn scene() -> Scene {
    p3f::parse(SCENE, "triangle", &Default::default()).unwrap().scene
}

/// Whether the point (x, y) of the plane z = 0 is inside the triangle.
fn inside(x: f64, y: f64) -> bool {
    let side = |[a, b]: [[f64; 2]; 2]| (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
    let s = [side([TRIANGLE[0], TRIANGLE[1]]), side([TRIANGLE[1], TRIANGLE[2]]), side([TRIANGLE[2], TRIANGLE[0]])];
    s.iter().all(|&v| v > 0.0) || s.iter().all(|&v| v < 0.0)
}

/// Each pixel's share of its area that sees the background, by a 64 x 64 quadrature through the
/// camera itself, top row first.
fn uncovered(scene: &Scene) -> Vec<f64> {
    const Q: u32 = 64;
    let camera = Pinhole::new(&scene.view);
    let (w, h) = camera.resolution();
    let mut out = Vec::new();
    for row in 0..h {
        // The render loop counts the camera's y from the bottom.
        let y = h - 1 - row;
        for x in 0..w {
            let mut misses = 0u32;
            for j in 0..Q {
                for i in 0..Q {
                    let offset = Vec2::new((i as f32 + 0.5) / Q as f32, (j as f32 + 0.5) / Q as f32);
                    let film = Vec2::new(x as f32, y as f32) + offset;
                    let ray = camera.generate_ray(&CameraSample { film, lens: Vec2::splat(0.5), time: 0.0 });
                    let (o, d): (Vec3A, Vec3A) = (ray.origin, ray.dir);
                    let t = -o.z as f64 / d.z as f64;
                    let (px, py) = (o.x as f64 + t * d.x as f64, o.y as f64 + t * d.y as f64);
                    misses += u32::from(!inside(px, py));
                }
            }
            out.push(misses as f64 / (Q * Q) as f64);
        }
    }
    out
}

fn options(sampler: SamplerKind, seed: u64) -> RenderOptions {
    let mut o = RenderOptions { spp: Some(16), passes: 4, sampler, ..RenderOptions::default() };
    o.settings.seed = seed;
    o
}

#[test]
fn the_estimate_finds_the_variance_of_independent_samples() {
    let scene = scene();
    let p = uncovered(&scene);
    // Every channel of a pixel is the same Bernoulli mean of 16 samples.
    let truth = p.iter().map(|p| p * (1.0 - p) / 16.0).sum::<f64>() / p.len() as f64;
    assert!(truth > 1e-4, "the triangle's edges cross enough pixels to measure: {truth}");
    let exact: Vec<f32> = p.iter().flat_map(|&p| [p as f32; 3]).collect();
    let seeds = 16;
    let (mut estimated, mut measured, mut held) = (0.0, 0.0, 0);
    for seed in 0..seeds {
        let out = scene.render(&options(SamplerKind::Independent, seed), &()).unwrap();
        let e = out.estimate.expect("four passes give an estimate");
        estimated += e.mse / seeds as f64;
        measured += metrics::mse(&out.film.channels(), &exact).unwrap() / seeds as f64;
        held += usize::from((e.rmse_interval.0..=e.rmse_interval.1).contains(&truth.sqrt()));
    }
    assert!((measured / truth - 1.0).abs() < 0.06, "the renders' error {measured} against p(1-p)/n {truth}");
    assert!((estimated / truth - 1.0).abs() < 0.06, "estimated {estimated} against the true {truth}");
    assert!(held >= 12, "the 95 % interval held the truth in {held} renders of {seeds}");
}

#[test]
fn the_estimate_follows_stratified_and_low_discrepancy_samples() {
    // Stratified samples have less variance than p(1-p)/n, by an amount the quadrature cannot tell:
    // the truth is the measured error against the exact image, over many renders.
    let scene = scene();
    let exact: Vec<f32> = uncovered(&scene).iter().flat_map(|&p| [p as f32; 3]).collect();
    for sampler in [SamplerKind::Jittered, SamplerKind::Sobol] {
        let seeds = 16;
        let (mut estimated, mut measured) = (0.0, 0.0);
        for seed in 0..seeds {
            let out = scene.render(&options(sampler, seed), &()).unwrap();
            estimated += out.estimate.unwrap().mse / seeds as f64;
            measured += metrics::mse(&out.film.channels(), &exact).unwrap() / seeds as f64;
        }
        assert!((estimated / measured - 1.0).abs() < 0.1, "{sampler:?}: estimated {estimated}, measured {measured}");
    }
}

#[test]
fn one_pass_has_no_estimate_and_the_plain_image() {
    let scene = scene();
    let one = scene.render(&RenderOptions { passes: 1, ..options(SamplerKind::Jittered, 3) }, &()).unwrap();
    assert!(one.estimate.is_none() && one.variance.is_none());
    assert_eq!((one.passes, one.samples_per_pixel), (1, 16));
    let four = scene.render(&options(SamplerKind::Jittered, 3), &()).unwrap();
    assert_eq!((four.passes, four.samples_per_pixel), (4, 16));
    let variance: &Film = four.variance.as_ref().unwrap();
    assert_eq!(variance.width(), 96);
    // Inside the triangle and far from it every sample agrees: no variance.
    assert_eq!(variance.pixel(48, 36).x, 0.0);
    assert_eq!(variance.pixel(1, 1).x, 0.0);
}
