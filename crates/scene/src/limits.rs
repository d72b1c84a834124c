//! The limits on what a scene may ask for, the same for scene files and scenes built in code. Each
//! is checked before any work starts and refused with a message that names the value and the
//! limit. `raylume_render::limits` adds the limits of rendering (threads, memory, grid density).

/// Largest image side, in pixels.
pub const MAX_RESOLUTION: u32 = 16_384;
/// Largest image, in pixels.
pub const MAX_PIXELS: u64 = 1 << 27;
/// Largest coordinate (and sphere radius) a scene file may give, in magnitude: within it, the square
/// of any distance in the scene (at most `2√3` times it) stays finite in single precision; beyond,
/// squared distances overflow and shapes would vanish from the image.
pub const MAX_COORDINATE: f32 = 4e18;
/// Largest scene file read, in bytes.
pub const MAX_FILE_BYTES: u64 = 1 << 32;
/// Largest OBJ file read, in bytes.
pub const MAX_OBJ_BYTES: u64 = 1 << 32;
/// Most samples per pixel a scene's `spp` may ask for (the render loop's own limit,
/// `raylume_integrator::MAX_SPP`, is the same).
pub const MAX_SPP: u32 = 1 << 16;
/// Largest side of the grid of point lights that stands for an area light (the render loop's
/// `raylume_integrator::MAX_LIGHT_GRID`).
pub const MAX_LIGHT_GRID: u32 = 64;
