//! Each distribution effect measured against the geometry that predicts it.

use raylume::prelude::*;
use raylume::scene::{Light, Object, Shape};

/// Area of the part of the pixel square `[x, x+1] x [y, y+1]` inside the counter-clockwise triangle `t`
/// (film coordinates), by clipping the square against the triangle's three edges.
fn coverage(t: [Vec2; 3], x: f32, y: f32) -> f64 {
    let mut poly: Vec<(f64, f64)> = vec![
        (x as f64, y as f64),
        (x as f64 + 1.0, y as f64),
        (x as f64 + 1.0, y as f64 + 1.0),
        (x as f64, y as f64 + 1.0),
    ];
    for k in 0..3 {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        let (ax, ay, bx, by) = (a.x as f64, a.y as f64, b.x as f64, b.y as f64);
        let side = |p: (f64, f64)| (bx - ax) * (p.1 - ay) - (by - ay) * (p.0 - ax);
        let mut out = Vec::new();
        for i in 0..poly.len() {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                let s = sp / (sp - sq);
                out.push((p.0 + s * (q.0 - p.0), p.1 + s * (q.1 - p.1)));
            }
        }
        poly = out;
        if poly.is_empty() {
            return 0.0;
        }
    }
    let n = poly.len();
    (0..n).map(|i| poly[i].0 * poly[(i + 1) % n].1 - poly[(i + 1) % n].0 * poly[i].1).sum::<f64>().abs() / 2.0
}

#[test]
fn antialiasing_converges_to_the_analytic_edge_coverage() {
    // A black triangle on a white background, in the view plane, so film coordinates are affine in
    // world coordinates: the exact coverage of every pixel is known.
    let (size, d, fov) = (24u32, 5.0f32, 40.0f32);
    let h = 2.0 * d * (fov.to_radians() / 2.0).tan();
    let world = [Vec3A::new(-0.93, -1.2, 0.0), Vec3A::new(1.31, -0.37, 0.0), Vec3A::new(-0.2, 1.17, 0.0)];
    let film = world.map(|p| Vec2::new((p.x / h + 0.5) * size as f32, (p.y / h + 0.5) * size as f32));
    let scene = SceneBuilder::new()
        .camera(Vec3A::new(0.0, 0.0, d), Vec3A::ZERO, Vec3A::Y, fov, size, size)
        .background(Vec3::ONE)
        .material(Phong { diffuse: Vec3::ZERO, kd: 0.0, ..Phong::default() })
        .triangle(world[0], world[1], world[2])
        .build()
        .unwrap();
    let mut errors = Vec::new();
    for spp in [1u32, 4, 16, 64, 256] {
        let options =
            RenderOptions { settings: RenderSettings { spp, seed: 5, ..Default::default() }, ..Default::default() };
        let out = scene.render(&options, &|| {}).unwrap();
        let (mut sum, mut count) = (0.0, 0);
        for row in 0..size {
            for col in 0..size {
                let y = (size - 1 - row) as f32;
                let c = coverage(film, col as f32, y);
                if c > 0.0 && c < 1.0 {
                    sum += (out.film.pixel(col, row).x as f64 - (1.0 - c)).abs();
                    count += 1;
                }
            }
        }
        assert!(count > 30, "the triangle's edges cross {count} pixels");
        errors.push(sum / count as f64);
    }
    println!("mean edge-pixel error for 1, 4, 16, 64, 256 spp: {errors:?}");
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "error must fall as spp grows: {errors:?}");
    assert!(errors[0] > 0.15, "one centre sample is either in or out");
    assert!(errors[4] < 0.01, "256 jittered samples: {}", errors[4]);
}

