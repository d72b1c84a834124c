//! The `raylume` command line: renders p3f scenes (whole, or in regions that `merge` assembles, for
//! render farms), writes procedural ones, measures accelerators and convergence. The binary is
//! [`run`]; [`check_arguments`] is its validation of a command line, everything it checks before
//! any work starts.
//!
//! Exit codes: 0 success, 2 bad input (arguments, scene, missing files), 1 any other failure, 3 a
//! render stopped early, with the image so far written: by a signal (SIGINT, SIGTERM, SIGHUP) at the
//! end of a pass, or from the preview window; 130 ended by a signal at once (a second signal during
//! a render, or any other command), which leaves no partial output file.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use raylume_accel::AccelKind;
use raylume_integrator::{Profile, RenderSettings};
use raylume_material::FresnelMode;
use raylume_render::{RenderOptions, RenderScene, SamplerKind, limits};
use raylume_scene::{DEFAULT_SCENE, p3f, procedural};

mod bench;
mod checkpoint;
mod converge;
mod display;
mod farm;
mod preview;
mod report;
mod tev;

#[derive(Parser)]
#[command(name = "raylume", version, about = "raylume: a Whitted and distribution ray tracer")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a p3f scene (the embedded default scene without SCENE) to an image.
    Render(Box<RenderArgs>),
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
    /// Print the RMSE between two images of the same size: .png (8-bit channels as values in
    /// [0, 1]), .exr or .pfm (float values as they are), or .jpg.
    Compare {
        /// The first image.
        a: PathBuf,
        /// The second image.
        b: PathBuf,
    },
    /// Assemble the regions rendered with `render --tile` into the full image, refusing parts of
    /// different renders, overlapping parts and missing ones (see docs/FARM.md).
    Merge {
        /// The full image: .exr, .pfm or .png.
        output: PathBuf,
        /// The parts (.exr files written by `render --tile`).
        #[arg(required = true)]
        parts: Vec<PathBuf>,
    },
}

/// The flags that decide how a scene's image is made (the depth, the shading rules, the effects) and
/// with what (the accelerator, the threads): `render`'s and `converge`'s.
#[derive(clap::Args)]
pub(crate) struct ImageArgs {
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
    /// Use Schlick's approximation instead of the exact Fresnel equations.
    #[arg(long)]
    schlick: bool,
    /// Adaptive depth control: leave out reflected and refracted rays whose weight in the pixel is
    /// below W, in [0, 1] (0: trace every ray up to --depth). Each ray left out changes the pixel by
    /// at most its weight (times the background's brightness, if above 1).
    #[arg(long, default_value_t = 0.0, value_name = "W", allow_negative_numbers = true)]
    min_weight: f32,
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
    /// Depth of field: the lens radius, in pixel sizes of the view plane (0: pinhole).
    #[arg(long)]
    aperture: Option<f32>,
    /// Depth of field: the focal distance as a ratio of the view-plane distance.
    #[arg(long)]
    focal: Option<f32>,
    /// Density of the uniform grid: about K cells per primitive.
    #[arg(long, default_value_t = 2.0, value_name = "K")]
    grid_k: f32,
    /// Motion blur: the shutter interval.
    #[arg(long, num_args = 2, value_names = ["T0", "T1"])]
    shutter: Option<Vec<f32>>,
}

impl ImageArgs {
    /// `base` with these flags' depth, shading rules, effects and accelerator (its seed, crop,
    /// resolution, sampler and passes kept), not yet validated.
    pub(crate) fn options(&self, base: RenderOptions) -> Result<RenderOptions, Failure> {
        check_threads(self.threads)?;
        let profile = Profile::from(self.profile);
        let settings = RenderSettings {
            max_depth: self.depth.unwrap_or(profile.default_depth()),
            fresnel: if self.schlick { FresnelMode::Schlick } else { FresnelMode::Exact },
            light_grid: self.light_grid,
            min_weight: self.min_weight,
            ..base.settings
        };
        Ok(RenderOptions {
            settings,
            accel: self.accel.map(accel_kind),
            specular_scale: self.specular_scale,
            area_light_size: self.area_light,
            roughness: self.roughness,
            aperture: self.aperture,
            focal: self.focal,
            shutter: self.shutter.as_ref().map(|s| (s[0], s[1])),
            grid: raylume_accel::GridParams { k: self.grid_k, mailbox: true },
            profile,
            ..base
        })
    }

