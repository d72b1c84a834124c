//! Procedural scenes: the classic Standard Procedural Databases scenes (Haines, 1987), written here
//! from their published descriptions, each with a size parameter, and a framing scene for a mesh.
//!
//! ```
//! use raylume_scene::procedural::{Generator, sphereflake};
//! // Depth 1 is the course's balls_low: a sphere and 9 children.
//! assert_eq!(sphereflake(1).unwrap().primitive_count(), 1 + 1 + 9);
//! assert_eq!(Generator::Tetra.generate(2).unwrap().primitive_count(), 4 * 4 * 4);
//! ```

use std::str::FromStr;

use raylume_camera::View;
use raylume_geometry::{Aabb, Vec3, Vec3A, orthonormal_basis};
use raylume_material::Phong;

use crate::{Light, Object, Scene, SceneError, Shape};

/// The procedural scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Generator {
    /// The sphereflake: a sphere with nine children a third its size, recursively (SPD `balls`).
    Balls,
    /// A Sierpinski tetrahedron of triangles (SPD `tetra`).
    Tetra,
    /// A fractal mountain by midpoint displacement, with four glass spheres (SPD `mount`).
    Mount,
    /// Rings of spheres linked by cylinders, in a pentagonal pattern (SPD `rings`).
    Rings,
}

impl FromStr for Generator {
    type Err = SceneError;
    fn from_str(s: &str) -> Result<Self, SceneError> {
        match s {
            "balls" => Ok(Self::Balls),
            "tetra" => Ok(Self::Tetra),
            "mount" => Ok(Self::Mount),
            "rings" => Ok(Self::Rings),
            _ => Err(SceneError::Invalid(format!("unknown generator '{s}' (expected balls, tetra, mount or rings)"))),
        }
    }
}

impl Generator {
    /// The scene of the given size (a recursion depth, or the number of rings).
    pub fn generate(self, size: u32) -> Result<Scene, SceneError> {
        match self {
            Self::Balls => sphereflake(size),
            Self::Tetra => tetra(size),
            Self::Mount => mount(size),
            Self::Rings => rings(size),
        }
    }

    /// The number of primitives the scene of this size has.
    pub fn primitives(self, size: u32) -> u64 {
        // Saturating, so that a size too large for the count still counts as too large.
        let s = size as u64;
        match self {
            Self::Balls => (9u64.saturating_pow(size.saturating_add(1)) - 1) / 8 + 1,
            Self::Tetra => 4u64.saturating_pow(size.saturating_add(1)),
            Self::Mount => 4u64.saturating_pow(size).saturating_mul(2).saturating_add(4),
            Self::Rings => s * 2 * RING_SEGMENTS as u64 + 1,
        }
    }
}

/// Largest scene a generator makes, in primitives.
pub const MAX_PRIMITIVES: u64 = 20_000_000;

fn check(generator: Generator, size: u32, min: u32) -> Result<(), SceneError> {
    let n = generator.primitives(size);
    if size < min || n > MAX_PRIMITIVES {
        return Err(SceneError::Invalid(format!(
            "{generator:?} of size {size} ({n} primitives): expected a size from {min} up to {MAX_PRIMITIVES} primitives"
        )));
    }
    Ok(())
}

fn view(from: Vec3A, at: Vec3A, up: Vec3A, angle_deg: f32) -> View {
    View { from, at, up, angle_deg, hither: 0.01, width: 512, height: 512, aperture: 0.0, focal: 1.0 }
}

fn material(diffuse: [f32; 3], kd: f32, ks: f32, shine: f32, transmittance: f32, ior: f32) -> Phong {
    Phong { diffuse: Vec3::from(diffuse), kd, specular: Vec3::ONE, ks, shine, transmittance, ior, ..Phong::default() }
}

fn light(x: f32, y: f32, z: f32) -> Light {
    Light::point(Vec3A::new(x, y, z), Vec3::ONE)
}

