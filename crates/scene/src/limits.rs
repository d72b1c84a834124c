//! Every limit raylume puts on what it is asked to do, in one place: the same for scene files, the
//! command line's flags and scenes built in code. Each is checked before any work starts and
//! refused with a message that names the value and the limit.

pub use raylume_integrator::{MAX_DEPTH, MAX_IMAGE_PIXELS, MAX_LIGHT_GRID, MAX_SPP};

/// Largest image side, in pixels.
pub const MAX_RESOLUTION: u32 = 16_384;
/// Largest image, in pixels.
pub const MAX_PIXELS: u64 = 1 << 27;
/// Largest scene file read, in bytes.
pub const MAX_FILE_BYTES: u64 = 1 << 32;
/// Largest OBJ file read, in bytes.
pub const MAX_OBJ_BYTES: u64 = 1 << 32;
/// Most worker threads.
pub const MAX_THREADS: usize = 1024;
/// Largest uniform-grid density (cells per primitive).
pub const MAX_GRID_K: f32 = 1000.0;
/// Most memory a render may plan to take for its primitives, accelerator and image, in bytes.
pub const MAX_RENDER_BYTES: u64 = 16 << 30;

/// An estimate of the memory a render of `primitives` primitives at `pixels` pixels takes: the
/// primitives and their shading, the accelerator's nodes and references, and the image with its
/// accumulation.
pub fn render_bytes(primitives: u64, pixels: u64) -> u64 {
    primitives.saturating_mul(192).saturating_add(pixels.saturating_mul(32))
}
