//! Every limit raylume puts on what it is asked to do, in one place: the scene's
//! ([`raylume_scene::limits`]), the render loop's ([`raylume_integrator::MAX_DEPTH`] and the
//! others) and those of rendering a scene (threads, memory, grid density). Each is checked before
//! any work starts and refused with a message that names the value and the limit.

pub use raylume_integrator::{MAX_DEPTH, MAX_IMAGE_PIXELS, MAX_LIGHT_GRID, MAX_SPP};
pub use raylume_scene::limits::{MAX_FILE_BYTES, MAX_OBJ_BYTES, MAX_PIXELS, MAX_RESOLUTION};

/// Most worker threads.
pub const MAX_THREADS: usize = 1024;
/// Largest uniform-grid density (cells per primitive).
pub const MAX_GRID_K: f32 = raylume_accel::GridParams::MAX_K;
/// Most memory a render may plan to take for its primitives, accelerator and image, in bytes.
pub const MAX_RENDER_BYTES: u64 = 16 << 30;

/// An estimate of the memory a render of `primitives` primitives at `pixels` pixels takes: the
/// primitives and their shading, the accelerator's nodes and references, and the image with its
/// accumulation.
///
/// ```
/// assert_eq!(raylume_render::limits::render_bytes(1, 1), 192 + 32);
/// ```
pub fn render_bytes(primitives: u64, pixels: u64) -> u64 {
    primitives.saturating_mul(192).saturating_add(pixels.saturating_mul(32))
}

#[cfg(test)]
mod tests {
    /// A scene may ask for what the render loop takes, and no more.
    #[test]
    fn the_scene_limits_are_the_render_loops() {
        assert_eq!(raylume_scene::limits::MAX_SPP, super::MAX_SPP);
        assert_eq!(raylume_scene::limits::MAX_LIGHT_GRID, super::MAX_LIGHT_GRID);
        assert_eq!(raylume_scene::limits::MAX_PIXELS, super::MAX_IMAGE_PIXELS);
    }
}
