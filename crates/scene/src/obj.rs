//! Wavefront OBJ meshes: their faces triangulated (concave polygons too), with their normals
//! (`vn`) for smooth shading, optionally scaled and moved into place ([`load_transformed`], as the
//! p3f `obj` tag does). The reader takes the files editors and exporters write: any line ending
//! (LF, CRLF, CR), byte-order marks, `\` continuations, comments after entries, names and comments
//! in any encoding, a fourth coordinate (w) and vertex colours after a position. What has no
//! surface (lines, points, free-form curves and surfaces) is skipped with a warning.

use std::path::Path;

use raylume_geometry::Vec3A;

use crate::p3f::shown;
use crate::{SceneError, Shape, Warning};

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
    load_with_warnings(path).map(|(shape, _)| shape)
}

/// Reads an OBJ file as [`load`] does, with what was skipped in it (in file order).
///
/// ```no_run
/// let (mesh, warnings) = raylume_scene::obj::load_with_warnings("bunny.obj").unwrap();
/// for w in &warnings {
///     eprintln!("{w}");
/// }
/// ```
pub fn load_with_warnings(path: impl AsRef<Path>) -> Result<(Shape, Vec<Warning>), SceneError> {
    let path = path.as_ref();
    let bytes = crate::p3f::read_capped(path, MAX_OBJ_BYTES)
        .map_err(|source| SceneError::Io { path: path.to_owned(), source })?;
    parse_with_warnings(&bytes, &path.display().to_string())
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

/// Parses the bytes of an OBJ file ([`load`]); `name` names it in messages, which give the line and
/// column of a malformed entry. What was skipped is dropped: [`parse_with_warnings`] keeps it.
///
/// ```
/// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n";
/// let raylume_scene::Shape::Mesh { triangles, .. } = raylume_scene::obj::parse(obj, "quad.obj").unwrap() else {
///     unreachable!()
/// };
/// assert_eq!(triangles.len(), 2);
/// let err = raylume_scene::obj::parse(b"v 0 0 0\nv 1 x 0\n", "bad.obj").unwrap_err();
/// assert_eq!(err.to_string(), "bad.obj:2:5: not a readable OBJ file (expected a number (vertex y), found 'x'): 'v 1 x 0'");
/// ```
pub fn parse(bytes: &[u8], name: &str) -> Result<Shape, SceneError> {
    parse_with_warnings(bytes, name).map(|(shape, _)| shape)
}

/// Parses the bytes of an OBJ file as [`parse`] does, with what was skipped (in file order): faces
/// of fewer than three corners, lines and points, free-form geometry, unknown keywords, and normal
/// references that point at nothing (such a face is shaded flat).
///
/// ```
/// let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\nf 1 2 3\n";
/// let (mesh, warnings) = raylume_scene::obj::parse_with_warnings(obj, "m.obj").unwrap();
/// assert_eq!(warnings[0].to_string(), "m.obj:4:1: warning: a line (l) has no surface: skipped");
/// ```
pub fn parse_with_warnings(bytes: &[u8], name: &str) -> Result<(Shape, Vec<Warning>), SceneError> {
    if bytes.starts_with(b"\xFF\xFE") || bytes.starts_with(b"\xFE\xFF") {
        return Err(SceneError::Invalid(format!(
            "{name}: not a readable OBJ file (it is UTF-16 text: expected ASCII or UTF-8, as most editors can save it)"
        )));
    }
    let mut reader = Reader::new(name);
    reader.other_format = other_format(bytes);
    for line in Lines::new(bytes) {
        reader.entry(&line)?;
    }
    reader.finish()
}

/// What `bytes` hold if they start as another format's file would (an image, compressed data, a PLY,
/// STL, pbrt, glTF, USD or XML file): an OBJ file that holds no face says so.
fn other_format(bytes: &[u8]) -> Option<String> {
    use crate::p3f::foreign::{binary_kind, foreign_format};
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    binary_kind(bytes).or_else(|| {
        let (format, _, _, instead) = foreign_format(&head)?;
        (format != "a Wavefront OBJ mesh").then(|| format!("{format} ({instead})"))
    })
}

/// A vertex, texture coordinate or normal that a face may refer to: how many of each came before.
const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];

