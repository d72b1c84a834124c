//! Procedural scenes, OBJ meshes and ray sets.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use raylume_geometry::{Aabb, Vec3A};
use raylume_scene::procedural::{Generator, mesh_view, mount, sphereflake};
use raylume_scene::rays::{camera_rays, random_rays, read_rays, write_hits, write_rays};
use raylume_scene::{Scene, Shape, obj, p3f};

fn shared() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!("skipped: ../shared is absent");
        None
    }
}

fn spheres(scene: &Scene) -> Vec<(Vec3A, f32)> {
    scene
        .objects
        .iter()
        .filter_map(|o| match o.shape {
            Shape::Sphere { center, radius } => Some((center, radius)),
            _ => None,
        })
        .collect()
}

#[test]
fn sphereflake_depth_1_is_the_course_balls_low() {
    let Some(shared) = shared() else { return };
    let course = p3f::load(shared.join("scenes/balls_low.p3f"), &Default::default()).unwrap().scene;
    let ours = sphereflake(1).unwrap();
    let (a, b) = (spheres(&course), spheres(&ours));
    assert_eq!(a.len(), b.len());
    // The same spheres (the course lists them in another order).
    for (ca, ra) in &a {
        assert!(b.iter().any(|(cb, rb)| (*ca - *cb).length() < 1e-5 && (ra - rb).abs() < 1e-5), "{ca:?} {ra} missing");
    }
    assert_eq!(ours.lights, course.lights);
    assert_eq!(ours.view, course.view);
}

#[test]
fn sizes_match_the_course_scenes_and_the_formulas() {
    // balls_low, balls_medium, balls_high: 10, 91 and 7381 spheres.
    for (depth, count) in [(1, 10), (2, 91), (4, 7381)] {
        assert_eq!(spheres(&sphereflake(depth).unwrap()).len(), count);
    }
    // mount_low, mount_high, mount_very_high: 8, 2048 and 32768 triangles (and 4 spheres).
    for (depth, count) in [(1, 8), (5, 2048), (7, 32768)] {
        assert_eq!(mount(depth).unwrap().primitive_count(), count + 4);
    }
    for g in [Generator::Balls, Generator::Tetra, Generator::Mount, Generator::Rings] {
        for size in 1..4 {
            let scene = g.generate(size).unwrap();
            assert_eq!(scene.primitive_count() as u64, g.primitives(size), "{g:?} {size}");
            let again = p3f::parse(&scene.to_p3f(), "gen.p3f", &Default::default()).unwrap().scene;
            assert_eq!(again, scene, "{g:?} {size} round trip");
        }
    }
    assert!(Generator::Balls.generate(9).is_err(), "too large is refused before anything is built");
    assert!("teapot".parse::<Generator>().is_err());
}

#[test]
fn fractal_mountain_has_no_cracks() {
    // Every edge inside the mountain is shared by exactly two triangles, with the same endpoints.
    let scene = mount(4).unwrap();
    let Some(Shape::Mesh { vertices, triangles, .. }) =
        scene.objects.iter().map(|o| &o.shape).find(|s| matches!(s, Shape::Mesh { .. }))
    else {
        panic!("a mesh")
    };
    let key = |v: Vec3A| (v.x.to_bits(), v.y.to_bits(), v.z.to_bits());
    let mut edges: HashMap<_, u32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (key(vertices[t[k] as usize]), key(vertices[t[(k + 1) % 3] as usize]));
            *edges.entry(if a < b { (a, b) } else { (b, a) }).or_default() += 1;
        }
    }
    let boundary = edges.values().filter(|&&c| c == 1).count();
    assert!(edges.values().all(|&c| c <= 2));
    // The boundary of a 2 x 2^4-per-side subdivided square: 4 * 16 edges, plus none inside.
    assert_eq!(boundary, 4 * 16);
}

