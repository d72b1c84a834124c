//! Render farms: `render --tile I/N` renders one region of the image as an OpenEXR part (its data
//! window and the attributes that identify the render), and `merge OUT PARTS...` assembles the
//! parts into the image one machine would have rendered, bit for bit. See docs/FARM.md.
//!
//! The image of height H is split into N bands of whole rows: band I holds the rows
//! `floor(I * H / N)` to `floor((I + 1) * H / N)` (exclusive), so the bands differ in height by at
//! most one row and none is empty for N <= H.

use std::path::{Path, PathBuf};

use raylume_geometry::Vec3;
use raylume_integrator::{Extras, Film, ImageFormat, MAX_IMAGE_PIXELS, MetaValue, Window};
use raylume_render::RenderOptions;

use crate::{Failure, bad_input};

/// Header attribute: the hash of the scene and of the settings that change pixels.
pub(crate) const SCENE_HASH: &str = "raylume.scene_hash";
/// Header attribute: the region, `X0 Y0 X1 Y1` (pixels `[X0, X1) x [Y0, Y1)` of the full image).
const REGION: &str = "raylume.region";
/// Header attribute: the region's index and the number of regions, `I/N`.
const TILE: &str = "raylume.tile";

/// Region `index` of `count` regions of the image (horizontal bands of whole rows).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Tile {
    /// The region, from 0.
    pub(crate) index: u32,
    /// The number of regions.
    pub(crate) count: u32,
}

impl Tile {
    /// The tile the flags ask for: `--tile I/N`, or `--tile-from-env VAR` with `--tiles N` (the
    /// index read from the environment variable VAR). A tile's part must be an `.exr` file.
    pub(crate) fn from_flags(
        tile: Option<&str>,
        from_env: Option<&str>,
        tiles: Option<u32>,
        output: &Path,
    ) -> Result<Option<Tile>, Failure> {
        let tile = match (tile, from_env, tiles) {
            (Some(spec), _, _) => Self::parse(spec).map_err(|e| bad_input(format!("--tile {spec}: {e}")))?,
            (None, Some(var), Some(count)) => {
                let value = std::env::var(var).map_err(|e| {
                    bad_input(match e {
                        std::env::VarError::NotPresent => format!("--tile-from-env {var}: the variable is not set"),
                        std::env::VarError::NotUnicode(_) => format!("--tile-from-env {var}: the value is not text"),
                    })
                })?;
                let index = value.trim().parse::<u32>().map_err(|_| {
                    bad_input(format!("--tile-from-env {var}: the value '{value}' is not a region index (0, 1, ...)"))
                })?;
                Self::new(index, count).map_err(|e| bad_input(format!("--tile-from-env {var} = {value}: {e}")))?
            }
            (None, Some(var), None) => {
                return Err(bad_input(format!("--tile-from-env {var}: give the number of regions with --tiles N")));
            }
            (None, None, _) => return Ok(None),
        };
        if ImageFormat::from_path(output).ok() != Some(ImageFormat::Exr) {
            return Err(bad_input(format!(
                "{}: a region is written as OpenEXR with its place in the image: name the output .exr",
                output.display()
            )));
        }
        Ok(Some(tile))
    }

    /// `I/N`, with I from 0 to N - 1.
    ///
    /// ```text
    /// "2/8" -> region 2 of 8;  "8/8", "1/0", "x/4" -> an error
    /// ```
    pub(crate) fn parse(spec: &str) -> Result<Tile, String> {
        let (i, n) = spec.split_once('/').ok_or("expected I/N (region I of N, I from 0)")?;
        let number =
            |s: &str, what: &str| s.trim().parse::<u32>().map_err(|_| format!("expected I/N, found '{s}' for {what}"));
        Self::new(number(i, "I")?, number(n, "N")?)
    }

    fn new(index: u32, count: u32) -> Result<Tile, String> {
        if count == 0 {
            return Err("N = 0: expected at least one region".to_owned());
        }
        if index >= count {
            return Err(format!("region {index} of {count}: expected I from 0 to {}", count - 1));
        }
        Ok(Tile { index, count })
    }

