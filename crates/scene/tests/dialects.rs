//! Every dialect of the format (tests/dialects/, one file each, written from the grammar of
//! `p3f.md`): each loads to its primitives, says which dialect it is, renders a picture that is not
//! flat, and comes back the same through canonical p3f; each malformed variant gets its message.

use std::path::{Path, PathBuf};

use raylume_geometry::{Vec3, Vec3A};
use raylume_render::{RenderOptions, RenderScene};
use raylume_scene::p3f::{Dialect, LoadOptions, Loaded, load, parse, parse_bytes};
use raylume_scene::{AccelHint, LightShape, Scene, SceneError, Shape};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/dialects").join(name)
}

fn loaded(name: &str) -> Loaded {
    load(example(name), &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn kinds(scene: &Scene) -> Vec<&'static str> {
    scene
        .objects
        .iter()
        .map(|o| match o.shape {
            Shape::Sphere { .. } => "s",
            Shape::MovingSphere { .. } => "sm",
            Shape::Box { .. } => "box",
            Shape::Polygon(_) => "p",
            Shape::Patch(_) => "pp",
            Shape::Plane(_) => "pl",
            Shape::Cone { .. } => "c",
            Shape::Mesh { .. } => "mesh",
        })
        .collect()
}

/// The line of `name` that starts with `start`, from 1.
fn line_of(name: &str, start: &str) -> u32 {
    let text = std::fs::read_to_string(example(name)).unwrap();
    text.lines().position(|l| l.starts_with(start)).expect("the line is in the file") as u32 + 1
}

/// Renders at the scene's size, one sample per pixel, and checks that the picture is finite and not
/// flat; returns the render's warnings.
fn renders_a_picture(scene: &Scene) -> Vec<String> {
    let options = RenderOptions { spp: Some(1), ..RenderOptions::default() };
    let out = scene.render(&options, &|| {}).unwrap_or_else(|e| panic!("{e}"));
    let lum: Vec<f32> = out.film.pixels().iter().map(|p| p.x + p.y + p.z).collect();
    assert!(lum.iter().all(|l| l.is_finite()));
    let (lo, hi) = lum.iter().fold((f32::MAX, f32::MIN), |(a, b), &l| (a.min(l), b.max(l)));
    assert!(hi - lo > 0.3, "a flat picture: luminance {lo}..{hi}");
    out.warnings.iter().map(|w| w.to_string()).collect()
}

/// Written as canonical p3f and read again, the scene is the same.
fn round_trips(scene: &Scene) {
    let text = scene.to_p3f();
    let options = LoadOptions { base_dir: scene.base_dir.clone(), ..LoadOptions::default() };
    let again = parse(&text, "canonical.p3f", &options).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(&again.scene, scene, "canonical text:\n{text}");
}

#[test]
fn nff_of_the_early_course_years() {
    let name = "nff_1998.nff";
    let l = loaded(name);
    assert_eq!(l.dialect, Dialect::Nff);
    assert!(l.extensions.is_empty(), "{:?}", l.extensions);
    assert_eq!(l.summary(), "read as NFF");
    let s = &l.scene;
    assert_eq!(s.background, Vec3::new(0.2, 0.3, 0.5));
    assert_eq!((s.view.width, s.view.height, s.view.aperture), (96, 64, 0.0));
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.lights[0].color, Vec3::ONE);
    assert_eq!(s.materials.len(), 5);
    let m = s.materials[1];
    assert_eq!((m.diffuse, m.kd, m.specular, m.ks, m.shine), (Vec3::new(0.9, 0.2, 0.1), 0.7, Vec3::ONE, 0.3, 40.0));
    assert_eq!((s.materials[2].transmittance, s.materials[2].ior), (0.9, 1.5));
    assert_eq!(kinds(s), ["p", "s", "s", "p", "c", "box", "pp"]);
    assert!(matches!(s.objects[2].shape, Shape::Sphere { radius: 0.7, .. }), "a negative radius is its size");
    assert!(matches!(s.objects[4].shape, Shape::Cone { base_radius: 0.4, apex_radius: 0.1, .. }));
    let Shape::Box { min, max } = s.objects[5].shape else { unreachable!() };
    assert_eq!((min, max), (Vec3A::new(1.7, 0.5, 0.0), Vec3A::new(2.5, 1.5, 0.8)), "aabb corners in any order");
    assert_eq!(s.primitive_count(), 2 + 1 + 1 + 4 + 1 + 1 + 1);
    // The free-text lines the course's line-based reader ignored are skipped with a warning each.
    let skipped: Vec<(u32, &str)> = l.warnings.iter().map(|w| (w.line, w.message.as_str())).collect();
    assert_eq!(skipped.len(), 3, "{skipped:?}");
    for (w, start) in l.warnings.iter().zip(["Floor", "oldplane", "An L-shaped"]) {
        assert_eq!((w.line, w.column), (line_of(name, start), 1), "{w}");
        assert!(w.message.contains(&format!("skipped '{start}")), "{w}");
    }
    // The concave L is covered by its triangles exactly: area 3 in its plane's (x, z) projection,
    // which is tilted by atan(1/2).
    let Shape::Polygon(wall) = &s.objects[3].shape else { unreachable!() };
    let area: f32 = raylume_scene::triangulate(wall)
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| wall[i as usize]);
            (b - a).cross(c - a).length() / 2.0
        })
        .sum();
    assert!((area - 3.0 * 1.25f32.sqrt()).abs() < 1e-5, "{area}");
    assert!(renders_a_picture(s).is_empty());
    round_trips(s);
    assert!(load(example(name), &LoadOptions { strict: true, ..Default::default() }).is_err());
}