/// Keywords of the format that carry nothing a render uses: names, groups, smoothing, materials
/// (MTL files are never opened), texture coordinates, and display and rendering attributes.
const IGNORED: &[&[u8]] = &[
    b"o",
    b"g",
    b"s",
    b"usemtl",
    b"mtllib",
    b"vp",
    b"mg",
    b"lod",
    b"usemap",
    b"maplib",
    b"shadow_obj",
    b"trace_obj",
    b"bevel",
    b"c_interp",
    b"d_interp",
    b"ctech",
    b"stech",
];

/// Keywords of free-form curves and surfaces, which are not rendered.
const FREE_FORM: &[&[u8]] = &[
    b"cstype", b"deg", b"bmat", b"step", b"curv", b"curv2", b"surf", b"parm", b"trim", b"hole", b"scrv", b"sp", b"end",
    b"con",
];

/// Distinct unknown keywords warned about at most; the rest are counted in one last warning.
const UNKNOWN_WARNED: usize = 8;

/// One line of the file, with its continuations (`\` at a line's end) joined.
struct Line<'a> {
    /// The line's number, from 1 (the first of a continued line).
    number: u32,
    /// Its bytes, without the line ending or a leading byte-order mark; continuations joined by a
    /// space each.
    text: std::borrow::Cow<'a, [u8]>,
}

/// The lines of an OBJ file: ended by LF, CRLF or a lone CR; a UTF-8 byte-order mark at the start
/// of any line (the first of the file, or of a file joined to another) is not part of it.
struct Lines<'a> {
    bytes: &'a [u8],
    at: usize,
    number: u32,
}

impl<'a> Lines<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0, number: 0 }
    }

    /// The next physical line, without its ending.
    fn physical(&mut self) -> Option<&'a [u8]> {
        if self.at >= self.bytes.len() {
            return None;
        }
        let rest = &self.bytes[self.at..];
        let end = rest.iter().position(|&b| b == b'\n' || b == b'\r').unwrap_or(rest.len());
        let ending = match rest.get(end..end + 2) {
            Some(b"\r\n") => 2,
            _ if end < rest.len() => 1,
            _ => 0,
        };
        self.at += end + ending;
        self.number += 1;
        let line = &rest[..end];
        Some(line.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(line))
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = Line<'a>;

    fn next(&mut self) -> Option<Line<'a>> {
        let first = self.physical()?;
        let number = self.number;
        let continues = |l: &[u8]| l.trim_ascii_end().ends_with(b"\\");
        if !continues(first) {
            return Some(Line { number, text: std::borrow::Cow::Borrowed(first) });
        }
        let mut text = first.trim_ascii_end().to_vec();
        while text.ends_with(b"\\") {
            text.pop();
            text.push(b' ');
            match self.physical() {
                Some(next) => text.extend_from_slice(next.trim_ascii_end()),
                None => break,
            }
        }
        Some(Line { number, text: std::borrow::Cow::Owned(text) })
    }
}

/// A vertex or normal whose numbers cannot be used (not finite, or beyond the largest
/// coordinate): an error only if a face refers to it.
struct Unusable {
    index: u32,
    line: u32,
    column: u32,
    why: String,
    text: String,
}

