//! `raylume bench`: build time, closest-hit and occlusion throughput, structure size and primitives
//! tested per ray, on camera or random rays that can be saved and read back.

use std::path::PathBuf;
use std::time::Instant;

use raylume_accel::{AccelKind, AccelVisitor, Accelerator, Counts, GridParams, with_accelerator};
use raylume_geometry::{Interval, Ray};
use raylume_render::RenderScene;
use raylume_scene::{Scene, rays};
use rayon::prelude::*;

use crate::{Failure, bad_input};

/// The side of the tiles the camera rays are ordered in for `--batch`, and the runs handed to
/// threads: one packet of the BVH's batch queries.
const BATCH_TILE: usize = 8;
const BATCH_RUN: usize = BATCH_TILE * BATCH_TILE;

/// Which rays to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum RayKind {
    /// Coherent rays through the pixel centres of the scene's camera (a square view).
    Camera,
    /// Incoherent rays: origins on a sphere around the scene, aimed at random points in it.
    Random,
}

/// What to measure.
pub struct BenchArgs {
    pub scene: Scene,
    pub accel: AccelKind,
    pub grid: GridParams,
    pub rays: RayKind,
    pub count: usize,
    pub seed: u64,
    /// Trace through the batch queries (camera rays in tiles).
    pub batch: bool,
    pub read_rays: Option<PathBuf>,
    pub write_rays: Option<PathBuf>,
    pub write_hits: Option<PathBuf>,
    pub repeat: usize,
}

pub fn run(args: BenchArgs) -> Result<(), Failure> {
    let prims = args.scene.primitives().primitives;
    let n = prims.len();
    let shutter = args.scene.shutter();
    if let (AccelKind::Bvh | AccelKind::BvhPortable, Some(kernel)) = (args.accel, args.accel.kernel()) {
        println!("kernel              {kernel:?}");
    }
    let start = Instant::now();
    with_accelerator(args.accel, prims, shutter, args.grid, Measure { args: &args, start, n })
}

/// Measures the accelerator it is handed.
struct Measure<'a> {
    args: &'a BenchArgs,
    start: Instant,
    n: usize,
}

impl AccelVisitor for Measure<'_> {
    type Output = Result<(), Failure>;

    fn visit<A: Accelerator>(self, accel: A) -> Self::Output {
        measure(self.args, accel, self.start, self.n)
    }
}