#[test]
fn p3f_of_2019_with_a_missing_cubemap() {
    let name = "course_2019.p3f";
    let l = loaded(name);
    assert_eq!(l.dialect, Dialect::P3f);
    let s = &l.scene;
    assert_eq!(kinds(s), ["pl", "s", "sm", "box", "p", "c"]);
    assert_eq!(s.env.as_deref(), Some("no_such_cubemap"), "the scene says what the file says");
    // The folder is missing: a warning at the `env` entry, and the background colour is used.
    assert_eq!(l.warnings.len(), 1);
    let w = &l.warnings[0];
    assert_eq!((w.line, w.column), (line_of(name, "env"), 1));
    assert!(w.message.contains("no folder 'no_such_cubemap'") && w.message.contains("background colour"), "{w}");
    let render_warnings = renders_a_picture(s);
    assert_eq!(render_warnings.len(), 1, "{render_warnings:?}");
    round_trips(s);
    // Under --strict it is an error at the same place, and so is the render.
    let e = load(example(name), &LoadOptions { strict: true, ..Default::default() }).unwrap_err();
    let SceneError::Syntax { line, column, .. } = e else { panic!("{e}") };
    assert_eq!((line, column), (w.line, 1));
    let strict = RenderOptions { strict: true, ..RenderOptions::default() };
    assert!(matches!(s.render(&strict, &|| {}), Err(SceneError::Environment { .. })));
}

