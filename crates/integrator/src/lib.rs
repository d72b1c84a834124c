//! Rendering for raylume: the [`World`] a render reads, the [`Whitted`] integrator behind the
//! [`Integrator`] trait, the parallel [`render`] loop, the [`Film`] and its output to PNG, EXR and PFM.
//!
//! ```
//! use raylume_accel::BruteForce;
//! use raylume_camera::{Pinhole, View};
//! use raylume_geometry::{Sphere, Vec3, Vec3A};
//! use raylume_integrator::{render, Background, Centre, Light, RenderSettings, Whitted, World};
//! use raylume_intersect::Primitive;
//! use raylume_material::Phong;
//!
//! let prims = vec![Primitive::Sphere(Sphere { center: Vec3A::ZERO, radius: 1.0 })];
//! let world = World::new(
//!     BruteForce::new(prims),
//!     vec![Phong::default()],
//!     vec![0],
//!     vec![Light::point(Vec3A::new(0.0, 0.0, 10.0), Vec3::ONE)],
//!     Background::color(Vec3::ZERO),
//! );
//! let view = View { from: Vec3A::new(0.0, 0.0, 5.0), at: Vec3A::ZERO, up: Vec3A::Y,
//!     angle_deg: 45.0, hither: 0.0, width: 16, height: 16, aperture: 0.0, focal: 1.0 };
//! let settings = RenderSettings::default();
//! let camera = Pinhole::new(&view);
//! let (film, stats) = render(&world, &camera, &Centre::new(0), &Whitted::new(&settings), &settings, &|| {});
//! assert_eq!(stats.camera, 256);
//! assert!(film.pixel(8, 8).x > 0.9); // the lit centre of the sphere
//! assert_eq!(film.pixel(0, 0), Vec3::ZERO); // the background
//! ```

mod background;
mod estimate;
mod film;
pub mod metrics;
mod profile;
mod render;
pub mod sampler;
mod whitted;

pub use background::{Background, Cubemap, CubemapFace, Texels};
pub use estimate::{Accumulator, Estimate, REL_MSE_EPS};
pub use film::{
    Extras, Film, ImageFormat, InputError, MAX_IMAGE_PIXELS, MetaValue, OutputError, Window, remove_partial_outputs,
    write_atomically,
};
pub use profile::Profile;
pub use render::{
    CancelToken, MAX_DEPTH, MAX_LIGHT_GRID, MAX_SPP, Observer, RayStats, RenderSettings, render, render_pass,
};
pub use sampler::{Centre, Independent, Jittered, SampleSource, Sampler, Sobol};
pub use whitted::{BatchBuffers, SoftShadows, Whitted};

use raylume_accel::{Accelerator, Interiors};
use raylume_geometry::{Ray, Vec3, Vec3A};
use raylume_material::Material;
pub use raylume_material::{Light, LightShape};

/// Per-primitive shading data: which material, and optional vertex normals (p3f `pp` patches).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading {
    /// Index into the world's materials.
    pub material: u32,
    /// Index into the world's vertex-normal table of a smooth triangle; `None` shades with the
    /// geometric normal.
    pub normals: Option<u32>,
}

/// Everything a render reads: the accelerator over the primitives, the materials, the lights and
/// what rays that escape see.
pub struct World<A, M> {
    /// The primitives, behind an accelerator.
    pub accel: A,
    /// The materials.
    pub materials: Vec<M>,
    /// One entry per primitive (same indices as the accelerator's).
    pub shading: Vec<Shading>,
    /// Vertex normals of smooth triangles, referenced by [`Shading::normals`].
    pub vertex_normals: Vec<[Vec3A; 3]>,
    /// The point lights.
    pub lights: Vec<Light>,
    /// The glass spheres ([`Interiors`]): rays refracted into one, or reflected inside it, find their
    /// closest hit on it, or on the few spheres and planes that reach into it, without the
    /// accelerator, and shadow rays from inside any of them test it first. Empty: every ray asks the
    /// accelerator.
    pub interiors: Interiors,
    /// What escaping rays return.
    pub background: Background,
}

impl<A: Accelerator, M: Material> World<A, M> {
    /// A world whose primitive `i` uses material `materials[prim_material[i]]`.
    pub fn new(
        accel: A,
        materials: Vec<M>,
        prim_material: Vec<u32>,
        lights: Vec<Light>,
        background: Background,
    ) -> Self {
        let shading = prim_material.into_iter().map(|material| Shading { material, normals: None }).collect();
        Self {
            accel,
            materials,
            shading,
            vertex_normals: Vec::new(),
            lights,
            interiors: Interiors::default(),
            background,
        }
    }
}

/// Computes the light arriving along a camera ray.
pub trait Integrator: Sync {
    /// The colour seen along `ray` (a camera ray, whose hits are accepted from `t_min` on), drawing
    /// the sample's other dimensions (area lights, fuzzy reflections) from `sample`.
    fn radiance<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        t_min: f32,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3;

    /// [`radiance`](Integrator::radiance) along a camera ray whose closest hit from `t_min` on is
    /// already known (`first`, the answer of `world.accel.closest_hit`): the render loop finds the
    /// first hits of coherent camera rays together ([`Accelerator::closest_hits`]). The same colour,
    /// bit for bit; by default the hit is found again.
    fn radiance_after<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        t_min: f32,
        first: Option<raylume_accel::PrimitiveHit>,
        sample: &mut S,
        stats: &mut RayStats,
    ) -> Vec3 {
        let _ = first;
        self.radiance(world, ray, t_min, sample, stats)
    }

    /// [`radiance_after`](Integrator::radiance_after) of a batch of camera rays, into `colors`:
    /// `colors[i]` is the colour along `rays[i]`, whose closest hit is `firsts[i]`, drawn from
    /// `samples[i]`, bit for bit. An integrator overrides it to trace the batch's secondary rays
    /// together where they are coherent (the shadow rays of neighbouring hits); `buffers` is kept
    /// from one batch to the next.
    ///
    /// # Panics
    /// If `firsts`, `samples` or `colors` is not as long as `rays`.
    #[allow(clippy::too_many_arguments)]
    fn radiances_after<A: Accelerator, M: Material, S: SampleSource>(
        &self,
        world: &World<A, M>,
        rays: &[Ray],
        t_min: f32,
        firsts: &[Option<raylume_accel::PrimitiveHit>],
        samples: &mut [S],
        colors: &mut [Vec3],
        buffers: &mut BatchBuffers,
        stats: &mut RayStats,
    ) {
        let count = rays.len();
        assert!(firsts.len() == count && samples.len() == count && colors.len() == count, "one of each per ray");
        let _ = buffers;
        for (((ray, first), sample), color) in rays.iter().zip(firsts).zip(samples).zip(colors) {
            *color = self.radiance_after(world, ray, t_min, *first, sample, stats);
        }
    }
}
