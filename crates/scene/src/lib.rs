//! Scene descriptions for raylume: the [`Scene`] model, the loader of p3f and its dialects
//! ([`p3f::parse`], [`p3f::load`]), Wavefront OBJ meshes ([`obj`]), the p3f writer
//! ([`Scene::to_p3f`]), a [`SceneBuilder`] for scenes made in code, the Standard Procedural
//! Databases scenes ([`procedural`]) and the [`limits`] every scene meets.
//!
//! This crate describes scenes and renders nothing: it depends on the geometry, camera and material
//! crates only, so a program that reads or writes p3f builds no accelerator, render loop or image
//! codec. Rendering a [`Scene`] is `raylume-render`'s job.
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
mod cubemap;
mod error;
pub mod limits;
mod model;
pub mod obj;
pub mod p3f;
mod polygon;
pub mod procedural;
pub mod rays;
mod writer;

pub use builder::SceneBuilder;
pub use cubemap::{CUBEMAP_FACES, cubemap_faces, find_cubemap};
pub use error::{SceneError, Warning};
pub use model::{AccelHint, Object, Scene, Shape};
pub use polygon::triangulate;
pub use raylume_material::{Light, LightShape};

/// The embedded default scene (p3f text), rendered when the CLI is given no scene.
pub const DEFAULT_SCENE: &str = include_str!("default.p3f");
