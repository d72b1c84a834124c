//! Render assembly for raylume: turns a [`Scene`] description into what the render loop needs (the
//! primitives behind an accelerator, the camera, the sampler, the integrator, the cubemap decoded
//! from its images) and runs it. [`RenderScene`] adds the rendering methods to [`Scene`].
//!
//! The crates form a graph that only points down: `raylume-geometry` at the bottom; `intersect`,
//! `camera` and `material` (materials and lights) on it; `accel` on `intersect`; `integrator`
//! (the render loop, the film and image files) on those; `raylume-scene` (the description: model,
//! loaders, writer, builder) on `geometry`, `camera` and `material` only; and this crate on both
//! `integrator` and `scene`, the one place where a description meets the machinery. Image decoding stays at or above the
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
//!
//! [`Scene`]: raylume_scene::Scene

use std::ops::ControlFlow;

use raylume_accel::AccelKind;
use raylume_scene::SceneError;

mod assemble;
mod env;
pub mod limits;
mod options;
mod resume;

pub use assemble::{PassSplit, Primitives, Progress, pass_split};
pub use env::load_cubemap;
pub use options::{ADAPTIVE_MIN_PASSES, DEFAULT_PASSES, Features, RenderOptions, RenderOutput, SamplerKind};
pub use raylume_integrator::{Accumulator, Estimate};
pub use raylume_integrator::{CancelToken, Observer};
pub use resume::{PartialPass, Recorder, RenderState};

/// Rendering a [`Scene`]: the methods are [`Scene`]'s once the trait is in scope (it is in
/// `raylume::prelude`).
///
/// [`Scene`]: raylume_scene::Scene
pub trait RenderScene {
    /// The primitives the scene's objects make (polygons as triangle fans, meshes as triangles).
    fn primitives(&self) -> Primitives;

    /// The accelerator `options` ask for, else the scene's hint, else the BVH.
    fn accel_kind(&self, options: &RenderOptions) -> AccelKind;

    /// Checks that rendering with `options` can start: the scene
    /// ([`Scene::validate`](raylume_scene::Scene::validate)), the settings and overrides against the
    /// [`limits`], the crop inside the image, and the memory the render would take.
    /// [`RenderScene::render`] does the same before any work.
    fn check(&self, options: &RenderOptions) -> Result<(), SceneError>;

    /// What rendering with `options` uses.
    fn features(&self, options: &RenderOptions) -> Result<Features, SceneError>;

    /// The samples per pixel a render with `options` takes (before the sampler rounds them).
    fn samples_per_pixel(&self, options: &RenderOptions) -> Result<u32, SceneError>;

    /// Renders the scene. `observer` hears of each finished row and can cancel the render
    /// ([`Observer`]): `&()` for neither, `&|| bar.inc(1)` for a progress bar, a [`CancelToken`]
    /// to stop it from another thread (the render then returns [`SceneError::Cancelled`]).
    ///
    /// With [`RenderOptions::default()`] a scene renders as the CLI renders it without flags: with
    /// its own `spp`, accelerator hint and cubemap. The effects the scene and options use
    /// ([`RenderScene::features`]) choose one of a small set of monomorphised render loops
    /// (accelerator, camera, sampler and soft-shadow mode are type parameters), so the work of an
    /// unused effect is absent from the loop rather than skipped per ray. The samples are drawn in
    /// independent passes ([`RenderOptions::passes`]); their spread is the image's estimated error
    /// ([`RenderOutput::estimate`]).
    ///
    /// ```
    /// use raylume_render::{CancelToken, RenderOptions, RenderScene};
    /// use raylume_scene::{p3f, DEFAULT_SCENE};
    /// let scene = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
    /// let small = RenderOptions { resolution: Some((16, 10)), ..RenderOptions::default() };
    /// let out = scene.render(&small, &()).unwrap();
    /// assert_eq!(out.samples_per_pixel, 16); // the scene's `spp 16`,
    /// assert_eq!(out.passes, 4); // in 4 passes of 4,
    /// let estimate = out.estimate.unwrap(); // whose spread estimates the image's error
    /// assert!(estimate.rmse_interval.0 <= estimate.rmse && estimate.rmse <= estimate.rmse_interval.1);
    ///
    /// let cancel = CancelToken::new();
    /// cancel.cancel();
    /// assert!(matches!(scene.render(&small, &cancel), Err(raylume_scene::SceneError::Cancelled)));
    /// ```
    fn render<O: Observer + ?Sized>(&self, options: &RenderOptions, observer: &O) -> Result<RenderOutput, SceneError>;

    /// Renders as [`RenderScene::render`] does, pass by pass, and hands `on_pass` each pass's
    /// [`Progress`]: the image so far, the samples, the time spent and the estimated error. It
    /// returns [`ControlFlow::Continue`] to let the render go on as its options say (the passes of
    /// [`RenderOptions::passes`], or until a budget: [`RenderOptions::time_limit`],
    /// [`RenderOptions::noise_threshold`]) or [`ControlFlow::Break`] to stop after this pass, with
    /// the image so far (a user's stop button, a signal, a target of its own). `observer` works as
    /// in [`RenderScene::render`], within passes.
    ///
    /// ```
    /// use std::ops::ControlFlow;
    /// use raylume_render::{RenderOptions, RenderScene};
    /// use raylume_scene::{p3f, DEFAULT_SCENE};
    /// let scene = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
    /// // Passes of 4 samples per pixel, for as long as the callback lets them go on.
    /// let options = RenderOptions {
    ///     resolution: Some((16, 10)),
    ///     spp: Some(4),
    ///     passes: 1,
    ///     time_limit: Some(f64::INFINITY),
    ///     ..RenderOptions::default()
    /// };
    /// let mut seen = Vec::new();
    /// let out = scene.render_progressive(&options, &(), |p| {
    ///     seen.push((p.samples_per_pixel, p.estimate.is_some()));
    ///     if p.pass == 2 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    /// }).unwrap();
    /// assert_eq!(seen, [(4, false), (8, true), (12, true)]);
    /// assert_eq!((out.samples_per_pixel, out.passes), (12, 3));
    /// assert!(out.estimate.unwrap().rmse > 0.0);
    /// ```
    fn render_progressive<O: Observer + ?Sized>(
        &self,
        options: &RenderOptions,
        observer: &O,
        on_pass: impl FnMut(&Progress) -> ControlFlow<()>,
    ) -> Result<RenderOutput, SceneError>;
}
