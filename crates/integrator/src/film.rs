use std::io::Write;
use std::path::{Path, PathBuf};

use raylume_geometry::{LargeBuffer, Vec3};

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The file name's extension names no format raylume writes.
    #[error("{path}: unknown image format '{ext}' (expected .png, .exr or .pfm)")]
    UnknownFormat {
        /// The output path.
        path: PathBuf,
        /// The extension found.
        ext: String,
    },
    /// Writing failed.
    #[error("{path}: {source}")]
    Io {
        /// The output path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Encoding failed.
    #[error("{path}: {source}")]
    Encode {
        /// The output path.
        path: PathBuf,
        /// The cause.
        source: image::ImageError,
    },
    /// The image has no pixels.
    #[error("{path}: the image is empty ({width}x{height})")]
    Empty {
        /// The output path.
        path: PathBuf,
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
}

/// Why an image could not be read.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct InputError {
    /// The file.
    pub path: PathBuf,
    /// What is wrong with it.
    pub message: String,
}

/// Largest image read, in pixels (the largest a render can make).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 27;
/// Largest side of an image read, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// A rendered image: linear RGB floats, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    pixels: LargeBuffer<Vec3>,
}

/// What an OpenEXR file carries besides the image ([`Film::write_with`]).
#[derive(Clone, Debug, Default)]
pub struct Extras<'a> {
    /// The estimated variance of each pixel's value, per channel.
    pub variance: Option<&'a Film>,
    /// Named attributes of the header (ASCII names, such as `raylume.spp`).
    pub attributes: Vec<(String, MetaValue)>,
    /// Where the image lies in a larger one: it is written as the data window, and the larger
    /// image as the display window (without it, both are the image itself).
    pub window: Option<Window>,
    /// Further images of the same size, each written as the channels `NAME.R`, `NAME.G`, `NAME.B`
    /// (the passes of a share of a render's samples, for a render farm).
    pub layers: Vec<(String, &'a Film)>,
}

/// The place of an image (a region) in a larger image: the OpenEXR data window's origin and the
/// display window's size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    /// Column and row of the region's top-left pixel in the larger image.
    pub origin: (u32, u32),
    /// Width and height of the larger image.
    pub full: (u32, u32),
}

impl Extras<'_> {
    fn is_empty(&self) -> bool {
        self.variance.is_none() && self.attributes.is_empty() && self.window.is_none() && self.layers.is_empty()
    }
}

/// The value of an attribute in an image file's header.
#[derive(Clone, Debug, PartialEq)]
pub enum MetaValue {
    /// A number (written as a double).
    Number(f64),
    /// Text (its ASCII characters).
    Text(String),
}

/// The image formats raylume writes and reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit PNG, written as the course does.
    Png,
    /// OpenEXR, linear 32-bit float.
    Exr,
    /// Portable float map, linear 32-bit float.
    Pfm,
}

impl ImageFormat {
    /// The format a file name's extension names.
    ///
    /// ```
    /// use raylume_integrator::ImageFormat;
    /// assert_eq!(ImageFormat::from_path("out.PFM").unwrap(), ImageFormat::Pfm);
    /// assert!(ImageFormat::from_path("out.jpg").is_err());
    /// ```
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self, OutputError> {
        let path = path.as_ref();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "png" => Ok(Self::Png),
            "exr" => Ok(Self::Exr),
            "pfm" => Ok(Self::Pfm),
            _ => Err(OutputError::UnknownFormat { path: path.to_owned(), ext }),
        }
    }
}

/// The temporary files being written now, removed by [`remove_partial_outputs`].
static PARTIAL: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Removes the temporary files of writes in progress, so that a process ended by a signal leaves
/// either the previous file or the complete new one and nothing else. It holds the lock of the
/// writers' renames until the process exits, so call it only on the way out (a signal handler).
pub fn remove_partial_outputs() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    let mut partial = PARTIAL.lock().unwrap_or_else(|e| e.into_inner());
    for tmp in partial.drain(..) {
        let _ = std::fs::remove_file(tmp);
    }
    partial
}