/// A floor under a long horizontal bar lit by a square area light: the width of the penumbra across
/// the bar's edge is `L * h / (H - h)` by similar triangles.
fn penumbra_width_in_pixels(spp: u32, grid: u32) -> (f64, f64) {
    let (light_h, bar_h, light_size) = (10.0f32, 5.0f32, 2.0f32);
    let (cam_h, fov, size) = (40.0f32, 30.0f32, 256u32);
    let build = |with_bar: bool| {
        let mut b = SceneBuilder::new()
            .camera(Vec3A::new(10.0, 0.0, cam_h), Vec3A::new(10.0, 0.0, 0.0), Vec3A::Y, fov, size, size)
            .area_light(Vec3A::new(-10.0, 0.0, light_h), Vec3::ONE, light_size)
            .material(Phong { diffuse: Vec3::ONE, kd: 1.0, ..Phong::default() })
            .plane([Vec3A::ZERO, Vec3A::X, Vec3A::Y]);
        if with_bar {
            b = b.shape(Shape::Polygon(vec![
                Vec3A::new(-3.0, -100.0, bar_h),
                Vec3A::new(3.0, -100.0, bar_h),
                Vec3A::new(3.0, 100.0, bar_h),
                Vec3A::new(-3.0, 100.0, bar_h),
            ]));
        }
        b.build().unwrap()
    };
    let options = RenderOptions {
        settings: RenderSettings { spp, light_grid: grid, seed: 1, ..Default::default() },
        ..Default::default()
    };
    let lit = build(false).render(&options, &|| {}).unwrap().film;
    let shadowed = build(true).render(&options, &|| {}).unwrap().film;
    // Along the middle row, the pixels neither fully lit nor fully dark (same samples in both
    // renders, so the ratio is exactly 1 where no light sample is blocked).
    let row = size / 2;
    let pixel = 2.0 * cam_h as f64 * (fov as f64 / 2.0).to_radians().tan() / size as f64;
    // Only the floor between the bar's image and the umbra: the penumbra of the bar's edge at x = -3,
    // which falls on x in [3, 5] (the other edge's is at [15, 17]; the bar itself hides x < 2).
    let floor_x = |px: u32| 10.0 + (px as f64 + 0.5 - size as f64 / 2.0) * pixel;
    let penumbra = (0..size)
        .filter(|&x| (2.5..10.0).contains(&floor_x(x)))
        .filter(|&x| {
            let r = shadowed.pixel(x, row).x / lit.pixel(x, row).x;
            r > 1e-6 && r < 1.0 - 1e-6
        })
        .count();
    // The light's samples span L (jittered) or L (N-1)/N (the centres of an N x N grid).
    let extent = if spp > 1 { light_size as f64 } else { light_size as f64 * (grid as f64 - 1.0) / grid as f64 };
    let predicted = extent * bar_h as f64 / (light_h - bar_h) as f64 / pixel;
    // One sample at the centre counts the pixels whose centre is in the penumbra; with jittered
    // samples a pixel counts as soon as its footprint overlaps it, which adds one pixel.
    let overlap = if spp > 1 { 1.0 } else { 0.0 };
    (penumbra as f64, predicted + overlap)
}

#[test]
fn penumbra_width_follows_similar_triangles() {
    for (spp, grid) in [(1, 8), (1, 16), (256, 4)] {
        let (measured, predicted) = penumbra_width_in_pixels(spp, grid);
        println!("penumbra, spp {spp}, grid {grid}: {measured} px, predicted {predicted:.2} px");
        assert!((measured - predicted).abs() <= 1.0, "spp {spp}: {measured} px vs {predicted:.2} px");
    }
}