#[test]
fn p3f_of_2021_with_accel_spp_and_a_mesh() {
    let l = loaded("course_2021.p3f");
    assert_eq!(l.dialect, Dialect::P3f);
    assert!(l.warnings.is_empty());
    let s = &l.scene;
    assert_eq!((s.accel_hint, s.spp_hint), (Some(AccelHint::Grid), Some(4)));
    let Shape::Mesh { vertices, triangles, .. } = &s.objects[0].shape else { panic!("a mesh") };
    assert_eq!(vertices.len(), 5);
    assert_eq!(triangles, &[[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], "-1 is the last vertex");
    // The library takes the scene's spp and accelerator unless told otherwise.
    assert_eq!(s.samples_per_pixel(&RenderOptions::default()).unwrap(), 4);
    assert_eq!(s.samples_per_pixel(&RenderOptions { spp: Some(9), ..Default::default() }).unwrap(), 9);
    assert_eq!(s.accel_kind(&RenderOptions::default()), raylume_accel::AccelKind::Grid);
    assert!(renders_a_picture(s).is_empty());
    round_trips(s);
}

#[test]
fn p3f_of_2024_with_its_own_words() {
    let l = loaded("course_2024.p3f");
    assert_eq!(l.dialect, Dialect::P3f2024);
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let s = &l.scene;
    assert_eq!((s.accel_hint, s.spp_hint), (Some(AccelHint::Bvh), Some(1)));
    assert_eq!((s.view.from, s.view.at), (Vec3A::new(0.0, -5.0, 2.0), Vec3A::new(0.0, 0.0, 0.5)));
    assert_eq!((s.view.width, s.view.height, s.view.angle_deg), (80, 60, 40.0));
    assert_eq!(s.lights[0].shape, LightShape::Point);
    assert_eq!(s.lights[0].color, Vec3::splat(0.6));
    assert_eq!(s.lights[1].position, Vec3A::new(-1.0, -1.0, 4.0));
    assert_eq!(
        s.lights[1].shape,
        LightShape::Parallelogram { ends: [Vec3A::new(1.0, -1.0, 4.0), Vec3A::new(-1.0, 1.0, 4.0)], grid: 3 }
    );
    assert_eq!(s.materials.len(), 3);
    assert_eq!(kinds(s), ["pl", "s", "s"]);
    // `npl 0 0 1 0.5` is the plane z = -0.5, facing +z.
    let Shape::Plane([p0, p1, p2]) = s.objects[0].shape else { unreachable!() };
    assert!([p0, p1, p2].iter().all(|p| (p.z + 0.5).abs() < 1e-6), "{p0} {p1} {p2}");
    assert!((p1 - p0).cross(p2 - p0).normalize().abs_diff_eq(Vec3A::Z, 1e-6));
    let features = s.features(&RenderOptions::default()).unwrap();
    assert!(features.area_lights && features.transmission);
    assert!(renders_a_picture(s).is_empty());
    round_trips(s);
}

#[test]
fn students_extensions() {
    let name = "student.p3f";
    let l = loaded(name);
    assert_eq!(l.dialect, Dialect::P3f);
    assert_eq!(l.extensions, ["al", "fire", "ms"]);
    assert_eq!(l.summary(), "read as p3f with al, fire, ms");
    let s = &l.scene;
    assert_eq!(s.env.as_deref(), Some("flames"), "fire names a cubemap as env does");
    assert_eq!(l.warnings.len(), 1, "the missing 'flames' folder: {:?}", l.warnings);
    assert_eq!(l.warnings[0].line, line_of(name, "fire"));
    assert_eq!(kinds(s), ["pl", "sm", "sm", "c"]);
    let Shape::MovingSphere { center0, center1, radius, time0, time1 } = s.objects[2].shape else { unreachable!() };
    assert_eq!(
        (center0, center1, radius, time0, time1),
        (Vec3A::new(0.5, 0.0, 0.5), Vec3A::new(0.9, 0.0, 0.9), 0.3, 0.0, 1.0),
        "7 numbers: c0 at time 0, c1 at time 1"
    );
    assert!(matches!(s.objects[1].shape, Shape::MovingSphere { time0: 0.0, time1: 1.0, radius: 0.4, .. }));
    assert!(matches!(s.objects[3].shape, Shape::Cone { base_radius: 0.4, apex_radius: 0.0, .. }));
    // `al`: a rectangle centred on its position, perpendicular to its direction, w by h.
    let light = s.lights[0];
    let LightShape::Parallelogram { ends: [e1, e2], .. } = light.shape else { panic!("an area light") };
    let (u, v) = (e1 - light.position, e2 - light.position);
    assert!((u.length() - 1.5).abs() < 1e-6 && (v.length() - 1.0).abs() < 1e-6);
    assert!(u.dot(Vec3A::Z).abs() < 1e-6 && v.dot(Vec3A::Z).abs() < 1e-6 && u.dot(v).abs() < 1e-6);
    assert!((light.position + (u + v) * 0.5).abs_diff_eq(Vec3A::new(0.0, 0.0, 4.0), 1e-6));
    assert_eq!(s.lights[1].color, Vec3::new(0.4, 0.4, 0.3));
    let features = s.features(&RenderOptions::default()).unwrap();
    assert!(features.area_lights && features.motion_blur);
    assert_eq!(renders_a_picture(s).len(), 1, "the missing cubemap, again at render time");
    round_trips(s);
}

fn message(text: &str) -> String {
    parse(text, "x.p3f", &LoadOptions::default()).expect_err("must fail").to_string()
}

const CAMERA: &str = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8\n";

/// Files of programs that give no material: their objects are white and diffuse, as `f 1 1 1 1 0 0 0 0 1 0 1`
/// makes them.
#[test]
fn objects_before_any_material_are_white_and_diffuse_with_a_warning() {
    let text = format!("{CAMERA}l 0 5 5\ns 0 0 0 1\nbox 2 0 0 3 1 1\nf 1 0 0 1 0 0 0 0\ns 0 2 0 1\n");
    let l = parse(&text, "plain.nff", &LoadOptions::default()).unwrap();
    let warnings: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        warnings,
        [
            "plain.nff:3:1: warning: 's' comes before any material: it takes a white diffuse one, as 'f 1 1 1 1 0 0 0 0 1 \
          0 1' gives"
        ]
    );
    let written = parse(&format!("{CAMERA}f 1 1 1 1 0 0 0 0 1 0 1\n"), "f.p3f", &LoadOptions::default()).unwrap();
    assert_eq!(l.scene.materials[0], written.scene.materials[0]);
    assert_eq!((l.scene.materials.len(), l.scene.materials[1].diffuse), (2, Vec3::X), "the file's own 'f' after it");
    let materials: Vec<u32> = l.scene.objects.iter().map(|o| o.material).collect();
    assert_eq!(materials, [0, 0, 1], "the two first objects take the white one");
    let strict = LoadOptions { strict: true, ..LoadOptions::default() };
    let e = parse(&text, "plain.nff", &strict).unwrap_err().to_string();
    assert!(
        e.starts_with("plain.nff:3:1: 's' comes before any material")
            && e.ends_with("(an error when loading strictly)"),
        "{e}"
    );
}