/// Writes the file `path` through a temporary file beside it (`.NAME.PID.tmp.EXT`, keeping the
/// extension for writers that go by it): `write` fills the temporary file, which is then renamed
/// over `path`. A failed write removes the temporary file and leaves `path` as it was, and so does
/// a signal through [`remove_partial_outputs`]: no half-written file is ever left. `rename_failed`
/// turns an error of the rename into `write`'s error type.
///
/// ```
/// let path = std::env::temp_dir().join(format!("raylume-doc-{}.txt", std::process::id()));
/// let wrote = raylume_integrator::write_atomically(&path, |tmp| std::fs::write(tmp, "done"), |e| e);
/// assert!(wrote.is_ok());
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "done");
/// let refuse = |_: &std::path::Path| Err("no".to_owned());
/// assert!(raylume_integrator::write_atomically(&path, refuse, |e| e.to_string()).is_err());
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "done", "the previous file is left");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn write_atomically<E>(
    path: impl AsRef<Path>,
    write: impl FnOnce(&Path) -> Result<(), E>,
    rename_failed: impl FnOnce(std::io::Error) -> E,
) -> Result<(), E> {
    let path = path.as_ref();
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.{}.tmp{ext}", std::process::id()));
    PARTIAL.lock().unwrap_or_else(|e| e.into_inner()).push(tmp.clone());
    let written = write(&tmp);
    let mut partial = PARTIAL.lock().unwrap_or_else(|e| e.into_inner());
    let renamed = written.and_then(|()| std::fs::rename(&tmp, path).map_err(rename_failed));
    if renamed.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    partial.retain(|p| p != &tmp);
    renamed
}

impl Film {
    /// A film from pixels in row order, top row first. Panics if the count is not `width * height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize, "pixel count does not match the size");
        Self { width, height, pixels: pixels.into() }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, top row first.
    pub fn pixels(&self) -> &[Vec3] {
        &self.pixels
    }

    /// The pixels, top row first, for writing in place.
    pub(crate) fn pixels_mut(&mut self) -> &mut [Vec3] {
        &mut self.pixels
    }

    /// A black film, its memory zeroed by the system rather than written over ([`LargeBuffer`]):
    /// the render writes each pixel once.
    pub(crate) fn black(width: u32, height: u32) -> Self {
        Self { width, height, pixels: LargeBuffer::zeroed(width as usize * height as usize) }
    }

    /// The pixels' channels, `r g b` per pixel, top row first (for the [`metrics`](crate::metrics)).
    pub fn channels(&self) -> Vec<f32> {
        self.pixels.iter().flat_map(|c| c.to_array()).collect()
    }

    /// The pixel in column `x` and row `y` (row 0 at the top).
    pub fn pixel(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// 8-bit RGB as the course writes it: `min(255, floor(c * 255.99))` of the colour clamped to [0, 1].
    pub fn to_rgb8(&self) -> Vec<u8> {
        // The product is in [0, 255.99], or NaN, which `min` takes to 255; `as` truncates, which is the
        // floor here. The channels as one flat run, with no array per pixel.
        let channels: &[f32] = bytemuck::cast_slice(&self.pixels);
        channels.iter().map(|&c| (c.clamp(0.0, 1.0) * 255.99).min(255.0) as u8).collect()
    }

    /// Writes the image in the format its extension names (`.png`: 8-bit; `.exr`, `.pfm`: linear
    /// float). The data go to a temporary file beside `path` that is renamed over it at the end, so
    /// a failed or interrupted write never leaves a half-written image (see
    /// [`remove_partial_outputs`] for signals).
    ///
    /// ```
    /// use raylume_integrator::Film;
    /// use raylume_geometry::Vec3;
    /// let path = std::env::temp_dir().join(format!("raylume-film-doc-{}.pfm", std::process::id()));
    /// let film = Film::from_pixels(2, 1, vec![Vec3::new(0.25, 0.5, 1.0), Vec3::ZERO]);
    /// film.write(&path).unwrap();
    /// assert_eq!(Film::read(&path).unwrap(), film);
    /// # std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), OutputError> {
        let path = path.as_ref();
        let format = ImageFormat::from_path(path)?;
        if self.pixels.is_empty() {
            return Err(OutputError::Empty { path: path.to_owned(), width: self.width, height: self.height });
        }
        let io = |source| OutputError::Io { path: path.to_owned(), source };
        let result = write_atomically(path, |tmp| self.encode(tmp, format), io);
        result.map_err(|e| match e {
            OutputError::Io { source, .. } => OutputError::Io { path: path.to_owned(), source },
            OutputError::Encode { source, .. } => OutputError::Encode { path: path.to_owned(), source },
            other => other,
        })
    }

