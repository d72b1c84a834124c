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
//! let out = scene.render(&RenderOptions::default(), &())?;
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

/// What an embedder needs: scenes (loaded from p3f or OBJ files, built in code), rendering them
/// with progress, cancellation and progressive passes, the image and its files, and the metrics
/// that compare images.
///
/// ```
/// // Everything an embedding program names comes from here.
/// use raylume::prelude::{
///     CancelToken, Film, Grid, LoadOptions, OutputError, Progress, RenderScene, SamplerKind, Shape, Triangle, Warning,
///     metrics, obj, p3f,
/// };
/// let _: fn(&Film, &Film) -> Option<f64> = |a, b| metrics::rmse(&a.channels(), &b.channels());
/// let _ = (obj::Transform::default(), SamplerKind::Sobol, LoadOptions::default(), CancelToken::new());
/// let _: Option<(&Progress, &Shape, &Triangle, &Grid<raylume::prelude::Primitive>, &Warning, &OutputError)> = None;
/// let _ = p3f::parse(raylume::prelude::DEFAULT_SCENE, "d", &LoadOptions::default()).unwrap().scene.primitives();
/// ```
pub mod prelude {
    pub use raylume_accel::{AccelKind, Accelerator, BruteForce, Bvh, Grid, GridParams};
    pub use raylume_camera::{Camera, CameraSample, Pinhole, ThinLens, View};
    pub use raylume_geometry::{Aabb, Interval, Ray, Triangle, Vec2, Vec3, Vec3A};
    pub use raylume_integrator::{
        CancelToken, Film, ImageFormat, InputError, Observer, OutputError, RayStats, RenderSettings, metrics, render,
    };
    pub use raylume_intersect::{Hit, Intersect, Primitive};
    pub use raylume_material::{FresnelMode, Material, Phong};
    pub use raylume_render::{Features, Progress, RenderOptions, RenderOutput, RenderScene, SamplerKind};
    pub use raylume_scene::p3f::LoadOptions;
    pub use raylume_scene::{
        AccelHint, DEFAULT_SCENE, Light, LightShape, Scene, SceneBuilder, SceneError, Shape, Warning, obj, p3f,
    };
}

/// The README's Rust examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
