//! Render farms from the command line: `render --tile` parts merged by `raylume merge` equal the
//! one-machine render byte for byte, and bad tiles and bad parts are refused with clear errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn raylume() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_raylume"));
    c.env_remove("RAYLUME_TEST_TILE");
    c
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("raylume-farm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The flags of every render here: the default scene, small, 4 samples per pixel in 4 passes.
const FLAGS: [&str; 8] = ["--width", "40", "--height", "25", "--spp", "4", "--quiet", "--threads"];

fn render(extra: &[&str], out: &Path) -> Output {
    raylume().arg("render").args(FLAGS).arg("2").args(extra).arg("-o").arg(out).output().unwrap()
}

fn merge(out: &Path, parts: &[PathBuf]) -> Output {
    raylume().arg("merge").arg(out).args(parts).output().unwrap()
}

fn ok(run: &Output) {
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
}

/// Exit code 2, one line of error that contains `needle`.
fn refused(run: &Output, needle: &str) -> String {
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains(needle), "expected '{needle}' in: {stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    stderr
}

/// Parts `0/n` .. `n-1/n` of the flags `extra`, in `dir`.
fn parts(dir: &Path, n: u32, extra: &[&str], prefix: &str) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let out = dir.join(format!("{prefix}-{i}.exr"));
            let tile = format!("{i}/{n}");
            let mut args = vec!["--tile", tile.as_str()];
            args.extend_from_slice(extra);
            ok(&render(&args, &out));
            out
        })
        .collect()
}

#[test]
fn merged_regions_equal_the_one_machine_render_byte_for_byte() {
    let dir = temp_dir("exact");
    let full = dir.join("full.pfm");
    ok(&render(&[], &full));
    let full_exr = dir.join("full.exr");
    ok(&render(&[], &full_exr));
    // 25 rows in 3 and 7 regions: bands of unequal height; also in 25 regions of one row.
    for n in [3u32, 7, 25] {
        let mut parts = parts(&dir, n, &[], &format!("n{n}"));
        parts.reverse();
        let merged = dir.join(format!("merged-{n}.pfm"));
        ok(&merge(&merged, &parts));
        assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&full).unwrap(), "{n} regions");
    }
    // A merged EXR has the pixels and the variance of the one-machine EXR.
    let parts = parts(&dir, 2, &[], "exr");
    let merged = dir.join("merged.exr");
    ok(&merge(&merged, &parts));
    let channels = |p: &Path| {
        let image = exr::prelude::read_first_flat_layer_from_file(p).unwrap();
        let mut list: Vec<(String, Vec<f32>)> = image
            .layer_data
            .channel_data
            .list
            .iter()
            .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
            .collect();
        list.sort_by(|a, b| a.0.cmp(&b.0));
        list
    };
    let (a, b) = (channels(&merged), channels(&full_exr));
    let names: Vec<&str> = a.iter().map(|c| c.0.as_str()).collect();
    assert_eq!(names, ["B", "G", "R", "variance.B", "variance.G", "variance.R"]);
    assert_eq!(a, b);
}

#[test]
fn a_part_carries_its_data_window_and_the_render_identity() {
    let dir = temp_dir("part");
    let out = dir.join("part.exr");
    // The index from an environment variable: region 1 of 3 of 25 rows is rows 8..16.
    let run = raylume()
        .arg("render")
        .args(FLAGS)
        .arg("2")
        .args(["--tile-from-env", "RAYLUME_TEST_TILE", "--tiles", "3", "-o"])
        .arg(&out)
        .env("RAYLUME_TEST_TILE", "1")
        .output()
        .unwrap();
    ok(&run);
    let image = exr::prelude::read_first_flat_layer_from_file(&out).unwrap();
    let layer = &image.layer_data;
    assert_eq!(image.attributes.display_window.size, exr::math::Vec2(40, 25));
    assert_eq!(layer.attributes.layer_position, exr::math::Vec2(0, 8));
    assert_eq!(layer.size, exr::math::Vec2(40, 8));
    let get = |k: &str| layer.attributes.other.get(&exr::prelude::Text::from(k)).cloned();
    let text = |k: &str| match get(k) {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => t.to_string(),
        other => panic!("{k}: {other:?}"),
    };
    assert_eq!(text("raylume.region"), "0 8 40 16");
    assert_eq!(text("raylume.tile"), "1/3");
    assert_eq!(text("raylume.seed"), "0");
    assert_eq!(text("raylume.scene_hash").len(), 16);
    for k in ["raylume.full_width", "raylume.full_height", "raylume.spp", "raylume.passes", "raylume.seconds"] {
        assert!(matches!(get(k), Some(exr::meta::attribute::AttributeValue::F64(_))), "{k}");
    }
    // The same region from --tile has the same pixels.
    let direct = dir.join("direct.exr");
    ok(&render(&["--tile", "1/3"], &direct));
    let again = exr::prelude::read_first_flat_layer_from_file(&direct).unwrap();
    assert_eq!(again.layer_data.channel_data, layer.channel_data);
}

