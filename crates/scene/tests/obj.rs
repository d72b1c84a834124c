//! OBJ files as editors and exporters write them: the mesh read, and messages that point at the
//! line and column of a malformed entry.

use raylume_scene::{Shape, obj};

const BOM: &[u8] = b"\xEF\xBB\xBF";

fn with_bom(text: &str) -> Vec<u8> {
    [BOM, text.as_bytes()].concat()
}

fn error(bytes: &[u8]) -> String {
    obj::parse(bytes, "m.obj").unwrap_err().to_string()
}

/// A UTF-8 byte-order mark before the first line is not part of it: the mesh is the one without
/// the mark, and messages give the same lines and columns.
#[test]
fn a_byte_order_mark_is_skipped() {
    let square = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\n";
    let plain = obj::parse(square.as_bytes(), "m.obj").unwrap();
    assert_eq!(obj::parse(&with_bom(square), "m.obj").unwrap(), plain);
    let Shape::Mesh { vertices, .. } = &plain else { unreachable!() };
    assert_eq!(vertices[0].to_array(), [-1.0, -1.0, 0.0]);

    let dangling = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    let expected =
        "m.obj:4:7: not a readable OBJ file (expected a vertex reference from 1 to 3 or from -3 to -1): 'f 1 2 4'";
    assert_eq!(error(dangling.as_bytes()), expected);
    assert_eq!(error(&with_bom(dangling)), expected);
    assert_eq!(
        error(&with_bom("f 1 2 3\n")),
        "m.obj:1:3: not a readable OBJ file (a face refers to a vertex, and no vertex precedes it): 'f 1 2 3'"
    );
    assert_eq!(
        error(&with_bom("v 1 x 0\n")),
        "m.obj:1: not a readable OBJ file (cannot parse a vertex position): 'v 1 x 0'"
    );
    // A mark followed by a comment line.
    let commented = with_bom("# header\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\n");
    assert_eq!(obj::parse(&commented, "m.obj").unwrap(), plain);
}

/// A `#` comment after an entry, as exporters write them, is ignored to the end of its line: the
/// mesh is the one without comments, numbers in a comment are not read as references, and
/// messages give the line and column of the entry, and show it without its comment.
#[test]
fn comments_after_entries_are_ignored() {
    let plain = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "m.obj").unwrap();
    let commented = [
        "v 0 0 0 # origin\nv\t1  0\t0\nv 0 1 0\nf 1 2 3 # tri\n",
        "# header\nv 0 0 0\nv 1 0 0\nv 0 1 0 #\nf 1 2 3#x\n",
        "o tri # the only one\nv 0 0 0 # see 9\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3 # 9 9 9\r\n",
        "  v 0 0 0   # indented\nv 1 0 0\nv 0 1 0\n\tf 1 2 3 # 1/2/3 -7\n",
    ];
    for text in commented {
        assert_eq!(obj::parse(text.as_bytes(), "m.obj").unwrap(), plain, "{text:?}");
    }
    assert_eq!(obj::parse(&with_bom("v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\nf 1 2 3 # tri\n"), "m.obj").unwrap(), plain);

    assert_eq!(
        error(b"v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\nf 1 2 4 # tri\n"),
        "m.obj:4:7: not a readable OBJ file (expected a vertex reference from 1 to 3 or from -3 to -1): 'f 1 2 4'"
    );
    assert_eq!(
        error(b"v 0 0 0 # origin\nv 1 x 0 # bad\nv 0 1 0\nf 1 2 3\n"),
        "m.obj:2: not a readable OBJ file (cannot parse a vertex position): 'v 1 x 0'"
    );
    assert_eq!(
        error(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 y # tri\n"),
        "m.obj:4: not a readable OBJ file (cannot parse a face): 'f 1 2 y'"
    );
}

/// A vertex beyond ±4e18 (where squared distances overflow single precision) is refused with the
/// file's name; one within loads.
#[test]
fn vertices_beyond_the_largest_coordinate_are_refused() {
    let within = obj::parse(b"v 0 0 0\nv 1e18 0 0\nv 0 -1e18 0\nf 1 2 3\n", "big.obj");
    assert!(within.is_ok());
    let err = obj::parse(b"v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n", "huge.obj").unwrap_err().to_string();
    assert!(err.starts_with("huge.obj: a vertex of") && err.contains("within ±4e18"), "{err}");
}

/// A tiny mesh is framed to fill the view as a unit one does: the camera's distance scales with it.
#[test]
fn a_tiny_mesh_is_framed_at_its_own_scale() {
    let tri = |s: f32| Shape::Mesh {
        vertices: vec![raylume_geometry::Vec3A::ZERO, raylume_geometry::Vec3A::X * s, raylume_geometry::Vec3A::Y * s],
        triangles: vec![[0, 1, 2]],
        normals: Vec::new(),
    };
    let unit = raylume_scene::procedural::mesh_view(tri(1.0), 64, 64).view;
    for s in [1e-7f32, 1e-12] {
        let view = raylume_scene::procedural::mesh_view(tri(s), 64, 64).view;
        let ratio = (view.from - view.at).length() / (unit.from - unit.at).length() / s;
        assert!((ratio - 1.0).abs() < 1e-3, "scale {s}: distance ratio {ratio}");
    }
}