/// Whole numbers written as decimals, as programs that print every number as a float write them.
#[test]
fn whole_numbers_written_as_decimals_are_read_with_a_warning() {
    let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 512.0 2.56e2\nl 1 1 1\n\
                f 1 1 1 1 0 0 0 0 0 0 1\np 3.\n0 0 0\n1 0 0\n0 1 0\n";
    let l = parse(text, "floats.p3f", &LoadOptions::default()).unwrap();
    assert_eq!((l.scene.view.width, l.scene.view.height), (512, 256));
    assert_eq!(kinds(&l.scene), ["p"]);
    let warnings: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        warnings,
        [
            "floats.p3f:1:61: warning: resolution width '512.0' is a whole number written as a decimal: read as 512",
            "floats.p3f:1:67: warning: resolution height '2.56e2' is a whole number written as a decimal: read as 256",
            "floats.p3f:4:3: warning: polygon vertex count '3.' is a whole number written as a decimal: read as 3",
        ]
    );
    let strict = LoadOptions { strict: true, ..LoadOptions::default() };
    let e = parse(text, "floats.p3f", &strict).unwrap_err().to_string();
    assert!(
        e.starts_with("floats.p3f:1:61: resolution width '512.0' is a whole number")
            && e.ends_with("(an error when loading strictly)"),
        "{e}"
    );
    for (field, expected) in [
        ("512.5 256", "floats.p3f:1:61: expected an integer (resolution width), found '512.5'"),
        ("1e9 256", "floats.p3f:1:61: expected resolution width in 1..=16384, found '1e9'"),
    ] {
        let text = text.replace("512.0 2.56e2", field);
        let e = parse(&text, "floats.p3f", &LoadOptions::default()).unwrap_err().to_string();
        assert!(e.starts_with(expected), "{e}");
    }
}

#[test]
fn malformed_variants_say_what_was_expected() {
    let f = "f 1 1 1 1 1 1 1 1 1 0 1\n";
    let cases: Vec<(String, &str)> = vec![
        (
            format!("{CAMERA}f 1 1 1 1 1 1 1 1 1\n"),
            "x.p3f:2:1: expected 8 (NFF: r g b Kd Ks shine T ior) or 11 (p3f: dr dg db Kd sr sg sb Ks shine T ior) \
             numbers after 'f', found 9 numbers",
        ),
        (
            format!("{CAMERA}mat 1 1 1 1 1 1 1 1 1 1\n"),
            "x.p3f:2:1: expected 8 (NFF: r g b Kd Ks shine T ior) or 11 (p3f: dr dg db Kd sr sg sb Ks shine T ior) \
             numbers after 'mat', found 10 numbers",
        ),
        (
            format!("{CAMERA}{f}ms 0 0 0 1 1 1 0.5 0\n"),
            "x.p3f:3:1: expected 7 (c0 c1 r) or 9 (c0 c1 r t0 t1) numbers after 'ms', found 8 numbers",
        ),
        (
            format!("{CAMERA}l 1 2 3 4\n"),
            "x.p3f:2:1: expected 3 (x y z), 6 (x y z r g b) or 7 (x y z r g b size) numbers after 'l', found 4 numbers",
        ),
        (
            format!("{CAMERA}l 4\n"),
            "x.p3f:2:1: expected 3 (x y z), 6 (x y z r g b) or 7 (x y z r g b size) numbers after 'l', found 1 number",
        ),
        (
            format!("{CAMERA}al 0 0 4 0 0 -1 1 1 1\n"),
            "x.p3f:2:1: expected 8 (x y z ax ay az w h) or 11 (… r g b) numbers after 'al', found 9 numbers",
        ),
        (format!("{CAMERA}al 0 0 4 0 0 0 1 1\n"), "x.p3f:2:1: expected an area light direction that is not zero"),
        (
            format!("{CAMERA}light spot 0 0 0 1 1 1\n"),
            "x.p3f:2:7: expected a light kind (punctual or quad) after 'light', found 'spot'",
        ),
        (
            format!("{CAMERA}light quad 0 0 0 1 1 1 1 0 0 0 1 0 65\n"),
            "x.p3f:2:36: expected quad light grid resolution (0: the render's) in 0..=64, found '65'",
        ),
        (
            "accel kdtree\n".to_owned(),
            "x.p3f:1:7: expected an accelerator (0 or none, 1 or grid, 2 or bvh), found 'kdtree'",
        ),
        (
            format!("{CAMERA}{f}npl 0 0 0 1\n"),
            "x.p3f:3:1: expected a plane normal that is not zero and a plane at a finite distance",
        ),
        (format!("{CAMERA}{f}s 0 0 0 -2e19\n"), "x.p3f:3:9: expected a sphere radius within ±4e18, found '-2e19'"),
        (
            format!("{CAMERA}{f}c 0 0 0 1 0 0 1 5e18\n"),
            "x.p3f:3:17: expected a coordinate (cone apex radius) within ±4e18 (squared distances beyond overflow \
             single precision), found '5e18'",
        ),
        (
            format!("{CAMERA}{f}p 3\n0 0 0\n1e20 0 0\n0 1 0\n"),
            "x.p3f:5:1: expected a coordinate (polygon vertex 2 x) within ±4e18 (squared distances beyond overflow \
             single precision), found '1e20'",
        ),
        (
            format!("{CAMERA}{f}mesh 3 1\n0 0 0\n1 0 0\n0 -5e18 0\n1 2 3\n"),
            "x.p3f:6:3: expected a coordinate (mesh vertex 3 y) within ±4e18 (squared distances beyond overflow \
             single precision), found '-5e18'",
        ),
        ("b 0.1 0.2\nv".to_owned(), "x.p3f:2:1: expected a number (background colour b), found 'v'"),
        ("v\nfrom 0 0 5\nat 0 0 0\nupp 0 1 0\n".to_owned(), "x.p3f:4:1: expected 'up', found 'upp'"),
        (
            "camera eye 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0\n".to_owned(),
            "x.p3f:2:1: expected 'resolution', found the end of the file",
        ),
        ("camera at 0 0 0 up 0 1 0\n".to_owned(), "x.p3f:2:1: expected 'eye', found the end of the file"),
        ("v from 0 0 5 at 0 0 0 from 1 1 1\n".to_owned(), "x.p3f:1:23: camera keyword 'from' given twice"),
        (
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8 focal 0\n".to_owned(),
            "x.p3f:1:71: expected a positive focal ratio, found '0'",
        ),
    ];
    for (text, expected) in &cases {
        assert_eq!(&message(text), expected, "for input:\n{text}");
    }
}

