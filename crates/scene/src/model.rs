use raylume_camera::View;
use raylume_geometry::{Vec3, Vec3A};
use raylume_material::{Light, LightShape, Phong};

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
    /// Suggested accelerator (p3f `accel`).
    pub accel_hint: Option<AccelHint>,
    /// Suggested samples per pixel (p3f `spp`).
    pub spp_hint: Option<u32>,
    /// The camera's shutter interval (raylume's `shutter t0 t1` tag); by default the moving spheres'
    /// time span.
    pub shutter: Option<(f32, f32)>,
    /// The folder the scene's relative names (its `env` cubemap, `obj` meshes) are looked up in
    /// first, then its parent: the scene file's folder when it was read by [`crate::p3f::load`].
    pub base_dir: Option<std::path::PathBuf>,
}

/// The accelerator a scene file suggests (p3f `accel`: `0`/`none`, `1`/`grid`, `2`/`bvh`); its
/// value as a number is the one p3f writes.
///
/// ```
/// use raylume_scene::AccelHint;
/// assert_eq!(AccelHint::ALL[1], AccelHint::Grid);
/// assert_eq!(AccelHint::Bvh as u32, 2);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AccelHint {
    /// No accelerator: every primitive tested by every ray (`accel 0`).
    None = 0,
    /// A uniform grid (`accel 1`).
    Grid = 1,
    /// A bounding volume hierarchy (`accel 2`).
    Bvh = 2,
}

impl AccelHint {
    /// The hints in the order of their p3f numbers.
    pub const ALL: [AccelHint; 3] = [AccelHint::None, AccelHint::Grid, AccelHint::Bvh];
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
    /// `mesh` (or `obj`): a triangle mesh with 0-based indices.
    Mesh {
        /// Vertex positions.
        vertices: Vec<Vec3A>,
        /// Triangles as vertex indices.
        triangles: Vec<[u32; 3]>,
        /// The shading normals at each triangle's three corners (an OBJ file's `vn`), for smooth
        /// shading; empty for a mesh shaded with its faces' normals.
        normals: Vec<[Vec3A; 3]>,
    },
}

impl Shape {
    /// Why part or all of the shape can never be hit, if so: triangles (of polygons, patches and
    /// meshes) whose vertices are collinear once in f32 have no plane, and the intersection routines
    /// and accelerators leave them out. Loaders report it as a warning, naming the entity.
    ///
    /// ```
    /// use raylume_scene::Shape;
    /// use raylume_geometry::Vec3A;
    /// let sliver = Shape::Polygon(vec![Vec3A::ZERO, Vec3A::X, Vec3A::new(2.0, 0.0, 0.0)]);
    /// assert!(sliver.never_hit().unwrap().contains("never hit"));
    /// assert_eq!(Shape::Polygon(vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y]).never_hit(), None);
    /// ```
    pub fn never_hit(&self) -> Option<String> {
        let (what, flat, total) = self.flat_triangles()?;
        match (flat, total) {
            (0, _) => None,
            (f, t) if f == t => Some(format!("{what}: its vertices are collinear in f32 (no area): it is never hit")),
            (1, t) => {
                Some(format!("{what}: 1 of its {t} triangles has collinear vertices in f32 (no area): it is never hit"))
            }
            (f, t) => Some(format!(
                "{what}: {f} of its {t} triangles have collinear vertices in f32 (no area): they are never hit"
            )),
        }
    }

    /// Whether every triangle of the shape (a polygon, patch or mesh) is collinear in f32, so that
    /// nothing of it can be hit ([`Shape::never_hit`]); `false` for the other shapes.
    ///
    /// ```
    /// use raylume_scene::Shape;
    /// use raylume_geometry::Vec3A;
    /// assert!(Shape::Polygon(vec![Vec3A::ZERO, Vec3A::X, Vec3A::new(2.0, 0.0, 0.0)]).has_no_area());
    /// assert!(!Shape::Polygon(vec![Vec3A::ZERO, Vec3A::X, Vec3A::Y]).has_no_area());
    /// ```
    pub fn has_no_area(&self) -> bool {
        self.flat_triangles().is_some_and(|(_, flat, total)| flat == total)
    }

