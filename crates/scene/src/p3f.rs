//! The p3f scene format: [`parse`] text or [`load`] a file into a [`Scene`].
//!
//! The grammar is the one of `p3f.md` (NFF with specular colours, a cubemap and a thin-lens camera).
//! Every error names the file, line and column, the token found and what was expected; unknown tags
//! are skipped with a [`Warning`] unless [`LoadOptions::strict`] is set.
//!
//! ```
//! use raylume_scene::p3f::{parse, LoadOptions};
//! let err = parse("v\nfrom 0 0 x", "bad.p3f", &LoadOptions::default()).unwrap_err();
//! assert_eq!(err.to_string(), "bad.p3f:2:10: expected a number (from z), found 'x'");
//! ```

use std::path::Path;

use raylume_camera::View;
use raylume_geometry::{Vec3, Vec3A};
use raylume_material::Phong;

use crate::{Light, Object, Scene, SceneError, Shape, Warning};

/// Largest image side accepted, in pixels.
pub const MAX_RESOLUTION: u32 = 16_384;
/// Largest image accepted, in pixels.
pub const MAX_PIXELS: u64 = 1 << 27;

/// How to load a file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Make warnings (unknown tags) errors.
    pub strict: bool,
    /// The folder relative file names (`obj`) are resolved in; [`load`] sets it to the scene's
    /// folder, [`parse`] uses the current folder without it.
    pub base_dir: Option<std::path::PathBuf>,
}

/// The tags of the format.
const TAGS: &[&str] = &["v", "bclr", "env", "l", "f", "s", "sm", "box", "p", "pp", "pl", "c", "mesh", "accel", "spp"];

/// Reads and parses a p3f file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<(Scene, Vec<Warning>), SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io { path: path.to_owned(), source })?;
    let mut options = options.clone();
    if options.base_dir.is_none() {
        options.base_dir = path.parent().map(Path::to_path_buf);
    }
    parse(&text, &path.display().to_string(), &options)
}

/// Parses p3f text; `file` names it in messages.
pub fn parse(text: &str, file: &str, options: &LoadOptions) -> Result<(Scene, Vec<Warning>), SceneError> {
    Parser { lex: Lexer::new(text), file, options, warnings: Vec::new() }.scene()
}

/// A token and where it starts.
#[derive(Clone, Copy, Debug)]
struct Token<'a> {
    text: &'a str,
    line: u32,
    column: u32,
}

struct Lexer<'a> {
    text: &'a str,
    pos: usize,
    line: u32,
    line_start: usize,
    peeked: Option<Option<Token<'a>>>,
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        Self { text, pos: 0, line: 1, line_start: 0, peeked: None }
    }

    fn scan(&mut self) -> Option<Token<'a>> {
        let bytes = self.text.as_bytes();
        loop {
            while self.pos < bytes.len() && bytes[self.pos].is_ascii_whitespace() {
                if bytes[self.pos] == b'\n' {
                    self.line += 1;
                    self.line_start = self.pos + 1;
                }
                self.pos += 1;
            }
            if self.pos < bytes.len() && bytes[self.pos] == b'#' {
                while self.pos < bytes.len() && bytes[self.pos] != b'\n' {
                    self.pos += 1;
                }
                continue;
            }
            break;
        }
        if self.pos >= bytes.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < bytes.len() && !bytes[self.pos].is_ascii_whitespace() && bytes[self.pos] != b'#' {
            self.pos += 1;
        }
        let column = self.text[self.line_start..start].chars().count() as u32 + 1;
        Some(Token { text: &self.text[start..self.pos], line: self.line, column })
    }

    fn next(&mut self) -> Option<Token<'a>> {
        match self.peeked.take() {
            Some(t) => t,
            None => self.scan(),
        }
    }

    fn peek(&mut self) -> Option<Token<'a>> {
        if self.peeked.is_none() {
            self.peeked = Some(self.scan());
        }
        self.peeked.unwrap()
    }

    /// Where the end of the text is, for errors at end of file.
    fn eof_position(&self) -> (u32, u32) {
        let column = self.text[self.line_start..].chars().count() as u32 + 1;
        (self.line, column)
    }

    /// The number of bytes after `pos`.
    fn remaining(&self) -> usize {
        self.text.len() - self.pos
    }
}