#[test]
fn camera_keywords_in_any_order_and_an_unknown_one_after_them() {
    let text =
        "v resolution 8 6 angle 30 up 0 1 0 at 0 0 0 hither 0.1 from 0 0 5 lens 2\nf 1 1 1 1 0 1 0 0\ns 0 0 0 1\n";
    let l = parse(text, "any.p3f", &LoadOptions::default()).unwrap();
    assert_eq!((l.scene.view.width, l.scene.view.height, l.scene.view.hither), (8, 6, 0.1));
    assert_eq!(l.scene.view.from, Vec3A::new(0.0, 0.0, 5.0));
    assert_eq!(l.warnings.len(), 1);
    assert_eq!(l.warnings[0].to_string(), "any.p3f:1:67: warning: unknown tag 'lens': skipped 'lens 2'");
    assert_eq!(l.scene.objects.len(), 1);
}

#[test]
fn warnings_found_before_a_fatal_error_come_with_it() {
    let text = format!("{CAMERA}Sphere of glass\nF 1 1 1\nf 1 1 1 1 1 1 1 1 1\n");
    let e = parse(&text, "w.p3f", &LoadOptions::default()).unwrap_err();
    let shown: Vec<String> = e.warnings().iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        [
            "w.p3f:2:1: warning: unknown tag 'Sphere': skipped 'Sphere of glass'",
            "w.p3f:3:1: warning: unknown tag 'F' (tags are lower case: 'f'): skipped 'F 1 1 1'",
        ]
    );
    assert!(e.to_string().starts_with("w.p3f:4:1: expected 8 (NFF"), "{e}");
}

