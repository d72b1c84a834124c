//! The command line: renders, exit codes, messages, and no half-written output.

use std::path::PathBuf;
use std::process::Command;

fn raylume() -> Command {
    Command::new(env!("CARGO_BIN_EXE_raylume"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("raylume-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn default_scene_renders_to_png_exr_and_pfm() {
    let dir = temp_dir("default");
    for ext in ["png", "exr", "pfm"] {
        let out = dir.join(format!("out.{ext}"));
        let run = raylume()
            .args(["render", "--width", "40", "--height", "25", "--spp", "1", "-o"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(stderr.contains("rays (camera 1000, shadow"), "{stderr}");
        let bytes = std::fs::read(&out).unwrap();
        match ext {
            "png" => assert_eq!(&bytes[1..4], b"PNG"),
            "exr" => assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01]),
            _ => {
                assert!(bytes.starts_with(b"PF\n40 25\n-1.0\n"));
                assert_eq!(bytes.len(), "PF\n40 25\n-1.0\n".len() + 40 * 25 * 12);
            }
        }
    }
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

#[test]
fn bad_scene_exits_2_with_position_and_writes_nothing() {
    let dir = temp_dir("bad");
    let scene = dir.join("bad.p3f");
    std::fs::write(&scene, "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle forty\n").unwrap();
    let out = dir.join("out.png");
    let run = raylume().arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("bad.p3f:5:7: expected a number (angle in degrees), found 'forty'"), "{stderr}");
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "only the scene file is there");
}

#[test]
fn missing_file_absurd_size_and_unknown_format_exit_2() {
    let dir = temp_dir("input");
    let run = raylume().args(["render", "/nonexistent/x.p3f", "-o"]).arg(dir.join("a.png")).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("/nonexistent/x.p3f"));
    let run = raylume()
        .args(["render", "--width", "1000000", "--height", "1000000", "-o"])
        .arg(dir.join("b.png"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("resolution 1000000 x 1000000"));
    let run = raylume().args(["render", "-o"]).arg(dir.join("c.bmp")).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("unknown image format 'bmp'"));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
}

#[test]
fn unwritable_output_exits_1_and_leaves_nothing() {
    let dir = temp_dir("unwritable");
    let out = dir.join("no/such/folder/out.png");
    let run = raylume().args(["render", "--width", "8", "--height", "8", "-o"]).arg(&out).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    assert!(!out.exists());
    // Found before the render starts, not after it.
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("no folder") && !stderr.contains("rays (camera"), "{stderr}");
}

#[test]
fn a_report_that_cannot_be_written_fails_before_the_image_is_written() {
    let dir = temp_dir("unwritable_report");
    let (out, file) = (dir.join("out.png"), dir.join("a_file"));
    std::fs::write(&out, b"kept").unwrap();
    std::fs::write(&file, b"not a folder").unwrap();
    for report in [file.clone(), file.join("below")] {
        let run = raylume()
            .args(["render", "--width", "8", "--height", "8", "--report"])
            .arg(&report)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("--report") && stderr.contains("is not a folder"), "{stderr}");
        assert!(!stderr.contains("rays (camera"), "found before the render: {stderr}");
        assert_eq!(std::fs::read(&out).unwrap(), b"kept");
    }
}

#[test]
fn strict_turns_unknown_tags_into_errors() {
    let dir = temp_dir("strict");
    let scene = dir.join("s.p3f");
    std::fs::write(&scene, "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8\nf 1 1 1 1 1 1 1 0 1 0 1\nfoo 1 2\ns 0 0 0 1\n").unwrap();
    let out = dir.join("o.png");
    let run = raylume().arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap();
    assert!(run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("s.p3f:3:1: warning: unknown tag 'foo'"));
    std::fs::remove_file(&out).unwrap();
    let run = raylume().arg("render").arg(&scene).arg("--strict").arg("-o").arg(&out).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(!out.exists());
}

#[test]
fn non_square_spp_is_rounded_up_and_said() {
    let dir = temp_dir("spp");
    let run = raylume()
        .args(["render", "--width", "8", "--height", "8", "--spp", "5", "-o"])
        .arg(dir.join("o.png"))
        .output()
        .unwrap();
    assert!(run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("--spp 5: rendering 8 samples per pixel (2 passes of 4, 2 x 2 jittered)"), "{stderr}");
    assert!(stderr.contains("camera 512"), "{stderr}");
}

#[test]
fn compare_reports_rmse() {
    let dir = temp_dir("compare");
    let (a, b) = (dir.join("a.png"), dir.join("b.png"));
    for (p, seed) in [(&a, "1"), (&b, "1")] {
        assert!(
            raylume()
                .args(["render", "--width", "16", "--height", "10", "--seed", seed, "-o"])
                .arg(p)
                .status()
                .unwrap()
                .success()
        );
    }
    let run = raylume().arg("compare").arg(&a).arg(&b).output().unwrap();
    assert_eq!(String::from_utf8_lossy(&run.stdout).trim(), "rmse 0.000000 (0.000 of 255)");
}

