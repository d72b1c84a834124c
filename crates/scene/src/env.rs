use std::path::{Path, PathBuf};

use raylume_geometry::Vec3;
use raylume_integrator::{Cubemap, CubemapFace};

use crate::SceneError;

/// Finds the cubemap folder `name` in the first of `search_dirs` that holds it with an image for
/// each of its six faces; the error says where it looked and what was missing.
pub fn find_cubemap(name: &str, search_dirs: &[PathBuf]) -> Result<PathBuf, String> {
    let dir = search_dirs.iter().map(|d| d.join(name)).find(|d| d.is_dir()).ok_or_else(|| {
        let looked: Vec<String> = search_dirs.iter().map(|d| d.display().to_string()).collect();
        format!(
            "no folder '{name}' in {} (give --env-dir, or --no-env to use the background colour)",
            if looked.is_empty() { "any search folder".to_owned() } else { looked.join(", ") }
        )
    })?;
    for face in Cubemap::FACE_NAMES {
        face_path(&dir, face).ok_or_else(|| format!("{}: no image for the '{face}' face", dir.display()))?;
    }
    Ok(dir)
}

fn face_path(dir: &Path, face: &str) -> Option<PathBuf> {
    ["jpg", "jpeg", "png"].iter().map(|ext| dir.join(format!("{face}.{ext}"))).find(|p| p.is_file())
}

/// Finds the cubemap folder `name` in the first of `search_dirs` that holds it ([`find_cubemap`])
/// and decodes its six faces (`right left top bottom front back`, `.jpg` or `.png`) to linear
/// colours in [0, 1].
pub fn load_cubemap(name: &str, search_dirs: &[PathBuf]) -> Result<Cubemap, SceneError> {
    let err = |message: String| SceneError::Environment { name: name.to_owned(), message };
    let dir = find_cubemap(name, search_dirs).map_err(err)?;
    let mut faces = Vec::with_capacity(6);
    for face in Cubemap::FACE_NAMES {
        let path =
            face_path(&dir, face).ok_or_else(|| err(format!("{}: no image for the '{face}' face", dir.display())))?;
        faces.push(load_face(&path).map_err(|e| err(format!("{}: {e}", path.display())))?);
    }
    let faces: [CubemapFace; 6] = faces.try_into().expect("six faces");
    Ok(Cubemap { faces })
}

fn load_face(path: &Path) -> Result<CubemapFace, image::ImageError> {
    let img = image::ImageReader::open(path)?.with_guessed_format()?.decode()?.into_rgb8();
    let (width, height) = img.dimensions();
    let mut texels = Vec::with_capacity(width as usize * height as usize);
    // Row 0 of the face is the image's bottom row.
    for row in (0..height).rev() {
        for col in 0..width {
            let p = img.get_pixel(col, row).0;
            texels.push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0);
        }
    }
    Ok(CubemapFace { width, height, texels })
}
