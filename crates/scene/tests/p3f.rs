//! The p3f loader: every tag, malformed input with its message and position, limits, round trips,
//! and every scene of the course.

use std::path::{Path, PathBuf};

use raylume_geometry::{Vec3, Vec3A};
use raylume_scene::p3f::{LoadOptions, load, parse};
use raylume_scene::{Scene, SceneError, Shape};

const HEADER: &str = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.01\nresolution 64 48\n";

fn ok(text: &str) -> Scene {
    match parse(text, "t.p3f", &LoadOptions::default()) {
        Ok(loaded) => {
            assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
            loaded.scene
        }
        Err(e) => panic!("{e}"),
    }
}

fn err(text: &str) -> String {
    parse(text, "bad.p3f", &LoadOptions::default()).expect_err("must fail").to_string()
}

#[test]
fn camera_with_and_without_lens() {
    let s = ok(HEADER);
    assert_eq!(s.view.from, Vec3A::new(0.0, 0.0, 5.0));
    assert_eq!((s.view.width, s.view.height), (64, 48));
    assert_eq!((s.view.aperture, s.view.focal), (0.0, 1.0));
    let s = ok(&format!("{HEADER}aperture 12 focal 1.5\n"));
    assert_eq!((s.view.aperture, s.view.focal), (12.0, 1.5));
}

#[test]
fn every_tag() {
    let text = format!(
        "accel 2\nspp 16\nbclr 0.1 0.2 0.3\n{HEADER}aperture 0 focal 1\n\
         l 1 2 3 0.5 0.5 0.5\nl 4 5 6\n\
         f 1 0.9 0.7 0.5 1 1 1 0.5 30.0827 0 1 #a comment right after a token\n\
         s 0 0 0 0.5\nsm 0 0 0 1 1 1 0.5 0 3\nbox 0 0 0 1 2 3\n\
         p 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\
         pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n\
         pl 12 12 -0.5 -12 12 -0.5 -12 -12 -0.5\n\
         c 0 0 0 1 0 2 0 0.5\n\
         f 1 1 1 0 1 1 1 0.2 20 1 1.35\n\
         mesh 4 2\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n1 2 3\n1 3 -1\n"
    );
    let s = ok(&text);
    assert_eq!(s.accel_hint, Some(raylume_scene::AccelHint::Bvh));
    assert_eq!(s.spp_hint, Some(16));
    assert_eq!(s.background, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.lights[1].color, Vec3::ONE, "a light without colour is white");
    assert_eq!(s.materials.len(), 2);
    assert_eq!(s.materials[0].shine, 30.0827);
    assert_eq!(s.materials[1].ior, 1.35);
    let kinds: Vec<&str> = s
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
        .collect();
    assert_eq!(kinds, ["s", "sm", "box", "p", "pp", "pl", "c", "mesh"]);
    assert_eq!(s.objects[7].material, 1);
    let Shape::Mesh { triangles, .. } = &s.objects[7].shape else { unreachable!() };
    assert_eq!(triangles, &vec![[0, 1, 2], [0, 2, 3]], "1-based, and -1 is the last vertex");
    assert_eq!(s.primitive_count(), 1 + 1 + 1 + 2 + 1 + 1 + 1 + 2);
    assert_eq!(s.shutter().max, 3.0);
}

