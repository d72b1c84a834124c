use std::path::Path;

use rayon::prelude::*;

use raylume_integrator::{Cubemap, CubemapFace, Texels};
use raylume_scene::{SceneError, cubemap_faces};

/// Finds the cubemap folder `name` in the first of `search_dirs` that holds it
/// ([`raylume_scene::find_cubemap`]) and decodes its six faces (`right left top bottom front back`,
/// `.jpg` or `.png`) side by side on the current rayon thread pool, each texel kept as its three bytes
/// ([`Texels::Rgb8`]).
///
/// ```
/// let err = raylume_render::load_cubemap("no such cubemap", &[std::env::temp_dir()]).unwrap_err();
/// assert!(err.to_string().starts_with("environment map 'no such cubemap': no folder"));
/// ```
pub fn load_cubemap(name: &str, search_dirs: &[impl AsRef<Path>]) -> Result<Cubemap, SceneError> {
    let err = |message: String| SceneError::Environment { name: name.to_owned(), message };
    let (_, paths) = cubemap_faces(name, search_dirs).map_err(err)?;
    // The faces decode side by side on the current thread pool; the first face that fails, in the
    // faces' order, names the error.
    let decoded: Vec<_> = paths.as_slice().par_iter().map(|path| load_face(path)).collect();
    let mut faces = Vec::with_capacity(6);
    for (path, face) in paths.iter().zip(decoded) {
        faces.push(face.map_err(|e| err(format!("{}: {e}", path.display())))?);
    }
    let faces: [CubemapFace; 6] = faces.try_into().expect("six faces");
    Ok(Cubemap { faces })
}

fn load_face(path: &Path) -> Result<CubemapFace, image::ImageError> {
    let bytes = std::fs::read(path)?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes)).with_guessed_format()?;
    // The JPEG decoder fills what a truncated file lacks with grey, silently: such a file is refused.
    if reader.format() == Some(image::ImageFormat::Jpeg) && !jpeg_ends_its_last_scan(&bytes) {
        return Err(image::ImageError::Decoding(image::error::DecodingError::new(
            image::ImageFormat::Jpeg.into(),
            "the file is truncated: no end-of-image marker after its last scan",
        )));
    }
    let img = reader.decode()?.into_rgb8();
    let (width, height) = img.dimensions();
    let mut texels = Vec::with_capacity(img.as_raw().len());
    // Row 0 of the face is the image's bottom row.
    for row in img.as_raw().chunks_exact(width as usize * 3).rev() {
        texels.extend_from_slice(row);
    }
    Ok(CubemapFace { width, height, texels: Texels::Rgb8(texels) })
}

/// Whether a JPEG file's last scan is followed by the end-of-image marker, as it is in a whole file.
/// Scan data never holds the bytes `FF D9` (a stuffed `FF` is followed by `00`), so a file cut short
/// in its last scan has none after that scan's start (`FF DA`); an end-of-image before it (an EXIF
/// thumbnail's) does not count, and bytes after the marker (a camera's trailer) do not matter.
fn jpeg_ends_its_last_scan(bytes: &[u8]) -> bool {
    let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]).unwrap_or(0);
    bytes[last_scan..].windows(2).any(|w| w == [0xFF, 0xD9])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The faces decode side by side, yet the error is always the first broken face's in the faces'
    /// order, and good faces keep their bytes, rows reversed.
    #[test]
    fn the_first_broken_face_in_order_names_the_error() {
        let root = std::env::temp_dir().join(format!("raylume-env-faces-{}", std::process::id()));
        let dir = root.join("sky");
        std::fs::create_dir_all(&dir).unwrap();
        let faces = ["right", "left", "top", "bottom", "front", "back"];
        for (i, face) in faces.iter().enumerate() {
            let img = image::RgbImage::from_fn(3, 2, |x, y| image::Rgb([i as u8, x as u8, y as u8]));
            img.save(dir.join(format!("{face}.png"))).unwrap();
        }
        let cubemap = load_cubemap("sky", &[&root]).unwrap();
        for (i, face) in cubemap.faces.iter().enumerate() {
            let Texels::Rgb8(bytes) = &face.texels else { panic!("bytes expected") };
            // Row 0 is the image's bottom row (y = 1).
            assert_eq!(&bytes[..3], &[i as u8, 0, 1]);
            assert_eq!(&bytes[9..12], &[i as u8, 0, 0]);
        }
        for broken in ["back", "top"] {
            std::fs::write(dir.join(format!("{broken}.png")), b"not a png").unwrap();
        }
        for _ in 0..8 {
            let message = load_cubemap("sky", &[&root]).unwrap_err().to_string();
            assert!(message.contains("top.png"), "{message}");
        }
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// A JPEG face cut short anywhere in its data is refused with its name, where the whole file and
    /// one with bytes after its end load.
    #[test]
    fn a_truncated_jpeg_face_is_refused() {
        let root = std::env::temp_dir().join(format!("raylume-env-jpeg-{}", std::process::id()));
        let dir = root.join("sky");
        std::fs::create_dir_all(&dir).unwrap();
        let img = image::RgbImage::from_fn(64, 48, |x, y| image::Rgb([(x * 4) as u8, (y * 5) as u8, (x ^ y) as u8]));
        let mut jpeg = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut jpeg), image::ImageFormat::Jpeg).unwrap();
        for face in ["right", "left", "top", "bottom", "front", "back"] {
            std::fs::write(dir.join(format!("{face}.jpg")), &jpeg).unwrap();
        }
        assert!(load_cubemap("sky", &[&root]).is_ok());
        let trailer = [&jpeg[..], b"camera trailer"].concat();
        std::fs::write(dir.join("top.jpg"), &trailer).unwrap();
        assert!(load_cubemap("sky", &[&root]).is_ok(), "bytes after the end-of-image marker");
        for cut in [jpeg.len() / 2, jpeg.len() - 2, jpeg.len() - 40] {
            std::fs::write(dir.join("top.jpg"), &jpeg[..cut]).unwrap();
            let message = load_cubemap("sky", &[&root]).unwrap_err().to_string();
            assert!(message.contains("top.jpg") && message.contains("truncated"), "cut at {cut}: {message}");
        }
        std::fs::remove_dir_all(&root).unwrap();
    }
}
