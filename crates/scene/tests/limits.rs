//! Bad input through the API: every limit is refused before work starts, with a message, for
//! scenes built in code as for files; nothing that passes the checks can crash a render.

use raylume_geometry::{Vec3, Vec3A};
use raylume_integrator::RenderSettings;
use raylume_material::Phong;
use raylume_render::{RenderOptions, RenderScene, limits};
use raylume_scene::{Scene, SceneBuilder, SceneError, Shape, obj, p3f};

fn lit() -> SceneBuilder {
    SceneBuilder::new()
        .camera(Vec3A::new(0.0, 0.0, 5.0), Vec3A::ZERO, Vec3A::Y, 45.0, 16, 16)
        .light(Vec3A::new(0.0, 5.0, 5.0), Vec3::ONE)
        .material(Phong::default())
}

fn invalid(r: Result<Scene, SceneError>) -> String {
    match r {
        Err(SceneError::Invalid(m)) => m,
        other => panic!("expected an invalid scene, got {other:?}"),
    }
}

/// Two mirrors facing each other, the camera between them: every camera ray bounces to the depth
/// limit.
fn facing_mirrors() -> Scene {
    SceneBuilder::new()
        .camera(Vec3A::new(0.0, 0.0, 0.5), Vec3A::new(0.0, 0.0, -1.0), Vec3A::Y, 10.0, 4, 4)
        .light(Vec3A::new(0.0, 0.0, 0.9), Vec3::ONE)
        .material(Phong { kd: 0.1, specular: Vec3::ONE, ks: 0.99, shine: 10.0, ..Phong::default() })
        .plane([Vec3A::new(-1.0, -1.0, -1.0), Vec3A::new(1.0, -1.0, -1.0), Vec3A::new(1.0, 1.0, -1.0)])
        .plane([Vec3A::new(-1.0, -1.0, 1.0), Vec3A::new(-1.0, 1.0, 1.0), Vec3A::new(1.0, 1.0, 1.0)])
        .build()
        .unwrap()
}

#[test]
fn a_deep_ray_tree_is_refused_and_the_deepest_allowed_fits_a_default_stack() {
    let scene = facing_mirrors();
    let deep =
        RenderOptions { settings: RenderSettings { max_depth: 4000, ..Default::default() }, ..Default::default() };
    let e = scene.render(&deep, &|| {}).unwrap_err().to_string();
    assert_eq!(e, format!("depth 4000: expected 1..={}", limits::MAX_DEPTH));
    // The deepest allowed tree, on threads with the 2 MiB stack a default thread has.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).stack_size(2 << 20).build().unwrap();
    let deepest = RenderOptions {
        settings: RenderSettings { max_depth: limits::MAX_DEPTH, ..Default::default() },
        ..Default::default()
    };
    let out = pool.install(|| scene.render(&deepest, &|| {})).unwrap();
    assert_eq!(out.stats.reflection, 16 * (limits::MAX_DEPTH as u64 - 1));
}

#[test]
fn samples_resolution_and_crops_beyond_the_limits_are_refused() {
    let scene = lit().sphere(Vec3A::ZERO, 1.0).build().unwrap();
    let e = |o: RenderOptions| scene.render(&o, &|| {}).unwrap_err().to_string();
    assert_eq!(
        e(RenderOptions { spp: Some(u32::MAX), ..Default::default() }),
        "spp 4294967295: expected 1..=65536 samples per pixel"
    );
    assert!(e(RenderOptions { resolution: Some((100_000, 100_000)), ..Default::default() }).starts_with("resolution"));
    let crop =
        |c| RenderOptions { settings: RenderSettings { crop: Some(c), ..Default::default() }, ..Default::default() };
    assert_eq!(e(crop([0, 0, 17, 4])), "crop 0 0 17 4: expected pixels inside the 16 x 16 image");
    assert_eq!(e(crop([20, 20, 30, 30])), "crop 20 20 30 30: expected pixels inside the 16 x 16 image");
    assert_eq!(e(crop([4, 4, 4, 8])), "crop 4 4 4 8: expected X0 < X1 and Y0 < Y1");
    let grid = RenderOptions { grid: raylume_accel::GridParams { k: f32::NAN, mailbox: true }, ..Default::default() };
    assert_eq!(e(grid), "grid density NaN: expected a number in (0, 1000]");
    // A crop inside the image renders exactly its pixels.
    assert_eq!(scene.render(&crop([0, 0, 16, 4]), &|| {}).unwrap().film.height(), 4);
}

