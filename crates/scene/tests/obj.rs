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
        "m.obj:1:5: not a readable OBJ file (expected a number (vertex y), found 'x'): 'v 1 x 0'"
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
        "m.obj:2:5: not a readable OBJ file (expected a number (vertex y), found 'x'): 'v 1 x 0'"
    );
    assert_eq!(
        error(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 y # tri\n"),
        "m.obj:4:7: not a readable OBJ file (expected a vertex reference (an integer), found 'y'): 'f 1 2 y'"
    );
}

/// A vertex beyond ±4e18 (where squared distances overflow single precision) is refused with the
/// file's name; one within loads.
#[test]
fn vertices_beyond_the_largest_coordinate_are_refused() {
    let within = obj::parse(b"v 0 0 0\nv 1e18 0 0\nv 0 -1e18 0\nf 1 2 3\n", "big.obj");
    assert!(within.is_ok());
    let err = obj::parse(b"v 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n", "huge.obj").unwrap_err().to_string();
    assert_eq!(
        err,
        "huge.obj: no faces (found 3 vertices, 1 face using unusable vertices; line 4: a face uses the vertex at line 2 \
         ('v 1e30 0 0'), whose coordinate at column 3 is beyond ±4e18 (squared distances beyond overflow single \
         precision): the face is skipped)"
    );
    // A face using a vertex that is not finite (as Microsoft's C library writes NaN and infinities
    // too) is skipped with a warning; the other faces stand.
    let text = b"v 1.#IND -1.#IND 1.#QNAN\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv -1.#INF 0 0\nf 1 3 4\nf 2 3 4\nf 5 3 4\n";
    let (mesh, warnings) = obj::parse_with_warnings(text, "nan.obj").unwrap();
    assert_eq!(mesh, obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "m.obj").unwrap());
    let shown: Vec<String> = warnings.iter().map(|w| w.to_string()).collect();
    assert_eq!(
        shown,
        [
            "nan.obj:6:1: warning: a face uses the vertex at line 1 ('v 1.#IND -1.#IND 1.#QNAN'), whose coordinate at \
             column 3 is not finite: the face is skipped",
            "nan.obj: warning: 1 more faces using vertices that cannot be used were skipped",
        ]
    );
    // A vertex that no face uses is not part of the mesh, whatever its numbers.
    let unused = obj::parse(b"v 0 0 0\nv 1e30 nan 0\nv 1 0 0\nv 0 1 0\nf 1 3 4\n", "unused.obj").unwrap();
    assert_eq!(unused, obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "m.obj").unwrap());
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

fn warnings_of(bytes: &[u8]) -> Vec<String> {
    let (_, warnings) = obj::parse_with_warnings(bytes, "m.obj").unwrap();
    warnings.iter().map(|w| w.to_string()).collect()
}

fn triangles_of(bytes: &[u8]) -> Vec<[raylume_geometry::Vec3A; 3]> {
    let Shape::Mesh { vertices, triangles, .. } = obj::parse(bytes, "m.obj").unwrap() else { unreachable!() };
    triangles.iter().map(|t| t.map(|i| vertices[i as usize])).collect()
}

fn area(tris: &[[raylume_geometry::Vec3A; 3]]) -> f32 {
    tris.iter().map(|[a, b, c]| (*b - *a).cross(*c - *a).length() / 2.0).sum()
}

/// Lines and points have no surface: they are skipped with a warning, never filled, and a file of
/// nothing else has no faces.
#[test]
fn lines_and_points_are_not_faces() {
    let square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    let with_face = format!("{square}l 1 2 3 4 1\np 1 2\nf 1 2 3\n");
    assert_eq!(triangles_of(with_face.as_bytes()).len(), 1, "the line is not filled");
    assert_eq!(warnings_of(with_face.as_bytes()), ["m.obj:5:1: warning: a line (l) has no surface: skipped"]);
    assert_eq!(
        error(format!("{square}l 1 2 3 4 1\nl 1 3\n").as_bytes()),
        "m.obj: no faces (found 4 vertices, 2 lines and points (no surface))"
    );
    // Faces of fewer than three corners alone: the error says where the first one is.
    assert_eq!(
        error(format!("{square}f 1 2\nf 3\n").as_bytes()),
        "m.obj: no faces (found 4 vertices, 2 faces of fewer than three corners; line 5: a face of 2 corners has \
         no surface: skipped)"
    );
}

