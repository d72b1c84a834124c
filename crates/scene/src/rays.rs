//! Ray sets for measuring accelerators: coherent camera rays and incoherent random rays, and a binary
//! format so exactly the same rays (and their hits) can be traced and compared by another engine.
//!
//! Ray file: little-endian `u32 count`, then `count` records of six `f32` (origin x y z, direction
//! x y z; directions normalised; valid t from 0 to infinity). Hit file: per ray `f32 t` (infinity on
//! a miss) and `u32` primitive index (`u32::MAX` on a miss).
//!
//! ```
//! use raylume_scene::rays::{random_rays, read_rays, write_rays};
//! use raylume_geometry::{Aabb, Vec3A};
//! let rays = random_rays(&Aabb::new(Vec3A::ZERO, Vec3A::ONE), 10, 1);
//! let mut bytes = Vec::new();
//! write_rays(&mut bytes, &rays).unwrap();
//! assert_eq!(bytes.len(), 4 + 10 * 24);
//! assert_eq!(read_rays(&mut bytes.as_slice()).unwrap(), rays);
//! ```

use std::io::{Read, Write};

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume_camera::{Camera, CameraSample, Pinhole, View};
use raylume_geometry::{Aabb, Ray, Vec2, Vec3A, sampling::uniform_sphere};

/// Rays through the pixel centres of a `side x side` pinhole view, `side = round(sqrt(count))`,
/// with the view's camera (its resolution replaced).
pub fn camera_rays(view: &View, count: usize) -> Vec<Ray> {
    let side = ((count as f64).sqrt().round() as u32).max(1);
    let camera = Pinhole::new(&View { width: side, height: side, ..*view });
    let mut rays = Vec::with_capacity((side * side) as usize);
    for y in (0..side).rev() {
        for x in 0..side {
            rays.push(camera.generate_ray(&CameraSample::at_film(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))));
        }
    }
    rays
}

/// The rays of a row-major `side x side` view (as [`camera_rays`] makes them) reordered tile by tile:
/// `tile x tile` pixels, the tiles row-major, short tiles along the right and bottom edges where
/// `tile` does not divide `side`. The order in which a renderer hands the batch queries
/// (`raylume_accel::Accelerator::closest_hits`) runs of neighbouring rays.
///
/// ```
/// use raylume_geometry::{Ray, Vec3A};
/// use raylume_scene::rays::in_tiles;
/// let rays: Vec<Ray> = (0..9).map(|i| Ray::new(Vec3A::ZERO, Vec3A::new(i as f32, 0.0, 1.0))).collect();
/// let order: Vec<f32> = in_tiles(&rays, 3, 2).iter().map(|r| r.dir.x).collect();
/// assert_eq!(order, [0.0, 1.0, 3.0, 4.0, 2.0, 5.0, 6.0, 7.0, 8.0]);
/// ```
///
/// # Panics
/// If `rays` does not hold `side * side` rays, or `tile` is 0.
pub fn in_tiles(rays: &[Ray], side: usize, tile: usize) -> Vec<Ray> {
    assert_eq!(rays.len(), side * side, "a square view");
    assert!(tile > 0, "tiles of at least one pixel");
    let mut out = Vec::with_capacity(rays.len());
    for ty in (0..side).step_by(tile) {
        for tx in (0..side).step_by(tile) {
            for y in ty..(ty + tile).min(side) {
                out.extend_from_slice(&rays[y * side + tx..y * side + (tx + tile).min(side)]);
            }
        }
    }
    out
}

/// Incoherent rays: origins uniform on the sphere of 1.5 times the bounding radius of `bounds`,
/// aimed at uniform random points in `bounds`; the same for the same seed.
pub fn random_rays(bounds: &Aabb, count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 0x5851_f42d_4c95_7f2d);
    let mut u = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
    let centre = bounds.centroid();
    let radius = (bounds.diagonal().length() * 0.5).max(f32::MIN_POSITIVE) * 1.5;
    (0..count)
        .map(|_| {
            let (a, b) = (u(), u());
            let origin = centre + uniform_sphere(Vec2::new(a, b)) * radius;
            let target = bounds.min + bounds.diagonal() * Vec3A::new(u(), u(), u());
            let dir = (target - origin).normalize_or(Vec3A::Z);
            Ray::new(origin, dir)
        })
        .collect()
}

/// Writes a ray set.
pub fn write_rays(out: &mut impl Write, rays: &[Ray]) -> std::io::Result<()> {
    let count = u32::try_from(rays.len()).map_err(|_| std::io::Error::other("more than 2^32 rays"))?;
    out.write_all(&count.to_le_bytes())?;
    for r in rays {
        for v in [r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z] {
            out.write_all(&v.to_le_bytes())?;
        }
    }
    Ok(())
}

/// Reads a ray set; the count must match the data that follows.
pub fn read_rays(input: &mut impl Read) -> std::io::Result<Vec<Ray>> {
    let mut word = [0u8; 4];
    input.read_exact(&mut word)?;
    let count = u32::from_le_bytes(word) as usize;
    let mut data = Vec::new();
    input.read_to_end(&mut data)?;
    if data.len() != count * 24 {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("the header says {count} rays ({} bytes) but {} bytes follow", count * 24, data.len()),
        ));
    }
    let f = |b: &[u8]| f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    data.chunks_exact(24)
        .enumerate()
        .map(|(i, c)| {
            let o = Vec3A::new(f(&c[0..4]), f(&c[4..8]), f(&c[8..12]));
            let d = Vec3A::new(f(&c[12..16]), f(&c[16..20]), f(&c[20..24]));
            if !o.is_finite() || !d.is_finite() || d.length_squared() == 0.0 {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!("ray {i} is not finite or has no direction"),
                ));
            }
            Ok(Ray::new(o, d))
        })
        .collect()
}

/// Writes per-ray hits: `t` (infinity on a miss) and the primitive index (`u32::MAX` on a miss).
pub fn write_hits(out: &mut impl Write, hits: &[Option<(f32, u32)>]) -> std::io::Result<()> {
    for h in hits {
        let (t, prim) = h.unwrap_or((f32::INFINITY, u32::MAX));
        out.write_all(&t.to_le_bytes())?;
        out.write_all(&prim.to_le_bytes())?;
    }
    Ok(())
}
