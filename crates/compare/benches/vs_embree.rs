//! raylume's BVH against Embree 3 called as an Embree user calls it, on the same triangles and the
//! same rays, single-threaded: `rtcIntersect1` / `rtcOccluded1` per ray on a scene of medium build
//! quality with no flags, and on a second scene with `RTC_SCENE_FLAG_ROBUST`, for the camera and the
//! random rays of each bunny mesh; then the camera rays in 8x8 tiles through raylume's batch queries
//! (runs of 64) against Embree's packets (`rtcIntersect8` / `rtcOccluded8`, a tile's row per packet)
//! and streams (`rtcIntersect1M` / `rtcOccluded1M`, a tile per call), both with the coherent flag.
//! What each Embree call makes per ray is in [`common::Embree`].
//!
//! Every row is timed in alternating passes (raylume, Embree, the other Embree call, then again
//! from the next engine on: each pass all rays of the set once), the median pass of each engine, so
//! that the machine's load falls on all engines alike. It prints the tables that
//! docs/PERFORMANCE.md#against-obvhs-and-embree carries and how many rays each engine found hit or
//! occluded.
//!
//! `cargo bench -p raylume-compare --features embree --bench vs_embree [-- MESH...]` (default: all
//! three meshes). `RAYLUME_COMPARE_SIDE=512` shrinks the 1024x1024 ray sets; `RAYLUME_EMBREE_PASSES`
//! sets the passes per engine (9).
//!
//! `RAYLUME_EMBREE_ONCE=ENGINE/QUERY/RAYS` instead runs one engine's pass once over the first mesh and
//! exits, a fixed workload for `valgrind --tool=callgrind`: ENGINE is `raylume`, `embree`, `robust`
//! (single rays), `batch`, `packet` or `stream` (tiles of camera rays); QUERY `closest` or
//! `occluded`; RAYS `camera` or `random`. `RAYLUME_EMBREE_REPEAT=n` runs that pass n times, for a
//! sampling profiler.

use std::hint::black_box;
use std::time::Instant;

mod common;

use common::Embree;
use raylume_accel::{Accelerator, Bvh};
use raylume_compare::{load_shared, shared_meshes};
use raylume_geometry::{Interval, Ray};
use raylume_intersect::Primitive;

/// The rays of an 8x8 tile: a batch query's run, and an Embree stream's.
const TILE: usize = 64;

/// One pass of an engine over a ray set: how many rays it found hit (or occluded).
type Pass<'a> = Box<dyn FnMut() -> usize + 'a>;

/// A row of the tables: the mesh, the query, the rays, and per engine its Mrays/s and its count.
struct Row {
    mesh: String,
    query: &'static str,
    rays: &'static str,
    engines: Vec<(f64, usize)>,
}

fn main() {
    let Some(dir) = shared_meshes() else {
        eprintln!("skipped: ../shared/meshes is not beside the repository");
        return;
    };
    let side = std::env::var("RAYLUME_COMPARE_SIDE").ok().and_then(|s| s.parse().ok()).unwrap_or(1024);
    let passes = std::env::var("RAYLUME_EMBREE_PASSES").ok().and_then(|s| s.parse().ok()).unwrap_or(9);
    let once = std::env::var("RAYLUME_EMBREE_ONCE").ok();
    let mut meshes: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    if meshes.is_empty() {
        meshes = ["bunny", "bunny_loop2", "bunny_loop3"].map(String::from).to_vec();
    }
    let mut single = Vec::new();
    let mut batch = Vec::new();
    for mesh in &meshes {
        let Some(w) = load_shared(&dir, mesh, side) else { continue };
        let prims: Vec<Primitive> = w.triangles.iter().map(|&t| Primitive::Triangle(t)).collect();
        let ours = Bvh::new(prims, Interval::new(0.0, 0.0));
        let embree = Embree::with_flags(&w.triangles, false);
        let robust = Embree::with_flags(&w.triangles, true);
        let tiles = raylume_scene::rays::in_tiles(&w.camera, w.side, 8);
        // One tile's answers at a time, as Embree's packets and streams give theirs.
        let mut hits = vec![None; TILE];
        let mut occluded = [false; TILE];
        let (mut hit_buffer, mut ray_buffer) = (Vec::new(), Vec::new());
        for query in ["closest", "occluded"] {
            for (kind, rays) in [("camera", &w.camera), ("random", &w.random)] {
                let closest = query == "closest";
                let raylume: Pass = if closest {
                    Box::new(|| rays.iter().filter(|r| ours.closest_hit(r, Interval::POSITIVE).is_some()).count())
                } else {
                    Box::new(|| rays.iter().filter(|r| ours.occluded(r, f32::INFINITY)).count())
                };
                let engines = vec![
                    ("raylume", raylume),
                    ("embree", single_rays(&embree, rays, closest)),
                    ("robust", single_rays(&robust, rays, closest)),
                ];
                if let Some(row) = run(&once, mesh, query, kind, rays.len(), passes, engines) {
                    single.push(row);
                }
            }
            let closest = query == "closest";
            let raylume: Pass = if closest {
                Box::new(|| {
                    let mut count = 0;
                    for tile in tiles.chunks(TILE) {
                        let hits = &mut hits[..tile.len()];
                        ours.closest_hits(tile, Interval::POSITIVE, hits);
                        count += hits.iter().filter(|h| h.is_some()).count();
                    }
                    count
                })
            } else {
                Box::new(|| {
                    let mut count = 0;
                    for tile in tiles.chunks(TILE) {
                        let occluded = &mut occluded[..tile.len()];
                        ours.occluded_each(tile, f32::INFINITY, occluded);
                        count += occluded.iter().filter(|&&o| o).count();
                    }
                    count
                })
            };
            let (packet, stream): (Pass, Pass) = if closest {
                (
                    Box::new(|| embree.closest_packets(&tiles)),
                    Box::new(|| embree.closest_stream(&tiles, true, &mut hit_buffer)),
                )
            } else {
                (
                    Box::new(|| embree.occluded_packets(&tiles)),
                    Box::new(|| embree.occluded_stream(&tiles, true, &mut ray_buffer)),
                )
            };
            let engines = vec![("batch", raylume), ("packet", packet), ("stream", stream)];
            if let Some(row) = run(&once, mesh, query, "camera", tiles.len(), passes, engines) {
                batch.push(row);
            }
        }
        if once.is_some() {
            eprintln!("RAYLUME_EMBREE_ONCE names no engine, query and rays of {mesh}");
            return;
        }
    }
    print_tables(&single, &batch, passes);
}

