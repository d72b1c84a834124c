//! `render --report DIR`: the estimated error of each pass against time, as CSV and a plot, and the
//! attributes an EXR output carries.

use std::fmt::Write as _;
use std::path::Path;

use raylume_integrator::{MetaValue, metrics};
use raylume_render::{Progress, RenderOptions, RenderOutput};

use crate::Failure;

/// One pass of a render, as the report shows it.
pub(crate) struct Row {
    pass: usize,
    seconds: f64,
    mean_spp: f64,
    pixels_rendered: usize,
    estimate: Option<raylume_render::Estimate>,
}

impl Row {
    pub(crate) fn of(p: &Progress) -> Self {
        Self {
            pass: p.pass,
            seconds: p.seconds,
            mean_spp: p.mean_samples_per_pixel,
            pixels_rendered: p.pixels_rendered,
            estimate: p.estimate,
        }
    }
}

/// The header attributes of an EXR output: what was rendered, how, and its estimated error.
pub(crate) fn attributes(out: &RenderOutput, seed: u64, spp: u32, options: &RenderOptions) -> Vec<(String, MetaValue)> {
    let number = |k: &str, v: f64| (format!("raylume.{k}"), MetaValue::Number(v));
    let mut a = vec![
        number("spp", out.samples_per_pixel as f64),
        number("mean_spp", out.mean_samples_per_pixel),
        number("requested_spp", spp as f64),
        number("passes", out.passes as f64),
        number("seconds", out.render_seconds),
        number("build_seconds", out.build_seconds),
        ("raylume.seed".to_owned(), MetaValue::Text(seed.to_string())),
        ("raylume.sampler".to_owned(), MetaValue::Text(format!("{:?}", options.sampler).to_lowercase())),
        ("raylume.adaptive".to_owned(), MetaValue::Text(options.adaptive.to_string())),
        ("raylume.version".to_owned(), MetaValue::Text(env!("CARGO_PKG_VERSION").to_owned())),
    ];
    if let Some(e) = out.estimate {
        a.push(number("estimated_rmse", e.rmse));
        a.push(number("estimated_rmse_low", e.rmse_interval.0));
        a.push(number("estimated_rmse_high", e.rmse_interval.1));
        a.push(number("estimated_rel_mse", e.rel_mse));
    }
    a
}

/// Whether the report can go into `dir`, checked before the render (so that a render whose report
/// cannot be written fails before it writes its image): `dir` is a folder, or a folder can be made
/// there, and the nearest folder that exists takes new files.
pub(crate) fn check(dir: &Path) -> Result<(), Failure> {
    let fail = |message: String| Failure { code: 1, message: format!("--report {}: {message}", dir.display()) };
    let mut existing = dir;
    while !existing.exists() {
        existing = match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
    }
    if !existing.is_dir() {
        return Err(fail(format!("'{}' is not a folder", existing.display())));
    }
    let probe = existing.join(format!(".raylume-report.{}.probe", std::process::id()));
    std::fs::File::create(&probe).map_err(|e| fail(format!("cannot write into '{}': {e}", existing.display())))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Writes `dir/error.csv` (one row per pass) and `dir/error.png` (the estimated RMSE against
/// seconds on log-log axes, with the fitted slope).
pub(crate) fn write(dir: &Path, rows: &[Row], title: &str) -> Result<(), Failure> {
    let fail = |p: &Path, e: &dyn std::fmt::Display| Failure { code: 1, message: format!("{}: {e}", p.display()) };
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, &e))?;
    let mut csv =
        String::from("pass,seconds,mean_spp,pixels_rendered,est_rmse,est_rmse_low,est_rmse_high,est_rel_mse\n");
    let (mut times, mut errors) = (Vec::new(), Vec::new());
    for r in rows {
        let (rmse, lo, hi, rel) = r.estimate.map_or((f64::NAN, f64::NAN, f64::NAN, f64::NAN), |e| {
            (e.rmse, e.rmse_interval.0, e.rmse_interval.1, e.rel_mse)
        });
        let _ = writeln!(
            csv,
            "{},{:.6},{:.3},{},{rmse:.6e},{lo:.6e},{hi:.6e},{rel:.6e}",
            r.pass, r.seconds, r.mean_spp, r.pixels_rendered
        );
        if r.estimate.is_some() {
            times.push(r.seconds);
            errors.push(rmse);
        }
    }
    let csv_path = dir.join("error.csv");
    raylume_integrator::write_atomically(&csv_path, |tmp| std::fs::write(tmp, &csv), |e| e)
        .map_err(|e| fail(&csv_path, &e))?;
    let slope = metrics::log_log_slope(&times, &errors);
    let label = format!("estimated RMSE (slope {})", slope.map_or("n/a".to_owned(), |s| format!("{s:.2}")));
    let png_path = dir.join("error.png");
    if times.is_empty() {
        eprintln!("raylume: {}: no pass with an estimate (one pass) to plot", png_path.display());
        return Ok(());
    }
    let series = [(label, times.into_iter().zip(errors).collect::<Vec<_>>())];
    crate::converge::plot(&png_path, &series, title, "estimated RMSE (log)").map_err(|e| fail(&png_path, &e))?;
    Ok(())
}