#[test]
fn bad_tiles_exit_2_before_rendering() {
    let dir = temp_dir("tiles");
    let out = dir.join("part.exr");
    let cases: [(&[&str], &str); 6] = [
        (&["--tile", "3/3"], "--tile 3/3: region 3 of 3: expected I from 0 to 2"),
        (&["--tile", "0/0"], "N = 0"),
        (&["--tile", "two/3"], "--tile two/3: expected I/N"),
        (&["--tile", "0/26"], "26 regions of an image of 25 rows"),
        (&["--tile-from-env", "RAYLUME_TEST_TILE", "--tiles", "3"], "RAYLUME_TEST_TILE: the variable is not set"),
        (&["--tile", "0/2", "--crop", "0", "0", "4", "4"], "cannot be used with"),
    ];
    for (args, message) in cases {
        let run = render(args, &out);
        if message == "cannot be used with" {
            assert_eq!(run.status.code(), Some(2));
            assert!(String::from_utf8_lossy(&run.stderr).contains(message));
        } else {
            refused(&run, message);
        }
        assert!(!out.exists(), "{args:?}");
    }
    let bad_env = raylume()
        .arg("render")
        .args(["--tile-from-env", "RAYLUME_TEST_TILE", "--tiles", "3", "-o"])
        .arg(&out)
        .env("RAYLUME_TEST_TILE", "x1")
        .output()
        .unwrap();
    refused(&bad_env, "--tile-from-env RAYLUME_TEST_TILE: the value 'x1' is not a region index");
    let png = dir.join("part.png");
    refused(&render(&["--tile", "0/2"], &png), "part.png: a region is written as OpenEXR");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

#[test]
fn merge_refuses_bad_parts_naming_the_file() {
    let dir = temp_dir("refuse");
    let good = parts(&dir, 3, &[], "good");
    let out = dir.join("merged.pfm");
    let with = |i: usize, part: &Path| {
        let mut p = good.clone();
        p[i] = part.to_owned();
        p
    };
    let name = |p: &Path| p.display().to_string();

    // Another seed, other settings (depth), another scene size.
    let seed = parts(&dir, 3, &["--seed", "7"], "seed");
    refused(
        &merge(&out, &with(1, &seed[1])),
        &format!("{}: seed 7, but {} has seed 0", name(&seed[1]), name(&good[0])),
    );
    let depth = parts(&dir, 3, &["--depth", "2"], "depth");
    let run = merge(&out, &with(2, &depth[2]));
    refused(&run, &format!("{}: scene hash", name(&depth[2])));
    refused(&run, "parts of different scenes or settings");

    // Overlapping and missing regions.
    let half = parts(&dir, 2, &[], "half");
    refused(&merge(&out, &[good[0].clone(), half[1].clone(), good[1].clone()]), "overlaps");
    refused(&merge(&out, &[good[0].clone(), good[0].clone(), good[1].clone(), good[2].clone()]), "overlaps");
    refused(&merge(&out, &[good[0].clone(), good[2].clone()]), "do not cover rows 8-15 of the image's 25");

    // Truncated, not EXR, an EXR that is not a part, a missing file.
    let bytes = std::fs::read(&good[1]).unwrap();
    for keep in [bytes.len() - 1, bytes.len() / 2, 400, 10] {
        let cut = dir.join(format!("cut-{keep}.exr"));
        std::fs::write(&cut, &bytes[..keep]).unwrap();
        refused(&merge(&out, &with(1, &cut)), &name(&cut));
    }
    let pfm = dir.join("full.pfm");
    ok(&render(&[], &pfm));
    refused(&merge(&out, &with(0, &pfm)), &format!("{}: not an OpenEXR file", name(&pfm)));
    let plain = dir.join("plain.exr");
    ok(&render(&[], &plain));
    refused(&merge(&out, &with(0, &plain)), &format!("{}: no raylume.scene_hash attribute", name(&plain)));
    let absent = dir.join("absent.exr");
    refused(&merge(&out, &with(0, &absent)), &name(&absent));
    assert!(!out.exists(), "no output from a refused merge");
    ok(&merge(&out, &good));
    assert!(out.exists());
}

/// An output that is one of the parts, by the same path or another path to the same file, is
/// refused before anything is written: the part is left as it was.
#[test]
fn merge_refuses_an_output_that_is_one_of_the_parts() {
    let dir = temp_dir("self");
    let good = parts(&dir, 3, &[], "part");
    let before = std::fs::read(&good[0]).unwrap();
    let stderr = refused(&merge(&good[0], &good), "expected an output other than the parts");
    assert!(stderr.contains(&format!("{}: the output is also the part {}", good[0].display(), good[0].display())));
    // Relative paths: `part-0.exr` and `./part-0.exr`, and the folder named another way.
    let in_dir = |args: &[&str]| raylume().current_dir(&dir).arg("merge").args(args).output().unwrap();
    let run = in_dir(&["part-0.exr", "./part-1.exr", "part-0.exr", "part-2.exr"]);
    refused(&run, "part-0.exr: the output is also the part part-0.exr");
    let run = in_dir(&["./part-2.exr", "part-0.exr", "part-1.exr", "part-2.exr"]);
    refused(&run, "./part-2.exr: the output is also the part part-2.exr");
    let other = dir.join("..").join(dir.file_name().unwrap()).join("part-1.exr");
    refused(&merge(&other, &good), &format!("{}: the output is also the part {}", other.display(), good[1].display()));
    // Shares of the samples too.
    let shares: Vec<PathBuf> = ["0..2", "2..4"]
        .iter()
        .map(|range| {
            let out = dir.join(format!("share-{}.exr", &range[..1]));
            ok(&render(&["--samples", range], &out));
            out
        })
        .collect();
    let share = std::fs::read(&shares[1]).unwrap();
    refused(&merge(&shares[1], &shares), "expected an output other than the parts");
    assert_eq!(std::fs::read(&good[0]).unwrap(), before, "the part is unchanged");
    assert_eq!(std::fs::read(&shares[1]).unwrap(), share, "the share is unchanged");
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left.len(), 5, "nothing else written: {left:?}");
    ok(&merge(&dir.join("frame.exr"), &good));
}

