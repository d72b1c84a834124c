//! What an embedder relies on: a scene file with a cubemap renders with default options and its own
//! `spp`; renders report the samples they drew, can be observed and cancelled, and run progressively
//! for as long as asked; OBJ normals shade meshes smoothly and survive the p3f writer.

use std::ops::ControlFlow;
use std::path::PathBuf;

use raylume_geometry::{Vec3, Vec3A};
use raylume_material::Phong;
use raylume_render::{CancelToken, RenderOptions, RenderScene, SamplerKind};
use raylume_scene::p3f::{LoadOptions, load, parse};
use raylume_scene::{DEFAULT_SCENE, Scene, SceneBuilder, SceneError, Shape, obj};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("raylume-render-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn default_scene() -> Scene {
    parse(DEFAULT_SCENE, "default", &LoadOptions::default()).unwrap().scene
}

fn small() -> RenderOptions {
    RenderOptions { resolution: Some((16, 10)), ..RenderOptions::default() }
}

#[test]
fn a_scene_file_with_a_cubemap_renders_with_default_options_and_its_own_spp() {
    let dir = temp_dir("cubemap");
    std::fs::create_dir(dir.join("sky")).unwrap();
    for face in raylume_scene::CUBEMAP_FACES {
        image::RgbImage::from_pixel(2, 2, image::Rgb([255, 0, 0]))
            .save(dir.join("sky").join(format!("{face}.png")))
            .unwrap();
    }
    let text = "spp 4\nenv sky\nbclr 0 0 0\nv from 0 0 5 at 0 0 0 up 0 1 0 angle 40 hither 0 resolution 8 6\n";
    std::fs::write(dir.join("scene.p3f"), text).unwrap();
    let loaded = load(dir.join("scene.p3f"), &LoadOptions::default()).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let out = loaded.scene.render(&RenderOptions::default(), &()).unwrap();
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    assert_eq!(out.samples_per_pixel, 4, "the scene's spp");
    assert!(out.features.antialiasing);
    assert!(out.film.pixels().iter().all(|&p| p == Vec3::X), "every ray escapes into the red sky");
    let without = loaded.scene.render(&RenderOptions { use_env: false, ..RenderOptions::default() }, &()).unwrap();
    assert!(without.film.pixels().iter().all(|&p| p == Vec3::ZERO), "bclr without the cubemap");
}

#[test]
fn renders_report_the_samples_their_sampler_drew() {
    let scene = default_scene();
    let drawn = |sampler, spp| {
        let options = RenderOptions { spp: Some(spp), sampler, ..small() };
        scene.render(&options, &()).unwrap().samples_per_pixel
    };
    // At most four passes of equal share, as few samples as the sampler allows beyond those asked.
    assert_eq!(drawn(SamplerKind::Sobol, 8), 8);
    assert_eq!(drawn(SamplerKind::Independent, 5), 6, "3 passes of 2");
    assert_eq!(drawn(SamplerKind::Jittered, 8), 8, "2 passes of 2 x 2");
    assert_eq!(drawn(SamplerKind::Jittered, 16), 16, "4 passes of 2 x 2");
    assert_eq!(drawn(SamplerKind::Jittered, 9), 12, "3 passes of 3, rounded up to 2 x 2");
    assert_eq!(drawn(SamplerKind::Jittered, 1), 1);
    let one_pass = |spp| RenderOptions { spp: Some(spp), passes: 1, ..small() };
    assert_eq!(scene.render(&one_pass(9), &()).unwrap().samples_per_pixel, 9, "one pass of 3 x 3");
    let zero = RenderOptions { spp: Some(0), ..small() };
    assert_eq!(scene.render(&zero, &()).unwrap_err().to_string(), "spp 0: expected 1..=65536 samples per pixel");
}

#[test]
fn an_observer_hears_every_row_and_a_token_cancels_from_another_thread() {
    let scene = default_scene();
    let rows = std::sync::atomic::AtomicU32::new(0);
    let count = || {
        rows.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    };
    scene.render(&small(), &count).unwrap();
    assert_eq!(rows.load(std::sync::atomic::Ordering::Relaxed), 10 * 4, "each row of the 4 passes");

    // Cancelled while it runs (by the first finished row), the render stops with an error.
    let cancel = CancelToken::new();
    let stop = || cancel.cancel();
    let big = RenderOptions { resolution: Some((64, 400)), ..RenderOptions::default() };
    let result = scene.render(&big, &(stop, cancel.clone()));
    assert!(matches!(result, Err(SceneError::Cancelled)), "{:?}", result.map(|o| o.stats));
    assert_eq!(SceneError::Cancelled.to_string(), "the render was cancelled");

    // A progressive render is cancelled the same way, and its callback is not called again.
    let cancel = CancelToken::new();
    let mut passes = 0;
    let result = scene.render_progressive(&small(), &cancel, |_| {
        passes += 1;
        cancel.cancel();
        ControlFlow::Continue(())
    });
    assert!(matches!(result, Err(SceneError::Cancelled)));
    assert_eq!(passes, 1);
}

