//! Wavefront OBJ meshes, read with `tobj` and triangulated, with their normals (`vn`) for smooth
//! shading, optionally scaled and moved into place ([`load_transformed`], as the p3f `obj` tag
//! does).

use std::borrow::Cow;
use std::path::Path;

use raylume_geometry::Vec3A;

use crate::{SceneError, Shape};

pub use crate::limits::MAX_OBJ_BYTES;

/// Reads every model of an OBJ file into one triangle mesh ([`Shape::Mesh`]); polygons are
/// triangulated, and the faces' normals (`f v//vn`) kept as the mesh's shading normals (a model
/// without them gets its faces' own normals where another has them). Materials (and the MTL files
/// they name, which are not opened) and texture coordinates are ignored. Only regular files of at
/// most [`MAX_OBJ_BYTES`] are read.
///
/// ```no_run
/// let mesh = raylume_scene::obj::load("bunny.obj").unwrap();
/// ```
pub fn load(path: impl AsRef<Path>) -> Result<Shape, SceneError> {
    let path = path.as_ref();
    let bytes = crate::p3f::read_capped(path, MAX_OBJ_BYTES)
        .map_err(|source| SceneError::Io { path: path.to_owned(), source })?;
    parse(&bytes, &path.display().to_string())
}

/// Reads an OBJ file ([`load`]) scaled and moved by `transform`.
///
/// ```no_run
/// use raylume_scene::obj::{load_transformed, Transform};
/// use raylume_geometry::Vec3A;
/// let bunny = load_transformed("bunny.obj", Transform { scale: 10.0, translate: Vec3A::new(0.0, -1.0, 0.0) });
/// ```
pub fn load_transformed(path: impl AsRef<Path>, transform: Transform) -> Result<Shape, SceneError> {
    transform.apply(load(path)?)
}

/// Where a mesh goes: scaled by `scale` about the origin, then moved by `translate` (the p3f tag
/// `obj FILE scale tx ty tz`). The default leaves a mesh as it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// The scale, positive.
    pub scale: f32,
    /// The translation, applied after the scale.
    pub translate: Vec3A,
}

impl Default for Transform {
    fn default() -> Self {
        Self { scale: 1.0, translate: Vec3A::ZERO }
    }
}

impl Transform {
    /// The mesh `shape` moved into place (its normals, unchanged by a uniform scale and a
    /// translation, are kept); other shapes are returned as they are. An error if the scale is not
    /// positive or the vertices would not stay finite.
    ///
    /// ```
    /// use raylume_scene::{obj::Transform, Shape};
    /// use raylume_geometry::Vec3A;
    /// let tri = raylume_scene::obj::parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap();
    /// let moved = Transform { scale: 2.0, translate: Vec3A::new(0.0, 0.0, 5.0) }.apply(tri).unwrap();
    /// let Shape::Mesh { vertices, .. } = moved else { unreachable!() };
    /// assert_eq!(vertices[1], Vec3A::new(2.0, 0.0, 5.0));
    /// ```
    pub fn apply(&self, shape: Shape) -> Result<Shape, SceneError> {
        if !(self.scale.is_finite() && self.scale > 0.0 && self.translate.is_finite()) {
            return Err(SceneError::Invalid(format!(
                "obj transform: expected a positive scale and a finite translation, found scale {} and translation {}",
                self.scale, self.translate
            )));
        }
        let Shape::Mesh { vertices, triangles, normals } = shape else { return Ok(shape) };
        let vertices: Vec<Vec3A> = vertices.into_iter().map(|v| v * self.scale + self.translate).collect();
        if vertices.iter().any(|v| !v.is_finite()) {
            return Err(SceneError::Invalid(
                "expected an obj scale and translation that keep its vertices finite".to_owned(),
            ));
        }
        Ok(Shape::Mesh { vertices, triangles, normals })
    }
}

