//! What each distribution effect costs, and that a scene using none of them pays nothing for them.
//!
//! `cargo bench --bench effects` — single-threaded renders of small images, so the figures are
//! comparable between runs; see docs/PERFORMANCE.md#one-render-loop-per-set-of-effects.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use raylume::prelude::*;

fn scene(name: &str) -> Option<Scene> {
    if name == "default" {
        return Some(p3f::parse(raylume::scene::DEFAULT_SCENE, "default", &Default::default()).unwrap().scene);
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes").join(format!("{name}.p3f"));
    if !path.is_file() {
        eprintln!("skipped {name}: ../shared is absent");
        return None;
    }
    Some(p3f::load(&path, &Default::default()).unwrap().scene)
}

fn plain(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut group = c.benchmark_group("plain");
    group.sample_size(30);
    for name in ["default", "balls_low", "balls_medium"] {
        let Some(scene) = scene(name) else { continue };
        let options =
            RenderOptions { spp: Some(1), resolution: Some((160, 120)), use_env: false, ..RenderOptions::default() };
        group.bench_function(name, |b| b.iter(|| pool.install(|| scene.render(&options, &|| {}).unwrap())));
    }
    group.finish();
}

/// Each effect alone on its example scene (assets/scenes), against the same scene with the effect
/// switched off through the options: the ratio is the effect's own cost.
fn effects(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut group = c.benchmark_group("effect");
    group.sample_size(20);
    let load = |name: &str| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes").join(format!("{name}.p3f"));
        p3f::load(&path, &Default::default()).unwrap().scene
    };
    let base = RenderOptions { spp: Some(1), resolution: Some((160, 100)), ..RenderOptions::default() };
    let with_spp = |spp| RenderOptions { spp: Some(spp), ..base.clone() };
    let cases: Vec<(&str, &str, RenderOptions, RenderOptions)> = vec![
        ("antialiasing", "antialiasing_16spp", with_spp(16), base.clone()),
        (
            "soft_shadows",
            "soft_shadows_grid",
            base.clone(),
            RenderOptions { area_light_size: Some(0.0), ..base.clone() },
        ),
        (
            "soft_shadows",
            "soft_shadows_stratified_16spp",
            with_spp(16),
            RenderOptions { area_light_size: Some(0.0), ..with_spp(16) },
        ),
        ("depth_of_field", "depth_of_field", base.clone(), RenderOptions { aperture: Some(0.0), ..base.clone() }),
        (
            "fuzzy_reflections",
            "fuzzy_reflections",
            base.clone(),
            RenderOptions { roughness: Some(0.0), ..base.clone() },
        ),
        ("motion_blur", "motion_blur", base.clone(), RenderOptions { shutter: Some((0.0, 0.0)), ..base.clone() }),
    ];
    for (scene_name, label, on, off) in cases {
        let scene = load(scene_name);
        group.bench_function(format!("{label}/on"), |b| b.iter(|| pool.install(|| scene.render(&on, &|| {}).unwrap())));
        group.bench_function(format!("{label}/off"), |b| {
            b.iter(|| pool.install(|| scene.render(&off, &|| {}).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, plain, effects);
criterion_main!(benches);
