//! End-to-end rendering tests: silhouettes against analytic coverage, every course scene, the course's
//! reference image, determinism across thread counts, and optics seen through the integrator.

use std::path::{Path, PathBuf};

use raylume::integrator::metrics::rmse;
use raylume::prelude::*;

fn shared() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipped: ../shared is absent");
        None
    }
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(f)
}

/// A lone sphere seen head-on covers the fraction of the image its projected disc predicts.
#[test]
fn lone_sphere_silhouette_matches_the_analytic_fraction() {
    let (dist, radius, fov, size) = (6.0f32, 1.3f32, 40.0f32, 256u32);
    // Lit from the eye, so every visible point of the sphere is brighter than the black background.
    let scene = SceneBuilder::new()
        .camera(Vec3A::new(0.0, 0.0, dist), Vec3A::ZERO, Vec3A::Y, fov, size, size)
        .light(Vec3A::new(0.0, 0.0, dist), Vec3::ONE)
        .material(Phong { diffuse: Vec3::ONE, kd: 1.0, ..Phong::default() })
        .sphere(Vec3A::ZERO, radius)
        .build()
        .unwrap();
    let out = scene.render(&RenderOptions::default(), &|| {}).unwrap();
    let covered = out.film.pixels().iter().filter(|c| c.x > 0.0).count() as f64;
    let fraction = covered / (size * size) as f64;
    // The silhouette is a disc of angular radius asin(r/D); on the view plane at distance d its
    // radius is d tan(asin(r/D)), and the image is 2 d tan(fov/2) high.
    let half_angle = (radius as f64 / dist as f64).asin();
    let disc = half_angle.tan() / (fov as f64 / 2.0).to_radians().tan();
    let expected = std::f64::consts::PI * disc * disc / 4.0;
    assert!((fraction - expected).abs() / expected < 0.01, "coverage {fraction} vs analytic {expected}");
}

/// A glass sphere whose index matches the air is invisible: the image is the background alone.
#[test]
fn index_matched_glass_is_invisible() {
    let build = |with_sphere: bool| {
        let mut b = SceneBuilder::new()
            .camera(Vec3A::new(0.0, 0.0, 5.0), Vec3A::ZERO, Vec3A::Y, 40.0, 48, 48)
            .background(Vec3::new(0.2, 0.4, 0.6))
            .light(Vec3A::new(5.0, 5.0, 5.0), Vec3::ONE)
            .material(Phong { diffuse: Vec3::new(0.9, 0.1, 0.1), kd: 0.9, ..Phong::default() })
            .aabox(Vec3A::new(-0.4, -0.4, -3.0), Vec3A::new(0.4, 0.4, -2.5))
            .material(Phong {
                diffuse: Vec3::ZERO,
                kd: 0.0,
                specular: Vec3::ONE,
                ks: 0.0,
                transmittance: 1.0,
                ior: 1.0,
                ..Phong::default()
            });
        if with_sphere {
            b = b.sphere(Vec3A::ZERO, 1.2);
        }
        b.build().unwrap().render(&RenderOptions::default(), &|| {}).unwrap().film
    };
    let (glass, empty) = (build(true), build(false));
    let diff =
        glass.pixels().iter().zip(empty.pixels()).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0, f32::max);
    // The box behind the sphere is seen through it undistorted (shadow rays stop at the glass,
    // but the box is lit from the front-right, away from the sphere's shadow).
    assert!(diff < 1e-3, "index-matched glass changed a pixel by {diff}");
    // And a real glass sphere (n = 1.5) does change it.
    let real = {
        SceneBuilder::new()
            .camera(Vec3A::new(0.0, 0.0, 5.0), Vec3A::ZERO, Vec3A::Y, 40.0, 48, 48)
            .background(Vec3::new(0.2, 0.4, 0.6))
            .light(Vec3A::new(5.0, 5.0, 5.0), Vec3::ONE)
            .material(Phong { diffuse: Vec3::new(0.9, 0.1, 0.1), kd: 0.9, ..Phong::default() })
            .aabox(Vec3A::new(-0.4, -0.4, -3.0), Vec3A::new(0.4, 0.4, -2.5))
            .material(Phong { kd: 0.0, transmittance: 1.0, ior: 1.5, ..Phong::default() })
            .sphere(Vec3A::ZERO, 1.2)
            .build()
            .unwrap()
            .render(&RenderOptions::default(), &|| {})
            .unwrap()
            .film
    };
    assert_ne!(real.pixels(), empty.pixels());
}