    /// The pool of `threads` workers whose stacks take the deepest recursion `--depth` allows.
    pub(crate) fn pool(&self) -> Result<rayon::ThreadPool, Failure> {
        check_threads(self.threads)?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads.unwrap_or(0))
            .stack_size(RENDER_STACK_BYTES)
            .build()
            .map_err(|e| Failure { code: 1, message: e.to_string() })
    }
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The p3f or NFF scene (`-`: read from standard input; a .obj file is rendered as `--mesh`
    /// renders it); without it, the embedded default scene.
    scene: Option<PathBuf>,
    /// Render an OBJ mesh instead, framed by an automatic camera and light.
    #[arg(long, conflicts_with = "scene")]
    mesh: Option<PathBuf>,
    /// Output image: .png (8-bit), .exr or .pfm (linear float).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Samples per pixel, 1..=65536 (1: the pixel centre; more with the jittered sampler: n x n
    /// strata, n = ceil(sqrt(spp))); default: the scene's `spp`, else 1.
    #[arg(long)]
    spp: Option<u32>,
    /// Depth, shading rules, effects, accelerator and threads.
    #[command(flatten)]
    image: ImageArgs,
    /// Seed of the random samples.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Image width (overrides the scene's; give --height too).
    #[arg(long, requires = "height")]
    width: Option<u32>,
    /// Image height (overrides the scene's; give --width too).
    #[arg(long, requires = "width")]
    height: Option<u32>,
    /// Treat warnings (unknown tags, skipped lines, shapes without a surface, a missing cubemap) as errors.
    #[arg(long)]
    strict: bool,
    /// A further folder to look for the scene's `env` cubemap in.
    #[arg(long)]
    env_dir: Vec<PathBuf>,
    /// Ignore the scene's cubemap: escaping rays return the background colour.
    #[arg(long)]
    no_env: bool,
    /// The sampler of antialiased renders.
    #[arg(long, value_enum, default_value = "jittered")]
    sampler: SamplerArg,
    /// Render only the pixels in [X0, X1) x [Y0, Y1) (row 0 at the top); they equal the full image's.
    /// The corners come in this order (pbrt's --pixelbounds takes X0 X1 Y0 Y1).
    #[arg(long, num_args = 4, value_names = ["X0", "Y0", "X1", "Y1"])]
    crop: Option<Vec<u32>>,
    /// Render region I of N (I from 0): the image split into N bands of whole rows, band I holding
    /// rows floor(I*H/N) up to floor((I+1)*H/N), exclusive. The output must be .exr: a part for
    /// `raylume merge`.
    #[arg(long, value_name = "I/N", conflicts_with_all = ["crop", "tile_from_env", "tiles"])]
    tile: Option<String>,
    /// Render the region whose index I (from 0) is the value of the environment variable VAR
    /// (such as SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX); give N with --tiles.
    #[arg(long, value_name = "VAR", requires = "tiles", conflicts_with = "crop")]
    tile_from_env: Option<String>,
    /// The number of regions N of --tile-from-env.
    #[arg(long, value_name = "N", requires = "tile_from_env")]
    tiles: Option<u32>,
    /// Render only samples A..B of each pixel's (whole passes: A and B multiples of a pass's
    /// samples), as an .exr part with its pass images, for `raylume merge` (docs/FARM.md).
    #[arg(long, value_name = "A..B", conflicts_with_all = ["tile", "tile_from_env"])]
    samples: Option<String>,
    /// When a signal (SIGTERM from a scheduler's time limit, SIGINT, SIGHUP) stops the render,
    /// stop at once and write to STATE (.exr) what `--resume STATE` needs to finish it: the passes
    /// finished and the rows finished of the pass under way. Removed when the render completes.
    #[arg(long, value_name = "STATE", conflicts_with = "budget")]
    checkpoint: Option<PathBuf>,
    /// With --checkpoint: also write the state after a pass once SECONDS have gone since it was
    /// last written (a task killed without a signal loses at most that).
    #[arg(long, value_name = "SECONDS", requires = "checkpoint")]
    checkpoint_every: Option<f64>,
    /// Finish the render that --checkpoint STATE stopped: give the scene and flags it had. Only
    /// what is left is rendered; the image is, bit for bit, the one of the render that never stopped.
    #[arg(long, value_name = "STATE", conflicts_with = "budget")]
    resume: Option<PathBuf>,
    /// Print only warnings and errors: no progress bar, no summary.
    #[arg(short, long)]
    quiet: bool,
    /// Draw the samples in this many independent passes of spp/K samples each, whose spread
    /// estimates the image's error (1: one stratified set, no estimate); with a budget, passes of
    /// spp/K samples for as long as it lasts. Default 4.
    #[arg(long, value_name = "K")]
    passes: Option<u32>,
    /// Render passes until this many seconds have gone (scene loading excluded; a pass that would
    /// end past the limit is not started).
    #[arg(long, value_name = "SECONDS", group = "budget", conflicts_with_all = ["tile", "tile_from_env", "samples"])]
    time_limit: Option<f64>,
    /// Render passes until the estimated RMSE of the image (linear RGB) is at most E.
    #[arg(long, value_name = "E", group = "budget", conflicts_with_all = ["tile", "tile_from_env", "samples"])]
    noise_threshold: Option<f64>,
    /// Adaptive sampling, with a budget (--time-limit or --noise-threshold): after 4 passes over
    /// every pixel, give further passes to the pixels whose estimated error is high (and their
    /// neighbours).
    #[arg(long, requires = "budget", conflicts_with_all = ["tile", "tile_from_env", "samples"])]
    adaptive: bool,
    /// Write the estimated error of each pass against time to DIR/error.csv and DIR/error.png.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Show the image in a window as it renders; closing it (or Esc) stops the render and writes
    /// what is done, S writes a snapshot. The window stays open on the final image until closed.
    #[arg(long)]
    preview: bool,
    /// Stream the image as it renders to the tev image viewer listening at HOST:PORT (tev's port
    /// is 14158).
    #[arg(long, value_name = "HOST:PORT")]
    display_server: Option<String>,
}