    /// The rows `[y0, y1)` of this region in an image of `height` rows.
    pub(crate) fn rows(&self, height: u32) -> (u32, u32) {
        let edge = |i: u32| (i as u64 * height as u64 / self.count as u64) as u32;
        (edge(self.index), edge(self.index + 1))
    }

    /// The crop (`X0 Y0 X1 Y1`) of this region in an image of `width` x `height`; an error if
    /// there are more regions than rows.
    pub(crate) fn crop(&self, width: u32, height: u32) -> Result<[u32; 4], Failure> {
        if self.count > height {
            return Err(bad_input(format!(
                "--tile {}/{}: {} regions of an image of {height} rows: expected at most {height}",
                self.index, self.count, self.count
            )));
        }
        let (y0, y1) = self.rows(height);
        Ok([0, y0, width, y1])
    }
}

/// A region render's identity: written into its part with [`PartPlan::add_to`].
pub(crate) struct PartPlan {
    tile: Tile,
    hash: String,
    crop: [u32; 4],
    full: (u32, u32),
}

impl PartPlan {
    /// The part of `tile` for a render with `options` (their crop already the tile's) of the
    /// scene read from `scene` (`None`: `fallback`, the embedded default scene), of `full` size.
    pub(crate) fn new(
        tile: Tile,
        scene: Option<&Path>,
        fallback: &str,
        options: &RenderOptions,
        full: (u32, u32),
    ) -> Result<PartPlan, Failure> {
        let crop = options.settings.crop.unwrap_or([0, 0, full.0, full.1]);
        Ok(PartPlan { tile, hash: scene_hash_of(scene, fallback, options, full)?, crop, full })
    }

    /// Adds the part's data window and attributes (scene hash, full size, region, tile) to `extras`.
    pub(crate) fn add_to(&self, extras: &mut Extras) {
        let [x0, y0, x1, y1] = self.crop;
        extras.window = Some(Window { origin: (x0, y0), full: self.full });
        let text = |k: &str, v: String| (k.to_owned(), MetaValue::Text(v));
        extras.attributes.push(text(SCENE_HASH, self.hash.clone()));
        extras.attributes.push(text(REGION, format!("{x0} {y0} {x1} {y1}")));
        extras.attributes.push(text(TILE, format!("{}/{}", self.tile.index, self.tile.count)));
        extras.attributes.push(("raylume.full_width".to_owned(), MetaValue::Number(self.full.0 as f64)));
        extras.attributes.push(("raylume.full_height".to_owned(), MetaValue::Number(self.full.1 as f64)));
    }
}

/// The hash (64-bit FNV-1a, as 16 hex digits) of the scene file's bytes, the raylume version and
/// the render options that change pixels: everything in `options` but the crop, the folders
/// searched for cubemaps, strictness and budgets, with the samples per pixel and the size as
/// resolved. Files the scene refers to (cubemaps, meshes) are not hashed.
pub(crate) fn scene_hash(scene: &[u8], options: &RenderOptions, full: (u32, u32)) -> String {
    let mut o = options.clone();
    o.settings.crop = None;
    o.env_dirs.clear();
    o.strict = false;
    o.time_limit = None;
    o.noise_threshold = None;
    o.pass_range = None;
    o.resume = None;
    o.spp = None;
    o.resolution = Some(full);
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut feed = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    feed(format!("raylume {}\nscene {} bytes\n", env!("CARGO_PKG_VERSION"), scene.len()).as_bytes());
    feed(scene);
    feed(format!("\n{o:?}").as_bytes());
    format!("{h:016x}")
}

/// [`scene_hash`] of the scene read from `scene` (`None`: `fallback`, the embedded default scene).
pub(crate) fn scene_hash_of(
    scene: Option<&Path>,
    fallback: &str,
    options: &RenderOptions,
    full: (u32, u32),
) -> Result<String, Failure> {
    let bytes = match scene {
        Some(path) => std::fs::read(path).map_err(|e| bad_input(format!("{}: {e}", path.display())))?,
        None => fallback.as_bytes().to_vec(),
    };
    Ok(scene_hash(&bytes, options, full))
}

