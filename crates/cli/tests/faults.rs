//! Faults while writing: a signal at any moment, a full disk, a read-only folder, a folder that
//! refuses new files, a process allowed too little memory. Each leaves either the previous file or
//! the complete new one, and nothing else, with a clear message and exit code.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn raylume() -> Command {
    Command::new(env!("CARGO_BIN_EXE_raylume"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("raylume-faults-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The files in `dir` other than `keep`.
fn others(dir: &Path, keep: &[&str]) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !keep.contains(&n.as_str()))
        .collect()
}

/// A scene with nothing but its background: rendering is quick, writing its large PFM is not.
fn background_scene(dir: &Path, side: u32) -> PathBuf {
    let scene = dir.join("empty.p3f");
    std::fs::write(
        &scene,
        format!("bclr 0.2 0.3 0.4\nv from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution {side} {side}\n"),
    )
    .unwrap();
    scene
}

fn signal(pid: u32, name: &str) {
    let status = Command::new("kill").arg(format!("-{name}")).arg(pid.to_string()).status().unwrap();
    assert!(status.success());
}

#[test]
fn a_signal_at_any_moment_leaves_the_previous_file_or_the_complete_new_one() {
    let dir = temp_dir("signal");
    let side = 2000;
    let scene = background_scene(&dir, side);
    let out = dir.join("out.pfm");
    let complete = ("PF\n2000 2000\n-1.0\n".len() + 2000 * 2000 * 12) as u64;
    // How long a whole run takes here, to spread the signals over it.
    let start = Instant::now();
    assert!(raylume().arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap().status.success());
    let whole = start.elapsed();
    assert_eq!(std::fs::metadata(&out).unwrap().len(), complete);
    let previous = std::fs::read(&out).unwrap();
    let mut interrupted = 0;
    for (i, sig) in ["INT", "TERM", "INT", "TERM", "INT", "TERM", "INT", "TERM", "INT", "TERM"].iter().enumerate() {
        let at = whole.mul_f64(0.3 + 0.08 * i as f64);
        let mut child = raylume()
            .args(["render", "--seed", &(i + 1).to_string()])
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(at);
        signal(child.id(), sig);
        let status = child.wait().unwrap();
        // During the render a signal ends it at the end of its pass and the image so far is written
        // (3); during the write, the process ends at once and writes nothing (130).
        if matches!(status.code(), Some(130 | 3)) {
            interrupted += 1;
        } else {
            assert!(status.success(), "SIG{sig} after {at:?}: {status:?}");
        }
        assert_eq!(others(&dir, &["empty.p3f", "out.pfm"]), Vec::<String>::new(), "SIG{sig} after {at:?}");
        // The background is the same for every seed: the file is the previous one or an equal new one.
        assert_eq!(std::fs::metadata(&out).unwrap().len(), complete, "SIG{sig} after {at:?}");
        assert!(std::fs::read(&out).unwrap() == previous);
    }
    println!("{interrupted} of 10 runs were interrupted (a whole run takes {whole:?})");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A small file system of our own (root only), or a printed reason to skip.
struct Mounted(PathBuf);

impl Mounted {
    fn tmpfs(dir: &Path, options: &str) -> Option<Self> {
        let ok = Command::new("mount").args(["-t", "tmpfs", "-o", options, "tmpfs"]).arg(dir).output();
        match ok {
            Ok(o) if o.status.success() => Some(Self(dir.to_owned())),
            Ok(o) => {
                println!("skipped: cannot mount a tmpfs here ({})", String::from_utf8_lossy(&o.stderr).trim());
                None
            }
            Err(e) => {
                println!("skipped: no mount command ({e})");
                None
            }
        }
    }
}

impl Drop for Mounted {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_disk_exits_1_keeps_the_previous_file_and_leaves_nothing_else() {
    let dir = temp_dir("full");
    let scene = background_scene(&dir, 8);
    let disk = dir.join("disk");
    std::fs::create_dir_all(&disk).unwrap();
    let Some(_mounted) = Mounted::tmpfs(&disk, "size=64k") else { return };
    let out = disk.join("out.pfm");
    assert!(raylume().arg("render").arg(&scene).arg("-o").arg(&out).output().unwrap().status.success());
    let previous = std::fs::read(&out).unwrap();
    // 200 x 200 pixels of 12 bytes do not fit in 64 KiB.
    let run = raylume().args(["render", "--width", "200", "--height", "200"]).arg(&scene).arg("-o").arg(&out).output();
    let run = run.unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("out.pfm") && stderr.contains("No space left on device"), "{stderr}");
    assert_eq!(std::fs::read(&out).unwrap(), previous);
    assert_eq!(others(&disk, &["out.pfm"]), Vec::<String>::new());
}

#[test]
fn a_read_only_folder_exits_1_before_rendering() {
    let dir = temp_dir("readonly");
    let scene = background_scene(&dir, 8);
    let ro = dir.join("ro");
    std::fs::create_dir_all(&ro).unwrap();
    let Some(_mounted) = Mounted::tmpfs(&ro, "ro,size=64k") else { return };
    let run = raylume().arg("render").arg(&scene).arg("-o").arg(ro.join("out.png")).output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("cannot write into") && stderr.contains("Read-only file system"), "{stderr}");
    assert!(!stderr.contains("rays (camera"), "refused before the render: {stderr}");
    assert_eq!(others(&ro, &[]), Vec::<String>::new());
}

#[test]
fn a_folder_that_refuses_new_files_exits_1_before_rendering() {
    // sysfs refuses new files even to root.
    if !Path::new("/sys/kernel").is_dir() {
        println!("skipped: no /sys here");
        return;
    }
    let dir = temp_dir("denied");
    let scene = background_scene(&dir, 8);
    let run = raylume().arg("render").arg(&scene).arg("-o").arg("/sys/kernel/raylume-out.png").output().unwrap();
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("cannot write into '/sys/kernel'"), "{stderr}");
    assert!(!Path::new("/sys/kernel/raylume-out.png").exists());
}