/// A file of another format given as an OBJ mesh is named as such; an OBJ file that starts like one
/// but has faces is read as it is.
#[test]
fn files_of_other_formats_are_named_where_no_face_is() {
    let cases: [(&[u8], &str); 4] = [
        (b"ply\nformat ascii 1.0\nelement vertex 3\n", "m.obj: expected an OBJ mesh, found a PLY mesh"),
        (b"solid x\n facet normal 0 0 1\n", "m.obj: expected an OBJ mesh, found an STL mesh"),
        (b"\x89PNG\r\n\x1a\n", "m.obj: expected an OBJ mesh, found a PNG image"),
        (b"{\"asset\": {}}\n", "m.obj: expected an OBJ mesh, found a JSON document"),
    ];
    for (bytes, expected) in cases {
        assert!(error(bytes).starts_with(expected), "{}", error(bytes));
    }
    // Vertices alone: an OBJ file without faces, which the message describes.
    assert!(error(b"v 0 0 0\nv 1 0 0\n").starts_with("m.obj: no faces (found 2 vertices"));
    // A group named like a pbrt directive does not make an OBJ file anything else.
    assert_eq!(triangles_of(b"o Camera\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").len(), 1);
}

/// A face whose vertices are collinear in f32 is never hit: the warning is at the first such face, and
/// counts the others.
#[test]
fn faces_without_area_are_reported_at_the_first() {
    let square = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\n";
    assert_eq!(warnings_of(format!("{square}f 1 2 3\n").as_bytes()), Vec::<String>::new());
    assert_eq!(
        warnings_of(format!("{square}f 1 2 3\n# a comment\nf 1 2 4\nf 1 1 1\nf 2 3 4\n").as_bytes()),
        ["m.obj:7:1: warning: this face's vertices are collinear in f32 (no area): it is never hit, nor is one more \
          of the mesh's 4 triangles"]
    );
    assert_eq!(
        warnings_of(format!("{square}f 2 3 4\nf 3 3 3\n").as_bytes()),
        ["m.obj:6:1: warning: this face's vertices are collinear in f32 (no area): it is never hit"]
    );
}

/// A concave face is covered as drawn, whichever corner it starts at: its notch stays open.
#[test]
fn concave_faces_keep_their_notches() {
    let l_shape = ["0 0 0", "2 0 0", "2 1 0", "1 1 0", "1 2 0", "0 2 0"];
    for start in 0..l_shape.len() {
        let v: String = (0..6).map(|k| format!("v {}\n", l_shape[(start + k) % 6])).collect();
        let tris = triangles_of(format!("{v}f 1 2 3 4 5 6\n").as_bytes());
        assert_eq!(tris.len(), 4);
        assert!((area(&tris) - 3.0).abs() < 1e-6, "start {start}: area {}", area(&tris));
    }
}

/// What may follow a position (a weight w, or a vertex colour) is not part of it.
#[test]
fn a_fourth_coordinate_or_a_colour_leaves_the_position_as_it_is() {
    let plain = obj::parse(b"v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n", "m.obj").unwrap();
    for extra in ["v 0 0 0 0.5\nv 2 0 0 2\nv 0 2 0 0\n", "v 0 0 0 1 0 0\nv 2 0 0 0 1 0\nv 0 2 0 0 0 1\n"] {
        assert_eq!(obj::parse(format!("{extra}f 1 2 3\n").as_bytes(), "m.obj").unwrap(), plain, "{extra:?}");
    }
}