#[test]
fn malformed_files_name_file_line_column_and_what_was_expected() {
    let cases: &[(&str, &str)] = &[
        ("v\nfrom 0 0 x", "bad.p3f:2:10: expected a number (from z), found 'x'"),
        ("v\nto 0 0 1", "bad.p3f:2:1: expected 'from', found 'to'"),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\ns 0 0"),
            "bad.p3f:9:6: expected a number (sphere centre z), found the end of the file",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\ns 0 0 NaN 1"),
            "bad.p3f:9:7: expected a finite number (sphere centre z), found 'NaN'",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\ns 0 0 0 inf"),
            "bad.p3f:9:9: expected a finite number (sphere radius), found 'inf'",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\ns 0 0 0 1e19"),
            "bad.p3f:9:9: expected a sphere radius within ±4e18, found '1e19'",
        ),
        (
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 0 512",
            "bad.p3f:1:61: expected resolution width in 1..=16384, found '0'",
        ),
        (
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 1000000 1000000",
            "bad.p3f:1:61: expected resolution width in 1..=16384, found '1000000'",
        ),
        (
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 16384 16384",
            "bad.p3f:1:61: resolution 16384 x 16384 exceeds 134217728 pixels",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\nmesh 3 1\n0 0 0 1 0 0 0 1 0\n1 2 4"),
            "bad.p3f:11:5: vertex index 3 of mesh triangle 1 is 4, out of range for 3 vertices",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\nmesh 100000000 1\n0 0 0"),
            "bad.p3f:9:6: mesh vertex count is 100000000, but the rest of the file holds at most 5 numbers",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\nmesh 3 100000000\n0 0 0 1 0 0 0 1 0\n1 2 3"),
            "bad.p3f:9:8: mesh of 3 vertices and 100000000 triangles, but the rest of the file holds at most 13 numbers",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\np 2\n0 0 0 1 1 1"),
            "bad.p3f:9:3: expected polygon vertex count in 3..=4294967295, found '2'",
        ),
        (
            &format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\npl 0 0 0 1 1 1 2 2 2"),
            "bad.p3f:9:1: expected three plane points that are not collinear",
        ),
        ("bclr 0 0 0\n", "bad.p3f:2:1: expected a camera ('v' entity), found none in the file"),
        (
            &format!("{HEADER}f 1 1 1"),
            "bad.p3f:8:1: expected 8 (NFF: r g b Kd Ks shine T ior) or 11 (p3f: dr dg db Kd sr sg sb Ks shine T ior) \
             numbers after 'f', found 3 numbers",
        ),
        ("v from 0 0 5 at 0 0 5 up 0 1 0 angle 45 hither 0 resolution 4 4", "bad.p3f:1:14: expected 'from' != 'at'"),
        (
            "v from 0 0 5e-30 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 4 4",
            "bad.p3f:1:18: expected 'from' and 'at' further apart: their distance, 5e-30, squares to 0 in single \
             precision",
        ),
        (
            "v from 0 0 5 at 0 0 0 up 0 0 -3 angle 45 hither 0 resolution 4 4",
            "bad.p3f:1:26: expected 'up' not parallel to the view direction (and not too short to give it a side)",
        ),
        (
            "v from 0 0 5 at 0 0 0 up 0 1e-30 0 angle 45 hither 0 resolution 4 4",
            "bad.p3f:1:26: expected 'up' not parallel to the view direction (and not too short to give it a side)",
        ),
        (
            // Parallel in real numbers; the normalised view direction's rounding alone gives a side.
            "v from 2.1 1.3 1.7 at 0 0 0 up 2.1 1.3 1.7 angle 45 hither 0 resolution 4 4",
            "bad.p3f:1:32: expected 'up' not parallel to the view direction (and not too short to give it a side)",
        ),
        (
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 180 hither 0 resolution 4 4",
            "bad.p3f:1:38: expected an angle in (0, 180) degrees, found '180'",
        ),
        ("accel 7", "bad.p3f:1:7: expected accelerator (0 none, 1 grid, 2 BVH) in 0..=2, found '7'"),
        (
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 99999999999999999999 4",
            "bad.p3f:1:61: expected resolution width in 1..=16384, found '99999999999999999999'",
        ),
        ("accel 2.5", "bad.p3f:1:7: expected an integer (accelerator (0 none, 1 grid, 2 BVH)), found '2.5'"),
    ];
    for (text, expected) in cases {
        assert_eq!(&err(text), expected, "for input:\n{text}");
    }
}

#[test]
fn errors_are_values_with_positions() {
    let e = parse("v\nfrom 0 0 x", "f.p3f", &LoadOptions::default()).unwrap_err();
    let SceneError::Syntax { file, line, column, .. } = e else { panic!("a syntax error") };
    assert_eq!((file.as_str(), line, column), ("f.p3f", 2, 10));
    let missing = load(Path::new("/nonexistent/scene.p3f"), &LoadOptions::default()).unwrap_err();
    assert!(matches!(missing, SceneError::Io { .. }));
    assert!(missing.to_string().starts_with("/nonexistent/scene.p3f: "), "{missing}");
}

#[test]
fn unknown_tags_warn_and_strict_makes_them_errors() {
    let text = format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\nzz 0 0 0 1 1 1 0.5\ns 0 0 0 1\n");
    let loaded = parse(&text, "w.p3f", &LoadOptions::default()).unwrap();
    let warnings = &loaded.warnings;
    assert_eq!(warnings.len(), 1);
    assert_eq!((warnings[0].line, warnings[0].column), (9, 1));
    assert!(warnings[0].to_string().starts_with("w.p3f:9:1: warning: unknown tag 'zz'"), "{}", warnings[0]);
    assert_eq!(loaded.scene.objects.len(), 1, "the numbers of the unknown tag are skipped, the sphere is kept");
    let e = parse(&text, "w.p3f", &LoadOptions { strict: true, ..Default::default() }).unwrap_err().to_string();
    assert!(e.starts_with("w.p3f:9:1: unknown tag 'zz'"), "{e}");
}

