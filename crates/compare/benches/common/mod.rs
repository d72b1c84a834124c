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

/// Embree 3's scene over the same triangles (default flags and medium build quality, one build
/// thread), for the rows of the comparison that name it. Embree picks the widest kernels the CPU has;
/// `RAYLUME_EMBREE_ISA=sse2|sse4.2|avx|avx2` caps them.
#[cfg(feature = "embree")]
pub struct Embree {
    // The scene borrows the device's handle; both live as long as this.
    scene: embree3::Scene<'static>,
    _device: embree3::Device,
}

#[cfg(feature = "embree")]
impl Embree {
    pub fn build(tris: &[Triangle]) -> Self {
        use embree3::{BufferUsage, Config, Device, Format, GeometryKind, Isa};
        let max_isa = match std::env::var("RAYLUME_EMBREE_ISA").as_deref() {
            Ok("sse2") => Isa::Sse2,
            Ok("sse4.2") => Isa::Sse4_2,
            Ok("avx") => Isa::Avx,
            Ok("avx2") => Isa::Avx2,
            _ => Isa::Avx512,
        };
        let device =
            Device::with_config(Config { threads: 1, max_isa, ..Config::default() }).expect("an Embree device");
        let mut mesh = device.create_geometry(GeometryKind::TRIANGLE).expect("a triangle geometry");
        let vertices: Vec<[f32; 3]> = tris.iter().flat_map(|t| t.p.map(|p| p.to_array())).collect();
        mesh.set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, vertices.len())
            .expect("a vertex buffer")
            .copy_from_slice(&vertices);
        let indices: Vec<[u32; 3]> = (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        mesh.set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, indices.len())
            .expect("an index buffer")
            .copy_from_slice(&indices);
        let mesh = mesh.commit();
        let mut scene = device.create_scene().expect("a scene");
        scene.attach_geometry(&mesh);
        scene.commit();
        Self { scene, _device: device }
    }

    pub fn closest(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut ctx = embree3::IntersectContext::incoherent();
        let mut hit = embree3::RayHit::from(Self::ray(ray));
        self.scene.intersect(&mut ctx, &mut hit);
        hit.hit.is_valid().then_some((hit.ray.tfar, hit.hit.primID))
    }

    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut ctx = embree3::IntersectContext::incoherent();
        self.scene.occluded(&mut ctx, &mut Self::ray(ray))
    }

    /// The closest hits of `rays` through Embree's stream query (`rtcIntersect1M`) in runs of 64,
    /// flagged coherent or not; returns how many hit.
    pub fn closest_stream(&self, rays: &[Ray], coherent: bool, buffer: &mut Vec<embree3::RayHit>) -> usize {
        let mut ctx = Self::context(coherent);
        let mut hits = 0;
        for run in rays.chunks(64) {
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
        let mut ctx = Self::context(coherent);
        let mut occluded = 0;
        for run in rays.chunks(64) {
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
}
