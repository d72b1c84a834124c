//! Inputs the fuzzer found (tests/fuzz-regressions/, named `<target>-<name>.<ext>`): each is fed
//! to the same call as its fuzz target (fuzz/fuzz_targets/), which must return, Ok or Err, without
//! panicking; for `p3f`, a scene that loads must also come back equal through `Scene::to_p3f`.

use std::path::{Path, PathBuf};

use raylume_scene::p3f::{LoadOptions, parse, parse_bytes};

/// The regression inputs of `target`, sorted.
fn inputs(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
    let prefix = format!("{target}-");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("a directory entry").path())
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with(&prefix)))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| (p.clone(), std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))))
        .collect()
}

/// Runs `check` on every input of `target`; fails naming each input that panicked.
fn each_input(target: &str, check: impl Fn(&[u8]) + std::panic::RefUnwindSafe) {
    let mut panicked = Vec::new();
    for (path, data) in inputs(target) {
        if std::panic::catch_unwind(|| check(&data)).is_err() {
            panicked.push(path.display().to_string());
        }
    }
    assert!(panicked.is_empty(), "these inputs panicked: {panicked:#?}");
}

#[test]
fn p3f_inputs_load_or_fail_and_round_trip() {
    each_input("p3f", |data| {
        let strict = LoadOptions { strict: true, ..Default::default() };
        let _ = parse_bytes(data, "fuzz.p3f", &strict);
        let Ok(loaded) = parse_bytes(data, "fuzz.p3f", &LoadOptions::default()) else { return };
        let text = loaded.scene.to_p3f();
        let options = LoadOptions { base_dir: loaded.scene.base_dir.clone(), ..Default::default() };
        let again = parse(&text, "again.p3f", &options)
            .unwrap_or_else(|e| panic!("to_p3f wrote text that does not parse: {e}\n--- to_p3f ---\n{text}"));
        assert_eq!(loaded.scene, again.scene, "the scene read back from to_p3f differs\n--- to_p3f ---\n{text}");
    });
}

#[test]
fn obj_inputs_load_or_fail() {
    each_input("obj", |data| {
        let _ = raylume_scene::obj::parse(data, "fuzz.obj");
    });
}

#[test]
fn image_inputs_decode_or_fail() {
    use raylume_integrator::{Film, ImageFormat};
    each_input("image", |data| {
        for format in [ImageFormat::Pfm, ImageFormat::Exr, ImageFormat::Png] {
            let _ = Film::decode(data, format);
        }
    });
}