/// The state of a file being read.
struct Reader<'n> {
    name: &'n str,
    positions: Vec<Vec3A>,
    normals: Vec<Vec3A>,
    texcoords: usize,
    unusable_positions: Vec<Unusable>,
    unusable_normals: Vec<Unusable>,
    /// Triangles, as indices into `positions`, and their corners' normals where the face gave them.
    triangles: Vec<[u32; 3]>,
    corner_normals: Vec<Option<[Vec3A; 3]>>,
    /// The line of each triangle's face.
    triangle_lines: Vec<u32>,
    warnings: Vec<Warning>,
    lines_and_points: usize,
    free_form: bool,
    unknown: Vec<Vec<u8>>,
    unknown_more: usize,
    /// Faces skipped for a vertex whose numbers cannot be used.
    faces_without_vertices: usize,
    /// The warning about the first of them.
    first_unusable: Option<String>,
    /// Faces of fewer than three corners.
    short_faces: usize,
    /// Where the first of them is, and what it is.
    first_short: Option<String>,
    /// Scratch: one face's corners.
    corners: Vec<(u32, Option<u32>)>,
    /// What the file is, if its first bytes or line are those of another format: said instead of
    /// what was found where no face is.
    other_format: Option<String>,
}

impl<'n> Reader<'n> {
    fn new(name: &'n str) -> Self {
        Self {
            name,
            positions: Vec::new(),
            normals: Vec::new(),
            texcoords: 0,
            unusable_positions: Vec::new(),
            unusable_normals: Vec::new(),
            triangles: Vec::new(),
            corner_normals: Vec::new(),
            triangle_lines: Vec::new(),
            warnings: Vec::new(),
            lines_and_points: 0,
            free_form: false,
            unknown: Vec::new(),
            unknown_more: 0,
            faces_without_vertices: 0,
            first_unusable: None,
            short_faces: 0,
            first_short: None,
            corners: Vec::new(),
            other_format: None,
        }
    }

    fn warn(&mut self, line: u32, column: u32, message: String) {
        self.warnings.push(Warning { file: self.name.to_owned(), line, column, message });
    }

    fn error(&self, line: &Line, column: usize, expected: String) -> SceneError {
        let entry = entry_of(&line.text);
        // A `#` inside a word (`1.#IND`) cut the line there: say so.
        let cut = match entry.len() {
            at if at < line.text.len() && entry.last().is_some_and(|b| !b.is_ascii_whitespace()) => {
                format!("; the '#' at column {} starts a comment", column_of(&line.text, at))
            }
            _ => String::new(),
        };
        SceneError::Invalid(format!(
            "{}:{}:{column}: not a readable OBJ file ({expected}{cut}): '{}'",
            self.name,
            line.number,
            shown(String::from_utf8_lossy(entry).trim())
        ))
    }

    fn entry(&mut self, line: &Line) -> Result<(), SceneError> {
        let text = entry_of(&line.text);
        let mut words = Words::new(text);
        let Some((keyword, keyword_column)) = words.next() else { return Ok(()) };
        match keyword {
            b"v" => {
                let p = self.numbers(line, &mut words, "vertex", keyword_column)?;
                self.keep(false, p, line);
            }
            b"vn" => {
                let n = self.numbers(line, &mut words, "normal", keyword_column)?;
                self.keep(true, n, line);
            }
            b"vt" => self.texcoords += 1,
            b"f" | b"fo" => self.face(line, words)?,
            b"l" | b"p" => {
                if self.lines_and_points == 0 {
                    let what = if keyword == b"l" { "a line (l)" } else { "a point (p)" };
                    self.warn(line.number, keyword_column as u32, format!("{what} has no surface: skipped"));
                }
                self.lines_and_points += 1;
            }
            k if IGNORED.contains(&k) => {}
            k if FREE_FORM.contains(&k) => {
                if !self.free_form {
                    self.free_form = true;
                    let message = "free-form curves and surfaces are not rendered: skipped".to_owned();
                    self.warn(line.number, keyword_column as u32, message);
                }
            }
            k => {
                if self.unknown.iter().any(|u| u == k) {
                    return Ok(());
                }
                if self.unknown.len() == UNKNOWN_WARNED {
                    self.unknown_more += 1;
                    return Ok(());
                }
                self.unknown.push(k.to_vec());
                let lower = k.to_ascii_lowercase();
                let known = [&[&b"v"[..], b"vn", b"vt", b"f", b"l", b"p"][..], IGNORED, FREE_FORM].concat();
                let hint = if lower != k && known.contains(&&lower[..]) {
                    format!(" (keywords are lower case: '{}')", String::from_utf8_lossy(&lower))
                } else {
                    String::new()
                };
                let shown_line = shown(String::from_utf8_lossy(text).trim());
                let message = format!(
                    "unknown keyword '{}'{hint}: skipped '{shown_line}' (and any later line it starts)",
                    shown(&String::from_utf8_lossy(k))
                );
                self.warn(line.number, keyword_column as u32, message);
            }
        }
        Ok(())
    }