    /// [`Film::write`] with what an OpenEXR file carries besides the image: the per-pixel variance
    /// as the channels `variance.R`, `variance.G`, `variance.B`, and attributes of the render
    /// (sample count, seed, time, estimated error), and the image's place in a larger one
    /// ([`Window`]). PNG and PFM files hold the image alone.
    ///
    /// ```
    /// use raylume_integrator::{Extras, Film, MetaValue};
    /// use raylume_geometry::Vec3;
    /// let path = std::env::temp_dir().join(format!("raylume-extras-doc-{}.exr", std::process::id()));
    /// let film = Film::from_pixels(2, 1, vec![Vec3::new(0.25, 0.5, 1.0), Vec3::ZERO]);
    /// let variance = Film::from_pixels(2, 1, vec![Vec3::splat(1e-4), Vec3::ZERO]);
    /// let extras = Extras {
    ///     variance: Some(&variance),
    ///     attributes: vec![("raylume.spp".into(), MetaValue::Number(16.0))],
    ///     ..Extras::default()
    /// };
    /// film.write_with(&path, &extras).unwrap();
    /// assert_eq!(Film::read(&path).unwrap(), film);
    /// # std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn write_with(&self, path: impl AsRef<Path>, extras: &Extras) -> Result<(), OutputError> {
        let path = path.as_ref();
        if ImageFormat::from_path(path)? != ImageFormat::Exr || extras.is_empty() {
            return self.write(path);
        }
        if self.pixels.is_empty() {
            return Err(OutputError::Empty { path: path.to_owned(), width: self.width, height: self.height });
        }
        if let Some(v) = extras.variance {
            assert_eq!((v.width, v.height), (self.width, self.height), "the variance is of another size");
        }
        if let Some(w) = extras.window {
            let fits = |o: u32, n: u32, full: u32| o as u64 + n as u64 <= full as u64 && full <= i32::MAX as u32;
            assert!(
                fits(w.origin.0, self.width, w.full.0) && fits(w.origin.1, self.height, w.full.1),
                "the window does not hold the image"
            );
        }
        let io = |source| OutputError::Io { path: path.to_owned(), source };
        write_atomically(path, |tmp| self.encode_exr(tmp, extras).map_err(io), io)
    }

    fn encode_exr(&self, tmp: &Path, extras: &Extras) -> std::io::Result<()> {
        use exr::prelude::*;
        let plane = |film: &Film, c: usize| FlatSamples::F32(film.pixels.iter().map(|p| p[c]).collect());
        let mut channels: Vec<AnyChannel<FlatSamples>> =
            ["R", "G", "B"].iter().enumerate().map(|(c, name)| AnyChannel::new(*name, plane(self, c))).collect();
        if let Some(v) = extras.variance {
            for (c, name) in ["variance.R", "variance.G", "variance.B"].iter().enumerate() {
                channels.push(AnyChannel::new(*name, plane(v, c)));
            }
        }
        for (name, film) in &extras.layers {
            assert_eq!((film.width, film.height), (self.width, self.height), "a layer of another size");
            for (c, channel) in ["R", "G", "B"].iter().enumerate() {
                channels.push(AnyChannel::new(format!("{name}.{channel}").as_str(), plane(film, c)));
            }
        }
        let mut attributes = LayerAttributes { software_name: Some(Text::from("raylume")), ..Default::default() };
        let text = |s: &str| {
            let ascii: String = s.chars().filter(|c| c.is_ascii() && !c.is_ascii_control()).collect();
            Text::new_or_none(ascii).unwrap_or_default()
        };
        for (key, value) in &extras.attributes {
            let value = match value {
                MetaValue::Number(x) => AttributeValue::F64(*x),
                MetaValue::Text(t) => AttributeValue::Text(text(t)),
            };
            attributes.other.insert(text(key), value);
        }
        let size = (self.width as usize, self.height as usize);
        let (origin, full) = match extras.window {
            Some(w) => (w.origin, w.full),
            None => ((0, 0), (self.width, self.height)),
        };
        attributes.layer_position = Vec2(origin.0 as i32, origin.1 as i32);
        let display = IntegerBounds::new((0, 0), (full.0 as usize, full.1 as usize));
        let layer = Layer::new(size, attributes, Encoding::FAST_LOSSLESS, AnyChannels::sort(channels.into()));
        Image::new(ImageAttributes::new(display), layer).write().to_file(tmp).map_err(|e| match e {
            exr::error::Error::Io(e) => e,
            other => std::io::Error::other(other.to_string()),
        })
    }

    /// Reads a linear image: PFM (colour or grey, either byte order), OpenEXR, or PNG (8-bit values
    /// as `v / 255`).
    /// Only regular files of at most [`MAX_IMAGE_PIXELS`] pixels are read.
    pub fn read(path: impl AsRef<Path>) -> Result<Film, InputError> {
        let path = path.as_ref();
        let fail = |message: String| InputError { path: path.to_owned(), message };
        let format = ImageFormat::from_path(path).map_err(|e| fail(e.to_string()))?;
        let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
        if !meta.is_file() {
            return Err(fail("not a regular file".to_owned()));
        }
        // 12 bytes per pixel is the most any of the formats can take, plus a header.
        if meta.len() > MAX_IMAGE_PIXELS * 12 + (1 << 20) {
            return Err(fail(format!("{} bytes is more than an image of {MAX_IMAGE_PIXELS} pixels", meta.len())));
        }
        let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
        Self::decode(&bytes, format).map_err(fail)
    }

    /// Decodes an image of `format` from memory ([`Film::read`]).
    ///
    /// ```
    /// use raylume_integrator::{Film, ImageFormat};
    /// let mut pfm = b"PF\n1 1\n-1.0\n".to_vec();
    /// for v in [0.5f32, 0.25, 1.0] {
    ///     pfm.extend_from_slice(&v.to_le_bytes());
    /// }
    /// let film = Film::decode(&pfm, ImageFormat::Pfm).unwrap();
    /// assert_eq!(film.pixel(0, 0).y, 0.25);
    /// assert!(Film::decode(b"PF\n99999999 99999999\n-1.0\n", ImageFormat::Pfm).is_err());
    /// ```
    pub fn decode(bytes: &[u8], format: ImageFormat) -> Result<Film, String> {
        match format {
            ImageFormat::Pfm => decode_pfm(bytes),
            ImageFormat::Exr | ImageFormat::Png => {
                let format =
                    if format == ImageFormat::Png { image::ImageFormat::Png } else { image::ImageFormat::OpenExr };
                let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
                let mut limits = image::Limits::default();
                limits.max_alloc = Some(MAX_IMAGE_PIXELS * 16);
                limits.max_image_width = Some(MAX_IMAGE_SIDE);
                limits.max_image_height = Some(MAX_IMAGE_SIDE);
                reader.limits(limits);
                let decoder = reader.into_decoder().map_err(|e| e.to_string())?;
                // The header's size is checked before anything is allocated for it: within the
                // limits, and no more than 400 pixels per byte of the file (a flat-colour 8-bit RGB
                // PNG, the most compressible render, holds about 343; decoding takes up to 40 bytes
                // per pixel, so a small corrupt file cannot ask for gigabytes).
                let (w, h) = image::ImageDecoder::dimensions(&decoder);
                let pixels = w as u64 * h as u64;
                let holds = bytes.len() as u64 * 400 + (1 << 16);
                if w == 0 || h == 0 || pixels > MAX_IMAGE_PIXELS || pixels > holds {
                    return Err(format!(
                        "{w}x{h} pixels: expected 1 to {MAX_IMAGE_PIXELS}, and at most {holds} for a file of {} bytes",
                        bytes.len()
                    ));
                }
                if format == image::ImageFormat::OpenExr {
                    exr_blocks_within(bytes, w)?;
                }
                let img = image::DynamicImage::from_decoder(decoder).map_err(|e| e.to_string())?;
                let img = img.into_rgb32f();
                let (w, h) = img.dimensions();
                let pixels = img.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
                Ok(Film::from_pixels(w, h, pixels))
            }
        }
    }

    fn encode(&self, tmp: &Path, format: ImageFormat) -> Result<(), OutputError> {
        let io = |source| OutputError::Io { path: tmp.to_owned(), source };
        let enc = |source| OutputError::Encode { path: tmp.to_owned(), source };
        match format {
            ImageFormat::Png => {
                let img = image::RgbImage::from_raw(self.width, self.height, self.to_rgb8()).expect("buffer size");
                img.save_with_format(tmp, image::ImageFormat::Png).map_err(enc)
            }
            ImageFormat::Exr => {
                let data = self.pixels.iter().flat_map(|c| c.to_array()).collect();
                let img = image::Rgb32FImage::from_raw(self.width, self.height, data).expect("buffer size");
                img.save_with_format(tmp, image::ImageFormat::OpenExr).map_err(enc)
            }
            ImageFormat::Pfm => {
                let file = std::fs::File::create(tmp).map_err(io)?;
                let mut out = std::io::BufWriter::new(file);
                write!(out, "PF\n{} {}\n-1.0\n", self.width, self.height).map_err(io)?;
                // PFM stores the bottom row first, little-endian (negative scale).
                for row in self.pixels.chunks(self.width as usize).rev() {
                    for c in row {
                        for v in c.to_array() {
                            out.write_all(&v.to_le_bytes()).map_err(io)?;
                        }
                    }
                }
                out.into_inner().map_err(|e| io(e.into_error()))?.sync_all().map_err(io)
            }
        }
    }
}