#[test]
fn cameras_that_see_nothing_are_refused_when_built_and_when_rendered() {
    let camera = |from: Vec3A, at: Vec3A, w: u32, h: u32| {
        invalid(SceneBuilder::new().camera(from, at, Vec3A::Y, 45.0, w, h).material(Phong::default()).build())
    };
    assert_eq!(camera(Vec3A::ZERO, Vec3A::ZERO, 8, 8), "camera: 'from' equals 'at'");
    assert!(camera(Vec3A::splat(f32::NAN), Vec3A::ZERO, 8, 8).contains("finite"));
    assert!(camera(Vec3A::Z, Vec3A::ZERO, 0, 0).starts_with("camera: resolution 0 x 0"));
    assert!(camera(Vec3A::Z, Vec3A::ZERO, 100_000, 100_000).starts_with("camera: resolution 100000 x 100000"));
    // A scene changed after it was built is checked again by the render.
    let mut scene = lit().sphere(Vec3A::ZERO, 1.0).build().unwrap();
    scene.view.at = scene.view.from;
    assert!(matches!(scene.render(&RenderOptions::default(), &|| {}), Err(SceneError::Invalid(_))));
}

#[test]
fn meshes_and_objects_that_index_nothing_are_refused() {
    let mesh = lit().mesh(vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y], vec![[0, 1, 3]]).build();
    assert_eq!(invalid(mesh), "object 0: mesh: triangle 0 refers to vertex 3 of 3");
    let mut scene = lit().sphere(Vec3A::ZERO, 1.0).build().unwrap();
    scene.objects[0].material = 7;
    assert_eq!(scene.validate().unwrap_err().to_string(), "object 0: material 7 of 1");
    let nan = lit().shape(Shape::Sphere { center: Vec3A::ZERO, radius: f32::NAN }).build();
    assert!(invalid(nan).starts_with("object 0: sphere"));
}

#[test]
fn a_grid_over_primitives_that_all_overlap_stays_bounded_and_exact() {
    use raylume_accel::{Accelerator, BruteForce, Grid, GridParams};
    use raylume_geometry::{Interval, Ray, Sphere};
    use raylume_intersect::Primitive;
    // 20 000 spheres on one spot, with 1000 cells asked per primitive: every cell would hold every
    // sphere (4 * 10^11 entries).
    let n = 20_000;
    let prims: Vec<Primitive> =
        (0..n).map(|i| Primitive::Sphere(Sphere { center: Vec3A::splat(i as f32 * 1e-6), radius: 1.0 })).collect();
    let grid = Grid::new(prims.clone(), Interval::new(0.0, 0.0), GridParams { k: 1000.0, mailbox: true });
    // At most 64 entries per primitive, or 2^24 in all.
    assert!(grid.entries() as u64 <= (64 * n as u64).max(1 << 24), "{} entries", grid.entries());
    let brute = BruteForce::new(prims);
    for i in 0..200 {
        let a = i as f32 * 0.1;
        let ray = Ray::new(Vec3A::new(a.cos() * 5.0, a.sin() * 3.0, 4.0), Vec3A::new(-a.cos(), -a.sin() * 0.5, -0.8));
        let range = Interval::new(0.0, f32::INFINITY);
        let (g, b) = (grid.closest_hit(&ray, range), brute.closest_hit(&ray, range));
        assert_eq!(g.map(|h| h.hit.t), b.map(|h| h.hit.t), "ray {i}");
    }
    // The same through a scene file's own `accel 1`.
    let mut text =
        String::from("accel 1\nv from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8\nf 1 1 1 1 0 1 0 0\n");
    text.push_str(&"s 0 0 0 1\n".repeat(n));
    let scene = p3f::parse(&text, "same.p3f", &Default::default()).unwrap().scene;
    let options = RenderOptions { grid: GridParams { k: 1000.0, mailbox: true }, ..Default::default() };
    assert_eq!(scene.render(&options, &|| {}).unwrap().accel, raylume_accel::AccelKind::Grid);
}