const FIRST_PASS: &str = "raylume.first_pass";
const TOTAL_PASSES: &str = "raylume.total_passes";
const SAMPLES_PER_PASS: &str = "raylume.samples_per_pass";

/// A share of each pixel's samples for one machine of a farm (`render --samples A..B`): whole passes
/// of the render, written with their images so that `merge` adds them in order, as one machine does.
pub(crate) struct SampleShare {
    first: u32,
    end: u32,
    total: u32,
    per_pass: u32,
}

impl SampleShare {
    /// The share `spec` (`A..B`, samples from A to B) of a render split as `split`, written to `output`.
    pub(crate) fn new(spec: &str, split: raylume_render::PassSplit, output: &Path) -> Result<Self, Failure> {
        let flag = format!("--samples {spec}");
        if ImageFormat::from_path(output).ok() != Some(ImageFormat::Exr) {
            return Err(bad_input(format!(
                "{flag}: a share of the samples is written as .exr, not {}",
                output.display()
            )));
        }
        let (Some(total), m) = (split.passes, split.samples_per_pass) else {
            return Err(bad_input(format!("{flag}: a budget or adaptive sampling has no fixed passes to share")));
        };
        let parsed = spec
            .split_once("..")
            .and_then(|(a, b)| Some((a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?)));
        let Some((a, b)) = parsed else {
            return Err(bad_input(format!("{flag}: expected A..B, sample indices such as 0..8")));
        };
        let all = total * m;
        if a >= b || b > all || a % m != 0 || b % m != 0 {
            return Err(bad_input(format!(
                "{flag}: expected A < B <= {all}, both multiples of {m} (the render is {total} passes of {m} samples)"
            )));
        }
        Ok(Self { first: a / m, end: b / m, total, per_pass: m })
    }

    /// The render's passes this share holds.
    pub(crate) fn pass_range(&self) -> (u32, u32) {
        (self.first, self.end)
    }

    /// The name of the layer of the share's `k`-th pass.
    pub(crate) fn layer_name(&self, k: usize) -> String {
        format!("pass{}", self.first as usize + k)
    }

    /// Adds the share's identity to an EXR's attributes.
    pub(crate) fn add_to(&self, extras: &mut Extras, hash: &str, full: (u32, u32)) {
        let number = |k: &str, v: f64| (k.to_owned(), MetaValue::Number(v));
        extras.attributes.push((SCENE_HASH.to_owned(), MetaValue::Text(hash.to_owned())));
        extras.attributes.push(number(FIRST_PASS, self.first as f64));
        extras.attributes.push(number(TOTAL_PASSES, self.total as f64));
        extras.attributes.push(number(SAMPLES_PER_PASS, self.per_pass as f64));
        extras.attributes.push(number("raylume.full_width", full.0 as f64));
        extras.attributes.push(number("raylume.full_height", full.1 as f64));
        let samples = format!("{}..{}", self.first * self.per_pass, self.end * self.per_pass);
        extras.attributes.push(("raylume.samples".to_owned(), MetaValue::Text(samples)));
    }
}

/// A share of the samples read back.
struct SharePart {
    path: PathBuf,
    hash: String,
    seed: String,
    first: u32,
    total: u32,
    per_pass: u32,
    size: (u32, u32),
    seconds: f64,
    passes: Vec<Film>,
}

/// Whether `path` is a share of the samples (has the attribute `render --samples` writes).
fn is_share(path: &Path) -> bool {
    let Ok(bytes) = std::fs::read(path) else { return false };
    let Ok(meta) = exr::meta::MetaData::read_from_buffered(bytes.as_slice(), false) else { return false };
    meta.headers.iter().any(|h| h.own_attributes.other.contains_key(&exr::prelude::Text::from(FIRST_PASS)))
}

