//! What both comparison benches share: obvhs's structure over a workload's triangles, and the
//! conversions of triangles and rays to its types.

// Each bench uses part of it.
#![allow(dead_code)]

use std::time::Duration;

use glam::Vec3A;
use obvhs::cwbvh::{CwBvh, builder::build_cwbvh_from_tris};
use obvhs::ray::{Ray as ORay, RayHit};
use obvhs::rt_triangle::RtTriangle;
use obvhs::{BvhBuildParams, triangle::Triangle as OTriangle};
use raylume_geometry::{Ray, Triangle};

/// obvhs's structure with its triangles laid out in leaf order (its fastest documented layout).
pub struct Obvhs {
    bvh: CwBvh,
    tris: Vec<RtTriangle>,
}

impl Obvhs {
    pub fn build(tris: &[OTriangle]) -> Self {
        let bvh = build_cwbvh_from_tris(tris, BvhBuildParams::medium_build(), &mut Duration::default());
        let tris = bvh.primitive_indices.iter().map(|&i| RtTriangle::from(&tris[i as usize])).collect();
        Self { bvh, tris }
    }

    pub fn closest(&self, ray: &ORay) -> Option<(f32, u32)> {
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(*ray, &mut hit, |r, id| self.tris[id].intersect(r))
            .then(|| (hit.t, self.bvh.primitive_indices[hit.primitive_id as usize]))
    }

    pub fn occluded(&self, ray: &ORay) -> bool {
        !self.bvh.ray_traverse_miss(*ray, |r, id| self.tris[id].intersect(r))
    }

    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.bvh.nodes.as_slice())
            + std::mem::size_of_val(self.bvh.primitive_indices.as_slice())
            + std::mem::size_of_val(self.tris.as_slice())
    }
}

pub fn to_obvhs(r: &Ray) -> ORay {
    ORay::new_inf(Vec3A::from(r.origin.to_array()), Vec3A::from(r.dir.to_array()))
}

/// The triangles as obvhs takes them.
pub fn to_obvhs_triangles(tris: &[Triangle]) -> Vec<OTriangle> {
    tris.iter()
        .map(|t| {
            let [v0, v1, v2] = t.p.map(|p| Vec3A::from(p.to_array()));
            OTriangle { v0, v1, v2 }
        })
        .collect()
}

/// Embree 3's scene over the same triangles, made as an Embree user makes it: medium build quality
/// (`RTC_BUILD_QUALITY_MEDIUM`, Embree's default, set explicitly), no scene flags unless asked for
/// the robust one, one build thread. Each query takes raylume's `Ray` and makes Embree's ray from it
/// the way a caller of `rtcIntersect1` does, per call: an `RTCRayHit` (`tnear` 0, `tfar` infinity)
/// and an intersect context (`rtcInitIntersectContext`'s: incoherent, no filter). Embree picks the
/// widest kernels the CPU has; `RAYLUME_EMBREE_ISA=sse2|sse4.2|avx|avx2` caps them, and
/// `RAYLUME_EMBREE_VERBOSE=n` sets Embree's verbosity (2 prints its BVH statistics and kernels).
#[cfg(feature = "embree")]
pub struct Embree {
    // The scene borrows the device's handle; both live as long as this.
    scene: embree3::Scene<'static>,
    _device: embree3::Device,
}

/// A packet of eight lanes' valid mask, aligned as `rtcIntersect8` reads it.
#[cfg(feature = "embree")]
#[repr(C, align(32))]
struct Valid8(embree3::ValidMaskN<8>);

#[cfg(feature = "embree")]
impl Embree {
    /// The scene with default flags.
    pub fn build(tris: &[Triangle]) -> Self {
        Self::with_flags(tris, false)
    }