/// Parses the bytes of an OBJ file ([`load`]); `name` names it in messages, which give the line
/// of a malformed entry. A leading UTF-8 byte-order mark is skipped (columns count from after it),
/// and a `#` comment may follow an entry on its line.
///
/// ```
/// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n";
/// let raylume_scene::Shape::Mesh { triangles, .. } = raylume_scene::obj::parse(obj, "quad.obj").unwrap() else {
///     unreachable!()
/// };
/// assert_eq!(triangles.len(), 2);
/// let err = raylume_scene::obj::parse(b"v 0 0 0\nv 1 x 0\n", "bad.obj").unwrap_err();
/// assert_eq!(err.to_string(), "bad.obj:2: not a readable OBJ file (cannot parse a vertex position): 'v 1 x 0'");
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Shape, SceneError> {
    // tobj would read a byte-order mark as part of the first line's tag, and drop that line.
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // tobj reads comments only as whole lines; a comment after an entry is blanked out here, at the
    // same offsets, so that lines and columns stay those of the file.
    let uncommented = without_trailing_comments(bytes);
    let bytes = &*uncommented;
    // tobj turns a face's reference into an offset unchecked (a wrapping product, or a panic where
    // overflow is checked), so references that point at nothing are refused here first. tobj still
    // reads the lines before such a face, so an earlier malformed line is reported as the first.
    let bad_face = first_dangling_reference(bytes);
    let read = bad_face.map_or(bytes, |bad| &bytes[..bad.offset]);
    let options = tobj::LoadOptions { triangulate: true, single_index: false, ignore_points: true, ignore_lines: true };
    let no_materials = |_: &Path| -> tobj::MTLLoadResult { Ok((Vec::new(), Default::default())) };
    let read = tobj::load_obj_buf(&mut std::io::BufReader::new(read), &options, no_materials);
    let (models, _materials) = read.map_err(|e| {
        let what = describe(&e);
        match locate(bytes, &e) {
            Some((line, text)) => SceneError::Invalid(format!(
                "{name}:{line}: not a readable OBJ file ({what}): '{}'",
                crate::p3f::shown(text.trim())
            )),
            None => SceneError::Invalid(format!("{name}: not a readable OBJ file ({what})")),
        }
    })?;
    if let Some(bad) = bad_face {
        let (kind, n) = (bad.kind, bad.count);
        let expected = match n {
            0 => format!("a face refers to a {kind}, and no {kind} precedes it"),
            _ => format!("expected a {kind} reference from 1 to {n} or from -{n} to -1"),
        };
        return Err(SceneError::Invalid(format!(
            "{name}:{}:{}: not a readable OBJ file ({expected}): '{}'",
            bad.line,
            bad.column,
            crate::p3f::shown(bad.text.trim())
        )));
    }
    let path = Path::new(name);
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    // Corner normals of each triangle, `None` for a model without normals.
    let mut corner_normals: Vec<Option<[Vec3A; 3]>> = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let base = vertices.len() as u32;
        for p in mesh.positions.chunks_exact(3) {
            let v = Vec3A::new(p[0], p[1], p[2]);
            if !v.is_finite() {
                return Err(SceneError::Invalid(format!(
                    "{}: a vertex of '{}' is not finite",
                    path.display(),
                    model.name
                )));
            }
            if v.abs().max_element() > crate::limits::MAX_COORDINATE {
                return Err(SceneError::Invalid(format!(
                    "{}: a vertex of '{}' is {v}: expected coordinates within ±{:e} (squared distances beyond \
                     overflow single precision)",
                    path.display(),
                    model.name,
                    crate::limits::MAX_COORDINATE
                )));
            }
            vertices.push(v);
        }
        let count = (mesh.positions.len() / 3) as u32;
        for t in mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i >= count) {
                return Err(SceneError::Invalid(format!(
                    "{}: a face of '{}' indexes a missing vertex",
                    path.display(),
                    model.name
                )));
            }
            triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
        let normal = |k: u32| {
            let n = mesh.normals.get(3 * k as usize..3 * k as usize + 3)?;
            Some(Vec3A::new(n[0], n[1], n[2])).filter(|n| n.is_finite())
        };
        let smooth = !mesh.normals.is_empty() && mesh.normal_indices.len() == mesh.indices.len();
        for ni in mesh.normal_indices.chunks_exact(3).take(if smooth { usize::MAX } else { 0 }) {
            let corners = [normal(ni[0]), normal(ni[1]), normal(ni[2])];
            let [Some(a), Some(b), Some(c)] = corners else {
                return Err(SceneError::Invalid(format!(
                    "{}: a face of '{}' refers to a normal that is missing or not finite",
                    path.display(),
                    model.name
                )));
            };
            corner_normals.push(Some([a, b, c]));
        }
        if !smooth {
            corner_normals.extend(std::iter::repeat_n(None, mesh.indices.len() / 3));
        }
    }
    if triangles.is_empty() {
        return Err(SceneError::Invalid(format!("{}: no faces", path.display())));
    }
    let normals = if corner_normals.iter().any(Option::is_some) {
        let face = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            [(b - a).cross(c - a).normalize_or_zero(); 3]
        };
        corner_normals.iter().zip(&triangles).map(|(n, t)| n.unwrap_or_else(|| face(t))).collect()
    } else {
        Vec::new()
    };
    Ok(Shape::Mesh { vertices, triangles, normals })
}

/// `bytes` with each comment that follows an entry on its line (`v 0 0 0 # origin`) replaced by
/// spaces up to the end of the line, so that every byte keeps its offset, line and column; borrowed
/// as they are when no line has such a comment. Lines that are comments as a whole are kept.
fn without_trailing_comments(bytes: &[u8]) -> Cow<'_, [u8]> {
    let mut blanked: Option<Vec<u8>> = None;
    let mut start = 0;
    for line in bytes.split(|&b| b == b'\n') {
        let entry = line.iter().position(|b| !b.is_ascii_whitespace()).filter(|&at| line[at] != b'#');
        let comment = entry.and_then(|at| line[at..].iter().position(|&b| b == b'#').map(|k| at + k));
        if let Some(at) = comment {
            blanked.get_or_insert_with(|| bytes.to_vec())[start + at..start + line.len()].fill(b' ');
        }
        start += line.len() + 1;
    }
    blanked.map_or(Cow::Borrowed(bytes), Cow::Owned)
}

