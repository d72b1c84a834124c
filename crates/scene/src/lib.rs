//! Scenes for raylume: the [`Scene`] model, the p3f loader ([`p3f::parse`], [`p3f::load`]) and writer
//! ([`Scene::to_p3f`]), a [`SceneBuilder`] for scenes made in code, and [`Scene::render`], which builds
//! the accelerator, camera and integrator a scene needs and renders it.
//!
//! ```
//! use raylume_scene::{p3f, SceneBuilder};
//! use raylume_geometry::{Vec3, Vec3A};
//! let scene = SceneBuilder::new()
//!     .camera(Vec3A::new(0.0, 0.0, 5.0), Vec3A::ZERO, Vec3A::Y, 45.0, 32, 32)
//!     .light(Vec3A::new(0.0, 5.0, 5.0), Vec3::ONE)
//!     .material(raylume_material::Phong::default())
//!     .sphere(Vec3A::ZERO, 1.0)
//!     .build()
//!     .unwrap();
//! // Written to p3f and read back, it is the same scene.
//! let text = scene.to_p3f();
//! let again = p3f::parse(&text, "roundtrip.p3f", &p3f::LoadOptions::default()).unwrap();
//! assert_eq!(again.scene, scene);
//! ```

mod builder;
mod env;
mod error;
pub mod limits;
mod model;
pub mod obj;
pub mod p3f;
mod polygon;
pub mod procedural;
pub mod rays;
mod render;
mod writer;

pub use builder::SceneBuilder;
pub use env::{find_cubemap, load_cubemap};
pub use error::{SceneError, Warning};
pub use model::{Light, LightShape, Object, Scene, Shape};
pub use polygon::triangulate;
pub use render::{Features, Primitives, Progress, RenderOptions, RenderOutput, SamplerKind};

/// The embedded default scene (p3f text), rendered when the CLI is given no scene.
pub const DEFAULT_SCENE: &str = include_str!("default.p3f");
