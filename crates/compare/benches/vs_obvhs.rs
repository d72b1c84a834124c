//! raylume's BVH against obvhs 0.4's CWBVH (medium build) on the same triangles and the same rays, in
//! one criterion run: build time, closest-hit and occlusion throughput for primary and incoherent rays
//! on the shared bunny meshes, single-threaded. After the measurements it prints the table of medians
//! and ratios that docs/PERFORMANCE.md#against-obvhs-and-embree carries, and the memory and agreement
//! figures.
//!
//! On a shared machine the load moves between one engine's benchmark and the other's, which the
//! ratio of two criterion medians takes in. So the bench also times the single-ray queries in
//! alternating passes (raylume, obvhs, Embree, raylume, ...: each pass all rays of a set once) and
//! prints the engines' median passes as a second, paired table.
//!
//! Every engine is timed from the same input, raylume's `Ray` (origin and direction), and makes what
//! it derives from a ray inside the timed loop, as a caller of its single-ray query does: raylume its
//! reciprocals and watertight frame in the query, Embree its `RTCRayHit` and what `rtcIntersect1`
//! derives, obvhs its `Ray`, whose constructor computes the reciprocal directions. The paired table
//! also times obvhs on its `Ray`s made before the timer starts, which shows what that set-up costs it
//! (docs/PERFORMANCE.md#how-the-comparison-is-timed).
//!
//! `cargo bench -p raylume-compare` (all meshes; a criterion filter such as `-- bunny/` picks some).
//! `RAYLUME_COMPARE_SIDE=512` shrinks the 1024x1024 ray sets for a quick look;
//! `RAYLUME_COMPARE_PAIRED=0` leaves out the paired passes.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

mod common;

use common::{Obvhs, to_obvhs, to_obvhs_triangles};
use criterion::{BenchmarkId, Criterion, Throughput};
use obvhs::ray::Ray as ORay;
use raylume_accel::{Accelerator, Bvh};
use raylume_compare::{Workload, load_shared, shared_meshes};
use raylume_geometry::{Interval, Ray};
use raylume_intersect::Primitive;

const MESHES: [&str; 3] = ["bunny", "bunny_loop2", "bunny_loop3"];

fn main() {
    let since = SystemTime::now();
    let Some(dir) = shared_meshes() else {
        eprintln!("skipped: ../shared/meshes is not beside the repository");
        return;
    };
    let side = std::env::var("RAYLUME_COMPARE_SIDE").ok().and_then(|s| s.parse().ok()).unwrap_or(1024);
    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
        .configure_from_args();
    let mut notes = Vec::new();
    for mesh in MESHES {
        let Some(w) = load_shared(&dir, mesh, side) else { continue };
        notes.push(measure(&mut c, &w));
    }
    c.final_summary();
    print_table(&notes, since);
}

/// What the bench prints beside criterion's timings.
struct Note {
    mesh: String,
    triangles: usize,
    /// Rays per ray set (one benchmark iteration).
    rays: usize,
    raylume_bytes: usize,
    obvhs_bytes: usize,
    agreement: [String; 2],
    /// Query, ray kind and each engine's Mrays/s (raylume, obvhs, Embree if measured, obvhs on rays
    /// made before the timer) from the paired passes.
    paired: Vec<(&'static str, &'static str, [Option<f64>; ENGINES])>,
}

/// Passes per engine in the paired measurement.
const PAIRED_PASSES: usize = 7;
/// Engines of the paired measurement: raylume, obvhs, Embree, obvhs on rays made before the timer.
const ENGINES: usize = 4;