#[derive(clap::Args)]
struct BenchCli {
    /// A p3f or NFF scene (`-`: read from standard input; a .obj file is taken as `--mesh`; or give
    /// --mesh or --gen).
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

impl From<ProfileArg> for Profile {
    fn from(p: ProfileArg) -> Self {
        match p {
            ProfileArg::Plain => Profile::Plain,
            ProfileArg::Course => Profile::Course,
        }
    }
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
pub(crate) struct Failure {
    pub(crate) code: u8,
    pub(crate) message: String,
}

pub(crate) fn bad_input(message: impl ToString) -> Failure {
    Failure { code: 2, message: message.to_string() }
}

/// Exit code of a run ended by a signal.
pub const INTERRUPTED: u8 = 130;
/// Exit code of a render stopped early (a signal, the preview window closed): the image so far was
/// written.
pub const STOPPED_EARLY: u8 = 3;

/// Set while a render can stop gracefully at the end of a pass: the first signal then asks it to.
static GRACEFUL: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
/// Set while a render with a checkpoint runs: the first signal stops it at once and writes its state.
static CHECKPOINT: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
/// Set by the first signal during a render that can stop gracefully.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Runs the command line of this process and returns its exit code.
pub fn run() -> ExitCode {
    // A signal removes the temporary file of a write in progress, so that only the previous file or
    // the complete new one is ever left.
    // During a render, the first signal ends it at the end of the current pass, and the image so
    // far is written (exit code 3); any other signal ends the process at once (130).
    let _ = ctrlc::set_handler(|| {
        use std::sync::atomic::Ordering;
        if GRACEFUL.load(Ordering::SeqCst) && !STOP.swap(true, Ordering::SeqCst) {
            if CHECKPOINT.load(Ordering::SeqCst) {
                eprintln!("\nraylume: stopping now to write the state (again to stop at once, writing nothing)");
            } else {
                eprintln!("\nraylume: stopping at the end of this pass (again to stop now, writing nothing)");
            }
            return;
        }
        let _held = raylume_integrator::remove_partial_outputs();
        eprintln!("raylume: interrupted");
        std::process::exit(INTERRUPTED as i32);
    });
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(mut args) => {
            obj_as_mesh(&mut args.scene, &mut args.mesh);
            render(*args)
        }
        Command::Compare { a, b } => compare(&a, &b),
        Command::Merge { output, parts } => farm::merge(&output, &parts),
        Command::Gen { name, size } => generate(&name, size),
        Command::Bench(mut args) => {
            obj_as_mesh(&mut args.scene, &mut args.mesh);
            bench_command(args)
        }
        Command::Converge(args) => converge::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) if f.code == STOPPED_EARLY => {
            eprintln!("raylume: {}", f.message);
            ExitCode::from(STOPPED_EARLY)
        }
        Err(f) => {
            eprintln!("raylume: error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

/// Checks a command line (`args` without the program name) as [`run`] does before any work:
/// its syntax, every flag against the [`limits`], the output's format and folder. Files are not
/// read and nothing is written.
///
/// ```
/// use raylume_cli::check_arguments;
/// assert!(check_arguments(["render", "--spp", "16", "-o", "out.png"]).is_ok());
/// let refused = |spp| check_arguments(["render", "--spp", spp]).unwrap_err();
/// assert_eq!(refused("4294967295"), "spp 4294967295: expected 1..=65536 samples per pixel");
/// assert_eq!(refused("0"), "spp 0: expected 1..=65536 samples per pixel");
/// assert!(check_arguments(["render", "--threads", "10000"]).unwrap_err().starts_with("--threads 10000"));
/// ```
pub fn check_arguments<I, T>(args: I) -> Result<(), String>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let argv = std::iter::once(std::ffi::OsString::from("raylume")).chain(args.into_iter().map(Into::into));
    let cli = Cli::try_parse_from(argv).map_err(|e| e.to_string())?;
    let checked = match &cli.command {
        Command::Render(args) => render_options(args).and_then(|_| check_output(&args.output, false)),
        Command::Bench(args) => bench_limits(args),
        _ => Ok(()),
    };
    checked.map_err(|f| f.message)
}

/// The threads flag within its limit.
fn check_threads(threads: Option<usize>) -> Result<(), Failure> {
    match threads {
        Some(n) if !(1..=limits::MAX_THREADS).contains(&n) => {
            Err(bad_input(format!("--threads {n}: expected 1..={}", limits::MAX_THREADS)))
        }
        _ => Ok(()),
    }
}

/// The output can be written: a format raylume writes, into a folder that exists (and, with
/// `probe`, that takes a new file).
pub(crate) fn check_output(path: &Path, probe: bool) -> Result<(), Failure> {
    raylume_integrator::ImageFormat::from_path(path).map_err(bad_input)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        let message = format!("{}: no folder '{}' to write into", path.display(), dir.display());
        return Err(Failure { code: 1, message });
    }
    if probe {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let test = dir.join(format!(".{name}.{}.probe", std::process::id()));
        std::fs::File::create(&test).map_err(|e| Failure {
            code: 1,
            message: format!("{}: cannot write into '{}': {e}", path.display(), dir.display()),
        })?;
        let _ = std::fs::remove_file(&test);
    }
    Ok(())
}

/// The render's options from its flags, checked against the limits (nothing depends on the scene).
fn render_options(args: &RenderArgs) -> Result<RenderOptions, Failure> {
    tile_of(args)?;
    if let Some(server) = &args.display_server {
        tev::parse_address(server).map_err(|e| bad_input(format!("--display-server {server}: {e}")))?;
    }
    let settings = RenderSettings {
        seed: args.seed,
        crop: args.crop.as_ref().map(|c| [c[0], c[1], c[2], c[3]]),
        ..RenderSettings::default()
    };
    let base = RenderOptions {
        settings,
        spp: args.spp,
        strict: args.strict,
        resolution: args.width.zip(args.height),
        env_dirs: args.env_dir.clone(),
        use_env: !args.no_env,
        sampler: args.sampler.into(),
        passes: args.passes.unwrap_or(raylume_render::DEFAULT_PASSES),
        time_limit: args.time_limit,
        noise_threshold: args.noise_threshold,
        adaptive: args.adaptive,
        pass_range: None,
        resume: None,
        ..RenderOptions::default()
    };
    let options = args.image.options(base)?;
    options.validate().map_err(bad_input)?;
    Ok(options)
}

/// The region of `render --tile` or `--tile-from-env`.
fn tile_of(args: &RenderArgs) -> Result<Option<farm::Tile>, Failure> {
    farm::Tile::from_flags(args.tile.as_deref(), args.tile_from_env.as_deref(), args.tiles, &args.output)
}

/// A scene that did not load: the warnings found before the error are printed first.
/// Reads the scene at `path`: a file, a pipe, or `-` for standard input (named `<stdin>` in
/// messages; the files it names are looked for from the current folder).
pub(crate) fn load_scene(path: &Path, options: &p3f::LoadOptions) -> Result<p3f::Loaded, Failure> {
    if path != Path::new("-") {
        return p3f::load(path, options).map_err(load_failure);
    }
    use std::io::Read;
    let mut bytes = Vec::new();
    std::io::stdin()
        .lock()
        .take(p3f::MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| bad_input(format!("<stdin>: {e}")))?;
    if bytes.len() as u64 > p3f::MAX_FILE_BYTES {
        return Err(bad_input(format!("<stdin>: more than {} bytes", p3f::MAX_FILE_BYTES)));
    }
    let options = p3f::LoadOptions { base_dir: Some(PathBuf::from(".")), ..options.clone() };
    p3f::parse_bytes(&bytes, "<stdin>", &options).map_err(load_failure)
}

pub(crate) fn load_failure(e: raylume_scene::SceneError) -> Failure {
    for w in e.warnings() {
        eprintln!("{w}");
    }
    bad_input(e)
}

fn render(args: RenderArgs) -> Result<(), Failure> {
    // Everything the flags alone decide is checked before the scene is read.
    let mut render_options = render_options(&args)?;
    check_output(&args.output, true)?;
    if let Some(dir) = &args.report {
        report::check(dir)?;
    }
    let parts = args.tile.is_some() || args.tile_from_env.is_some() || args.samples.is_some();
    if args.scene.as_deref() == Some(Path::new("-")) && (parts || args.checkpoint.is_some() || args.resume.is_some()) {
        return Err(bad_input(
            "a scene read from standard input cannot be farmed, checkpointed or resumed (each part and each \
             resumption reads the scene again): give its file",
        ));
    }
    if let Some(state) = &args.checkpoint {
        if raylume_integrator::ImageFormat::from_path(state).ok() != Some(raylume_integrator::ImageFormat::Exr) {
            return Err(bad_input(format!("--checkpoint {}: a state is written as .exr", state.display())));
        }
        if state == &args.output {
            return Err(bad_input(format!("--checkpoint {}: the state and the image need two files", state.display())));
        }
        check_output(state, true)?;
    }
    if let Some(e) = args.checkpoint_every.filter(|e| !(e.is_finite() && *e >= 0.0)) {
        return Err(bad_input(format!("--checkpoint-every {e}: expected seconds >= 0")));
    }
    let options = p3f::LoadOptions {
        strict: args.strict,
        env_dirs: args.env_dir.clone(),
        ignore_env: args.no_env,
        ..Default::default()
    };
    let (scene, warnings, summary) = match (&args.scene, &args.mesh) {
        (_, Some(mesh)) => {
            let (shape, warnings) = load_mesh(mesh, args.strict)?;
            (procedural::mesh_view(shape, 512, 512), warnings, None)
        }
        (scene, None) => {
            let loaded = match scene {
                Some(path) => load_scene(path, &options)?,
                None => p3f::parse(DEFAULT_SCENE, "<default scene>", &options).map_err(load_failure)?,
            };
            let summary = scene.as_ref().map(|path| format!("{}: {}", path.display(), loaded.summary()));
            (loaded.scene, loaded.warnings, summary)
        }
    };
    for w in &warnings {
        eprintln!("{w}");
    }
    if let Some(summary) = summary.filter(|_| !args.quiet) {
        eprintln!("raylume: {summary}");
    }
    // A cubemap the loader did not find was reported with its line: render with the background.
    if let Some(name) = &scene.env {
        render_options.use_env &=
            raylume_scene::find_cubemap(name, &scene.cubemap_dirs(&render_options.env_dirs)).is_ok();
    }
    // A region of a farmed render is a crop.
    let full = render_options.resolution.unwrap_or((scene.view.width, scene.view.height));
    let tile = tile_of(&args)?;
    if let Some(tile) = tile {
        render_options.settings.crop = Some(tile.crop(full.0, full.1)?);
    }
    // What depends on the scene (its spp, the crop inside its image, the memory) before any work.
    scene.check(&render_options).map_err(bad_input)?;
    let spp = scene.samples_per_pixel(&render_options).map_err(bad_input)?;
    render_options.settings.spp = spp;
    let part = match tile {
        Some(tile) => {
            let file = args.scene.as_deref().or(args.mesh.as_deref());
            Some(farm::PartPlan::new(tile, file, DEFAULT_SCENE, &render_options, full)?)
        }
        None => None,
    };
    let settings = render_options.settings;
    let split = raylume_render::pass_split(&render_options, spp);
    if let Some(passes) = split.passes.filter(|k| k * split.samples_per_pass != spp && !args.quiet) {
        let drawn = passes * split.samples_per_pass;
        let n = (split.samples_per_pass as f64).sqrt() as u32;
        let why = if render_options.sampler == SamplerKind::Jittered && n * n == split.samples_per_pass {
            format!(", {n} x {n} jittered")
        } else {
            String::new()
        };
        eprintln!(
            "raylume: --spp {spp}: rendering {drawn} samples per pixel ({passes} passes of {}{why})",
            split.samples_per_pass
        );
    }
    // A share of the samples of a farmed render is a range of its passes.
    let share = match &args.samples {
        Some(spec) => {
            let share = farm::SampleShare::new(spec, split, &args.output)?;
            render_options.pass_range = Some(share.pass_range());
            let file = args.scene.as_deref().or(args.mesh.as_deref());
            Some((share, farm::scene_hash_of(file, DEFAULT_SCENE, &render_options, full)?))
        }
        None => None,
    };
    // A render that a signal can stop and resume: what identifies it, and the state it resumes from.
    let resumable = match (&args.checkpoint, &args.resume) {
        (None, None) => None,
        _ => {
            let file = args.scene.as_deref().or(args.mesh.as_deref());
            let hash = farm::scene_hash_of(file, DEFAULT_SCENE, &render_options, full)?;
            let pixels = render_options.settings.crop.unwrap_or([0, 0, full.0, full.1]);
            let passes = render_options.pass_range.unwrap_or((0, split.passes.unwrap_or(1)));
            Some(checkpoint::Identity { hash, pixels, full, passes })
        }
    };
    let saved = match (&args.resume, &resumable) {
        (Some(path), Some(id)) => {
            let saved = checkpoint::read(path, id)?;
            if !args.quiet {
                eprintln!(
                    "raylume: resuming from {}: {} of {} passes done{}",
                    path.display(),
                    saved.state.next_pass - id.passes.0,
                    id.passes.1 - id.passes.0,
                    match saved.state.rows_done() {
                        0 => String::new(),
                        rows => format!(", and {rows} rows of the next"),
                    }
                );
            }
            render_options.resume = Some(std::sync::Arc::new(saved.state.clone()));
            Some(saved)
        }
        _ => None,
    };
    let recorder = match (&args.checkpoint, &resumable, &saved) {
        (Some(_), _, Some(saved)) => Some(raylume_render::Recorder::resuming(saved.state.clone())),
        (Some(_), Some(id), None) => {
            let [x0, y0, x1, y1] = id.pixels;
            Some(raylume_render::Recorder::new(x1 - x0, y1 - y0, id.passes.0))
        }
        _ => None,
    };
    let features = scene.features(&render_options).map_err(bad_input)?;
    let pool = args.image.pool()?;
    let h = render_options.resolution.map_or(scene.view.height, |r| r.1);
    let rows = settings.crop.map_or(h, |c| c[3].min(h).saturating_sub(c[1]));
    // Rows of all passes when their number is known, else rows of the current pass.
    let known_passes = split.passes;
    let bar = if std::io::stderr().is_terminal() && !args.quiet {
        let bar = ProgressBar::new(rows as u64 * known_passes.unwrap_or(1) as u64);
        let template = if known_passes.is_some() {
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} rows ({eta} left) {msg}"
        } else {
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} rows of this pass {msg}"
        };
        bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        bar
    } else {
        ProgressBar::hidden()
    };
    let w = render_options.resolution.map_or(scene.view.width, |r| r.0);
    let columns = settings.crop.map_or(w, |c| c[2].min(w).saturating_sub(c[0]));
    let display = display::Display::start(&display_options(&args), columns, rows, spp, say(&bar))
        .map_err(|message| Failure { code: 1, message })?;
    let (mut report, mut pass_films) = (Vec::new(), Vec::new());
    let seconds_before = saved.as_ref().map_or(0.0, |s| s.seconds);
    if share.is_some() {
        pass_films = saved.map(|s| s.pass_films).unwrap_or_default();
    }
    let (render_started, mut last_checkpoint) = (std::time::Instant::now(), std::time::Instant::now());
    CHECKPOINT.store(recorder.is_some(), std::sync::atomic::Ordering::SeqCst);
    GRACEFUL.store(true, std::sync::atomic::Ordering::SeqCst);
    let rendered = pool.install(|| {
        let on_pass = |p: &raylume_render::Progress| {
            report.push(report::Row::of(p));
            if share.is_some() {
                pass_films.push(p.pass_film.clone());
            }
            if let (Some(recorder), Some(id), Some(path)) = (&recorder, &resumable, &args.checkpoint) {
                recorder.on_pass(p);
                let every = args.checkpoint_every.unwrap_or(f64::INFINITY);
                let last = p.pass as u32 + 1 == id.passes.1;
                if !last && last_checkpoint.elapsed().as_secs_f64() >= every {
                    let saved = checkpoint::Saved {
                        state: recorder.state(),
                        pass_films: pass_films.clone(),
                        seconds: seconds_before + p.seconds,
                    };
                    match checkpoint::write(path, id, &saved) {
                        Ok(()) => last_checkpoint = std::time::Instant::now(),
                        Err(f) => bar.suspend(|| eprintln!("raylume: warning: checkpoint not written: {}", f.message)),
                    }
                }
            }
            if known_passes.is_none() {
                bar.set_position(0);
            }
            bar.set_message(match p.estimate {
                Some(e) => format!("pass {}, {:.1} spp, RMSE ~ {:.2e}", p.pass + 1, p.mean_samples_per_pixel, e.rmse),
                None => format!("pass {}, {:.1} spp", p.pass + 1, p.mean_samples_per_pixel),
            });
            if let Some(d) = &display {
                d.show_pass(p.film, p.samples_per_pixel, p.seconds, p.estimate.map(|e| e.rmse));
            }
            let window_closed = display.as_ref().is_some_and(|d| d.stop_requested());
            // With a checkpoint a signal stops the render at once, through the observer.
            let signalled = STOP.load(std::sync::atomic::Ordering::SeqCst) && recorder.is_none();
            if signalled || window_closed {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        };
        let watch = Watch { count: || bar.inc(1), display: display.as_ref(), recorder: recorder.clone() };
        scene.render_progressive(&render_options, &watch, on_pass)
    });
    // From here a signal ends the process at once (the write leaves no partial file).
    GRACEFUL.store(false, std::sync::atomic::Ordering::SeqCst);
    bar.finish_and_clear();
    let rendered = match (rendered, &recorder, &resumable, &args.checkpoint) {
        (Err(raylume_scene::SceneError::Cancelled), Some(recorder), Some(id), Some(path))
            if STOP.load(std::sync::atomic::Ordering::SeqCst) =>
        {
            let state = recorder.state();
            let (done, rows) = (state.next_pass - id.passes.0, state.rows_done());
            let seconds = seconds_before + render_started.elapsed().as_secs_f64();
            checkpoint::write(path, id, &checkpoint::Saved { state, pass_films, seconds })?;
            return Err(Failure {
                code: STOPPED_EARLY,
                message: format!(
                    "stopped by a signal: wrote the state ({done} of {} passes done, and {rows} rows of the next) to {}; \
                     --resume {} with the same flags finishes the render",
                    id.passes.1 - id.passes.0,
                    path.display(),
                    path.display()
                ),
            });
        }
        (rendered, ..) => rendered.map_err(bad_input),
    };
    // The window closed during the first pass cancels it: its rows done are the image.
    let out = match (rendered, &display) {
        (Err(_), Some(d)) if d.stop_requested() => return stopped_from_window(display, &args.output),
        (out, _) => out?,
    };
    let window_closed = display.as_ref().is_some_and(|d| d.stop_requested());
    // A render with a checkpoint that ends is complete, whenever a signal came.
    let stopped = (STOP.load(std::sync::atomic::Ordering::SeqCst) && recorder.is_none()) || window_closed;
    for w in &out.warnings {
        eprintln!("{w}");
    }
    let mut attributes = report::attributes(&out, settings.seed, spp, &render_options);
    if seconds_before > 0.0 {
        for (name, value) in &mut attributes {
            if name == "raylume.seconds" {
                *value = raylume_integrator::MetaValue::Number(out.render_seconds + seconds_before);
            }
        }
    }
    let mut extras = raylume_integrator::Extras { variance: out.variance.as_ref(), attributes, ..Default::default() };
    if let Some(part) = &part {
        part.add_to(&mut extras);
    }
    let names: Vec<String> = match &share {
        Some((share, hash)) if !stopped => {
            share.add_to(&mut extras, hash, full);
            (0..pass_films.len()).map(|k| share.layer_name(k)).collect()
        }
        _ => Vec::new(),
    };
    extras.layers = names.iter().cloned().zip(pass_films.iter()).collect();
    out.film.write_with(&args.output, &extras).map_err(|e| Failure { code: 1, message: e.to_string() })?;
    if let Some(dir) = &args.report {
        report::write(dir, &report, &scene_title(&args))?;
    }
    // The render is complete: its state would only resume a finished render.
    if let Some(path) = args.checkpoint.as_ref().filter(|p| !stopped && p.is_file()) {
        let _ = std::fs::remove_file(path);
    }
    let done = if stopped {
        Err(Failure {
            code: STOPPED_EARLY,
            message: format!(
                "stopped {}: wrote the image of {} passes",
                if window_closed { "from the preview window" } else { "by a signal" },
                out.passes
            ),
        })
    } else {
        Ok(())
    };
    if args.quiet {
        if let Some(d) = display {
            d.finish();
        }
        return done;
    }
    let s = out.stats;
    let total = out.build_seconds + out.render_seconds;
    let (w, h) = (out.film.width(), out.film.height());
    eprintln!(
        "raylume: wrote {} ({w}x{h}, {} spp, effects: {features}, accel {:?}, {} threads) in {:.4} s (build {:.4} s, render {:.4} s)",
        args.output.display(),
        out.samples_per_pixel,
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
    match (&out.estimate, out.passes) {
        (Some(e), passes) => eprintln!(
            "raylume: estimated error {e} over {passes} passes{}",
            if render_options.adaptive {
                format!(" (adaptive: {:.1} spp per pixel on average)", out.mean_samples_per_pixel)
            } else {
                String::new()
            }
        ),
        (None, _) => {
            eprintln!("raylume: estimated error: none (one pass; --passes 2 or more, or --spp 2 or more, gives one)")
        }
    }
    if let Some(d) = display {
        d.finish();
    }
    done
}

/// The observer of a render from the command line: it counts rows for the progress bar, shows them
/// in the display, keeps the state for a checkpoint, and with a checkpoint stops at once on a signal.
struct Watch<'a, F> {
    count: F,
    display: Option<&'a display::Display>,
    recorder: Option<raylume_render::Recorder>,
}

impl<F: Fn() + Sync> raylume_render::Observer for Watch<'_, F> {
    fn row_done(&self) {
        (self.count)();
    }