/// Checks the blocks of an OpenEXR file `width` pixels wide before its decoder reads one: the decoder
/// sets aside room for a whole block's bytes as the headers give them (a tile, or the scan lines one
/// compression takes at a time), so a small corrupt file could ask for gigabytes. A block's bytes may
/// be no more than those of an image a file of that size may hold (400 pixels per byte of the file,
/// see [`Film::decode`], of 16 bytes each). Every `tiledesc`, `chlist`, `compression` and `box2i`
/// attribute in the file counts, wherever it is, so the check does not depend on how a damaged header is
/// read; a pixel's bytes are bounded by 4 per channel, and a channel entry takes at least 18 bytes.
fn exr_blocks_within(bytes: &[u8], width: u32) -> Result<(), String> {
    let most = (bytes.len() as u64 * 400 + (1 << 16)).min(MAX_IMAGE_PIXELS) * 16;
    // The declared size and the value of each attribute of type `kind`.
    let values = |kind: &'static [u8]| {
        let pattern = [kind, b"\0"].concat();
        (0..bytes.len()).filter(move |&at| bytes[at..].starts_with(&pattern)).filter_map(move |at| {
            let size = bytes.get(at + kind.len() + 1..)?.get(..4)?;
            let size = u32::from_le_bytes([size[0], size[1], size[2], size[3]]) as usize;
            let value = bytes.get(at + kind.len() + 5..)?;
            Some((size, &value[..size.min(value.len())]))
        })
    };
    let channels = values(b"chlist").map(|(size, _)| size.min(bytes.len()) / 18 + 1).max().unwrap_or(1);
    let pixel_bytes = 4 * channels as u64;
    let too_many = |what: String, pixels: u64| {
        (pixels.saturating_mul(pixel_bytes) > most).then(|| {
            format!(
                "OpenEXR {what} of up to {pixel_bytes} bytes a pixel: expected at most {most} bytes a block for a \
                 file of {} bytes",
                bytes.len()
            )
        })
    };
    for (_, value) in values(b"tiledesc") {
        let Some(v) = value.get(..8) else { continue };
        let x = u32::from_le_bytes([v[0], v[1], v[2], v[3]]) as u64;
        let y = u32::from_le_bytes([v[4], v[5], v[6], v[7]]) as u64;
        if let Some(e) = too_many(format!("tiles of {x}x{y} pixels"), x * y) {
            return Err(e);
        }
    }
    // Scan lines a block, by compression: none, RLE and ZIPS 1, ZIP and PXR24 16, DWAB 256, the others 32.
    let lines = values(b"compression")
        .filter_map(|(size, v)| v.first().filter(|_| size == 1))
        .map(|kind| match kind {
            0..=2 => 1,
            3 | 5 => 16,
            9 => 256,
            _ => 32,
        })
        .max()
        .unwrap_or(32);
    // The widest window the file declares (`box2i`: x min, y min, x max, y max), the decoder's width at
    // least; a window whose corners are out of order is refused (the decoder's sizes of it wrap).
    let mut widest = width as u64;
    for (_, v) in values(b"box2i") {
        let Some(v) = v.get(..16) else { continue };
        let [x0, y0, x1, y1] = [0, 4, 8, 12].map(|k| i32::from_le_bytes([v[k], v[k + 1], v[k + 2], v[k + 3]]) as i64);
        if x1 < x0 || y1 < y0 {
            return Err(format!("OpenEXR window from ({x0}, {y0}) to ({x1}, {y1}): expected its corners in order"));
        }
        widest = widest.max((x1 - x0 + 1) as u64);
    }
    let width = widest;
    too_many(format!("blocks of {lines} scan lines of {width} pixels"), lines * width).map_or(Ok(()), Err)
}