    /// The first three numbers of a `v` or `vn` line (later ones, a w or a colour, are not used).
    fn numbers(
        &self,
        line: &Line,
        words: &mut Words,
        what: &str,
        keyword_column: usize,
    ) -> Result<Number3, SceneError> {
        let mut out = [0.0f32; 3];
        let mut columns = [0usize; 3];
        for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
            let Some((word, column)) = words.next() else {
                let end = entry_of(&line.text).len() + 1;
                let column = if k == 0 { keyword_column } else { end };
                return Err(self.error(
                    line,
                    column,
                    format!("expected a number ({what} {axis}), found the end of the line"),
                ));
            };
            out[k] = number(word).ok_or_else(|| {
                let found = shown(&String::from_utf8_lossy(word));
                self.error(line, column, format!("expected a number ({what} {axis}), found '{found}'"))
            })?;
            columns[k] = column;
        }
        Ok(Number3 { v: Vec3A::from_array(out), columns })
    }

    /// Keeps a position (or, with `normal`, a normal), noting it if its numbers cannot be used.
    fn keep(&mut self, normal: bool, n: Number3, line: &Line) {
        let list = if normal { &self.normals } else { &self.positions };
        let index = list.len() as u32;
        let limit = crate::limits::MAX_COORDINATE;
        let bad = (0..3).find_map(|k| {
            let x = n.v[k];
            if !x.is_finite() {
                Some((k, "is not finite".to_owned()))
            } else if !normal && x.abs() > limit {
                Some((k, format!("is beyond ±{limit:e} (squared distances beyond overflow single precision)")))
            } else {
                None
            }
        });
        if let Some((k, why)) = bad {
            let text = shown(String::from_utf8_lossy(entry_of(&line.text)).trim());
            let unusable = Unusable { index, line: line.number, column: n.columns[k] as u32, why, text };
            if normal { &mut self.unusable_normals } else { &mut self.unusable_positions }.push(unusable);
        }
        if normal { &mut self.normals } else { &mut self.positions }.push(n.v);
    }

    /// A face: its corners' references resolved, then its triangles.
    fn face(&mut self, line: &Line, words: Words) -> Result<(), SceneError> {
        let mut corners = std::mem::take(&mut self.corners);
        corners.clear();
        let mut refs = Vec::new();
        refs.extend(words);
        if refs.len() < 3 {
            if self.short_faces == 0 {
                let corners = if refs.len() == 1 { "corner" } else { "corners" };
                self.warn(line.number, 1, format!("a face of {} {corners} has no surface: skipped", refs.len()));
                self.first_short = self.warnings.last().map(|w| format!("line {}: {}", w.line, w.message));
            }
            self.short_faces += 1;
            self.corners = corners;
            return Ok(());
        }
        let counts = [self.positions.len(), self.texcoords, self.normals.len()];
        let mut flat = None;
        for &(word, column) in &refs {
            let mut parts = word.split(|&b| b == b'/');
            let v = parts.next().unwrap_or_default();
            let vt = parts.next().unwrap_or_default();
            let vn = parts.next().unwrap_or_default();
            if parts.next().is_some() {
                let found = shown(&String::from_utf8_lossy(word));
                return Err(self.error(
                    line,
                    column,
                    format!("expected a corner v, v/vt, v//vn or v/vt/vn, found '{found}'"),
                ));
            }
            let position = resolve(v, counts[0]).map_err(|e| self.reference_error(line, column, 0, counts[0], v, e))?;
            let Some(position) = position else {
                return Err(self.error(line, column, "expected a vertex reference, found none".to_owned()));
            };
            // Texture coordinates are not used: their references are not followed.
            let vn_column = column + v.len() + vt.len() + 2;
            let normal = match resolve(vn, counts[2]) {
                Ok(n) => n,
                Err(e) => {
                    if flat.is_none() {
                        flat = Some((vn_column, self.reference_problem(2, counts[2], vn, e)));
                    }
                    None
                }
            };
            corners.push((position, normal));
        }
        if let Some((column, problem)) = flat {
            self.warn(line.number, column as u32, format!("{problem}: the face is shaded flat"));
        }
        let unusable = corners.iter().find_map(|&(p, _)| find_unusable(&self.unusable_positions, p));
        if let Some(u) = unusable {
            if self.faces_without_vertices == 0 {
                let message = format!(
                    "a face uses the vertex at line {} ('{}'), whose coordinate at column {} {}: the face is skipped",
                    u.line, u.text, u.column, u.why
                );
                self.warn(line.number, 1, message);
                self.first_unusable = self.warnings.last().map(|w| format!("line {}: {}", w.line, w.message));
            }
            self.faces_without_vertices += 1;
            self.corners = corners;
            return Ok(());
        }
        // Normals only where every corner gives a usable one.
        let smooth =
            corners.iter().all(|&(_, n)| n.is_some_and(|n| find_unusable(&self.unusable_normals, n).is_none()));
        let normal_of = |k: usize| self.normals[corners[k].1.unwrap_or(0) as usize];
        if corners.len() == 3 {
            self.triangles.push([corners[0].0, corners[1].0, corners[2].0]);
            self.corner_normals.push(smooth.then(|| [normal_of(0), normal_of(1), normal_of(2)]));
        } else {
            let points: Vec<Vec3A> = corners.iter().map(|&(p, _)| self.positions[p as usize]).collect();
            for t in crate::polygon::triangulate(&points) {
                let [a, b, c] = t.map(|k| k as usize);
                self.triangles.push([corners[a].0, corners[b].0, corners[c].0]);
                self.corner_normals.push(smooth.then(|| [normal_of(a), normal_of(b), normal_of(c)]));
            }
        }
        self.triangle_lines.resize(self.triangles.len(), line.number);
        self.corners = corners;
        Ok(())
    }

    fn reference_problem(&self, kind: usize, count: usize, text: &[u8], problem: Reference) -> String {
        let kind_name = KINDS[kind];
        match problem {
            Reference::NotANumber => {
                format!(
                    "expected a {kind_name} reference (an integer), found '{}'",
                    shown(&String::from_utf8_lossy(text))
                )
            }
            Reference::Missing if count == 0 => {
                format!("a face refers to a {kind_name}, and no {kind_name} precedes it")
            }
            Reference::Missing => format!("expected a {kind_name} reference from 1 to {count} or from -{count} to -1"),
        }
    }

    fn reference_error(
        &self,
        line: &Line,
        column: usize,
        kind: usize,
        count: usize,
        text: &[u8],
        problem: Reference,
    ) -> SceneError {
        self.error(line, column, self.reference_problem(kind, count, text, problem))
    }

    fn finish(mut self) -> Result<(Shape, Vec<Warning>), SceneError> {
        let more = [
            (self.unknown_more, "more unknown keywords were skipped"),
            (self.short_faces.saturating_sub(1), "more faces of fewer than three corners were skipped"),
            (
                self.faces_without_vertices.saturating_sub(1),
                "more faces using vertices that cannot be used were skipped",
            ),
        ];
        for (n, what) in more.into_iter().filter(|&(n, _)| n > 0) {
            self.warn(0, 0, format!("{n} {what}"));
        }
        if self.triangles.is_empty() {
            let plural =
                |n: usize, one: &str, many: &str| if n == 1 { format!("1 {one}") } else { format!("{n} {many}") };
            let mut found = Vec::new();
            if self.positions.is_empty() {
                found.push("no vertices".to_owned());
            } else {
                found.push(plural(self.positions.len(), "vertex", "vertices"));
            }
            if self.lines_and_points > 0 {
                found.push(plural(
                    self.lines_and_points,
                    "line or point (no surface)",
                    "lines and points (no surface)",
                ));
            }
            if self.short_faces > 0 {
                found.push(plural(
                    self.short_faces,
                    "face of fewer than three corners",
                    "faces of fewer than three corners",
                ));
            }
            if self.faces_without_vertices > 0 {
                found.push(plural(
                    self.faces_without_vertices,
                    "face using unusable vertices",
                    "faces using unusable vertices",
                ));
            }
            if self.free_form {
                found.push("free-form geometry (not rendered)".to_owned());
            }
            if !self.unknown.is_empty() {
                let words: Vec<String> =
                    self.unknown.iter().map(|k| format!("'{}'", shown(&String::from_utf8_lossy(k)))).collect();
                found.push(format!("unknown keywords {}", words.join(", ")));
            }
            if let Some(other) = self.other_format.take() {
                return Err(SceneError::Invalid(format!("{}: expected an OBJ mesh, found {other}", self.name)));
            }
            let firsts = [&self.first_short, &self.first_unusable];
            let hint: String = firsts.into_iter().flatten().map(|first| format!("; {first}")).collect();
            return Err(SceneError::Invalid(format!("{}: no faces (found {}{hint})", self.name, found.join(", "))));
        }
        // Only the vertices that faces use, in their order in the file.
        let mut index = vec![u32::MAX; self.positions.len()];
        for &i in self.triangles.iter().flatten() {
            index[i as usize] = 0;
        }
        let mut vertices = Vec::new();
        for (slot, &p) in index.iter_mut().zip(&self.positions) {
            if *slot == 0 {
                *slot = vertices.len() as u32;
                vertices.push(p);
            }
        }
        for i in self.triangles.iter_mut().flatten() {
            *i = index[*i as usize];
        }
        // Triangles without an area in f32 are never hit: where the first one's face is, and how many.
        let mut flat = self.triangles.iter().enumerate().filter(|(_, t)| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            !raylume_geometry::Triangle::new(a, b, c).has_plane()
        });
        if let Some((first, _)) = flat.next() {
            let (count, total) = (1 + flat.count(), self.triangles.len());
            let mut message = "this face's vertices are collinear in f32 (no area): it is never hit".to_owned();
            match count - 1 {
                0 => {}
                1 => message += &format!(", nor is one more of the mesh's {total} triangles"),
                more => message += &format!(", nor are {more} more of the mesh's {total} triangles"),
            }
            self.warn(self.triangle_lines[first], 1, message);
        }
        let normals = if self.corner_normals.iter().any(Option::is_some) {
            let face = |t: &[u32; 3]| {
                let [a, b, c] = t.map(|i| vertices[i as usize]);
                [(b - a).cross(c - a).normalize_or_zero(); 3]
            };
            self.corner_normals.iter().zip(&self.triangles).map(|(n, t)| n.unwrap_or_else(|| face(t))).collect()
        } else {
            Vec::new()
        };
        Ok((Shape::Mesh { vertices, triangles: self.triangles, normals }, self.warnings))
    }
}