fn read_share(path: &Path) -> Result<SharePart, Failure> {
    use exr::prelude::*;
    let fail = |m: String| bad_input(format!("{}: {m}", path.display()));
    let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
    if meta.len() > MAX_IMAGE_PIXELS * 12 * 64 {
        return Err(fail(format!("{} bytes is more than a share of the samples can be", meta.len())));
    }
    let image = read_exr(path).map_err(|e| fail(format!("unreadable OpenEXR part (truncated or damaged?): {e}")))?;
    let layer = &image.layer_data;
    let attribute = |name: &str| layer.attributes.other.get(&Text::from(name));
    let number = |name: &str| match attribute(name) {
        Some(AttributeValue::F64(x)) if *x >= 0.0 && *x <= u32::MAX as f64 => Ok(*x),
        _ => Err(fail(format!("no {name} attribute: not a share written by raylume render --samples"))),
    };
    let text = |name: &str| match attribute(name) {
        Some(AttributeValue::Text(t)) => Ok(t.to_string()),
        _ => Err(fail(format!("no {name} attribute: not a share written by raylume render --samples"))),
    };
    let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
    let (first, total) = (number(FIRST_PASS)? as u32, number(TOTAL_PASSES)? as u32);
    let mut passes = Vec::new();
    for k in first..total {
        let Some(pixels) = rgb_channels(layer, &format!("pass{k}")) else { break };
        passes.push(Film::from_pixels(w, h, pixels));
    }
    if passes.is_empty() {
        return Err(fail(format!("no pass{first}.R, .G, .B channels: a share holds its passes' images")));
    }
    Ok(SharePart {
        path: path.to_owned(),
        hash: text(SCENE_HASH)?,
        seed: text("raylume.seed")?,
        first,
        total,
        per_pass: number(SAMPLES_PER_PASS)? as u32,
        size: (w, h),
        seconds: number("raylume.seconds")?,
        passes,
    })
}

/// The first layer of an OpenEXR file, with every channel and attribute.
pub(crate) type ExrImage =
    exr::prelude::Image<exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>>;

/// Reads the first layer of the OpenEXR file at `path`, strictly (a truncated or damaged file is an error).
pub(crate) fn read_exr(path: &Path) -> exr::error::Result<ExrImage> {
    read_exr_from(std::io::BufReader::new(std::fs::File::open(path)?))
}

/// [`read_exr`] of an OpenEXR file's bytes from `reader`.
fn read_exr_from(reader: impl std::io::Read + std::io::Seek + Send) -> exr::error::Result<ExrImage> {
    use exr::prelude::*;
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .non_parallel()
        .from_buffered(reader)
}

/// The channels `NAME.R`, `NAME.G`, `NAME.B` of `layer` (`R`, `G`, `B` for an empty name) as colours,
/// if all three are there with a value per pixel.
pub(crate) fn rgb_channels(
    layer: &exr::prelude::Layer<exr::prelude::AnyChannels<exr::prelude::FlatSamples>>,
    name: &str,
) -> Option<Vec<Vec3>> {
    let n = layer.size.0 * layer.size.1;
    let channel = |c: &str| -> Option<Vec<f32>> {
        let key = if name.is_empty() { c.to_owned() } else { format!("{name}.{c}") };
        let found = layer.channel_data.list.iter().find(|ch| ch.name == *key.as_str())?;
        let values: Vec<f32> = found.sample_data.values_as_f32().collect();
        (values.len() == n).then_some(values)
    };
    let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
    Some(r.iter().zip(&g).zip(&b).map(|((&r, &g), &b)| Vec3::new(r, g, b)).collect())
}