#[test]
fn files_that_are_not_regular_or_endless_are_not_read() {
    if !std::path::Path::new("/dev/zero").exists() {
        println!("skipped: no /dev/zero");
        return;
    }
    let e = obj::load("/dev/zero").unwrap_err().to_string();
    assert_eq!(e, "/dev/zero: not a regular file or a pipe");
    let e = p3f::load("/dev/zero", &Default::default()).unwrap_err().to_string();
    assert_eq!(e, "/dev/zero: not a regular file or a pipe");
    // A scene's `obj` naming a device, and an OBJ whose `mtllib` names one (MTL files are never opened).
    let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 4 4\nf 1 1 1 1 0 1 0 0\nobj /dev/zero\n";
    let e = p3f::parse(text, "dev.p3f", &Default::default()).unwrap_err().to_string();
    assert_eq!(e, "dev.p3f:3:5: obj '/dev/zero': /dev/zero: not a regular file or a pipe");
    let mesh = obj::parse(b"mtllib /dev/zero\nusemtl x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "m.obj").unwrap();
    assert!(matches!(mesh, Shape::Mesh { ref triangles, .. } if triangles.len() == 1));
}

#[test]
fn messages_show_invisible_characters_and_give_lines() {
    let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 4 4\nf 1 1 1 1 0 1 0 0\ns 0 0\u{a0}0 1\n";
    let e = p3f::parse(text, "nbsp.p3f", &Default::default()).unwrap_err().to_string();
    assert_eq!(e, "nbsp.p3f:3:5: expected a number (sphere centre y), found '0\\u{a0}0'");
    let e = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n", "far.obj").unwrap_err().to_string();
    assert_eq!(
        e,
        "far.obj:5:7: not a readable OBJ file (expected a vertex reference from 1 to 3 or from -3 to -1): 'f 1 2 9'"
    );
}

/// Faces whose vertex references point at nothing, including those whose offsets overflow, are
/// refused with the line and column of the reference; a malformed line before them is reported
/// first. A normal reference that points at nothing leaves its face shaded flat, with a warning;
/// texture coordinates are not used, and their references not followed.
#[test]
fn faces_referring_to_nothing_are_refused_where_they_are() {
    let error = |text: &str| obj::parse(text.as_bytes(), "f.obj").unwrap_err().to_string();
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n";
    let cases = [
        ("f 1 2 0\n", "5:7: not a readable OBJ file (expected a vertex reference from 1 to 3 or from -3 to -1)"),
        (
            "f 1 2 -9223372036854775808\n",
            "5:7: not a readable OBJ file (expected a vertex reference from 1 to 3 or from -3 to -1)",
        ),
        (
            "f 1 2 9223372036854775807\n",
            "5:7: not a readable OBJ file (expected a vertex reference from 1 to 3 or from -3 to -1)",
        ),
        (
            "f 1 2 99999999999999999999999\n",
            "5:7: not a readable OBJ file (expected a vertex reference (an integer), found '99999999999999999999999')",
        ),
    ];
    for (face, expected) in cases {
        let e = error(&format!("{head}{face}"));
        assert!(e.starts_with(&format!("f.obj:{expected}")), "{face:?}: {e}");
    }
    // The first malformed line is the one reported.
    let e = error(&format!("{head}v 1 x 0\nf 1 2 -7\n"));
    assert_eq!(e, "f.obj:5:5: not a readable OBJ file (expected a number (vertex y), found 'x'): 'v 1 x 0'");
    // References counted back from the face read as forward ones; faces of fewer than three
    // references are skipped with a warning.
    let (mesh, warnings) =
        obj::parse_with_warnings(format!("{head}f -3//-1 -2//-1 -1//1\nf 1 9\n").as_bytes(), "f.obj").unwrap();
    assert!(
        matches!(mesh, Shape::Mesh { ref triangles, ref normals, .. } if triangles.len() == 1 && normals.len() == 1)
    );
    let shown: Vec<String> = warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(shown, ["f.obj:6:1: warning: a face of 2 corners has no surface: skipped"]);
    // Normals that are not there: the face is shaded flat.
    for (face, column, problem) in [
        ("f 1//1 2//-5 3//1\n", 11, "expected a normal reference from 1 to 1 or from -1 to -1"),
        ("f 1//0 2//1 3//1\n", 6, "expected a normal reference from 1 to 1 or from -1 to -1"),
        ("f 1/6148914691236517206/1 2//9 3//1\n", 30, "expected a normal reference from 1 to 1 or from -1 to -1"),
    ] {
        let (mesh, warnings) = obj::parse_with_warnings(format!("{head}{face}").as_bytes(), "f.obj").unwrap();
        let Shape::Mesh { normals, .. } = mesh else { unreachable!() };
        assert!(normals.is_empty(), "{face:?}: flat");
        let shown: Vec<String> = warnings.iter().map(|w| w.to_string()).collect();
        assert_eq!(shown, [format!("f.obj:5:{column}: warning: {problem}: the face is shaded flat")], "{face:?}");
    }
}
