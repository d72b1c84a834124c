//! raylume: a ray tracing library — Whitted and distribution ray tracing of p3f scenes and of
//! scenes built in Rust.
//!
//! This facade re-exports the workspace's crates; `use raylume::prelude::*` brings what an embedder
//! needs.
//!
//! ```
//! use raylume::prelude::*;
//!
//! let scene = SceneBuilder::new()
//!     .camera(Vec3A::new(0.0, 1.0, 5.0), Vec3A::ZERO, Vec3A::Y, 40.0, 32, 24)
//!     .light(Vec3A::new(3.0, 5.0, 4.0), Vec3::ONE)
//!     .material(Phong { diffuse: Vec3::new(0.9, 0.3, 0.2), kd: 0.9, ..Phong::default() })
//!     .sphere(Vec3A::ZERO, 1.0)
//!     .build()?;
//! let out = scene.render(&RenderOptions::default(), &|| {})?;
//! assert_eq!((out.film.width(), out.film.height()), (32, 24));
//! # Ok::<(), SceneError>(())
//! ```

pub use raylume_accel as accel;
pub use raylume_camera as camera;
pub use raylume_geometry as geometry;
pub use raylume_integrator as integrator;
pub use raylume_integrator::metrics;
pub use raylume_intersect as intersect;
pub use raylume_material as material;
pub use raylume_render as render;
pub use raylume_scene as scene;

/// What an embedder needs: scenes, their loader and builder, rendering and its output.
pub mod prelude {
    pub use raylume_accel::{AccelKind, Accelerator, BruteForce, Bvh};
    pub use raylume_camera::{Camera, CameraSample, Pinhole, ThinLens, View};
    pub use raylume_geometry::{Aabb, Interval, Ray, Vec2, Vec3, Vec3A};
    pub use raylume_integrator::{Film, RayStats, RenderSettings, render};
    pub use raylume_intersect::{Hit, Intersect, Primitive};
    pub use raylume_material::{FresnelMode, Material, Phong};
    pub use raylume_render::{RenderOptions, RenderOutput, RenderScene};
    pub use raylume_scene::{Scene, SceneBuilder, SceneError, p3f};
}