/// The blur of a vertical edge at depth `z` through a thin lens focused at `focus`: the standard
/// deviation of the line spread function, in pixels.
fn edge_blur_radius(z: f32, focus_ratio: f32, aperture: f32) -> (f64, f64) {
    let (d, size) = (10.0f32, 64u32);
    let eye = Vec3A::new(0.0, 0.0, d);
    let view = View {
        from: eye,
        at: Vec3A::ZERO,
        up: Vec3A::Y,
        angle_deg: 30.0,
        hither: 0.0,
        width: size,
        height: size,
        aperture,
        focal: focus_ratio,
    };
    // A quad covering x > 0 at distance z from the eye, lit evenly by a distant light behind the eye.
    let wz = d - z;
    let scene = Scene {
        view,
        background: Vec3::ZERO,
        env: None,
        lights: vec![Light::point(Vec3A::new(0.0, 0.0, 1e5), Vec3::ONE)],
        materials: vec![Phong { diffuse: Vec3::ONE, kd: 1.0, ..Phong::default() }],
        objects: vec![Object {
            material: 0,
            shape: Shape::Polygon(vec![
                Vec3A::new(0.0, -100.0, wz),
                Vec3A::new(100.0, -100.0, wz),
                Vec3A::new(100.0, 100.0, wz),
                Vec3A::new(0.0, 100.0, wz),
            ]),
        }],
        accel_hint: None,
        spp_hint: None,
        shutter: None,
        base_dir: None,
    };
    let options =
        RenderOptions { settings: RenderSettings { spp: 256, seed: 3, ..Default::default() }, ..Default::default() };
    let film = scene.render(&options, &|| {}).unwrap().film;
    // Mean profile over all rows, normalised by the lit level far right; its derivative is the line
    // spread function, whose variance is r^2/4 for a disc of radius r, plus 1/12 for the pixel.
    let profile: Vec<f64> =
        (0..size).map(|x| (0..size).map(|y| film.pixel(x, y).x as f64).sum::<f64>() / size as f64).collect();
    let top = profile[size as usize - 1];
    let lsf: Vec<f64> = profile.windows(2).map(|w| (w[1] - w[0]) / top).collect();
    let total: f64 = lsf.iter().sum();
    let mean: f64 = lsf.iter().enumerate().map(|(i, v)| i as f64 * v).sum::<f64>() / total;
    let var: f64 = lsf.iter().enumerate().map(|(i, v)| (i as f64 - mean).powi(2) * v).sum::<f64>() / total;
    let measured = 2.0 * (var - 1.0 / 12.0).max(0.0).sqrt();
    // Thin lens: a lens of radius R = aperture * pixel size (at the view plane) focused at F blurs
    // depth z over a disc of radius R |1 - z/F| there, which is aperture * |d/z - d/F| pixels.
    let predicted = aperture as f64 * (d as f64 / z as f64 - 1.0 / focus_ratio as f64).abs();
    (measured, predicted)
}

#[test]
fn depth_of_field_blurs_by_the_circle_of_confusion() {
    let (sharp, zero) = edge_blur_radius(10.0, 1.0, 6.0);
    println!("edge on the focal plane: blur radius {sharp:.3} px (predicted {zero})");
    assert!(sharp < 0.3, "a point on the focal plane is sharp: {sharp}");
    for (z, focus) in [(20.0, 1.0), (5.0, 1.0), (10.0, 0.6)] {
        let (measured, predicted) = edge_blur_radius(z, focus, 6.0);
        println!("edge at depth {z}, focus {focus}: blur radius {measured:.3} px, predicted {predicted:.3} px");
        assert!((measured - predicted).abs() < 0.1 * predicted + 0.2, "depth {z}: {measured} vs {predicted}");
    }
}

#[test]
fn motion_blur_streak_spans_the_distance_travelled() {
    let (d, size, fov, radius, travel) = (10.0f32, 128u32, 40.0f32, 1.0f32, 4.0f32);
    let eye = Vec3A::new(0.0, 0.0, d);
    let scene = SceneBuilder::new()
        .camera(eye, Vec3A::ZERO, Vec3A::Y, fov, size, size)
        .light(eye, Vec3::ONE)
        .material(Phong { diffuse: Vec3::ONE, kd: 1.0, ..Phong::default() })
        .moving_sphere(Vec3A::new(-travel / 2.0, 0.0, 0.0), Vec3A::new(travel / 2.0, 0.0, 0.0), radius, 0.0, 1.0)
        .build()
        .unwrap();
    let options =
        RenderOptions { settings: RenderSettings { spp: 256, seed: 9, ..Default::default() }, ..Default::default() };
    let out = scene.render(&options, &|| {}).unwrap();
    assert!(out.features.motion_blur);
    let row = size / 2;
    let covered: Vec<u32> = (0..size).filter(|&x| out.film.pixel(x, row).x > 0.0).collect();
    let span = (covered.last().unwrap() - covered.first().unwrap() + 1) as f64;
    // The silhouette's extreme tangents at both ends of the motion, on the view plane.
    let h = 2.0 * d as f64 * (fov as f64 / 2.0).to_radians().tan();
    let edge = |cx: f64, sign: f64| {
        let theta = (cx / d as f64).atan();
        let alpha = (radius as f64 / (cx * cx + (d as f64).powi(2)).sqrt()).asin();
        d as f64 * (theta + sign * alpha).tan()
    };
    let predicted = (edge(travel as f64 / 2.0, 1.0) - edge(-travel as f64 / 2.0, -1.0)) / h * size as f64;
    println!("motion streak: {span} px, predicted {predicted:.2} px");
    assert!((span - predicted).abs() <= 1.5, "{span} vs {predicted}");
    // Without motion (a zero-length shutter) the same sphere covers only 2r.
    let still = RenderOptions { shutter: Some((0.0, 0.0)), ..options };
    let out = scene.render(&still, &|| {}).unwrap();
    assert!(!out.features.motion_blur);
    let covered = (0..size).filter(|&x| out.film.pixel(x, row).x > 0.0).count() as f64;
    assert!(covered < span * 0.5);
}

