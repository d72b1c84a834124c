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

/// An estimate of the memory a render of `primitives` primitives at `pixels` pixels takes at its
/// peak: the primitives and their shading, the accelerator's nodes and references, and the image
/// with its accumulation, its error estimate and its encoded copy.
///
/// ```
/// assert_eq!(raylume_render::limits::render_bytes(1, 1), 192 + 64);
/// ```
pub fn render_bytes(primitives: u64, pixels: u64) -> u64 {
    primitives.saturating_mul(192).saturating_add(pixels.saturating_mul(64))
}

/// What a process takes besides a render's own buffers: its code, threads and allocator.
pub const PROCESS_BYTES: u64 = 128 << 20;

/// The most memory a render may plan to take here, and what sets it: [`MAX_RENDER_BYTES`], or less
/// where the process may not take that much (on Linux, its address-space limit, `ulimit -v`, or the
/// machine's memory), less [`PROCESS_BYTES`].
pub fn render_bytes_allowed() -> (u64, &'static str) {
    let mut allowed = (MAX_RENDER_BYTES, "allowed");
    let limits = [
        (address_space_limit(), "the process's address-space limit (ulimit -v) leaves"),
        (physical_memory(), "the machine's memory leaves"),
    ];
    for (limit, what) in limits {
        if let Some(bytes) = limit.map(|b| b.saturating_sub(PROCESS_BYTES))
            && bytes < allowed.0
        {
            allowed = (bytes, what);
        }
    }
    allowed
}

/// The soft limit on the process's address space (`ulimit -v`), where one is set and readable.
fn address_space_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

/// The machine's memory, where it is readable.
fn physical_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line["MemTotal:".len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
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