/// Adds shares of the samples in the order of their passes, as one machine adds its passes, and
/// writes the image: the one-machine render's, bit for bit.
fn merge_shares(output: &Path, paths: &[PathBuf]) -> Result<(), Failure> {
    let mut parts = paths.iter().map(|p| read_share(p)).collect::<Result<Vec<_>, _>>()?;
    parts.sort_by_key(|p| p.first);
    let first = &parts[0];
    for p in &parts[1..] {
        let same = p.hash == first.hash
            && p.seed == first.seed
            && p.total == first.total
            && p.per_pass == first.per_pass
            && p.size == first.size;
        if !same {
            return Err(bad_input(format!(
                "{}: a share of another render than {} (scene hash, seed, passes or size differ)",
                p.path.display(),
                first.path.display()
            )));
        }
    }
    let mut next = 0;
    for p in &parts {
        let range = |a: u32, b: u32| format!("{}..{}", a * p.per_pass, b * p.per_pass);
        if p.first > next {
            return Err(bad_input(format!(
                "the shares do not hold samples {} (a part is missing)",
                range(next, p.first)
            )));
        }
        if p.first < next {
            return Err(bad_input(format!(
                "{} overlaps another share: both hold samples {}",
                p.path.display(),
                range(p.first, next)
            )));
        }
        next = p.first + p.passes.len() as u32;
    }
    if next != first.total {
        let m = first.per_pass;
        return Err(bad_input(format!(
            "the shares do not hold samples {}..{} (a part is missing)",
            next * m,
            first.total * m
        )));
    }
    let (w, h) = first.size;
    let mut accumulator = raylume_integrator::Accumulator::new(w, h);
    for film in parts.iter().flat_map(|p| &p.passes) {
        accumulator.add_pass(film, None);
    }
    let seconds: f64 = parts.iter().map(|p| p.seconds).sum();
    let identity = Merged {
        hash: &first.hash,
        seed: &first.seed,
        spp: (first.total * first.per_pass) as f64,
        passes: first.total as f64,
        seconds,
        parts: parts.len(),
    };
    identity.write(output, &accumulator.film(), accumulator.variance_film().as_ref())?;
    eprintln!(
        "raylume: merged {} shares of the samples into {} ({w}x{h}, {} passes, {seconds:.3} s of rendering in all)",
        parts.len(),
        output.display(),
        first.total
    );
    Ok(())
}

/// What a merged image says of itself: the render it comes from and what its parts took.
struct Merged<'a> {
    hash: &'a str,
    seed: &'a str,
    spp: f64,
    passes: f64,
    seconds: f64,
    parts: usize,
}

impl Merged<'_> {
    /// Writes `film` (with `variance` in an EXR) and these attributes to `output`.
    fn write(&self, output: &Path, film: &Film, variance: Option<&Film>) -> Result<(), Failure> {
        let attributes = vec![
            (SCENE_HASH.to_owned(), MetaValue::Text(self.hash.to_owned())),
            ("raylume.seed".to_owned(), MetaValue::Text(self.seed.to_owned())),
            ("raylume.spp".to_owned(), MetaValue::Number(self.spp)),
            ("raylume.passes".to_owned(), MetaValue::Number(self.passes)),
            ("raylume.seconds".to_owned(), MetaValue::Number(self.seconds)),
            ("raylume.parts".to_owned(), MetaValue::Number(self.parts as f64)),
        ];
        let extras = Extras { variance, attributes, ..Extras::default() };
        film.write_with(output, &extras).map_err(|e| Failure { code: 1, message: e.to_string() })
    }
}

/// A part read back: its place, its identity and its pixels.
struct Part {
    path: PathBuf,
    hash: String,
    seed: String,
    spp: f64,
    passes: f64,
    seconds: f64,
    full: (u32, u32),
    origin: (u32, u32),
    size: (u32, u32),
    rgb: Vec<Vec3>,
    variance: Option<Vec<Vec3>>,
}

impl Part {
    fn rows(&self) -> (u32, u32) {
        (self.origin.1, self.origin.1 + self.size.1)
    }

    fn columns(&self) -> (u32, u32) {
        (self.origin.0, self.origin.0 + self.size.0)
    }
}