fn effects_scene() -> Scene {
    SceneBuilder::new()
        .camera(Vec3A::new(0.0, 2.0, 6.0), Vec3A::new(0.0, 0.5, 0.0), Vec3A::Y, 40.0, 64, 48)
        .background(Vec3::new(0.3, 0.5, 0.8))
        .area_light(Vec3A::new(2.0, 4.0, 3.0), Vec3::ONE, 1.0)
        .material(Phong {
            diffuse: Vec3::splat(0.8),
            kd: 0.8,
            specular: Vec3::ONE,
            ks: 0.3,
            shine: 20.0,
            ..Phong::default()
        })
        .plane([Vec3A::ZERO, Vec3A::new(0.0, 0.0, -1.0), Vec3A::new(-1.0, 0.0, 0.0)])
        .material(Phong {
            diffuse: Vec3::splat(0.1),
            kd: 0.1,
            specular: Vec3::ONE,
            ks: 0.9,
            shine: 100.0,
            ..Phong::default()
        })
        .sphere(Vec3A::new(-1.0, 1.0, 0.0), 1.0)
        .material(Phong { diffuse: Vec3::new(0.8, 0.2, 0.1), kd: 0.8, ..Phong::default() })
        .moving_sphere(Vec3A::new(1.0, 0.5, 1.0), Vec3A::new(1.6, 0.5, 1.0), 0.5, 0.0, 1.0)
        .build()
        .unwrap()
}

#[test]
fn zero_roughness_is_exactly_the_mirror_image() {
    let scene = effects_scene();
    let render = |roughness| {
        let o = RenderOptions {
            roughness,
            settings: RenderSettings { spp: 4, ..Default::default() },
            ..Default::default()
        };
        scene.render(&o, &|| {}).unwrap()
    };
    let plain = render(None);
    assert!(!plain.features.fuzzy_reflections);
    let zero = render(Some(0.0));
    assert_eq!(plain.film.pixels(), zero.film.pixels());
    let slight = render(Some(0.02));
    assert!(slight.features.fuzzy_reflections);
    assert_ne!(plain.film.pixels(), slight.film.pixels());
    let rough = render(Some(0.5));
    let diff = |a: &Film, b: &Film| raylume::integrator::metrics::rmse(&flat(a), &flat(b)).unwrap();
    assert!(diff(&plain.film, &slight.film) < diff(&plain.film, &rough.film), "more roughness, more change");
}

fn flat(f: &Film) -> Vec<f32> {
    f.pixels().iter().flat_map(|c| c.to_array()).collect()
}

#[test]
fn every_effect_is_deterministic_across_threads_and_crops() {
    let scene = Scene { view: View { aperture: 3.0, focal: 1.0, ..effects_scene().view }, ..effects_scene() };
    let options = RenderOptions {
        roughness: Some(0.2),
        settings: RenderSettings { spp: 9, seed: 42, ..Default::default() },
        ..Default::default()
    };
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let one = pool(1).install(|| scene.render(&options, &|| {}).unwrap());
    let f = one.features;
    assert!(f.antialiasing && f.area_lights && f.depth_of_field && f.fuzzy_reflections && f.motion_blur);
    let two = pool(2).install(|| scene.render(&options, &|| {}).unwrap());
    assert_eq!(one.film.pixels(), two.film.pixels());
    let crop = [10, 7, 41, 30];
    let cropped = scene
        .render(
            &RenderOptions { settings: RenderSettings { crop: Some(crop), ..options.settings }, ..options.clone() },
            &|| {},
        )
        .unwrap();
    assert_eq!((cropped.film.width(), cropped.film.height()), (31, 23));
    for y in 0..23 {
        for x in 0..31 {
            assert_eq!(cropped.film.pixel(x, y), one.film.pixel(x + crop[0], y + crop[1]));
        }
    }
    let other = scene
        .render(&RenderOptions { settings: RenderSettings { seed: 43, ..options.settings }, ..options.clone() }, &|| {})
        .unwrap();
    assert_ne!(other.film.pixels(), one.film.pixels());
}
