//! The p3f scene format and its dialects: [`parse`] text or [`load`] a file into a [`Scene`].
//!
//! One reader takes every variant of the format that the course's years and its students wrote
//! (see `p3f.md`): Eric Haines' NFF (8-number `f`, `b`, `aabb`, free-text lines), the course's p3f
//! (11-number `f`, `mesh`, `accel`, `spp`), its 2024/25 syntax (`mat`, `npl`, `light`, `camera`,
//! `accel bvh`), and the students' extensions (`ms`, `fire`, `al`, `c` on one line). Where two
//! dialects spell an entity differently, the count of numbers that follow tells them apart; the
//! [`Dialect`] read is reported in [`Loaded`]. [`Scene::to_p3f`] writes any of them back as
//! canonical p3f.
//!
//! Every error names the file, line and column, the token found and what was expected. What can be
//! forgiven is, with a [`Warning`]: unknown tags and free-text lines are skipped, a missing cubemap
//! folder leaves the background colour. [`LoadOptions::strict`] makes warnings errors.
//!
//! ```
//! use raylume_scene::p3f::{parse, Dialect, LoadOptions};
//! let err = parse("v\nfrom 0 0 x", "bad.p3f", &LoadOptions::default()).unwrap_err();
//! assert_eq!(err.to_string(), "bad.p3f:2:10: expected a number (from z), found 'x'");
//!
//! // An NFF file: the background is `b`, a material has 8 numbers.
//! let nff = "b 0.1 0.2 0.3\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 64 64\n\
//!            l 0 5 5\nf 1 0 0 0.8 0.2 20 0 1\ns 0 0 0 1\n";
//! let loaded = parse(nff, "ball.nff", &LoadOptions::default()).unwrap();
//! assert_eq!(loaded.dialect, Dialect::Nff);
//! assert_eq!(loaded.scene.objects.len(), 1);
//! ```

use std::path::{Path, PathBuf};

use crate::{Scene, SceneError, Warning};

pub(crate) mod foreign;
mod lexer;
pub(crate) use lexer::shown;
mod parser;

pub use crate::limits::{MAX_COORDINATE, MAX_FILE_BYTES, MAX_PIXELS, MAX_RESOLUTION};

/// How to load a file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Make warnings (unknown tags, skipped lines, a missing cubemap) errors.
    pub strict: bool,
    /// The folder relative file names (`obj`, `env`) are resolved in; [`load`] sets it to the
    /// scene's folder, [`parse`] uses the current folder without it. The scene keeps it as
    /// [`Scene::base_dir`].
    pub base_dir: Option<PathBuf>,
    /// Further folders to look for the scene's `env` cubemap in, after the base folder and its
    /// parent.
    pub env_dirs: Vec<PathBuf>,
    /// The cubemap will not be used (a render with `--no-env`): its folder is not looked for, so a
    /// missing one is neither a warning nor, under `strict`, an error.
    pub ignore_env: bool,
}

/// The variant of the format a file was written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// Eric Haines' NFF as the course used it up to 2018/19: `b` background, 8-number `f` with a
    /// white specular colour, `aabb`, lines of free text.
    Nff,
    /// The course's p3f of 2019/20 to 2023/24: 11-number `f`, `bclr`, `env`, `mesh`, `accel N`, `spp N`.
    P3f,
    /// The course's 2024/25 syntax: `mat`, `npl`, `light punctual|quad`, `camera eye …`,
    /// `accel none|grid|bvh`.
    P3f2024,
}

impl std::fmt::Display for Dialect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Dialect::Nff => "NFF",
            Dialect::P3f => "p3f",
            Dialect::P3f2024 => "p3f 2024/25",
        })
    }
}

/// A scene read from text, with what was skipped and which dialect it was written in.
#[derive(Clone, Debug, PartialEq)]
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// What was skipped or replaced, in file order.
    pub warnings: Vec<Warning>,
    /// The dialect the file was read as: by its content, and by its name's extension (`.nff`).
    pub dialect: Dialect,
    /// Entities beyond the dialect that the file used (students' `ms`, `fire`, `al`; raylume's
    /// `obj`, `shutter`, area light sizes and roughness), sorted.
    pub extensions: Vec<&'static str>,
}