/// Shares of the samples (`--samples A..B`, whole passes) merged in pass order equal the
/// one-machine render byte for byte; missing, overlapping and foreign shares,
/// and shares that are not whole passes, are refused.
#[test]
fn shares_of_the_samples_merge_into_the_one_machine_render() {
    let dir = temp_dir("shares");
    let flags = ["--spp", "16", "--width", "40", "--height", "25", "--quiet"];
    let share = |range: &str, out: &Path, threads: &str| {
        raylume()
            .arg("render")
            .args(flags)
            .args(["--threads", threads, "--samples", range, "-o"])
            .arg(out)
            .output()
            .unwrap()
    };
    let whole = dir.join("whole.exr");
    ok(&raylume().arg("render").args(flags).arg("-o").arg(&whole).output().unwrap());
    let (a, b, c) = (dir.join("a.exr"), dir.join("b.exr"), dir.join("c.exr"));
    ok(&share("0..4", &a, "1"));
    ok(&share("4..12", &b, "2"));
    ok(&share("12..16", &c, "3"));
    let merged = dir.join("merged.exr");
    ok(&merge(&merged, &[c.clone(), a.clone(), b.clone()]));
    let read = |p: &Path| raylume_integrator::Film::read(p).unwrap();
    assert_eq!(read(&merged), read(&whole), "the image, bit for bit");
    let (pfm_whole, pfm_merged) = (dir.join("whole.pfm"), dir.join("merged.pfm"));
    ok(&raylume().arg("render").args(flags).arg("-o").arg(&pfm_whole).output().unwrap());
    ok(&merge(&pfm_merged, &[a.clone(), b.clone(), c.clone()]));
    assert_eq!(std::fs::read(&pfm_merged).unwrap(), std::fs::read(&pfm_whole).unwrap(), "byte for byte");

    refused(&merge(&dir.join("x.pfm"), &[a.clone(), c.clone()]), "do not hold samples 4..12 (a part is missing)");
    refused(&merge(&dir.join("x.pfm"), &[a.clone(), a.clone(), b.clone(), c.clone()]), "overlaps another share");
    let other = dir.join("other.exr");
    ok(&raylume()
        .arg("render")
        .args(flags)
        .args(["--seed", "7", "--samples", "4..12", "-o"])
        .arg(&other)
        .output()
        .unwrap());
    refused(&merge(&dir.join("x.pfm"), &[a.clone(), other, c.clone()]), "a share of another render");
    refused(&share("0..6", &dir.join("y.exr"), "1"), "both multiples of 4 (the render is 4 passes of 4 samples)");
    refused(&share("0..4", &dir.join("y.png"), "1"), "is written as .exr");
    assert!(!dir.join("x.pfm").exists() && !dir.join("y.exr").exists());
}

