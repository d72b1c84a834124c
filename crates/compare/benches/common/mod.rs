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
