use raylume_camera::View;
use raylume_geometry::{Vec3, Vec3A};
use raylume_material::Phong;

use crate::{AccelHint, Light, LightShape, Object, Scene, SceneError, Shape};

/// Builds a [`Scene`] in code, entity by entity, as a p3f file would: each object takes the material
/// set last. Positions take anything that converts into a [`Vec3A`] and colours anything that
/// converts into a [`Vec3`] (either vector type, or `[f32; 3]`), so values of one kind can be
/// passed where the other is kept.
///
/// ```
/// use raylume_scene::SceneBuilder;
/// use raylume_geometry::{Vec3, Vec3A};
/// use raylume_material::Phong;
/// let scene = SceneBuilder::new()
///     .camera(Vec3A::new(0.0, 2.0, 6.0), Vec3A::ZERO, Vec3A::Y, 40.0, 64, 48)
///     .background(Vec3::new(0.1, 0.2, 0.4))
///     .light(Vec3A::new(4.0, 6.0, 4.0), Vec3::ONE)
///     .material(Phong { diffuse: Vec3::new(0.8, 0.2, 0.2), kd: 0.9, ..Phong::default() })
///     .sphere(Vec3A::ZERO, 1.0)
///     .plane([Vec3A::new(0.0, -1.0, 0.0), Vec3A::new(0.0, -1.0, 1.0), Vec3A::new(1.0, -1.0, 0.0)])
///     .build()
///     .unwrap();
/// assert_eq!(scene.objects.len(), 2);
///
/// // Plain arrays, or a colour vector as a position, convert at the boundary.
/// let same = SceneBuilder::new()
///     .camera([0.0, 2.0, 6.0], Vec3::ZERO, Vec3A::Y, 40.0, 64, 48)
///     .background([0.1, 0.2, 0.4])
///     .light(Vec3::new(4.0, 6.0, 4.0), [1.0; 3])
///     .material(Phong { diffuse: Vec3::new(0.8, 0.2, 0.2), kd: 0.9, ..Phong::default() })
///     .sphere([0.0; 3], 1.0)
///     .plane([Vec3A::new(0.0, -1.0, 0.0), Vec3A::new(0.0, -1.0, 1.0), Vec3A::new(1.0, -1.0, 0.0)])
///     .build()
///     .unwrap();
/// assert_eq!(same, scene);
/// ```
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    view: Option<View>,
    background: Vec3,
    env: Option<String>,
    lights: Vec<Light>,
    materials: Vec<Phong>,
    objects: Vec<Object>,
    accel_hint: Option<AccelHint>,
    spp_hint: Option<u32>,
    shutter: Option<(f32, f32)>,
    error: Option<String>,
}

impl SceneBuilder {
    /// An empty scene.
    pub fn new() -> Self {
        Self::default()
    }

    /// A pinhole camera at `from` looking at `at`, with a vertical field of view in degrees.
    pub fn camera(
        self,
        from: impl Into<Vec3A>,
        at: impl Into<Vec3A>,
        up: impl Into<Vec3A>,
        angle_deg: f32,
        width: u32,
        height: u32,
    ) -> Self {
        let (from, at, up) = (from.into(), at.into(), up.into());
        self.view(View { from, at, up, angle_deg, hither: 0.0, width, height, aperture: 0.0, focal: 1.0 })
    }

    /// The camera, with every field of the p3f `v` entity.
    pub fn view(mut self, view: View) -> Self {
        self.view = Some(view);
        self
    }

    /// The background colour.
    pub fn background(mut self, color: impl Into<Vec3>) -> Self {
        self.background = color.into();
        self
    }

    /// The environment cubemap folder's name.
    pub fn env(mut self, name: impl Into<String>) -> Self {
        self.env = Some(name.into());
        self
    }

    /// A point light.
    pub fn light(mut self, position: impl Into<Vec3A>, color: impl Into<Vec3>) -> Self {
        self.lights.push(Light::point(position.into(), color.into()));
        self
    }

