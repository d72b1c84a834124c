//! Rays refracted into a glass sphere, or reflected inside it, find their hits on it (or on the shapes
//! that reach into it) without the accelerator, and shadow rays from inside a glass sphere are occluded
//! by it: the image is the one the accelerator alone makes, bit for bit.

mod common;

use raylume_accel::{Accelerator, BruteForce, Bvh, Interiors};
use raylume_camera::{Pinhole, View};
use raylume_geometry::{Interval, Sphere, Triangle, Vec3, Vec3A};
use raylume_integrator::{Background, Film, Jittered, Light, RenderSettings, SoftShadows, Whitted, World, render};
use raylume_intersect::Primitive;
use raylume_material::Phong;

/// Glass balls (three apart, two overlapping, one touching a mirror ball) over a floor of two
/// triangles, at `scale`.
fn scene(scale: f32) -> (Vec<Primitive>, Vec<u32>, Vec<Phong>) {
    let ball = |x: f32, y: f32, z: f32, r: f32| {
        Primitive::Sphere(Sphere { center: Vec3A::new(x, y, z) * scale, radius: r * scale })
    };
    let mut prims = vec![
        ball(-1.2, 0.0, 0.5, 0.5),
        ball(0.0, 0.0, 0.4, 0.4),
        ball(1.1, 0.3, 0.6, 0.55),
        ball(0.2, 1.2, 0.5, 0.5),
        ball(0.7, 1.4, 0.5, 0.4),
        ball(-0.9, 1.3, 0.45, 0.45),
        ball(-0.9, 2.2, 0.45, 0.45),
    ];
    let v = |x: f32, y: f32| Vec3A::new(x, y, -0.01) * scale;
    prims.push(Primitive::Triangle(Triangle::new(v(-4.0, -4.0), v(4.0, -4.0), v(4.0, 4.0))));
    prims.push(Primitive::Triangle(Triangle::new(v(-4.0, -4.0), v(4.0, 4.0), v(-4.0, 4.0))));
    let glass = common::glass();
    let mirror = Phong { kd: 0.2, specular: Vec3::ONE, ks: 0.8, shine: 30.0, ..Phong::default() };
    let floor = Phong { diffuse: Vec3::new(0.8, 0.6, 0.3), kd: 0.9, ..Phong::default() };
    let materials = vec![glass, mirror, floor];
    let mut of = vec![0, 0, 0, 0, 0, 0, 1];
    of.extend([2, 2]);
    (prims, of, materials)
}

fn view(scale: f32) -> View {
    View {
        from: Vec3A::new(0.5, -4.0, 2.5) * scale,
        at: Vec3A::new(0.0, 0.6, 0.4) * scale,
        up: Vec3A::Z,
        angle_deg: 40.0,
        hither: 0.0,
        width: 96,
        height: 72,
        aperture: 0.0,
        focal: 1.0,
    }
}

fn image<A: Accelerator, const SOFT: u8>(
    mut world: World<A, Phong>,
    clear: Option<Interiors>,
    scale: f32,
    settings: &RenderSettings,
) -> Film {
    if let Some(clear) = clear {
        world.interiors = clear;
    }
    let camera = Pinhole::new(&view(scale));
    let sampler = Jittered::new(settings.seed, settings.spp);
    render(&world, &camera, &sampler, &Whitted::<SOFT>::with_soft_shadows(settings), settings, &|| {}).0
}

fn world<A: Accelerator>(accel: A, of: Vec<u32>, materials: Vec<Phong>, lights: Vec<Light>) -> World<A, Phong> {
    World::new(accel, materials, of, lights, Background::color(Vec3::new(0.2, 0.3, 0.5)))
}

fn same(a: &Film, b: &Film) -> bool {
    a.pixels().iter().zip(b.pixels()).all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
}

#[test]
fn glass_balls_render_the_same_with_their_interiors() {
    for scale in [1e-3, 1.0, 2e4] {
        let (prims, of, materials) = scene(scale);
        let glass = |i: usize| materials[of[i] as usize].transmittance > 0.0;
        let clear = Interiors::new(&prims, glass, Interval::new(0.0, 0.0));
        assert!(clear.answers_any(), "the balls apart are clear at scale {scale}");
        let point = vec![Light::point(Vec3A::new(2.0, -3.0, 5.0) * scale, Vec3::ONE)];
        let settings = RenderSettings { max_depth: 8, ..RenderSettings::default() };
        let bvh =
            || world(Bvh::new(prims.clone(), Interval::new(0.0, 0.0)), of.clone(), materials.clone(), point.clone());
        let plain = image::<_, { SoftShadows::NONE }>(bvh(), None, scale, &settings);
        let fast = image::<_, { SoftShadows::NONE }>(bvh(), Some(clear.clone()), scale, &settings);
        assert!(same(&plain, &fast), "Whitted at scale {scale}");
        let list = world(BruteForce::new(prims.clone()), of.clone(), materials.clone(), point.clone());
        assert!(same(&plain, &image::<_, { SoftShadows::NONE }>(list, Some(clear.clone()), scale, &settings)));

        let area = vec![Light::square(Vec3A::new(2.0, -3.0, 5.0) * scale, Vec3::ONE, 0.8 * scale)];
        let settings = RenderSettings { max_depth: 6, spp: 4, seed: 7, ..RenderSettings::default() };
        let bvh =
            || world(Bvh::new(prims.clone(), Interval::new(0.0, 0.0)), of.clone(), materials.clone(), area.clone());
        let plain = image::<_, { SoftShadows::STRATIFIED }>(bvh(), None, scale, &settings);
        let fast = image::<_, { SoftShadows::STRATIFIED }>(bvh(), Some(clear), scale, &settings);
        assert!(same(&plain, &fast), "soft shadows at scale {scale}");
    }
}