/// Three numbers of a line and the columns they start at.
struct Number3 {
    v: Vec3A,
    columns: [usize; 3],
}

/// Why a reference cannot be followed.
#[derive(Clone, Copy, Debug)]
enum Reference {
    NotANumber,
    Missing,
}

/// The index a reference `text` names among `count` entries (1 to `count`, or counting back from
/// -1); `None` for an empty reference (the `vt` of `v//vn`).
fn resolve(text: &[u8], count: usize) -> Result<Option<u32>, Reference> {
    if text.is_empty() {
        return Ok(None);
    }
    let k: i64 = std::str::from_utf8(text).ok().and_then(|t| t.parse().ok()).ok_or(Reference::NotANumber)?;
    let index = if k > 0 { k - 1 } else { count as i64 + k };
    if k == 0 || index < 0 || index >= count as i64 {
        return Err(Reference::Missing);
    }
    Ok(Some(index as u32))
}

/// The noted entry of `index`, if it is one whose numbers cannot be used.
fn find_unusable(list: &[Unusable], index: u32) -> Option<&Unusable> {
    list.binary_search_by_key(&index, |u| u.index).ok().map(|k| &list[k])
}

/// A line without its comment: a `#` at its start, or anywhere after its keyword, begins one, but
/// for the `#` of the non-finite numbers that Microsoft's C library writes (`1.#IND`, `-1.#INF`).
fn entry_of(text: &[u8]) -> &[u8] {
    let comment = (0..text.len()).find(|&at| text[at] == b'#' && !msvc_non_finite_at(text, at));
    comment.map_or(text, |at| &text[..at])
}