    fn rows_done(&self, first_row: u32, width: u32, pixels: &[raylume_geometry::Vec3]) {
        if let Some(d) = self.display {
            d.rows_done(first_row, width, pixels);
        }
        if let Some(r) = &self.recorder {
            r.rows_done(first_row, width, pixels);
        }
    }

    fn cancelled(&self) -> bool {
        let signalled = self.recorder.is_some() && STOP.load(std::sync::atomic::Ordering::SeqCst);
        signalled || self.display.is_some_and(|d| d.cancelled())
    }
}

/// The scene's name for titles: its file name, else the default scene's.
fn scene_title(args: &RenderArgs) -> String {
    match (&args.scene, &args.mesh) {
        (Some(p), _) | (None, Some(p)) => p.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()),
        (None, None) => "default scene".to_owned(),
    }
}

/// Where `args` ask to watch the render.
fn display_options(args: &RenderArgs) -> display::DisplayOptions {
    display::DisplayOptions { preview: args.preview, server: args.display_server.clone(), output: args.output.clone() }
}

/// Lines for the user from the display threads, printed above the progress bar.
fn say(bar: &ProgressBar) -> display::Say {
    let bar = bar.clone();
    std::sync::Arc::new(move |line: &str| bar.suspend(|| eprintln!("{line}")))
}

