//! `raylume converge`: error against run time, per sample count and sampler.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use raylume_integrator::{Film, RenderSettings, metrics};
use raylume_render::{RenderOptions, RenderScene, SamplerKind};
use raylume_scene::{DEFAULT_SCENE, p3f};

use crate::{Failure, ImageArgs, SamplerArg, bad_input};

#[derive(clap::Args)]
pub struct ConvergeArgs {
    /// The p3f or NFF scene (`-`: read from standard input; a .obj mesh is framed by an automatic
    /// camera and light); without it, the embedded default scene.
    scene: Option<PathBuf>,
    /// A reference image (.pfm or .exr, linear) instead of rendering one.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Samples per pixel of the rendered reference.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Sample counts to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
    spp_list: Vec<u32>,
    /// Measure at these render times (seconds) instead: each sampler renders progressively and the
    /// image is measured when each budget is reached (instead of --spp-list).
    #[arg(long, value_delimiter = ',')]
    time_budgets: Option<Vec<f64>>,
    /// Passes of each render (their spread is the estimated error; 1: none).
    #[arg(long, default_value_t = raylume_render::DEFAULT_PASSES)]
    passes: u32,
    /// Samplers to compare.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "independent,jittered,sobol")]
    sampler: Vec<SamplerArg>,
    /// Image width (give --height too).
    #[arg(long, requires = "height")]
    width: Option<u32>,
    /// Image height (give --width too).
    #[arg(long, requires = "width")]
    height: Option<u32>,
    /// A further folder to look for the scene's `env` cubemap in.
    #[arg(long)]
    env_dir: Vec<PathBuf>,
    /// Ignore the scene's cubemap.
    #[arg(long)]
    no_env: bool,
    /// Depth, shading rules, effects, accelerator and threads, as `render` takes them: the
    /// reference and every measured render are made with them.
    #[command(flatten)]
    image: ImageArgs,
    /// The report folder (created if needed).
    #[arg(short, long, default_value = "report")]
    output: PathBuf,
}

pub fn run(args: ConvergeArgs) -> Result<(), Failure> {
    args.image.pool()?.install(|| measure(&args))
}

