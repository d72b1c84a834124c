//! Lights: a point, the course's square area light, or a parallelogram, as scene files describe
//! them and the integrator shades with them.

use raylume_geometry::{Vec3, Vec3A};

/// A light: a point, or an area light whose [`LightShape`] starts at `position`.
///
/// ```
/// use raylume_material::{Light, LightShape};
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

    /// The course's square area light: side `size` in the world XY plane, centred on `position`.
    ///
    /// ```
    /// use raylume_material::Light;
    /// use raylume_geometry::{Vec3, Vec3A};
    /// let square = Light::square(Vec3A::new(0.0, 0.0, 5.0), Vec3::ONE, 0.5);
    /// assert_eq!(square.edges(), [Vec3A::new(0.5, 0.0, 0.0), Vec3A::new(0.0, 0.5, 0.0)]);
    /// assert_eq!(square.centre(), Vec3A::new(0.0, 0.0, 5.0));
    /// assert!(square.is_area() && !Light::point(Vec3A::ZERO, Vec3::ONE).is_area());
    /// ```
    pub fn square(position: Vec3A, color: Vec3, size: f32) -> Self {
        Self { position, color, shape: LightShape::Square(size) }
    }

    /// The two edges that span the emitting area (both zero for a point).
    ///
    /// ```
    /// use raylume_material::{Light, LightShape};
    /// use raylume_geometry::{Vec3, Vec3A};
    /// let shape = LightShape::Parallelogram { ends: [Vec3A::new(2.0, 0.0, 0.0), Vec3A::new(0.0, 0.0, 1.0)], grid: 0 };
    /// let quad = Light { position: Vec3A::ZERO, color: Vec3::ONE, shape };
    /// assert_eq!(quad.edges(), [Vec3A::new(2.0, 0.0, 0.0), Vec3A::new(0.0, 0.0, 1.0)]);
    /// assert_eq!(quad.centre(), Vec3A::new(1.0, 0.0, 0.5));
    /// ```
    #[inline]
    pub fn edges(&self) -> [Vec3A; 2] {
        match self.shape {
            LightShape::Point => [Vec3A::ZERO; 2],
            LightShape::Square(size) => [Vec3A::X * size, Vec3A::Y * size],
            LightShape::Parallelogram { ends, .. } => ends.map(|e| e - self.position),
        }
    }

    /// The centre of the emitting area (the position of a point light), where a render without
    /// soft shadows puts the light.
    #[inline]
    pub fn centre(&self) -> Vec3A {
        match self.shape {
            LightShape::Point | LightShape::Square(_) => self.position,
            LightShape::Parallelogram { .. } => {
                let [e0, e1] = self.edges();
                self.position + (e0 + e1) * 0.5
            }
        }
    }

    /// Side of the grid of point lights that stands for the area without antialiasing (0: the
    /// render's light grid).
    #[inline]
    pub fn grid(&self) -> u32 {
        match self.shape {
            LightShape::Parallelogram { grid, .. } => grid,
            LightShape::Point | LightShape::Square(_) => 0,
        }
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
