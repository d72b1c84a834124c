//! Cameras for raylume: the course's [`Pinhole`] camera, the [`ThinLens`] camera (depth of field) and
//! the [`MotionBlur`] wrapper (a shutter interval), behind the [`Camera`] trait, built from a [`View`].
//!
//! ```
//! use raylume_camera::{Camera, CameraSample, Pinhole, View};
//! use raylume_geometry::{Vec2, Vec3A};
//! let view = View {
//!     from: Vec3A::new(0.0, 0.0, 5.0), at: Vec3A::ZERO, up: Vec3A::Y,
//!     angle_deg: 45.0, hither: 0.01, width: 64, height: 64, aperture: 0.0, focal: 1.0,
//! };
//! let cam = Pinhole::new(&view);
//! // The centre of the image looks straight at `at`.
//! let ray = cam.generate_ray(&CameraSample::at_film(Vec2::new(32.0, 32.0)));
//! assert!((ray.dir - Vec3A::new(0.0, 0.0, -1.0)).length() < 1e-6);
//! ```

use raylume_geometry::{Interval, Ray, Vec2, Vec3A, sampling::concentric_disk};

/// What a camera needs to make one ray: a film position, a lens position and a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSample {
    /// Position on the film in pixels: x from the left, y from the bottom row; the centre of
    /// pixel `(i, j)` is `(i + 0.5, j + 0.5)`.
    pub film: Vec2,
    /// Position on the lens in `[0, 1)^2` (ignored by a pinhole).
    pub lens: Vec2,
    /// Fraction of the shutter interval in `[0, 1)`.
    pub time: f32,
}

impl CameraSample {
    /// A sample at a film position, the lens centre and the shutter's opening.
    #[inline]
    pub fn at_film(film: Vec2) -> Self {
        Self { film, lens: Vec2::splat(0.5), time: 0.0 }
    }
}

/// Makes camera rays.
///
/// The associated constants tell the render loop which sample dimensions the camera reads, so a
/// camera without a lens or a shutter costs nothing for them: the loop does not even draw them.
pub trait Camera: Sync + Send {
    /// Whether [`CameraSample::lens`] is read (thin lens).
    const USES_LENS: bool = false;
    /// Whether [`CameraSample::time`] is read (motion blur).
    const USES_TIME: bool = false;

    /// The ray for a sample.
    fn generate_ray(&self, sample: &CameraSample) -> Ray;

    /// The image size in pixels, `(width, height)`.
    fn resolution(&self) -> (u32, u32);

    /// The smallest ray parameter of camera rays (the near plane).
    fn t_min(&self) -> f32 {
        0.0
    }
}

/// The p3f `v` entity: where the camera is, where it looks, and its lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Eye position.
    pub from: Vec3A,
    /// The point looked at.
    pub at: Vec3A,
    /// The up direction.
    pub up: Vec3A,
    /// Vertical field of view in degrees.
    pub angle_deg: f32,
    /// Near distance: camera rays start there.
    pub hither: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Lens radius as a multiple of the pixel size on the view plane (0 = pinhole): the thin lens's
    /// radius is `aperture * w / W` (p3f's camera formula; its tag table calls the number a
    /// diameter, the formula uses it as the radius).
    pub aperture: f32,
    /// Focal distance as a ratio of the view-plane distance `|from - at|`.
    pub focal: f32,
}

/// The camera's frame and view plane, as the course defines them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Frame {
    from: Vec3A,
    u: Vec3A,
    v: Vec3A,
    n: Vec3A,
    /// View-plane distance.
    d: f32,
    /// View-plane width and height.
    w: f32,
    h: f32,
    res: Vec2,
    hither: f32,
}

impl Frame {
    fn new(view: &View) -> Self {
        let n = (view.from - view.at).normalize();
        let d = (view.from - view.at).length();
        let u = view.up.cross(n).normalize();
        let v = n.cross(u);
        let h = 2.0 * d * (view.angle_deg.to_radians() * 0.5).tan();
        let w = view.width as f32 / view.height as f32 * h;
        Self {
            from: view.from,
            u,
            v,
            n,
            d,
            w,
            h,
            res: Vec2::new(view.width as f32, view.height as f32),
            hither: view.hither,
        }
    }

    /// The unnormalised direction from the eye through a film position.
    #[inline]
    fn direction(&self, film: Vec2) -> Vec3A {
        let s = film / self.res - Vec2::splat(0.5);
        self.u * (self.w * s.x) + self.v * (self.h * s.y) - self.n * self.d
    }
}