/// The RMSE `compare` prints for `a` and `b`.
fn compared(a: &std::path::Path, b: &std::path::Path) -> f64 {
    let run = raylume().arg("compare").arg(a).arg(b).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let out = String::from_utf8_lossy(&run.stdout);
    out.split_whitespace().nth(1).and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("bad compare output {out}"))
}

/// A PFM file: `tag` `PF` (colour) or `Pf` (grey), the values of its rows from the bottom one up.
fn pfm(tag: &str, width: u32, height: u32, big_endian: bool, values: &[f32]) -> Vec<u8> {
    let scale = if big_endian { "1.0" } else { "-1.0" };
    let mut bytes = format!("{tag}\n{width} {height}\n{scale}\n").into_bytes();
    for v in values {
        bytes.extend_from_slice(&if big_endian { v.to_be_bytes() } else { v.to_le_bytes() });
    }
    bytes
}

/// `compare` reads the PFM files `render` writes, in either byte order, colour or grey, rows from
/// the bottom up, and compares their float values as they are with the same RMSE; a malformed
/// or short file is refused, naming it.
#[test]
fn compare_reads_pfm() {
    let dir = temp_dir("compare-pfm");
    let out = |ext: &str| dir.join(format!("d.{ext}"));
    for ext in ["pfm", "png", "exr"] {
        let run = raylume().args(["render", "-q", "--width", "40", "--height", "25", "-o"]).arg(out(ext)).output();
        assert!(run.unwrap().status.success());
    }
    assert_eq!(compared(&out("pfm"), &out("pfm")), 0.0);
    assert_eq!(compared(&out("pfm"), &out("exr")), 0.0);
    // The PNG differs from the floats by its 8-bit steps alone.
    let quantised = compared(&out("pfm"), &out("png"));
    assert!(quantised > 0.0 && quantised < 1.0 / 255.0, "{quantised}");

    // A white top row and a black bottom row, as PNG, then as PFM in each form.
    let png = dir.join("top.png");
    raylume_integrator::Film::from_pixels(1, 2, vec![glam::Vec3::ONE, glam::Vec3::ZERO]).write(&png).unwrap();
    let forms = [
        pfm("PF", 1, 2, false, &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
        pfm("PF", 1, 2, true, &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
        pfm("Pf", 1, 2, false, &[0.0, 1.0]),
        pfm("Pf", 1, 2, true, &[0.0, 1.0]),
    ];
    for (i, bytes) in forms.iter().enumerate() {
        let path = dir.join(format!("top-{i}.pfm"));
        std::fs::write(&path, bytes).unwrap();
        assert_eq!(compared(&png, &path), 0.0, "form {i}");
    }
    // Float values are not clamped: 3 against 1 at the top, 2 against 0 at the bottom.
    let bright = dir.join("bright.pfm");
    std::fs::write(&bright, pfm("Pf", 1, 2, false, &[2.0, 3.0])).unwrap();
    assert_eq!(compared(&png, &bright), 2.0);

    let refused = |bytes: &[u8], needle: &str| {
        let path = dir.join("bad.pfm");
        std::fs::write(&path, bytes).unwrap();
        let run = raylume().arg("compare").arg(&png).arg(&path).output().unwrap();
        assert_eq!(run.status.code(), Some(2));
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(stderr.contains(&format!("{}: {needle}", path.display())), "{stderr}");
    };
    refused(b"P6\n1 2\n255\n", "not a PFM file (expected 'PF' or 'Pf', width, height and scale)");
    refused(b"PF\n1 two\n-1.0\n", "expected the height in pixels, found 'two'");
    refused(&pfm("PF", 1, 2, false, &[0.0; 5]), "expected 1x2 pixels of 12 bytes (24 bytes), found 20 bytes");
    refused(&pfm("Pf", 1, 2, false, &[0.0, f32::NAN]), "pixel (0, 0) is [NaN, NaN, NaN]: expected finite values");
}

#[test]
fn effects_from_the_command_line_and_crops_match_the_full_image() {
    let dir = temp_dir("effects");
    let scene = dir.join("e.p3f");
    std::fs::write(
        &scene,
        "v from 0 1 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 24 16\nl 2 4 3 1 1 1\n\
         f 0.8 0.8 0.8 0.9 1 1 1 0.5 30 0 1\npl 0 -1 0 0 -1 -1 -1 -1 0\nsm -0.5 0 0 0.5 0 0 0.6 0 1\n",
    )
    .unwrap();
    let args = ["--spp", "4", "--area-light", "1", "--roughness", "0.2", "--aperture", "2", "--focal", "1"];
    let full = dir.join("full.pfm");
    let run = raylume().arg("render").arg(&scene).args(args).arg("-o").arg(&full).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("effects: antialiasing, soft shadows, depth of field, fuzzy reflections, motion blur"),
        "{stderr}"
    );
    let part = dir.join("part.pfm");
    let run = raylume()
        .arg("render")
        .arg(&scene)
        .args(args)
        .args(["--crop", "5", "3", "17", "11", "-o"])
        .arg(&part)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    // PFM rows are stored bottom first; compare the cropped rows with the full image's.
    let read = |p: &std::path::Path| {
        let bytes = std::fs::read(p).unwrap();
        let header_end = bytes.iter().enumerate().filter(|(_, b)| **b == b'\n').nth(2).unwrap().0 + 1;
        let floats: Vec<f32> =
            bytes[header_end..].chunks(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        floats
    };
    let (full, part) = (read(&full), read(&part));
    assert_eq!(part.len(), 12 * 8 * 3);
    for row in 0..8usize {
        for col in 0..12usize {
            // Row `row` of the crop from the top is row 3 + row of the full image; PFM stores bottom first.
            let p = ((7 - row) * 12 + col) * 3;
            let f = ((15 - (3 + row)) * 24 + 5 + col) * 3;
            assert_eq!(&part[p..p + 3], &full[f..f + 3], "pixel ({col}, {row}) of the crop");
        }
    }
    let run = raylume()
        .arg("render")
        .arg(&scene)
        .args(["--crop", "5", "3", "5", "11", "-o"])
        .arg(dir.join("x.png"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
}

#[test]
fn gen_writes_a_loadable_scene_and_bench_reports() {
    let dir = temp_dir("gen");
    let run = raylume().args(["gen", "balls", "2"]).output().unwrap();
    assert!(run.status.success());
    let scene = dir.join("balls.p3f");
    std::fs::write(&scene, &run.stdout).unwrap();
    assert_eq!(String::from_utf8_lossy(&run.stdout).lines().filter(|l| l.starts_with("s ")).count(), 91);
    let (rays, hits) = (dir.join("r.bin"), dir.join("h.bin"));
    let run = raylume()
        .arg("bench")
        .arg(&scene)
        .args(["--rays", "random", "--count", "500", "--repeat", "1", "--write-rays"])
        .arg(&rays)
        .arg("--write-hits")
        .arg(&hits)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let out = String::from_utf8_lossy(&run.stdout);
    for field in ["build", "nodes", "bytes per primitive", "closest hit", "occlusion", "tested per ray"] {
        assert!(out.contains(field), "{field} in {out}");
    }
    assert_eq!(std::fs::metadata(&rays).unwrap().len(), 4 + 500 * 24);
    assert_eq!(std::fs::metadata(&hits).unwrap().len(), 500 * 8);
    // The same rays read back, through the grid, give the same hits.
    let hits2 = dir.join("h2.bin");
    let run = raylume()
        .arg("bench")
        .arg(&scene)
        .args(["--accel", "grid", "--repeat", "1", "--read-rays"])
        .arg(&rays)
        .arg("--write-hits")
        .arg(&hits2)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(std::fs::read(&hits).unwrap(), std::fs::read(&hits2).unwrap());
    let run = raylume().args(["gen", "teapot", "2"]).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
}

#[test]
fn converge_writes_a_well_formed_csv() {
    let dir = temp_dir("converge");
    let report = dir.join("report");
    let run = raylume()
        .args(["converge", "--width", "24", "--height", "16", "--reference-spp", "64", "--spp-list", "1,4,16", "-o"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let csv = std::fs::read_to_string(report.join("convergence.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "sampler,spp,seconds,rmse,rel_mse,psnr,mae,rmse_vs_truth,est_rmse,est_rmse_low,est_rmse_high");
    assert_eq!(lines.len(), 1 + 3 * 3, "three samplers, three sample counts");
    for line in &lines[1..] {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), 11);
        assert!(["independent", "jittered", "sobol"].contains(&fields[0]), "{line}");
        // One pass at 1 spp has no estimate; four passes at 4 and 16 spp have one.
        let one_pass = fields[1] == "1";
        for (i, f) in fields[1..].iter().enumerate() {
            let v: f64 = f.parse().unwrap();
            if one_pass && i >= 7 {
                assert!(v.is_nan(), "{line}");
            } else {
                assert!(v.is_finite() && v >= 0.0, "{line}");
            }
        }
    }
    assert!(String::from_utf8_lossy(&run.stdout).contains("slope of log RMSE against log seconds"));
    assert!(report.join("reference.pfm").is_file());
    let png = std::fs::read(report.join("convergence.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The reference can be read back.
    let again = raylume()
        .args([
            "converge",
            "--width",
            "24",
            "--height",
            "16",
            "--spp-list",
            "1",
            "--sampler",
            "jittered",
            "--reference",
        ])
        .arg(report.join("reference.pfm"))
        .arg("-o")
        .arg(dir.join("again"))
        .output()
        .unwrap();
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
}

#[test]
fn converge_by_time_budgets() {
    let dir = temp_dir("budgets");
    let run = raylume()
        .args([
            "converge",
            "--width",
            "16",
            "--height",
            "12",
            "--reference-spp",
            "16",
            "--time-budgets",
            "0.002,0.01",
            "-o",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let csv = std::fs::read_to_string(dir.join("convergence.csv")).unwrap();
    let rows: Vec<Vec<f64>> =
        csv.lines().skip(1).map(|l| l.split(',').skip(1).map(|f| f.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 3 * 2, "three samplers, two budgets");
    for pair in rows.chunks(2) {
        assert!(pair[0][1] >= 0.002 && pair[1][1] >= 0.01, "each image is taken once its budget has passed");
        assert!(pair[1][0] >= pair[0][0], "more time, more samples");
    }
}

#[test]
fn bench_batch_gives_the_single_ray_hits() {
    let dir = temp_dir("batch");
    let run = raylume().args(["gen", "tetra", "4"]).output().unwrap();
    assert!(run.status.success());
    let scene = dir.join("tetra.p3f");
    std::fs::write(&scene, &run.stdout).unwrap();
    let (rays, single, batch) = (dir.join("r.bin"), dir.join("single.bin"), dir.join("batch.bin"));
    let bench = |extra: &[&str], hits: &std::path::Path| {
        let run = raylume()
            .arg("bench")
            .arg(&scene)
            .args(["--count", "4096", "--repeat", "1"])
            .args(extra)
            .arg("--write-hits")
            .arg(hits)
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        String::from_utf8_lossy(&run.stdout).into_owned()
    };
    bench(&["--write-rays", rays.to_str().unwrap()], &single);
    // The same camera rays, in the same order, through the batch queries on two threads.
    let out = bench(&["--batch", "--threads", "2", "--read-rays", rays.to_str().unwrap()], &batch);
    assert!(out.contains("batch queries"), "{out}");
    let hits = std::fs::read(&single).unwrap();
    assert_eq!(hits, std::fs::read(&batch).unwrap());
    let hit_count = hits.chunks(8).filter(|h| f32::from_le_bytes(h[..4].try_into().unwrap()).is_finite()).count();
    assert!(hit_count > 200, "the view must see the tetrahedron: {hit_count} hits");
}

#[test]
fn warnings_are_printed_before_the_error_that_stops_a_load() {
    let dir = temp_dir("warn-then-fail");
    let scene = dir.join("old.nff");
    let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 1 resolution 8 8\nGlass ball\nf 1 1 1 0.5 0.5\n";
    std::fs::write(&scene, text).unwrap();
    let out = dir.join("out.png");
    let run = raylume().arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap();
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    let warning = stderr.find("old.nff:2:1: warning: unknown tag 'Glass': skipped 'Glass ball'").expect("the warning");
    let error = stderr.find("raylume: error: ").expect("the error");
    assert!(warning < error, "{stderr}");
    assert!(stderr.contains("old.nff:3:1: expected 8 (NFF"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn every_dialect_renders_from_the_command_line_and_says_which_it_read() {
    let dir = temp_dir("dialects");
    let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scene/tests/dialects");
    let expected = [
        ("nff_1998.nff", "read as NFF"),
        ("course_2019.p3f", "read as p3f"),
        ("course_2021.p3f", "read as p3f"),
        ("course_2024.p3f", "read as p3f 2024/25"),
        ("student.p3f", "read as p3f with al, fire, ms"),
    ];
    for (name, summary) in expected {
        let out = dir.join(format!("{name}.png"));
        let run = raylume()
            .args(["render", "--width", "24", "--height", "16", "--spp", "1"])
            .arg(examples.join(name))
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{name}: {stderr}");
        assert!(stderr.contains(&format!("{name}: {summary}\n")), "{name}: {stderr}");
        assert!(out.exists());
    }
    // A missing cubemap is a warning that names the `env` line; --strict makes it an error.
    let scene = examples.join("course_2019.p3f");
    let run = raylume()
        .args(["render", "--width", "8", "--height", "8"])
        .arg(&scene)
        .arg("-o")
        .arg(dir.join("a.png"))
        .output();
    let stderr = String::from_utf8_lossy(&run.unwrap().stderr).into_owned();
    assert!(stderr.contains("course_2019.p3f:4:1: warning: environment map: no folder 'no_such_cubemap'"), "{stderr}");
    let strict = raylume()
        .args(["render", "--strict", "--width", "8", "--height", "8"])
        .arg(&scene)
        .arg("-o")
        .arg(dir.join("b.png"))
        .output()
        .unwrap();
    assert_eq!(strict.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&strict.stderr);
    assert!(
        stderr.contains("course_2019.p3f:4:1: environment map: no folder 'no_such_cubemap'")
            && stderr.contains("(an error when loading strictly; without the cubemap, --no-env or")
            && !stderr.contains("escaping rays show"),
        "{stderr}"
    );
    assert!(!dir.join("b.png").exists());
}

/// Flags beyond the limits are refused before any work, and nothing is written.
#[test]
fn flags_beyond_the_limits_exit_2_before_any_work() {
    let dir = temp_dir("limits");
    let out = dir.join("out.pfm");
    let cases: &[(&[&str], &str)] = &[
        (&["--spp", "4294967295"], "spp 4294967295: expected 1..=65536 samples per pixel"),
        (&["--spp", "0"], "spp 0: expected 1..=65536 samples per pixel"),
        (&["--crop", "10", "4", "10", "8"], "crop 10 4 10 8: expected X0 < X1 and Y0 < Y1"),
        (&["--crop", "0", "8", "10", "4"], "crop 0 8 10 4: expected X0 < X1 and Y0 < Y1"),
        (&["--threads", "10000"], "--threads 10000: expected 1..=1024"),
        (&["--threads", "0"], "--threads 0: expected 1..=1024"),
        (&["--depth", "5000"], "depth 5000: expected 1..=256"),
        (&["--light-grid", "0"], "light grid 0: expected 1..=64"),
        (&["--crop", "10", "0", "5", "4"], "crop 10 0 5 4: expected X0 < X1 and Y0 < Y1"),
        (&["--crop", "700", "0", "710", "4"], "crop 700 0 710 4: expected pixels inside the 640 x 400 image"),
        (&["--crop", "0", "390", "8", "410"], "crop 0 390 8 410: expected pixels inside the 640 x 400 image"),
        (&["--shutter", "1", "0"], "shutter [1, 0] is not an interval"),
        (&["--grid-k", "0"], "grid density 0: expected a number in (0, 1000]"),
        (&["--min-weight", "1.5"], "minimum weight 1.5: expected a number in [0, 1]"),
        (&["--min-weight", "NaN"], "minimum weight NaN: expected a number in [0, 1]"),
        (&["--min-weight", "-0.1"], "minimum weight -0.1: expected a number in [0, 1]"),
    ];
    for (flags, message) in cases {
        let run = raylume().arg("render").args(*flags).arg("-o").arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{flags:?}: {stderr}");
        assert!(stderr.contains(message), "{flags:?}: {stderr}");
        assert!(!stderr.contains("rays (camera"), "{flags:?} refused before rendering: {stderr}");
        assert!(
            raylume_cli::check_arguments(["render"].iter().chain(flags.iter())).is_err() || message.contains("image")
        );
    }
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

/// `render` and `bench` check the grid's density with the same rule and say so in the same words.
#[test]
fn render_and_bench_refuse_a_grid_density_alike() {
    for k in ["0", "NaN", "1001"] {
        let render = raylume_cli::check_arguments(["render", "--grid-k", k]).unwrap_err();
        let bench = raylume_cli::check_arguments(["bench", "--grid-k", k]).unwrap_err();
        assert_eq!(render, bench);
        assert!(render.starts_with(&format!("grid density {k}: expected a number in (0, 1000]")), "{render}");
    }
    assert!(raylume_cli::check_arguments(["bench", "--grid-k", "1000"]).is_ok());
}

fn write_pfm(path: &std::path::Path, w: u32, h: u32, pixel: impl Fn(u32) -> [f32; 3]) {
    let mut bytes = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for i in 0..w * h {
        for v in pixel(i) {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// A sample count beyond the limit, in the list or for the reference, is refused before the
/// reference is rendered and before the report's folder is made.
#[test]
fn converge_refuses_sample_counts_beyond_the_limit_before_rendering() {
    let dir = temp_dir("converge-spp");
    for args in [["--spp-list", "1,1000000000"], ["--reference-spp", "1000000000"]] {
        let report = dir.join("report");
        let run = raylume()
            .args(["converge", "--width", "8", "--height", "4", "--sampler", "jittered"])
            .args(args)
            .arg("-o")
            .arg(&report)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("1000000000") && !stderr.contains("rendering the reference"), "{stderr}");
        assert!(!report.exists());
    }
}

#[test]
fn converge_refuses_references_that_are_not_finite_or_lie_about_their_size() {
    let dir = temp_dir("converge-bad");
    let reference = dir.join("ref.pfm");
    write_pfm(&reference, 8, 4, |i| if i == 13 { [f32::INFINITY, 0.0, 0.0] } else { [0.5; 3] });
    let converge = |reference: &std::path::Path| {
        raylume()
            .args([
                "converge",
                "--width",
                "8",
                "--height",
                "4",
                "--spp-list",
                "1",
                "--sampler",
                "jittered",
                "--reference",
            ])
            .arg(reference)
            .arg("-o")
            .arg(dir.join("report"))
            .output()
            .unwrap()
    };
    let run = converge(&reference);
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("ref.pfm: pixel (5, 2) (row 0 at the top) is [inf, 0, 0]: a reference must be finite"),
        "{stderr}"
    );
    // A header whose width x height x 12 wraps around in 32 bits.
    let lying = dir.join("lying.pfm");
    std::fs::write(&lying, b"PF\n1431655766 1\n-1.0\n\0\0\0\0\0\0\0\0").unwrap();
    let run = converge(&lying);
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("lying.pfm: 1431655766x1 pixels: expected 1 to 134217728"));
}

#[test]
fn converge_of_a_scene_without_error_writes_its_rows_and_no_plot() {
    // Nothing but a background: every render equals the reference, so every error is 0 and a
    // log-log plot has no point to draw.
    let dir = temp_dir("converge-flat");
    let scene = dir.join("flat.p3f");
    std::fs::write(&scene, "bclr 0.25 0.5 0.75\nv from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 6 4\n")
        .unwrap();
    let report = dir.join("report");
    let run = raylume()
        .arg("converge")
        .arg(&scene)
        .args(["--reference-spp", "4", "--spp-list", "1,4", "--sampler", "jittered,sobol", "-o"])
        .arg(&report)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("every error measured is 0") && stderr.contains("no log-log plot"), "{stderr}");
    let csv = std::fs::read_to_string(report.join("convergence.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "a header and four rows: {csv}");
    assert!(!report.join("convergence.png").exists());
    let leftovers: Vec<_> = std::fs::read_dir(&report).unwrap().filter_map(|e| e.ok()).map(|e| e.file_name()).collect();
    assert_eq!(leftovers.len(), 2, "the CSV and the reference only: {leftovers:?}");
}

/// Options that cannot be rendered are refused before the reference, the longest render, starts.
#[test]
fn converge_checks_its_options_before_rendering_the_reference() {
    let dir = temp_dir("converge-early");
    for (flags, message) in [
        (&["--passes", "0"][..], "passes 0: expected 1..="),
        (&["--time-budgets", "0"][..], "--time-budgets: expected positive numbers of seconds"),
        (&["--time-budgets", "1,nan"][..], "--time-budgets: expected positive numbers of seconds"),
        (&["--min-weight", "2"][..], "minimum weight 2: expected a number in [0, 1]"),
        (&["--depth", "0"][..], "depth 0: expected 1..="),
        (&["--roughness", "2"][..], "roughness 2: expected [0, 1]"),
        (&["--threads", "0"][..], "--threads 0: expected 1..="),
    ] {
        let run = raylume()
            .arg("converge")
            .args(["--width", "8", "--height", "8", "--spp-list", "1", "-o"])
            .arg(dir.join("report"))
            .args(flags)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{flags:?}: {stderr}");
        assert!(stderr.contains(message), "{flags:?}: {stderr}");
        assert!(!stderr.contains("rendering the reference"), "{flags:?}: {stderr}");
    }
}

/// The RMSE `raylume compare` finds between two images.
fn rmse(a: &std::path::Path, b: &std::path::Path) -> f64 {
    let run = raylume().arg("compare").arg(a).arg(b).output().unwrap();
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{out} {}", String::from_utf8_lossy(&run.stderr));
    out.split_whitespace().nth(1).and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{out}"))
}

/// Runs `raylume converge ARGS -o REPORT`, which must succeed, and returns what it printed to stderr.
fn converged<S: AsRef<std::ffi::OsStr>>(report: &std::path::Path, args: Vec<S>) -> String {
    let run = raylume().arg("converge").args(&args).arg("-o").arg(report).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{stderr}");
    stderr
}

/// `converge` makes its reference and the renders it measures with the flags `render` takes for
/// the image (here `--depth 1`, which leaves the default scene's mirrors black).
#[test]
fn converge_renders_with_the_image_flags() {
    let dir = temp_dir("converge-flags");
    let size = ["--width", "24", "--height", "16"];
    let rendered = |name: &str, flags: &[&str]| {
        let out = dir.join(name);
        let run = raylume().arg("render").args(size).args(["--spp", "64", "-q", "-o"]).arg(&out).args(flags).output();
        assert!(run.unwrap().status.success());
        out
    };
    let (shallow, deep) = (rendered("depth1.pfm", &["--depth", "1"]), rendered("default.pfm", &[]));
    assert!(rmse(&shallow, &deep) > 0.1, "the mirrors make the difference");
    let converge = |report: &str, flags: &[&str]| {
        let report = dir.join(report);
        let flags = [&size[..], &["--sampler", "jittered", "--spp-list", "16", "--reference-spp", "64"], flags];
        converged(&report, flags.concat());
        report
    };
    // The reference it renders.
    let report = converge("rendered", &["--depth", "1"]);
    let reference = report.join("reference.pfm");
    assert!(rmse(&reference, &shallow) < 0.02 && rmse(&reference, &deep) > 0.1);
    // The renders it measures against a reference given.
    let measured = |report: PathBuf| -> f64 {
        let csv = std::fs::read_to_string(report.join("convergence.csv")).unwrap();
        csv.lines().nth(1).unwrap().split(',').nth(3).unwrap().parse().unwrap()
    };
    let given = shallow.to_str().unwrap();
    assert!(measured(converge("given", &["--depth", "1", "--reference", given])) < 0.03);
    assert!(measured(converge("given-deep", &["--reference", given])) > 0.1);
}

/// `converge` looks for a scene's cubemap in `--env-dir`, as `render` does (the message of a cubemap
/// not found asks for it).
#[test]
fn converge_finds_the_cubemap_in_env_dir() {
    let shared = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    if !shared.join("skybox").is_dir() {
        eprintln!("skipped: the course's cubemap (../shared/skybox) is absent");
        return;
    }
    let dir = temp_dir("converge-env");
    let scene = dir.join("sky.p3f");
    std::fs::write(
        &scene,
        "bclr 0.1 0.2 0.3\nenv skybox\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.01\n\
         resolution 16 16\nl 1 1 5 1 1 1\nf 1 0 0 1 0 0 0 0 1 0 1\ns 0 0 0 0.5\n",
    )
    .unwrap();
    let converge = |report: &str, flags: &[&std::ffi::OsStr]| {
        let report = dir.join(report);
        let args = ["--sampler", "jittered", "--spp-list", "1", "--reference-spp", "4"].map(std::ffi::OsStr::new);
        let stderr = converged(&report, [&[scene.as_os_str()][..], &args, flags].concat());
        (report.join("reference.pfm"), stderr)
    };
    let (without, warned) = converge("without", &[]);
    assert!(warned.contains("no folder 'skybox'") && warned.contains("give --env-dir"), "{warned}");
    let (with, quiet) = converge("with", &["--env-dir".as_ref(), shared.as_os_str()]);
    assert!(!quiet.contains("warning"), "{quiet}");
    assert!(rmse(&without, &with) > 0.1, "the sky is seen around the ball");
}

/// The summary gives the samples per pixel each sampler really drew: split into passes of equal
/// size (a jittered pass rounds up to a square), a count may round up, and the CLI says so.
#[test]
fn the_summary_reports_the_samples_rendered() {
    let dir = temp_dir("samples");
    let out = dir.join("out.png");
    for (sampler, spp, shown, rounded) in [
        ("sobol", "8", "8 spp", false),
        ("independent", "5", "6 spp", true),
        ("jittered", "8", "8 spp", false),
        ("jittered", "9", "12 spp", true),
    ] {
        let run = raylume()
            .args(["render", "--sampler", sampler, "--spp", spp, "--width", "16", "--height", "10", "-o"])
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(0), "{stderr}");
        assert!(stderr.contains(&format!("(16x10, {shown}, ")), "{sampler}: {stderr}");
        assert_eq!(stderr.contains(&format!("--spp {spp}: rendering")), rounded, "{sampler}: {stderr}");
    }
}

/// `--quiet` leaves stderr empty on success (no summary, no progress) and still writes the image.
#[test]
fn quiet_prints_nothing_on_success() {
    let dir = temp_dir("quiet");
    let out = dir.join("out.png");
    let run =
        raylume().args(["render", "--quiet", "--width", "16", "--height", "10", "-o"]).arg(&out).output().unwrap();
    assert_eq!(run.status.code(), Some(0));
    assert_eq!(String::from_utf8_lossy(&run.stderr), "");
    assert!(out.is_file());
    let loud = raylume().args(["render", "--width", "16", "--height", "10", "-o"]).arg(&out).output().unwrap();
    assert!(String::from_utf8_lossy(&loud.stderr).contains("raylume: wrote"));
}

/// `render --help` calls the aperture what the camera uses it as: a lens radius.
#[test]
fn help_calls_the_aperture_a_radius() {
    let help = raylume().args(["render", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(text.contains("the lens radius"), "{text}");
    assert!(!text.contains("diameter"), "{text}");
    assert!(text.contains("--quiet"), "{text}");
}

/// Every render says its estimated error; `--report` writes it per pass against time, and a budget
/// or adaptive sampling render as many passes as they need.
#[test]
fn renders_report_their_estimated_error_per_pass() {
    let dir = temp_dir("report");
    let report = dir.join("report");
    let run = raylume()
        .args(["render", "--width", "32", "--height", "20", "--spp", "16", "--report"])
        .arg(&report)
        .arg("-o")
        .arg(dir.join("out.exr"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(stderr.contains("raylume: estimated error RMSE ") && stderr.contains("over 4 passes"), "{stderr}");
    let csv = std::fs::read_to_string(report.join("error.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "pass,seconds,mean_spp,pixels_rendered,est_rmse,est_rmse_low,est_rmse_high,est_rel_mse");
    assert_eq!(lines.len(), 1 + 4, "one row per pass: {csv}");
    let rmse: Vec<f64> = lines[1..].iter().map(|l| l.split(',').nth(4).unwrap().parse().unwrap()).collect();
    assert!(rmse[0].is_nan() && rmse[1..].iter().all(|e| e.is_finite() && *e > 0.0), "{csv}");
    assert_eq!(&std::fs::read(report.join("error.png")).unwrap()[1..4], b"PNG");

    // One pass: no estimate, and the summary says so.
    let run = raylume()
        .args(["render", "--width", "32", "--height", "20", "--spp", "16", "--passes", "1", "-o"])
        .arg(dir.join("one.png"))
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&run.stderr).contains("estimated error: none (one pass"));

    // A noise threshold and adaptive sampling.
    let run = raylume()
        .args(["render", "--width", "32", "--height", "20", "--spp", "4", "--noise-threshold", "0.02", "--adaptive"])
        .arg("-o")
        .arg(dir.join("adaptive.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let rmse: f64 = stderr.split("estimated error RMSE ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(rmse <= 0.02, "{stderr}");
    assert!(stderr.contains("(adaptive: "), "{stderr}");
    let refused = raylume().args(["render", "--time-limit", "0"]).output().unwrap();
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("time limit 0: expected seconds > 0"));
}

/// A scene on standard input (`-`) or through a pipe renders the image of the same scene's file; a
/// scene from standard input cannot be farmed (each part reads the scene again).
#[test]
fn a_scene_from_standard_input_renders_as_its_file() {
    use std::io::Write;
    use std::process::Stdio;
    let dir = temp_dir("stdin");
    let text = raylume().args(["gen", "balls", "1"]).output().unwrap().stdout;
    let file = dir.join("balls.p3f");
    std::fs::write(&file, &text).unwrap();
    let render = |scene: &str, out: &str, input: Option<&[u8]>, extra: &[&str]| {
        let mut child = raylume()
            .args(["render", "-q", "--width", "48", "--height", "32", scene, "-o"])
            .arg(dir.join(out))
            .args(extra)
            .stdin(if input.is_some() { Stdio::piped() } else { Stdio::null() })
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        if let Some(bytes) = input {
            child.stdin.take().unwrap().write_all(bytes).unwrap();
        }
        child.wait_with_output().unwrap()
    };
    let run = render(file.to_str().unwrap(), "file.pfm", None, &[]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    for (scene, out) in [("-", "dash.pfm"), ("/dev/stdin", "dev.pfm")] {
        if scene == "/dev/stdin" && !std::path::Path::new(scene).exists() {
            continue;
        }
        let run = render(scene, out, Some(&text), &[]);
        assert!(run.status.success(), "{scene}: {}", String::from_utf8_lossy(&run.stderr));
        assert_eq!(std::fs::read(dir.join(out)).unwrap(), std::fs::read(dir.join("file.pfm")).unwrap(), "{scene}");
    }
    let run = render("-", "bad.png", Some(b"v garbage\n"), &[]);
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("<stdin>:1:3: expected 'from'"));
    assert!(!dir.join("bad.png").exists());
    let run = render("-", "part.exr", Some(&text), &["--tile", "0/2"]);
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("standard input cannot be farmed"));
}

/// `gen` into a reader that stops early (`| head -1`) ends quietly, as a Unix filter does.
#[test]
fn gen_into_a_closed_pipe_ends_quietly() {
    use std::process::Stdio;
    let mut child =
        raylume().args(["gen", "balls", "5"]).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let mut first = [0u8; 16];
    std::io::Read::read_exact(child.stdout.as_mut().unwrap(), &mut first).unwrap();
    drop(child.stdout.take());
    let run = child.wait_with_output().unwrap();
    assert_eq!(run.status.code(), Some(0), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(String::from_utf8_lossy(&run.stderr), "");
}

/// A scene given as `--mesh` is refused with the OBJ reader's error and a word that it is a scene;
/// a file that is neither keeps the OBJ reader's error alone.
#[test]
fn a_scene_given_as_a_mesh_is_named_a_scene() {
    let dir = temp_dir("scene-as-mesh");
    let scene = dir.join("balls.p3f");
    std::fs::write(&scene, "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.01\nresolution 8 8\nl 1 1 5 1 1 1\nf 1 0 0 1 0 0 0 0 1 0 1\ns 0 0 0 1\n").unwrap();
    let junk = dir.join("junk.obj");
    std::fs::write(&junk, "v 1 2\n").unwrap();
    for command in ["render", "bench"] {
        let run = raylume().arg(command).arg("--mesh").arg(&scene).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("balls.p3f:1:1: not a readable OBJ file"), "{stderr}");
        assert!(stderr.contains("the file reads as a p3f scene: give it as the scene, without --mesh"), "{stderr}");
        let run = raylume().arg(command).arg("--mesh").arg(&junk).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("junk.obj:1:") && !stderr.contains("reads as"), "{stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An OBJ file given where a scene goes is a mesh, framed as `--mesh` frames it, in `render`,
/// `bench` and `converge` alike; its extension is read in any case.
#[test]
fn an_obj_file_given_as_the_scene_renders_as_a_mesh() {
    let dir = temp_dir("obj-as-scene");
    let mesh = dir.join("Tetra.OBJ");
    std::fs::write(&mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n").unwrap();
    let render = |args: &[&str], out: &str| {
        let run = raylume()
            .arg("render")
            .args(args)
            .arg(&mesh)
            .args(["--width", "48", "--height", "32", "--threads", "1", "-o"])
            .arg(dir.join(out))
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        std::fs::read(dir.join(out)).unwrap()
    };
    let as_scene = render(&[], "scene.pfm");
    let as_mesh = render(&["--mesh"], "mesh.pfm");
    assert_eq!(as_scene, as_mesh);
    // The mesh is in view: the image is not one colour.
    let pixels: Vec<&[u8]> = as_scene["PF\n48 32\n-1.0\n".len()..].chunks(12).collect();
    assert!(pixels.iter().any(|p| *p != pixels[0]), "the mesh is not in the picture");

    let bench = raylume().arg("bench").arg(&mesh).args(["--count", "256", "--threads", "1"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&bench.stdout);
    assert!(bench.status.success(), "{}", String::from_utf8_lossy(&bench.stderr));
    assert!(stdout.contains("primitives          4"), "{stdout}");

    let report = dir.join("report");
    let converge = raylume()
        .arg("converge")
        .arg(&mesh)
        .args(["--width", "16", "--height", "12", "--reference-spp", "4", "--spp-list", "1", "-o"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(converge.status.success(), "{}", String::from_utf8_lossy(&converge.stderr));
    assert!(report.join("convergence.csv").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