/// The OpenEXR magic number.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Reads a part written by `render --tile`, refusing anything else with the file's name.
fn read_part(path: &Path) -> Result<Part, Failure> {
    use exr::prelude::*;
    let fail = |m: String| bad_input(format!("{}: {m}", path.display()));
    let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
    if !meta.is_file() {
        return Err(fail("not a regular file".to_owned()));
    }
    if meta.len() > MAX_IMAGE_PIXELS * 24 + (1 << 20) {
        return Err(fail(format!("{} bytes is more than a part of {MAX_IMAGE_PIXELS} pixels", meta.len())));
    }
    let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
    if !bytes.starts_with(&EXR_MAGIC) {
        return Err(fail("not an OpenEXR file (a part is the .exr that render --tile writes)".to_owned()));
    }
    let exr_error = |e: exr::error::Error| fail(format!("unreadable OpenEXR part (truncated or damaged?): {e}"));
    // The header first: its sizes are checked before the pixels are allocated.
    let header = exr::meta::MetaData::read_from_buffered(bytes.as_slice(), true).map_err(exr_error)?;
    let [layer] = header.headers.as_slice() else {
        return Err(fail(format!("{} layers: a part has one", header.headers.len())));
    };
    let (size, display) = (layer.layer_size, layer.shared_attributes.display_window);
    let pixels = |s: Vec2<usize>| s.0 as u64 * s.1 as u64;
    if pixels(size) == 0 || pixels(size) > MAX_IMAGE_PIXELS || pixels(display.size) > MAX_IMAGE_PIXELS {
        return Err(fail(format!(
            "a region of {}x{} in an image of {}x{}: expected 1 to {MAX_IMAGE_PIXELS} pixels",
            size.0, size.1, display.size.0, display.size.1
        )));
    }
    let image = read_exr_from(std::io::Cursor::new(bytes.as_slice())).map_err(exr_error)?;
    let layer = &image.layer_data;
    let attribute = |name: &str| layer.attributes.other.get(&Text::from(name));
    let text = |name: &str| match attribute(name) {
        Some(AttributeValue::Text(t)) => Ok(t.to_string()),
        _ => Err(fail(format!("no {name} attribute: not a part written by raylume render --tile"))),
    };
    let number = |name: &str| match attribute(name) {
        Some(AttributeValue::F64(x)) => Ok(*x),
        _ => Err(fail(format!("no {name} attribute: not a part written by raylume render --tile"))),
    };
    let hash = text(SCENE_HASH)?;
    let full = (number("raylume.full_width")?, number("raylume.full_height")?);
    let display = image.attributes.display_window;
    let position = layer.attributes.layer_position;
    let to_u32 = |v: i64| u32::try_from(v).ok();
    let place = (
        to_u32(position.0 as i64 - display.position.0 as i64),
        to_u32(position.1 as i64 - display.position.1 as i64),
        to_u32(display.size.0 as i64),
        to_u32(display.size.1 as i64),
    );
    let (Some(x), Some(y), Some(fw), Some(fh)) = place else {
        return Err(fail("the data window lies outside the display window".to_owned()));
    };
    let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
    if (fw as f64, fh as f64) != full || x as u64 + w as u64 > fw as u64 || y as u64 + h as u64 > fh as u64 {
        return Err(fail(format!(
            "the region {w}x{h} at ({x}, {y}) does not lie in the image of {fw}x{fh} (its attributes say {}x{})",
            full.0, full.1
        )));
    }
    let n = w as usize * h as usize;
    let channel = |name: &str| -> Option<std::result::Result<Vec<f32>, Failure>> {
        let c = layer.channel_data.list.iter().find(|c| c.name == *name)?;
        let values: Vec<f32> = c.sample_data.values_as_f32().collect();
        Some(if values.len() == n {
            Ok(values)
        } else {
            Err(fail(format!("channel {name} holds {} values for {n} pixels", values.len())))
        })
    };
    let rgb_of = |names: [&str; 3]| -> std::result::Result<Option<Vec<Vec3>>, Failure> {
        match names.map(channel) {
            [Some(r), Some(g), Some(b)] => {
                let (r, g, b) = (r?, g?, b?);
                Ok(Some(r.iter().zip(&g).zip(&b).map(|((&r, &g), &b)| Vec3::new(r, g, b)).collect()))
            }
            _ => Ok(None),
        }
    };
    let rgb = rgb_of(["R", "G", "B"])?.ok_or_else(|| fail("no R, G and B channels".to_owned()))?;
    let variance = rgb_of(["variance.R", "variance.G", "variance.B"])?;
    Ok(Part {
        path: path.to_owned(),
        hash,
        seed: text("raylume.seed")?,
        spp: number("raylume.spp")?,
        passes: number("raylume.passes")?,
        seconds: number("raylume.seconds")?,
        full: (fw, fh),
        origin: (x, y),
        size: (w, h),
        rgb,
        variance,
    })
}

