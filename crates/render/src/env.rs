use std::path::Path;

use raylume_integrator::{Cubemap, CubemapFace, Texels};
use raylume_scene::{SceneError, cubemap_faces};

/// Finds the cubemap folder `name` in the first of `search_dirs` that holds it
/// ([`raylume_scene::find_cubemap`]) and decodes its six faces (`right left top bottom front back`,
/// `.jpg` or `.png`), each texel kept as its three bytes ([`Texels::Rgb8`]).
///
/// ```
/// let err = raylume_render::load_cubemap("no such cubemap", &[std::env::temp_dir()]).unwrap_err();
/// assert!(err.to_string().starts_with("environment map 'no such cubemap': no folder"));
/// ```
pub fn load_cubemap(name: &str, search_dirs: &[impl AsRef<Path>]) -> Result<Cubemap, SceneError> {
    let err = |message: String| SceneError::Environment { name: name.to_owned(), message };
    let (_, paths) = cubemap_faces(name, search_dirs).map_err(err)?;
    let mut faces = Vec::with_capacity(6);
    for path in &paths {
        faces.push(load_face(path).map_err(|e| err(format!("{}: {e}", path.display())))?);
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
