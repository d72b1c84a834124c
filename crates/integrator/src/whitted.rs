use raylume_accel::Accelerator;
use raylume_geometry::{Interval, Ray, Vec3, Vec3A};
use raylume_material::{FresnelMode, Material, reflect, refract};

use crate::{Integrator, RayStats, RenderSettings, World};

/// Whitted ray tracing as the course defines it: Blinn-Phong from each point light not in shadow,
/// then mirror reflection for opaque specular surfaces, or Fresnel-weighted reflection and refraction
/// for transmissive ones, up to a maximum depth; the colour is clamped to [0, 1] at every level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Whitted {
    max_depth: u32,
    fresnel: FresnelMode,
}

impl Whitted {
    /// The integrator for the given settings (depth and Fresnel mode).
    pub fn new(settings: &RenderSettings) -> Self {
        Self {
            max_depth: settings.max_depth.max(1),
            fresnel: settings.fresnel,
        }
    }

    fn trace<A: Accelerator, M: Material>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        t_min: f32,
        depth: u32,
        stats: &mut RayStats,
    ) -> Vec3 {
        let Some(found) = world
            .accel
            .closest_hit(ray, Interval::new(t_min, f32::INFINITY))
        else {
            return world.background.eval(ray.dir);
        };
        let hit = found.hit;
        let shading = world.shading[found.primitive as usize];
        let material = &world.materials[shading.material as usize];
        let entering = hit.front_face(ray);
        // Geometric normal on the side the ray came from.
        let n = if entering { hit.normal } else { -hit.normal };
        let ns = if shading.normals == u32::MAX {
            n
        } else {
            let vn = world.vertex_normals[shading.normals as usize];
            let b = hit.uv;
            let s = (vn[0] * (1.0 - b.x - b.y) + vn[1] * b.x + vn[2] * b.y).normalize_or_zero();
            if s == Vec3A::ZERO {
                n
            } else if s.dot(n) < 0.0 {
                -s
            } else {
                s
            }
        };
        let wo = -ray.dir;
        let eps = spawn_offset(hit.point, ray, hit.t);
        let above = hit.point + n * eps;

        let mut color = Vec3::ZERO;
        for light in &world.lights {
            let to_light = light.position - above;
            let dist = to_light.length();
            let wi = to_light / dist;
            if n.dot(wi) <= 0.0 || dist == 0.0 {
                continue;
            }
            stats.shadow += 1;
            let shadow = Ray::with_time(above, wi, ray.time);
            if !world.accel.occluded(&shadow, dist) {
                color += light.color * material.local(ns, wo, wi);
            }
        }

        if depth < self.max_depth {
            if let Some(d) = material.dielectric() {
                // A ray leaving the solid uses the inverse index ratio.
                let eta = if entering { 1.0 / d.ior } else { d.ior };
                let kr = self.fresnel.reflectance(wo.dot(ns).max(0.0), eta);
                stats.reflection += 1;
                let r = Ray::with_time(above, reflect(ray.dir, ns).normalize(), ray.time);
                color += kr * self.trace(world, &r, 0.0, depth + 1, stats);
                if kr < 1.0 {
                    if let Some(dir) = refract(ray.dir, ns, eta) {
                        stats.refraction += 1;
                        let below = hit.point - n * eps;
                        let t = Ray::with_time(below, dir, ray.time);
                        color += (1.0 - kr)
                            * d.transmittance
                            * self.trace(world, &t, 0.0, depth + 1, stats);
                    }
                }
            } else {
                let mirror = material.mirror();
                if mirror != Vec3::ZERO {
                    stats.reflection += 1;
                    let r = Ray::with_time(above, reflect(ray.dir, ns).normalize(), ray.time);
                    color += mirror * self.trace(world, &r, 0.0, depth + 1, stats);
                }
            }
        }
        color.clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// How far to move a secondary ray's origin off the surface: a bound on the rounding error of the
/// hit point, which grows with the magnitude of the coordinates and of the ray's travel.
#[inline]
fn spawn_offset(p: Vec3A, ray: &Ray, t: f32) -> f32 {
    let magnitude = p
        .abs()
        .max_element()
        .max(ray.origin.abs().max_element())
        .max(t.abs());
    magnitude * 64.0 * f32::EPSILON + f32::MIN_POSITIVE
}

impl Integrator for Whitted {
    fn radiance<A: Accelerator, M: Material>(
        &self,
        world: &World<A, M>,
        ray: &Ray,
        t_min: f32,
        stats: &mut RayStats,
    ) -> Vec3 {
        self.trace(world, ray, t_min, 1, stats)
    }
}
