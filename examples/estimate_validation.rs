//! How well a render's own error estimate matches its true error: each scene is rendered at a high
//! sample count as the reference, then at several sample counts with each sampler; each render's
//! estimated RMSE (from the spread of its passes) is set against its RMSE to the reference (with the
//! reference's own estimated error taken out). Prints a Markdown table and the share of cells
//! within ±20 %.
//!
//! `cargo run --release --example estimate_validation -- [--width W] [--reference-spp N]
//! [--spp 4,16,64,256,1024] [--passes K] [--csv FILE] [SCENE...]`; without scenes, the five of assets/scenes and
//! six of ../shared/scenes.

use std::fmt::Write as _;
use std::path::PathBuf;

use raylume::prelude::*;
use raylume_integrator::metrics;
use raylume_render::SamplerKind;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (mut width, mut reference_spp, mut spp_list) = (96u32, 8192u32, vec![4u32, 16, 64, 256, 1024]);
    let mut passes = raylume_render::DEFAULT_PASSES;
    let (mut csv_path, mut scenes) = (None::<PathBuf>, Vec::<PathBuf>::new());
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a}: expected a value"));
        match a.as_str() {
            "--width" => width = value()?.parse()?,
            "--reference-spp" => reference_spp = value()?.parse()?,
            "--spp" => spp_list = value()?.split(',').map(str::parse).collect::<Result<_, _>>()?,
            "--csv" => csv_path = Some(value()?.into()),
            "--passes" => passes = value()?.parse()?,
            _ => scenes.push(a.into()),
        }
    }
    if scenes.is_empty() {
        for name in ["antialiasing", "soft_shadows", "depth_of_field", "fuzzy_reflections", "motion_blur"] {
            scenes.push(format!("assets/scenes/{name}.p3f").into());
        }
        for name in ["balls_low", "balls_box", "mount_low", "dof", "ball_motion", "balls_low_transparent"] {
            scenes.push(format!("../shared/scenes/{name}.p3f").into());
        }
    }
    let mut csv = String::from("scene,sampler,spp,seconds,true_rmse,est_rmse,est_low,est_high,ratio\n");
    let mut table =
        String::from("| scene | sampler | spp | true RMSE | estimated RMSE (95 % interval) | estimate / true |\n");
    table.push_str("|---|---|---:|---:|---:|---:|\n");
    let (mut cells, mut within) = (0, 0);
    for path in &scenes {
        let name = path.file_stem().map_or(String::new(), |s| s.to_string_lossy().into_owned());
        let scene = match p3f::load(path, &LoadOptions::default()) {
            Ok(loaded) => loaded.scene,
            Err(e) => {
                eprintln!("{}: skipped: {e}", path.display());
                continue;
            }
        };
        let height = (width as f64 * scene.view.height as f64 / scene.view.width as f64).round().max(1.0) as u32;
        let base = RenderOptions { resolution: Some((width, height)), ..RenderOptions::default() };
        // Passes of spp / passes samples over the pixel's area (an open time limit), stopped after
        // the passes asked for.
        let render = |spp: u32, seed: u64, sampler: SamplerKind, passes: u32| {
            let passes = passes.min(spp);
            let mut o =
                RenderOptions { spp: Some(spp), sampler, passes, time_limit: Some(f64::INFINITY), ..base.clone() };
            o.settings.seed = seed;
            scene.render_progressive(&o, &(), |p| {
                if p.pass + 1 >= passes as usize {
                    std::ops::ControlFlow::Break(())
                } else {
                    std::ops::ControlFlow::Continue(())
                }
            })
        };
        let reference = render(reference_spp, 0x005e_ed0f_7e1e, SamplerKind::Jittered, 16)?;
        let reference_mse = reference.estimate.map_or(0.0, |e| e.mse);
        let exact = reference.film.channels();
        eprintln!("{name}: reference {reference_spp} spp in {:.1} s", reference.render_seconds);
        for sampler in [SamplerKind::Independent, SamplerKind::Jittered, SamplerKind::Sobol] {
            for &spp in &spp_list {
                let out = render(spp, 1, sampler, passes)?;
                let measured = metrics::mse(&out.film.channels(), &exact).ok_or("sizes differ")?;
                let truth = (measured - reference_mse).max(0.0).sqrt();
                let sampler_name = format!("{sampler:?}").to_lowercase();
                let Some(e) = out.estimate else {
                    let _ = writeln!(csv, "{name},{sampler_name},{spp},{:.4},{truth:.6e},,,,", out.render_seconds);
                    let _ = writeln!(table, "| {name} | {sampler_name} | {spp} | {truth:.3e} | none | |");
                    cells += 1;
                    continue;
                };
                let ratio = e.rmse / truth;
                cells += 1;
                within += usize::from((0.8..=1.2).contains(&ratio));
                let _ = writeln!(
                    csv,
                    "{name},{sampler_name},{},{:.4},{truth:.6e},{:.6e},{:.6e},{:.6e},{ratio:.4}",
                    out.samples_per_pixel, out.render_seconds, e.rmse, e.rmse_interval.0, e.rmse_interval.1
                );
                let _ = writeln!(
                    table,
                    "| {name} | {sampler_name} | {} | {truth:.3e} | {:.3e} ({:.3e}–{:.3e}) | {ratio:.2} |",
                    out.samples_per_pixel, e.rmse, e.rmse_interval.0, e.rmse_interval.1
                );
            }
        }
    }
    print!("{table}");
    println!("\n{within} of {cells} cells within ±20 % ({:.0} %)", 100.0 * within as f64 / cells.max(1) as f64);
    if let Some(p) = csv_path {
        std::fs::write(&p, csv)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}