/// A PFM image: `PF` (colour, three floats a pixel) or `Pf` (grey, one float a pixel, read as
/// equal channels), width, height, a scale whose sign gives the byte order (negative:
/// little-endian), then the rows from the bottom one up.
fn decode_pfm(bytes: &[u8]) -> Result<Film, String> {
    let mut fields = Vec::new();
    let mut pos = 0;
    while fields.len() < 4 && pos < bytes.len() && pos < 256 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1;
    let channels = match fields.first().map(String::as_str) {
        Some("PF") => 3,
        Some("Pf") => 1,
        _ => 0,
    };
    if fields.len() < 4 || channels == 0 {
        return Err("not a PFM file (expected 'PF' or 'Pf', width, height and scale)".to_owned());
    }
    let size =
        |s: &str, what: &str| s.parse::<u32>().map_err(|_| format!("expected the {what} in pixels, found '{s}'"));
    let (w, h) = (size(&fields[1], "width")?, size(&fields[2], "height")?);
    let scale: f32 = fields[3].parse().map_err(|_| format!("expected the scale, found '{}'", fields[3]))?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(format!("expected a finite non-zero scale, found '{}'", fields[3]));
    }
    let n = w as u64 * h as u64;
    if w == 0 || h == 0 || n > MAX_IMAGE_PIXELS {
        return Err(format!("{w}x{h} pixels: expected 1 to {MAX_IMAGE_PIXELS}"));
    }
    let data = bytes.get(pos..).unwrap_or(&[]);
    let pixel = 4 * channels;
    if data.len() as u64 != n * pixel as u64 {
        return Err(format!(
            "expected {w}x{h} pixels of {pixel} bytes ({} bytes), found {} bytes",
            n * pixel as u64,
            data.len()
        ));
    }
    let read = |b: &[u8]| {
        let b = [b[0], b[1], b[2], b[3]];
        if scale < 0.0 { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) }
    };
    let (w_, h_) = (w as usize, h as usize);
    let mut pixels = vec![Vec3::ZERO; w_ * h_];
    for (i, c) in data.chunks_exact(pixel).enumerate() {
        // PFM rows are stored bottom first.
        let (row, col) = (i / w_, i % w_);
        pixels[(h_ - 1 - row) * w_ + col] = match c.len() {
            12 => Vec3::new(read(&c[0..4]), read(&c[4..8]), read(&c[8..12])),
            _ => Vec3::splat(read(c)),
        };
    }
    Ok(Film::from_pixels(w, h, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_bit_values_are_the_course_formula() {
        let course = |c: f32| (c.clamp(0.0, 1.0) * 255.99).floor().min(255.0) as u8;
        // Every f32 in [0, 1] near a step of the formula, then the values outside it.
        let mut values: Vec<f32> = (0..=256)
            .flat_map(|k| {
                let edge = k as f32 / 255.99;
                (-64..=64).map(move |ulps: i32| f32::from_bits((edge.to_bits() as i32 + ulps).max(0) as u32))
            })
            .collect();
        values.extend([-0.0, -1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE, 1e-45]);
        let film = Film::from_pixels(values.len() as u32, 1, values.iter().map(|&c| Vec3::splat(c)).collect());
        let expected: Vec<u8> = values.iter().flat_map(|&c| [course(c); 3]).collect();
        let ours = film.to_rgb8();
        let wrong = (0..expected.len()).find(|&i| ours[i] != expected[i]);
        assert!(wrong.is_none(), "{:?}", wrong.map(|i| (values[i / 3], ours[i], expected[i])));
    }

    /// OpenEXR blocks (tiles, or a compression's scan lines) larger than a file of that size may hold
    /// are refused before a block is read; ordinary tiled and scan-line files decode.
    #[test]
    fn exr_blocks_are_checked_before_they_are_read() {
        use exr::prelude::*;
        // A gradient, or a flat colour where `flat`.
        let write =
            |size: (usize, usize), encoding: Encoding, flat: bool| {
                let mut file = Vec::new();
                let rgb = SpecificChannels::rgb(move |p: Vec2<usize>| {
                    if flat { (0.5f32, 0.5f32, 0.5f32) } else { (p.0 as f32, p.1 as f32, 0.5f32) }
                });
                let layer = Layer::new(size, LayerAttributes::default(), encoding, rgb);
                Image::from_layer(layer).write().to_buffered(std::io::Cursor::new(&mut file)).unwrap();
                file
            };
        let tiled = write((40, 24), Encoding { blocks: Blocks::Tiles(Vec2(16, 16)), ..Encoding::UNCOMPRESSED }, false);
        let lines = write((40, 24), Encoding { compression: Compression::ZIP16, ..Encoding::UNCOMPRESSED }, false);
        for file in [&tiled, &lines] {
            let film = Film::decode(file, ImageFormat::Exr).unwrap();
            assert_eq!((film.width, film.height, film.pixel(39, 23)), (40, 24, Vec3::new(39.0, 23.0, 0.5)));
        }
        // A flat line 16384 pixels wide, a file of a few hundred bytes, decodes; said to be compressed by
        // DWAB (blocks of 256 scan lines), it is refused.
        let mut wide = write((16384, 1), Encoding { compression: Compression::ZIP16, ..Encoding::UNCOMPRESSED }, true);
        assert_eq!(Film::decode(&wide, ImageFormat::Exr).map(|f| f.width), Ok(16384));
        let at = wide.windows(24).position(|w| w == b"compression\0compression\0").unwrap() + 28;
        wide[at] = 9;
        let e = Film::decode(&wide, ImageFormat::Exr).map(|f| f.width).unwrap_err();
        assert!(e.starts_with("OpenEXR blocks of 256 scan lines of 16384 pixels of up to 16 bytes a pixel"), "{e}");
        // What the fuzzer found: files of a few hundred bytes asking for gigabytes.
        for found in [
            &include_bytes!("../../scene/tests/fuzz-regressions/image-exr-huge-tiles.exr")[..],
            // Tiles after an attribute with no type: the decoder reads the header on past it.
            include_bytes!("../../scene/tests/fuzz-regressions/image-exr-tiles-in-a-damaged-header.exr"),
            // A data window 15 597 588 pixels wide, whose DWAB blocks would take 7.1 GB.
            include_bytes!("../../scene/tests/fuzz-regressions/image-exr-wide-data-window.exr"),
            // A data window whose corners are out of order.
            include_bytes!("../../scene/tests/fuzz-regressions/image-exr-window-out-of-order.exr"),
        ] {
            let e = Film::decode(found, ImageFormat::Exr).map(|f| f.width).unwrap_err();
            assert!(e.starts_with("OpenEXR ") && (e.contains("bytes a block") || e.contains("in order")), "{e}");
        }
    }

    #[test]
    fn a_window_is_written_as_the_data_and_display_windows() {
        let path = std::env::temp_dir().join(format!("raylume-window-{}.exr", std::process::id()));
        let film = Film::from_pixels(3, 2, (0..6).map(|i| Vec3::splat(i as f32 * 0.25)).collect());
        let extras = Extras { window: Some(Window { origin: (4, 5), full: (10, 9) }), ..Extras::default() };
        film.write_with(&path, &extras).unwrap();
        let image = exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let display = image.attributes.display_window;
        assert_eq!((display.position, display.size), (exr::math::Vec2(0, 0), exr::math::Vec2(10, 9)));
        assert_eq!(image.layer_data.attributes.layer_position, exr::math::Vec2(4, 5));
        assert_eq!(image.layer_data.size, exr::math::Vec2(3, 2));
        let red = image.layer_data.channel_data.list.iter().find(|c| c.name == *"R");
        let red: Vec<f32> = red.unwrap().sample_data.values_as_f32().collect();
        assert_eq!(red, [0.0, 0.25, 0.5, 0.75, 1.0, 1.25]);
    }
}
