use raylume_camera::View;
use raylume_geometry::{Vec3, Vec3A};
use raylume_material::Phong;

/// A scene as the p3f format describes it: camera, background, lights, materials and objects.
///
/// Shapes keep the data the file gave (a plane's three points, a polygon's vertices), so that
/// [`Scene::to_p3f`] writes back what was read.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The camera.
    pub view: View,
    /// Background colour for rays that escape.
    pub background: Vec3,
    /// Name of the environment cubemap folder, if any.
    pub env: Option<String>,
    /// Point lights.
    pub lights: Vec<Light>,
    /// Materials, in the order of their `f` entities.
    pub materials: Vec<Phong>,
    /// Objects, each with its material.
    pub objects: Vec<Object>,
    /// Suggested accelerator (p3f `accel`): 0 none, 1 grid, 2 BVH.
    pub accel_hint: Option<u32>,
    /// Suggested samples per pixel (p3f `spp`).
    pub spp_hint: Option<u32>,
    /// The camera's shutter interval (raylume's `shutter t0 t1` tag); by default the moving spheres'
    /// time span.
    pub shutter: Option<(f32, f32)>,
    /// The folder the scene's relative names (its `env` cubemap, `obj` meshes) are looked up in
    /// first, then its parent: the scene file's folder when it was read by [`crate::p3f::load`].
    pub base_dir: Option<std::path::PathBuf>,
}

/// A light: a point, or an area light whose [`LightShape`] starts at `position`.
///
/// ```
/// use raylume_scene::{Light, LightShape};
/// use raylume_geometry::{Vec3, Vec3A};
/// let lamp = Light::point(Vec3A::new(0.0, 5.0, 0.0), Vec3::ONE);
/// assert_eq!(lamp.shape, LightShape::Point);
/// assert!(!lamp.is_area());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Position: the point light, the centre of a square, the corner of a parallelogram.
    pub position: Vec3A,
    /// Colour.
    pub color: Vec3,
    /// What emits: a point or an area.
    pub shape: LightShape,
}

/// The emitting shape of a [`Light`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightShape {
    /// A point at the light's position (p3f `l x y z r g b`, `light punctual`).
    Point,
    /// The course's square area light: this side, in the world XY plane, centred on the light's
    /// position (raylume's `l x y z r g b size`).
    Square(f32),
    /// A parallelogram with one corner at the light's position and its two edges ending at these
    /// points (p3f 2024/25 `light quad`, student `al`).
    Parallelogram {
        /// The ends of the two edges that leave the corner.
        ends: [Vec3A; 2],
        /// Side of the grid of point lights that stands for it without antialiasing (0: the
        /// render's light grid).
        grid: u32,
    },
}

impl Light {
    /// A point light.
    pub fn point(position: Vec3A, color: Vec3) -> Self {
        Self { position, color, shape: LightShape::Point }
    }

    /// Whether the light has an area (soft shadows).
    pub fn is_area(&self) -> bool {
        match self.shape {
            LightShape::Point => false,
            LightShape::Square(size) => size > 0.0,
            LightShape::Parallelogram { ends, .. } => ends.iter().any(|&e| e != self.position),
        }
    }
}

/// An object: a shape and the index of its material in [`Scene::materials`].
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// The geometry.
    pub shape: Shape,
}

/// The geometry of one p3f entity.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// `s`: a sphere.
    Sphere {
        /// Centre.
        center: Vec3A,
        /// Radius.
        radius: f32,
    },
    /// `sm`: a sphere moving from `center0` at `time0` to `center1` at `time1`.
    MovingSphere {
        /// Centre at `time0`.
        center0: Vec3A,
        /// Centre at `time1`.
        center1: Vec3A,
        /// Radius.
        radius: f32,
        /// Start time.
        time0: f32,
        /// End time.
        time1: f32,
    },
    /// `box`: an axis-aligned box.
    Box {
        /// Smallest corner.
        min: Vec3A,
        /// Largest corner.
        max: Vec3A,
    },
    /// `p`: a convex polygon (triangulated as a fan).
    Polygon(Vec<Vec3A>),
    /// `pp`: a polygonal patch with vertex normals.
    Patch(Vec<(Vec3A, Vec3A)>),
    /// `pl`: an infinite plane through three points.
    Plane([Vec3A; 3]),
    /// `c`: a cone or cylinder without caps.
    Cone {
        /// Base centre.
        base: Vec3A,
        /// Base radius.
        base_radius: f32,
        /// Apex centre.
        apex: Vec3A,
        /// Apex radius.
        apex_radius: f32,
    },
    /// `mesh`: a triangle mesh with 0-based indices.
    Mesh {
        /// Vertex positions.
        vertices: Vec<Vec3A>,
        /// Triangles as vertex indices.
        triangles: Vec<[u32; 3]>,
    },
}

impl Scene {
    /// The shutter interval: the scene's `shutter`, else the union of the moving spheres' time
    /// spans, or `[0, 0]` without motion.
    pub fn shutter(&self) -> raylume_geometry::Interval {
        if let Some((t0, t1)) = self.shutter {
            return raylume_geometry::Interval::new(t0, t1);
        }
        let mut shutter: Option<(f32, f32)> = None;
        for o in &self.objects {
            if let Shape::MovingSphere { time0, time1, .. } = o.shape {
                let (a, b) = (time0.min(time1), time0.max(time1));
                shutter = Some(shutter.map_or((a, b), |(s0, s1)| (s0.min(a), s1.max(b))));
            }
        }
        let (a, b) = shutter.unwrap_or((0.0, 0.0));
        raylume_geometry::Interval::new(a, b)
    }

    /// The number of primitives the scene makes (triangles of polygons and meshes counted one by one).
    pub fn primitive_count(&self) -> usize {
        self.objects
            .iter()
            .map(|o| match &o.shape {
                Shape::Polygon(v) => v.len().saturating_sub(2),
                Shape::Patch(v) => v.len().saturating_sub(2),
                Shape::Mesh { triangles, .. } => triangles.len(),
                _ => 1,
            })
            .sum()
    }
}
