//! Adaptive depth control ([`RenderSettings::min_weight`]): a reflected or refracted ray whose
//! weight in its sample falls below the minimum is left out, the same in the batch path as one by
//! one, and each ray left out changes its pixel by at most its weight.

mod common;

use raylume_accel::{Bvh, Interiors};
use raylume_camera::Pinhole;
use raylume_geometry::{Interval, Vec3, Vec3A};
use raylume_integrator::{
    Background, Film, Jittered, Light, RayStats, RenderSettings, SoftShadows, Whitted, World, render,
};
use raylume_intersect::Primitive;
use raylume_material::Phong;

/// A mirror of weight 0.8 (white, `ks` 0.8) and one of weight 0.6 (its largest component).
fn mirrors() -> [Phong; 2] {
    [
        Phong { kd: 0.2, specular: Vec3::ONE, ks: 0.8, shine: 30.0, ..Phong::default() },
        Phong { kd: 0.3, specular: Vec3::new(0.5, 1.0, 0.25), ks: 0.6, shine: 10.0, ..Phong::default() },
    ]
}

/// Balls over a mirror floor of two triangles in the plane z = 0: with `glass`, the first two balls
/// are glass (and answered inside by their [`Interiors`]), else all are mirrors.
fn world(glass: bool, lights: Vec<Light>) -> World<Bvh<Primitive>, Phong> {
    let prims = common::balls_over_a_floor();
    let [bright, tinted] = mirrors();
    let materials = vec![bright, tinted, common::glass()];
    let of = if glass { vec![2, 2, 0, 1, 0, 1, 1] } else { vec![0, 1, 0, 1, 0, 1, 1] };
    let interiors = Interiors::new(&prims, |i| of[i] == 2, Interval::new(0.0, 0.0));
    let accel = Bvh::new(prims, Interval::new(0.0, 0.0));
    let mut world = World::new(accel, materials, of, lights, Background::color(Vec3::new(0.2, 0.3, 0.5)));
    world.interiors = interiors;
    world
}

fn point_lights() -> Vec<Light> {
    vec![
        Light::point(Vec3A::new(2.0, -3.0, 5.0), Vec3::ONE),
        Light::point(Vec3A::new(-3.0, 1.0, 4.0), Vec3::splat(0.6)),
    ]
}

/// The image of `world` by [`render`], with its ray counts.
fn image(world: &World<Bvh<Primitive>, Phong>, settings: &RenderSettings) -> (Film, RayStats) {
    let camera = Pinhole::new(&common::view());
    let sampler = Jittered::new(settings.seed, settings.spp);
    render(world, &camera, &sampler, &Whitted::new(settings), settings, &|| {})
}