/// Row ranges `a-b` (inclusive) of `rows`, as text (at most 8 ranges, then "...").
fn ranges(rows: &[u32]) -> String {
    let mut out: Vec<(u32, u32)> = Vec::new();
    for &r in rows {
        match out.last_mut() {
            Some(last) if last.1 == r => last.1 = r + 1,
            _ => out.push((r, r + 1)),
        }
    }
    let shown: Vec<String> =
        out.iter().take(8).map(|&(a, b)| if b == a + 1 { format!("{a}") } else { format!("{a}-{}", b - 1) }).collect();
    let more = if out.len() > 8 { ", ..." } else { "" };
    format!("{}{more}", shown.join(", "))
}

/// Refuses an output that is one of the parts (the same path, or the same file by another path
/// where both exist), which the merged image would replace.
fn output_is_no_part(output: &Path, paths: &[PathBuf]) -> Result<(), Failure> {
    let canonical = output.canonicalize().ok();
    let same = |part: &PathBuf| part == output || canonical.is_some() && part.canonicalize().ok() == canonical;
    match paths.iter().find(|p| same(p)) {
        Some(part) => Err(bad_input(format!(
            "{}: the output is also the part {}: expected an output other than the parts, which it would overwrite",
            output.display(),
            part.display()
        ))),
        None => Ok(()),
    }
}