#[test]
fn an_interrupted_render_before_the_write_leaves_nothing() {
    let dir = temp_dir("early");
    let scene = background_scene(&dir, 1500);
    let out = dir.join("out.exr");
    let mut child = raylume().arg("render").arg(&scene).arg("-o").arg(&out).spawn().unwrap();
    std::thread::sleep(Duration::from_millis(30));
    signal(child.id(), "INT");
    let status = child.wait().unwrap();
    assert!(matches!(status.code(), Some(130 | 3)) || status.success(), "{status:?}");
    assert_eq!(others(&dir, &["empty.p3f", "out.exr"]), Vec::<String>::new());
}

/// A long render of many passes: the first signal ends it at the end of the current pass, writes
/// the image of the passes done and exits 3; a second signal ends it at once, writing nothing.
#[test]
fn a_signal_stops_a_render_at_the_end_of_a_pass_and_a_second_stops_it_at_once() {
    let dir = temp_dir("passes");
    let out = dir.join("out.exr");
    let long = ["render", "--width", "160", "--height", "100", "--spp", "4096", "--passes", "4096", "-o"];
    let child = raylume().args(long).arg(&out).stderr(std::process::Stdio::piped()).spawn().unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let asked = Instant::now();
    signal(child.id(), "TERM");
    let run = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(3), "{stderr}");
    assert!(asked.elapsed() < Duration::from_secs(20), "it stopped at the end of a pass, not of the render");
    assert!(stderr.contains("stopped by a signal: wrote the image of"), "{stderr}");
    let passes: u32 = stderr.split("wrote the image of ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!((1..4096).contains(&passes), "{stderr}");
    assert!(stderr.contains(&format!("over {passes} passes")), "the summary gives the estimate: {stderr}");
    let film = raylume_integrator::Film::read(&out).unwrap();
    assert_eq!((film.width(), film.height()), (160, 100));
    assert!(film.pixels().iter().all(|p| p.is_finite()) && film.pixels().iter().any(|p| p.x > 0.0));

    // Passes long enough that the second signal comes within the pass the first one ends.
    let again = dir.join("again.exr");
    let slow = ["render", "--width", "1280", "--height", "800", "--spp", "4096", "--passes", "4096", "-o"];
    let child = raylume().args(slow).arg(&again).stderr(std::process::Stdio::piped()).spawn().unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    signal(child.id(), "INT");
    std::thread::sleep(Duration::from_millis(20));
    signal(child.id(), "INT");
    let run = child.wait_with_output().unwrap();
    assert_eq!(run.status.code(), Some(130), "{}", String::from_utf8_lossy(&run.stderr));
    assert_eq!(others(&dir, &["out.exr"]), Vec::<String>::new(), "nothing written by the second run");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A render larger than the process may take (`ulimit -v`) is refused before it starts, with the
/// memory it would take and the limit, where the same render with room enough runs.
#[test]
fn a_render_larger_than_the_address_space_limit_is_refused_before_it_starts() {
    if !Path::new("/proc/self/limits").exists() {
        println!("skipped: no /proc/self/limits to read the address-space limit from");
        return;
    }
    let dir = temp_dir("ulimit");
    let scene = background_scene(&dir, 8);
    let out = dir.join("out.png");
    let under_limit = |kib: u64, crop: &[&str]| {
        let script = "ulimit -v \"$1\" && shift && exec \"$@\"";
        let mut command = Command::new("sh");
        command.args(["-c", script, "sh", &kib.to_string(), env!("CARGO_BIN_EXE_raylume"), "render"]).arg(&scene);
        command.args(["--width", "4096", "--height", "4096", "-o"]).arg(&out).args(crop);
        command.output().unwrap()
    };
    // A crop needs the memory of its own pixels only: a farm's region of an image too large for one
    // machine renders.
    let run = under_limit(700 * 1024, &["--crop", "0", "0", "4096", "1024"]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    std::fs::remove_file(&out).unwrap();
    let run = under_limit(700 * 1024, &[]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("4096 x 4096 pixels") && stderr.contains("address-space limit"), "{stderr}");
    assert!(!stderr.contains("rays (camera"), "refused before the render: {stderr}");
    assert_eq!(others(&dir, &["empty.p3f"]), Vec::<String>::new());
    let run = under_limit(3 * 1024 * 1024, &[]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(out.exists());
}
