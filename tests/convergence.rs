//! Error against run time: metrics on known images, samplers compared by their convergence.

use raylume::metrics::{log_log_slope, mae, mse, psnr, rel_mse, rmse};
use raylume::prelude::*;
use raylume::render::SamplerKind;

#[test]
fn metrics_on_hand_computed_images() {
    let reference = [0.0f32, 0.5, 1.0, 0.25];
    let image = [0.1f32, 0.5, 0.8, 0.25];
    // Differences 0.1, 0, -0.2, 0: squares 0.01, 0, 0.04, 0.
    assert!((mse(&image, &reference).unwrap() - 0.0125).abs() < 1e-7);
    assert!((rmse(&image, &reference).unwrap() - 0.0125f64.sqrt()).abs() < 1e-7);
    assert!((mae(&image, &reference).unwrap() - 0.075).abs() < 1e-7);
    assert!((psnr(&image, &reference, 1.0).unwrap() - 10.0 * (1.0f64 / 0.0125).log10()).abs() < 1e-4);
    let expected_rel = (0.01 / 0.01 + 0.04 / 1.01) / 4.0;
    assert!((rel_mse(&image, &reference, 0.01).unwrap() - expected_rel).abs() < 1e-7);
    assert_eq!(rmse(&image, &reference[..3]), None);
    assert_eq!(psnr(&reference, &reference, 1.0), Some(f64::INFINITY));
}

/// Renders a blurred edge (a defocused quad) at growing sample counts and fits the slope of log RMSE
/// against log spp: jittered sampling converges faster than independent sampling.
#[test]
fn jittered_converges_faster_than_independent_on_a_blurred_edge() {
    let view = View {
        from: Vec3A::new(0.0, 0.0, 10.0),
        at: Vec3A::ZERO,
        up: Vec3A::Y,
        angle_deg: 30.0,
        hither: 0.0,
        width: 32,
        height: 32,
        aperture: 4.0,
        focal: 0.6,
    };
    let scene = Scene {
        view,
        ..SceneBuilder::new()
            .view(view)
            .light(Vec3A::new(0.0, 0.0, 1e5), Vec3::ONE)
            .material(Phong { diffuse: Vec3::ONE, kd: 1.0, ..Phong::default() })
            .shape(raylume::scene::Shape::Polygon(vec![
                Vec3A::new(0.0, -100.0, 0.0),
                Vec3A::new(100.0, -100.0, 0.0),
                Vec3A::new(100.0, 100.0, 0.0),
                Vec3A::new(0.0, 100.0, 0.0),
            ]))
            .build()
            .unwrap()
    };
    let render = |spp: u32, seed: u64, sampler: SamplerKind| {
        let options = RenderOptions {
            settings: RenderSettings { seed, ..Default::default() },
            spp: Some(spp),
            sampler,
            ..Default::default()
        };
        scene.render_progressive(&options, &(), |_| std::ops::ControlFlow::Break(())).unwrap().film.channels()
    };
    let reference = render(4096, 99, SamplerKind::Jittered);
    let spps = [4u32, 16, 64, 256];
    let slope = |sampler| {
        let errors: Vec<f64> = spps.iter().map(|&n| rmse(&render(n, 7, sampler), &reference).unwrap()).collect();
        let xs: Vec<f64> = spps.iter().map(|&n| n as f64).collect();
        log_log_slope(&xs, &errors).unwrap()
    };
    let (independent, jittered) = (slope(SamplerKind::Independent), slope(SamplerKind::Jittered));
    println!("slope of log RMSE against log spp: independent {independent:.3}, jittered {jittered:.3}");
    // Independent sampling converges as spp^-1/2; stratification does better on a smooth blur.
    assert!((independent + 0.5).abs() < 0.1, "independent slope {independent}");
    assert!(jittered < independent - 0.1, "jittered {jittered} must be steeper than independent {independent}");
}
