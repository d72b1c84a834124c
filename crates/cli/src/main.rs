//! `raylume`: renders p3f scenes from the command line.
//!
//! Exit codes: 0 success, 2 bad input (arguments, scene, missing files), 1 any other failure.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use raylume_accel::AccelKind;
use raylume_integrator::{Profile, RenderSettings};
use raylume_material::FresnelMode;
use raylume_scene::{DEFAULT_SCENE, RenderOptions, SamplerKind, Scene, p3f, procedural};

mod bench;
mod converge;

#[derive(Parser)]
#[command(name = "raylume", version, about = "raylume: a Whitted and distribution ray tracer")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a p3f scene (the embedded default scene without SCENE) to an image.
    Render(RenderArgs),
    /// Write a procedural scene (balls, tetra, mount, rings) of the given size as p3f to stdout.
    Gen {
        /// balls (sphereflake), tetra, mount or rings.
        name: String,
        /// Recursion depth (balls, tetra, mount) or number of rings.
        size: u32,
    },
    /// Measure an accelerator: build time, closest-hit and occlusion Mrays/s, size, primitives tested.
    Bench(BenchCli),
    /// Error against run time: render a reference, then each sample count with each sampler, and
    /// write report/convergence.csv with the metrics and the time taken.
    Converge(converge::ConvergeArgs),
    /// Print the RMSE between two images of the same size (8-bit channels as values in [0, 1]).
    Compare {
        /// The first image.
        a: PathBuf,
        /// The second image.
        b: PathBuf,
    },
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The p3f scene; without it, the embedded default scene.
    scene: Option<PathBuf>,
    /// Render an OBJ mesh instead, framed by an automatic camera and light.
    #[arg(long, conflicts_with = "scene")]
    mesh: Option<PathBuf>,
    /// Output image: .png (8-bit), .exr or .pfm (linear float).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Samples per pixel (1: the pixel centre; more: jittered n x n strata, n = ceil(sqrt(spp))).
    #[arg(long)]
    spp: Option<u32>,
    /// Maximum ray depth, counting the camera ray as 1 (default: the profile's, 4 for plain, 8 for course).
    #[arg(long)]
    depth: Option<u32>,
    /// Shading rules: plain (the model as the course describes it) or course (the rules of the
    /// course's reference renders).
    #[arg(long, value_enum, default_value_t = ProfileArg::Plain)]
    profile: ProfileArg,
    /// Accelerator (bvh: binned SAH; bvh-midpoint: the course's build; grid: uniform grid with
    /// mailboxing); by default the scene's `accel` hint, else bvh.
    #[arg(long, value_enum)]
    accel: Option<AccelArg>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of the random samples.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Image width (overrides the scene's; give --height too).
    #[arg(long, requires = "height")]
    width: Option<u32>,
    /// Image height (overrides the scene's; give --width too).
    #[arg(long, requires = "width")]
    height: Option<u32>,
    /// Treat warnings (unknown tags) as errors.
    #[arg(long)]
    strict: bool,
    /// A further folder to look for the scene's `env` cubemap in.
    #[arg(long)]
    env_dir: Vec<PathBuf>,
    /// Ignore the scene's cubemap: escaping rays return the background colour.
    #[arg(long)]
    no_env: bool,
    /// Use Schlick's approximation instead of the exact Fresnel equations.
    #[arg(long)]
    schlick: bool,
    /// Scale of the specular highlight (1: the plain model).
    #[arg(long, default_value_t = 1.0)]
    specular_scale: f32,
    /// Soft shadows: make every light a square area light of this side (0: point lights).
    #[arg(long, value_name = "SIZE")]
    area_light: Option<f32>,
    /// Side of the grid of point lights standing for an area light without antialiasing.
    #[arg(long, default_value_t = 4, value_name = "N")]
    light_grid: u32,
    /// Fuzzy reflections: the roughness of every reflective material, in [0, 1].
    #[arg(long)]
    roughness: Option<f32>,
    /// Depth of field: the lens diameter in pixel sizes (0: pinhole).
    #[arg(long)]
    aperture: Option<f32>,
    /// Depth of field: the focal distance as a ratio of the view-plane distance.
    #[arg(long)]
    focal: Option<f32>,
    /// Density of the uniform grid: about K cells per primitive.
    #[arg(long, default_value_t = 2.0, value_name = "K")]
    grid_k: f32,
    /// The sampler of antialiased renders.
    #[arg(long, value_enum, default_value = "jittered")]
    sampler: SamplerArg,
    /// Motion blur: the shutter interval.
    #[arg(long, num_args = 2, value_names = ["T0", "T1"])]
    shutter: Option<Vec<f32>>,
    /// Render only the pixels in [X0, X1) x [Y0, Y1) (row 0 at the top); they equal the full image's.
    #[arg(long, num_args = 4, value_names = ["X0", "Y0", "X1", "Y1"])]
    crop: Option<Vec<u32>>,
}

