//! Render assembly for raylume: turns a [`Scene`](raylume_scene::Scene) description into what the render loop needs (the
//! primitives behind an accelerator, the camera, the sampler, the integrator, the cubemap decoded
//! from its images) and runs it. [`RenderScene`] adds the rendering methods to [`Scene`](raylume_scene::Scene).
//!
//! The crates form a graph that only points down: `raylume-geometry` at the bottom; `intersect`,
//! `camera` and `material` on it; `accel` on `intersect`; `integrator` (the render loop, the film
//! and image files) on those; `raylume-scene` (the description: model, loaders, writer, builder)
//! on `geometry`, `camera` and `material` only; and this crate on both `integrator` and `scene`,
//! the one place where a description meets the machinery. Image decoding stays at or above the
//! integrator: the cubemap's faces are decoded here, not in the scene crate, so reading a p3f
//! file builds no image codec, accelerator or render loop.
//!
//! ```
//! use raylume_render::{RenderOptions, RenderScene};
//! use raylume_scene::{p3f, DEFAULT_SCENE};
//! let scene = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
//! let options = RenderOptions { resolution: Some((32, 20)), ..RenderOptions::default() };
//! let out = scene.render(&options, &|| {}).unwrap();
//! assert_eq!((out.film.width(), out.film.height()), (32, 20));
//! ```

use std::ops::ControlFlow;

use raylume_accel::AccelKind;
use raylume_scene::SceneError;

mod assemble;
mod env;
pub mod limits;
mod options;

pub use assemble::{Primitives, Progress};
pub use env::load_cubemap;
pub use options::{Features, RenderOptions, RenderOutput, SamplerKind};

/// Rendering a [`Scene`](raylume_scene::Scene): the methods are [`Scene`](raylume_scene::Scene)'s once the trait is in scope (it is in
/// `raylume::prelude`).
pub trait RenderScene {
    /// The primitives the scene's objects make (polygons as triangle fans, meshes as triangles).
    fn primitives(&self) -> Primitives;

    /// The accelerator `options` ask for, else the scene's hint, else the BVH.
    fn accel_kind(&self, options: &RenderOptions) -> AccelKind;

    /// Checks that rendering with `options` can start: the scene ([`Scene::validate`](raylume_scene::Scene::validate)), the
    /// settings and overrides against the [`limits`], the crop inside the image, and the memory the
    /// render would take. [`RenderScene::render`] does the same before any work.
    fn check(&self, options: &RenderOptions) -> Result<(), SceneError>;

    /// What rendering with `options` uses.
    fn features(&self, options: &RenderOptions) -> Result<Features, SceneError>;

    /// The samples per pixel a render with `options` takes (before the sampler rounds them).
    fn samples_per_pixel(&self, options: &RenderOptions) -> Result<u32, SceneError>;

    /// Renders the scene. `on_row` is called once per finished image row.
    ///
    /// The effects the scene and options use ([`RenderScene::features`]) choose one of a small set of
    /// monomorphised render loops (camera, sampler and soft-shadow mode are type parameters), so
    /// the work of an unused effect is absent from the loop rather than skipped per ray.
    fn render(&self, options: &RenderOptions, on_row: &(dyn Fn() + Sync)) -> Result<RenderOutput, SceneError>;

    /// Renders progressively: one pass per entry of `passes` (samples per pixel), each with its own
    /// seed, accumulated into one image weighted by samples. After each pass `on_pass` gets the image so
    /// far and the time spent; it returns [`ControlFlow::Break`] to stop there (a time budget). The
    /// passes always sample the pixel area (antialiasing on), so every pass estimates the same image.
    ///
    /// ```
    /// use std::ops::ControlFlow;
    /// use raylume_render::{RenderOptions, RenderScene};
    /// use raylume_scene::{p3f, DEFAULT_SCENE};
    /// let scene = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
    /// let options = RenderOptions { resolution: Some((16, 10)), ..RenderOptions::default() };
    /// let mut seen = Vec::new();
    /// let out = scene.render_progressive(&options, &[1, 3, 4, 8], &mut |p| {
    ///     seen.push(p.samples_per_pixel);
    ///     if p.samples_per_pixel >= 8 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    /// }).unwrap();
    /// assert_eq!(seen, [1, 5, 9]); // 3 and 8 round up to 4 and 9 jittered samples
    /// assert_eq!(out.film.width(), 16);
    /// ```
    fn render_progressive(
        &self,
        options: &RenderOptions,
        passes: &[u32],
        on_pass: &mut dyn FnMut(&Progress) -> ControlFlow<()>,
    ) -> Result<RenderOutput, SceneError>;
}
