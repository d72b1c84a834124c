//! What adaptive sampling gains: each scene is rendered uniformly and adaptively with the same
//! number of samples in all, and both are measured against a high-sample reference. The gain is the
//! ratio of error² · time (uniform over adaptive; above 1, adaptive wins), and of error² · samples,
//! which the machine's load does not move.
//!
//! `cargo run --release --example adaptive_sampling -- [--width W] [--spp N] [--reference-spp N]
//! [--runs R] [SCENE...]`; without scenes, those of assets/scenes and ../shared/scenes with local
//! noise (soft shadows, depth of field, motion blur, fuzzy reflections, glass).

use std::path::PathBuf;

use raylume::prelude::*;
use raylume_integrator::metrics;
use raylume_render::SamplerKind;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (mut width, mut spp, mut reference_spp, mut runs) = (160u32, 64u32, 4096u32, 3usize);
    let mut scenes = Vec::<PathBuf>::new();
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a}: expected a value"));
        match a.as_str() {
            "--width" => width = value()?.parse()?,
            "--spp" => spp = value()?.parse()?,
            "--reference-spp" => reference_spp = value()?.parse()?,
            "--runs" => runs = value()?.parse()?,
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
        "| scene | uniform RMSE | adaptive RMSE | uniform s | adaptive s | gain, error² · time | gain, error² · samples |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
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
        let measure = |adaptive: bool| -> Result<(f64, f64, f64), Box<dyn std::error::Error>> {
            let mut o = RenderOptions { spp: Some(spp), adaptive, ..base.clone() };
            o.passes = if adaptive { 16 } else { raylume_render::DEFAULT_PASSES };
            // The median time of a few runs (the same image each time).
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..runs {
                let out = scene.render(&o, &())?;
                times.push(out.render_seconds);
                last = Some(out);
            }
            times.sort_by(f64::total_cmp);
            let out = last.expect("runs >= 1");
            let mse = (metrics::mse(&out.film.channels(), &exact).ok_or("sizes differ")? - reference_mse).max(1e-30);
            Ok((mse, times[times.len() / 2], out.mean_samples_per_pixel))
        };
        let (mse_u, t_u, s_u) = measure(false)?;
        let (mse_a, t_a, s_a) = measure(true)?;
        let gain_time = (mse_u * t_u) / (mse_a * t_a);
        let gain_samples = (mse_u * s_u) / (mse_a * s_a);
        println!(
            "| {name} | {:.3e} | {:.3e} | {t_u:.3} | {t_a:.3} | {gain_time:.2} | {gain_samples:.2} |",
            mse_u.sqrt(),
            mse_a.sqrt()
        );
        count += 1;
        wins += usize::from(gain_time >= 1.5);
        worst = worst.min(gain_time);
    }
    println!("\n{wins} of {count} scenes gain 1.5x or more in error² · time; the least gain is {worst:.2}");
    Ok(())
}