/// A face's reference to a position, texture coordinate or normal that is not there.
#[derive(Clone, Copy)]
struct DanglingReference<'a> {
    /// The byte offset of the face's line.
    offset: usize,
    /// The line, from 1.
    line: usize,
    /// The column of the reference, from 1.
    column: usize,
    /// What it refers to: "vertex", "texture coordinate" or "normal".
    kind: &'static str,
    /// How many of those precede the face.
    count: usize,
    /// The face's line.
    text: &'a str,
}

/// Whether the OBJ reference `word` (a face's `v`, `vt` or `vn` index) is one of the
/// `count` entries before it: 1 to `count` or, counting back, -1 to -`count`. An empty reference
/// (the `vt` of `v//vn`) is absent, not dangling.
fn refers_to_one_of(word: &str, count: usize) -> bool {
    word.is_empty() || word.parse::<i64>().is_ok_and(|k| k != 0 && k.unsigned_abs() <= count as u64)
}

/// The first face with a reference to an entry that does not precede it, counting entries as tobj
/// does. Reading stops at the first line that is not UTF-8, where tobj stops.
fn first_dangling_reference(bytes: &[u8]) -> Option<DanglingReference<'_>> {
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut counts = [0usize; 3];
    let mut offset = 0;
    for (i, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let start = offset;
        offset += raw.len() + 1;
        let text = std::str::from_utf8(raw).ok()?;
        let mut words = text.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            // tobj drops lines (`l`), and faces of one or two references, without following them.
            Some("f") if text.split_whitespace().count() > 3 => {
                for word in words {
                    for (k, part) in word.split('/').enumerate().take(3) {
                        if !refers_to_one_of(part, counts[k]) && part.parse::<i64>().is_ok() {
                            let column = part.as_ptr() as usize - text.as_ptr() as usize + 1;
                            let (kind, count) = (KINDS[k], counts[k]);
                            return Some(DanglingReference { offset: start, line: i + 1, column, kind, count, text });
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

fn describe(e: &tobj::LoadError) -> &'static str {
    use tobj::LoadError as E;
    match e {
        E::PositionParseError => "cannot parse a vertex position",
        E::NormalParseError => "cannot parse a normal",
        E::TexcoordParseError => "cannot parse a texture coordinate",
        E::FaceParseError => "cannot parse a face",
        E::FaceVertexOutOfBounds | E::FaceNormalOutOfBounds | E::FaceTexCoordOutOfBounds => {
            "a face refers to a vertex that is not there"
        }
        E::InvalidPolygon => "a face with fewer than three vertices",
        E::InvalidLoadOptionConfig => "invalid options",
        _ => "cannot read it",
    }
}

/// The line (from 1) and text of the first entry that makes tobj fail with `e`.
fn locate<'a>(bytes: &'a [u8], e: &tobj::LoadError) -> Option<(usize, &'a str)> {
    use tobj::LoadError as E;
    let text = std::str::from_utf8(bytes).ok()?;
    let floats = |rest: &str, min: usize| {
        let parsed: Option<Vec<f32>> = rest.split_whitespace().map(|t| t.parse().ok()).collect();
        parsed.is_some_and(|v| v.len() >= min)
    };
    let (mut positions, mut normals, mut texcoords) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let mut words = line.split_whitespace();
        let (Some(tag), rest) = (words.next(), line.trim_start().get(1..).unwrap_or("")) else { continue };
        let rest = rest.trim_start_matches(|c: char| !c.is_whitespace());
        let bad = match tag {
            "v" => {
                positions += 1;
                matches!(e, E::PositionParseError) && !floats(rest, 3)
            }
            "vn" => {
                normals += 1;
                matches!(e, E::NormalParseError) && !floats(rest, 3)
            }
            "vt" => {
                texcoords += 1;
                matches!(e, E::TexcoordParseError) && !floats(rest, 1)
            }
            "f" => {
                let refs: Vec<&str> = rest.split_whitespace().collect();
                let in_range = |s: &str, count: i64| refers_to_one_of(s, count as usize);
                let parses = |s: &str| s.is_empty() || s.parse::<i64>().is_ok_and(|k| k != 0);
                match e {
                    E::InvalidPolygon => refs.len() < 3,
                    E::FaceParseError => refs.iter().any(|r| r.split('/').any(|s| !parses(s))),
                    E::FaceVertexOutOfBounds => {
                        refs.iter().any(|r| !in_range(r.split('/').next().unwrap_or(""), positions))
                    }
                    E::FaceTexCoordOutOfBounds => {
                        refs.iter().any(|r| !in_range(r.split('/').nth(1).unwrap_or(""), texcoords))
                    }
                    E::FaceNormalOutOfBounds => {
                        refs.iter().any(|r| !in_range(r.split('/').nth(2).unwrap_or(""), normals))
                    }
                    _ => false,
                }
            }
            _ => false,
        };
        if bad {
            return Some((line_no, line));
        }
    }
    None
}