/// The same seed gives the same bytes on 1 and 2 threads; another seed gives other bytes.
#[test]
fn images_are_identical_whatever_the_thread_count() {
    let scene = p3f::parse(raylume::scene::DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
    let options = |seed| RenderOptions {
        spp: Some(4),
        settings: RenderSettings { seed, ..RenderSettings::default() },
        resolution: Some((96, 60)),
        ..RenderOptions::default()
    };
    let one = in_pool(1, || scene.render(&options(1), &|| {}).unwrap());
    let two = in_pool(2, || scene.render(&options(1), &|| {}).unwrap());
    assert_eq!(one.film.to_rgb8(), two.film.to_rgb8());
    assert_eq!(one.film.pixels(), two.film.pixels());
    assert_eq!(one.stats, two.stats);
    let other = in_pool(2, || scene.render(&options(2), &|| {}).unwrap());
    assert_ne!(one.film.pixels(), other.film.pixels());
}

/// Every accelerator renders the same image as the brute-force list.
#[test]
fn accelerators_render_identical_images() {
    let scene = p3f::parse(raylume::scene::DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
    let render = |accel| {
        let o =
            RenderOptions { accel: Some(accel), spp: Some(1), resolution: Some((80, 50)), ..RenderOptions::default() };
        scene.render(&o, &|| {}).unwrap().film
    };
    let reference = render(AccelKind::None);
    for kind in [AccelKind::Bvh, AccelKind::BvhPortable, AccelKind::BvhMidpoint, AccelKind::Grid] {
        assert_eq!(reference.pixels(), render(kind).pixels(), "{kind:?}");
    }
}

/// Where the BVH gathers camera rays (a scene with triangles: tiles of 8x8 pixels, 64 samples per
/// query), the image and the ray counts are those of one query per ray: antialiased, with a lens and
/// soft shadows, at a size that is no multiple of the tile, and cropped.
#[test]
fn gathered_camera_rays_render_the_image_of_single_queries() {
    let scene = raylume::scene::procedural::Generator::Mount.generate(3).unwrap();
    assert!(scene.primitive_count() > 100);
    let render = |accel, crop| {
        let o = RenderOptions {
            accel: Some(accel),
            spp: Some(4),
            resolution: Some((37, 21)),
            aperture: Some(2.0),
            area_light_size: Some(0.5),
            settings: RenderSettings { crop, ..RenderSettings::default() },
            ..RenderOptions::default()
        };
        scene.render(&o, &()).unwrap()
    };
    for crop in [None, Some([3, 2, 30, 19])] {
        let (single, gathered) = (render(AccelKind::None, crop), render(AccelKind::Bvh, crop));
        assert_eq!(single.film.pixels(), gathered.film.pixels(), "crop {crop:?}");
        assert_eq!(single.stats, gathered.stats, "crop {crop:?}");
    }
}

/// Every course scene renders at a small size, without error, and not as a flat image.
#[test]
fn every_course_scene_renders() {
    let Some(shared) = shared() else { return };
    let mut count = 0;
    for entry in std::fs::read_dir(shared.join("scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "p3f") {
            continue;
        }
        let scene = p3f::load(&path, &Default::default()).unwrap().scene;
        let options = RenderOptions {
            resolution: Some((48, 36)),
            env_dirs: vec![path.parent().unwrap().to_path_buf(), path.parent().unwrap().join("..")],
            ..RenderOptions::default()
        };
        let out = scene.render(&options, &|| {}).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let first = out.film.pixels()[0];
        assert!(out.film.pixels().iter().any(|p| *p != first), "{} rendered a constant image", path.display());
        assert!(out.film.pixels().iter().all(|p| p.is_finite()), "{}: NaN or infinite pixel", path.display());
        count += 1;
    }
    assert_eq!(count, 12);
}

/// The render of balls_low matches the course's own image closely (see README for the figure).
#[test]
fn balls_low_matches_the_course_reference() {
    let Some(shared) = shared() else { return };
    let scene = p3f::load(shared.join("scenes/balls_low.p3f"), &Default::default()).unwrap().scene;
    let reference = image::open(shared.join("refimages/balls_low.png")).unwrap().into_rgb8();
    let ref_values: Vec<f32> = reference.as_raw().iter().map(|&v| v as f32 / 255.0).collect();
    let error = |specular_scale| {
        let options = RenderOptions { use_env: false, specular_scale, ..RenderOptions::default() };
        let film = scene.render(&options, &|| {}).unwrap().film;
        assert_eq!((film.width(), film.height()), reference.dimensions());
        let ours: Vec<f32> = film.to_rgb8().iter().map(|&v| v as f32 / 255.0).collect();
        rmse(&ours, &ref_values).unwrap()
    };
    let plain = error(1.0);
    let fitted = error(0.27);
    println!("balls_low RMSE: plain model {plain:.4}, specular scale 0.27: {fitted:.4}");
    assert!(plain < 0.045, "plain model RMSE {plain}");
    assert!(fitted < 0.022, "fitted RMSE {fitted}");
    assert!(fitted < plain);
}