/// The sphereflake of the given depth (depth 1: the course's balls_low, 10 spheres; 4: balls_high,
/// 7381), on a floor plane, with the course's camera, lights and materials.
pub fn sphereflake(depth: u32) -> Result<Scene, SceneError> {
    check(Generator::Balls, depth, 0)?;
    let mut spheres = Vec::with_capacity(Generator::Balls.primitives(depth) as usize);
    fn grow(spheres: &mut Vec<Shape>, center: Vec3A, radius: f32, up: Vec3A, depth: u32) {
        spheres.push(Shape::Sphere { center, radius });
        if depth == 0 {
            return;
        }
        let (s, t) = orthonormal_basis(up);
        let child = radius / 3.0;
        let elevation = (2.0f32 / 3.0).sqrt().asin();
        // Six around the equator at 15 + 60k degrees, three above at 45 + 120k degrees.
        let directions = (0..6)
            .map(|k| ((15.0 + 60.0 * k as f32).to_radians(), 0.0))
            .chain((0..3).map(|k| ((45.0 + 120.0 * k as f32).to_radians(), elevation)));
        for (phi, theta) in directions {
            let dir = (s * phi.cos() + t * phi.sin()) * theta.cos() + up * theta.sin();
            grow(spheres, center + dir * (radius + child), child, dir, depth - 1);
        }
    }
    grow(&mut spheres, Vec3A::ZERO, 0.5, Vec3A::Z, depth);
    let mut objects = vec![Object {
        material: 0,
        shape: Shape::Plane([
            Vec3A::new(12.0, 12.0, -0.5),
            Vec3A::new(-12.0, 12.0, -0.5),
            Vec3A::new(-12.0, -12.0, -0.5),
        ]),
    }];
    objects.extend(spheres.into_iter().map(|shape| Object { material: 1, shape }));
    Ok(Scene {
        view: view(Vec3A::new(2.1, 1.3, 1.7), Vec3A::ZERO, Vec3A::Z, 45.0),
        background: Vec3::new(0.078, 0.361, 0.753),
        env: None,
        lights: vec![light(4.0, 3.0, 2.0), light(1.0, -4.0, 4.0), light(-3.0, 1.0, 5.0)],
        materials: vec![
            material([1.0, 0.75, 0.33], 1.0, 0.8, 10.0, 0.0, 1.0),
            material([1.0, 0.9, 0.7], 0.5, 0.5, 30.0827, 0.0, 1.0),
        ],
        objects,
        accel_hint: None,
        spp_hint: None,
        base_dir: None,
        shutter: None,
    })
}

/// The Sierpinski tetrahedron of the given depth: `4^(depth+1)` triangles.
pub fn tetra(depth: u32) -> Result<Scene, SceneError> {
    check(Generator::Tetra, depth, 0)?;
    let corners = [
        Vec3A::new(1.0, 1.0, 1.0),
        Vec3A::new(-1.0, -1.0, 1.0),
        Vec3A::new(-1.0, 1.0, -1.0),
        Vec3A::new(1.0, -1.0, -1.0),
    ];
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    fn split(c: [Vec3A; 4], depth: u32, vertices: &mut Vec<Vec3A>, triangles: &mut Vec<[u32; 3]>) {
        if depth == 0 {
            let base = vertices.len() as u32;
            vertices.extend(c);
            // Faces wound outwards.
            triangles.extend([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]].map(|t| t.map(|i| base + i)));
            return;
        }
        for k in 0..4 {
            let sub = c.map(|v| (v + c[k]) * 0.5);
            split(sub, depth - 1, vertices, triangles);
        }
    }
    split(corners, depth, &mut vertices, &mut triangles);
    Ok(Scene {
        view: view(Vec3A::new(1.8, 4.0, 2.6), Vec3A::ZERO, Vec3A::Z, 45.0),
        background: Vec3::new(0.078, 0.361, 0.753),
        env: None,
        lights: vec![light(4.0, 3.0, 5.0), light(-3.0, 5.0, 2.0)],
        materials: vec![material([1.0, 0.2, 0.2], 0.9, 0.1, 20.0, 0.0, 1.0)],
        objects: vec![Object { material: 0, shape: Shape::Mesh { vertices, triangles, normals: Vec::new() } }],
        accel_hint: None,
        spp_hint: None,
        base_dir: None,
        shutter: None,
    })
}

