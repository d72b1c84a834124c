//! The workloads of the comparison against obvhs (`cargo bench -p raylume-compare`): the shared bunny
//! meshes, their primary rays (a 1024x1024 pinhole view filling the frame) and incoherent rays (origins
//! on a sphere of 1.5 times the bounding radius, aimed at uniform random points in the bounding box).
//!
//! obvhs is a dev-dependency of the bench only; this library hands both engines the same triangles and
//! the same rays.

use std::path::{Path, PathBuf};

use raylume_geometry::{Aabb, Ray, Triangle};
use raylume_intersect::Primitive;
use raylume_render::RenderScene;
use raylume_scene::{obj, procedural, rays};

/// One mesh and its two ray sets.
pub struct Workload {
    /// The mesh's file stem (`bunny`, `bunny_loop2`, ...).
    pub name: String,
    /// The triangles, in file order.
    pub triangles: Vec<Triangle>,
    /// The view's side in pixels.
    pub side: usize,
    /// Primary rays: a pinhole view of `side x side` pixels filling the frame, row by row.
    pub camera: Vec<Ray>,
    /// Incoherent rays, as many as the primary ones.
    pub random: Vec<Ray>,
}

impl Workload {
    /// Loads `mesh` and makes `side * side` rays of each kind.
    pub fn load(mesh: &Path, side: u32) -> Result<Self, String> {
        let shape = obj::load(mesh).map_err(|e| e.to_string())?;
        let scene = procedural::mesh_view(shape, side, side);
        let triangles: Vec<Triangle> = scene
            .primitives()
            .primitives
            .into_iter()
            .filter_map(|p| match p {
                Primitive::Triangle(t) => Some(t),
                _ => None,
            })
            .collect();
        let bounds = triangles.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()));
        let count = (side * side) as usize;
        let name = mesh.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        Ok(Self {
            name,
            side: side as usize,
            camera: rays::camera_rays(&scene.view, count),
            random: rays::random_rays(&bounds, count, 1),
            triangles,
        })
    }
}

/// The workload of the shared mesh `name` (`dir/name.obj`) with `side * side` rays of each kind, or
/// `None` after saying on stderr why it is skipped.
pub fn load_shared(dir: &Path, name: &str, side: u32) -> Option<Workload> {
    Workload::load(&dir.join(format!("{name}.obj")), side).map_err(|e| eprintln!("skipped {name}: {e}")).ok()
}

/// The shared meshes directory (`../shared/meshes` beside the repository), if present.
pub fn shared_meshes() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes");
    dir.is_dir().then_some(dir)
}
