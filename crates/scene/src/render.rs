use std::path::PathBuf;
use std::time::Instant;

use raylume_accel::{AccelKind, Accelerator, BruteForce, Bvh};
use raylume_camera::{Camera, Pinhole, ThinLens};
use raylume_geometry::{AaBox, Aabb, Cone, MovingSphere, Plane, Sphere, Triangle, Vec3A};
use raylume_integrator::{
    Background, Film, PointLight, RayStats, RenderSettings, Shading, Whitted, World, render,
};
use raylume_intersect::Primitive;
use raylume_material::Phong;

use crate::{Scene, SceneError, Shape, load_cubemap, p3f};

/// How to render a scene: the integrator's settings plus the choices the scene file may suggest.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Depth, samples, seed, Fresnel mode.
    pub settings: RenderSettings,
    /// The accelerator; `None` takes the scene's `accel` hint, else the BVH.
    pub accel: Option<AccelKind>,
    /// Overrides the scene's resolution (the vertical field of view is kept).
    pub resolution: Option<(u32, u32)>,
    /// Folders searched, in order, for the scene's `env` cubemap.
    pub env_dirs: Vec<PathBuf>,
    /// Whether to use the scene's cubemap (false: escaping rays return the background colour).
    pub use_env: bool,
    /// Scale of every material's specular highlight (1 in the plain model).
    pub specular_scale: f32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            settings: RenderSettings::default(),
            accel: None,
            resolution: None,
            env_dirs: Vec::new(),
            use_env: true,
            specular_scale: 1.0,
        }
    }
}

/// A rendered image and what it took.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The image.
    pub film: Film,
    /// Rays traced by kind.
    pub stats: RayStats,
    /// The accelerator used.
    pub accel: AccelKind,
    /// Seconds spent building the accelerator.
    pub build_seconds: f64,
    /// Seconds spent tracing.
    pub render_seconds: f64,
}

/// The primitives of a scene with their shading data, in one order.
pub struct Primitives {
    /// The primitives.
    pub primitives: Vec<Primitive>,
    /// Shading of each primitive.
    pub shading: Vec<Shading>,
    /// Vertex normals referenced by [`Shading::normals`].
    pub vertex_normals: Vec<[Vec3A; 3]>,
}

impl Scene {
    /// The primitives the scene's objects make (polygons as triangle fans, meshes as triangles).
    pub fn primitives(&self) -> Primitives {
        let count = self.primitive_count();
        let mut out = Primitives {
            primitives: Vec::with_capacity(count),
            shading: Vec::with_capacity(count),
            vertex_normals: Vec::new(),
        };
        let none = u32::MAX;
        for o in &self.objects {
            let mut push = |p: Primitive, normals: u32| {
                out.primitives.push(p);
                out.shading.push(Shading {
                    material: o.material,
                    normals,
                });
            };
            match &o.shape {
                Shape::Sphere { center, radius } => push(
                    Primitive::Sphere(Sphere {
                        center: *center,
                        radius: *radius,
                    }),
                    none,
                ),
                Shape::MovingSphere {
                    center0,
                    center1,
                    radius,
                    time0,
                    time1,
                } => push(
                    Primitive::MovingSphere(MovingSphere {
                        center0: *center0,
                        center1: *center1,
                        radius: *radius,
                        time0: *time0,
                        time1: *time1,
                    }),
                    none,
                ),
                Shape::Box { min, max } => push(
                    Primitive::Box(AaBox {
                        bounds: Aabb::new(*min, *max),
                    }),
                    none,
                ),
                Shape::Polygon(v) => {
                    for i in 1..v.len().saturating_sub(1) {
                        push(
                            Primitive::Triangle(Triangle::new(v[0], v[i], v[i + 1])),
                            none,
                        );
                    }
                }
                Shape::Patch(v) => {
                    for i in 1..v.len().saturating_sub(1) {
                        let normals = [v[0].1, v[i].1, v[i + 1].1].map(|n| n.normalize_or_zero());
                        let index = out.vertex_normals.len() as u32;
                        out.vertex_normals.push(normals);
                        let mut push = |p: Primitive, normals: u32| {
                            out.primitives.push(p);
                            out.shading.push(Shading {
                                material: o.material,
                                normals,
                            });
                        };
                        push(
                            Primitive::Triangle(Triangle::new(v[0].0, v[i].0, v[i + 1].0)),
                            index,
                        );
                    }
                }
                Shape::Plane([p0, p1, p2]) => {
                    if let Some(plane) = Plane::from_points(*p0, *p1, *p2) {
                        push(Primitive::Plane(plane), none);
                    }
                }
                Shape::Cone {
                    base,
                    base_radius,
                    apex,
                    apex_radius,
                } => push(
                    Primitive::Cone(Cone {
                        base: *base,
                        base_radius: *base_radius,
                        apex: *apex,
                        apex_radius: *apex_radius,
                    }),
                    none,
                ),
                Shape::Mesh {
                    vertices,
                    triangles,
                } => {
                    for t in triangles {
                        let [a, b, c] = t.map(|i| vertices[i as usize]);
                        push(Primitive::Triangle(Triangle::new(a, b, c)), none);
                    }
                }
            }
        }
        out
    }