    /// The scene, with `RTC_SCENE_FLAG_ROBUST` if `robust`.
    pub fn with_flags(tris: &[Triangle], robust: bool) -> Self {
        use embree3::{BufferUsage, BuildQuality, Config, Device, Format, GeometryKind, Isa, SceneFlags};
        let max_isa = match std::env::var("RAYLUME_EMBREE_ISA").as_deref() {
            Ok("sse2") => Isa::Sse2,
            Ok("sse4.2") => Isa::Sse4_2,
            Ok("avx") => Isa::Avx,
            Ok("avx2") => Isa::Avx2,
            _ => Isa::Avx512,
        };
        let verbose = std::env::var("RAYLUME_EMBREE_VERBOSE").ok().and_then(|v| v.parse().ok()).unwrap_or(0);
        let device = Device::with_config(Config { threads: 1, max_isa, verbose, ..Config::default() })
            .expect("an Embree device");
        let mut mesh = device.create_geometry(GeometryKind::TRIANGLE).expect("a triangle geometry");
        let vertices: Vec<[f32; 3]> = tris.iter().flat_map(|t| t.p.map(|p| p.to_array())).collect();
        mesh.set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, vertices.len())
            .expect("a vertex buffer")
            .copy_from_slice(&vertices);
        let indices: Vec<[u32; 3]> = (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        mesh.set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, indices.len())
            .expect("an index buffer")
            .copy_from_slice(&indices);
        mesh.set_build_quality(BuildQuality::MEDIUM);
        let mesh = mesh.commit();
        let mut scene = device.create_scene().expect("a scene");
        scene.set_build_quality(BuildQuality::MEDIUM);
        scene.set_flags(if robust { SceneFlags::ROBUST } else { SceneFlags::NONE });
        scene.attach_geometry(&mesh);
        scene.commit();
        Self { scene, _device: device }
    }

    /// The closest hit of `ray` through `rtcIntersect1`: its distance and triangle.
    pub fn closest(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut ctx = embree3::IntersectContext::incoherent();
        let mut hit = embree3::RayHit::from(Self::ray(ray));
        self.scene.intersect(&mut ctx, &mut hit);
        hit.hit.is_valid().then_some((hit.ray.tfar, hit.hit.primID))
    }

    /// Whether `ray` is occluded, through `rtcOccluded1`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut ctx = embree3::IntersectContext::incoherent();
        self.scene.occluded(&mut ctx, &mut Self::ray(ray))
    }

    /// The closest hits of `rays` through Embree's packet query (`rtcIntersect8`), eight consecutive
    /// rays per packet (a row of an 8x8 tile), the context flagged coherent; returns how many hit.
    pub fn closest_packets(&self, rays: &[Ray]) -> usize {
        let mut hits = 0;
        for run in rays.chunks(8) {
            let mut ctx = embree3::IntersectContext::coherent();
            let mut packet = embree3::RayHit8 { ray: Self::ray8(run), hit: embree3::Hit8::new() };
            self.scene.intersect8(&mut ctx, &mut packet, &Self::valid8(run.len()).0);
            hits += packet.hit.geomID[..run.len()].iter().filter(|&&g| g != embree3::INVALID_ID).count();
        }
        hits
    }

    /// Occlusion of `rays` through `rtcOccluded8`, eight consecutive rays per packet, the context
    /// flagged coherent; returns how many are occluded (Embree sets an occluded ray's `tfar` to -inf).
    pub fn occluded_packets(&self, rays: &[Ray]) -> usize {
        let mut occluded = 0;
        for run in rays.chunks(8) {
            let mut ctx = embree3::IntersectContext::coherent();
            let mut packet = Self::ray8(run);
            self.scene.occluded8(&mut ctx, &mut packet, &Self::valid8(run.len()).0);
            occluded += packet.tfar[..run.len()].iter().filter(|&&t| t == f32::NEG_INFINITY).count();
        }
        occluded
    }

    /// The closest hits of `rays` through Embree's stream query (`rtcIntersect1M`) in runs of 64,
    /// flagged coherent or not; returns how many hit.
    pub fn closest_stream(&self, rays: &[Ray], coherent: bool, buffer: &mut Vec<embree3::RayHit>) -> usize {
        let mut hits = 0;
        for run in rays.chunks(64) {
            let mut ctx = Self::context(coherent);
            buffer.clear();
            buffer.extend(run.iter().map(|r| embree3::RayHit::from(Self::ray(r))));
            self.scene.intersect_stream_aos(&mut ctx, buffer);
            hits += buffer.iter().filter(|h| h.hit.is_valid()).count();
        }
        hits
    }

    /// Occlusion of `rays` through Embree's stream query (`rtcOccluded1M`) in runs of 64; returns how
    /// many are occluded (Embree sets an occluded ray's `tfar` to -inf).
    pub fn occluded_stream(&self, rays: &[Ray], coherent: bool, buffer: &mut Vec<embree3::Ray>) -> usize {
        let mut occluded = 0;
        for run in rays.chunks(64) {
            let mut ctx = Self::context(coherent);
            buffer.clear();
            buffer.extend(run.iter().map(Self::ray));
            self.scene.occluded_stream_aos(&mut ctx, buffer);
            occluded += buffer.iter().filter(|r| r.tfar == f32::NEG_INFINITY).count();
        }
        occluded
    }

    fn context(coherent: bool) -> embree3::IntersectContext {
        if coherent { embree3::IntersectContext::coherent() } else { embree3::IntersectContext::incoherent() }
    }

    fn ray(r: &Ray) -> embree3::Ray {
        embree3::Ray::segment(r.origin.to_array(), r.dir.to_array(), 0.0, f32::INFINITY)
    }

    /// Up to eight rays as a packet; missing lanes repeat the first ray (and are masked off).
    fn ray8(run: &[Ray]) -> embree3::Ray8 {
        let lane = |i: usize| run.get(i).unwrap_or(&run[0]);
        embree3::Ray8::new(
            std::array::from_fn(|i| lane(i).origin.to_array()),
            std::array::from_fn(|i| lane(i).dir.to_array()),
        )
    }

    fn valid8(lanes: usize) -> Valid8 {
        use embree3::ValidMask;
        Valid8(embree3::ValidMaskN::new(std::array::from_fn(|i| {
            if i < lanes { ValidMask::Valid } else { ValidMask::Invalid }
        })))
    }
}