#[test]
fn a_progressive_render_runs_until_its_callback_stops_it() {
    let scene = default_scene();
    let options = RenderOptions { spp: Some(1), passes: 1, time_limit: Some(f64::INFINITY), ..small() };
    let mut seen = Vec::new();
    let out = scene
        .render_progressive(&options, &(), |p| {
            seen.push(p.samples_per_pixel);
            if p.pass == 5 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
        })
        .unwrap();
    assert_eq!(seen, [1, 2, 3, 4, 5, 6]);
    assert_eq!((out.samples_per_pixel, out.passes), (6, 6));
    let bad = RenderOptions { passes: 0, ..options };
    let refused = scene.render_progressive(&bad, &(), |_| ControlFlow::Continue(())).unwrap_err();
    assert_eq!(refused.to_string(), "passes 0: expected 1..=65536");
}

#[test]
fn budgets_stop_the_passes() {
    let scene = default_scene();
    // A noise threshold: passes go on until the estimate reaches it, and no longer.
    let options = RenderOptions { spp: Some(4), passes: 1, noise_threshold: Some(0.02), ..small() };
    let mut estimates = Vec::new();
    let out = scene
        .render_progressive(&options, &(), |p| {
            estimates.push(p.estimate.map(|e| e.rmse));
            ControlFlow::Continue(())
        })
        .unwrap();
    let last = out.estimate.unwrap().rmse;
    assert!(last <= 0.02, "stopped at {last}");
    assert!(estimates[..estimates.len() - 1].iter().all(|e| e.is_none_or(|e| e > 0.02)), "{estimates:?}");
    assert!(out.passes >= 3, "{} passes: the threshold needs several", out.passes);

    // A time limit: the render ends by then (within a pass), having rendered more than one pass.
    let options = RenderOptions { spp: Some(1), passes: 1, time_limit: Some(0.5), ..small() };
    let start = std::time::Instant::now();
    let out = scene.render(&options, &()).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    assert!(out.passes > 1, "{} passes in {seconds} s", out.passes);
    let pass = out.render_seconds / out.passes as f64;
    assert!(seconds < 0.5 + 2.0 * pass + 0.1, "{seconds} s for a limit of 0.5 s and passes of {pass} s");

    let refused = scene.render(&RenderOptions { time_limit: Some(-1.0), ..small() }, &()).unwrap_err();
    assert_eq!(refused.to_string(), "time limit -1: expected seconds > 0");
    let refused = scene.render(&RenderOptions { noise_threshold: Some(f64::NAN), ..small() }, &()).unwrap_err();
    assert_eq!(refused.to_string(), "noise threshold NaN: expected an RMSE > 0");
}

#[test]
fn adaptive_sampling_spends_the_uniform_samples_where_the_noise_is_the_same_on_any_thread_count() {
    let scene = default_scene();
    let options = RenderOptions {
        spp: Some(32),
        passes: 16,
        adaptive: true,
        resolution: Some((64, 40)),
        ..RenderOptions::default()
    };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| scene.render(&options, &())).unwrap();
    let b = three.install(|| scene.render(&options, &())).unwrap();
    assert_eq!(a.film, b.film, "the same image on one thread and on three");
    assert_eq!(a.variance, b.variance);
    // As many samples as the uniform render (8 passes of 2 x 2), within one pass's worth, spread
    // unevenly.
    let uniform = 32.0;
    assert!((a.mean_samples_per_pixel - uniform).abs() <= 4.0 + 1e-9, "{}", a.mean_samples_per_pixel);
    assert!(a.samples_per_pixel > 32, "the noisiest pixels got more than the uniform render: {}", a.samples_per_pixel);
    let v = a.variance.as_ref().unwrap();
    let calm = (0..v.pixels().len()).filter(|&i| v.pixels()[i] == raylume_geometry::Vec3::ZERO).count();
    assert!(calm > 0, "some pixels never vary");
}

/// A tilted square of two triangles under a light, with `normals` (per triangle corner) if any.
fn panel(normals: Vec<[Vec3A; 3]>) -> Scene {
    let vertices = vec![
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(1.0, 1.0, 0.0),
        Vec3A::new(-1.0, 1.0, 0.0),
    ];
    SceneBuilder::new()
        .camera([0.0, 0.0, 4.0], [0.0; 3], [0.0, 1.0, 0.0], 40.0, 24, 24)
        .light([0.0, 0.0, 20.0], [1.0; 3])
        .material(Phong { diffuse: Vec3::ONE, kd: 0.9, ..Phong::default() })
        .shape(Shape::Mesh { vertices, triangles: vec![[0, 1, 2], [0, 2, 3]], normals })
        .build()
        .unwrap()
}

