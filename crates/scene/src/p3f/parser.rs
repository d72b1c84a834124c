//! The grammar of every dialect: one entity at a time, each read by its tag and the count of
//! numbers that follow it.

use std::collections::BTreeSet;
use std::fmt::Display;
use std::path::Path;

use raylume_camera::View;
use raylume_geometry::{Vec3, Vec3A};
use raylume_material::Phong;

use super::lexer::{Lexer, Token, shown};
use super::{Dialect, LoadOptions, Loaded, MAX_COORDINATE, MAX_PIXELS, MAX_RESOLUTION, env_search_dirs};
use crate::{AccelHint, Light, LightShape, Object, Scene, SceneError, Shape, Warning};

/// Every tag of every dialect.
const TAGS: &[&str] = &[
    "v", "camera", "bclr", "b", "env", "fire", "l", "light", "al", "f", "mat", "s", "sm", "ms", "box", "aabb", "p",
    "pp", "pl", "npl", "c", "mesh", "obj", "accel", "spp", "shutter",
];

/// The tags that make an object (and need a material before them).
const OBJECT_TAGS: &[&str] = &["s", "sm", "ms", "box", "aabb", "p", "pp", "pl", "npl", "c", "mesh", "obj"];

/// The camera's keywords, in the order the format writes them.
const CAMERA_KEYWORDS: &[&str] = &["from", "at", "up", "angle", "hither", "resolution", "aperture", "focal"];

pub(super) struct Parser<'a, 'f> {
    lex: Lexer<'a>,
    file: &'f str,
    options: &'f LoadOptions,
    warnings: Vec<Warning>,
    /// Signs of NFF and of the 2024/25 syntax seen so far.
    nff: bool,
    p3f2024: bool,
    extensions: BTreeSet<&'static str>,
}

/// What one entity added to the scene.
enum Entity {
    Nothing,
    Object(Shape),
    Light(Light),
    Material(Phong),
}

#[derive(Default)]
struct SceneParts<'a> {
    view: Option<View>,
    /// The tag of the camera block kept in `view`.
    view_tag: Option<Token<'a>>,
    background: Vec3,
    env: Option<(String, Token<'a>)>,
    lights: Vec<Light>,
    materials: Vec<Phong>,
    objects: Vec<Object>,
    accel_hint: Option<AccelHint>,
    spp_hint: Option<u32>,
    shutter: Option<(f32, f32)>,
}

impl<'a, 'f> Parser<'a, 'f> {
    pub fn new(text: &'a str, file: &'f str, options: &'f LoadOptions) -> Self {
        let nff = Path::new(file).extension().is_some_and(|e| e.eq_ignore_ascii_case("nff"));
        Self {
            lex: Lexer::new(text),
            file,
            options,
            warnings: Vec::new(),
            nff,
            p3f2024: false,
            extensions: BTreeSet::new(),
        }
    }

    fn error_at(&self, line: u32, column: u32, message: String) -> SceneError {
        SceneError::Syntax { file: self.file.to_owned(), line, column, message, warnings: Vec::new() }
    }

    fn error(&self, token: &Token, message: String) -> SceneError {
        self.error_at(token.line, token.column, message)
    }

    /// Records a warning, or fails with it as an error under `strict`.
    fn warn(&mut self, token: &Token, message: String) -> Result<(), SceneError> {
        if self.options.strict {
            return Err(self.error(token, format!("{message} (an error when loading strictly)")));
        }
        self.warnings.push(Warning { file: self.file.to_owned(), line: token.line, column: token.column, message });
        Ok(())
    }

