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
    let img = image::ImageReader::open(path)?.with_guessed_format()?.decode()?.into_rgb8();
    let (width, height) = img.dimensions();
    let mut texels = Vec::with_capacity(img.as_raw().len());
    // Row 0 of the face is the image's bottom row.
    for row in img.as_raw().chunks_exact(width as usize * 3).rev() {
        texels.extend_from_slice(row);
    }
    Ok(CubemapFace { width, height, texels: Texels::Rgb8(texels) })
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
}
