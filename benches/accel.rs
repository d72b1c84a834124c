//! Accelerators: build time and closest-hit throughput on the bunny and on the sphereflake at three
//! sizes, with coherent camera rays and incoherent random rays (fixed seed).
//!
//! `cargo bench --bench accel` (single-threaded; see docs/PERFORMANCE.md#binned-sah-build).

use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use raylume::accel::{BvhBuild, Grid, GridParams};
use raylume::prelude::*;
use raylume::scene::{procedural, rays};

const RAYS: usize = 16_384;

fn scenes() -> Vec<(String, Scene)> {
    let mut out = Vec::new();
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes/bunny.obj");
    match raylume::scene::obj::load(&bunny) {
        Ok(mesh) => out.push(("bunny".to_owned(), procedural::mesh_view(mesh, 512, 512))),
        Err(e) => eprintln!("skipped the bunny: {e}"),
    }
    for depth in [2, 4, 5] {
        let scene = procedural::sphereflake(depth).unwrap();
        out.push((format!("balls{depth}_{}", scene.primitive_count()), scene));
    }
    out
}

fn build_and_trace(c: &mut Criterion) {
    // Builds on one thread: a BVH's build would otherwise use rayon's pool.
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    for (name, scene) in scenes() {
        let prims = scene.primitives().primitives;
        let n = prims.len();
        let shutter = scene.shutter();
        let bounds = Bvh::new(prims.clone(), shutter).bounds();
        let ray_sets =
            [("camera", rays::camera_rays(&scene.view, RAYS)), ("random", rays::random_rays(&bounds, RAYS, 1))];

        let mut group = c.benchmark_group(format!("build/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function("bvh", |b| b.iter(|| one.install(|| Bvh::new(prims.clone(), shutter))));
        group.bench_function("bvh-midpoint", |b| {
            b.iter(|| one.install(|| Bvh::with_build(prims.clone(), shutter, BvhBuild::Midpoint)))
        });
        group.bench_function("grid", |b| b.iter(|| Grid::new(prims.clone(), shutter, GridParams::default())));
        group.finish();

        let mut group = c.benchmark_group(format!("trace/{name}"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(RAYS as u64));
        fn trace<A: Accelerator>(accel: &A, rays: &[Ray]) -> usize {
            rays.iter().filter(|r| accel.closest_hit(r, Interval::POSITIVE).is_some()).count()
        }
        let bvh = Bvh::new(prims.clone(), shutter);
        let mid = Bvh::with_build(prims.clone(), shutter, BvhBuild::Midpoint);
        let grid = Grid::new(prims.clone(), shutter, GridParams::default());
        let brute = BruteForce::new(prims.clone());
        for (kind, rays) in &ray_sets {
            group.bench_with_input(BenchmarkId::new("bvh", kind), rays, |b, r| b.iter(|| trace(&bvh, r)));
            group.bench_with_input(BenchmarkId::new("bvh-midpoint", kind), rays, |b, r| b.iter(|| trace(&mid, r)));
            group.bench_with_input(BenchmarkId::new("grid", kind), rays, |b, r| b.iter(|| trace(&grid, r)));
            if n <= 100 {
                group.bench_with_input(BenchmarkId::new("none", kind), rays, |b, r| b.iter(|| trace(&brute, r)));
            }
        }
        group.finish();
    }
}

criterion_group!(benches, build_and_trace);
criterion_main!(benches);
