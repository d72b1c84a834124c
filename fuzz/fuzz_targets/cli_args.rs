//! The command line's checks on arbitrary arguments: the input split at NUL bytes, each part one
//! argument (not necessarily UTF-8).
#![no_main]

use std::ffi::OsStr;
use std::os::unix::ffi::OsStrExt;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let args: Vec<&OsStr> = data.split(|&b| b == 0).map(OsStr::from_bytes).collect();
    let _ = raylume_cli::check_arguments(&args);
});