    /// The next token, or an error naming what was expected at the end of the file.
    fn token(&mut self, expected: impl Display) -> Result<Token<'a>, SceneError> {
        match self.lex.next() {
            Some(t) => Ok(t),
            None => {
                let (line, column) = self.lex.eof_position();
                Err(self.error_at(line, column, format!("expected {expected}, found the end of the file")))
            }
        }
    }

    fn number(&mut self, what: impl Display) -> Result<f32, SceneError> {
        let t = self.token(format_args!("a number ({what})"))?;
        self.number_of(&t, what)
    }

    fn number_of(&self, t: &Token, what: impl Display) -> Result<f32, SceneError> {
        match t.text.parse::<f64>() {
            Ok(v) if v.is_finite() && (v as f32).is_finite() => Ok(v as f32),
            Ok(_) => Err(self.error(t, format!("expected a finite number ({what}), found '{}'", t.shown()))),
            Err(_) => Err(self.error(t, format!("expected a number ({what}), found '{}'", t.shown()))),
        }
    }

    /// A number checked by `ok`, with `expected` in the message if it fails.
    fn number_where(&mut self, what: &str, expected: &str, ok: impl Fn(f32) -> bool) -> Result<f32, SceneError> {
        let t = self.token(format_args!("a number ({what})"))?;
        let v = self.number_of(&t, what)?;
        if !ok(v) {
            // A number written non-zero that rounds to zero in f32 (below about 1.4e-45) says so.
            let rounded =
                if v == 0.0 && nonzero_mantissa(t.text) { ", which rounds to 0 in single precision" } else { "" };
            return Err(self.error(&t, format!("expected {expected}, found '{}'{rounded}", t.shown())));
        }
        Ok(v)
    }

    /// A point or direction: three numbers within [`MAX_COORDINATE`] of 0.
    fn vec3(&mut self, what: impl Display) -> Result<Vec3A, SceneError> {
        let x = self.coordinate(format_args!("{what} x"))?;
        let y = self.coordinate(format_args!("{what} y"))?;
        let z = self.coordinate(format_args!("{what} z"))?;
        Ok(Vec3A::new(x, y, z))
    }

    fn coordinate(&mut self, what: impl Display) -> Result<f32, SceneError> {
        let t = self.token(format_args!("a number ({what})"))?;
        let v = self.number_of(&t, &what)?;
        if v.abs() > MAX_COORDINATE {
            return Err(self.error(
                &t,
                format!(
                    "expected a coordinate ({what}) within ±{MAX_COORDINATE:e} (squared distances beyond overflow \
                     single precision), found '{}'",
                    t.shown()
                ),
            ));
        }
        Ok(v)
    }

    /// A colour: three numbers. A negative one is kept, with a warning: it takes light away.
    fn color(&mut self, what: impl Display) -> Result<Vec3, SceneError> {
        let mut rgb = [0.0; 3];
        for (value, channel) in rgb.iter_mut().zip(["r", "g", "b"]) {
            let t = self.lex.peek();
            *value = self.number(format_args!("{what} {channel}"))?;
            if let Some(t) = t.filter(|_| *value < 0.0) {
                let message = format!("{what} {channel} is negative ({}): it takes light away", t.shown());
                self.warn(&t, message)?;
            }
        }
        Ok(Vec3::from_array(rgb))
    }

    /// A whole number in `min..=max`.
    fn integer(&mut self, what: impl Display, min: i64, max: i64) -> Result<i64, SceneError> {
        let t = self.token(format_args!("an integer ({what})"))?;
        match t.text.parse::<i64>() {
            Ok(v) if (min..=max).contains(&v) => Ok(v),
            // Digits beyond i64 are an integer too, out of range.
            Ok(_) | Err(_) if is_digits(t.text) => {
                Err(self.error(&t, format!("expected {what} in {min}..={max}, found '{}'", t.shown())))
            }
            _ => match t.text.parse::<f64>() {
                // A whole number written with a fraction or an exponent (`512.0`, `5.12e2`), as programs
                // that print every number as a float write it: read as that integer, with a warning.
                Ok(v) if v.is_finite() && v.fract() == 0.0 => {
                    if !(min as f64..=max as f64).contains(&v) {
                        return Err(self.error(&t, format!("expected {what} in {min}..={max}, found '{}'", t.shown())));
                    }
                    let message = format!("{what} '{}' is a whole number written as a decimal: read as {v}", t.shown());
                    self.warn(&t, message)?;
                    Ok(v as i64)
                }
                _ => Err(self.error(&t, format!("expected an integer ({what}), found '{}'", t.shown()))),
            },
        }
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

    /// How many numbers follow (at most `limit`), checked against the counts `allowed` that the
    /// entity's forms take.
    fn form(&mut self, tag: &Token, allowed: &[usize], forms: &str) -> Result<usize, SceneError> {
        let limit = allowed.iter().max().copied().unwrap_or(0) + 1;
        // The numbers on the tag's line first: lines of stray numbers after it (a polygon's vertices
        // left behind by a commented-out tag) are then skipped with a warning, as numbers where a
        // tag belongs.
        let on_line = self.lex.numbers_on_line(tag.line, limit);
        if allowed.contains(&on_line) {
            return Ok(on_line);
        }
        let n = self.lex.numbers_ahead(limit);
        if allowed.contains(&n) {
            return Ok(n);
        }
        let found = match n {
            1 => "1 number".to_owned(),
            n if n == limit => format!("more than {} numbers", limit - 1),
            n => format!("{n} numbers"),
        };
        Err(self.error(tag, format!("expected {forms} after '{}', found {found}", tag.text)))
    }

    pub fn scene(mut self) -> Result<Loaded, SceneError> {
        match self.entities() {
            Ok(parts) => self.finish(parts),
            Err(e) => {
                let warnings = std::mem::take(&mut self.warnings);
                Err(e.with_earlier_warnings(warnings))
            }
        }
    }

    fn entities(&mut self) -> Result<SceneParts<'a>, SceneError> {
        let mut parts = SceneParts::default();
        while let Some(tag) = self.lex.next() {
            // Some programs' files give no material at all: their objects are white and diffuse.
            if OBJECT_TAGS.contains(&tag.text) && parts.materials.is_empty() {
                let message = format!(
                    "'{}' comes before any material: it takes a white diffuse one, as 'f 1 1 1 1 0 0 0 0 1 0 1' gives",
                    tag.text
                );
                self.warn(&tag, message)?;
                parts.materials.push(Phong::default());
            }
            match self.entity(&tag, &mut parts)? {
                Entity::Nothing => {}
                Entity::Object(shape) => {
                    // An OBJ file's reader names its faces without area at their lines.
                    if let Some(message) = shape.never_hit().filter(|_| tag.text != "obj") {
                        self.warn(&tag, message)?;
                    }
                    let material = parts.materials.len() as u32 - 1;
                    parts.objects.push(Object { material, shape });
                }
                Entity::Light(light) => parts.lights.push(light),
                Entity::Material(m) => parts.materials.push(m),
            }
        }
        Ok(parts)
    }

    fn entity(&mut self, tag: &Token<'a>, parts: &mut SceneParts<'a>) -> Result<Entity, SceneError> {
        Ok(match tag.text {
            "v" => {
                let view = self.view(tag, "from")?;
                self.keep_view(tag, view, parts)?;
                Entity::Nothing
            }
            "camera" => {
                self.p3f2024 = true;
                let view = self.view(tag, "eye")?;
                self.keep_view(tag, view, parts)?;
                Entity::Nothing
            }
            "bclr" => {
                parts.background = self.color("background colour")?;
                Entity::Nothing
            }
            "b" => {
                self.nff = true;
                parts.background = self.color("background colour")?;
                Entity::Nothing
            }
            "env" | "fire" => {
                if tag.text == "fire" {
                    self.extensions.insert("fire");
                }
                // The folder's name is on the tag's line: a bare tag names nothing, and the next
                // line's tag stays a tag.
                let name = match self.lex.peek() {
                    Some(name) if name.line == tag.line => self.lex.next().expect("peeked"),
                    _ => {
                        let message = format!("'{}' without a cubemap folder name on its line: ignored", tag.text);
                        self.warn(tag, message)?;
                        return Ok(Entity::Nothing);
                    }
                };
                if let Some((first, _)) = &parts.env {
                    let message = format!("a second cubemap '{}' is ignored: the scene uses '{first}'", name.shown());
                    self.warn(tag, message)?;
                } else {
                    parts.env = Some((name.text.to_owned(), *tag));
                }
                Entity::Nothing
            }
            "l" => Entity::Light(self.light(tag)?),
            "light" => Entity::Light(self.light_2024(tag)?),
            "al" => Entity::Light(self.area_light(tag)?),
            "f" | "mat" => Entity::Material(self.material(tag)?),
            "s" => {
                let center = self.vec3("sphere centre")?;
                match self.radius("sphere radius")? {
                    Some(radius) => Entity::Object(Shape::Sphere { center, radius }),
                    None => Entity::Nothing,
                }
            }
            "sm" => self.moving_sphere(false)?.map_or(Entity::Nothing, Entity::Object),
            "ms" => {
                self.extensions.insert("ms");
                let timed = self.form(tag, &[7, 9], "7 (c0 c1 r) or 9 (c0 c1 r t0 t1) numbers")? == 9;
                self.moving_sphere(!timed)?.map_or(Entity::Nothing, Entity::Object)
            }
            "box" | "aabb" => {
                if tag.text == "aabb" {
                    self.nff = true;
                }
                let a = self.vec3("box corner")?;
                let b = self.vec3("box opposite corner")?;
                let (min, max) = (a.min(b), a.max(b));
                // Flat on one axis, a box is a rectangle; on two or three, it has no area.
                if (max - min).cmpeq(Vec3A::ZERO).bitmask().count_ones() >= 2 {
                    self.warn(
                        tag,
                        "a box whose corners meet on two axes or more has no area: it is skipped".to_owned(),
                    )?;
                    Entity::Nothing
                } else {
                    Entity::Object(Shape::Box { min, max })
                }
            }
            "p" => {
                let n = self.count("polygon vertex count", 3, 3)?;
                let mut v = Vec::with_capacity(n);
                for i in 0..n {
                    v.push(self.vec3(format_args!("polygon vertex {}", i + 1))?);
                }
                Entity::Object(Shape::Polygon(v))
            }
            "pp" => {
                let n = self.count("patch vertex count", 3, 6)?;
                let mut v = Vec::with_capacity(n);
                for i in 0..n {
                    let p = self.vec3(format_args!("patch vertex {}", i + 1))?;
                    let nrm = self.vec3(format_args!("patch normal {}", i + 1))?;
                    v.push((p, nrm));
                }
                Entity::Object(Shape::Patch(v))
            }
            "pl" => {
                let p0 = self.vec3("plane point 0")?;
                let p1 = self.vec3("plane point 1")?;
                let p2 = self.vec3("plane point 2")?;
                if raylume_geometry::Plane::from_points(p0, p1, p2).is_none() {
                    return Err(self.error(tag, "expected three plane points that are not collinear".to_owned()));
                }
                Entity::Object(Shape::Plane([p0, p1, p2]))
            }
            "npl" => {
                self.p3f2024 = true;
                let n = self.vec3("plane normal")?;
                let d = self.number("plane offset D")?;
                let Some(points) = plane_points(n, d) else {
                    return Err(self.error(
                        tag,
                        "expected a plane normal that is not zero and a plane at a finite distance".to_owned(),
                    ));
                };
                Entity::Object(Shape::Plane(points))
            }
            "c" => {
                let base = self.vec3("cone base")?;
                let base_radius = self.coordinate("cone base radius")?.abs();
                let apex = self.vec3("cone apex")?;
                let apex_radius = self.coordinate("cone apex radius")?.abs();
                let degenerate = if base_radius == 0.0 && apex_radius == 0.0 {
                    Some("a cone whose radii are both 0 has no surface: skipped")
                } else if base == apex {
                    Some("a cone whose base and apex are one point has no surface: skipped")
                } else {
                    None
                };
                match degenerate {
                    Some(message) => {
                        self.warn(tag, message.to_owned())?;
                        Entity::Nothing
                    }
                    None => Entity::Object(Shape::Cone { base, base_radius, apex, apex_radius }),
                }
            }
            "mesh" => self.mesh()?.map_or(Entity::Nothing, Entity::Object),
            "obj" => {
                self.extensions.insert("obj");
                Entity::Object(self.obj()?)
            }
            "accel" => {
                parts.accel_hint = Some(self.accel()?);
                Entity::Nothing
            }
            "spp" => {
                parts.spp_hint = Some(self.integer("samples per pixel", 0, 1 << 16)? as u32);
                Entity::Nothing
            }
            "shutter" => {
                self.extensions.insert("shutter");
                let t0 = self.number("shutter open time")?;
                let t1 =
                    self.number_where("shutter close time", &format!("a shutter close time >= {t0}"), |t| t >= t0)?;
                parts.shutter = Some((t0, t1));
                Entity::Nothing
            }
            _ => {
                self.unknown(tag)?;
                Entity::Nothing
            }
        })
    }

    /// Puts the parts together: checks the camera and the cubemap.
    fn finish(mut self, parts: SceneParts<'a>) -> Result<Loaded, SceneError> {
        let Some(view) = parts.view else {
            let (line, column) = self.lex.eof_position();
            let e = self.error_at(line, column, "expected a camera ('v' entity), found none in the file".to_owned());
            return Err(e.with_earlier_warnings(self.warnings));
        };
        let env = parts.env;
        if let Some((name, tag)) = env.as_ref().filter(|_| !self.options.ignore_env) {
            let dirs = env_search_dirs(self.options.base_dir.as_deref(), &self.options.env_dirs);
            if let Err(why) = crate::cubemap::find_cubemap(name, &dirs) {
                if self.options.strict {
                    let message = format!(
                        "environment map: {why} (an error when loading strictly; without the cubemap, --no-env \
                         or LoadOptions::ignore_env)"
                    );
                    return Err(self.error(tag, message).with_earlier_warnings(self.warnings));
                }
                let message = format!("environment map: {why}; escaping rays show the background colour");
                self.warn(tag, message)?;
            }
        }
        let scene = Scene {
            view,
            background: parts.background,
            env: env.map(|(name, _)| name),
            lights: parts.lights,
            materials: parts.materials,
            objects: parts.objects,
            accel_hint: parts.accel_hint,
            spp_hint: parts.spp_hint,
            shutter: parts.shutter,
            base_dir: self.options.base_dir.clone(),
        };
        let dialect = if self.p3f2024 {
            Dialect::P3f2024
        } else if self.nff {
            Dialect::Nff
        } else {
            Dialect::P3f
        };
        Ok(Loaded { scene, warnings: self.warnings, dialect, extensions: self.extensions.into_iter().collect() })
    }

    /// Skips what the reader does not know, with a warning: an unknown word and the rest of its
    /// line, and the lines of numbers that follow it (its data), as the course's line-based
    /// readers did; or a run of numbers where a tag was expected.
    fn unknown(&mut self, tag: &Token<'a>) -> Result<(), SceneError> {
        if tag.is_number() {
            let mut skipped = 1;
            while self.lex.peek().is_some_and(|t| t.is_number()) {
                self.lex.next();
                skipped += 1;
            }
            let what = if skipped == 1 { "number".to_owned() } else { format!("numbers (the first of {skipped})") };
            return self.warn(tag, format!("unexpected {what} '{}' where a tag was expected, skipped", tag.shown()));
        }
        let hint = match TAGS.iter().find(|k| k.eq_ignore_ascii_case(tag.text)) {
            Some(k) => format!(" (tags are lower case: '{k}')"),
            None => String::new(),
        };
        let line = shown(self.lex.skip_line(tag));
        let mut more = 0;
        while self.lex.peek().is_some_and(|t| t.first_on_line && t.is_number()) {
            let t = self.lex.next().expect("peeked");
            self.lex.skip_line(&t);
            more += 1;
        }
        let also = match more {
            0 => String::new(),
            1 => " and the line of numbers after it".to_owned(),
            n => format!(" and the {n} lines of numbers after it"),
        };
        self.warn(tag, format!("unknown tag '{}'{hint}: skipped '{line}'{also}", tag.shown()))
    }

    /// Keeps `view`, the camera block that starts at `tag`; a second block replaces the first with a
    /// warning at its line.
    fn keep_view(&mut self, tag: &Token<'a>, view: View, parts: &mut SceneParts<'a>) -> Result<(), SceneError> {
        if let Some(first) = parts.view_tag.replace(*tag) {
            let message = format!(
                "a second camera block replaces the one at line {}: the scene is seen from this one",
                first.line
            );
            self.warn(tag, message)?;
        }
        parts.view = Some(view);
        Ok(())
    }

    /// A sphere's radius, within [`MAX_COORDINATE`]; a negative radius (NFF: the inside is visible)
    /// is its size. `None`, with a warning (an error when loading strictly), for a radius of 0 in
    /// single precision: the sphere has no surface and is left out.
    fn radius(&mut self, what: &str) -> Result<Option<f32>, SceneError> {
        let t = self.token(format_args!("a number ({what})"))?;
        let r = self.number_of(&t, what)?;
        if r.abs() > MAX_COORDINATE {
            let message = format!("expected a {what} within ±{MAX_COORDINATE:e}, found '{}'", t.shown());
            return Err(self.error(&t, message));
        }
        if r != 0.0 {
            return Ok(Some(r.abs()));
        }
        let written = if nonzero_mantissa(t.text) { ", which rounds to 0 in single precision," } else { "" };
        self.warn(&t, format!("a {what} of '{}'{written} leaves no surface: the sphere is skipped", t.shown()))?;
        Ok(None)
    }

    /// A moving sphere's numbers; `None` (with a warning) for a radius of 0.
    fn moving_sphere(&mut self, untimed: bool) -> Result<Option<Shape>, SceneError> {
        let center0 = self.vec3("moving sphere centre 0")?;
        let center1 = self.vec3("moving sphere centre 1")?;
        let radius = self.radius("moving sphere radius")?;
        let (time0, time1) =
            if untimed { (0.0, 1.0) } else { (self.number("moving sphere t0")?, self.number("moving sphere t1")?) };
        Ok(radius.map(|radius| Shape::MovingSphere { center0, center1, radius, time0, time1 }))
    }

    /// `l x y z [r g b [size]]`: a point light, white without a colour; raylume's 7th number makes
    /// it a square area light of that side.
    fn light(&mut self, tag: &Token) -> Result<Light, SceneError> {
        let n = self.form(tag, &[3, 6, 7], "3 (x y z), 6 (x y z r g b) or 7 (x y z r g b size) numbers")?;
        let position = self.vec3("light position")?;
        let color = if n >= 6 { self.color("light colour")? } else { Vec3::ONE };
        let shape = if n == 7 {
            self.extensions.insert("area light size");
            LightShape::Square(self.number_where("area light size", "an area light size >= 0", |s| s >= 0.0)?)
        } else {
            LightShape::Point
        };
        Ok(Light { position, color, shape })
    }

    /// `light punctual x y z r g b` or `light quad x y z r g b v1 v2 grid_res` (2024/25).
    fn light_2024(&mut self, tag: &Token) -> Result<Light, SceneError> {
        self.p3f2024 = true;
        let kind = self.token("a light kind (punctual or quad)")?;
        let quad = match kind.text {
            "punctual" => false,
            "quad" => true,
            other => {
                let message =
                    format!("expected a light kind (punctual or quad) after '{}', found '{}'", tag.text, shown(other));
                return Err(self.error(&kind, message));
            }
        };
        let position = self.vec3("light position")?;
        let color = self.color("light colour")?;
        let shape = if quad {
            let e1 = self.vec3("quad light edge end 1")?;
            let e2 = self.vec3("quad light edge end 2")?;
            let grid = self.integer("quad light grid resolution (0: the render's)", 0, 64)? as u32;
            LightShape::Parallelogram { ends: [e1, e2], grid }
        } else {
            LightShape::Point
        };
        Ok(Light { position, color, shape })
    }

    /// `al x y z ax ay az w h [r g b]`: a rectangle centred at x y z facing a, w wide and h high
    /// (students' area light). Its width runs along `a × up` (up = +Y, or +Z when `a` is vertical).
    fn area_light(&mut self, tag: &Token) -> Result<Light, SceneError> {
        self.extensions.insert("al");
        let n = self.form(tag, &[8, 11], "8 (x y z ax ay az w h) or 11 (… r g b) numbers")?;
        let center = self.vec3("area light centre")?;
        let facing = self.vec3("area light direction")?;
        let width = self.number_where("area light width", "an area light width >= 0", |w| w >= 0.0)?;
        let height = self.number_where("area light height", "an area light height >= 0", |h| h >= 0.0)?;
        let color = if n == 11 { self.color("area light colour")? } else { Vec3::ONE };
        let Some(a) = facing.try_normalize() else {
            return Err(self.error(tag, "expected an area light direction that is not zero".to_owned()));
        };
        let up = if a.cross(Vec3A::Y).length_squared() > 1e-6 { Vec3A::Y } else { Vec3A::Z };
        let across = a.cross(up).normalize();
        let (u, v) = (across * width, across.cross(a) * height);
        let corner = center - (u + v) * 0.5;
        if !(corner.is_finite() && (corner + u).is_finite() && (corner + v).is_finite()) {
            return Err(self.error(tag, "expected an area light whose corners are finite numbers".to_owned()));
        }
        Ok(Light {
            position: corner,
            color,
            shape: LightShape::Parallelogram { ends: [corner + u, corner + v], grid: 0 },
        })
    }

    /// `accel N` (0 none, 1 grid, 2 BVH) or, in 2024/25, `accel none|grid|bvh`.
    fn accel(&mut self) -> Result<AccelHint, SceneError> {
        let t = self.lex.peek();
        if let Some(word) = t.filter(|t| !t.is_number()) {
            let hint = match word.text.to_ascii_lowercase().as_str() {
                "none" => AccelHint::None,
                "grid" => AccelHint::Grid,
                "bvh" => AccelHint::Bvh,
                _ => {
                    return Err(self.error(
                        &word,
                        format!("expected an accelerator (0 or none, 1 or grid, 2 or bvh), found '{}'", word.shown()),
                    ));
                }
            };
            self.lex.next();
            self.p3f2024 = true;
            return Ok(hint);
        }
        Ok(AccelHint::ALL[self.integer("accelerator (0 none, 1 grid, 2 BVH)", 0, 2)? as usize])
    }

    /// The camera: `v from …` (or 2024/25 `camera eye …`) and its keywords. They may come in any
    /// order; `aperture` and `focal` may be left out (a pinhole).
    fn view(&mut self, tag: &Token, first: &str) -> Result<View, SceneError> {
        let mut seen: [Option<Token>; 8] = [None; 8];
        let mut up_numbers = None;
        let (mut from, mut at, mut up) = (Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO);
        let (mut angle_deg, mut hither, mut width, mut height, mut aperture, mut focal) = (0.0, 0.0, 0, 0, 0.0, 1.0);
        loop {
            let next = self.lex.peek();
            let index = next.and_then(|t| {
                let word = if t.text == "eye" { "from" } else { t.text };
                CAMERA_KEYWORDS.iter().position(|k| *k == word)
            });
            let Some(index) = index else {
                // The block ends at the first word that is not a camera keyword, once it is complete.
                let required = [0, 1, 2, 3, 4, 5];
                if let Some(&missing) = required.iter().find(|&&i| seen[i].is_none()) {
                    let keyword = if missing == 0 { first } else { CAMERA_KEYWORDS[missing] };
                    let expected = format!("'{keyword}'");
                    return match next {
                        Some(t) => Err(self.error(&t, format!("expected {expected}, found '{}'", t.shown()))),
                        None => self.token(&expected).map(|_| unreachable!()),
                    };
                }
                break;
            };
            let keyword = self.lex.next().expect("peeked");
            if seen[index].is_some() {
                return Err(self.error(&keyword, format!("camera keyword '{}' given twice", keyword.text)));
            }
            seen[index] = Some(keyword);
            match index {
                0 => from = self.vec3(keyword.text)?,
                1 => at = self.vec3("at")?,
                2 => {
                    up_numbers = self.lex.peek();
                    up = self.vec3("up")?
                }
                3 => {
                    angle_deg =
                        self.number_where("angle in degrees", "an angle in (0, 180) degrees", |a| a > 0.0 && a < 180.0)?
                }
                4 => hither = self.number("hither")?,
                5 => {
                    let res = self.lex.peek();
                    width = self.integer("resolution width", 1, MAX_RESOLUTION as i64)? as u32;
                    height = self.integer("resolution height", 1, MAX_RESOLUTION as i64)? as u32;
                    if width as u64 * height as u64 > MAX_PIXELS {
                        let t = res.expect("a number was read");
                        return Err(
                            self.error(&t, format!("resolution {width} x {height} exceeds {MAX_PIXELS} pixels"))
                        );
                    }
                }
                6 => aperture = self.number_where("aperture", "an aperture >= 0", |a| a >= 0.0)?,
                _ => focal = self.number_where("focal ratio", "a positive focal ratio", |f| f > 0.0)?,
            }
        }
        // The camera's frame, formed as the camera forms it: each check names what it lacks.
        let dir = from - at;
        let n = dir.normalize_or_zero();
        let at_keyword = seen[1].unwrap_or(*tag);
        let up_numbers = up_numbers.unwrap_or(*tag);
        let problem = if dir == Vec3A::ZERO {
            Some((at_keyword, "expected 'from' != 'at'".to_owned()))
        } else if n == Vec3A::ZERO {
            let distance = dir.as_dvec3().length() as f32;
            let message = format!(
                "expected 'from' and 'at' further apart: their distance, {distance:e}, squares to 0 in single precision"
            );
            Some((at_keyword, message))
        } else if up.cross(n).normalize_or_zero() == Vec3A::ZERO || up.cross(dir).length_squared() == 0.0 {
            let message = "expected 'up' not parallel to the view direction (and not too short to give it a side)";
            Some((up_numbers, message.to_owned()))
        } else {
            None
        };
        if let Some((t, message)) = problem {
            return Err(self.error(&t, message));
        }
        Ok(View { from, at, up, angle_deg, hither, width, height, aperture, focal })
    }

    /// A material: `f` (or 2024/25 `mat`) with 11 numbers (p3f: two colours), 12 (raylume: and a
    /// roughness), or 8 (NFF: one colour, specular white).
    fn material(&mut self, tag: &Token) -> Result<Phong, SceneError> {
        if tag.text == "mat" {
            self.p3f2024 = true;
        }
        let forms = "8 (NFF: r g b Kd Ks shine T ior) or 11 (p3f: dr dg db Kd sr sg sb Ks shine T ior) numbers";
        let n = self.form(tag, &[8, 11, 12], forms)?;
        let diffuse = self.color("diffuse colour")?;
        let kd = self.number("Kd")?;
        let specular = if n == 8 {
            self.nff = true;
            Vec3::ONE
        } else {
            self.color("specular colour")?
        };
        let ks = self.number("Ks")?;
        let shine = self.number("shine")?;
        let transmittance = self.number("transmittance")?;
        let ior_token = self.lex.peek();
        let ior = self.number("index of refraction")?;
        if transmittance > 0.0 && ior <= 0.0 {
            let t = ior_token.expect("a number was read");
            return Err(self.error(
                &t,
                format!("expected a positive index of refraction for a transparent material, found '{}'", t.shown()),
            ));
        }
        let mut roughness = 0.0;
        if n == 12 {
            self.extensions.insert("roughness");
            roughness = self.number_where("roughness", "a roughness in [0, 1]", |r| (0.0..=1.0).contains(&r))?;
        }
        Ok(Phong { diffuse, kd, specular, ks, shine, transmittance, ior, specular_scale: 1.0, roughness })
    }

    /// raylume's extension `obj FILE [scale tx ty tz]`: an OBJ mesh, path relative to the scene's
    /// folder, optionally scaled then translated.
    fn obj(&mut self) -> Result<Shape, SceneError> {
        let name = self.token("an OBJ file name")?;
        let path = self.options.base_dir.as_deref().unwrap_or(Path::new(".")).join(name.text);
        let (shape, skipped) = crate::obj::load_with_warnings(&path)
            .map_err(|e| self.error(&name, format!("obj '{}': {e}", name.shown())))?;
        for w in skipped {
            if self.options.strict {
                let at = format!("{}:{}:{}", w.file, w.line, w.column);
                let message = format!("obj '{}': {at}: {} (an error when loading strictly)", name.shown(), w.message);
                return Err(self.error(&name, message));
            }
            self.warnings.push(w);
        }
        let mut place = crate::obj::Transform::default();
        if self.lex.peek().is_some_and(|t| t.is_number()) {
            place.scale = self.number_where("obj scale", "a positive obj scale", |s| s > 0.0)?;
            place.translate = self.vec3("obj translation")?;
        }
        place.apply(shape).map_err(|e| self.error(&name, e.to_string()))
    }

    /// A mesh's counts, vertices and index triples; `None` (with a warning) for one of no triangles,
    /// which has no surface.
    fn mesh(&mut self) -> Result<Option<Shape>, SceneError> {
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
            vertices.push(self.vec3(format_args!("mesh vertex {}", i + 1))?);
        }
        let mut triangles = Vec::with_capacity(nf);
        for f in 0..nf {
            let mut tri = [0u32; 3];
            for (k, slot) in tri.iter_mut().enumerate() {
                let t = self.token("a vertex index")?;
                let Ok(i) = t.text.parse::<i64>() else {
                    let what = format!("vertex index {} of mesh triangle {}", k + 1, f + 1);
                    return Err(self.error(&t, format!("expected an integer ({what}), found '{}'", t.shown())));
                };
                // 1-based; a negative index counts back from the end, -1 the last (OBJ style); 0 is out of range.
                let zero_based = if i > 0 { i - 1 } else { nv as i64 + i };
                if zero_based < 0 || zero_based >= nv as i64 {
                    let what = format!("vertex index {} of mesh triangle {}", k + 1, f + 1);
                    return Err(self.error(&t, format!("{what} is {i}, out of range for {nv} vertices")));
                }
                *slot = zero_based as u32;
            }
            triangles.push(tri);
        }
        if triangles.is_empty() {
            let t = nf_token.expect("a number was read");
            self.warn(&t, "a mesh of 0 triangles has no surface: skipped".to_owned())?;
            return Ok(None);
        }
        Ok(Some(Shape::Mesh { vertices, triangles, normals: Vec::new() }))
    }
}

/// Whether `text` is a whole number in decimal digits, with an optional sign.
fn is_digits(text: &str) -> bool {
    let digits = text.strip_prefix(['+', '-']).unwrap_or(text);
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
}

/// Three points of the plane `n · x + d = 0` whose winding gives back the normal's direction, if
/// they are finite in f32.
fn plane_points(n: Vec3A, d: f32) -> Option<[Vec3A; 3]> {
    let n = n.as_dvec3();
    let len = n.length();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let unit = n / len;
    let p0 = unit * (-(d as f64) / len);
    let helper = if unit.x.abs() < 0.9 { glam::DVec3::X } else { glam::DVec3::Y };
    let u = helper.cross(unit).normalize();
    let v = unit.cross(u);
    let points = [p0, p0 + u, p0 + v].map(|p| p.as_vec3a());
    points.iter().all(|p| p.is_finite()).then_some(points)
}

/// Whether a number's text has a digit other than 0 before its exponent: written as not zero.
fn nonzero_mantissa(text: &str) -> bool {
    let mantissa = text.split(['e', 'E']).next().unwrap_or("");
    mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b))
}