/// [`run`] on the pool of `--threads` workers.
fn measure(args: &ConvergeArgs) -> Result<(), Failure> {
    let options = p3f::LoadOptions { ignore_env: args.no_env, env_dirs: args.env_dir.clone(), ..Default::default() };
    let (scene, warnings) = match &args.scene {
        Some(path) if crate::is_obj(path) => {
            let (mesh, warnings) = crate::load_mesh(path, false)?;
            (raylume_scene::procedural::mesh_view(mesh, 512, 512), warnings)
        }
        Some(path) => {
            let loaded = crate::load_scene(path, &options)?;
            (loaded.scene, loaded.warnings)
        }
        None => {
            let loaded = p3f::parse(DEFAULT_SCENE, "<default scene>", &options).map_err(crate::load_failure)?;
            (loaded.scene, loaded.warnings)
        }
    };
    for w in &warnings {
        eprintln!("{w}");
    }
    if args.spp_list.is_empty() || args.spp_list.contains(&0) || args.reference_spp == 0 {
        return Err(bad_input("sample counts must be at least 1"));
    }
    if args.time_budgets.as_ref().is_some_and(|b| b.is_empty() || b.iter().any(|b| !b.is_finite() || *b <= 0.0)) {
        return Err(bad_input("--time-budgets: expected positive numbers of seconds"));
    }
    let base = args.image.options(RenderOptions {
        resolution: args.width.zip(args.height),
        env_dirs: args.env_dir.clone(),
        use_env: !args.no_env,
        ..RenderOptions::default()
    })?;
    // Every option is checked before the reference, the longest render, starts.
    RenderOptions { passes: args.passes, ..base.clone() }.validate().map_err(bad_input)?;
    let counts = if args.time_budgets.is_some() { &[][..] } else { &args.spp_list[..] };
    let reference_spp = args.reference.is_none().then_some(args.reference_spp);
    for spp in counts.iter().copied().chain(reference_spp) {
        RenderOptions { spp: Some(spp), ..base.clone() }.validate().map_err(bad_input)?;
    }
    std::fs::create_dir_all(&args.output)
        .map_err(|e| Failure { code: 1, message: format!("{}: {e}", args.output.display()) })?;
    let render = |spp: u32, seed: u64, sampler: SamplerKind, passes: u32| {
        let passes = passes.min(spp);
        // Budgeted passes sample the pixel's area even at 1 spp: an open time limit, stopped after
        // the passes asked for.
        let options = RenderOptions {
            settings: RenderSettings { seed, ..base.settings },
            spp: Some(spp),
            sampler,
            passes,
            time_limit: Some(f64::INFINITY),
            ..base.clone()
        };
        let stop = |p: &raylume_render::Progress| {
            if p.pass + 1 >= passes as usize {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        };
        scene.render_progressive(&options, &(), stop).map_err(bad_input)
    };
    // The reference's own error, estimated from its passes, is taken out of each render's measured
    // MSE (the render and the reference are independent, so their errors' squares add up).
    let mut reference_mse = 0.0;
    let reference: Film = match &args.reference {
        Some(path) => {
            let film = Film::read(path).map_err(bad_input)?;
            if let Some((x, y, p)) = crate::first_not_finite(&film) {
                return Err(bad_input(format!(
                    "{}: pixel ({x}, {y}) (row 0 at the top) is {p}: a reference must be finite",
                    path.display()
                )));
            }
            film
        }
        None => {
            eprintln!("raylume: rendering the reference at {} spp", args.reference_spp);
            let out = render(args.reference_spp, 0x005e_ed0f_7e1e, SamplerKind::Jittered, REFERENCE_PASSES)?;
            reference_mse = out.estimate.map_or(0.0, |e| e.mse);
            out.film
                .write(args.output.join("reference.pfm"))
                .map_err(|e| Failure { code: 1, message: e.to_string() })?;
            out.film
        }
    };
    let reference_channels = reference.channels();
    let mut csv =
        String::from("sampler,spp,seconds,rmse,rel_mse,psnr,mae,rmse_vs_truth,est_rmse,est_rmse_low,est_rmse_high\n");
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut table = String::new();
    for sampler in &args.sampler {
        let kind: SamplerKind = (*sampler).into();
        let (mut times, mut errors, mut estimated) = (Vec::new(), Vec::new(), Vec::new());
        // Each render's samples per pixel as drawn (a jittered sampler rounds up to a square).
        let measured: Vec<Measured> = match &args.time_budgets {
            Some(budgets) => progressive_budgets(&scene, &base, kind, budgets)?,
            None => args
                .spp_list
                .iter()
                .map(|&spp| {
                    render(spp, 1, kind, args.passes).map(|out| Measured {
                        spp: out.samples_per_pixel,
                        seconds: out.render_seconds,
                        film: out.film,
                        estimate: out.estimate,
                    })
                })
                .collect::<Result<_, _>>()?,
        };
        for Measured { spp, seconds, film, estimate } in measured {
            if (film.width(), film.height()) != (reference.width(), reference.height()) {
                return Err(bad_input(format!(
                    "the reference is {}x{} but the renders are {}x{}",
                    reference.width(),
                    reference.height(),
                    film.width(),
                    film.height()
                )));
            }
            let image = film.channels();
            let rmse = metrics::rmse(&image, &reference_channels).unwrap_or(f64::NAN);
            let rel = metrics::rel_mse(&image, &reference_channels, 0.01).unwrap_or(f64::NAN);
            let psnr = metrics::psnr(&image, &reference_channels, 1.0).unwrap_or(f64::NAN);
            let mae = metrics::mae(&image, &reference_channels).unwrap_or(f64::NAN);
            let truth = (rmse * rmse - reference_mse).max(0.0).sqrt();
            let (est, lo, hi) =
                estimate.map_or((f64::NAN, f64::NAN, f64::NAN), |e| (e.rmse, e.rmse_interval.0, e.rmse_interval.1));
            let name = format!("{sampler:?}").to_lowercase();
            let _ = writeln!(
                csv,
                "{name},{spp},{:.6},{rmse:.6e},{rel:.6e},{psnr:.3},{mae:.6e},{truth:.6e},{est:.6e},{lo:.6e},{hi:.6e}",
                seconds
            );
            let _ = writeln!(
                table,
                "{name:<12} {spp:>6} {:>10.4} {rmse:>12.5e} {rel:>12.5e} {psnr:>8.2} {mae:>12.5e} {est:>12.5e} {:>8.3}",
                seconds,
                est / truth
            );
            times.push(seconds);
            errors.push(rmse);
            estimated.push(est);
        }
        let slope = metrics::log_log_slope(&times, &errors);
        let label = format!(
            "{} (slope {})",
            format!("{sampler:?}").to_lowercase(),
            slope.map_or("n/a".to_owned(), |s| format!("{s:.2}"))
        );
        series.push((label, times.iter().copied().zip(errors.iter().copied()).collect()));
        let slope = metrics::log_log_slope(&times, &estimated);
        let label = format!(
            "{} estimated (slope {})",
            format!("{sampler:?}").to_lowercase(),
            slope.map_or("n/a".to_owned(), |s| format!("{s:.2}"))
        );
        // Renders of one pass have no estimate: no line for them.
        if estimated.iter().any(|e| e.is_finite()) {
            series.push((label, times.iter().copied().zip(estimated.iter().copied()).collect()));
        }
        let _ = writeln!(
            table,
            "{:<12} slope of log RMSE against log seconds: {}",
            format!("{sampler:?}").to_lowercase(),
            slope.map_or("n/a".to_owned(), |s| format!("{s:.3}"))
        );
    }
    // The measured rows first: a plot that cannot be drawn loses none of them.
    let csv_path = args.output.join("convergence.csv");
    std::fs::write(&csv_path, csv).map_err(|e| Failure { code: 1, message: format!("{}: {e}", csv_path.display()) })?;
    eprintln!("raylume: wrote {}", csv_path.display());
    println!(
        "{:<12} {:>6} {:>10} {:>12} {:>12} {:>8} {:>12} {:>12} {:>8}",
        "sampler", "spp", "seconds", "rmse", "rel_mse", "psnr", "mae", "est_rmse", "est/true"
    );
    print!("{table}");
    let png_path = args.output.join("convergence.png");
    if !series.iter().flat_map(|s| &s.1).any(|&p| plottable(p)) {
        eprintln!("raylume: every error measured is 0 (each render equals the reference): no log-log plot to draw");
        return Ok(());
    }
    plot(&png_path, &series, &scene_name(args), "RMSE against the reference, and estimated (log)")
        .map_err(|e| Failure { code: 1, message: format!("{}: {e}", png_path.display()) })?;
    eprintln!("raylume: wrote {}", png_path.display());
    Ok(())
}

fn scene_name(args: &ConvergeArgs) -> String {
    args.scene
        .as_ref()
        .and_then(|p| p.file_name())
        .map_or("default scene".to_owned(), |n| n.to_string_lossy().into_owned())
}

/// A log-log plot of RMSE against seconds, one line per series, written through a temporary file;
/// `y_desc` says what the RMSE is measured against.
pub(crate) fn plot(
    path: &Path,
    series: &[(String, Vec<(f64, f64)>)],
    title: &str,
    y_desc: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    let points: Vec<(f64, f64)> = series.iter().flat_map(|s| s.1.iter().copied()).filter(|&p| plottable(p)).collect();
    if points.is_empty() {
        return Err("no positive points to plot".into());
    }
    let (x0, x1) = points.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = points.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let draw = |tmp: &Path| -> Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(tmp, (900, 600)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(format!("RMSE against render time: {title}"), ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d((x0 * 0.8..x1 * 1.25).log_scale(), (y0 * 0.8..y1 * 1.25).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("seconds (log)")
            .y_desc(y_desc)
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .light_line_style(WHITE)
            .draw()?;
        for (i, (label, pts)) in series.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(pts.iter().copied().filter(|&p| plottable(p)), color.stroke_width(2)))?
                .label(label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2)));
            chart.draw_series(pts.iter().filter(|&&p| plottable(p)).map(|&p| Circle::new(p, 4, color.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()?;
        root.present()?;
        Ok(())
    };
    raylume_integrator::write_atomically(path, draw, |e| e.into())
}

/// Whether a point can stand on the log-log axes.
fn plottable((x, y): (f64, f64)) -> bool {
    x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()
}

/// One measured render.
struct Measured {
    /// Samples per pixel drawn.
    spp: u64,
    seconds: f64,
    film: Film,
    estimate: Option<raylume_integrator::Estimate>,
}

/// Passes of the rendered reference: many, so that its own error is well estimated.
const REFERENCE_PASSES: u32 = 16;

/// Renders progressively, in passes of one sample per pixel, and keeps the image available when
/// each time budget is reached.
fn progressive_budgets(
    scene: &raylume_scene::Scene,
    base: &RenderOptions,
    sampler: SamplerKind,
    budgets: &[f64],
) -> Result<Vec<Measured>, Failure> {
    let mut budgets: Vec<f64> = budgets.to_vec();
    budgets.sort_by(f64::total_cmp);
    let options = RenderOptions {
        settings: RenderSettings { seed: 1, ..base.settings },
        spp: Some(1),
        passes: 1,
        time_limit: Some(f64::INFINITY),
        sampler,
        ..base.clone()
    };
    let mut found = Vec::new();
    scene
        .render_progressive(&options, &(), |p| {
            while found.len() < budgets.len() && p.seconds >= budgets[found.len()] {
                found.push(Measured {
                    spp: p.samples_per_pixel,
                    seconds: p.seconds,
                    film: p.film.clone(),
                    estimate: p.estimate,
                });
            }
            if found.len() == budgets.len() {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        })
        .map_err(bad_input)?;
    if found.len() < budgets.len() {
        eprintln!(
            "raylume: the budgets from {} s on were not reached at the most samples per pixel; they are left out",
            budgets[found.len()],
        );
    }
    Ok(found)
}
