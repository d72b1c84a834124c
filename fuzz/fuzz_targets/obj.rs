//! The OBJ reader on arbitrary bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = raylume_scene::obj::parse(data, "fuzz.obj");
});