fn signal(pid: u32, name: &str) {
    let status = Command::new("kill").arg(format!("-{name}")).arg(pid.to_string()).status().unwrap();
    assert!(status.success());
}

/// Runs `render` with `flags` and `--checkpoint state`, resuming from `state` while it exists,
/// sending SIGTERM (as a scheduler's time limit does) `after` into each run, until a run completes.
/// Returns how many runs the signal stopped.
fn render_with_stops(flags: &[&str], state: &Path, out: &Path, after: std::time::Duration) -> usize {
    let mut stops = 0;
    for _ in 0..30 {
        let mut cmd = raylume();
        cmd.arg("render").args(flags).arg("--checkpoint").arg(state).arg("-o").arg(out);
        if state.exists() {
            cmd.arg("--resume").arg(state);
        }
        let child = cmd.stderr(std::process::Stdio::piped()).spawn().unwrap();
        std::thread::sleep(after);
        signal(child.id(), "TERM");
        let run = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        match run.status.code() {
            Some(0) => {
                assert!(!state.exists(), "the state of a complete render is removed");
                return stops;
            }
            Some(3) => {
                assert!(stderr.contains("wrote the state") && state.exists(), "{stderr}");
                stops += 1;
            }
            // The signal came before the render began (while the scene loaded): nothing to keep.
            Some(130) => assert!(!stderr.contains("wrote"), "{stderr}"),
            code => panic!("exit {code:?}: {stderr}"),
        }
    }
    panic!("30 runs did not complete the render");
}

