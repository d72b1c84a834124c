//! The p3f reader on arbitrary bytes, lenient and strict, with a round-trip oracle: a scene that
//! loads is written back with `Scene::to_p3f`, which must parse again to an equal scene.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raylume_scene::p3f::{LoadOptions, parse, parse_bytes};

fuzz_target!(|data: &[u8]| {
    let strict = LoadOptions { strict: true, ..Default::default() };
    let _ = parse_bytes(data, "fuzz.p3f", &strict);
    let Ok(loaded) = parse_bytes(data, "fuzz.p3f", &LoadOptions::default()) else { return };
    let text = loaded.scene.to_p3f();
    let options = LoadOptions { base_dir: loaded.scene.base_dir.clone(), ..Default::default() };
    let again = match parse(&text, "again.p3f", &options) {
        Ok(again) => again,
        Err(e) => panic!("to_p3f wrote text that does not parse: {e}\n--- to_p3f ---\n{text}"),
    };
    assert_eq!(loaded.scene, again.scene, "the scene read back from to_p3f differs\n--- to_p3f ---\n{text}");
});
