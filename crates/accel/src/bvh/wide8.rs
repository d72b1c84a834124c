//! The box test of eight-wide nodes in 256-bit registers, for CPUs with AVX2: the same operations as
//! [`BoxRay`](super::wide::BoxRay)'s, on eight children at once.
//!
//! Queries that use it run inside [`V3::vectorize`], which compiles them with AVX2 enabled; the token
//! exists only on CPUs that have it (`V3::try_new`), so the crate needs no `unsafe` of its own.

use pulp::x86::V3;
use raylume_geometry::{Ray, Vec3A};
use std::arch::x86_64::{__m256, __m256i, _CMP_LE_OQ};

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

    /// The keys as the default method makes them, sorted by a bitonic network in one register.
    #[inline(always)]
    fn order(&self, near: [f32; 8], mask: u32) -> [u32; 8] {
        let (avx, avx2) = (self.simd.avx, self.simd.avx2);
        let bits: __m256i = pulp::cast(near);
        // order_key: flip the sign bit of positive floats, every bit of negative ones.
        let flip = avx2._mm256_or_si256(avx2._mm256_srai_epi32::<31>(bits), avx._mm256_set1_epi32(i32::MIN));
        let slots = avx._mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let key = avx2._mm256_or_si256(
            avx2._mm256_andnot_si256(avx._mm256_set1_epi32(7), avx2._mm256_xor_si256(bits, flip)),
            slots,
        );
        let lane_bit = avx2._mm256_sllv_epi32(avx._mm256_set1_epi32(1), slots);
        let missed = avx2._mm256_cmpeq_epi32(
            avx2._mm256_and_si256(avx._mm256_set1_epi32(mask as i32), lane_bit),
            avx._mm256_setzero_si256(),
        );
        let mut k = avx2._mm256_or_si256(key, missed);
        // Lane i of each layer keeps the smaller key of itself and lane i ^ j when the bit of i in the
        // layer's constant is set (Batcher's bitonic sort, ascending).
        macro_rules! layer {
            ($partner:expr, $min_lanes:literal) => {{
                let p = $partner;
                let (lo, hi) = (avx2._mm256_min_epu32(k, p), avx2._mm256_max_epu32(k, p));
                k = avx2._mm256_blend_epi32::<$min_lanes>(hi, lo);
            }};
        }
        layer!(avx2._mm256_shuffle_epi32::<0xB1>(k), 0x99);
        layer!(avx2._mm256_shuffle_epi32::<0x4E>(k), 0xC3);
        layer!(avx2._mm256_shuffle_epi32::<0xB1>(k), 0xA5);
        layer!(avx2._mm256_permute2x128_si256::<0x01>(k, k), 0x0F);
        layer!(avx2._mm256_shuffle_epi32::<0x4E>(k), 0x33);
        layer!(avx2._mm256_shuffle_epi32::<0xB1>(k), 0x55);
        pulp::cast(k)
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The default ordering of [`NodeTest`], for comparison.
    struct Scalar;

    impl NodeTest<8> for Scalar {
        fn intersect(&self, _: &WideNode<8>, _: f32, _: f32) -> ([f32; 8], u32) {
            unreachable!()
        }
    }

    fn arb_distance() -> impl Strategy<Value = f32> {
        prop_oneof![
            Just(0.0f32),
            Just(-0.0f32),
            Just(f32::INFINITY),
            Just(f32::MAX),
            Just(1.5f32),
            -10.0f32..10.0,
            any::<f32>().prop_filter("not NaN", |x| !x.is_nan()),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The network sorts the children's keys as the scalar ordering does: equal distances and
        /// signed zeros included, missed children last.
        #[test]
        fn network_orders_as_the_scalar_sort(near in prop::array::uniform8(arb_distance()), mask in 0u32..256) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let ray = BoxRay8::new(simd, &Ray::new(Vec3A::ZERO, Vec3A::ONE));
            let got = simd.vectorize(|| ray.order(near, mask));
            prop_assert_eq!(got, Scalar.order(near, mask));
        }
    }
}