#[test]
fn shapes_without_a_surface_are_skipped_with_a_warning() {
    let text = format!(
        "{CAMERA}f 1 1 1 1 0 1 0 0\ns 0 0 0 1e-50\ns 0 0 0 0e5\nsm 0 0 0 1 0 0 0 0 1\nc 0 0 0 0 0 1 0 -0\nc\n1 2 3 1\n1 2 3 0.5\n\
         mesh 3 0\n0 0 0\n1 0 0\n0 1 0\ns 1 1 1 1\n"
    );
    let l = parse(&text, "d.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        [
            "d.p3f:3:9: warning: a sphere radius of '1e-50', which rounds to 0 in single precision, leaves no surface: \
             the sphere is skipped",
            "d.p3f:4:9: warning: a sphere radius of '0e5' leaves no surface: the sphere is skipped",
            "d.p3f:5:16: warning: a moving sphere radius of '0' leaves no surface: the sphere is skipped",
            "d.p3f:6:1: warning: a cone whose radii are both 0 has no surface: skipped",
            "d.p3f:7:1: warning: a cone whose base and apex are one point has no surface: skipped",
            "d.p3f:10:8: warning: a mesh of 0 triangles has no surface: skipped",
        ]
    );
    assert_eq!(kinds(&l.scene), ["s"], "only the last sphere has a surface");
    let strict = LoadOptions { strict: true, ..LoadOptions::default() };
    let e = parse(&text, "d.p3f", &strict).unwrap_err().to_string();
    assert!(
        e.starts_with("d.p3f:3:9: a sphere radius of '1e-50'") && e.ends_with("(an error when loading strictly)"),
        "{e}"
    );
}

#[test]
fn a_bare_env_tag_names_no_cubemap_and_leaves_the_next_line_alone() {
    let text = format!("env\n{CAMERA}f 1 1 1 1 0 1 0 0\ns 0 0 0 1\n");
    let l = parse(&text, "e.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(shown, ["e.p3f:1:1: warning: 'env' without a cubemap folder name on its line: ignored"]);
    assert_eq!((l.scene.env, l.scene.view.width), (None, 8));
}

#[test]
fn a_second_camera_block_is_the_one_used_with_a_warning() {
    let text = format!(
        "{CAMERA}f 1 1 1 1 0 1 0 0\ns 0 0 0 1\nv from 0 0 9 at 0 0 0 up 0 1 0 angle 30 hither 0 resolution 4 4\n"
    );
    let l = parse(&text, "v.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        ["v.p3f:4:1: warning: a second camera block replaces the one at line 1: the scene is seen from this one"]
    );
    assert_eq!((l.scene.view.from.z, l.scene.view.width), (9.0, 4));
}

#[test]
fn stray_numbers_and_unknown_lines_with_their_numbers_are_skipped() {
    let text = format!("{CAMERA}f 1 1 1 1 0 1 0 0\ns 0 0 0 1 7 8\nwobble 1 2 3\n4 5 6\n7 8 9\ns 1 1 1 1\n");
    let l = parse(&text, "n.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        [
            "n.p3f:3:11: warning: unexpected numbers (the first of 2) '7' where a tag was expected, skipped",
            "n.p3f:4:1: warning: unknown tag 'wobble': skipped 'wobble 1 2 3' and the 2 lines of numbers after it",
        ]
    );
    assert_eq!(l.scene.objects.len(), 2);
}

#[test]
fn lines_ended_by_a_lone_carriage_return_are_lines() {
    // Classic Mac OS text: a comment ends at its CR, and free text skips its own line alone.
    let text = "# the floor and a ball\rv\rfrom 0 0 5\rat 0 0 0\rup 0 1 0\rangle 45\rhither 0\rresolution 8 8\r\
                Floor\rf 1 1 1 1 0 1 0 0\rp 3\r-1 -1 0\r1 -1 0\r0 1 0\rs 0 0 0 1 9\r";
    let l = parse(text, "mac.nff", &LoadOptions::default()).unwrap();
    assert_eq!(kinds(&l.scene), ["p", "s"]);
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        [
            "mac.nff:9:1: warning: unknown tag 'Floor': skipped 'Floor'",
            "mac.nff:15:11: warning: unexpected number '9' where a tag was expected, skipped",
        ]
    );
    let e = parse_bytes(b"v\rfrom 0 0 \xff", "mac.nff", &LoadOptions { strict: true, ..Default::default() });
    assert_eq!(e.unwrap_err().to_string(), "mac.nff:2:10: byte 0xFF is not UTF-8");
}