#[test]
fn mesh_normals_shade_smoothly_and_survive_the_writer() {
    let options = RenderOptions { spp: Some(1), ..RenderOptions::default() };
    let flat = panel(Vec::new()).render(&options, &()).unwrap().film;
    let facing = panel(vec![[Vec3A::Z; 3]; 2]).render(&options, &()).unwrap().film;
    assert_eq!(flat, facing, "normals equal to the face's shade as the face does");
    let tilted = [Vec3A::new(-1.0, 0.0, 1.0), Vec3A::new(1.0, 0.0, 1.0), Vec3A::new(1.0, 0.0, 1.0)];
    let bowl = panel(vec![tilted, [tilted[0], tilted[2], tilted[0]]]);
    let smooth = bowl.render(&options, &()).unwrap().film;
    assert_ne!(smooth, flat, "the corner normals change the shading");
    // Written as p3f (patches) and read back, it renders the same.
    let again = parse(&bowl.to_p3f(), "bowl.p3f", &LoadOptions::default()).unwrap().scene;
    assert_eq!(again.render(&options, &()).unwrap().film, smooth);
}

#[test]
fn obj_files_keep_their_normals_and_load_into_place() {
    let dir = temp_dir("obj");
    let path = dir.join("tri.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 1 1\nf 1//1 2//1 3//2\n").unwrap();
    let Shape::Mesh { normals, .. } = obj::load(&path).unwrap() else { panic!("a mesh") };
    assert_eq!(normals, [[Vec3A::Z, Vec3A::Z, Vec3A::new(0.0, 1.0, 1.0)]]);
    let flat = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "flat.obj").unwrap();
    assert!(matches!(flat, Shape::Mesh { ref normals, .. } if normals.is_empty()));

    let place = obj::Transform { scale: 2.0, translate: Vec3A::new(1.0, 0.0, -1.0) };
    let Shape::Mesh { vertices, normals: kept, .. } = obj::load_transformed(&path, place).unwrap() else {
        panic!("a mesh")
    };
    assert_eq!(vertices, [Vec3A::new(1.0, 0.0, -1.0), Vec3A::new(3.0, 0.0, -1.0), Vec3A::new(1.0, 2.0, -1.0)]);
    assert_eq!(kept, normals);
    let bad = obj::load_transformed(&path, obj::Transform { scale: 0.0, ..obj::Transform::default() });
    assert!(bad.unwrap_err().to_string().starts_with("obj transform: expected a positive scale"));
    let missing = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nvn 0 0 0\n", "n.obj");
    assert!(missing.is_ok());
}

/// A render's passes can be rendered apart (`pass_range`, as machines of a farm would) and put
/// together in order: the same image and variance, bit for bit.
#[test]
fn passes_rendered_apart_and_put_together_in_order_are_the_whole_render() {
    let scene = default_scene();
    let options = RenderOptions { spp: Some(16), passes: 4, resolution: Some((24, 15)), ..RenderOptions::default() };
    let passes_of = |options: &RenderOptions| {
        let mut films = Vec::new();
        let out = scene
            .render_progressive(options, &(), |p| {
                films.push(p.pass_film.clone());
                ControlFlow::Continue(())
            })
            .unwrap();
        (out, films)
    };
    let (whole, whole_passes) = passes_of(&options);
    assert_eq!(whole_passes.len(), 4);
    let mut apart = Vec::new();
    for range in [(0, 1), (1, 3), (3, 4)] {
        let (out, films) = passes_of(&RenderOptions { pass_range: Some(range), ..options.clone() });
        assert_eq!((out.passes, out.samples_per_pixel), (range.1 - range.0, 4 * (range.1 - range.0) as u64));
        apart.extend(films);
    }
    assert_eq!(apart, whole_passes, "each pass is the same wherever it is rendered");
    let mut together = raylume_render::Accumulator::new(24, 15);
    for film in &apart {
        together.add_pass(film, None);
    }
    assert_eq!(together.film(), whole.film);
    assert_eq!(together.variance_film(), whole.variance);
    let refused = scene.render(&RenderOptions { pass_range: Some((2, 5)), ..options.clone() }, &()).unwrap_err();
    assert_eq!(refused.to_string(), "passes 2..5: expected a range within 0..4 and no budget or adaptive sampling");
    // 8 samples are 2 passes of 2 x 2: their range is within 0..2.
    let eight = RenderOptions { spp: Some(8), pass_range: Some((1, 3)), ..options.clone() };
    assert_eq!(scene.render(&eight, &()).unwrap_err().to_string(), "passes 1..3: the render has 2 passes of 4 samples");
}
