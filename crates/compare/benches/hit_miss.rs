//! Where the time goes: the comparison's ray sets split into the rays that hit the mesh and those
//! that miss it (both engines agree on which), each subset timed on both engines (best of seven
//! passes, single-threaded), with raylume's nodes visited and triangles tested per ray by its
//! closest-hit and its occlusion queries. Camera rays that miss are mostly per-ray set-up; rays that
//! hit are mostly traversal and triangle tests. A third row per ray kind, `all`, times every ray in the
//! set's own order (the camera's row by row), as the comparison bench does: hits and misses interleaved.
//!
//! `cargo bench -p raylume-compare --bench hit_miss [-- MESH...]` (default: all three bunny meshes;
//! `RAYLUME_COMPARE_SIDE` sets the view's side, 512 by default).
//!
//! `RAYLUME_SPLIT_ONCE=camera-hit` (or `camera-miss`, `camera-all`, `random-hit`, ...) instead runs
//! raylume's closest-hit and occlusion queries once over that subset of the first mesh and exits: a
//! fixed workload for `valgrind --tool=callgrind --branch-sim=yes`, whose instruction and
//! mispredicted-branch counts do not move with the machine's load (`RAYLUME_SPLIT_QUERY=closest` or
//! `occluded` runs only that query; `RAYLUME_SPLIT_REPEAT=n` runs it n times, for a sampling profiler).
//! `RAYLUME_KERNEL=portable` measures raylume's portable kernel where the CPU would pick AVX2.

mod common;

use std::time::Instant;

use common::{Obvhs, to_obvhs, to_obvhs_triangles};
use raylume_accel::{Accelerator, Bvh, BvhBuild, BvhKernel, Counts};
use raylume_compare::{load_shared, shared_meshes};
use raylume_geometry::{Interval, Ray};
use raylume_intersect::Primitive;

/// Mrays/s of `query` over `n` rays, the best of seven passes.
fn mrays(n: usize, mut query: impl FnMut() -> usize) -> f64 {
    let best = (0..7)
        .map(|_| {
            let start = Instant::now();
            std::hint::black_box(query());
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min);
    n as f64 / best / 1e6
}

fn main() {
    let Some(dir) = shared_meshes() else {
        eprintln!("skipped: ../shared/meshes is not beside the repository");
        return;
    };
    let side = std::env::var("RAYLUME_COMPARE_SIDE").ok().and_then(|s| s.parse().ok()).unwrap_or(512);
    let once = std::env::var("RAYLUME_SPLIT_ONCE").ok();
    let mut meshes: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    if meshes.is_empty() {
        meshes = ["bunny", "bunny_loop2", "bunny_loop3"].map(String::from).to_vec();
    }
    if once.is_none() {
        println!(
            "| mesh | rays | subset | count | closest raylume/obvhs Mrays/s | ratio | occluded raylume/obvhs | ratio | visited | tested | visited / tested (occluded) |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|");
    }
    for mesh in meshes {
        let Some(w) = load_shared(&dir, &mesh, side) else { continue };
        let prims: Vec<Primitive> = w.triangles.iter().map(|&t| Primitive::Triangle(t)).collect();
        let kernel = match std::env::var("RAYLUME_KERNEL").as_deref() {
            Ok("portable") => BvhKernel::Portable,
            _ => BvhKernel::best(),
        };
        let ours = Bvh::with_kernel(prims, Interval::new(0.0, 0.0), BvhBuild::Sah, kernel);
        let theirs = Obvhs::build(&to_obvhs_triangles(&w.triangles));
        for (kind, rays) in [("camera", &w.camera), ("random", &w.random)] {
            // Split by obvhs's answer, so that raylume runs only the measured passes.
            let (hit, miss): (Vec<Ray>, Vec<Ray>) = rays.iter().partition(|r| theirs.closest(&to_obvhs(r)).is_some());
            for (subset, set) in [("hit", &hit), ("miss", &miss), ("all", rays)] {
                let name = format!("{kind}-{subset}");
                if let Some(once) = &once {
                    if *once == name {
                        let query = std::env::var("RAYLUME_SPLIT_QUERY").unwrap_or_default();
                        let repeat: usize =
                            std::env::var("RAYLUME_SPLIT_REPEAT").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
                        let (mut closest, mut occluded) = (0, 0);
                        for _ in 0..repeat {
                            if query != "occluded" {
                                closest =
                                    set.iter().filter(|r| ours.closest_hit(r, Interval::POSITIVE).is_some()).count();
                            }
                            if query != "closest" {
                                occluded = set.iter().filter(|r| ours.occluded(r, f32::INFINITY)).count();
                            }
                        }
                        println!("{} rays: {closest} hit, {occluded} occluded", set.len());
                        return;
                    }
                    continue;
                }
                // Both engines from the same rays, each making its own ray type in the timed loop (as in
                // the comparison bench).
                let n = set.len();
                let ours_closest =
                    mrays(n, || set.iter().filter(|r| ours.closest_hit(r, Interval::POSITIVE).is_some()).count());
                let theirs_closest = mrays(n, || set.iter().filter(|r| theirs.closest(&to_obvhs(r)).is_some()).count());
                let ours_occluded = mrays(n, || set.iter().filter(|r| ours.occluded(r, f32::INFINITY)).count());
                let theirs_occluded = mrays(n, || set.iter().filter(|r| theirs.occluded(&to_obvhs(r))).count());
                let (mut counts, mut any_counts) = (Counts::default(), Counts::default());
                for r in set.iter() {
                    ours.closest_hit_tally(r, Interval::POSITIVE, &mut counts);
                    ours.occluded_tally(r, f32::INFINITY, &mut any_counts);
                }
                let per_ray = |v: u64| v as f64 / n.max(1) as f64;
                println!(
                    "| {mesh} | {kind} | {subset} | {n} | {ours_closest:.2} / {theirs_closest:.2} | {:.2} | {ours_occluded:.2} / {theirs_occluded:.2} | {:.2} | {:.2} | {:.2} | {:.2} / {:.2} |",
                    ours_closest / theirs_closest,
                    ours_occluded / theirs_occluded,
                    per_ray(counts.visited),
                    per_ray(counts.tested),
                    per_ray(any_counts.visited),
                    per_ray(any_counts.tested),
                );
            }
        }
    }
}