struct Parser<'a, 'f> {
    lex: Lexer<'a>,
    file: &'f str,
    options: &'f LoadOptions,
    warnings: Vec<Warning>,
}

impl<'a> Parser<'a, '_> {
    fn error_at(&self, line: u32, column: u32, message: String) -> SceneError {
        SceneError::Syntax { file: self.file.to_owned(), line, column, message }
    }

    fn error(&self, token: &Token, message: String) -> SceneError {
        self.error_at(token.line, token.column, message)
    }

    /// The next token, or an error naming what was expected at the end of the file.
    fn token(&mut self, expected: &str) -> Result<Token<'a>, SceneError> {
        match self.lex.next() {
            Some(t) => Ok(t),
            None => {
                let (line, column) = self.lex.eof_position();
                Err(self.error_at(line, column, format!("expected {expected}, found the end of the file")))
            }
        }
    }

    fn number(&mut self, what: &str) -> Result<f32, SceneError> {
        let t = self.token(&format!("a number ({what})"))?;
        match t.text.parse::<f64>() {
            Ok(v) if v.is_finite() && (v as f32).is_finite() => Ok(v as f32),
            Ok(_) => Err(self.error(&t, format!("expected a finite number ({what}), found '{}'", t.text))),
            Err(_) => Err(self.error(&t, format!("expected a number ({what}), found '{}'", t.text))),
        }
    }

    fn vec3(&mut self, what: &str) -> Result<Vec3A, SceneError> {
        let x = self.number(&format!("{what} x"))?;
        let y = self.number(&format!("{what} y"))?;
        let z = self.number(&format!("{what} z"))?;
        Ok(Vec3A::new(x, y, z))
    }

    fn color(&mut self, what: &str) -> Result<Vec3, SceneError> {
        let r = self.number(&format!("{what} r"))?;
        let g = self.number(&format!("{what} g"))?;
        let b = self.number(&format!("{what} b"))?;
        Ok(Vec3::new(r, g, b))
    }

    /// A positive number that must be at least `min`.
    fn positive(&mut self, what: &str) -> Result<f32, SceneError> {
        let t = self.lex.peek();
        let v = self.number(what)?;
        if v <= 0.0 {
            let t = t.expect("a number was read");
            return Err(self.error(&t, format!("expected a positive {what}, found '{}'", t.text)));
        }
        Ok(v)
    }

    /// A whole number in `min..=max`.
    fn integer(&mut self, what: &str, min: i64, max: i64) -> Result<i64, SceneError> {
        let t = self.token(&format!("an integer ({what})"))?;
        match t.text.parse::<i64>() {
            Ok(v) if (min..=max).contains(&v) => Ok(v),
            Ok(_) => Err(self.error(&t, format!("expected {what} in {min}..={max}, found '{}'", t.text))),
            Err(_) => Err(self.error(&t, format!("expected an integer ({what}), found '{}'", t.text))),
        }
    }

    fn keyword(&mut self, word: &str) -> Result<(), SceneError> {
        let t = self.token(&format!("'{word}'"))?;
        if t.text != word {
            return Err(self.error(&t, format!("expected '{word}', found '{}'", t.text)));
        }
        Ok(())
    }

    /// A count of items of `numbers_each` numbers that the rest of the file must be able to hold
    /// (each number takes at least two bytes), checked before anything is allocated.
    fn count(&mut self, what: &str, min: i64, numbers_each: usize) -> Result<usize, SceneError> {
        let t = self.lex.peek();
        let n = self.integer(what, min, u32::MAX as i64)? as usize;
        let room = self.lex.remaining() / 2 + 1;
        if n.saturating_mul(numbers_each) > room {
            let t = t.expect("a number was read");
            return Err(self.error(&t, format!("{what} is {n}, but the rest of the file holds at most {room} numbers")));
        }
        Ok(n)
    }

    fn scene(mut self) -> Result<(Scene, Vec<Warning>), SceneError> {
        let mut view = None;
        let mut background = Vec3::ZERO;
        let mut env = None;
        let mut lights = Vec::new();
        let mut materials: Vec<Phong> = Vec::new();
        let mut objects = Vec::new();
        let mut accel_hint = None;
        let mut spp_hint = None;
        let mut shutter = None;
        while let Some(tag) = self.lex.next() {
            let needs_material = matches!(tag.text, "s" | "sm" | "box" | "p" | "pp" | "pl" | "c" | "mesh" | "obj");
            if needs_material && materials.is_empty() {
                return Err(
                    self.error(&tag, format!("'{}' comes before any material: expected an 'f' entity first", tag.text))
                );
            }
            let material = materials.len().saturating_sub(1) as u32;
            let shape = match tag.text {
                "v" => {
                    view = Some(self.view()?);
                    None
                }
                "bclr" => {
                    background = self.color("background colour")?;
                    None
                }
                "env" => {
                    env = Some(self.token("an environment map name")?.text.to_owned());
                    None
                }
                "l" => {
                    let position = self.vec3("light position")?;
                    let color = if self.next_is_number() { self.color("light colour")? } else { Vec3::ONE };
                    // raylume's extension: a 7th number makes it a square area light of that side.
                    let mut size = 0.0;
                    if self.next_is_number() {
                        let t = self.lex.peek().expect("a number is next");
                        size = self.number("area light size")?;
                        if size < 0.0 {
                            return Err(self.error(&t, format!("expected an area light size >= 0, found '{}'", t.text)));
                        }
                    }
                    lights.push(Light { position, color, size });
                    None
                }
                "f" => {
                    materials.push(self.material()?);
                    None
                }
                "s" => {
                    let center = self.vec3("sphere centre")?;
                    let radius = self.positive("sphere radius")?;
                    Some(Shape::Sphere { center, radius })
                }
                "sm" => {
                    let center0 = self.vec3("moving sphere centre 0")?;
                    let center1 = self.vec3("moving sphere centre 1")?;
                    let radius = self.positive("moving sphere radius")?;
                    let time0 = self.number("moving sphere t0")?;
                    let time1 = self.number("moving sphere t1")?;
                    Some(Shape::MovingSphere { center0, center1, radius, time0, time1 })
                }
                "box" => {
                    let min = self.vec3("box min")?;
                    let t = self.lex.peek();
                    let max = self.vec3("box max")?;
                    if min.cmpgt(max).any() {
                        let t = t.expect("a number was read");
                        return Err(self.error(&t, "expected box max >= box min on every axis".to_owned()));
                    }
                    Some(Shape::Box { min, max })
                }
                "p" => {
                    let n = self.count("polygon vertex count", 3, 3)?;
                    let mut v = Vec::with_capacity(n);
                    for i in 0..n {
                        v.push(self.vec3(&format!("polygon vertex {}", i + 1))?);
                    }
                    Some(Shape::Polygon(v))
                }
                "pp" => {
                    let n = self.count("patch vertex count", 3, 6)?;
                    let mut v = Vec::with_capacity(n);
                    for i in 0..n {
                        let p = self.vec3(&format!("patch vertex {}", i + 1))?;
                        let nrm = self.vec3(&format!("patch normal {}", i + 1))?;
                        v.push((p, nrm));
                    }
                    Some(Shape::Patch(v))
                }
                "pl" => {
                    let p0 = self.vec3("plane point 0")?;
                    let p1 = self.vec3("plane point 1")?;
                    let p2 = self.vec3("plane point 2")?;
                    if raylume_geometry::Plane::from_points(p0, p1, p2).is_none() {
                        return Err(self.error(&tag, "expected three plane points that are not collinear".to_owned()));
                    }
                    Some(Shape::Plane([p0, p1, p2]))
                }
                "c" => {
                    let base = self.vec3("cone base")?;
                    let base_radius = self.number("cone base radius")?;
                    let apex = self.vec3("cone apex")?;
                    let apex_radius = self.number("cone apex radius")?;
                    if base_radius < 0.0 || apex_radius < 0.0 || (base_radius == 0.0 && apex_radius == 0.0) {
                        return Err(self.error(&tag, "expected cone radii >= 0, not both 0".to_owned()));
                    }
                    Some(Shape::Cone { base, base_radius, apex, apex_radius })
                }
                "mesh" => Some(self.mesh()?),
                "obj" => Some(self.obj()?),
                "accel" => {
                    accel_hint = Some(self.integer("accelerator (0 none, 1 grid, 2 BVH)", 0, 2)? as u32);
                    None
                }
                "spp" => {
                    spp_hint = Some(self.integer("samples per pixel", 0, 1 << 16)? as u32);
                    None
                }
                "shutter" => {
                    let t0 = self.number("shutter open time")?;
                    let t = self.lex.peek();
                    let t1 = self.number("shutter close time")?;
                    if t1 < t0 {
                        let t = t.expect("a number was read");
                        return Err(
                            self.error(&t, format!("expected a shutter close time >= {t0}, found '{}'", t.text))
                        );
                    }
                    shutter = Some((t0, t1));
                    None
                }
                _ => {
                    self.unknown(&tag)?;
                    None
                }
            };
            if let Some(shape) = shape {
                objects.push(Object { material, shape });
            }
        }
        let Some(view) = view else {
            let (line, column) = self.lex.eof_position();
            return Err(self.error_at(
                line,
                column,
                "expected a camera ('v' entity), found none in the file".to_owned(),
            ));
        };
        let scene = Scene { view, background, env, lights, materials, objects, accel_hint, spp_hint, shutter };
        Ok((scene, self.warnings))
    }

    fn next_is_number(&mut self) -> bool {
        self.lex.peek().is_some_and(|t| t.text.parse::<f64>().is_ok())
    }

    /// Skips an unknown tag and its numbers (up to the next known tag), with a warning.
    fn unknown(&mut self, tag: &Token) -> Result<(), SceneError> {
        let message = if TAGS.iter().any(|k| k.eq_ignore_ascii_case(tag.text)) || tag.text.parse::<f64>().is_err() {
            format!("unknown tag '{}' (expected one of {}), skipped", tag.text, TAGS.join(" "))
        } else {
            format!("unexpected number '{}' where a tag was expected, skipped", tag.text)
        };
        if self.options.strict {
            return Err(self.error(tag, message.replace(", skipped", "")));
        }
        self.warnings.push(Warning { file: self.file.to_owned(), line: tag.line, column: tag.column, message });
        while let Some(t) = self.lex.peek() {
            if TAGS.contains(&t.text) {
                break;
            }
            self.lex.next();
        }
        Ok(())
    }

    fn view(&mut self) -> Result<View, SceneError> {
        self.keyword("from")?;
        let from = self.vec3("from")?;
        self.keyword("at")?;
        let at = self.vec3("at")?;
        self.keyword("up")?;
        let up_token = self.lex.peek();
        let up = self.vec3("up")?;
        self.keyword("angle")?;
        let angle_token = self.lex.peek();
        let angle_deg = self.number("angle in degrees")?;
        if !(angle_deg > 0.0 && angle_deg < 180.0) {
            let t = angle_token.expect("a number was read");
            return Err(self.error(&t, format!("expected an angle in (0, 180) degrees, found '{}'", t.text)));
        }
        self.keyword("hither")?;
        let hither = self.number("hither")?;
        self.keyword("resolution")?;
        let res_token = self.lex.peek();
        let width = self.integer("resolution width", 1, MAX_RESOLUTION as i64)? as u32;
        let height = self.integer("resolution height", 1, MAX_RESOLUTION as i64)? as u32;
        if width as u64 * height as u64 > MAX_PIXELS {
            let t = res_token.expect("a number was read");
            return Err(self.error(&t, format!("resolution {width} x {height} exceeds {MAX_PIXELS} pixels")));
        }
        let (mut aperture, mut focal) = (0.0, 1.0);
        if self.lex.peek().is_some_and(|t| t.text == "aperture") {
            self.lex.next();
            aperture = self.number("aperture")?;
            if aperture < 0.0 {
                return Err(self.error(&res_token.expect("read"), "expected aperture >= 0".to_owned()));
            }
            self.keyword("focal")?;
            focal = self.positive("focal ratio")?;
        }
        let dir = from - at;
        if dir.length_squared() == 0.0 || up.cross(dir).length_squared() == 0.0 {
            let t = up_token.expect("a number was read");
            return Err(
                self.error(&t, "expected 'from' != 'at' and 'up' not parallel to the view direction".to_owned())
            );
        }
        Ok(View { from, at, up, angle_deg, hither, width, height, aperture, focal })
    }

    fn material(&mut self) -> Result<Phong, SceneError> {
        let diffuse = self.color("diffuse colour")?;
        let kd = self.number("Kd")?;
        let specular = self.color("specular colour")?;
        let ks = self.number("Ks")?;
        let shine = self.number("shine")?;
        let transmittance = self.number("transmittance")?;
        let ior_token = self.lex.peek();
        let ior = self.number("index of refraction")?;
        if transmittance > 0.0 && ior <= 0.0 {
            let t = ior_token.expect("a number was read");
            return Err(self.error(
                &t,
                format!("expected a positive index of refraction for a transparent material, found '{}'", t.text),
            ));
        }
        // raylume's extension: an optional 12th number, the roughness of mirror reflections.
        let mut roughness = 0.0;
        if self.next_is_number() {
            let t = self.lex.peek().expect("a number is next");
            roughness = self.number("roughness")?;
            if !(0.0..=1.0).contains(&roughness) {
                return Err(self.error(&t, format!("expected a roughness in [0, 1], found '{}'", t.text)));
            }
        }
        Ok(Phong { diffuse, kd, specular, ks, shine, transmittance, ior, specular_scale: 1.0, roughness })
    }

    /// raylume's extension `obj FILE [scale tx ty tz]`: an OBJ mesh, path relative to the scene's
    /// folder, optionally scaled then translated.
    fn obj(&mut self) -> Result<Shape, SceneError> {
        let name = self.token("an OBJ file name")?;
        let path = self.options.base_dir.as_deref().unwrap_or(Path::new(".")).join(name.text);
        let shape = crate::obj::load(&path).map_err(|e| self.error(&name, format!("obj '{}': {e}", name.text)))?;
        let (mut scale, mut offset) = (1.0, Vec3A::ZERO);
        if self.next_is_number() {
            let t = self.lex.peek().expect("a number is next");
            scale = self.number("obj scale")?;
            if scale <= 0.0 {
                return Err(self.error(&t, format!("expected a positive obj scale, found '{}'", t.text)));
            }
            offset = self.vec3("obj translation")?;
        }
        Ok(match shape {
            Shape::Mesh { vertices, triangles } => {
                Shape::Mesh { vertices: vertices.into_iter().map(|v| v * scale + offset).collect(), triangles }
            }
            other => other,
        })
    }

    fn mesh(&mut self) -> Result<Shape, SceneError> {
        let nv = self.count("mesh vertex count", 3, 3)?;
        let nf_token = self.lex.peek();
        let nf = self.integer("mesh triangle count", 0, u32::MAX as i64)? as usize;
        let room = self.lex.remaining() / 2 + 1;
        if nv.saturating_mul(3).saturating_add(nf.saturating_mul(3)) > room {
            let t = nf_token.expect("a number was read");
            return Err(self.error(
                &t,
                format!(
                    "mesh of {nv} vertices and {nf} triangles, but the rest of the file holds at most {room} numbers"
                ),
            ));
        }
        let mut vertices = Vec::with_capacity(nv);
        for i in 0..nv {
            vertices.push(self.vec3(&format!("mesh vertex {}", i + 1))?);
        }
        let mut triangles = Vec::with_capacity(nf);
        for f in 0..nf {
            let mut tri = [0u32; 3];
            for (k, slot) in tri.iter_mut().enumerate() {
                let t = self.token("a vertex index")?;
                let what = format!("vertex index {} of mesh triangle {}", k + 1, f + 1);
                let Ok(i) = t.text.parse::<i64>() else {
                    return Err(self.error(&t, format!("expected an integer ({what}), found '{}'", t.text)));
                };
                // 1-based; non-positive counts back from the end (OBJ style).
                let zero_based = if i > 0 { i - 1 } else { nv as i64 + i };
                if zero_based < 0 || zero_based >= nv as i64 {
                    return Err(self.error(&t, format!("{what} is {i}, out of range for {nv} vertices")));
                }
                *slot = zero_based as u32;
            }
            triangles.push(tri);
        }
        Ok(Shape::Mesh { vertices, triangles })
    }
}