fn bits(film: &Film) -> Vec<[u32; 3]> {
    film.pixels().iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn batches_leave_out_the_rays_one_by_one_leaves_out() {
    let settings = |min_weight: f32, spp: u32| RenderSettings {
        max_depth: 8,
        spp,
        seed: 5,
        min_weight,
        ..RenderSettings::default()
    };
    let area = vec![Light::square(Vec3A::new(2.0, -3.0, 5.0), Vec3::ONE, 0.8), point_lights()[1]];
    for glass in [false, true] {
        let all = common::batches_match_one_by_one::<{ SoftShadows::NONE }>(
            &world(glass, point_lights()),
            &settings(0.0, 1),
            |_| {},
        );
        for min_weight in [0.05, 0.3, 0.7] {
            let some = common::batches_match_one_by_one::<{ SoftShadows::NONE }>(
                &world(glass, point_lights()),
                &settings(min_weight, 1),
                |_| {},
            );
            assert!(
                some.reflection + some.refraction < all.reflection + all.refraction,
                "glass {glass}, minimum weight {min_weight}: {some:?} against {all:?}"
            );
            common::batches_match_one_by_one::<{ SoftShadows::STRATIFIED }>(
                &world(glass, area.clone()),
                &settings(min_weight, 4),
                |_| {},
            );
            common::batches_match_one_by_one::<{ SoftShadows::GRID }>(
                &world(glass, area.clone()),
                &settings(min_weight, 1),
                |_| {},
            );
        }
    }
}

#[test]
fn a_chain_of_mirrors_stops_where_its_weight_falls_below_the_minimum() {
    let lights = point_lights();
    let at = |max_depth: u32, min_weight: f32| {
        let (film, stats) = image(
            &world(false, lights.clone()),
            &RenderSettings { max_depth, min_weight, ..RenderSettings::default() },
        );
        (bits(&film), stats)
    };
    // The mirrors weigh 0.8 and 0.6: above both, no ray leaves a surface.
    let (none, stats) = at(6, 0.81);
    assert_eq!(stats.reflection, 0);
    assert!(none == at(1, 0.0).0, "without reflections, the image of the first hits");
    // At 0.65, the bright mirror's reflections of camera hits (0.8) are traced, the tinted one's
    // (0.6) are not, nor any second bounce (at most 0.8 * 0.8 = 0.64): depth 6 is depth 2.
    let (first_bounces, stats) = at(6, 0.65);
    assert!(stats.reflection > 0);
    assert!(first_bounces == at(2, 0.65).0, "nothing beyond the first bounce");
    assert!(at(2, 0.65).0 != at(2, 0.0).0, "the tinted mirror's reflections are left out");
    // At 0.63, the bright mirror's second bounces off itself (0.64) are traced.
    assert!(at(6, 0.63).0 != at(2, 0.63).0, "second bounces of 0.64 are traced");
}

#[test]
fn each_ray_left_out_changes_its_pixel_by_at_most_its_weight() {
    let max_depth = 6;
    // The mirrors' chains weigh 0.8^k and 0.6^k; glass splits light into small weights soon.
    for (glass, minima) in [(false, [0.3, 0.5, 0.7]), (true, [0.001, 0.01, 0.1])] {
        let full = image(&world(glass, point_lights()), &RenderSettings { max_depth, ..RenderSettings::default() });
        for min_weight in minima {
            let (pruned, stats) = image(
                &world(glass, point_lights()),
                &RenderSettings { max_depth, min_weight, ..RenderSettings::default() },
            );
            assert!(stats.reflection + stats.refraction < full.1.reflection + full.1.refraction);
            // A sample leaves out at most 2^(depth - 1) rays, each of weight below the minimum, each
            // bringing back a colour of at most 1.
            let bound = min_weight * (1 << (max_depth - 1)) as f32;
            let worst = full.0.pixels().iter().zip(pruned.pixels()).map(|(p, q)| (*p - *q).abs().max_element());
            let worst = worst.fold(0.0, f32::max);
            assert!(worst > 0.0 && worst <= bound, "glass {glass}, minimum {min_weight}: {worst} against {bound}");
        }
    }
}

#[test]
fn glass_leaves_out_its_faint_reflection_and_keeps_its_refraction() {
    let at = |min_weight: f32| {
        image(&world(true, point_lights()), &RenderSettings { max_depth: 2, min_weight, ..RenderSettings::default() }).1
    };
    // Glass of index 1.5 reflects less than 5 % of the light below about 50 degrees of incidence, and
    // transmits 90 % of the rest: at 0.05 most of its reflections go, its refractions stay.
    let (all, some) = (at(0.0), at(0.05));
    assert!(all.refraction > 100);
    assert!(some.refraction as f64 > 0.9 * all.refraction as f64, "{some:?} against {all:?}");
    assert!(some.reflection + all.refraction / 4 < all.reflection, "{some:?} against {all:?}");
}

#[test]
fn rays_weighed_by_zero_are_not_traced_even_at_a_minimum_of_zero() {
    // Glass balls among matte ones over a matte floor: only the glass sends rays on.
    let glass_of = |ior: f32| {
        let mut world = world(true, point_lights());
        let matte = Phong { diffuse: Vec3::new(0.3, 0.7, 0.4), kd: 0.9, ..Phong::default() };
        world.materials[0] = matte;
        world.materials[1] = matte;
        world.materials[2].ior = ior;
        world
    };
    let settings = RenderSettings { max_depth: 6, ..RenderSettings::default() };
    let dense = common::batches_match_one_by_one::<{ SoftShadows::NONE }>(&glass_of(1.5), &settings, |_| {});
    assert!(dense.reflection > 100 && dense.refraction > 100, "{dense:?}");
    // Of index 1 its reflectance is zero: its reflections would add exactly nothing, and are not
    // traced.
    let clear = common::batches_match_one_by_one::<{ SoftShadows::NONE }>(&glass_of(1.0), &settings, |_| {});
    assert!(clear.refraction > 100 && clear.reflection == 0, "{clear:?}");
}