/// A negative colour component is kept as given (it takes light away), with a warning at its number;
/// `--strict` refuses it.
#[test]
fn negative_colours_warn_at_their_numbers() {
    let text = format!("bclr 0.1 -0.2 0.3\n{HEADER}l 1 1 1 1 1 -1\nf 1 1 1 1 1 1 1 1 1 0 1\ns 0 0 0 1\n");
    let loaded = parse(&text, "c.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = loaded.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(
        shown,
        [
            "c.p3f:1:10: warning: background colour g is negative (-0.2): it takes light away",
            "c.p3f:9:13: warning: light colour b is negative (-1): it takes light away",
        ]
    );
    assert_eq!(loaded.scene.background.y, -0.2);
    let e = parse(&text, "c.p3f", &LoadOptions { strict: true, ..Default::default() }).unwrap_err().to_string();
    assert!(e.starts_with("c.p3f:1:10: background colour g is negative"), "{e}");
}

/// A box whose corners meet on two axes or more (a segment or a point) has no area: skipped with a
/// warning at its tag. Flat on one axis, it is a rectangle, and kept.
#[test]
fn boxes_without_area_are_skipped_with_a_warning() {
    let text = format!("{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\nbox 1 1 1 1 1 1\nbox 0 0 0 1 0 0\nbox 0 0 0 1 1 0\n");
    let loaded = parse(&text, "b.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = loaded.warnings.iter().map(ToString::to_string).collect();
    let warning = "warning: a box whose corners meet on two axes or more has no area: it is skipped";
    assert_eq!(shown, [format!("b.p3f:9:1: {warning}"), format!("b.p3f:10:1: {warning}")]);
    assert_eq!(loaded.scene.objects.len(), 1, "the rectangle is kept");
    let e = parse(&text, "b.p3f", &LoadOptions { strict: true, ..Default::default() }).unwrap_err().to_string();
    assert!(e.starts_with("b.p3f:9:1: a box whose corners meet"), "{e}");
}

/// Triangles whose vertices are collinear once in f32 are never hit (the accelerators leave them
/// out): the loader says so, naming the entity, and `--strict` refuses the file.
#[test]
fn triangles_that_are_never_hit_are_reported() {
    let text = format!(
        "{HEADER}f 1 1 1 1 1 1 1 1 1 0 1\np 3\n0 0 0\n1 0 0\n2 0 0\n\
         p 3\n0 0 0\n1 0 0\n0 1 0\n\
         p 3\n0 0 0\n1e-30 0 0\n0 1e-30 0\n\
         mesh 4 2\n0 0 0\n1 0 0\n0 1 0\n3 0 0\n1 2 3\n1 2 4\n"
    );
    let loaded = parse(&text, "n.p3f", &LoadOptions::default()).unwrap();
    let shown: Vec<String> = loaded.warnings.iter().map(ToString::to_string).collect();
    assert_eq!(shown.len(), 2, "{shown:?}");
    assert!(shown[0].starts_with("n.p3f:9:1: warning: polygon: its vertices are collinear"), "{}", shown[0]);
    assert!(shown[1].starts_with("n.p3f:21:1: warning: mesh: 1 of its 2 triangles"), "{}", shown[1]);
    assert_eq!(loaded.scene.objects.len(), 4, "the shapes are kept");
    let e = parse(&text, "n.p3f", &LoadOptions { strict: true, ..Default::default() }).unwrap_err().to_string();
    assert!(e.starts_with("n.p3f:9:1: polygon: its vertices are collinear"), "{e}");
}

#[test]
fn comments_anywhere() {
    let s = ok(&format!(
        "# leading comment\n{HEADER}#glass\nf 1 1 1 0 1 1 1 0.2 20 1 1.35 # trailing\ns 1 1 0 0.25#tight\n"
    ));
    assert_eq!(s.objects.len(), 1);
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
fn every_course_scene_loads_and_round_trips() {
    let Some(shared) = shared() else { return };
    let mut count = 0;
    for entry in std::fs::read_dir(shared.join("scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "p3f") {
            continue;
        }
        let loaded = load(&path, &LoadOptions { strict: true, ..Default::default() }).unwrap_or_else(|e| panic!("{e}"));
        assert!(loaded.warnings.is_empty());
        assert_eq!(loaded.dialect, raylume_scene::p3f::Dialect::P3f, "{}", path.display());
        let scene = loaded.scene;
        assert!(!scene.objects.is_empty(), "{}", path.display());
        let text = scene.to_p3f();
        let options = LoadOptions { strict: true, base_dir: scene.base_dir.clone(), ..Default::default() };
        let again = parse(&text, "roundtrip.p3f", &options).unwrap().scene;
        assert_eq!(again, scene, "round trip of {}", path.display());
        count += 1;
    }
    assert_eq!(count, 12);
}

#[test]
fn dragon_has_its_hundred_thousand_triangles() {
    let Some(shared) = shared() else { return };
    let start = std::time::Instant::now();
    let scene = load(shared.join("scenes/dragon.p3f"), &LoadOptions::default()).unwrap().scene;
    println!("dragon.p3f loaded in {:.3} s", start.elapsed().as_secs_f64());
    let mesh = scene.objects.iter().find_map(|o| match &o.shape {
        Shape::Mesh { vertices, triangles, .. } => Some((vertices.len(), triangles.len())),
        _ => None,
    });
    assert_eq!(mesh, Some((50_000, 100_000)));
}

#[test]
fn built_scene_round_trips_through_text() {
    use raylume_material::Phong;
    let scene = raylume_scene::SceneBuilder::new()
        .camera(Vec3A::new(0.1, 0.2, 5.3), Vec3A::ZERO, Vec3A::Y, 33.3, 17, 9)
        .background(Vec3::new(0.1, 0.7, 1.0 / 3.0))
        .env("skybox")
        .light(Vec3A::new(1.0 / 7.0, 2.0, 3.0), Vec3::new(0.3, 0.4, 0.5))
        .material(Phong { diffuse: Vec3::new(0.123_456_79, 0.5, 1e-7), kd: 0.3, ..Phong::default() })
        .sphere(Vec3A::new(1e-20, -3.5, 2e10), 0.25)
        .aabox(Vec3A::ZERO, Vec3A::ONE)
        .material(Phong { transmittance: 0.9, ior: 1.5, ..Phong::default() })
        .triangle(Vec3A::ZERO, Vec3A::X, Vec3A::Y)
        .plane([Vec3A::ZERO, Vec3A::X, Vec3A::Z])
        .mesh(vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y, Vec3A::ONE], vec![[0, 1, 2], [1, 3, 2]])
        .accel_hint(raylume_scene::AccelHint::Grid)
        .spp_hint(4)
        .build()
        .unwrap();
    let again = parse(&scene.to_p3f(), "rt.p3f", &LoadOptions::default()).unwrap().scene;
    assert_eq!(again, scene);
    assert!(raylume_scene::SceneBuilder::new().sphere(Vec3A::ZERO, 1.0).build().is_err());
}

#[test]
fn a_missing_cubemap_is_not_looked_for_when_it_will_not_be_used() {
    let text = "env no_such_sky\nv from 0 0 5 at 0 0 0 up 0 1 0 angle 40 hither 0 resolution 8 6\n";
    let warned = parse(text, "sky.p3f", &LoadOptions::default()).unwrap();
    assert_eq!(warned.warnings.len(), 1, "{:?}", warned.warnings);
    assert!(parse(text, "sky.p3f", &LoadOptions { strict: true, ..Default::default() }).is_err());
    let ignored = LoadOptions { strict: true, ignore_env: true, ..Default::default() };
    let loaded = parse(text, "sky.p3f", &ignored).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(loaded.scene.env.as_deref(), Some("no_such_sky"), "the scene still names it");
}

/// A message quotes at most 120 characters of a long line and says how many it leaves out; under
/// strict loading, what would be skipped is an error that says so.
#[test]
fn messages_quote_long_text_cut_and_strict_errors_say_why() {
    let long = "x".repeat(1_000_000);
    let text = format!("v from 0 0 5 at 0 0 0 up 0 1 0 angle 40 hither 0 resolution 8 6\nfoo {long}\n");
    let loaded = parse(&text, "long.p3f", &LoadOptions::default()).unwrap();
    let warning = loaded.warnings[0].to_string();
    assert!(warning.len() < 400, "{} bytes", warning.len());
    assert!(warning.contains(&format!("{}… (999884 more characters)", "x".repeat(116))), "{warning}");
    let strict = parse(&text, "long.p3f", &LoadOptions { strict: true, ..Default::default() }).unwrap_err();
    assert!(strict.to_string().starts_with("long.p3f:2:1: unknown tag 'foo'"), "{strict}");
    assert!(strict.to_string().ends_with("(an error when loading strictly)"), "{strict}");
}
