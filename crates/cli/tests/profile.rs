//! The course profile against the course's reference renders, and the plain profile as the plain render.
//!
//! Needs the course's material in `../shared` beside the project (scenes and `refimages`); without it
//! the test says so and passes.

use std::path::{Path, PathBuf};
use std::process::Command;

fn raylume() -> Command {
    Command::new(env!("CARGO_BIN_EXE_raylume"))
}

fn shared() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    (dir.join("refimages").is_dir() && dir.join("scenes").is_dir()).then_some(dir)
}

fn render(scene: &Path, out: &Path, extra: &[&str]) {
    let run = raylume()
        .arg("render")
        .arg(scene)
        .args(["--no-env", "--width", "512", "--height", "512", "--spp", "1", "-o"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
}

fn rmse(a: &Path, b: &Path) -> f64 {
    let run = raylume().arg("compare").arg(a).arg(b).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let out = String::from_utf8_lossy(&run.stdout);
    out.split_whitespace().nth(1).and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("bad compare output {out}"))
}

#[test]
fn course_profile_reproduces_the_reference_renders_and_plain_stays_plain() {
    let Some(shared) = shared() else {
        eprintln!("skipped: the course's material (../shared/scenes, ../shared/refimages) is absent");
        return;
    };
    let dir = std::env::temp_dir().join(format!("raylume-profile-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // Scene, reference, bound with the course profile, lower bound of the plain render's distance.
    let cases = [
        ("balls_low_tris", "balls_low", 0.0035, 0.03),
        ("balls_medium", "balls_medium", 0.0065, 0.03),
        ("balls_box", "balls_box", 0.0175, 0.045),
        ("mount_low", "mount_low", 0.0030, 0.045),
    ];
    for (scene, reference, bound, plain_floor) in cases {
        let scene_path = shared.join("scenes").join(format!("{scene}.p3f"));
        let reference = shared.join("refimages").join(format!("{reference}.png"));
        let (course, plain, default) = (
            dir.join(format!("{scene}-course.png")),
            dir.join(format!("{scene}-plain.png")),
            dir.join(format!("{scene}.png")),
        );
        render(&scene_path, &course, &["--profile", "course"]);
        render(&scene_path, &plain, &["--profile", "plain"]);
        render(&scene_path, &default, &[]);
        let e = rmse(&course, &reference);
        eprintln!("{scene}: course profile rmse {e:.6}");
        assert!(e <= bound, "{scene}: course profile rmse {e} > {bound}");
        // The plain profile is the default render, bit for bit, and still the plain model.
        assert_eq!(rmse(&plain, &default), 0.0, "{scene}: --profile plain differs from the default render");
        assert_eq!(std::fs::read(&plain).unwrap(), std::fs::read(&default).unwrap());
        let p = rmse(&plain, &reference);
        assert!(p > plain_floor, "{scene}: plain rmse {p} unexpectedly close to the reference");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
