//! The box test of eight-wide nodes in 256-bit registers, for CPUs with AVX2: the same operations as
//! [`BoxRay`](super::wide::BoxRay)'s, on eight children at once.
//!
//! Queries that use it run inside [`V3::vectorize`], which compiles them with AVX2 enabled; the token
//! exists only on CPUs that have it (`V3::try_new`), so the crate needs no `unsafe` of its own.

use pulp::x86::V3;
use raylume_geometry::{Ray, Vec3A};
use std::arch::x86_64::{__m256, _CMP_LE_OQ};

use super::wide::{NodeTest, WideNode, reciprocals};

/// A ray prepared for the eight-wide box test: per axis, the origin and the reciprocal direction for
/// the near and the far planes, splatted, and which plane is entered first.
#[derive(Clone, Copy, Debug)]
pub(super) struct BoxRay8 {
    simd: V3,
    origin: [__m256; 3],
    inv_near: [__m256; 3],
    inv_far: [__m256; 3],
    negative: [bool; 3],
}

impl BoxRay8 {
    /// `ray` prepared as [`BoxRay::new`](super::wide::BoxRay::new) prepares it.
    #[inline(always)]
    pub fn new(simd: V3, ray: &Ray) -> Self {
        let d = ray.dir;
        let parallel = d.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE));
        let (inv, inv_far) = reciprocals(d);
        let inv_near = Vec3A::select(parallel, Vec3A::INFINITY, inv).to_array();
        let inv_far = Vec3A::select(parallel, Vec3A::INFINITY, inv_far).to_array();
        let negative = (d.cmplt(Vec3A::ZERO) & !parallel).bitmask();
        let splat = |x: f32| simd.avx._mm256_set1_ps(x);
        Self {
            simd,
            origin: ray.origin.to_array().map(splat),
            inv_near: inv_near.map(splat),
            inv_far: inv_far.map(splat),
            negative: [negative & 1 != 0, negative & 2 != 0, negative & 4 != 0],
        }
    }
}

impl NodeTest<8> for BoxRay8 {
    #[inline(always)]
    fn intersect(&self, node: &WideNode<8>, t_min: f32, t_max: f32) -> ([f32; 8], u32) {
        let avx = self.simd.avx;
        let mut near = avx._mm256_set1_ps(t_min);
        let mut far = avx._mm256_set1_ps(t_max);
        for a in 0..3 {
            let neg = self.negative[a] as usize;
            let lo: __m256 = pulp::cast(node.bounds[2 * a + neg]);
            let hi: __m256 = pulp::cast(node.bounds[2 * a + 1 - neg]);
            let tn = avx._mm256_mul_ps(avx._mm256_sub_ps(lo, self.origin[a]), self.inv_near[a]);
            let tf = avx._mm256_mul_ps(avx._mm256_sub_ps(hi, self.origin[a]), self.inv_far[a]);
            // As in the four-wide test: a NaN product leaves the bound as it was.
            near = avx._mm256_max_ps(tn, near);
            far = avx._mm256_min_ps(tf, far);
        }
        let mask = avx._mm256_movemask_ps(avx._mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
        (pulp::cast(near), mask)
    }
}
