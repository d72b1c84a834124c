//! What adaptive sampling gains at equal time: each scene is rendered progressively, in passes of
//! `--pass-spp` samples, until the same time limit, once uniformly and once adaptively, and both
//! are measured against a high-sample reference. The gain is the ratio of error² · time (uniform over
//! adaptive; above 1, adaptive wins), the median over `--runs` alternating runs. The time limit is
//! the wall time a uniform render of `--spp` samples takes, set-up included.
//!
//! With `--equal-samples`, both renders take `--spp` samples with no budget instead: the uniform
//! one in the default 4 passes, the adaptive one in 16.
//!
//! `cargo run --release --example adaptive_sampling -- [--width W] [--spp N] [--pass-spp N]
//! [--reference-spp N] [--runs R] [--equal-samples] [SCENE...]`; without scenes, those of assets/scenes and
//! ../shared/scenes with local noise (soft shadows, depth of field, motion blur, fuzzy reflections,
//! glass).

use std::path::PathBuf;

use raylume::prelude::*;
use raylume_integrator::metrics;
use raylume_render::SamplerKind;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (mut width, mut spp, mut reference_spp, mut runs, mut pass_spp) = (160u32, 64u32, 4096u32, 3usize, 4u32);
    let mut scenes = Vec::<PathBuf>::new();
    let mut equal_samples = false;
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a}: expected a value"));
        match a.as_str() {
            "--width" => width = value()?.parse()?,
            "--spp" => spp = value()?.parse()?,
            "--reference-spp" => reference_spp = value()?.parse()?,
            "--runs" => runs = value()?.parse()?,
            "--pass-spp" => pass_spp = value()?.parse()?,
            "--equal-samples" => equal_samples = true,
            _ => scenes.push(a.into()),
        }
    }
    if scenes.is_empty() {
        for name in ["soft_shadows", "depth_of_field", "motion_blur", "fuzzy_reflections"] {
            scenes.push(format!("assets/scenes/{name}.p3f").into());
        }
        for name in ["dof", "ball_motion", "balls_low_transparent"] {
            scenes.push(format!("../shared/scenes/{name}.p3f").into());
        }
    }
    println!(
        "| scene | time limit (s) | uniform RMSE (spp, s) | adaptive RMSE (mean spp, s) | gain, error² · time | estimated / true RMSE, uniform / adaptive |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    let (mut wins, mut worst, mut count) = (0, f64::INFINITY, 0);
    for path in &scenes {
        let name = path.file_stem().map_or(String::new(), |s| s.to_string_lossy().into_owned());
        let scene = p3f::load(path, &LoadOptions::default())?.scene;
        let height = (width as f64 * scene.view.height as f64 / scene.view.width as f64).round().max(1.0) as u32;
        let base = RenderOptions {
            resolution: Some((width, height)),
            sampler: SamplerKind::Jittered,
            ..RenderOptions::default()
        };
        let mut reference = base.clone();
        (reference.spp, reference.passes, reference.settings.seed) = (Some(reference_spp), 16, 0x005e_ed0f_7e1e);
        let reference = scene.render(&reference, &())?;
        let exact = reference.film.channels();
        let reference_mse = reference.estimate.map_or(0.0, |e| e.mse);
        // The time limit: a uniform render of `spp` samples in passes of `pass_spp`.
        let passes = spp.div_ceil(pass_spp);
        let calibration = RenderOptions { spp: Some(passes * pass_spp), passes, ..base.clone() };
        // The limit counts from the call (the cubemap's loading and the build included), as the
        // calibration's wall time does.
        let start = std::time::Instant::now();
        scene.render(&calibration, &())?;
        let limit = start.elapsed().as_secs_f64();
        let measure = |adaptive: bool| -> Result<(f64, f64, f64, f64), Box<dyn std::error::Error>> {
            let o = if equal_samples {
                // No budget: `spp` samples, uniformly in the default passes, adaptively in 16.
                let passes = if adaptive { 16 } else { raylume_render::DEFAULT_PASSES };
                RenderOptions { spp: Some(spp), passes, adaptive, ..base.clone() }
            } else {
                RenderOptions { spp: Some(pass_spp), passes: 1, time_limit: Some(limit), adaptive, ..base.clone() }
            };
            let out = scene.render(&o, &())?;
            let mse = (metrics::mse(&out.film.channels(), &exact).ok_or("sizes differ")? - reference_mse).max(1e-30);
            let estimated = out.estimate.map_or(f64::NAN, |e| e.rmse);
            Ok((mse, out.render_seconds, out.mean_samples_per_pixel, estimated))
        };
        let (mut uniform, mut adaptive) = (Vec::new(), Vec::new());
        for _ in 0..runs {
            uniform.push(measure(false)?);
            adaptive.push(measure(true)?);
        }
        let median = |v: &mut Vec<(f64, f64, f64, f64)>| {
            v.sort_by(|a, b| (a.0 * a.1).total_cmp(&(b.0 * b.1)));
            v[v.len() / 2]
        };
        let ((mse_u, t_u, s_u, e_u), (mse_a, t_a, s_a, e_a)) = (median(&mut uniform), median(&mut adaptive));
        let gain_time = (mse_u * t_u) / (mse_a * t_a);
        println!(
            "| {name} | {limit:.3} | {:.3e} ({s_u:.0} spp, {t_u:.3} s) | {:.3e} ({s_a:.0} spp, {t_a:.3} s) | {gain_time:.2} | {:.2} / {:.2} |",
            mse_u.sqrt(),
            mse_a.sqrt(),
            e_u / mse_u.sqrt(),
            e_a / mse_a.sqrt()
        );
        count += 1;
        wins += usize::from(gain_time >= 1.5);
        worst = worst.min(gain_time);
    }
    println!("\n{wins} of {count} scenes gain 1.5x or more in error² · time; the least gain is {worst:.2}");
    Ok(())
}