/// A uniform number in [-1, 1] from a point: displacements of shared edge midpoints agree, so the
/// surface has no cracks.
fn hash_unit(p: Vec3A, q: Vec3A) -> f32 {
    let key = |v: Vec3A| (v.x.to_bits() as u64) ^ ((v.y.to_bits() as u64) << 21) ^ ((v.z.to_bits() as u64) << 42);
    let (a, b) = if (p.x, p.y) <= (q.x, q.y) { (key(p), key(q)) } else { (key(q), key(p)) };
    let mut z = a.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ b.rotate_left(17);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

/// The fractal mountain of the given depth (`2 * 4^depth` triangles; 1: the course's mount_low, 5:
/// mount_high, 7: mount_very_high), with its four glass spheres.
pub fn mount(depth: u32) -> Result<Scene, SceneError> {
    check(Generator::Mount, depth, 0)?;
    let base = [
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(1.0, 1.0, 0.0),
        Vec3A::new(-1.0, 1.0, 0.0),
    ];
    let mut tris: Vec<[Vec3A; 3]> = vec![[base[0], base[1], base[2]], [base[0], base[2], base[3]]];
    for _ in 0..depth {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let mid = |p: Vec3A, q: Vec3A| {
                let len = (q - p).truncate().length();
                let m = (p + q) * 0.5;
                m + Vec3A::Z * (0.45 * len * hash_unit(p, q))
            };
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
    }
    let mut objects: Vec<Object> = [
        (Vec3A::new(-0.8, 0.8, 1.20821), 0.17),
        (Vec3A::new(-0.661196, 0.661196, 0.930598), 0.169),
        (Vec3A::new(-0.749194, 0.98961, 0.930598), 0.168),
        (Vec3A::new(-0.98961, 0.749194, 0.930598), 0.167),
    ]
    .into_iter()
    .map(|(center, radius)| Object { material: 0, shape: Shape::Sphere { center, radius } })
    .collect();
    let mut vertices = Vec::with_capacity(tris.len() * 3);
    let mut triangles = Vec::with_capacity(tris.len());
    for t in tris {
        let i = vertices.len() as u32;
        vertices.extend(t);
        triangles.push([i, i + 1, i + 2]);
    }
    objects.push(Object { material: 1, shape: Shape::Mesh { vertices, triangles, normals: Vec::new() } });
    Ok(Scene {
        view: view(Vec3A::new(-1.6, 1.6, 1.7), Vec3A::ZERO, Vec3A::Z, 45.0),
        background: Vec3::new(0.078, 0.361, 0.753),
        env: None,
        lights: vec![light(-100.0, -100.0, 100.0)],
        materials: vec![
            material([1.0, 1.0, 1.0], 0.1, 0.1, 101.148, 1.0, 1.6),
            material([0.5, 0.45, 0.35], 1.0, 0.0, 1000.0, 0.0, 0.0),
        ],
        objects,
        accel_hint: None,
        spp_hint: None,
        base_dir: None,
        shutter: None,
    })
}

/// Spheres per ring (each linked to the next by a cylinder).
const RING_SEGMENTS: u32 = 16;

/// `count` rings of spheres linked by cylinders, laid out in a pentagonal spiral that rises, over a
/// floor: `32 count + 1` primitives.
pub fn rings(count: u32) -> Result<Scene, SceneError> {
    check(Generator::Rings, count, 1)?;
    let mut objects = vec![Object {
        material: 0,
        shape: Shape::Plane([Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(0.0, 1.0, 0.0)]),
    }];
    let (ring_radius, sphere_radius, rod_radius) = (1.0f32, 0.2f32, 0.08f32);
    for i in 0..count {
        // Five rings per turn of the spiral; each turn is wider and higher than the last.
        let turn = (i / 5) as f32;
        let angle = (i % 5) as f32 * std::f32::consts::TAU / 5.0 + turn * 0.3;
        let centre = Vec3A::new(angle.cos(), angle.sin(), 0.0) * (2.5 + 2.2 * turn) + Vec3A::Z * (1.2 + 0.6 * turn);
        // Each ring stands facing the spiral's centre.
        let radial = Vec3A::new(angle.cos(), angle.sin(), 0.0);
        let tangent = Vec3A::Z.cross(radial);
        let material = 1 + i % 3;
        let point = |k: u32| {
            let a = k as f32 * std::f32::consts::TAU / RING_SEGMENTS as f32;
            centre + (tangent * a.cos() + Vec3A::Z * a.sin()) * ring_radius
        };
        for k in 0..RING_SEGMENTS {
            let (p, q) = (point(k), point(k + 1));
            objects.push(Object { material, shape: Shape::Sphere { center: p, radius: sphere_radius } });
            objects.push(Object {
                material,
                shape: Shape::Cone { base: p, base_radius: rod_radius, apex: q, apex_radius: rod_radius },
            });
        }
    }
    let extent = 2.5 + 2.2 * (count.saturating_sub(1) / 5) as f32 + 2.0;
    Ok(Scene {
        view: view(Vec3A::new(1.2, -1.6, 1.1) * extent * 1.6, Vec3A::new(0.0, 0.0, 1.0), Vec3A::Z, 45.0),
        background: Vec3::new(0.078, 0.361, 0.753),
        env: None,
        lights: vec![light(extent * 2.0, -extent, extent * 3.0), light(-extent * 2.0, -extent * 2.0, extent * 2.0)],
        materials: vec![
            material([0.8, 0.8, 0.8], 0.8, 0.2, 10.0, 0.0, 1.0),
            material([0.9, 0.3, 0.2], 0.8, 0.5, 40.0, 0.0, 1.0),
            material([0.2, 0.8, 0.3], 0.8, 0.5, 40.0, 0.0, 1.0),
            material([0.3, 0.4, 0.9], 0.8, 0.5, 40.0, 0.0, 1.0),
        ],
        objects,
        accel_hint: None,
        spp_hint: None,
        base_dir: None,
        shutter: None,
    })
}

/// The direction from a mesh's centre to the camera that frames it: from the front, above and to the
/// right, or, for a flat mesh that this direction would see nearly edge-on, mostly along its normal.
fn view_direction(mesh: &Shape) -> Vec3A {
    let standard = Vec3A::new(0.35, 0.3, 1.0).normalize();
    let Shape::Mesh { vertices, triangles, .. } = mesh else { return standard };
    let area_normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| vertices[i as usize].as_dvec3());
        (b - a).cross(c - a)
    };
    // Triangles' area-weighted normals, each turned to the side of the largest one's: their sum is as
    // long as their areas' sum only if the mesh is flat.
    let Some(largest) =
        triangles.iter().map(area_normal).max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
    else {
        return standard;
    };
    let (mut sum, mut area) = (glam::DVec3::ZERO, 0.0);
    for t in triangles {
        let n = area_normal(t);
        sum += if n.dot(largest) < 0.0 { -n } else { n };
        area += n.length();
    }
    let flat = area > 0.0 && sum.length() >= 0.98 * area;
    let normal = sum.normalize_or_zero().as_vec3a();
    if !flat || normal.dot(standard).abs() >= 0.5 {
        return standard;
    }
    // Along the normal, on the standard direction's side, tilted towards it.
    let normal = if normal.dot(standard) < 0.0 { -normal } else { normal };
    (normal + (standard - normal * normal.dot(standard)) * 0.4).normalize()
}

