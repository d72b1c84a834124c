//! Wavefront OBJ meshes, read with `tobj` and triangulated.

use std::path::Path;

use raylume_geometry::Vec3A;

use crate::{SceneError, Shape};

/// Reads every model of an OBJ file into one triangle mesh ([`Shape::Mesh`]); polygons are
/// triangulated, materials and texture coordinates ignored.
///
/// ```no_run
/// let mesh = raylume_scene::obj::load(std::path::Path::new("bunny.obj")).unwrap();
/// ```
pub fn load(path: &Path) -> Result<Shape, SceneError> {
    let options = tobj::LoadOptions { triangulate: true, single_index: false, ignore_points: true, ignore_lines: true };
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| match e {
        tobj::LoadError::OpenFileFailed | tobj::LoadError::ReadError => SceneError::Io {
            path: path.to_owned(),
            source: std::fs::File::open(path).err().unwrap_or_else(|| std::io::Error::other(e.to_string())),
        },
        other => SceneError::Invalid(format!("{}: not a readable OBJ file: {other}", path.display())),
    })?;
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        let base = vertices.len() as u32;
        for p in mesh.positions.chunks_exact(3) {
            let v = Vec3A::new(p[0], p[1], p[2]);
            if !v.is_finite() {
                return Err(SceneError::Invalid(format!(
                    "{}: a vertex of '{}' is not finite",
                    path.display(),
                    model.name
                )));
            }
            vertices.push(v);
        }
        let count = (mesh.positions.len() / 3) as u32;
        for t in mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i >= count) {
                return Err(SceneError::Invalid(format!(
                    "{}: a face of '{}' indexes a missing vertex",
                    path.display(),
                    model.name
                )));
            }
            triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if triangles.is_empty() {
        return Err(SceneError::Invalid(format!("{}: no faces", path.display())));
    }
    Ok(Shape::Mesh { vertices, triangles })
}