/// Whether the `#` at `at` is that of `1.#IND`, `1.#QNAN`, `1.#SNAN` or `1.#INF`.
fn msvc_non_finite_at(text: &[u8], at: usize) -> bool {
    at >= 2
        && text[at - 1] == b'.'
        && text[at - 2].is_ascii_digit()
        && [&b"IND"[..], b"QNAN", b"SNAN", b"INF"].iter().any(|w| text[at + 1..].starts_with(w))
}

/// A number as OBJ files write it: Rust's float syntax, or a non-finite number as Microsoft's C
/// library writes it (NaN for `1.#IND`, `1.#QNAN`, `1.#SNAN`; an infinity for `1.#INF`).
fn number(word: &[u8]) -> Option<f32> {
    let text = std::str::from_utf8(word).ok()?;
    if let Ok(x) = text.parse::<f32>() {
        return Some(x);
    }
    let at = text.find('#')?;
    if !msvc_non_finite_at(word, at)
        || !text[..at - 1].trim_start_matches(['-', '+']).bytes().all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let digits = |w: &str| text[at + 1 + w.len()..].bytes().all(|b| b.is_ascii_digit());
    let sign = if text.starts_with('-') { -1.0 } else { 1.0 };
    match &text[at + 1..] {
        t if t.starts_with("INF") && digits("INF") => Some(sign * f32::INFINITY),
        t if ["IND", "QNAN", "SNAN"].iter().any(|w| t.starts_with(w) && digits(w)) => Some(f32::NAN),
        _ => None,
    }
}

/// The words of an entry separated by blanks, with the column (from 1) each starts at.
struct Words<'a> {
    text: &'a [u8],
    at: usize,
}

impl<'a> Words<'a> {
    fn new(text: &'a [u8]) -> Self {
        Self { text, at: 0 }
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = (&'a [u8], usize);

    fn next(&mut self) -> Option<(&'a [u8], usize)> {
        let rest = &self.text[self.at..];
        let start = self.at + rest.iter().position(|b| !b.is_ascii_whitespace())?;
        let len = self.text[start..].iter().position(|b| b.is_ascii_whitespace()).unwrap_or(self.text.len() - start);
        self.at = start + len;
        Some((&self.text[start..start + len], column_of(self.text, start)))
    }
}

/// The column (from 1, in characters where the text is UTF-8, else in bytes) of byte `at`.
fn column_of(text: &[u8], at: usize) -> usize {
    match std::str::from_utf8(&text[..at]) {
        Ok(s) => s.chars().count() + 1,
        Err(_) => at + 1,
    }
}
