//! What each distribution effect costs, and that a scene using none of them pays nothing for them.
//!
//! `cargo bench --bench effects` — single-threaded renders of small images, so the figures are
//! comparable between runs; see docs/PERFORMANCE.md.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use raylume::prelude::*;

fn scene(name: &str) -> Option<Scene> {
    if name == "default" {
        return Some(p3f::parse(raylume::scene::DEFAULT_SCENE, "default", &Default::default()).unwrap().0);
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes").join(format!("{name}.p3f"));
    if !path.is_file() {
        eprintln!("skipped {name}: ../shared is absent");
        return None;
    }
    Some(p3f::load(&path, &Default::default()).unwrap().0)
}

fn plain(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut group = c.benchmark_group("plain");
    group.sample_size(30);
    for name in ["default", "balls_low", "balls_medium"] {
        let Some(scene) = scene(name) else { continue };
        let options = RenderOptions {
            settings: RenderSettings { spp: 1, ..RenderSettings::default() },
            resolution: Some((160, 120)),
            use_env: false,
            ..RenderOptions::default()
        };
        group.bench_function(name, |b| b.iter(|| pool.install(|| scene.render(&options, &|| {}).unwrap())));
    }
    group.finish();
}

criterion_group!(benches, plain);
criterion_main!(benches);