impl Loaded {
    /// One line saying what was read: the dialect and its extensions.
    pub fn summary(&self) -> String {
        if self.extensions.is_empty() {
            format!("read as {}", self.dialect)
        } else {
            format!("read as {} with {}", self.dialect, self.extensions.join(", "))
        }
    }
}

/// Reads and parses a scene file of any dialect (a regular file or a pipe).
///
/// UTF-16 text is read as such, and text that is not UTF-8 as Latin-1, with a warning (naming, for
/// Latin-1, the first byte that is not UTF-8).
pub fn load(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Loaded, SceneError> {
    let path = path.as_ref();
    let io = |source: std::io::Error| SceneError::Io { path: path.to_owned(), source };
    let bytes = read_capped(path, MAX_FILE_BYTES).map_err(io)?;
    let mut options = options.clone();
    if options.base_dir.is_none() {
        options.base_dir = path.parent().map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p }.to_owned());
    }
    parse_bytes(&bytes, &path.display().to_string(), &options)
}

/// Parses the bytes of a scene file of any dialect ([`parse`] once decoded): UTF-16 text (with or
/// without a byte-order mark) is read as UTF-16 with a warning, and text that is not UTF-8 is read
/// as Latin-1 with a warning naming the first byte that is not (each an error under `strict`).
///
/// ```
/// use raylume_scene::p3f::{parse_bytes, LoadOptions};
/// let text = b"v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 4 4 # D\xfcrer\n";
/// let loaded = parse_bytes(text, "latin1.p3f", &LoadOptions::default()).unwrap();
/// assert_eq!(loaded.warnings[0].to_string(), "latin1.p3f:1:68: warning: byte 0xFC is not UTF-8: the file is read as Latin-1");
/// ```
pub fn parse_bytes(bytes: &[u8], name: &str, options: &LoadOptions) -> Result<Loaded, SceneError> {
    if let Some(kind) = foreign::binary_kind(bytes) {
        let message = format!("expected the text of a scene, found {kind}");
        return Err(SceneError::Syntax { file: name.to_owned(), line: 1, column: 1, message, warnings: Vec::new() });
    }
    if let Some((text, order)) = utf16_text(bytes) {
        let message = format!("the file is UTF-16 ({order}) text, not ASCII or UTF-8");
        if options.strict {
            return Err(SceneError::Syntax {
                file: name.to_owned(),
                line: 1,
                column: 1,
                message,
                warnings: Vec::new(),
            });
        }
        let message = format!("{message}: it is read as UTF-16");
        let warning = Warning { file: name.to_owned(), line: 1, column: 1, message };
        let mut loaded = parse(&text, name, options).map_err(|e| e.with_earlier_warnings(vec![warning.clone()]))?;
        loaded.warnings.insert(0, warning);
        return Ok(loaded);
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => parse(text, name, options),
        Err(e) => {
            let (line, column) = position_of(bytes, e.valid_up_to());
            let byte = bytes[e.valid_up_to()];
            let text: String = bytes.iter().map(|&b| b as char).collect();
            let message = format!("byte 0x{byte:02X} is not UTF-8");
            if options.strict {
                return Err(SceneError::Syntax { file: name.to_owned(), line, column, message, warnings: Vec::new() });
            }
            let message = format!("{message}: the file is read as Latin-1");
            let warning = Warning { file: name.to_owned(), line, column, message };
            let mut loaded = parse(&text, name, options).map_err(|e| e.with_earlier_warnings(vec![warning.clone()]))?;
            loaded.warnings.insert(0, warning);
            Ok(loaded)
        }
    }
}

/// Reads a regular file, or a pipe (`/dev/stdin` fed by another program, `<(...)`), of at most `cap`
/// bytes.
pub(crate) fn read_capped(path: &Path, cap: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    #[cfg(unix)]
    let pipe = std::os::unix::fs::FileTypeExt::is_fifo(&meta.file_type());
    #[cfg(not(unix))]
    let pipe = false;
    if !meta.is_file() && !pipe {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file or a pipe"));
    }
    if meta.len() > cap {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("the file has {} bytes, more than the {cap} accepted", meta.len()),
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(cap) as usize);
    file.take(cap + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > cap {
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("more than {cap} bytes")));
    }
    Ok(bytes)
}