#[derive(clap::Args)]
struct BenchCli {
    /// A p3f scene (or give --mesh or --gen).
    scene: Option<PathBuf>,
    /// An OBJ mesh, framed by an automatic camera.
    #[arg(long, conflicts_with = "scene")]
    mesh: Option<PathBuf>,
    /// A procedural scene: NAME SIZE (e.g. balls 4).
    #[arg(long = "gen", num_args = 2, value_names = ["NAME", "SIZE"], conflicts_with_all = ["scene", "mesh"])]
    procedural: Option<Vec<String>>,
    /// The rays: camera (coherent) or random (incoherent).
    #[arg(long, value_enum, default_value = "camera")]
    rays: bench::RayKind,
    /// Number of rays (camera rays: rounded to a square view).
    #[arg(long, default_value_t = 1 << 20)]
    count: usize,
    /// Accelerator.
    #[arg(long, value_enum, default_value = "bvh")]
    accel: AccelArg,
    /// Density of the uniform grid: about K cells per primitive.
    #[arg(long, default_value_t = 2.0, value_name = "K")]
    grid_k: f32,
    /// Worker threads (default 1, the single-ray figure).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Seed of the random rays.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Trace the rays through the batch queries in runs of 64, the camera rays in tiles of 8x8.
    #[arg(long)]
    batch: bool,
    /// Trace the rays of this ray file instead.
    #[arg(long)]
    read_rays: Option<PathBuf>,
    /// Save the rays traced to this file.
    #[arg(long)]
    write_rays: Option<PathBuf>,
    /// Save each ray's closest hit (t, primitive) to this file.
    #[arg(long)]
    write_hits: Option<PathBuf>,
    /// Runs of each measurement; the best is reported.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum SamplerArg {
    Jittered,
    Independent,
    Sobol,
}

impl From<SamplerArg> for SamplerKind {
    fn from(s: SamplerArg) -> Self {
        match s {
            SamplerArg::Jittered => SamplerKind::Jittered,
            SamplerArg::Independent => SamplerKind::Independent,
            SamplerArg::Sobol => SamplerKind::Sobol,
        }
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum)]
enum ProfileArg {
    Plain,
    Course,
}

#[derive(Clone, Copy, ValueEnum)]
enum AccelArg {
    None,
    Bvh,
    BvhPortable,
    BvhMidpoint,
    Grid,
}

/// An error and the exit code it gets.
struct Failure {
    code: u8,
    message: String,
}