/// A scene that frames `mesh` (a [`Shape::Mesh`]): a pinhole camera whose view holds the mesh's
/// bounding sphere, a light beside the camera and a grey material. A flat mesh is seen mostly from
/// its front.
pub fn mesh_view(mesh: Shape, width: u32, height: u32) -> Scene {
    const SMALLEST_FRAMED: f32 = 1e-16;
    let bounds = match &mesh {
        Shape::Mesh { vertices, .. } => Aabb::from_points(vertices.iter().copied()),
        _ => Aabb::from_point(Vec3A::ZERO),
    };
    let centre = bounds.centroid();
    // A mesh of no extent (or one so small that squared distances across it fall below single
    // precision's normal numbers) is framed as one of this size.
    let radius = (bounds.diagonal().length() * 0.5).max(SMALLEST_FRAMED);
    let angle_deg = 40.0f32;
    let distance = radius / (angle_deg.to_radians() * 0.5).sin();
    let dir = view_direction(&mesh);
    let from = centre + dir * distance;
    Scene {
        view: View { from, at: centre, up: Vec3A::Y, angle_deg, hither: 0.0, width, height, aperture: 0.0, focal: 1.0 },
        background: Vec3::new(0.2, 0.25, 0.3),
        env: None,
        lights: vec![Light::point(from + Vec3A::new(radius, radius * 2.0, 0.0), Vec3::ONE)],
        materials: vec![material([0.8, 0.8, 0.8], 0.9, 0.2, 30.0, 0.0, 1.0)],
        objects: vec![Object { material: 0, shape: mesh }],
        accel_hint: None,
        spp_hint: None,
        base_dir: None,
        shutter: None,
    }
}

/// A closed icosphere of unit radius: the icosahedron's faces split `level` times, every new vertex
/// pushed onto the sphere. Vertices are shared (each computed once, in f32), so the mesh is closed:
/// `10·4^level + 2` vertices and `20·4^level` triangles. The standard mesh for watertightness tests.
///
/// ```
/// let (v, f) = raylume_scene::procedural::icosphere(3);
/// assert_eq!((v.len(), f.len()), (642, 1280));
/// ```
pub fn icosphere(level: u32) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3A> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3A::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    v.push(((v[i as usize] + v[j as usize]) * 0.5).normalize());
                    (v.len() - 1) as u32
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}