/// A pass of `rtcIntersect1` (`closest`) or `rtcOccluded1` calls over `rays`.
fn single_rays<'a>(engine: &'a Embree, rays: &'a [Ray], closest: bool) -> Pass<'a> {
    if closest {
        Box::new(move || rays.iter().filter(|r| engine.closest(r).is_some()).count())
    } else {
        Box::new(move || rays.iter().filter(|r| engine.occluded(r)).count())
    }
}

/// Times `engines` over `n` rays in `passes` alternating passes and returns their row; or, when
/// `once` names one of them on this row, runs that pass once and exits.
fn run(
    once: &Option<String>,
    mesh: &str,
    query: &'static str,
    rays: &'static str,
    n: usize,
    passes: usize,
    mut engines: Vec<(&'static str, Pass<'_>)>,
) -> Option<Row> {
    if let Some(once) = once {
        if let Some((name, pass)) = engines.iter_mut().find(|(name, _)| *once == format!("{name}/{query}/{rays}")) {
            let repeat = std::env::var("RAYLUME_EMBREE_REPEAT").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
            let mut found = 0;
            for _ in 0..repeat {
                found = pass();
            }
            println!("{mesh} {name} {query} {rays}: {found} of {n}");
            std::process::exit(0);
        }
        return None;
    }
    let mut times = vec![Vec::new(); engines.len()];
    let mut counts = vec![0; engines.len()];
    // Each round starts with the next engine, so that none always follows the same one.
    for round in 0..passes.max(1) {
        for k in 0..engines.len() {
            let e = (round + k) % engines.len();
            let start = Instant::now();
            counts[e] = black_box((engines[e].1)());
            times[e].push(start.elapsed().as_secs_f64());
        }
    }
    let engines = times
        .into_iter()
        .zip(counts)
        .map(|(mut t, count)| {
            t.sort_by(f64::total_cmp);
            (n as f64 / t[t.len() / 2] / 1e6, count)
        })
        .collect();
    Some(Row { mesh: mesh.to_owned(), query, rays, engines })
}

fn print_tables(single: &[Row], batch: &[Row], passes: usize) {
    println!("\nSingle rays: median of {passes} alternating passes per engine, one thread, Mrays/s.\n");
    println!("| mesh | query | rays | raylume | Embree rtc*1 | raylume/Embree | Embree robust | raylume/robust |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in single {
        let [(a, _), (e, _), (b, _)] = r.engines[..] else { continue };
        println!("| {} | {} | {} | {a:.2} | {e:.2} | {:.2} | {b:.2} | {:.2} |", r.mesh, r.query, r.rays, a / e, a / b);
    }
    println!("\nCamera rays in 8x8 tiles: raylume's batch queries (runs of 64) against Embree's packets of 8");
    println!("and streams of 64 (coherent), median of {passes} alternating passes, one thread, Mrays/s.\n");
    println!("| mesh | query | raylume batch | Embree rtc*8 | raylume/rtc*8 | Embree rtc*1M | raylume/rtc*1M |");
    println!("|---|---|---|---|---|---|---|");
    for r in batch {
        let [(a, _), (p, _), (s, _)] = r.engines[..] else { continue };
        println!("| {} | {} | {a:.2} | {p:.2} | {:.2} | {s:.2} | {:.2} |", r.mesh, r.query, a / p, a / s);
    }
    println!();
    for r in single.iter().chain(batch) {
        let counts: Vec<String> = r.engines.iter().map(|(_, c)| c.to_string()).collect();
        println!(
            "{} {} {}: {} rays hit or occluded (per engine, in column order)",
            r.mesh,
            r.query,
            r.rays,
            counts.join(" / ")
        );
    }
}