fn bad_input(message: impl ToString) -> Failure {
    Failure { code: 2, message: message.to_string() }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Compare { a, b } => compare(&a, &b),
        Command::Gen { name, size } => generate(&name, size),
        Command::Bench(args) => bench_command(args),
        Command::Converge(args) => converge::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("raylume: error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

fn render(args: RenderArgs) -> Result<(), Failure> {
    let options = p3f::LoadOptions { strict: args.strict, ..Default::default() };
    let (scene, warnings, mut env_dirs) = match (&args.scene, &args.mesh) {
        (_, Some(mesh)) => {
            let mesh = raylume_scene::obj::load(mesh).map_err(bad_input)?;
            (procedural::mesh_view(mesh, 512, 512), Vec::new(), Vec::new())
        }
        (scene, None) => match scene {
            Some(path) => {
                let (scene, warnings) = p3f::load(path, &options).map_err(bad_input)?;
                let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
                let dir = if dir.as_os_str().is_empty() { PathBuf::from(".") } else { dir };
                let mut dirs = vec![dir.clone()];
                dirs.push(dir.join(".."));
                (scene, warnings, dirs)
            }
            None => {
                let (scene, warnings) = p3f::parse(DEFAULT_SCENE, "<default scene>", &options).map_err(bad_input)?;
                (scene, warnings, vec![PathBuf::from(".")])
            }
        },
    };
    for w in &warnings {
        eprintln!("{w}");
    }
    env_dirs.extend(args.env_dir.iter().cloned());
    let spp = args.spp.or(scene.spp_hint).unwrap_or(1);
    let profile = match args.profile {
        ProfileArg::Plain => Profile::Plain,
        ProfileArg::Course => Profile::Course,
    };
    let settings = RenderSettings {
        max_depth: args.depth.unwrap_or(profile.default_depth()),
        spp,
        seed: args.seed,
        fresnel: if args.schlick { FresnelMode::Schlick } else { FresnelMode::Exact },
        light_grid: args.light_grid.clamp(1, 64),
        crop: args.crop.as_ref().map(|c| [c[0], c[1], c[2], c[3]]),
        profile,
    };
    if let Some([x0, y0, x1, y1]) = settings.crop {
        if x0 >= x1 || y0 >= y1 {
            return Err(bad_input(format!("--crop {x0} {y0} {x1} {y1}: expected X0 < X1 and Y0 < Y1")));
        }
    }
    let n = settings.strata();
    if spp > 1 && n * n != spp {
        eprintln!("raylume: --spp {spp} is not a square: rendering {} samples per pixel ({n} x {n})", n * n);
    }
    if !args.specular_scale.is_finite() || args.specular_scale < 0.0 {
        return Err(bad_input(format!("--specular-scale {}: expected a finite number >= 0", args.specular_scale)));
    }
    let accel = args.accel.map(accel_kind);
    let render_options = RenderOptions {
        settings,
        accel,
        resolution: args.width.zip(args.height),
        env_dirs,
        use_env: !args.no_env,
        specular_scale: args.specular_scale,
        area_light_size: args.area_light,
        roughness: args.roughness,
        aperture: args.aperture,
        focal: args.focal,
        shutter: args.shutter.as_ref().map(|s| (s[0], s[1])),
        grid: raylume_accel::GridParams { k: args.grid_k, mailbox: true },
        sampler: args.sampler.into(),
        profile,
    };
    if !(args.grid_k.is_finite() && args.grid_k > 0.0 && args.grid_k <= 1000.0) {
        return Err(bad_input(format!("--grid-k {}: expected a number in (0, 1000]", args.grid_k)));
    }
    let features = scene.features(&render_options).map_err(bad_input)?;
    // Check the output's format before spending time on the render.
    let ext = args.output.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if !matches!(ext.as_str(), "png" | "exr" | "pfm") {
        return Err(bad_input(format!(
            "{}: unknown image format '{ext}' (expected .png, .exr or .pfm)",
            args.output.display()
        )));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .map_err(|e| Failure { code: 1, message: e.to_string() })?;
    let h = render_options.resolution.map_or(scene.view.height, |r| r.1);
    let rows = settings.crop.map_or(h, |c| c[3].min(h).saturating_sub(c[1]));
    let bar = if std::io::stderr().is_terminal() {
        let bar = ProgressBar::new(rows as u64);
        bar.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} rows ({eta} left)")
                .expect("valid template"),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let out = pool.install(|| scene_render(&scene, &render_options, &bar))?;
    bar.finish_and_clear();
    out.film.write(&args.output).map_err(|e| Failure { code: 1, message: e.to_string() })?;
    let s = out.stats;
    let total = out.build_seconds + out.render_seconds;
    let (w, h) = (out.film.width(), out.film.height());
    eprintln!(
        "raylume: wrote {} ({w}x{h}, {} spp, effects: {features}, accel {:?}, {} threads) in {:.3} s (build {:.3} s, render {:.3} s)",
        args.output.display(),
        n * n,
        out.accel,
        pool.current_num_threads(),
        total,
        out.build_seconds,
        out.render_seconds
    );
    eprintln!(
        "raylume: {} rays (camera {}, shadow {}, reflection {}, refraction {}), {:.2} Mrays/s",
        s.total(),
        s.camera,
        s.shadow,
        s.reflection,
        s.refraction,
        s.total() as f64 / out.render_seconds.max(1e-9) / 1e6
    );
    Ok(())
}

fn scene_render(
    scene: &Scene,
    options: &RenderOptions,
    bar: &ProgressBar,
) -> Result<raylume_scene::RenderOutput, Failure> {
    scene.render(options, &|| bar.inc(1)).map_err(bad_input)
}

fn accel_kind(a: AccelArg) -> AccelKind {
    match a {
        AccelArg::None => AccelKind::None,
        AccelArg::Bvh => AccelKind::Bvh,
        AccelArg::BvhPortable => AccelKind::BvhPortable,
        AccelArg::BvhMidpoint => AccelKind::BvhMidpoint,
        AccelArg::Grid => AccelKind::Grid,
    }
}

fn generate(name: &str, size: u32) -> Result<(), Failure> {
    let generator: procedural::Generator = name.parse().map_err(bad_input)?;
    let scene = generator.generate(size).map_err(bad_input)?;
    let mut out = std::io::stdout().lock();
    std::io::Write::write_all(&mut out, scene.to_p3f().as_bytes())
        .map_err(|e| Failure { code: 1, message: e.to_string() })
}

fn bench_command(args: BenchCli) -> Result<(), Failure> {
    let scene = if let Some(path) = &args.mesh {
        let mesh = raylume_scene::obj::load(path).map_err(bad_input)?;
        procedural::mesh_view(mesh, 1024, 1024)
    } else if let Some(g) = &args.procedural {
        let size: u32 = g[1].parse().map_err(|_| bad_input(format!("--gen {} {}: expected a size", g[0], g[1])))?;
        g[0].parse::<procedural::Generator>().and_then(|g| g.generate(size)).map_err(bad_input)?
    } else if let Some(path) = &args.scene {
        p3f::load(path, &p3f::LoadOptions::default()).map_err(bad_input)?.0
    } else {
        return Err(bad_input("give a SCENE, --mesh FILE or --gen NAME SIZE"));
    };
    if !(args.grid_k.is_finite() && args.grid_k > 0.0 && args.grid_k <= 1000.0) {
        return Err(bad_input(format!("--grid-k {}: expected a number in (0, 1000]", args.grid_k)));
    }
    if args.count == 0 || args.count > 1 << 28 {
        return Err(bad_input(format!("--count {}: expected 1..=2^28 rays", args.count)));
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.max(1))
        .build()
        .map_err(|e| Failure { code: 1, message: e.to_string() })?;
    let run = bench::BenchArgs {
        scene,
        accel: accel_kind(args.accel),
        grid: raylume_accel::GridParams { k: args.grid_k, mailbox: true },
        rays: args.rays,
        count: args.count,
        seed: args.seed,
        batch: args.batch,
        read_rays: args.read_rays,
        write_rays: args.write_rays,
        write_hits: args.write_hits,
        repeat: args.repeat,
    };
    pool.install(|| bench::run(run))
}

fn compare(a: &Path, b: &Path) -> Result<(), Failure> {
    let load = |p: &Path| image::open(p).map(|i| i.into_rgb8()).map_err(|e| bad_input(format!("{}: {e}", p.display())));
    let (ia, ib) = (load(a)?, load(b)?);
    if ia.dimensions() != ib.dimensions() {
        return Err(bad_input(format!(
            "{} is {:?} but {} is {:?}: sizes differ",
            a.display(),
            ia.dimensions(),
            b.display(),
            ib.dimensions()
        )));
    }
    let to_f = |i: &image::RgbImage| i.as_raw().iter().map(|&v| v as f32 / 255.0).collect::<Vec<_>>();
    let rmse = raylume_integrator::metrics::rmse(&to_f(&ia), &to_f(&ib)).unwrap_or(0.0);
    println!("rmse {rmse:.6} ({:.3} of 255)", rmse * 255.0);
    Ok(())
}