/// Names, materials and comments in other encodings (Latin-1 from older exporters), `usemtl` with a
/// tab or no name, a byte-order mark at the start of a joined file, old Mac line endings and `\`
/// continuations all read as the plain file does.
#[test]
fn what_exporters_write_reads_as_the_plain_file() {
    let plain = obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n", "m.obj").unwrap();
    let variants: Vec<Vec<u8>> = vec![
        b"# Cr\xe9\xe9 par l'exportateur\no pi\xe8ce\ng groupe_\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl m\xe9tal\nf 1 2 3\nf 2 4 3\n"
            .to_vec(),
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl\tred\nf 1 2 3\nusemtl \nf 2 4 3\nusemtl\n".to_vec(),
        [&b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"[..], BOM, b"v 1 1 0\nf 1 2 3\nf 2 4 3\n"].concat(),
        b"v 0 0 0\rv 1 0 0\rv 0 1 0\rv 1 1 0\rf 1 2 3\rf 2 4 3\r".to_vec(),
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 \\\n 3\nf 2 \\\r\n4 \\\n3\n".to_vec(),
    ];
    for bytes in variants {
        let (mesh, warnings) = obj::parse_with_warnings(&bytes, "m.obj").unwrap();
        assert_eq!(mesh, plain, "{}", String::from_utf8_lossy(&bytes));
        assert!(warnings.is_empty(), "{warnings:?}");
    }
    // Lines keep their numbers past continuations and lone CRs.
    assert_eq!(
        error(b"v 0 0 \\\n0\rv 1 0 0\r\nv 0 x 0\n"),
        "m.obj:4:5: not a readable OBJ file (expected a number (vertex y), found 'x'): 'v 0 x 0'"
    );
    // A byte that is not UTF-8 where a number must be is refused where it is.
    assert_eq!(
        error(b"v 0 0 0\nv 1 \xe9 0\n"),
        "m.obj:2:5: not a readable OBJ file (expected a number (vertex y), found '\u{fffd}'): 'v 1 \u{fffd} 0'"
    );
}

/// Unknown keywords, free-form geometry and faces of fewer than three corners are skipped with a
/// warning at their line; a number cut by a `#` says where the comment began.
#[test]
fn what_is_skipped_is_said() {
    let text =
        b"V 0 0 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nwobble 1\nwobble 2\ncstype bspline\ncurv 0 1 1 2\nend\nf 1 2\nf 1 2 3\n";
    assert_eq!(
        warnings_of(text),
        [
            "m.obj:1:1: warning: unknown keyword 'V' (keywords are lower case: 'v'): skipped 'V 0 0 0' (and any later line \
             it starts)",
            "m.obj:5:1: warning: unknown keyword 'wobble': skipped 'wobble 1' (and any later line it starts)",
            "m.obj:7:1: warning: free-form curves and surfaces are not rendered: skipped",
            "m.obj:10:1: warning: a face of 2 corners has no surface: skipped",
        ]
    );
    assert_eq!(
        error(b"v 1 2#3 4\n"),
        "m.obj:1:6: not a readable OBJ file (expected a number (vertex z), found the end of the line; the '#' at column 6 \
         starts a comment): 'v 1 2'"
    );
    assert_eq!(
        error(b"cstype bspline\nsurf 0 1 0 1 1 2 3 4\nV 1 2 3\n"),
        "m.obj: no faces (found no vertices, free-form geometry (not rendered), unknown keywords 'V')"
    );
    assert_eq!(
        error(b"\xFF\xFEv\x00 \x001\x00"),
        "m.obj: not a readable OBJ file (it is UTF-16 text: expected ASCII or UTF-8, as most editors can save it)"
    );
}

/// A flat mesh that the standard view would see edge-on is seen from its front; other meshes keep the
/// standard view.
#[test]
fn a_flat_mesh_is_framed_from_its_front() {
    use raylume_geometry::Vec3A;
    let standard = Vec3A::new(0.35, 0.3, 1.0).normalize();
    // A square in the plane that holds the standard direction and the x axis.
    let (u, v) = (Vec3A::X, standard.cross(Vec3A::X).cross(Vec3A::X).normalize());
    let normal = u.cross(v).normalize();
    assert!(normal.dot(standard).abs() < 0.01);
    let square = Shape::Mesh {
        vertices: vec![Vec3A::ZERO, u, u + v, v],
        triangles: vec![[0, 1, 2], [0, 3, 2]],
        normals: Vec::new(),
    };
    let view = raylume_scene::procedural::mesh_view(square, 64, 64).view;
    let seen = (view.from - view.at).normalize();
    assert!(seen.dot(normal).abs() > 0.9, "seen along {seen}, normal {normal}");
    let (vertices, triangles) = raylume_scene::procedural::icosphere(2);
    let ball = Shape::Mesh { vertices, triangles, normals: Vec::new() };
    let view = raylume_scene::procedural::mesh_view(ball, 64, 64).view;
    assert!((view.from - view.at).normalize().abs_diff_eq(standard, 1e-6));
}