/// A task stopped by SIGTERM writes its state; resumed, however often it is stopped, it writes the
/// image of the task that never stopped, byte for byte: a whole frame, and a share of the samples.
#[test]
fn a_task_stopped_by_a_signal_resumes_to_the_image_it_would_have_made() {
    let dir = temp_dir("resume");
    let flags = ["--width", "320", "--height", "200", "--spp", "16", "--threads", "1", "--quiet"];
    let full = dir.join("full.pfm");
    let start = std::time::Instant::now();
    ok(&raylume().arg("render").args(flags).arg("-o").arg(&full).output().unwrap());
    let after = start.elapsed().mul_f64(0.4).max(std::time::Duration::from_millis(150));
    let state = dir.join("state.exr");
    let resumed = dir.join("resumed.pfm");
    let stops = render_with_stops(&flags, &state, &resumed, after);
    assert!(stops >= 1, "no run was stopped (a whole render takes {:?})", start.elapsed());
    assert_eq!(std::fs::read(&resumed).unwrap(), std::fs::read(&full).unwrap(), "{stops} stops");
    println!("the whole frame was stopped {stops} times and resumed");
    // A share of the samples keeps the images of its passes across stops.
    let mut shares = Vec::new();
    for (i, range) in ["0..4", "4..12", "12..16"].iter().enumerate() {
        let share = dir.join(format!("share-{i}.exr"));
        let mut f = flags.to_vec();
        f.extend(["--samples", range]);
        if *range == "4..12" {
            render_with_stops(&f, &state, &share, after.mul_f64(0.5));
        } else {
            ok(&raylume().arg("render").args(&f).arg("-o").arg(&share).output().unwrap());
        }
        shares.push(share);
    }
    let merged = dir.join("merged.pfm");
    ok(&merge(&merged, &shares));
    assert_eq!(std::fs::read(&merged).unwrap(), std::fs::read(&full).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_state_of_another_render_or_a_file_that_is_no_state_is_refused() {
    let dir = temp_dir("state");
    let state = dir.join("state.exr");
    let big = ["--width", "400", "--height", "250", "--spp", "64", "--threads", "1", "--quiet"];
    let resume = |extra: &[&str], state: &Path| {
        let out = dir.join("out.pfm");
        raylume().arg("render").args(big).args(extra).arg("--resume").arg(state).arg("-o").arg(out).output().unwrap()
    };
    refused(&resume(&[], &dir.join("none.exr")), "none.exr: No such file");
    let checkpoint = |extra: &[&str]| {
        raylume()
            .current_dir(&dir)
            .args(["render", "--width", "8", "--height", "5", "--quiet"])
            .args(extra)
            .output()
            .unwrap()
    };
    refused(
        &checkpoint(&["--checkpoint", "state.png", "-o", "x.png"]),
        "--checkpoint state.png: a state is written as .exr",
    );
    refused(&checkpoint(&["--checkpoint", "x.exr", "-o", "x.exr"]), "the state and the image need two files");
    refused(&checkpoint(&["--checkpoint", "s.exr", "--checkpoint-every=-1", "-o", "x.exr"]), "expected seconds >= 0");
    let image = dir.join("image.exr");
    ok(&render(&[], &image));
    refused(&resume(&[], &image), "image.exr: no raylume.next_pass attribute: not a state written by raylume render");
    let mut child = raylume()
        .arg("render")
        .args(big)
        .arg("--checkpoint")
        .arg(&state)
        .arg("-o")
        .arg(dir.join("big.pfm"))
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(400));
    signal(child.id(), "TERM");
    assert_eq!(child.wait().unwrap().code(), Some(3));
    refused(&resume(&["--seed", "7"], &state), "state.exr: the state of another render: its scene hash differs");
    refused(&resume(&["--crop", "0", "0", "40", "25"], &state), "state.exr: the state of another part of the render");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A task killed without a signal it can answer (SIGKILL: a lost node, an expired grace period)
/// resumes from the state `--checkpoint-every` wrote after its last pass, to the same image.
#[test]
fn a_killed_task_resumes_from_its_last_periodic_state() {
    let dir = temp_dir("killed");
    let flags = ["--width", "320", "--height", "200", "--spp", "16", "--threads", "1", "--quiet"];
    let full = dir.join("full.pfm");
    let start = std::time::Instant::now();
    ok(&raylume().arg("render").args(flags).arg("-o").arg(&full).output().unwrap());
    let whole = start.elapsed();
    let (state, out) = (dir.join("state.exr"), dir.join("out.pfm"));
    let mut kills_with_state = 0;
    for _ in 0..20 {
        let mut cmd = raylume();
        cmd.arg("render").args(flags).args(["--checkpoint-every", "0", "--checkpoint"]).arg(&state).arg("-o").arg(&out);
        if state.exists() {
            cmd.arg("--resume").arg(&state);
        }
        let mut child = cmd.stderr(std::process::Stdio::null()).spawn().unwrap();
        std::thread::sleep(whole.mul_f64(0.6));
        signal(child.id(), "KILL");
        let status = child.wait().unwrap();
        if status.success() {
            break;
        }
        kills_with_state += state.exists() as usize;
    }
    assert!(kills_with_state >= 1, "no kill left a state (a whole render takes {whole:?})");
    let mut cmd = raylume();
    cmd.arg("render").args(flags).arg("--checkpoint").arg(&state).arg("-o").arg(&out);
    if state.exists() {
        cmd.arg("--resume").arg(&state);
    }
    ok(&cmd.output().unwrap());
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&full).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}
