//! The image readers (PFM, OpenEXR, PNG) on arbitrary bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raylume_integrator::{Film, ImageFormat};

fuzz_target!(|data: &[u8]| {
    for format in [ImageFormat::Pfm, ImageFormat::Exr, ImageFormat::Png] {
        let _ = Film::decode(data, format);
    }
});