/// The byte order of UTF-16 bytes (as Windows Notepad's "Unicode" or PowerShell's `>` write a
/// file), `true` for little-endian, and the length of their byte-order mark: told by the mark or,
/// without one, by the zero bytes that ASCII characters have in one half of each pair; `None` for
/// any other bytes (a scene's text never holds a zero byte).
fn utf16_order(bytes: &[u8]) -> Option<(bool, usize)> {
    if bytes.starts_with(b"\xFF\xFE") {
        return Some((true, 2));
    }
    if bytes.starts_with(b"\xFE\xFF") {
        return Some((false, 2));
    }
    let head = &bytes[..bytes.len().min(64) & !1];
    let zero_at = |parity: usize| head.iter().enumerate().all(|(i, &b)| (b == 0) == (i % 2 == parity));
    match () {
        _ if head.is_empty() => None,
        _ if zero_at(1) => Some((true, 0)),
        _ if zero_at(0) => Some((false, 0)),
        _ => None,
    }
}

/// The text of UTF-16 bytes ([`utf16_order`]) and the name of their byte order; a lone last byte or
/// an unpaired surrogate reads as U+FFFD.
fn utf16_text(bytes: &[u8]) -> Option<(String, &'static str)> {
    let (little, mark) = utf16_order(bytes)?;
    let body = &bytes[mark..];
    let units = body
        .chunks_exact(2)
        .map(|p| if little { u16::from_le_bytes([p[0], p[1]]) } else { u16::from_be_bytes([p[0], p[1]]) });
    let mut text: String = char::decode_utf16(units).map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER)).collect();
    if body.len() % 2 == 1 {
        text.push(char::REPLACEMENT_CHARACTER);
    }
    Some((text, if little { "little-endian" } else { "big-endian" }))
}

/// Line and column (in characters of the valid text before it) of byte `at`; lines end as the
/// lexer ends them (LF, CR LF or a lone CR).
fn position_of(bytes: &[u8], at: usize) -> (u32, u32) {
    let before = &bytes[..at];
    let line = (0..at).filter(|&i| lexer::ends_line(bytes, i)).count() as u32 + 1;
    let start = (0..at).rev().find(|&i| lexer::ends_line(bytes, i)).map_or(0, |i| i + 1);
    let column = String::from_utf8_lossy(&before[start..]).chars().count() as u32 + 1;
    (line, column)
}

/// Parses scene text of any dialect; `file` names it in messages (and its extension, `.nff`, tells
/// the dialect where the content does not).
///
/// A file of another format (PLY, STL, an OBJ mesh, pbrt, glTF, USD, XML) is an error at its first
/// line that names the format, not a run of warnings about unknown tags.
///
/// ```
/// use raylume_scene::p3f::{parse, LoadOptions};
/// let e = parse("ply\nformat ascii 1.0\n", "bunny.ply", &LoadOptions::default()).unwrap_err();
/// assert!(e.to_string().starts_with("bunny.ply:1:1: expected a p3f or NFF scene, found a PLY mesh"));
/// ```
pub fn parse(text: &str, file: &str, options: &LoadOptions) -> Result<Loaded, SceneError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if let Some((format, line, column, instead)) = foreign::foreign_format(text) {
        let message = format!("expected a p3f or NFF scene, found {format} ({instead})");
        return Err(SceneError::Syntax { file: file.to_owned(), line, column, message, warnings: Vec::new() });
    }
    parser::Parser::new(text, file, options).scene()
}

/// The folders a cubemap named in a scene is looked for in: the scene's folder (else the current
/// one), its parent, then `extra`.
pub fn env_search_dirs(base_dir: Option<&Path>, extra: &[PathBuf]) -> Vec<PathBuf> {
    let base = base_dir.map_or_else(|| PathBuf::from("."), Path::to_path_buf);
    let mut dirs = vec![base.clone(), base.join("..")];
    dirs.extend(extra.iter().cloned());
    dirs
}
