//! The data of every shape. Each is a plain `Copy` struct; see `raylume-intersect` for the routines.

use glam::Vec3A;

use crate::Aabb;

/// A sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3A,
    /// Radius (positive).
    pub radius: f32,
}

/// A sphere that moves linearly from `center0` at `time0` to `center1` at `time1` (motion blur).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MovingSphere {
    /// Centre at `time0`.
    pub center0: Vec3A,
    /// Centre at `time1`.
    pub center1: Vec3A,
    /// Radius (positive).
    pub radius: f32,
    /// Time of `center0`.
    pub time0: f32,
    /// Time of `center1`.
    pub time1: f32,
}

impl MovingSphere {
    /// The centre at time `t` (extrapolated linearly outside `[time0, time1]`).
    #[inline]
    pub fn center_at(&self, t: f32) -> Vec3A {
        let span = self.time1 - self.time0;
        if span == 0.0 {
            return self.center0;
        }
        self.center0.lerp(self.center1, (t - self.time0) / span)
    }

    /// The sphere at time `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Sphere {
        Sphere { center: self.center_at(t), radius: self.radius }
    }
}

/// A triangle given by its three vertices. Its geometric normal is `(p1 - p0) x (p2 - p0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// The vertices, counter-clockwise seen from the side the normal points to.
    pub p: [Vec3A; 3],
}

impl Triangle {
    /// The triangle `(p0, p1, p2)`.
    #[inline]
    pub fn new(p0: Vec3A, p1: Vec3A, p2: Vec3A) -> Self {
        Self { p: [p0, p1, p2] }
    }

    /// The unnormalised geometric normal (its length is twice the area).
    #[inline]
    pub fn normal(&self) -> Vec3A {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }

    /// The bounds of the three vertices.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(self.p)
    }

    /// The geometric normal `(p1 - p0) x (p2 - p0)` formed in f64, where the differences of f32
    /// vertices are exact and the products neither overflow nor underflow for any f32 triangle.
    #[inline(always)]
    pub fn normal64(&self) -> [f64; 3] {
        let [e1, e2] = self.edges64();
        [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
    }

    /// The edges `p1 - p0` and `p2 - p0` in f64, where the differences of f32 vertices are exact.
    // Written out: array maps in a path the compiler deems cold are left as calls.
    #[inline(always)]
    pub fn edges64(&self) -> [[f64; 3]; 2] {
        let [p0, p1, p2] = self.p;
        let edge = |q: Vec3A| [q.x as f64 - p0.x as f64, q.y as f64 - p0.y as f64, q.z as f64 - p0.z as f64];
        [edge(p1), edge(p2)]
    }

    /// Whether the triangle spans a plane: its [`Triangle::normal64`] is neither zero nor infinite
    /// (nor NaN). A triangle whose vertices are collinear in f32 has no plane, and ray tests never
    /// hit it; huge and tiny triangles (legs from 2^-60 to 2^60) have one.
    ///
    /// ```
    /// use raylume_geometry::{Triangle, Vec3A};
    /// assert!(Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y).has_plane());
    /// assert!(Triangle::new(Vec3A::ZERO, Vec3A::X * 1e-30, Vec3A::Y * 1e-30).has_plane());
    /// assert!(!Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0).has_plane());
    /// ```
    #[inline(always)]
    pub fn has_plane(&self) -> bool {
        is_plane_normal(self.normal64())
    }
}

/// Whether an f64 normal is a plane's: not zero, and finite.
#[inline(always)]
pub fn is_plane_normal(n: [f64; 3]) -> bool {
    let square = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    square > 0.0 && square.is_finite()
}

/// An infinite plane `{x : normal . (x - point) = 0}`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane.
    pub point: Vec3A,
    /// The unit normal.
    pub normal: Vec3A,
}

impl Plane {
    /// The plane through three points; normal `(p1 - p0) x (p2 - p0)`, normalised.
    /// `None` if the points are collinear.
    pub fn from_points(p0: Vec3A, p1: Vec3A, p2: Vec3A) -> Option<Self> {
        let n = (p1 - p0).cross(p2 - p0);
        let len = n.length();
        (len > 0.0 && len.is_finite()).then(|| Self { point: p0, normal: n / len })
    }
}

/// An axis-aligned box as a solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AaBox {
    /// The extent of the box.
    pub bounds: Aabb,
}

/// A truncated cone (or cylinder when the radii are equal), open at both ends, as in NFF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Centre of the base cap.
    pub base: Vec3A,
    /// Radius at the base.
    pub base_radius: f32,
    /// Centre of the apex cap.
    pub apex: Vec3A,
    /// Radius at the apex.
    pub apex_radius: f32,
}

impl Cone {
    /// Bounds: the boxes around both end discs.
    pub fn bounds(&self) -> Aabb {
        let axis = (self.apex - self.base).normalize_or_zero();
        // Extent of a disc of radius r with normal `axis` along each world axis: r * sqrt(1 - a_i^2).
        let e = (Vec3A::ONE - axis * axis).max(Vec3A::ZERO).powf(0.5);
        let b = Aabb::new(self.base - e * self.base_radius, self.base + e * self.base_radius);
        b.union(Aabb::new(self.apex - e * self.apex_radius, self.apex + e * self.apex_radius))
    }
}