    /// The kind of a shape made of triangles, how many of its triangles are collinear in f32, and
    /// how many it has.
    fn flat_triangles(&self) -> Option<(&'static str, usize, usize)> {
        let flat = |tris: &mut dyn Iterator<Item = [Vec3A; 3]>| {
            let (mut total, mut flat) = (0usize, 0usize);
            for [a, b, c] in tris {
                total += 1;
                flat += usize::from(!raylume_geometry::Triangle::new(a, b, c).has_plane());
            }
            (flat, total)
        };
        let (what, (flat, total)) = match self {
            Shape::Polygon(v) => {
                ("polygon", flat(&mut crate::triangulate(v).into_iter().map(|t| t.map(|i| v[i as usize]))))
            }
            Shape::Patch(v) => {
                let points: Vec<Vec3A> = v.iter().map(|p| p.0).collect();
                ("patch", flat(&mut crate::triangulate(&points).into_iter().map(|t| t.map(|i| points[i as usize]))))
            }
            Shape::Mesh { vertices, triangles, .. } => (
                "mesh",
                flat(&mut triangles.iter().filter_map(|t| {
                    let [a, b, c] = t.map(|i| vertices.get(i as usize).copied());
                    Some([a?, b?, c?])
                })),
            ),
            _ => return None,
        };
        Some((what, flat, total))
    }
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