#[test]
fn text_that_is_not_utf8_is_read_as_latin1_with_a_warning() {
    let dir = std::env::temp_dir().join(format!("raylume-latin1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("caf\u{e9}.p3f");
    let mut bytes = format!("{CAMERA}# la sc\u{e8}ne de Ren").into_bytes();
    bytes.extend_from_slice(&[0xE9, b'\n']);
    bytes.extend_from_slice(b"f 1 1 1 1 0 1 0 0\ns 0 0 0 1\n");
    std::fs::write(&path, &bytes).unwrap();
    // Valid UTF-8 (the è) before the Latin-1 byte: the column counts characters.
    let l = load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(l.scene.objects.len(), 1);
    assert_eq!(l.warnings.len(), 1);
    assert_eq!((l.warnings[0].line, l.warnings[0].column), (2, 18));
    assert!(l.warnings[0].message.starts_with("byte 0xE9 is not UTF-8"), "{}", l.warnings[0]);
    let e = load(&path, &LoadOptions { strict: true, ..Default::default() }).unwrap_err().to_string();
    assert!(e.ends_with(":2:18: byte 0xE9 is not UTF-8"), "{e}");
    // A byte-order mark is not a tag.
    assert!(parse(&format!("\u{feff}{CAMERA}"), "bom.p3f", &LoadOptions::default()).unwrap().warnings.is_empty());
    // A folder is not a scene file.
    assert!(matches!(load(&dir, &LoadOptions::default()), Err(SceneError::Io { .. })));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn utf16_text_is_read_as_such_with_a_warning() {
    let text = format!("{CAMERA}f 1 1 1 1 0 1 0 0\r\ns 0 0 0 1 # caf\u{e9}\r\n");
    let le: Vec<u8> = text.encode_utf16().flat_map(u16::to_le_bytes).collect();
    let be: Vec<u8> = text.encode_utf16().flat_map(u16::to_be_bytes).collect();
    let cases = [
        ([&b"\xFF\xFE"[..], &le].concat(), "little-endian"),
        ([&b"\xFE\xFF"[..], &be].concat(), "big-endian"),
        (le.clone(), "little-endian"),
        (be.clone(), "big-endian"),
    ];
    for (bytes, order) in &cases {
        let l = parse_bytes(bytes, "u.p3f", &LoadOptions::default()).unwrap();
        assert_eq!(kinds(&l.scene), ["s"], "{order}");
        let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
        assert_eq!(
            shown,
            [format!(
                "u.p3f:1:1: warning: the file is UTF-16 ({order}) text, not ASCII or UTF-8: it is read as UTF-16"
            )]
        );
        let e = parse_bytes(bytes, "u.p3f", &LoadOptions { strict: true, ..Default::default() }).unwrap_err();
        assert_eq!(e.to_string(), format!("u.p3f:1:1: the file is UTF-16 ({order}) text, not ASCII or UTF-8"));
    }
    // Its errors have their positions in the decoded text, after the warning.
    let bad: Vec<u8> = "v from 0 0 x".encode_utf16().flat_map(u16::to_le_bytes).collect();
    let e = parse_bytes(&[&b"\xFF\xFE"[..], &bad].concat(), "u.p3f", &LoadOptions::default()).unwrap_err();
    assert_eq!(e.to_string(), "u.p3f:1:12: expected a number (from z), found 'x'");
    assert_eq!(e.warnings().len(), 1);
}

#[test]
fn a_binary_file_is_refused_at_once_saying_what_it_holds() {
    let cases: [(&[u8], &str); 6] = [
        (b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR", "a PNG image"),
        (b"\x1f\x8b\x08\x08\0\0\0\0\0\x03s.nff\0", "gzip-compressed data (decompress it first)"),
        (b"\xff\xd8\xff\xe0\0\x10JFIF\0", "a JPEG image"),
        (b"glTF\x02\0\0\0", "a binary glTF scene"),
        (&[0; 40], "binary data (byte 0x00, a control character, in its first 16 bytes)"),
        (b"v from 0\x01\x02 0 5", "binary data (byte 0x01, a control character, in its first 16 bytes)"),
    ];
    for (bytes, kind) in cases {
        let e = parse_bytes(bytes, "b.nff", &LoadOptions::default()).unwrap_err();
        assert_eq!(e.to_string(), format!("b.nff:1:1: expected the text of a scene, found {kind}"));
        assert!(e.warnings().is_empty(), "{:?}", e.warnings());
    }
    // Text with a control character further on is read, with what it cannot read skipped.
    let late = format!("{CAMERA}f 1 1 1 1 0 1 0 0\ns 0 0 0 1\n\0\0\0\n");
    let l = parse_bytes(late.as_bytes(), "late.p3f", &LoadOptions::default()).unwrap();
    assert_eq!((kinds(&l.scene), l.warnings.len()), (vec!["s"], 1));
}

fn shared() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipped: ../shared is absent");
        None
    }
}

#[test]
fn the_library_renders_a_cubemap_scene_with_default_options() {
    let Some(shared) = shared() else { return };
    let scene = load(shared.join("scenes/balls_low.p3f"), &LoadOptions::default()).unwrap().scene;
    let small = RenderOptions { resolution: Some((48, 48)), ..RenderOptions::default() };
    let with_env = scene.render(&small, &|| {}).unwrap();
    assert!(with_env.warnings.is_empty());
    let without = scene.render(&RenderOptions { use_env: false, ..small.clone() }, &|| {}).unwrap();
    assert_ne!(with_env.film.pixels(), without.film.pixels(), "escaping rays see the skybox");
    // The same scene parsed from a string finds the cubemap through the folders it is given.
    let text = std::fs::read_to_string(shared.join("scenes/balls_low.p3f")).unwrap();
    let parsed = parse(&text, "balls_low.p3f", &LoadOptions::default()).unwrap();
    assert_eq!(parsed.warnings.len(), 1, "no skybox beside the current folder");
    let options = LoadOptions { env_dirs: vec![shared.clone()], ..LoadOptions::default() };
    assert!(parse(&text, "balls_low.p3f", &options).unwrap().warnings.is_empty());
    let found = RenderOptions { env_dirs: vec![shared], ..small };
    assert_eq!(parsed.scene.render(&found, &|| {}).unwrap().film.pixels(), with_env.film.pixels());
}

#[test]
fn what_an_obj_skips_is_warned_about_in_the_scene() {
    let dir = std::env::temp_dir().join(format!("raylume-obj-warnings-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("m.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\nf 1 2 3\nf 1 2 2\n").unwrap();
    let text = format!("{CAMERA}f 1 1 1 1 0 1 0 0\nobj m.obj\n");
    let options = LoadOptions { base_dir: Some(dir.clone()), ..LoadOptions::default() };
    let l = parse(&text, "o.p3f", &options).unwrap();
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    let obj = dir.join("m.obj").display().to_string();
    // A face without area is said once, at its line in the OBJ file.
    assert_eq!(
        shown,
        [
            format!("{obj}:4:1: warning: a line (l) has no surface: skipped"),
            format!("{obj}:6:1: warning: this face's vertices are collinear in f32 (no area): it is never hit"),
        ]
    );
    assert_eq!(kinds(&l.scene), ["mesh"]);
    let strict = LoadOptions { strict: true, ..options };
    let e = parse(&text, "o.p3f", &strict).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "o.p3f:3:5: obj 'm.obj': {obj}:4:1: a line (l) has no surface: skipped (an error when loading strictly)"
        )
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn numbers_left_behind_after_an_entry_are_skipped_and_the_entry_read_from_its_line() {
    // The vertices of a commented-out polygon after a material's line.
    let text = format!("{CAMERA}l 0 5 5\nf 1 1 1 0 0 4.8 0 0\n#p 3\n0 0 0\n1 0 0\n0 1 0\ns 0 0 0 1\n");
    let l = parse(&text, "n.nff", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = l.warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        ["n.nff:5:1: warning: unexpected numbers (the first of 9) '0' where a tag was expected, skipped"]
    );
    assert_eq!((kinds(&l.scene), l.scene.materials[0].shine), (vec!["s"], 4.8));
}

#[test]
fn a_scene_without_lights_renders_with_a_warning() {
    let text = format!("{CAMERA}f 1 1 1 1 0 1 0 0\ns 0 0 0 1\n");
    let scene = parse(&text, "d.p3f", &LoadOptions::default()).unwrap().scene;
    let warnings = renders_a_picture_or_not(&scene);
    assert_eq!(
        warnings,
        ["warning: the scene has no lights: its surfaces show only what they reflect or transmit (the shading model \
          has no ambient term)"]
    );
    let strict = RenderOptions { strict: true, ..RenderOptions::default() };
    let e = scene.render(&strict, &|| {}).unwrap_err().to_string();
    assert!(e.starts_with("the scene has no lights") && e.ends_with("(an error when rendering strictly)"), "{e}");
}

#[test]
fn a_scene_without_objects_renders_its_background_with_a_warning() {
    // Every object of the file under a tag the reader does not know.
    let text = format!("{CAMERA}l 1 1 1\nppt 3\n0 0 0\n1 0 0\n0 1 0\n");
    let loaded = parse(&text, "d.nff", &LoadOptions::default()).unwrap();
    assert_eq!(loaded.warnings.len(), 1, "the unknown tag: {:?}", loaded.warnings);
    let warnings = renders_a_picture_or_not(&loaded.scene);
    assert_eq!(warnings, ["warning: the scene has no objects: the image is its background colour"]);
    let strict = RenderOptions { strict: true, ..RenderOptions::default() };
    let e = loaded.scene.render(&strict, &|| {}).unwrap_err().to_string();
    assert!(e.starts_with("the scene has no objects") && e.ends_with("(an error when rendering strictly)"), "{e}");
}

/// The render's warnings, whatever its picture.
fn renders_a_picture_or_not(scene: &Scene) -> Vec<String> {
    let out = scene.render(&RenderOptions::default(), &|| {}).unwrap();
    out.warnings.iter().map(|w| w.to_string()).collect()
}