    /// The accelerator `options` ask for, else the scene's hint, else the BVH.
    pub fn accel_kind(&self, options: &RenderOptions) -> AccelKind {
        options.accel.unwrap_or(match self.accel_hint {
            Some(0) => AccelKind::None,
            Some(1) => AccelKind::Grid,
            _ => AccelKind::Bvh,
        })
    }

    /// Renders the scene. `on_row` is called once per finished image row.
    pub fn render(
        &self,
        options: &RenderOptions,
        on_row: &(dyn Fn() + Sync),
    ) -> Result<RenderOutput, SceneError> {
        let mut view = self.view;
        if let Some((w, h)) = options.resolution {
            if w == 0
                || h == 0
                || w > p3f::MAX_RESOLUTION
                || h > p3f::MAX_RESOLUTION
                || w as u64 * h as u64 > p3f::MAX_PIXELS
            {
                return Err(SceneError::Invalid(format!(
                    "resolution {w} x {h}: each side must be 1..={} and the image at most {} pixels",
                    p3f::MAX_RESOLUTION,
                    p3f::MAX_PIXELS
                )));
            }
            view.width = w;
            view.height = h;
        }
        let env = match (&self.env, options.use_env) {
            (Some(name), true) => Some(load_cubemap(name, &options.env_dirs)?),
            _ => None,
        };
        let background = Background {
            color: self.background,
            env,
        };
        let lights = self
            .lights
            .iter()
            .map(|l| PointLight {
                position: l.position,
                color: l.color,
            })
            .collect();
        let materials: Vec<Phong> = self
            .materials
            .iter()
            .map(|m| Phong {
                specular_scale: options.specular_scale,
                ..*m
            })
            .collect();
        let Primitives {
            primitives,
            shading,
            vertex_normals,
        } = self.primitives();
        let shutter = self.shutter();
        let kind = match self.accel_kind(options) {
            // The uniform grid is not built yet: the BVH stands in for it.
            AccelKind::Grid => AccelKind::Bvh,
            k => k,
        };
        let build = Instant::now();
        let integrator = Whitted::new(&options.settings);
        let settings = &options.settings;
        let (film, stats, build_seconds, render_seconds) = match kind {
            AccelKind::None => {
                let world = World {
                    accel: BruteForce::new(primitives),
                    materials,
                    shading,
                    vertex_normals,
                    lights,
                    background,
                };
                let b = build.elapsed().as_secs_f64();
                let (f, s, r) = render_with(&world, &view, shutter, &integrator, settings, on_row);
                (f, s, b, r)
            }
            _ => {
                let world = World {
                    accel: Bvh::new(primitives, shutter),
                    materials,
                    shading,
                    vertex_normals,
                    lights,
                    background,
                };
                let b = build.elapsed().as_secs_f64();
                let (f, s, r) = render_with(&world, &view, shutter, &integrator, settings, on_row);
                (f, s, b, r)
            }
        };
        Ok(RenderOutput {
            film,
            stats,
            accel: kind,
            build_seconds,
            render_seconds,
        })
    }
}

/// Chooses the camera once, so each combination is its own monomorphised render loop.
fn render_with<A: Accelerator>(
    world: &World<A, Phong>,
    view: &raylume_camera::View,
    shutter: raylume_geometry::Interval,
    integrator: &Whitted,
    settings: &RenderSettings,
    on_row: &(dyn Fn() + Sync),
) -> (Film, RayStats, f64) {
    fn go<A: Accelerator, C: Camera>(
        world: &World<A, Phong>,
        camera: &C,
        integrator: &Whitted,
        settings: &RenderSettings,
        on_row: &(dyn Fn() + Sync),
    ) -> (Film, RayStats, f64) {
        let start = Instant::now();
        let (film, stats) = render(world, camera, integrator, settings, on_row);
        (film, stats, start.elapsed().as_secs_f64())
    }
    if view.aperture > 0.0 {
        go(
            world,
            &ThinLens::new(view).with_shutter(shutter),
            integrator,
            settings,
            on_row,
        )
    } else {
        go(
            world,
            &Pinhole::new(view).with_shutter(shutter),
            integrator,
            settings,
            on_row,
        )
    }
}