    /// A square area light of side `size` in the world XY plane, centred on `position`.
    pub fn area_light(mut self, position: impl Into<Vec3A>, color: impl Into<Vec3>, size: f32) -> Self {
        let (position, color) = (position.into(), color.into());
        self.lights.push(Light { position, color, shape: LightShape::Square(size) });
        self
    }

    /// A parallelogram area light with a corner at `corner` and edges from it to `ends[0]` and
    /// `ends[1]`.
    pub fn quad_light(mut self, corner: impl Into<Vec3A>, ends: [Vec3A; 2], color: impl Into<Vec3>) -> Self {
        let (position, color) = (corner.into(), color.into());
        self.lights.push(Light { position, color, shape: LightShape::Parallelogram { ends, grid: 0 } });
        self
    }

    /// The camera's shutter interval (motion blur).
    pub fn shutter(mut self, t0: f32, t1: f32) -> Self {
        self.shutter = Some((t0, t1));
        self
    }

    /// A sphere moving from `center0` at `time0` to `center1` at `time1`.
    pub fn moving_sphere(
        self,
        center0: impl Into<Vec3A>,
        center1: impl Into<Vec3A>,
        radius: f32,
        time0: f32,
        time1: f32,
    ) -> Self {
        let (center0, center1) = (center0.into(), center1.into());
        self.shape(Shape::MovingSphere { center0, center1, radius, time0, time1 })
    }

    /// The material of the objects added after it.
    pub fn material(mut self, material: Phong) -> Self {
        self.materials.push(material);
        self
    }

    /// Any shape, with the current material.
    pub fn shape(mut self, shape: Shape) -> Self {
        if self.materials.is_empty() {
            self.error.get_or_insert_with(|| "an object was added before any material".to_owned());
        }
        let material = self.materials.len().saturating_sub(1) as u32;
        self.objects.push(Object { material, shape });
        self
    }

    /// A sphere.
    pub fn sphere(self, center: impl Into<Vec3A>, radius: f32) -> Self {
        self.shape(Shape::Sphere { center: center.into(), radius })
    }

    /// An axis-aligned box.
    pub fn aabox(self, min: impl Into<Vec3A>, max: impl Into<Vec3A>) -> Self {
        self.shape(Shape::Box { min: min.into(), max: max.into() })
    }

    /// A triangle.
    pub fn triangle(self, p0: impl Into<Vec3A>, p1: impl Into<Vec3A>, p2: impl Into<Vec3A>) -> Self {
        self.shape(Shape::Polygon(vec![p0.into(), p1.into(), p2.into()]))
    }

    /// An infinite plane through three points.
    pub fn plane(self, points: [Vec3A; 3]) -> Self {
        self.shape(Shape::Plane(points))
    }

    /// A triangle mesh with 0-based indices.
    pub fn mesh(self, vertices: Vec<Vec3A>, triangles: Vec<[u32; 3]>) -> Self {
        self.shape(Shape::Mesh { vertices, triangles, normals: Vec::new() })
    }

    /// The suggested accelerator.
    pub fn accel_hint(mut self, hint: AccelHint) -> Self {
        self.accel_hint = Some(hint);
        self
    }

    /// The suggested samples per pixel.
    pub fn spp_hint(mut self, spp: u32) -> Self {
        self.spp_hint = Some(spp);
        self
    }

    /// The scene, or an error if it has no camera, an object precedes every material, or it fails
    /// [`Scene::validate`].
    pub fn build(self) -> Result<Scene, SceneError> {
        if let Some(e) = self.error {
            return Err(SceneError::Invalid(e));
        }
        let view = self.view.ok_or_else(|| SceneError::Invalid("the scene has no camera".to_owned()))?;
        let scene = Scene {
            view,
            background: self.background,
            env: self.env,
            lights: self.lights,
            materials: self.materials,
            objects: self.objects,
            accel_hint: self.accel_hint,
            spp_hint: self.spp_hint,
            shutter: self.shutter,
            base_dir: None,
        };
        scene.validate()?;
        Ok(scene)
    }
}