/// The course's pinhole camera. Its rays sample one instant (time 0 unless set with
/// [`Pinhole::at_time`]); wrap it in [`MotionBlur`] to sample a shutter interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pinhole {
    frame: Frame,
    time: f32,
}

impl Pinhole {
    /// A pinhole camera for `view`, at time 0.
    pub fn new(view: &View) -> Self {
        Self { frame: Frame::new(view), time: 0.0 }
    }

    /// The same camera at another instant.
    pub fn at_time(mut self, time: f32) -> Self {
        self.time = time;
        self
    }
}

impl Camera for Pinhole {
    #[inline]
    fn generate_ray(&self, sample: &CameraSample) -> Ray {
        Ray::with_time(self.frame.from, self.frame.direction(sample.film).normalize(), self.time)
    }

    fn resolution(&self) -> (u32, u32) {
        (self.frame.res.x as u32, self.frame.res.y as u32)
    }

    fn t_min(&self) -> f32 {
        self.frame.hither
    }
}

/// A thin-lens camera: rays leave a disk of the lens's diameter and converge on the focal plane, so
/// points there are sharp and others blur.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    frame: Frame,
    lens_radius: f32,
    focal_distance: f32,
    time: f32,
}

impl ThinLens {
    /// A thin-lens camera for `view`: lens radius `aperture * w / W`, focal plane at `focal * d`
    /// (the course's convention).
    pub fn new(view: &View) -> Self {
        let frame = Frame::new(view);
        Self {
            lens_radius: view.aperture * frame.w / view.width as f32,
            focal_distance: view.focal * frame.d,
            frame,
            time: 0.0,
        }
    }

    /// The same camera at another instant.
    pub fn at_time(mut self, time: f32) -> Self {
        self.time = time;
        self
    }

    /// The lens radius in world units.
    pub fn lens_radius(&self) -> f32 {
        self.lens_radius
    }

    /// The distance from the eye to the plane in focus.
    pub fn focal_distance(&self) -> f32 {
        self.focal_distance
    }
}

impl Camera for ThinLens {
    const USES_LENS: bool = true;

    #[inline]
    fn generate_ray(&self, sample: &CameraSample) -> Ray {
        let f = &self.frame;
        let centre = f.direction(sample.film).normalize();
        // Where the centre ray meets the focal plane (perpendicular to n at focal_distance).
        let focus = f.from + centre * (self.focal_distance / centre.dot(-f.n));
        let l = concentric_disk(sample.lens) * self.lens_radius;
        let origin = f.from + f.u * l.x + f.v * l.y;
        Ray::with_time(origin, (focus - origin).normalize(), self.time)
    }

    fn resolution(&self) -> (u32, u32) {
        (self.frame.res.x as u32, self.frame.res.y as u32)
    }

    fn t_min(&self) -> f32 {
        self.frame.hither
    }
}

/// Motion blur: wraps a camera so each ray samples an instant of the shutter interval,
/// `t0 + time * (t1 - t0)` for the sample's `time` in `[0, 1)`.
///
/// ```
/// use raylume_camera::{Camera, CameraSample, MotionBlur, Pinhole, View};
/// use raylume_geometry::{Interval, Vec2, Vec3A};
/// let view = View { from: Vec3A::Z, at: Vec3A::ZERO, up: Vec3A::Y, angle_deg: 45.0, hither: 0.0,
///     width: 8, height: 8, aperture: 0.0, focal: 1.0 };
/// let cam = MotionBlur::new(Pinhole::new(&view), Interval::new(1.0, 3.0));
/// let sample = CameraSample { film: Vec2::splat(4.0), lens: Vec2::ZERO, time: 0.25 };
/// assert_eq!(cam.generate_ray(&sample).time, 1.5);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionBlur<C> {
    camera: C,
    shutter: Interval,
}

impl<C: Camera> MotionBlur<C> {
    /// `camera` with its shutter open over `shutter`.
    pub fn new(camera: C, shutter: Interval) -> Self {
        Self { camera, shutter }
    }
}

impl<C: Camera> Camera for MotionBlur<C> {
    const USES_LENS: bool = C::USES_LENS;
    const USES_TIME: bool = true;

    #[inline]
    fn generate_ray(&self, sample: &CameraSample) -> Ray {
        let mut ray = self.camera.generate_ray(sample);
        ray.time = self.shutter.min + sample.time * (self.shutter.max - self.shutter.min);
        ray
    }

    fn resolution(&self) -> (u32, u32) {
        self.camera.resolution()
    }

    fn t_min(&self) -> f32 {
        self.camera.t_min()
    }
}
