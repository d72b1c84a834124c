//! Where a scene's `env` cubemap is: the folder and its six face images, found on disk without
//! decoding them (decoding belongs to the render assembly, `raylume-render`).

use std::path::{Path, PathBuf};

/// The faces of a cubemap folder, in the order a cubemap keeps them: each is an image
/// `NAME.jpg`, `NAME.jpeg` or `NAME.png`.
pub const CUBEMAP_FACES: [&str; 6] = ["right", "left", "top", "bottom", "front", "back"];

/// Finds the cubemap folder `name` in the first of `search_dirs` that holds it with an image for
/// each of its six faces; the error says where it looked and what was missing.
///
/// ```
/// let dirs = [std::env::temp_dir()];
/// let err = raylume_scene::find_cubemap("no such cubemap", &dirs).unwrap_err();
/// assert!(err.starts_with("no folder 'no such cubemap' in "));
/// ```
pub fn find_cubemap(name: &str, search_dirs: &[impl AsRef<Path>]) -> Result<PathBuf, String> {
    cubemap_faces(name, search_dirs).map(|(dir, _)| dir)
}

/// The cubemap folder `name` ([`find_cubemap`]) and the paths of its six face images, in the order
/// of [`CUBEMAP_FACES`].
pub fn cubemap_faces(name: &str, search_dirs: &[impl AsRef<Path>]) -> Result<(PathBuf, [PathBuf; 6]), String> {
    let dir = search_dirs.iter().map(|d| d.as_ref().join(name)).find(|d| d.is_dir()).ok_or_else(|| {
        let looked: Vec<String> = search_dirs.iter().map(|d| d.as_ref().display().to_string()).collect();
        format!(
            "no folder '{name}' in {} (give --env-dir, or --no-env to use the background colour)",
            if looked.is_empty() { "any search folder".to_owned() } else { looked.join(", ") }
        )
    })?;
    let mut faces: [PathBuf; 6] = Default::default();
    for (slot, face) in faces.iter_mut().zip(CUBEMAP_FACES) {
        *slot = ["jpg", "jpeg", "png"]
            .iter()
            .map(|ext| dir.join(format!("{face}.{ext}")))
            .find(|p| p.is_file())
            .ok_or_else(|| format!("{}: no image for the '{face}' face", dir.display()))?;
    }
    Ok((dir, faces))
}