#[test]
fn obj_meshes_load_and_place() {
    let Some(shared) = shared() else { return };
    let bunny = obj::load(shared.join("meshes/bunny.obj")).unwrap();
    let Shape::Mesh { ref vertices, ref triangles, .. } = bunny else { panic!("a mesh") };
    assert_eq!(triangles.len(), 3674);
    let bounds = Aabb::from_points(vertices.iter().copied());
    // The p3f extension places it with the current material, scaled and moved.
    let dir = std::env::temp_dir().join(format!("raylume-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(shared.join("meshes/bunny.obj"), dir.join("bunny.obj")).unwrap();
    let scene_path = dir.join("s.p3f");
    std::fs::write(&scene_path, "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8\nf 1 1 1 1 1 1 1 0 1 0 1\nobj bunny.obj 2 1 0 0\n").unwrap();
    let scene = p3f::load(&scene_path, &Default::default()).unwrap().scene;
    let Shape::Mesh { vertices: placed, .. } = &scene.objects[0].shape else { panic!("a mesh") };
    let placed_bounds = Aabb::from_points(placed.iter().copied());
    assert!((placed_bounds.min - (bounds.min * 2.0 + Vec3A::X)).length() < 1e-5);
    std::fs::write(
        &scene_path,
        "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8\nf 1 1 1 1 1 1 1 0 1 0 1\nobj missing.obj\n",
    )
    .unwrap();
    let e = p3f::load(&scene_path, &Default::default()).unwrap_err().to_string();
    assert!(e.contains("s.p3f:3:5: obj 'missing.obj'"), "{e}");
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    assert!(obj::load(dir.join("bad.obj")).is_err());
    let view = mesh_view(bunny, 64, 64);
    assert!(camera_rays(&view.view, 4096).len() == 4096);
}

/// Random rays scale with the scene: a scene 2^k times as large (k from -60 to 60) gets the same
/// rays with origins 2^k times as far, down to scenes far smaller than a micrometre.
#[test]
fn random_rays_scale_with_the_scene() {
    let bounds = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(3.0, 1.0, 4.0));
    let unit = random_rays(&bounds, 1000, 7);
    for k in [-60, -40, -20, 20, 60] {
        let s = 2.0f32.powi(k);
        let scaled = random_rays(&Aabb::new(bounds.min * s, bounds.max * s), 1000, 7);
        for (r, u) in scaled.iter().zip(&unit) {
            assert_eq!(r.origin, u.origin * s, "scale 2^{k}");
            assert!((r.dir - u.dir).length() < 1e-6, "scale 2^{k}: {} against {}", r.dir, u.dir);
        }
    }
}

#[test]
fn ray_sets_round_trip_and_reject_bad_files() {
    let bounds = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(3.0, 1.0, 4.0));
    let rays = random_rays(&bounds, 1000, 7);
    assert_eq!(rays, random_rays(&bounds, 1000, 7), "the same seed gives the same rays");
    let radius = bounds.diagonal().length() * 0.5 * 1.5;
    for r in &rays {
        assert!(((r.origin - bounds.centroid()).length() - radius).abs() < 1e-3 * radius);
        assert!((r.dir.length() - 1.0).abs() < 1e-5);
    }
    let mut bytes = Vec::new();
    write_rays(&mut bytes, &rays).unwrap();
    assert_eq!(read_rays(&mut bytes.as_slice()).unwrap(), rays);
    assert!(read_rays(&mut &bytes[..bytes.len() - 3]).is_err(), "truncated");
    let mut nan = bytes.clone();
    nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    assert!(read_rays(&mut nan.as_slice()).is_err());
    let mut hits = Vec::new();
    write_hits(&mut hits, &[Some((1.5, 3)), None]).unwrap();
    assert_eq!(hits.len(), 16);
    assert_eq!(&hits[8..12], &f32::INFINITY.to_le_bytes());
    assert_eq!(&hits[12..16], &u32::MAX.to_le_bytes());
}

/// Every size past the largest scene is refused before anything is made, the sizes whose counts
/// overflow 64 bits included.
#[test]
fn sizes_past_the_largest_scene_are_refused() {
    use raylume_scene::procedural::MAX_PRIMITIVES;
    for generator in [Generator::Balls, Generator::Tetra, Generator::Mount, Generator::Rings] {
        let largest = (0..=u32::MAX).find(|&s| generator.primitives(s) > MAX_PRIMITIVES).unwrap();
        for size in [largest, largest + 1, 31, 32, 33, 64, 100, 1000, u32::MAX - 1, u32::MAX] {
            if size < largest {
                continue;
            }
            assert!(generator.primitives(size) > MAX_PRIMITIVES, "{generator:?} {size}");
            let err = generator.generate(size).expect_err("too large");
            assert!(err.to_string().contains("expected a size"), "{generator:?} {size}: {err}");
        }
    }
}