/// A render stopped from the preview window: the rows done are written, and the run ends with
/// [`STOPPED_EARLY`].
fn stopped_from_window(display: Option<display::Display>, output: &Path) -> Result<(), Failure> {
    let Some(display) = display else { return Ok(()) };
    let film = display.image_so_far();
    display.finish();
    film.write(output).map_err(|e| Failure { code: 1, message: e.to_string() })?;
    let message = format!("stopped from the preview window: wrote the rows done to {}", output.display());
    Err(Failure { code: STOPPED_EARLY, message })
}

/// Stack of each render thread: the ray tree's recursion to `limits::MAX_DEPTH` with room to spare.
const RENDER_STACK_BYTES: usize = 8 << 20;

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
    match std::io::Write::write_all(&mut out, scene.to_p3f().as_bytes()).and_then(|()| std::io::Write::flush(&mut out))
    {
        // A reader that has read all it wants (`| head`) ends the output, as it ends any Unix filter's.
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(Failure { code: 1, message: format!("standard output: {e}") }),
        Ok(()) => Ok(()),
    }
}

/// The bench's flags within their limits (before a scene is read).
fn bench_limits(args: &BenchCli) -> Result<(), Failure> {
    check_threads(Some(args.threads))?;
    raylume_accel::GridParams { k: args.grid_k, mailbox: true }.validate().map_err(bad_input)?;
    if args.count == 0 || args.count > 1 << 28 {
        return Err(bad_input(format!("--count {}: expected 1..=2^28 rays", args.count)));
    }
    if args.repeat == 0 || args.repeat > 1000 {
        return Err(bad_input(format!("--repeat {}: expected 1..=1000", args.repeat)));
    }
    Ok(())
}