fn measure<A: Accelerator>(args: &BenchArgs, accel: A, start: Instant, n: usize) -> Result<(), Failure> {
    let build = start.elapsed().as_secs_f64();
    let rays = match &args.read_rays {
        Some(path) => {
            let file = std::fs::File::open(path).map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
            rays::read_rays(&mut std::io::BufReader::new(file))
                .map_err(|e| bad_input(format!("{}: {e}", path.display())))?
        }
        None => match args.rays {
            RayKind::Camera if args.batch => {
                let camera = rays::camera_rays(&args.scene.view, args.count);
                let side = (camera.len() as f64).sqrt().round() as usize;
                rays::in_tiles(&camera, side, BATCH_TILE)
            }
            RayKind::Camera => rays::camera_rays(&args.scene.view, args.count),
            RayKind::Random => rays::random_rays(&accel.bounds(), args.count, args.seed),
        },
    };
    if rays.is_empty() {
        return Err(bad_input("no rays to trace"));
    }
    if let Some(path) = &args.write_rays {
        write_atomically(path, |out| rays::write_rays(out, &rays))?;
    }
    // Closest hits, repeated; the best run is reported (the machine is shared and noisy).
    let threads = rayon::current_num_threads();
    let trace = |ray: &Ray| accel.closest_hit(ray, Interval::POSITIVE).map(|h| (h.hit.t, h.primitive));
    let mut best_closest = f64::INFINITY;
    let mut hits = Vec::new();
    let mut found = vec![None; if args.batch { rays.len() } else { 0 }];
    for _ in 0..args.repeat.max(1) {
        let t = Instant::now();
        if args.batch {
            // Runs of one packet each, so that threads share the work as finely as single rays do.
            let run = |(rays, found): (&[Ray], &mut [_])| accel.closest_hits(rays, Interval::POSITIVE, found);
            rays.par_chunks(BATCH_RUN).zip(found.par_chunks_mut(BATCH_RUN)).for_each(run);
        } else if threads == 1 {
            hits = rays.iter().map(trace).collect();
        } else {
            hits = rays.par_iter().map(trace).collect();
        }
        best_closest = best_closest.min(t.elapsed().as_secs_f64());
    }
    if args.batch {
        hits = found.iter().map(|h| h.map(|h: raylume_accel::PrimitiveHit| (h.hit.t, h.primitive))).collect();
    }
    let mut best_occluded = f64::INFINITY;
    let mut blocked = 0;
    let mut occluded = vec![false; if args.batch { rays.len() } else { 0 }];
    for _ in 0..args.repeat.max(1) {
        let t = Instant::now();
        let occ = |r: &Ray| accel.occluded(r, f32::INFINITY) as usize;
        blocked = if args.batch {
            let run = |(rays, occluded): (&[Ray], &mut [bool])| accel.occluded_each(rays, f32::INFINITY, occluded);
            rays.par_chunks(BATCH_RUN).zip(occluded.par_chunks_mut(BATCH_RUN)).for_each(run);
            occluded.iter().filter(|&&o| o).count()
        } else if threads == 1 {
            rays.iter().map(occ).sum()
        } else {
            rays.par_iter().map(occ).sum()
        };
        best_occluded = best_occluded.min(t.elapsed().as_secs_f64());
    }
    // Primitives tested per ray, in a separate counting pass (single-ray queries, also for `--batch`).
    let mut work = Counts::default();
    for r in &rays {
        accel.closest_hit_tally(r, Interval::POSITIVE, &mut work);
    }
    let mut work_shadow = Counts::default();
    for r in &rays {
        accel.occluded_tally(r, f32::INFINITY, &mut work_shadow);
    }
    if let Some(path) = &args.write_hits {
        write_atomically(path, |out| rays::write_hits(out, &hits))?;
    }
    let stats = accel.stats();
    let count = rays.len() as f64;
    let hit_count = hits.iter().filter(|h| h.is_some()).count();
    println!("primitives          {n}");
    println!("accelerator         {:?}", args.accel);
    println!("build               {:.3} ms", build * 1e3);
    println!("nodes               {}", stats.nodes);
    println!("bytes per primitive {:.1}", stats.bytes as f64 / n.max(1) as f64);
    println!(
        "rays                {} ({:?}{}), {hit_count} hit, {blocked} occluded, {threads} thread(s)",
        rays.len(),
        args.rays,
        if args.batch { ", batch queries" } else { "" }
    );
    println!("closest hit         {:.3} Mrays/s", count / best_closest / 1e6);
    println!("occlusion           {:.3} Mrays/s", count / best_occluded / 1e6);
    println!(
        "tested per ray      {:.2} (closest hit), {:.2} (occlusion)",
        work.tested as f64 / count,
        work_shadow.tested as f64 / count
    );
    println!(
        "visited per ray     {:.2} (closest hit), {:.2} (occlusion) {}",
        work.visited as f64 / count,
        work_shadow.visited as f64 / count,
        if matches!(args.accel, AccelKind::Grid) { "cells" } else { "nodes" }
    );
    Ok(())
}

/// Writes a ray or hit file through a temporary file ([`raylume_integrator::write_atomically`]).
fn write_atomically(
    path: &std::path::Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), Failure> {
    let fill = |tmp: &std::path::Path| {
        let mut out = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        write(&mut out)?;
        out.into_inner().map_err(|e| e.into_error())?.sync_all()
    };
    raylume_integrator::write_atomically(path, fill, |e| e)
        .map_err(|e| Failure { code: 1, message: format!("{}: {e}", path.display()) })
}
