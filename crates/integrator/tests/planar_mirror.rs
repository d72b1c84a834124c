//! A batch of camera samples whose surfaces all lie on one mirror plane finds its reflections
//! together ([`Integrator::radiances_after`]): each colour is the one [`Integrator::radiance`] gives
//! the sample on its own, bit for bit, and so are the ray counts.

mod common;

use raylume_accel::{Accelerator, Bvh};
use raylume_geometry::{Interval, Vec3, Vec3A};
use raylume_integrator::{Background, Light, RenderSettings, Shading, SoftShadows, World};
use raylume_intersect::Primitive;
use raylume_material::Phong;

/// Mirror and matte balls over a mirror floor of two triangles (the last two primitives) in the
/// plane z = 0; with `smooth`, the floor's shading normals lean away from its geometric normal.
fn world(lights: Vec<Light>, smooth: bool) -> World<Bvh<Primitive>, Phong> {
    let prims = common::balls_over_a_floor();
    let mirror = Phong { kd: 0.2, specular: Vec3::ONE, ks: 0.8, shine: 30.0, ..Phong::default() };
    let matte = Phong { diffuse: Vec3::new(0.3, 0.7, 0.4), kd: 0.9, ks: 0.0, ..Phong::default() };
    let floor = Phong {
        diffuse: Vec3::new(0.8, 0.6, 0.3),
        kd: 0.8,
        specular: Vec3::ONE,
        ks: 0.2,
        shine: 10.0,
        ..Phong::default()
    };
    let of = vec![0, 1, 0, 0, 1, 2, 2];
    let accel = Bvh::new(prims, Interval::new(0.0, 0.0));
    assert!(accel.gathers_coherent_rays(), "the reflections walk as packets");
    let mut world =
        World::new(accel, vec![mirror, matte, floor], of, lights, Background::color(Vec3::new(0.2, 0.3, 0.5)));
    if smooth {
        let lean = |x: f32, y: f32| Vec3A::new(x, y, 1.0).normalize();
        world.vertex_normals = vec![
            [lean(0.1, 0.0), lean(0.0, 0.1), lean(-0.1, 0.05)],
            [lean(0.1, 0.0), lean(-0.1, 0.05), lean(0.05, -0.1)],
        ];
        world.shading[5] = Shading { material: 2, normals: Some(0) };
        world.shading[6] = Shading { material: 2, normals: Some(1) };
    }
    world
}

/// Compares the batch path with the one-by-one path on `world`; returns how many tiles saw only
/// the floor.
fn compare<const SOFT: u8>(world: &World<Bvh<Primitive>, Phong>, spp: u32) -> usize {
    let settings = RenderSettings { max_depth: 6, spp, seed: 3, ..RenderSettings::default() };
    let mut floor_only = 0;
    common::batches_match_one_by_one::<SOFT>(world, &settings, |hits| {
        if hits.iter().all(|h| h.is_some_and(|h| h.primitive >= 5)) {
            floor_only += 1;
        }
    });
    floor_only
}

#[test]
fn reflections_off_a_mirror_plane_found_together_match_one_by_one() {
    let point = vec![
        Light::point(Vec3A::new(2.0, -3.0, 5.0), Vec3::ONE),
        Light::point(Vec3A::new(-3.0, 1.0, 4.0), Vec3::splat(0.6)),
    ];
    for smooth in [false, true] {
        let tiles = compare::<{ SoftShadows::NONE }>(&world(point.clone(), smooth), 1);
        assert!(tiles > 4, "{tiles} tiles see only the floor");
        let area = vec![Light::square(Vec3A::new(2.0, -3.0, 5.0), Vec3::ONE, 0.8), point[1]];
        compare::<{ SoftShadows::STRATIFIED }>(&world(area.clone(), smooth), 4);
        compare::<{ SoftShadows::GRID }>(&world(area, smooth), 1);
    }
}