/// Each engine's Mrays/s over `n` rays from alternating passes (the median pass of each); `None`
/// for an engine not given.
fn paired(n: usize, mut engines: [Option<Box<dyn FnMut() -> usize + '_>>; ENGINES]) -> [Option<f64>; ENGINES] {
    let mut times: [Vec<f64>; ENGINES] = Default::default();
    for _ in 0..PAIRED_PASSES {
        for (engine, times) in engines.iter_mut().zip(&mut times) {
            if let Some(pass) = engine {
                let start = Instant::now();
                black_box(pass());
                times.push(start.elapsed().as_secs_f64());
            }
        }
    }
    times.map(|mut t| {
        (!t.is_empty()).then(|| {
            t.sort_by(f64::total_cmp);
            n as f64 / t[t.len() / 2] / 1e6
        })
    })
}

fn measure(c: &mut Criterion, w: &Workload) -> Note {
    let prims: Vec<Primitive> = w.triangles.iter().map(|&t| Primitive::Triangle(t)).collect();
    let otris = to_obvhs_triangles(&w.triangles);
    let shutter = Interval::new(0.0, 0.0);

    let mut group = c.benchmark_group(format!("{}/build", w.name));
    group.throughput(Throughput::Elements(prims.len() as u64));
    // One thread, as obvhs and Embree build here: raylume's build would otherwise use rayon's pool.
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a thread pool");
    group.bench_function("raylume", |b| b.iter(|| one.install(|| Bvh::new(black_box(prims.clone()), shutter))));
    group.bench_function("obvhs", |b| b.iter(|| Obvhs::build(black_box(&otris))));

    #[cfg(feature = "embree")]
    group.bench_function("embree", |b| b.iter(|| common::Embree::build(black_box(&w.triangles))));
    group.finish();

    let ours = Bvh::new(prims.clone(), shutter);
    let theirs = Obvhs::build(&otris);
    #[cfg(feature = "embree")]
    let embree = common::Embree::build(&w.triangles);
    let mut agreement = [String::new(), String::new()];
    let mut paired_rows = Vec::new();
    for (k, (kind, rays)) in [("camera", &w.camera), ("random", &w.random)].into_iter().enumerate() {
        // The same rays through raylume's batch queries, the camera's in tiles of 8x8 (obvhs has no
        // batch query: its rows take the rays one by one, in the same order).
        let tiles = if kind == "camera" { raylume_scene::rays::in_tiles(rays, w.side, 8) } else { rays.clone() };
        let batch = format!("{kind}-batch");
        let mut group = c.benchmark_group(format!("{}/closest", w.name));
        group.throughput(Throughput::Elements(rays.len() as u64));
        let mut hits = vec![None; tiles.len()];
        group.bench_with_input(BenchmarkId::new("raylume", &batch), &tiles, |b, rays| {
            b.iter(|| {
                ours.closest_hits(rays, Interval::POSITIVE, &mut hits);
                hits.iter().filter(|h| h.is_some()).count()
            })
        });
        group.bench_with_input(BenchmarkId::new("obvhs", &batch), &tiles, |b, rays| {
            b.iter(|| rays.iter().filter(|r| theirs.closest(&to_obvhs(r)).is_some()).count())
        });
        #[cfg(feature = "embree")]
        {
            let mut buffer = Vec::new();
            group.bench_with_input(BenchmarkId::new("embree", &batch), &tiles, |b, rays| {
                b.iter(|| embree.closest_stream(rays, kind == "camera", &mut buffer))
            });
        }
        group.finish();
        let mut group = c.benchmark_group(format!("{}/occluded", w.name));
        group.throughput(Throughput::Elements(rays.len() as u64));
        let mut occluded = vec![false; tiles.len()];
        group.bench_with_input(BenchmarkId::new("raylume", &batch), &tiles, |b, rays| {
            b.iter(|| {
                ours.occluded_each(rays, f32::INFINITY, &mut occluded);
                occluded.iter().filter(|&&o| o).count()
            })
        });
        group.bench_with_input(BenchmarkId::new("obvhs", &batch), &tiles, |b, rays| {
            b.iter(|| rays.iter().filter(|r| theirs.occluded(&to_obvhs(r))).count())
        });
        #[cfg(feature = "embree")]
        {
            let mut buffer = Vec::new();
            group.bench_with_input(BenchmarkId::new("embree", &batch), &tiles, |b, rays| {
                b.iter(|| embree.occluded_stream(rays, kind == "camera", &mut buffer))
            });
        }
        group.finish();
        let orays: Vec<ORay> = rays.iter().map(to_obvhs).collect();
        agreement[k] = agree(&ours, |i| theirs.closest(&orays[i]).map(|h| h.0), rays);
        #[cfg(feature = "embree")]
        {
            let with_embree = agree(&ours, |i| embree.closest(&rays[i]).map(|h| h.0), rays);
            agreement[k] = format!("obvhs: {}; Embree: {with_embree}", agreement[k]);
        }
        let mut group = c.benchmark_group(format!("{}/closest", w.name));
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_with_input(BenchmarkId::new("raylume", kind), rays, |b, rays| {
            b.iter(|| rays.iter().filter(|r| ours.closest_hit(r, Interval::POSITIVE).is_some()).count())
        });
        group.bench_with_input(BenchmarkId::new("obvhs", kind), rays, |b, rays| {
            b.iter(|| rays.iter().filter(|r| theirs.closest(&to_obvhs(r)).is_some()).count())
        });
        #[cfg(feature = "embree")]
        group.bench_with_input(BenchmarkId::new("embree", kind), rays, |b, rays| {
            b.iter(|| rays.iter().filter(|r| embree.closest(r).is_some()).count())
        });
        group.finish();
        let mut group = c.benchmark_group(format!("{}/occluded", w.name));
        group.throughput(Throughput::Elements(rays.len() as u64));
        group.bench_with_input(BenchmarkId::new("raylume", kind), rays, |b, rays| {
            b.iter(|| rays.iter().filter(|r| ours.occluded(r, f32::INFINITY)).count())
        });
        group.bench_with_input(BenchmarkId::new("obvhs", kind), rays, |b, rays| {
            b.iter(|| rays.iter().filter(|r| theirs.occluded(&to_obvhs(r))).count())
        });
        #[cfg(feature = "embree")]
        group.bench_with_input(BenchmarkId::new("embree", kind), rays, |b, rays| {
            b.iter(|| rays.iter().filter(|r| embree.occluded(r)).count())
        });
        group.finish();
        if std::env::var("RAYLUME_COMPARE_PAIRED").as_deref() != Ok("0") {
            // One pass per engine over all rays (dynamic dispatch per pass, not per ray).
            type Pass<'a> = Option<Box<dyn FnMut() -> usize + 'a>>;
            let embree_pass = |closest: bool| -> Pass {
                #[cfg(feature = "embree")]
                return Some(if closest {
                    Box::new(|| rays.iter().filter(|r| embree.closest(r).is_some()).count())
                } else {
                    Box::new(|| rays.iter().filter(|r| embree.occluded(r)).count())
                });
                #[cfg(not(feature = "embree"))]
                {
                    let _ = closest;
                    None
                }
            };
            let closest: [Pass; ENGINES] = [
                Some(Box::new(|| rays.iter().filter(|r| ours.closest_hit(r, Interval::POSITIVE).is_some()).count())),
                Some(Box::new(|| rays.iter().filter(|r| theirs.closest(&to_obvhs(r)).is_some()).count())),
                embree_pass(true),
                Some(Box::new(|| orays.iter().filter(|r| theirs.closest(r).is_some()).count())),
            ];
            paired_rows.push(("closest", kind, paired(rays.len(), closest)));
            let occluded: [Pass; ENGINES] = [
                Some(Box::new(|| rays.iter().filter(|r| ours.occluded(r, f32::INFINITY)).count())),
                Some(Box::new(|| rays.iter().filter(|r| theirs.occluded(&to_obvhs(r))).count())),
                embree_pass(false),
                Some(Box::new(|| orays.iter().filter(|r| theirs.occluded(r)).count())),
            ];
            paired_rows.push(("occluded", kind, paired(rays.len(), occluded)));
        }
    }
    Note {
        mesh: w.name.clone(),
        triangles: prims.len(),
        rays: w.camera.len(),
        raylume_bytes: ours.stats().bytes,
        obvhs_bytes: theirs.bytes(),
        agreement,
        paired: paired_rows,
    }
}

/// How far raylume and another engine (`theirs(i)`: its hit distance for ray `i`) agree: rays hit by
/// one only, and hits whose distances differ by more than 1e-4 relative (the triangle tests differ on
/// edges: raylume's is watertight, the others' are not).
fn agree(ours: &Bvh<Primitive>, theirs: impl Fn(usize) -> Option<f32>, rays: &[Ray]) -> String {
    let (mut both, mut only_ours, mut only_theirs, mut far) = (0, 0, 0, 0);
    for (i, r) in rays.iter().enumerate() {
        match (ours.closest_hit(r, Interval::POSITIVE), theirs(i)) {
            (Some(a), Some(t)) => {
                both += 1;
                if (a.hit.t - t).abs() > 1e-4 * t.abs().max(1.0) {
                    far += 1;
                }
            }
            (Some(_), None) => only_ours += 1,
            (None, Some(_)) => only_theirs += 1,
            (None, None) => {}
        }
    }
    format!(
        "{both} hit by both ({far} at another distance), {only_ours} by raylume only, {only_theirs} by the other only"
    )
}

/// The median time of one criterion benchmark, from the estimates this run wrote (older estimates,
/// of benchmarks a filter left out, are ignored).
fn median_ns(id: &str, since: SystemTime) -> Option<f64> {
    let path = criterion_dir().join(id).join("new/estimates.json");
    if std::fs::metadata(&path).and_then(|m| m.modified()).ok()? < since {
        return None;
    }
    let text = std::fs::read_to_string(path).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["median"]["point_estimate"].as_f64()
}

fn criterion_dir() -> PathBuf {
    if let Some(home) = std::env::var_os("CRITERION_HOME") {
        return PathBuf::from(home);
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target"));
    target.join("criterion")
}

fn print_table(notes: &[Note], since: SystemTime) {
    println!(
        "\n| mesh | query | rays | raylume Mrays/s | obvhs Mrays/s | ratio | Embree Mrays/s | Embree/obvhs | raylume/Embree |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in notes {
        for query in ["closest", "occluded"] {
            for kind in ["camera", "camera-batch", "random", "random-batch"] {
                let mrays = |engine: &str| {
                    median_ns(&format!("{}_{query}/{engine}/{kind}", n.mesh), since).map(|ns| n.rays as f64 / ns * 1e3)
                };
                if let (Some(a), Some(b)) = (mrays("raylume"), mrays("obvhs")) {
                    let embree = mrays("embree")
                        .map_or("- | - | -".to_owned(), |e| format!("{e:.2} | {:.2} | {:.2}", e / b, a / e));
                    println!("| {} | {query} | {kind} | {a:.2} | {b:.2} | {:.2} | {embree} |", n.mesh, a / b);
                }
            }
        }
    }
    if notes.iter().any(|n| !n.paired.is_empty()) {
        println!(
            "\nPaired: median of {PAIRED_PASSES} alternating passes per engine (single-ray queries, one thread).\n"
        );
        println!(
            "| mesh | query | rays | raylume Mrays/s | obvhs Mrays/s | ratio | Embree Mrays/s | raylume/Embree | \
             obvhs, rays made before the timer | ratio |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|");
    }
    for n in notes {
        for (query, kind, [ours, theirs, embree, prepared]) in &n.paired {
            let (Some(a), Some(b)) = (ours, theirs) else { continue };
            let embree = embree.map_or("- | -".to_owned(), |e| format!("{e:.2} | {:.2}", a / e));
            let prepared = prepared.map_or("- | -".to_owned(), |p| format!("{p:.2} | {:.2}", a / p));
            println!("| {} | {query} | {kind} | {a:.2} | {b:.2} | {:.2} | {embree} | {prepared} |", n.mesh, a / b);
        }
    }
    println!("\n| mesh | triangles | raylume build ms | obvhs build ms | ratio | raylume B/tri | obvhs B/tri |");
    println!("|---|---|---|---|---|---|---|");
    for n in notes {
        let ours = median_ns(&format!("{}_build/raylume", n.mesh), since);
        let theirs = median_ns(&format!("{}_build/obvhs", n.mesh), since);
        let ms = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{:.2}", v / 1e6));
        let ratio = match (ours, theirs) {
            (Some(a), Some(b)) => format!("{:.2}", a / b),
            _ => "-".to_owned(),
        };
        println!(
            "| {} | {} | {} | {} | {ratio} | {:.1} | {:.1} |",
            n.mesh,
            n.triangles,
            ms(ours),
            ms(theirs),
            n.raylume_bytes as f64 / n.triangles as f64,
            n.obvhs_bytes as f64 / n.triangles as f64
        );
    }
    for n in notes {
        println!("{} camera: {}", n.mesh, n.agreement[0]);
        println!("{} random: {}", n.mesh, n.agreement[1]);
    }
}