    /// The folders the scene's `env` cubemap is looked for in: the scene's folder
    /// ([`Scene::base_dir`], else the current one), its parent, then `extra`.
    ///
    /// ```
    /// use std::path::PathBuf;
    /// use raylume_scene::{DEFAULT_SCENE, p3f};
    /// let mut scene = p3f::parse(DEFAULT_SCENE, "d", &Default::default()).unwrap().scene;
    /// scene.base_dir = Some(PathBuf::from("scenes"));
    /// let dirs = scene.cubemap_dirs(&[PathBuf::from("maps")]);
    /// assert_eq!(dirs, [PathBuf::from("scenes"), PathBuf::from("scenes/.."), PathBuf::from("maps")]);
    /// ```
    pub fn cubemap_dirs(&self, extra: &[std::path::PathBuf]) -> Vec<std::path::PathBuf> {
        crate::p3f::env_search_dirs(self.base_dir.as_deref(), extra)
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

impl Scene {
    /// Checks that the scene can be rendered: a camera within the [`limits`](crate::limits), finite
    /// numbers everywhere, radii and counts that make shapes, mesh and material indices in range.
    /// [`crate::SceneBuilder::build`] and the render (`raylume_render::RenderScene::render`) call it, so a scene made in code meets
    /// the same rules as a file.
    ///
    /// ```
    /// use raylume_scene::SceneBuilder;
    /// use raylume_geometry::Vec3A;
    /// let scene = SceneBuilder::new()
    ///     .camera(Vec3A::ZERO, Vec3A::ZERO, Vec3A::Y, 45.0, 64, 64)
    ///     .build();
    /// assert_eq!(scene.unwrap_err().to_string(), "camera: 'from' equals 'at'");
    /// ```
    pub fn validate(&self) -> Result<(), crate::SceneError> {
        validate(self).map_err(crate::SceneError::Invalid)
    }
}

fn finite(v: Vec3A) -> bool {
    v.is_finite()
}

fn validate(s: &Scene) -> Result<(), String> {
    use crate::limits::{MAX_LIGHT_GRID, MAX_PIXELS, MAX_RESOLUTION, MAX_SPP};
    let v = &s.view;
    if !(finite(v.from) && finite(v.at) && finite(v.up)) {
        return Err("camera: 'from', 'at' and 'up' must be finite".to_owned());
    }
    if v.from == v.at {
        return Err("camera: 'from' equals 'at'".to_owned());
    }
    if v.up.cross(v.from - v.at).length_squared() == 0.0 {
        return Err("camera: 'up' is parallel to the view direction".to_owned());
    }
    if !(v.angle_deg > 0.0 && v.angle_deg < 180.0) {
        return Err(format!("camera: angle {}: expected (0, 180) degrees", v.angle_deg));
    }
    if !(1..=MAX_RESOLUTION).contains(&v.width)
        || !(1..=MAX_RESOLUTION).contains(&v.height)
        || v.width as u64 * v.height as u64 > MAX_PIXELS
    {
        return Err(format!(
            "camera: resolution {} x {}: each side must be 1..={MAX_RESOLUTION} and the image at most {MAX_PIXELS} pixels",
            v.width, v.height
        ));
    }
    let lens_ok = v.aperture.is_finite() && v.aperture >= 0.0 && v.focal.is_finite() && v.focal > 0.0;
    if !(v.hither.is_finite() && lens_ok) {
        return Err(format!(
            "camera: hither {}, aperture {}, focal {}: expected finite, >= 0 and > 0",
            v.hither, v.aperture, v.focal
        ));
    }
    if !s.background.is_finite() {
        return Err("the background colour must be finite".to_owned());
    }
    for (i, l) in s.lights.iter().enumerate() {
        let shape_ok = match l.shape {
            LightShape::Point => true,
            LightShape::Square(size) => size.is_finite() && size >= 0.0,
            LightShape::Parallelogram { ends, grid } => ends.iter().all(|&e| finite(e)) && grid <= MAX_LIGHT_GRID,
        };
        if !(finite(l.position) && l.color.is_finite() && shape_ok) {
            return Err(format!("light {i}: expected finite numbers (and an area grid of at most {MAX_LIGHT_GRID})"));
        }
    }
    for (i, m) in s.materials.iter().enumerate() {
        let numbers = [m.kd, m.ks, m.shine, m.transmittance, m.ior, m.specular_scale, m.roughness];
        if !(m.diffuse.is_finite() && m.specular.is_finite() && numbers.iter().all(|x| x.is_finite())) {
            return Err(format!("material {i}: expected finite numbers"));
        }
        if m.transmittance > 0.0 && m.ior <= 0.0 {
            return Err(format!("material {i}: a transparent material needs a positive index of refraction"));
        }
        if !(0.0..=1.0).contains(&m.roughness) {
            return Err(format!("material {i}: roughness {}: expected [0, 1]", m.roughness));
        }
    }
    for (i, o) in s.objects.iter().enumerate() {
        if o.material as usize >= s.materials.len() {
            return Err(format!("object {i}: material {} of {}", o.material, s.materials.len()));
        }
        shape_problem(&o.shape).map_or(Ok(()), |why| Err(format!("object {i}: {why}")))?;
    }
    if let Some(spp) = s.spp_hint.filter(|&n| n > MAX_SPP) {
        return Err(format!("spp {spp}: expected 0..={MAX_SPP}"));
    }
    if let Some((t0, t1)) = s.shutter.filter(|(t0, t1)| !(t0.is_finite() && t1.is_finite() && t0 <= t1)) {
        return Err(format!("shutter [{t0}, {t1}] is not an interval"));
    }
    Ok(())
}

/// What makes a shape unrenderable, if anything.
fn shape_problem(shape: &Shape) -> Option<String> {
    let radius_ok = |r: f32| r.is_finite() && r > 0.0;
    match shape {
        Shape::Sphere { center, radius } => (!(finite(*center) && radius_ok(*radius)))
            .then(|| format!("sphere: expected a finite centre and a positive radius, found {radius}")),
        Shape::MovingSphere { center0, center1, radius, time0, time1 } => {
            (!(finite(*center0) && finite(*center1) && radius_ok(*radius) && time0.is_finite() && time1.is_finite()))
                .then(|| "moving sphere: expected finite centres and times and a positive radius".to_owned())
        }
        Shape::Box { min, max } => (!(finite(*min) && finite(*max) && min.cmple(*max).all()))
            .then(|| "box: expected finite corners with min <= max".to_owned()),
        Shape::Polygon(v) => (v.len() < 3 || !v.iter().all(|&p| finite(p)))
            .then(|| format!("polygon: expected at least 3 finite vertices, found {}", v.len())),
        Shape::Patch(v) => (v.len() < 3 || !v.iter().all(|&(p, n)| finite(p) && finite(n)))
            .then(|| format!("patch: expected at least 3 finite vertices, found {}", v.len())),
        Shape::Plane([p0, p1, p2]) => raylume_geometry::Plane::from_points(*p0, *p1, *p2)
            .is_none()
            .then(|| "plane: expected three finite points that are not collinear".to_owned()),
        Shape::Cone { base, base_radius, apex, apex_radius } => {
            let r_ok = |r: f32| r.is_finite() && r >= 0.0;
            (!(finite(*base)
                && finite(*apex)
                && r_ok(*base_radius)
                && r_ok(*apex_radius)
                && (*base_radius > 0.0 || *apex_radius > 0.0)
                && base != apex))
                .then(|| "cone: expected finite, distinct ends and radii >= 0, not both 0".to_owned())
        }
        Shape::Mesh { vertices, triangles, normals } => {
            if let Some(k) = vertices.iter().position(|&p| !finite(p)) {
                return Some(format!("mesh: vertex {k} is not finite"));
            }
            if !normals.is_empty() && normals.len() != triangles.len() {
                return Some(format!("mesh: {} normal triples for {} triangles", normals.len(), triangles.len()));
            }
            if let Some(t) = normals.iter().position(|n| !n.iter().all(|&n| finite(n))) {
                return Some(format!("mesh: a normal of triangle {t} is not finite"));
            }
            let n = vertices.len();
            triangles.iter().enumerate().find_map(|(t, tri)| {
                tri.iter()
                    .find(|&&k| k as usize >= n)
                    .map(|k| format!("mesh: triangle {t} refers to vertex {k} of {n}"))
            })
        }
    }
}