/// Assembles the parts into the full image and writes it to `output` (any format raylume writes;
/// an EXR output keeps the variance channels when every part has them).
pub(crate) fn merge(output: &Path, paths: &[PathBuf]) -> Result<(), Failure> {
    output_is_no_part(output, paths)?;
    crate::check_output(output, true)?;
    if !paths.is_empty() && paths.iter().all(|p| is_share(p)) {
        return merge_shares(output, paths);
    }
    let parts = paths.iter().map(|p| read_part(p)).collect::<Result<Vec<_>, _>>()?;
    let Some(first) = parts.first() else {
        return Err(bad_input("merge: give the parts to assemble"));
    };
    for p in &parts[1..] {
        let (a, b) = (first.path.display(), p.path.display());
        let differ = |what: &str, x: String, y: String| {
            bad_input(format!("{b}: {what} {y}, but {a} has {what} {x}: parts of different renders"))
        };
        if p.seed != first.seed {
            return Err(differ("seed", first.seed.clone(), p.seed.clone()));
        }
        if p.spp != first.spp {
            return Err(differ("spp", first.spp.to_string(), p.spp.to_string()));
        }
        if p.passes != first.passes {
            return Err(differ("passes", first.passes.to_string(), p.passes.to_string()));
        }
        if p.full != first.full {
            let size = |s: (u32, u32)| format!("{}x{}", s.0, s.1);
            return Err(differ("image size", size(first.full), size(p.full)));
        }
        if p.hash != first.hash {
            return Err(bad_input(format!(
                "{b}: scene hash {}, but {a} has {}: parts of different scenes or settings",
                p.hash, first.hash
            )));
        }
    }
    // No two regions overlap, and together they cover every pixel.
    for (i, p) in parts.iter().enumerate() {
        for q in &parts[..i] {
            let (r, c) = ((p.rows(), q.rows()), (p.columns(), q.columns()));
            let rows = (r.0.0.max(r.1.0), r.0.1.min(r.1.1));
            let columns = (c.0.0.max(c.1.0), c.0.1.min(c.1.1));
            if rows.0 < rows.1 && columns.0 < columns.1 {
                return Err(bad_input(format!(
                    "{} overlaps {}: both hold rows {}-{} of columns {}-{}",
                    p.path.display(),
                    q.path.display(),
                    rows.0,
                    rows.1 - 1,
                    columns.0,
                    columns.1 - 1
                )));
            }
        }
    }
    let (w, h) = first.full;
    let mut covered = vec![0u64; h as usize];
    for p in &parts {
        for y in p.rows().0..p.rows().1 {
            covered[y as usize] += p.size.0 as u64;
        }
    }
    let missing: Vec<u32> = (0..h).filter(|&y| covered[y as usize] < w as u64).collect();
    if !missing.is_empty() {
        return Err(bad_input(format!(
            "the parts do not cover rows {} of the image's {h} (a part is missing)",
            ranges(&missing)
        )));
    }
    let mut rgb = vec![Vec3::ZERO; w as usize * h as usize];
    let with_variance = parts.iter().all(|p| p.variance.is_some());
    let mut variance = vec![Vec3::ZERO; if with_variance { rgb.len() } else { 0 }];
    for p in &parts {
        for row in 0..p.size.1 as usize {
            let from = row * p.size.0 as usize..(row + 1) * p.size.0 as usize;
            let at = (p.origin.1 as usize + row) * w as usize + p.origin.0 as usize;
            rgb[at..at + p.size.0 as usize].copy_from_slice(&p.rgb[from.clone()]);
            if let (true, Some(v)) = (with_variance, &p.variance) {
                variance[at..at + p.size.0 as usize].copy_from_slice(&v[from]);
            }
        }
    }
    let film = Film::from_pixels(w, h, rgb);
    let variance = with_variance.then(|| Film::from_pixels(w, h, variance));
    let seconds: f64 = parts.iter().map(|p| p.seconds).sum();
    let identity = Merged {
        hash: &first.hash,
        seed: &first.seed,
        spp: first.spp,
        passes: first.passes,
        seconds,
        parts: parts.len(),
    };
    identity.write(output, &film, variance.as_ref())?;
    eprintln!(
        "raylume: merged {} parts into {} ({w}x{h}, {} s of rendering in all)",
        parts.len(),
        output.display(),
        format_args!("{seconds:.3}")
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_rows_once_and_differ_by_at_most_one_row() {
        for height in [1u32, 7, 10, 100, 101] {
            for count in 1..=height.min(13) {
                let mut next = 0;
                let mut heights = Vec::new();
                for index in 0..count {
                    let (y0, y1) = Tile { index, count }.rows(height);
                    assert_eq!(y0, next, "height {height}, {count} regions");
                    assert!(y1 > y0);
                    heights.push(y1 - y0);
                    next = y1;
                }
                assert_eq!(next, height);
                assert!(heights.iter().max().unwrap() - heights.iter().min().unwrap() <= 1);
            }
        }
    }

    #[test]
    fn tile_specs_are_checked() {
        assert_eq!(Tile::parse("2/8"), Ok(Tile { index: 2, count: 8 }));
        assert!(Tile::parse("8/8").unwrap_err().contains("expected I from 0 to 7"));
        assert!(Tile::parse("0/0").unwrap_err().contains("N = 0"));
        assert!(Tile::parse("x/4").is_err());
        assert!(Tile::parse("3").is_err());
        assert!(Tile { index: 0, count: 11 }.crop(5, 10).is_err());
        assert_eq!(Tile { index: 1, count: 3 }.crop(5, 10).ok(), Some([0, 3, 5, 6]));
    }

    #[test]
    fn the_scene_hash_follows_the_scene_and_the_pixels_settings_only() {
        let options = RenderOptions::default();
        let hash = |scene: &[u8], o: &RenderOptions| scene_hash(scene, o, (40, 25));
        let base = hash(b"scene", &options);
        assert_ne!(base, hash(b"scene ", &options));
        assert_ne!(base, scene_hash(b"scene", &options, (40, 26)));
        let mut seed = options.clone();
        seed.settings.seed = 1;
        assert_ne!(base, hash(b"scene", &seed));
        let mut passes = options.clone();
        passes.passes += 1;
        assert_ne!(base, hash(b"scene", &passes));
        let mut same = options.clone();
        same.settings.crop = Some([0, 5, 40, 10]);
        same.env_dirs.push(PathBuf::from("/elsewhere"));
        same.strict = true;
        assert_eq!(base, hash(b"scene", &same));
    }

    #[test]
    fn missing_rows_are_named_as_ranges() {
        assert_eq!(ranges(&[3, 4, 5, 9]), "3-5, 9");
    }
}