/// Whether `path` names a Wavefront OBJ file (by its extension, in any case): given as a scene, it
/// is rendered as `--mesh` renders it, framed by an automatic camera and light.
pub(crate) fn is_obj(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// An OBJ file given as the scene is taken as the `--mesh` it means.
fn obj_as_mesh(scene: &mut Option<PathBuf>, mesh: &mut Option<PathBuf>) {
    if mesh.is_none() && scene.as_deref().is_some_and(is_obj) {
        *mesh = scene.take();
    }
}

/// The OBJ mesh that `render --mesh` and `bench --mesh` frame, with what was skipped in it (an error
/// under `strict`). A mesh with no area at all is refused: nothing of it would be seen. A file that
/// is not an OBJ mesh but reads as a scene is refused with a word saying so.
pub(crate) fn load_mesh(
    path: &Path,
    strict: bool,
) -> Result<(raylume_scene::Shape, Vec<raylume_scene::Warning>), Failure> {
    let (mesh, warnings) = raylume_scene::obj::load_with_warnings(path).map_err(|e| {
        let options = p3f::LoadOptions { ignore_env: true, ..p3f::LoadOptions::default() };
        match p3f::load(path, &options) {
            Ok(scene) => bad_input(format!(
                "{e}; the file reads as a {} scene: give it as the scene, without --mesh",
                scene.dialect
            )),
            Err(_) => bad_input(e),
        }
    })?;
    if mesh.has_no_area() {
        return Err(bad_input(format!(
            "{}: no face of the mesh has an area (its vertices are collinear in f32): nothing to render",
            path.display()
        )));
    }
    if let Some(first) = warnings.first().filter(|_| strict) {
        let at = if first.line == 0 {
            first.file.clone()
        } else {
            format!("{}:{}:{}", first.file, first.line, first.column)
        };
        return Err(bad_input(format!("{at}: {} (an error when loading strictly)", first.message)));
    }
    Ok((mesh, warnings))
}

fn bench_command(args: BenchCli) -> Result<(), Failure> {
    bench_limits(&args)?;
    let scene = if let Some(path) = &args.mesh {
        let (mesh, warnings) = load_mesh(path, false)?;
        for warning in &warnings {
            eprintln!("{warning}");
        }
        procedural::mesh_view(mesh, 1024, 1024)
    } else if let Some(g) = &args.procedural {
        let size: u32 = g[1].parse().map_err(|_| bad_input(format!("--gen {} {}: expected a size", g[0], g[1])))?;
        g[0].parse::<procedural::Generator>().and_then(|g| g.generate(size)).map_err(bad_input)?
    } else if let Some(path) = &args.scene {
        load_scene(path, &p3f::LoadOptions::default())?.scene
    } else {
        return Err(bad_input("give a SCENE, --mesh FILE or --gen NAME SIZE"));
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
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
    let (ia, ib) = (comparable(a)?, comparable(b)?);
    let size = |f: &raylume_integrator::Film| (f.width(), f.height());
    if size(&ia) != size(&ib) {
        return Err(bad_input(format!(
            "{} is {:?} but {} is {:?}: sizes differ",
            a.display(),
            size(&ia),
            b.display(),
            size(&ib)
        )));
    }
    let rmse = raylume_integrator::metrics::rmse(&ia.channels(), &ib.channels()).unwrap_or(0.0);
    println!("rmse {rmse:.6} ({:.3} of 255)", rmse * 255.0);
    Ok(())
}

/// An image for `compare`, as linear values: the 8-bit (or 16-bit) channels of PNG and other
/// integer formats scaled to [0, 1], the floats of OpenEXR and PFM as they are, which must be
/// finite.
fn comparable(path: &Path) -> Result<raylume_integrator::Film, Failure> {
    use raylume_integrator::{Film, MAX_IMAGE_PIXELS};
    let film = if raylume_integrator::ImageFormat::from_path(path).is_ok() {
        Film::read(path).map_err(bad_input)?
    } else {
        // JPEG (and any other format the image reader was built with), a regular file, decoded
        // within the memory of the largest image read.
        let fail = |e: &dyn std::fmt::Display| bad_input(format!("{}: {e}", path.display()));
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
        if !image::ImageFormat::from_extension(&ext).is_some_and(|f| f.reading_enabled()) {
            return Err(fail(&format!("unknown image format '{ext}' (expected .png, .exr, .pfm or .jpg)")));
        }
        if !std::fs::metadata(path).map_err(|e| fail(&e))?.is_file() {
            return Err(fail(&"not a regular file"));
        }
        let mut reader = image::ImageReader::open(path).map_err(|e| fail(&e))?;
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(MAX_IMAGE_PIXELS * 16);
        reader.limits(limits);
        let img = reader.decode().map_err(|e| fail(&e))?.into_rgb32f();
        let pixels = img.pixels().map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect();
        Film::from_pixels(img.width(), img.height(), pixels)
    };
    if let Some((x, y, p)) = first_not_finite(&film) {
        return Err(bad_input(format!(
            "{}: pixel ({x}, {y}) is {p}: expected finite values to compare",
            path.display()
        )));
    }
    Ok(film)
}

/// The first pixel of `film` (row 0 at the top) that is not finite: its column, row and value.
pub(crate) fn first_not_finite(film: &raylume_integrator::Film) -> Option<(u32, u32, glam::Vec3)> {
    let i = film.pixels().iter().position(|p| !p.is_finite())?;
    Some((i as u32 % film.width(), i as u32 / film.width(), film.pixels()[i]))
}
