use std::io::Write;
use std::path::{Path, PathBuf};

use raylume_geometry::Vec3;

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
}

/// A rendered image: linear RGB floats, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

/// The image formats raylume writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    Exr,
    Pfm,
}

impl Film {
    /// A film from pixels in row order, top row first. Panics if the count is not `width * height`.
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Vec3>) -> Self {
        assert_eq!(pixels.len(), width as usize * height as usize, "pixel count does not match the size");
        Self { width, height, pixels }
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
        self.pixels
            .iter()
            .flat_map(|c| c.to_array())
            .map(|c| (c.clamp(0.0, 1.0) * 255.99).floor().min(255.0) as u8)
            .collect()
    }

    /// Writes the image in the format its extension names (`.png`: 8-bit; `.exr`, `.pfm`: linear
    /// float). The data go to a temporary file beside `path` that is renamed over it at the end, so
    /// a failed or interrupted write never leaves a half-written image.
    pub fn write(&self, path: &Path) -> Result<(), OutputError> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        let format = match ext.as_str() {
            "png" => Format::Png,
            "exr" => Format::Exr,
            "pfm" => Format::Pfm,
            _ => {
                return Err(OutputError::UnknownFormat { path: path.to_owned(), ext });
            }
        };
        let io = |source| OutputError::Io { path: path.to_owned(), source };
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        let result = self.encode(&tmp, format).and_then(|()| std::fs::rename(&tmp, path).map_err(io));
        if result.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        result.map_err(|e| match e {
            OutputError::Io { source, .. } => OutputError::Io { path: path.to_owned(), source },
            OutputError::Encode { source, .. } => OutputError::Encode { path: path.to_owned(), source },
            other => other,
        })
    }

    fn encode(&self, tmp: &Path, format: Format) -> Result<(), OutputError> {
        let io = |source| OutputError::Io { path: tmp.to_owned(), source };
        let enc = |source| OutputError::Encode { path: tmp.to_owned(), source };
        match format {
            Format::Png => {
                let img = image::RgbImage::from_raw(self.width, self.height, self.to_rgb8()).expect("buffer size");
                img.save_with_format(tmp, image::ImageFormat::Png).map_err(enc)
            }
            Format::Exr => {
                let data = self.pixels.iter().flat_map(|c| c.to_array()).collect();
                let img = image::Rgb32FImage::from_raw(self.width, self.height, data).expect("buffer size");
                img.save_with_format(tmp, image::ImageFormat::OpenExr).map_err(enc)
            }
            Format::Pfm => {
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
