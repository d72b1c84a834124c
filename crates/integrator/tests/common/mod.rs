//! What the integrator's tests share: a scene of balls over a floor, a glass material, and a
//! tile-by-tile comparison of the batch path with the one-by-one path.
#![allow(dead_code)]

use raylume_accel::{Accelerator, Bvh, PrimitiveHit};
use raylume_camera::{Camera, CameraSample, Pinhole, View};
use raylume_geometry::{Interval, Sphere, Triangle, Vec2, Vec3, Vec3A};
use raylume_integrator::{
    BatchBuffers, Integrator, Jittered, RayStats, RenderSettings, SampleSource, Sampler, Whitted, World,
};
use raylume_intersect::Primitive;
use raylume_material::Phong;

/// Five balls over a floor of two triangles (the last two primitives) in the plane z = 0.
pub fn balls_over_a_floor() -> Vec<Primitive> {
    let ball = |x: f32, y: f32, z: f32, r: f32| Primitive::Sphere(Sphere { center: Vec3A::new(x, y, z), radius: r });
    let mut prims = vec![
        ball(-1.2, 0.0, 0.5, 0.5),
        ball(0.0, 0.3, 0.4, 0.4),
        ball(1.1, 0.8, 0.6, 0.55),
        ball(0.2, 1.6, 0.5, 0.5),
        ball(-0.9, 1.5, 0.45, 0.45),
    ];
    let v = |x: f32, y: f32| Vec3A::new(x, y, 0.0);
    prims.push(Primitive::Triangle(Triangle::new(v(-4.0, -4.0), v(4.0, -4.0), v(4.0, 4.0))));
    prims.push(Primitive::Triangle(Triangle::new(v(-4.0, -4.0), v(4.0, 4.0), v(-4.0, 4.0))));
    prims
}

/// Clear glass of index 1.5 that transmits 90 % of what it refracts, with a faint diffuse colour.
pub fn glass() -> Phong {
    Phong {
        diffuse: Vec3::ONE,
        kd: 0.1,
        specular: Vec3::ONE,
        ks: 1.0,
        shine: 100.0,
        transmittance: 0.9,
        ior: 1.5,
        ..Phong::default()
    }
}

/// The view the comparisons render: 64x48 pixels looking at the origin's neighbourhood from above
/// the plane z = 0.
pub fn view() -> View {
    View {
        from: Vec3A::new(0.5, -4.0, 2.5),
        at: Vec3A::new(0.0, 0.6, 0.4),
        up: Vec3A::Z,
        angle_deg: 40.0,
        hither: 0.0,
        width: 64,
        height: 48,
        aperture: 0.0,
        focal: 1.0,
    }
}

/// Renders `world` in 8x8 tiles of [`view`] with [`Integrator::radiances_after`] and asserts that
/// every sample's colour is [`Integrator::radiance`]'s, bit for bit, and that both count the same
/// rays; `each_tile` sees each tile's camera hits. Returns the rays counted.
pub fn batches_match_one_by_one<const SOFT: u8>(
    world: &World<Bvh<Primitive>, Phong>,
    settings: &RenderSettings,
    mut each_tile: impl FnMut(&[Option<PrimitiveHit>]),
) -> RayStats {
    let view = view();
    let camera = Pinhole::new(&view);
    let spp = settings.spp;
    let integrator = Whitted::<SOFT>::with_soft_shadows(settings);
    let sampler = Jittered::new(settings.seed, spp);
    let t_min = camera.t_min();
    let mut buffers = BatchBuffers::default();
    let (mut batched, mut single) = (RayStats::default(), RayStats::default());
    for ty in (0..view.height).step_by(8) {
        for tx in (0..view.width).step_by(8) {
            let mut rays = Vec::new();
            let mut sources = Vec::new();
            let mut fresh = Vec::new();
            for y in ty..ty + 8 {
                for x in tx..tx + 8 {
                    for index in 0..spp {
                        let mut src = sampler.begin(x, y, index);
                        let film = Vec2::new(x as f32, y as f32) + src.film();
                        rays.push(camera.generate_ray(&CameraSample { film, lens: Vec2::splat(0.5), time: 0.0 }));
                        sources.push(src);
                        let mut again = sampler.begin(x, y, index);
                        again.film();
                        fresh.push(again);
                    }
                }
            }
            let mut hits = vec![None; rays.len()];
            world.accel.closest_hits(&rays, Interval::new(t_min, f32::INFINITY), &mut hits);
            each_tile(&hits);
            let mut colors = vec![Vec3::ZERO; rays.len()];
            integrator.radiances_after(
                world,
                &rays,
                t_min,
                &hits,
                &mut sources,
                &mut colors,
                &mut buffers,
                &mut batched,
            );
            for ((ray, color), src) in rays.iter().zip(&colors).zip(&mut fresh) {
                let expected = integrator.radiance(world, ray, t_min, src, &mut single);
                assert_eq!(
                    color.to_array().map(f32::to_bits),
                    expected.to_array().map(f32::to_bits),
                    "tile ({tx}, {ty}): batched {color:?}, one by one {expected:?}"
                );
            }
        }
    }
    assert_eq!(batched, single, "the same rays are counted");
    batched
}
