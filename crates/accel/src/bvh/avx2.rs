//! The kernels for CPUs with AVX2: the box test of eight-wide nodes in 256-bit registers (the same
//! operations as [`BoxRay`](super::wide::BoxRay)'s, on eight children at once), their children ordered
//! by a sorting network, the candidate filter of a leaf's eight triangles at once, and the check that
//! a run of rays can walk as a packet.
//!
//! Queries that use it run inside [`V3::vectorize`], which compiles them with AVX2 enabled; the token
//! exists only on CPUs that have it (`V3::try_new`), so the crate needs no `unsafe` of its own.

use glam::{Vec3A, Vec4};
use pulp::x86::V3;
use raylume_geometry::{Interval, Ray, gamma};
use raylume_intersect::{Intersect, ShearedRay, TINY_DISTANCE, TINY_TERM, TriangleHit};
use std::arch::x86_64::{
    __m128, __m256, __m256d, __m256i, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_UQ, _CMP_NLT_UQ,
};

use super::kernel::{BvhKernel, Kernel, Triangles};
use super::leaf::{AnyCandidateHit, Candidates, Exact, Filter, closest_of_candidates_scalar, exact_out_of_line};
use super::stream::{self, Block, Found, FrameGroup, Leaves, PacketQuery, Report};
use super::triangles::Leaf;
use super::wide::{Frustum, LeafTest, NodeTest, SlabRay, Stack, WideNode, WideTree, set_bits};
use crate::{PrimitiveHit, Tally};

/// The AVX2 kernel: eight-wide trees, their walks compiled with AVX2 enabled.
impl Kernel<8> for V3 {
    const KIND: BvhKernel = BvhKernel::Avx2;

    /// [`WideTree::walk`] of an eight-wide tree for `ray`, compiled with AVX2 enabled.
    #[inline(always)]
    fn walk<const ANY: bool, T: Tally, L: LeafTest<T>>(
        self,
        tree: &WideTree<8>,
        ray: &Ray,
        t_range: (f32, f32),
        tally: &mut T,
        leaf: &mut L,
    ) {
        self.vectorize(Walk::<ANY, T, L> { simd: self, tree, ray, t_range, tally, leaf })
    }

    #[inline(always)]
    fn answer_packet(
        self,
        tree: &WideTree<8>,
        tris: &Triangles,
        rays: &[Ray],
        frustum: &Frustum,
        query: PacketQuery<impl Report>,
    ) {
        answer_packet(self, tree, &tris.leaves, &tris.leaf_bounds, rays, frustum, query)
    }
}

/// The walk's arguments: a function object whose call is always inlined into the AVX2 function that
/// `vectorize` makes (a closure's call need not be, and the intrinsics then stay calls). Small enough
/// for `vectorize` to pass it in registers.
struct Walk<'a, const ANY: bool, T, L> {
    simd: V3,
    tree: &'a WideTree<8>,
    ray: &'a Ray,
    t_range: (f32, f32),
    tally: &'a mut T,
    leaf: &'a mut L,
}

impl<const ANY: bool, T: Tally, L: LeafTest<T>> pulp::NullaryFnOnce for Walk<'_, ANY, T, L> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let (t_min, t_max) = self.t_range;
        self.tree.walk::<ANY, T>(&BoxRay8::new(self.simd, self.ray), t_min, t_max, self.tally, self.leaf)
    }
}

/// [`stream::closest_by_shapes`] walking the other shapes' eight-wide tree `tree`, compiled with AVX2
/// enabled.
#[allow(clippy::too_many_arguments)]
pub(super) fn closest_by_shapes<P: Intersect>(
    simd: V3,
    frustum: &Frustum,
    tree: &WideTree<8>,
    shapes: (&[P], &[u32], &[[f32; 6]]),
    rays: &[Ray],
    t_min: f32,
    t_max: &mut [f32],
    hits: &mut [Option<PrimitiveHit>],
) {
    simd.vectorize(ClosestByShapes { simd, frustum, tree, shapes, rays, t_min, t_max, hits })
}

/// [`closest_by_shapes`]'s arguments, as a function object whose call is always inlined (see [`Walk`]).
struct ClosestByShapes<'a, P> {
    simd: V3,
    frustum: &'a Frustum,
    tree: &'a WideTree<8>,
    shapes: (&'a [P], &'a [u32], &'a [[f32; 6]]),
    rays: &'a [Ray],
    t_min: f32,
    t_max: &'a mut [f32],
    hits: &'a mut [Option<PrimitiveHit>],
}

impl<P: Intersect> pulp::NullaryFnOnce for ClosestByShapes<'_, P> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let Self { simd, frustum, tree, shapes, rays, t_min, t_max, hits } = self;
        stream::closest_by_shapes(frustum, (tree, &Frustum8::new(simd, frustum)), shapes, rays, t_min, t_max, hits)
    }
}

/// [`stream::occluded_by_shapes`] walking the other shapes' eight-wide tree `tree`, compiled with AVX2
/// enabled.
#[allow(clippy::too_many_arguments)]
pub(super) fn occluded_by_shapes<P: Intersect>(
    simd: V3,
    frustum: &Frustum,
    tree: &WideTree<8>,
    prims: &[P],
    boxes: &[[f32; 6]],
    rays: &[Ray],
    t_max: &[f32],
    occluded: &mut [bool],
) {
    simd.vectorize(OccludedByShapes { simd, frustum, tree, prims, boxes, rays, t_max, occluded })
}

/// [`occluded_by_shapes`]'s arguments, as a function object whose call is always inlined (see [`Walk`]).
struct OccludedByShapes<'a, P> {
    simd: V3,
    frustum: &'a Frustum,
    tree: &'a WideTree<8>,
    prims: &'a [P],
    boxes: &'a [[f32; 6]],
    rays: &'a [Ray],
    t_max: &'a [f32],
    occluded: &'a mut [bool],
}

impl<P: Intersect> pulp::NullaryFnOnce for OccludedByShapes<'_, P> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let Self { simd, frustum, tree, prims, boxes, rays, t_max, occluded } = self;
        stream::occluded_by_shapes(frustum, (tree, &Frustum8::new(simd, frustum)), prims, boxes, rays, t_max, occluded)
    }
}

/// A packet of rays prepared for the eight-wide box test: [`Frustum`]'s bounds, splatted.
#[derive(Clone, Copy, Debug)]
pub(super) struct Frustum8 {
    simd: V3,
    near_origin: [__m256; 3],
    far_origin: [__m256; 3],
    inv_near: [[__m256; 2]; 3],
    inv_far: [[__m256; 2]; 3],
    negative: [bool; 3],
}

impl Frustum8 {
    /// The packet `f`, its values splatted to eight lanes.
    #[inline(always)]
    pub fn new(simd: V3, f: &Frustum) -> Self {
        let (avx, negative) = (simd.avx, f.negative);
        let mut g = Self {
            simd,
            near_origin: [avx._mm256_setzero_ps(); 3],
            far_origin: [avx._mm256_setzero_ps(); 3],
            inv_near: [[avx._mm256_setzero_ps(); 2]; 3],
            inv_far: [[avx._mm256_setzero_ps(); 2]; 3],
            negative,
        };
        // Frustum's lanes are splats: lane 0 holds each value.
        for a in 0..3 {
            g.near_origin[a] = avx._mm256_set1_ps(f.near_origin[a].x);
            g.far_origin[a] = avx._mm256_set1_ps(f.far_origin[a].x);
            for e in 0..2 {
                g.inv_near[a][e] = avx._mm256_set1_ps(f.inv_near[a][e].x);
                g.inv_far[a][e] = avx._mm256_set1_ps(f.inv_far[a][e].x);
            }
        }
        g
    }
}

/// The slab test of a node's eight children, as [`slabs`](super::wide) of the four-wide tests:
/// `$planes(a, near planes, far planes)` gives the distances to axis `a`'s planes. A macro, not a
/// function taking a closure: every intrinsic must be inlined (see `Walk`).
macro_rules! slabs8 {
    ($self:ident, $node:ident, $t_min:ident, $t_max:ident, |$a:ident, $lo:ident, $hi:ident| $planes:expr) => {{
        let avx = $self.simd.avx;
        let mut near = avx._mm256_set1_ps($t_min);
        let mut far = avx._mm256_set1_ps($t_max);
        for $a in 0..3 {
            let neg = $self.negative[$a] as usize;
            let $lo: __m256 = pulp::cast($node.bounds[2 * $a + neg]);
            let $hi: __m256 = pulp::cast($node.bounds[2 * $a + 1 - neg]);
            let (tn, tf) = $planes;
            // As in the four-wide test: a NaN product leaves the bound as it was.
            near = avx._mm256_max_ps(tn, near);
            far = avx._mm256_min_ps(tf, far);
        }
        let mask = avx._mm256_movemask_ps(avx._mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
        (pulp::cast(near), mask)
    }};
    // The same test with the bounds joined in two levels of max and min rather than three: a shorter
    // chain from the node's load to its mask, which any-hit walks wait on (closest-hit walks, whose
    // ordering of the children holds more registers, run faster with the chain above). A NaN product
    // (an origin on a slab's plane, the direction parallel to it) leaves the bound as it was; where
    // `nz` (`fz`) is one, `ny`'s (`fy`'s) bound is left out too, so the test stays conservative.
    (shallow $self:ident, $node:ident, $t_min:ident, $t_max:ident, |$a:ident, $lo:ident, $hi:ident| $planes:expr) => {{
        let avx = $self.simd.avx;
        let (mut tn, mut tf) = ([avx._mm256_setzero_ps(); 3], [avx._mm256_setzero_ps(); 3]);
        for $a in 0..3 {
            let neg = $self.negative[$a] as usize;
            let $lo: __m256 = pulp::cast($node.bounds[2 * $a + neg]);
            let $hi: __m256 = pulp::cast($node.bounds[2 * $a + 1 - neg]);
            (tn[$a], tf[$a]) = $planes;
        }
        let ([nx, ny, nz], [fx, fy, fz]) = (tn, tf);
        let near = avx._mm256_max_ps(avx._mm256_max_ps(ny, nz), avx._mm256_max_ps(nx, avx._mm256_set1_ps($t_min)));
        let far = avx._mm256_min_ps(avx._mm256_min_ps(fy, fz), avx._mm256_min_ps(fx, avx._mm256_set1_ps($t_max)));
        let mask = avx._mm256_movemask_ps(avx._mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
        (pulp::cast(near), mask)
    }};
}

/// [`NodeTest::order`] of eight children: the keys as the default method makes them, sorted by a
/// bitonic network in one register.
#[inline(always)]
fn bitonic_order(simd: V3, near: [f32; 8], mask: u32) -> __m256i {
    let (avx, avx2) = (simd.avx, simd.avx2);
    let bits: __m256i = pulp::cast(near);
    // order_key: flip the sign bit of positive floats, every bit of negative ones.
    let flip = avx2._mm256_or_si256(avx2._mm256_srai_epi32::<31>(bits), avx._mm256_set1_epi32(i32::MIN));
    let slots = avx._mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let key = avx2
        ._mm256_or_si256(avx2._mm256_andnot_si256(avx._mm256_set1_epi32(7), avx2._mm256_xor_si256(bits, flip)), slots);
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
    k
}

/// For each eight-bit mask, the slots of its set bits in increasing order, three bits each (lane `j`
/// in bits `3 j..3 j + 3`), the rest zero.
const COMPRESS: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let (mut j, mut slot) = (0, 0);
        while slot < 8 {
            if m & (1 << slot) != 0 {
                t[m] |= slot << (3 * j);
                j += 1;
            }
            slot += 1;
        }
        m += 1;
    }
    t
};

/// [`NodeTest::push`] of eight children in AVX registers. Closest-hit walks push the hit children but
/// the nearest farthest first, three or more of them ordered by the network and stored with one vector
/// store per array; any-hit walks go on with the first hit child in slot order and push the others
/// with one store per array, without a branch on their number.
#[inline(always)]
fn push8<const ANY: bool>(
    simd: V3,
    node: &WideNode<8>,
    near: [f32; 8],
    mask: u32,
    stack: &mut Stack,
    sp: &mut usize,
) -> u32 {
    let (avx, avx2) = (simd.avx, simd.avx2);
    let first = mask.trailing_zeros() as usize;
    let rest = mask & (mask - 1);
    // Stores the children and distances of `slots` (lane j: the slot of entry sp + j) from sp; a macro,
    // not a closure (see `Walk`).
    macro_rules! store {
        ($slots:expr) => {{
            let slots: __m256i = $slots;
            let child: [u32; 8] = pulp::cast(avx2._mm256_permutevar8x32_epi32(pulp::cast(node.child), slots));
            let near: [f32; 8] = pulp::cast(avx2._mm256_permutevar8x32_ps(pulp::cast(near), slots));
            stack.child[*sp..*sp + 8].copy_from_slice(&child);
            stack.near[*sp..*sp + 8].copy_from_slice(&near);
        }};
    }
    if ANY {
        let shifts = avx._mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
        let packed = avx._mm256_set1_epi32(COMPRESS[rest as usize & 255] as i32);
        let slots = avx2._mm256_and_si256(avx2._mm256_srlv_epi32(packed, shifts), avx._mm256_set1_epi32(7));
        store!(slots);
        *sp += rest.count_ones() as usize;
        return node.child[first];
    }
    if rest == 0 {
        return node.child[first];
    }
    let second = rest.trailing_zeros() as usize;
    if rest & (rest - 1) == 0 {
        // Two children, the most common case: order them without a branch.
        let (a, b) = if near[second] < near[first] { (second, first) } else { (first, second) };
        (stack.child[*sp], stack.near[*sp]) = (node.child[b], near[b]);
        *sp += 1;
        return node.child[a];
    }
    let keys = bitonic_order(simd, near, mask);
    let n = mask.count_ones() as i32;
    // Entry sp + j takes the (n - 1 - j)th nearest.
    let from = avx2._mm256_sub_epi32(avx._mm256_set1_epi32(n - 1), avx._mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    let seven = avx._mm256_set1_epi32(7);
    let sorted = avx2._mm256_and_si256(keys, seven);
    let slots = avx2._mm256_permutevar8x32_epi32(sorted, avx2._mm256_and_si256(from, seven));
    store!(slots);
    *sp += n as usize - 1;
    let nearest: [u32; 8] = pulp::cast(sorted);
    node.child[nearest[0] as usize]
}

/// The children's order and push of the eight-wide box tests (`Frustum8`, `BoxRay8`), in AVX
/// registers: the network and [`push8`].
macro_rules! eight_wide_pushes {
    () => {
        #[inline(always)]
        fn order(&self, near: [f32; 8], mask: u32) -> [u32; 8] {
            pulp::cast(bitonic_order(self.simd, near, mask))
        }

        #[inline(always)]
        fn push<const ANY: bool>(
            &self,
            node: &WideNode<8>,
            near: [f32; 8],
            mask: u32,
            stack: &mut Stack,
            sp: &mut usize,
        ) -> u32 {
            push8::<ANY>(self.simd, node, near, mask, stack, sp)
        }
    };
}

impl NodeTest<8> for Frustum8 {
    /// [`Frustum`]'s test with the same operations, on eight children.
    #[inline(always)]
    fn intersect(&self, node: &WideNode<8>, t_min: f32, t_max: f32) -> ([f32; 8], u32) {
        let avx = self.simd.avx;
        slabs8!(self, node, t_min, t_max, |a, lo, hi| {
            let [n0, n1] = self.inv_near[a];
            let [f0, f1] = self.inv_far[a];
            let x = avx._mm256_sub_ps(lo, self.near_origin[a]);
            let y = avx._mm256_sub_ps(hi, self.far_origin[a]);
            (
                avx._mm256_min_ps(avx._mm256_mul_ps(x, n0), avx._mm256_mul_ps(x, n1)),
                avx._mm256_max_ps(avx._mm256_mul_ps(y, f0), avx._mm256_mul_ps(y, f1)),
            )
        })
    }

    eight_wide_pushes!();
}

/// [`Leaves::answer`] for a packet of `rays` (its frustum `frustum`) down the eight-wide tree,
/// compiled with AVX2 enabled.
fn answer_packet(
    simd: V3,
    tree: &WideTree<8>,
    leaves: &[Leaf],
    leaf_bounds: &[[f32; 6]],
    rays: &[Ray],
    frustum: &Frustum,
    query: PacketQuery<impl Report>,
) {
    simd.vectorize(PacketWalk { simd, tree, leaves, leaf_bounds, rays, frustum, query })
}

/// A packet walk's arguments, as a function object whose call is always inlined (see [`Walk`]).
struct PacketWalk<'a, 'q, R> {
    simd: V3,
    tree: &'a WideTree<8>,
    leaves: &'a [Leaf],
    leaf_bounds: &'a [[f32; 6]],
    rays: &'a [Ray],
    frustum: &'a Frustum,
    query: PacketQuery<'q, R>,
}

impl<R: Report> pulp::NullaryFnOnce for PacketWalk<'_, '_, R> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        let leaves = Leaves {
            tree: self.tree,
            frustum: Frustum8::new(self.simd, self.frustum),
            filter: self.simd,
            leaves: self.leaves,
            leaf_bounds: self.leaf_bounds,
        };
        leaves.answer(self.rays, self.frustum.negative, self.query)
    }
}

/// The [`Frustum`] of `rays` if [`canonical_signs`](super::stream::canonical_signs) finds they can
/// walk as they are, compiled with AVX2 enabled: each ray's origin and direction in one register,
/// the checks and the extremes of [`Frustum::new`] gathered over the rays in registers, in one pass.
pub(super) fn canonical_frustum(simd: V3, rays: &[Ray]) -> Option<Frustum> {
    simd.vectorize(CanonicalFrustum { simd, rays })
}

/// [`canonical_frustum`]'s arguments, as a function object whose call is always inlined (see [`Walk`]).
struct CanonicalFrustum<'a> {
    simd: V3,
    rays: &'a [Ray],
}

impl pulp::NullaryFnOnce for CanonicalFrustum<'_> {
    type Output = Option<Frustum>;

    #[inline(always)]
    fn call(self) -> Option<Frustum> {
        let (avx, sse) = (self.simd.avx, self.simd.sse);
        let first = self.rays.first()?;
        // Two rays at a time: the origins of both in one register, their directions in another (the
        // first ray in lanes 0-2, the second in 4-6; lanes 3 and 7 are left out).
        let two = |a: raylume_geometry::Vec3A, b: raylume_geometry::Vec3A| avx._mm256_set_m128(b.into(), a.into());
        let splat = |x: f32| avx._mm256_set1_ps(x);
        let sign = splat(-0.0);
        let first_dirs = two(first.dir, first.dir);
        let all = avx._mm256_castsi256_ps(avx._mm256_set1_epi32(-1));
        // An origin is finite; a direction's components are at least the smallest normal and below 1
        // in magnitude, the largest reaching 0.5 (canonical, inside `Ray::is_valid`'s range, finite).
        // The comparisons fail on NaN.
        let (mut finite, mut in_range, mut reaches_half, mut other_signs) = (all, all, all, avx._mm256_setzero_ps());
        let mut time_nan = sse._mm_setzero_ps();
        // The extremes of the origins and of the directions, each half over its own rays.
        let (mut o_lo, mut o_hi) = (splat(f32::INFINITY), splat(f32::NEG_INFINITY));
        let (mut d_lo, mut d_hi) = (o_lo, o_hi);
        // No closures here (see `Walk`).
        macro_rules! gather {
            ($a:expr, $b:expr) => {{
                let (a, b): (&Ray, &Ray) = ($a, $b);
                let (o, d) = (two(a.origin, b.origin), two(a.dir, b.dir));
                o_lo = avx._mm256_min_ps(o_lo, o);
                o_hi = avx._mm256_max_ps(o_hi, o);
                d_lo = avx._mm256_min_ps(d_lo, d);
                d_hi = avx._mm256_max_ps(d_hi, d);
                finite = avx._mm256_and_ps(
                    finite,
                    avx._mm256_cmp_ps::<_CMP_LT_OQ>(avx._mm256_andnot_ps(sign, o), splat(f32::INFINITY)),
                );
                let m = avx._mm256_andnot_ps(sign, d);
                let inside = avx._mm256_and_ps(
                    avx._mm256_cmp_ps::<_CMP_LT_OQ>(m, splat(1.0)),
                    avx._mm256_cmp_ps::<_CMP_GE_OQ>(m, splat(f32::MIN_POSITIVE)),
                );
                in_range = avx._mm256_and_ps(in_range, inside);
                // Every component of a direction within range is non-zero: its sign bit is its sign.
                other_signs = avx._mm256_or_ps(other_signs, avx._mm256_xor_ps(d, first_dirs));
                // Lane 0 of each half: whether any of the ray's three components reaches 0.5.
                let half = avx._mm256_cmp_ps::<_CMP_GE_OQ>(m, splat(0.5));
                let any = avx._mm256_or_ps(
                    avx._mm256_or_ps(half, avx._mm256_permute_ps::<0b00_00_00_01>(half)),
                    avx._mm256_permute_ps::<0b00_00_00_10>(half),
                );
                reaches_half = avx._mm256_and_ps(reaches_half, any);
                let times = sse._mm_cmpunord_ss(sse._mm_set_ss(a.time), sse._mm_set_ss(b.time));
                time_nan = sse._mm_or_ps(time_nan, times);
            }};
        }
        let pairs = self.rays.chunks_exact(2);
        let last = pairs.remainder().first();
        for pair in pairs {
            gather!(&pair[0], &pair[1]);
        }
        if let Some(r) = last {
            gather!(r, r);
        }
        let ok = avx._mm256_movemask_ps(avx._mm256_and_ps(finite, in_range)) & 0x77 == 0x77
            && avx._mm256_movemask_ps(avx._mm256_and_ps(other_signs, sign)) & 0x77 == 0
            && avx._mm256_movemask_ps(reaches_half) & 0x11 == 0x11
            && sse._mm_movemask_ps(time_nan) & 1 == 0;
        if !ok {
            return None;
        }
        let signs = first.dir.cmplt(raylume_geometry::Vec3A::ZERO).bitmask();
        let negative = [signs & 1 != 0, signs & 2 != 0, signs & 4 != 0];
        // Both halves' extremes folded into one.
        let low = |v: __m256| avx._mm256_castps256_ps128(v);
        let high = |v: __m256| avx._mm256_extractf128_ps::<1>(v);
        let o_min = sse._mm_min_ps(low(o_lo), high(o_lo)).into();
        let o_max = sse._mm_max_ps(low(o_hi), high(o_hi)).into();
        let d_min = sse._mm_min_ps(low(d_lo), high(d_lo)).into();
        let d_max = sse._mm_max_ps(low(d_hi), high(d_hi)).into();
        Some(Frustum::from_extremes([o_min, o_max], [d_min, d_max], negative))
    }
}

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
        let r = SlabRay::new(ray);
        // No closure to splat with (see `Walk`).
        let avx = simd.avx;
        let (mut origin, mut inv_near, mut inv_far) =
            ([avx._mm256_setzero_ps(); 3], [avx._mm256_setzero_ps(); 3], [avx._mm256_setzero_ps(); 3]);
        for a in 0..3 {
            origin[a] = avx._mm256_set1_ps(r.origin[a]);
            inv_near[a] = avx._mm256_set1_ps(r.inv_near[a]);
            inv_far[a] = avx._mm256_set1_ps(r.inv_far[a]);
        }
        Self { simd, origin, inv_near, inv_far, negative: r.negative }
    }
}

impl NodeTest<8> for BoxRay8 {
    #[inline(always)]
    fn intersect(&self, node: &WideNode<8>, t_min: f32, t_max: f32) -> ([f32; 8], u32) {
        let avx = self.simd.avx;
        slabs8!(self, node, t_min, t_max, |a, lo, hi| (
            avx._mm256_mul_ps(avx._mm256_sub_ps(lo, self.origin[a]), self.inv_near[a]),
            avx._mm256_mul_ps(avx._mm256_sub_ps(hi, self.origin[a]), self.inv_far[a]),
        ))
    }

    #[inline(always)]
    fn intersect_any(&self, node: &WideNode<8>, t_min: f32, t_max: f32) -> ([f32; 8], u32) {
        let avx = self.simd.avx;
        slabs8!(shallow self, node, t_min, t_max, |a, lo, hi| (
            avx._mm256_mul_ps(avx._mm256_sub_ps(lo, self.origin[a]), self.inv_near[a]),
            avx._mm256_mul_ps(avx._mm256_sub_ps(hi, self.origin[a]), self.inv_far[a]),
        ))
    }

    #[inline(always)]
    fn prefetch(&self, node: &WideNode<8>) {
        prefetch(self.simd, node);
    }

    eight_wide_pushes!();
}

/// An exact test compiled with AVX2 enabled ([`Filter::exact`]).
struct Compiled<E>(E);

impl<E: Exact> pulp::NullaryFnOnce for Compiled<E> {
    type Output = E::Output;

    #[inline(always)]
    fn call(self) -> E::Output {
        self.0.run()
    }
}

/// A leaf's triangles in the ray's frame, as [`watertight_decide`](raylume_intersect::watertight_decide)
/// forms them, lane by lane: the vertices' sheared coordinates (`z` not yet scaled) and the edge
/// functions.
pub(super) struct Edges {
    x: [__m256; 3],
    y: [__m256; 3],
    z: [__m256; 3],
    u: __m256,
    v: __m256,
    w: __m256,
    /// The edge functions' error bounds (`raylume_intersect::edge_error`).
    error: [__m256; 3],
}

/// [`Edges`] of `leaf` for `ray`, with the very operations of [`candidates`](super::triangles::candidates).
#[inline(always)]
fn edges(simd: V3, leaf: &Leaf, ray: &ShearedRay) -> Edges {
    // All eight lanes, those past the leaf's triangles masked off by the callers: no branch on the
    // leaf's size. No closures here: each must be inlined for its intrinsics to be (see `Walk`).
    let avx = simd.avx;
    let [kx, ky, kz] = ray.axes.map(|k| k.min(2));
    let (sx, sy) = (avx._mm256_set1_ps(ray.shear[0]), avx._mm256_set1_ps(ray.shear[1]));
    let o = ray.origin.to_array();
    let (ox, oy, oz) = (avx._mm256_set1_ps(o[kx]), avx._mm256_set1_ps(o[ky]), avx._mm256_set1_ps(o[kz]));
    // Vertex k's coordinates along the ray's frame, sheared, for all eight lanes.
    macro_rules! sheared {
        ($k:literal) => {{
            let x: __m256 = pulp::cast(leaf.v[$k][kx]);
            let y: __m256 = pulp::cast(leaf.v[$k][ky]);
            let z: __m256 = pulp::cast(leaf.v[$k][kz]);
            let az = avx._mm256_sub_ps(z, oz);
            (
                avx._mm256_sub_ps(avx._mm256_sub_ps(x, ox), avx._mm256_mul_ps(sx, az)),
                avx._mm256_sub_ps(avx._mm256_sub_ps(y, oy), avx._mm256_mul_ps(sy, az)),
                az,
            )
        }};
    }
    let ((ax, ay, az), (bx, by, bz), (cx, cy, cz)) = (sheared!(0), sheared!(1), sheared!(2));
    edge_functions(simd, [ax, bx, cx], [ay, by, cy], [az, bz, cz])
}

/// [`Edges`] of triangles whose vertices are at `x`, `y`, `z` in the rays' frames (`z` not yet
/// scaled), lane by lane.
#[inline(always)]
fn edge_functions(simd: V3, [ax, bx, cx]: [__m256; 3], [ay, by, cy]: [__m256; 3], z: [__m256; 3]) -> Edges {
    let avx = simd.avx;
    let sign = avx._mm256_set1_ps(-0.0);
    let (g3, tiny) = (avx._mm256_set1_ps(gamma(3)), avx._mm256_set1_ps(f32::MIN_POSITIVE));
    macro_rules! edge {
        ($p:ident, $q:ident, $r:ident, $s:ident) => {{
            let (pq, rs) = (avx._mm256_mul_ps($p, $q), avx._mm256_mul_ps($r, $s));
            let magnitude = avx._mm256_add_ps(avx._mm256_andnot_ps(sign, pq), avx._mm256_andnot_ps(sign, rs));
            (avx._mm256_sub_ps(pq, rs), avx._mm256_add_ps(avx._mm256_mul_ps(magnitude, g3), tiny))
        }};
    }
    let ((u, eu), (v, ev), (w, ew)) = (edge!(cx, by, cy, bx), edge!(ax, cy, ay, cx), edge!(bx, ay, by, ax));
    Edges { x: [ax, bx, cx], y: [ay, by, cy], z, u, v, w, error: [eu, ev, ew] }
}

/// The candidate lanes of a leaf of `count` triangles: all but those with two edge functions of
/// opposite signs beyond their error bounds.
#[inline(always)]
fn candidate_lanes(simd: V3, e: &Edges, count: usize) -> u32 {
    !rejected_lanes(simd, e) & ((1 << count) - 1)
}

/// The lanes with two edge functions of opposite signs beyond their error bounds: those no ray's
/// test can hit.
#[inline(always)]
fn rejected_lanes(simd: V3, e: &Edges) -> u32 {
    let avx = simd.avx;
    let sign = avx._mm256_set1_ps(-0.0);
    let [eu, ev, ew] = e.error;
    let below = |x: __m256, err: __m256| avx._mm256_cmp_ps::<_CMP_LT_OQ>(x, avx._mm256_xor_ps(err, sign));
    let above = |x: __m256, err: __m256| avx._mm256_cmp_ps::<_CMP_GT_OQ>(x, err);
    let negative = avx._mm256_or_ps(avx._mm256_or_ps(below(e.u, eu), below(e.v, ev)), below(e.w, ew));
    let positive = avx._mm256_or_ps(avx._mm256_or_ps(above(e.u, eu), above(e.v, ev)), above(e.w, ew));
    avx._mm256_movemask_ps(avx._mm256_and_ps(negative, positive)) as u32
}

/// The any-hit verdict of a leaf's lanes, decided in AVX registers with the operations of the scalar
/// watertight test: `hit`, lanes the scalar test accepts; `open`, candidates it must decide itself
/// (an edge function within its rounding error of zero, a distance too close to call in f32, or a
/// distance or bound that is not finite).
/// Every other lane is one the scalar test rejects.
/// With them, each lane's distance (in f32, as the scalar test forms it), the bound on its error
/// and the reciprocal of its determinant (the barycentrics' scale), meaningful in the `hit` lanes.
#[derive(Clone, Copy, Debug)]
struct Verdict {
    hit: u32,
    open: u32,
    /// The open lanes whose edge functions are decided and whose distance and bound are finite, but
    /// too close to call in f32: the scalar test decides them by the f64 plane distance alone
    /// ([`plane_decisions`]).
    close: u32,
    t: __m256,
    delta_t: __m256,
    inv: __m256,
}

/// The [`Verdict`] of the `candidates` lanes of a leaf whose triangles all have a unit normal (the BVH
/// leaves out those without), of edge functions `e`, for `ray` within `range`.
#[inline(always)]
fn verdict(simd: V3, e: &Edges, candidates: u32, ray: &ShearedRay, range: Interval) -> Verdict {
    let avx = simd.avx;
    let splat = |x: f32| avx._mm256_set1_ps(x);
    verdict_lanes(simd, e, candidates, splat(ray.shear[2]), splat(range.min), splat(range.max))
}

/// [`verdict`] of lanes that each have their own ray: the shears `sz` and the ranges' ends `min`
/// and `max`, lane by lane.
#[inline(always)]
fn verdict_lanes(simd: V3, e: &Edges, candidates: u32, sz: __m256, min: __m256, max: __m256) -> Verdict {
    let avx = simd.avx;
    // Lanes the vector test decides: every edge function beyond its error bound (the scalar test
    // recomputes the others in f64), so none is NaN either (a NaN among the maxima below would be taken
    // where `f32::max` skips it).
    let zero = avx._mm256_setzero_ps();
    let sign = avx._mm256_set1_ps(-0.0);
    let certain = |x: __m256, err: __m256| avx._mm256_cmp_ps::<_CMP_GT_OQ>(avx._mm256_andnot_ps(sign, x), err);
    let [eu, ev, ew] = e.error;
    let sure = avx._mm256_and_ps(avx._mm256_and_ps(certain(e.u, eu), certain(e.v, ev)), certain(e.w, ew));
    let decided = candidates & avx._mm256_movemask_ps(sure) as u32;
    if decided == 0 {
        return Verdict { hit: 0, open: candidates, close: 0, t: zero, delta_t: zero, inv: zero };
    }
    let [az, bz, cz] = e.z.map(|z| avx._mm256_mul_ps(sz, z));
    let det = avx._mm256_add_ps(avx._mm256_add_ps(e.u, e.v), e.w);
    let inv = avx._mm256_div_ps(avx._mm256_set1_ps(1.0), det);
    let t = avx._mm256_mul_ps(
        avx._mm256_add_ps(
            avx._mm256_add_ps(avx._mm256_mul_ps(e.u, az), avx._mm256_mul_ps(e.v, bz)),
            avx._mm256_mul_ps(e.w, cz),
        ),
        inv,
    );
    // pbrt-v4's bound on the error of t, as the scalar test computes it.
    let abs = |x: __m256| avx._mm256_andnot_ps(avx._mm256_set1_ps(-0.0), x);
    let max3 = |[a, b, c]: [__m256; 3]| avx._mm256_max_ps(avx._mm256_max_ps(abs(a), abs(b)), abs(c));
    let splat = |x: f32| avx._mm256_set1_ps(x);
    let (max_zt, max_xt, max_yt) = (max3([az, bz, cz]), max3(e.x), max3(e.y));
    let delta_z = avx._mm256_mul_ps(splat(gamma(3)), max_zt);
    let delta_x = avx._mm256_mul_ps(splat(gamma(5)), avx._mm256_add_ps(max_xt, max_zt));
    let delta_y = avx._mm256_mul_ps(splat(gamma(5)), avx._mm256_add_ps(max_yt, max_zt));
    let delta_e = error_term(avx, 2.0, (gamma(2), [max_xt, max_yt]), [delta_y, max_xt], [delta_x, max_yt]);
    let max_e = max3([e.u, e.v, e.w]);
    let relative = error_term(avx, 3.0, (gamma(3), [max_e, max_zt]), [delta_e, max_zt], [delta_z, max_e]);
    let tiny = avx._mm256_mul_ps(splat(TINY_TERM), avx._mm256_add_ps(splat(1.0), max_zt));
    let delta_t =
        avx._mm256_add_ps(avx._mm256_mul_ps(avx._mm256_add_ps(relative, tiny), abs(inv)), splat(TINY_DISTANCE));
    let finite = |x: __m256| avx._mm256_cmp_ps::<_CMP_LT_OQ>(abs(x), splat(f32::INFINITY));
    let in_range = avx._mm256_and_ps(avx._mm256_cmp_ps::<_CMP_GE_OQ>(t, min), avx._mm256_cmp_ps::<_CMP_LE_OQ>(t, max));
    // The scalar test rejects a lane whose determinant is not finite (it is not zero: the edge functions
    // are non-zero and of one sign), or whose distance and bound are finite and put it out of the range;
    // it accepts one whose distance is in the range and beyond its finite bound. Lanes whose distance or
    // bound is not finite are the f64 plane distance's to decide.
    let bounded = avx._mm256_and_ps(finite(t), finite(delta_t));
    let out = avx._mm256_and_ps(
        bounded,
        avx._mm256_or_ps(
            avx._mm256_cmp_ps::<_CMP_GT_OQ>(avx._mm256_sub_ps(t, delta_t), max),
            avx._mm256_cmp_ps::<_CMP_LT_OQ>(avx._mm256_add_ps(t, delta_t), min),
        ),
    );
    let rejected = decided
        & avx
            ._mm256_movemask_ps(avx._mm256_or_ps(out, avx._mm256_cmp_ps::<_CMP_NLT_UQ>(abs(det), splat(f32::INFINITY))))
            as u32;
    let beyond = avx._mm256_movemask_ps(avx._mm256_and_ps(bounded, avx._mm256_cmp_ps::<_CMP_GT_OQ>(t, delta_t))) as u32;
    let kept = avx._mm256_movemask_ps(avx._mm256_and_ps(finite(det), in_range)) as u32;
    let hit = decided & kept & beyond & !rejected;
    let close = decided & !rejected & avx._mm256_movemask_ps(bounded) as u32 & !beyond;
    Verdict { hit, open: candidates & !hit & !rejected, close, t, delta_t, inv }
}

/// [`Filter::closest_of_candidates`] with the lanes' verdict, distance and barycentrics from AVX
/// registers: the candidates are taken in turn as the scalar loop takes them, the scalar test run for
/// the lanes the verdict leaves open, and an accepted lane's distance and barycentrics those the scalar
/// test reports (its distance from [`decided_distances`]; a lane beyond the narrowed range by more than
/// its error bound is one the scalar test rejects), so the answer is the scalar loop's, bit for bit.
#[inline(always)]
fn closest_of_candidates(simd: V3, mut test: Candidates, e: &Edges) -> f32 {
    let avx = simd.avx;
    let (leaf, ray, mut range) = (test.leaf, test.ray, test.range);
    let Verdict { hit, open, close, t, delta_t, inv } = verdict(simd, e, test.lanes, ray, range);
    if hit | close == 0 {
        return closest_of_candidates_scalar(Candidates { lanes: open, ..test });
    }
    // The distances the scalar test reports: refined on the vertices' plane for the accepted lanes, the
    // plane distance itself for the close lanes it accepts (those it rejects are left out).
    let refined = if hit != 0 { decided_distances(simd, leaf, ray, t, hit) } else { t };
    let (accepted_close, decided) = if close != 0 {
        let (accepted, plane) = plane_decisions(simd, leaf, ray, close);
        (accepted, avx._mm256_blendv_ps(refined, plane, lane_mask(simd, close)))
    } else {
        (0, refined)
    };
    let decided: [f32; 8] = pulp::cast(decided);
    let (t, delta_t): ([f32; 8], [f32; 8]) = (pulp::cast(t), pulp::cast(delta_t));
    let b: [[f32; 8]; 3] = [e.u, e.v, e.w].map(|x| pulp::cast(avx._mm256_mul_ps(x, inv)));
    let scalar = open & !close;
    for bit in set_bits(hit | scalar | accepted_close) {
        let i = bit as usize;
        if scalar & (1 << bit) != 0 {
            test.decide(bit, &mut range);
        } else if t[i] - delta_t[i] <= range.max {
            let t = decided[i];
            if range.contains(t) && t > 0.0 {
                test.keep(bit, TriangleHit { t, b: [b[0][i], b[1][i], b[2][i]] }, &mut range);
            }
        }
    }
    range.max
}

/// The lanes of `lanes` as an eight-lane mask: all bits of lane `j` set where bit `j` is.
#[inline(always)]
fn lane_mask(simd: V3, lanes: u32) -> __m256 {
    let avx = simd.avx;
    let bits = avx._mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let set = simd.avx2._mm256_and_si256(avx._mm256_set1_epi32(lanes as i32), bits);
    pulp::cast(simd.avx2._mm256_cmpeq_epi32(set, bits))
}

/// The accepted lanes of `$lanes` and their distances, from `$half!(half)` ([`plane_decisions_of_half`])
/// of the halves that hold a lane of `$lanes` (the others' lanes rejected, their distances zero). A
/// macro: each caller's `$half` is a macro too (see `Walk`).
macro_rules! plane_halves {
    ($simd:ident, $lanes:ident, $half:ident) => {{
        let none = $simd.sse._mm_setzero_ps();
        let (low, t_low) = if $lanes & 0x0F != 0 { $half!(0) } else { (0, none) };
        let (high, t_high) = if $lanes & 0xF0 != 0 { $half!(1) } else { (0, none) };
        ((low | high << 4) & $lanes, $simd.avx._mm256_set_m128(t_high, t_low))
    }};
}

/// The scalar test's decision of the `lanes` of `leaf` it decides by the f64 distance to the vertices'
/// plane alone (edge functions decided, the f32 distance too close to call): the lanes whose triangle
/// spans a plane, whose plane distance is finite in f32 and beyond its error bound, with that distance
/// rounded to f32 (zero in the other lanes), for the halves holding a lane of `lanes`
/// ([`plane_decisions_of_half`]). A ray leaving a triangle's surface meets it again this way, and is
/// behind it.
#[inline(always)]
fn plane_decisions(simd: V3, leaf: &Leaf, ray: &ShearedRay, lanes: u32) -> (u32, __m256) {
    let (o, d) = (splat64(simd, ray.origin), splat64(simd, ray.dir));
    // No closures here (see `Walk`).
    macro_rules! half {
        ($half:literal) => {{
            let (p0, edges) = half_edges(simd, leaf, $half);
            plane_decisions_of_half(simd, p0, edges, o, d)
        }};
    }
    plane_halves!(simd, lanes, half)
}

/// The coordinates of `v` in f64, each splatted into four lanes.
#[inline(always)]
fn splat64(simd: V3, v: Vec3A) -> [__m256d; 3] {
    let avx = simd.avx;
    [avx._mm256_set1_pd(v.x as f64), avx._mm256_set1_pd(v.y as f64), avx._mm256_set1_pd(v.z as f64)]
}

/// The first vertices of the four triangles of `leaf`'s half `half`, and their edges `p1 - p0` and
/// `p2 - p0`, in f64 (where the differences of f32 vertices are exact).
#[inline(always)]
fn half_edges(simd: V3, leaf: &Leaf, half: usize) -> ([__m256d; 3], [[__m256d; 3]; 2]) {
    let avx = simd.avx;
    // No closures here (see `Walk`).
    macro_rules! wide {
        ($k:literal, $a:literal) => {
            avx._mm256_cvtps_pd(pulp::cast(leaf.quarter($k, $a, half)))
        };
    }
    let p0 = [wide!(0, 0), wide!(0, 1), wide!(0, 2)];
    macro_rules! edge {
        ($k:literal) => {
            [
                avx._mm256_sub_pd(wide!($k, 0), p0[0]),
                avx._mm256_sub_pd(wide!($k, 1), p0[1]),
                avx._mm256_sub_pd(wide!($k, 2), p0[2]),
            ]
        };
    }
    (p0, [edge!(1), edge!(2)])
}

/// `e1 x e2`, four lanes in f64, with `Triangle::normal64`'s operations in its order.
#[inline(always)]
fn cross64(avx: pulp::core_arch::x86::Avx, e1: [__m256d; 3], e2: [__m256d; 3]) -> [__m256d; 3] {
    [
        avx._mm256_sub_pd(avx._mm256_mul_pd(e1[1], e2[2]), avx._mm256_mul_pd(e1[2], e2[1])),
        avx._mm256_sub_pd(avx._mm256_mul_pd(e1[2], e2[0]), avx._mm256_mul_pd(e1[0], e2[2])),
        avx._mm256_sub_pd(avx._mm256_mul_pd(e1[0], e2[1]), avx._mm256_mul_pd(e1[1], e2[0])),
    ]
}

/// `a - b`, four lanes of each coordinate in f64.
#[inline(always)]
fn sub64(avx: pulp::core_arch::x86::Avx, a: [__m256d; 3], b: [__m256d; 3]) -> [__m256d; 3] {
    [avx._mm256_sub_pd(a[0], b[0]), avx._mm256_sub_pd(a[1], b[1]), avx._mm256_sub_pd(a[2], b[2])]
}

/// [`plane_decisions`] of triangle `j` of `leaf` for each lane's ray (of `groups`): the same
/// operations, the triangle's edges formed once.
#[inline(always)]
fn plane_decisions_of_rays(simd: V3, leaf: &Leaf, j: usize, groups: &[FrameGroup], lanes: u32) -> (u32, __m256) {
    let (p0, edges) = triangle_edges(simd, leaf, j);
    // No closures here (see `Walk`).
    macro_rules! half {
        ($half:literal) => {{
            let (o, d) = group_rays(simd, &groups[$half]);
            plane_decisions_of_half(simd, p0, edges, o, d)
        }};
    }
    plane_halves!(simd, lanes, half)
}

/// Four lanes of [`plane_decisions`]: triangles of first vertex `p0` and edges `e1`, `e2` (in f64,
/// where the differences of f32 vertices are exact), rays from `o` along `d`. The operations of
/// `raylume_intersect`'s `plane_distance64` and `plane_distance_error` in their order: the lanes
/// accepted (four low bits) and their distances rounded to f32.
#[inline(always)]
fn plane_decisions_of_half(
    simd: V3,
    p0: [__m256d; 3],
    [e1, e2]: [[__m256d; 3]; 2],
    o: [__m256d; 3],
    d: [__m256d; 3],
) -> (u32, __m128) {
    let (avx, sse) = (simd.avx, simd.sse);
    let (zero, sign) = (avx._mm256_setzero_pd(), avx._mm256_set1_pd(-0.0));
    // No closures here (see `Walk`).
    macro_rules! abs {
        ($x:expr) => {
            avx._mm256_andnot_pd(sign, $x)
        };
    }
    macro_rules! dot {
        ($a:expr, $x:expr) => {{
            let (a, x) = ($a, $x);
            avx._mm256_add_pd(
                avx._mm256_add_pd(avx._mm256_mul_pd(a[0], x[0]), avx._mm256_mul_pd(a[1], x[1])),
                avx._mm256_mul_pd(a[2], x[2]),
            )
        }};
    }
    let n = cross64(avx, e1, e2);
    let square = dot!(n, n);
    let plane = avx._mm256_and_pd(
        avx._mm256_cmp_pd::<_CMP_GT_OQ>(square, zero),
        avx._mm256_cmp_pd::<_CMP_LT_OQ>(square, avx._mm256_set1_pd(f64::INFINITY)),
    );
    let q = sub64(avx, p0, o);
    let (den, t) = plane_quotient(avx, n, q, d);
    let t32 = avx._mm256_cvtpd_ps(t);
    // `normal64_magnitude`, then the sums of magnitudes that bound the distance's error.
    macro_rules! abs3 {
        ($v:expr) => {{
            let v = $v;
            [abs!(v[0]), abs!(v[1]), abs!(v[2])]
        }};
    }
    let (a1, a2) = (abs3!(e1), abs3!(e2));
    let magnitude = [
        avx._mm256_add_pd(avx._mm256_mul_pd(a1[1], a2[2]), avx._mm256_mul_pd(a1[2], a2[1])),
        avx._mm256_add_pd(avx._mm256_mul_pd(a1[2], a2[0]), avx._mm256_mul_pd(a1[0], a2[2])),
        avx._mm256_add_pd(avx._mm256_mul_pd(a1[0], a2[1]), avx._mm256_mul_pd(a1[1], a2[0])),
    ];
    let (mag_q, mag_d) = (dot!(magnitude, abs3!(q)), dot!(magnitude, abs3!(d)));
    let bound = avx._mm256_div_pd(
        avx._mm256_div_pd(avx._mm256_add_pd(mag_q, avx._mm256_mul_pd(abs!(t), mag_d)), abs!(den)),
        avx._mm256_set1_pd((1u64 << 48) as f64),
    );
    let finite = sse._mm_cmplt_ps(sse._mm_andnot_ps(sse._mm_set1_ps(-0.0), t32), sse._mm_set1_ps(f32::INFINITY));
    let kept = avx._mm256_and_pd(
        avx._mm256_and_pd(plane, avx._mm256_cmp_pd::<_CMP_NEQ_UQ>(den, zero)),
        avx._mm256_cmp_pd::<_CMP_GT_OQ>(t, bound),
    );
    (avx._mm256_movemask_pd(kept) as u32 & sse._mm_movemask_ps(finite) as u32, t32)
}

/// The f64 plane distances `$distance!(half)` (four lanes each) of the halves that hold a lane of
/// `$lanes` (the others' lanes zero), where finite, else the f32 distances `$t` ([`finite_or`]). A macro:
/// each caller's `$distance` is a macro too (see `Walk`).
macro_rules! halves_or {
    ($simd:ident, $lanes:ident, $t:ident, $distance:ident) => {{
        let none = $simd.sse._mm_setzero_ps();
        let plane = $simd.avx._mm256_set_m128(
            if $lanes & 0xF0 != 0 { $distance!(1) } else { none },
            if $lanes & 0x0F != 0 { $distance!(0) } else { none },
        );
        finite_or($simd, plane, $t)
    }};
}

/// [`decided_distance`](raylume_intersect::decided_distance) of every lane of `leaf` whose f32 distance
/// is `t`, with the scalar routine's operations in its order, four lanes at a time in f64: the
/// triangle's `normal64`, the distance to its plane, and `t` where that distance is not finite in f32
/// (a zero denominator makes it infinite or NaN). Only the halves holding a lane of `lanes` are
/// formed (the others' lanes are zero); within a half every lane is, so that the distances do not
/// wait for the verdict's lanes one by one.
#[inline(always)]
fn decided_distances(simd: V3, leaf: &Leaf, ray: &ShearedRay, t: __m256, lanes: u32) -> __m256 {
    let avx = simd.avx;
    let (o, d) = (splat64(simd, ray.origin), splat64(simd, ray.dir));
    // No closures here (see `Walk`).
    macro_rules! distance {
        ($half:literal) => {{
            let (p0, [e1, e2]) = half_edges(simd, leaf, $half);
            plane_distance(avx, cross64(avx, e1, e2), sub64(avx, p0, o), d)
        }};
    }
    halves_or!(simd, lanes, t, distance)
}

/// `(n . q) / (n . d)` in f64, four lanes, rounded to f32: the distance along `d` to the plane of normal
/// `n` through the point `q` away ([`plane_quotient`]).
#[inline(always)]
fn plane_distance(avx: pulp::core_arch::x86::Avx, n: [__m256d; 3], q: [__m256d; 3], d: [__m256d; 3]) -> __m128 {
    avx._mm256_cvtpd_ps(plane_quotient(avx, n, q, d).1)
}

/// `n . d` and `(n . q) / (n . d)` in f64, four lanes, with `plane_distance64`'s operations in its order.
#[inline(always)]
fn plane_quotient(
    avx: pulp::core_arch::x86::Avx,
    [nx, ny, nz]: [__m256d; 3],
    [qx, qy, qz]: [__m256d; 3],
    [dx, dy, dz]: [__m256d; 3],
) -> (__m256d, __m256d) {
    let den = avx._mm256_add_pd(
        avx._mm256_add_pd(avx._mm256_mul_pd(nx, dx), avx._mm256_mul_pd(ny, dy)),
        avx._mm256_mul_pd(nz, dz),
    );
    let num = avx._mm256_add_pd(
        avx._mm256_add_pd(avx._mm256_mul_pd(nx, qx), avx._mm256_mul_pd(ny, qy)),
        avx._mm256_mul_pd(nz, qz),
    );
    (den, avx._mm256_div_pd(num, den))
}

/// Each lane's `plane` distance where it is finite, else its f32 distance `t`.
#[inline(always)]
fn finite_or(simd: V3, plane: __m256, t: __m256) -> __m256 {
    let avx = simd.avx;
    let finite = avx._mm256_cmp_ps::<_CMP_LT_OQ>(
        avx._mm256_andnot_ps(avx._mm256_set1_ps(-0.0), plane),
        avx._mm256_set1_ps(f32::INFINITY),
    );
    avx._mm256_blendv_ps(t, plane, finite)
}

/// `k * ((c * x * y + p * q) + r * s)` for `(c, [x, y])`, `[p, q]`, `[r, s]`: the shape of both terms of
/// pbrt-v4's error bound, with the scalar test's operations in its order.
#[inline(always)]
fn error_term(
    avx: pulp::core_arch::x86::Avx,
    k: f32,
    (c, [x, y]): (f32, [__m256; 2]),
    [p, q]: [__m256; 2],
    [r, s]: [__m256; 2],
) -> __m256 {
    let first = avx._mm256_mul_ps(avx._mm256_mul_ps(avx._mm256_set1_ps(c), x), y);
    let sum = avx._mm256_add_ps(avx._mm256_add_ps(first, avx._mm256_mul_ps(p, q)), avx._mm256_mul_ps(r, s));
    avx._mm256_mul_ps(avx._mm256_set1_ps(k), sum)
}

/// Starts loading every cache line of `item` into all levels of the cache.
#[inline(always)]
fn prefetch<I>(simd: V3, item: &I) {
    let p: *const i8 = (item as *const I).cast();
    for offset in (0..std::mem::size_of::<I>()).step_by(64) {
        simd.sse._mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.wrapping_add(offset));
    }
}

/// Starts loading every cache line of `items` into all levels of the cache.
#[inline(always)]
pub(super) fn prefetch_slice<T>(simd: V3, items: &[T]) {
    let p: *const i8 = items.as_ptr().cast();
    for offset in (0..std::mem::size_of_val(items)).step_by(64) {
        simd.sse._mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.wrapping_add(offset));
    }
}

/// Whether a lane the any-hit verdict leaves open is hit: the close lanes by their plane distance
/// ([`plane_decisions`]) within the range, the others by the scalar test.
struct OccludedOpen<'a> {
    simd: V3,
    leaf: &'a Leaf,
    open: u32,
    close: u32,
    ray: &'a ShearedRay,
    range: Interval,
}

impl Exact for OccludedOpen<'_> {
    type Output = bool;

    #[inline(always)]
    fn run(self) -> bool {
        let Self { simd, leaf, open, close, ray, range } = self;
        if close != 0 {
            let (accepted, t) = plane_decisions(simd, leaf, ray, close);
            let t: [f32; 8] = pulp::cast(t);
            if set_bits(accepted).any(|bit| range.contains(t[bit as usize]) && t[bit as usize] > 0.0) {
                return true;
            }
        }
        let scalar = open & !close;
        scalar != 0 && AnyCandidateHit { leaf, lanes: scalar, ray, range }.run()
    }
}

impl Filter for V3 {
    #[inline(always)]
    fn prefetch(self, leaf: &Leaf) {
        prefetch(self, leaf);
    }

    #[inline(always)]
    fn exact<E: Exact>(self, test: E) -> E::Output {
        self.vectorize(Compiled(test))
    }

    /// The leaf's edge functions, for the verdict of its candidates.
    type Prepared = Edges;

    /// [`Portable`](super::leaf::Portable)'s filter with the very operations of
    /// [`candidates`](super::triangles::candidates), on all eight lanes of a leaf at once.
    #[inline(always)]
    fn prepare(self, leaf: &Leaf, count: usize, ray: &ShearedRay) -> (u32, Edges) {
        let e = edges(self, leaf, ray);
        (candidate_lanes(self, &e, count), e)
    }

    /// The vector [`Verdict`] of the leaf's lanes; the scalar test for the lanes it leaves open.
    #[inline(always)]
    fn leaf_occluded(self, leaf: &Leaf, count: usize, ray: &ShearedRay, range: Interval) -> bool {
        let e = edges(self, leaf, ray);
        let Verdict { hit, open, close, .. } = verdict(self, &e, candidate_lanes(self, &e, count), ray, range);
        hit != 0 || (open != 0 && exact_out_of_line(self, OccludedOpen { simd: self, leaf, open, close, ray, range }))
    }

    #[inline(always)]
    fn closest_of_candidates(self, test: Candidates, e: &Edges) -> f32 {
        closest_of_candidates(self, test, e)
    }

    /// The block's rays together, a triangle at a time ([`ClosestBlock`]).
    const BLOCKS: bool = true;

    #[inline(always)]
    fn closest_in_block(self, leaves: &[Leaf], (first, count): (usize, usize), t_min: f32, block: Block<Found>) {
        exact_out_of_line(self, ClosestBlock { simd: self, leaves, first, count, t_min, block });
    }

    #[inline(always)]
    fn occluded_in_block(self, leaf: &Leaf, count: usize, block: Block<bool>) {
        exact_out_of_line(self, OccludedBlock { simd: self, leaf, count, block });
    }
}

/// Up to eight rays that share their frame's axes, lane by lane, for the test of one triangle at a
/// time: the origins along the frame's axes and the shears, each as [`edges`] splats them for one
/// ray.
struct BlockFrame {
    simd: V3,
    axes: [usize; 3],
    origin: [__m256; 3],
    shear: [__m256; 3],
}

impl BlockFrame {
    #[inline(always)]
    fn new(simd: V3, groups: &[FrameGroup], axes: [usize; 3]) -> Self {
        let [kx, ky, kz] = [axes[0].min(2), axes[1].min(2), axes[2].min(2)];
        let (low, high) = (&groups[0], &groups[1]);
        // Written out rather than by array maps, which compile out of line, with the intrinsics as
        // calls (see `Walk`).
        let origin = |k: usize| eight(simd, low.rays.lanes.origin[k], high.rays.lanes.origin[k]);
        let shear = |a: usize| eight(simd, low.shear[a], high.shear[a]);
        Self {
            simd,
            axes: [kx, ky, kz],
            origin: [origin(kx), origin(ky), origin(kz)],
            shear: [shear(0), shear(1), shear(2)],
        }
    }

    /// [`Edges`] of triangle `j` of `leaf` for each lane's ray, with the very operations of [`edges`].
    #[inline(always)]
    fn edges(&self, leaf: &Leaf, j: usize) -> Edges {
        let avx = self.simd.avx;
        let [kx, ky, kz] = self.axes;
        let [ox, oy, oz] = self.origin;
        let [sx, sy, _] = self.shear;
        // No closures here (see `Walk`).
        macro_rules! sheared {
            ($k:literal) => {{
                let x = avx._mm256_set1_ps(leaf.v[$k][kx][j]);
                let y = avx._mm256_set1_ps(leaf.v[$k][ky][j]);
                let z = avx._mm256_set1_ps(leaf.v[$k][kz][j]);
                let az = avx._mm256_sub_ps(z, oz);
                (
                    avx._mm256_sub_ps(avx._mm256_sub_ps(x, ox), avx._mm256_mul_ps(sx, az)),
                    avx._mm256_sub_ps(avx._mm256_sub_ps(y, oy), avx._mm256_mul_ps(sy, az)),
                    az,
                )
            }};
        }
        let ((ax, ay, az), (bx, by, bz), (cx, cy, cz)) = (sheared!(0), sheared!(1), sheared!(2));
        edge_functions(self.simd, [ax, bx, cx], [ay, by, cy], [az, bz, cz])
    }

    /// The edges and the [`Verdict`] of triangle `j` of `leaf` for the rays `lanes`, each within
    /// `[min, t_max]` (lane by lane); `None` where no ray is a candidate.
    #[inline(always)]
    fn verdict(&self, leaf: &Leaf, j: usize, lanes: u32, min: __m256, t_max: &[f32]) -> Option<(Edges, Verdict)> {
        let e = self.edges(leaf, j);
        let candidates = lanes & !rejected_lanes(self.simd, &e);
        if candidates == 0 {
            return None;
        }
        let mut ends = [0.0; 8];
        ends.copy_from_slice(&t_max[..8]);
        let v = verdict_lanes(self.simd, &e, candidates, self.shear[2], min, pulp::cast(ends));
        Some((e, v))
    }
}

/// The eight lanes of two groups' four.
#[inline(always)]
fn eight(simd: V3, low: Vec4, high: Vec4) -> __m256 {
    simd.avx._mm256_set_m128(high.into(), low.into())
}

/// [`decided_distances`] of triangle `j` of `leaf` for each lane's ray (of `groups`), whose f32
/// distance is `t`: the same operations, the triangle's normal formed once.
#[inline(always)]
fn decided_distances_of_rays(simd: V3, leaf: &Leaf, j: usize, groups: &[FrameGroup], t: __m256, lanes: u32) -> __m256 {
    let avx = simd.avx;
    let (p0, [e1, e2]) = triangle_edges(simd, leaf, j);
    let n = cross64(avx, e1, e2);
    // No closures here (see `Walk`).
    macro_rules! distance {
        ($half:literal) => {{
            let (o, d) = group_rays(simd, &groups[$half]);
            plane_distance(avx, n, sub64(avx, p0, o), d)
        }};
    }
    halves_or!(simd, lanes, t, distance)
}

/// Triangle `j` of `leaf` as [`half_edges`] gives four: its first vertex and its edges in f64, each
/// splatted into four lanes.
#[inline(always)]
fn triangle_edges(simd: V3, leaf: &Leaf, j: usize) -> ([__m256d; 3], [[__m256d; 3]; 2]) {
    let avx = simd.avx;
    // No closures here (see `Walk`).
    macro_rules! vertex {
        ($k:literal) => {
            [leaf.v[$k][0][j] as f64, leaf.v[$k][1][j] as f64, leaf.v[$k][2][j] as f64]
        };
    }
    let (p0, p1, p2) = (vertex!(0), vertex!(1), vertex!(2));
    macro_rules! splat {
        ($x:expr) => {{
            let x: [f64; 3] = $x;
            [avx._mm256_set1_pd(x[0]), avx._mm256_set1_pd(x[1]), avx._mm256_set1_pd(x[2])]
        }};
    }
    let e1 = splat!([p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]]);
    let e2 = splat!([p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]]);
    (splat!(p0), [e1, e2])
}

/// The origins and directions of `group`'s four rays in f64, lane by lane.
#[inline(always)]
fn group_rays(simd: V3, group: &FrameGroup) -> ([__m256d; 3], [__m256d; 3]) {
    let avx = simd.avx;
    let ([ox, oy, oz], [dx, dy, dz]) = (group.rays.lanes.origin, group.rays.lanes.dir);
    (
        [avx._mm256_cvtps_pd(ox.into()), avx._mm256_cvtps_pd(oy.into()), avx._mm256_cvtps_pd(oz.into())],
        [avx._mm256_cvtps_pd(dx.into()), avx._mm256_cvtps_pd(dy.into()), avx._mm256_cvtps_pd(dz.into())],
    )
}

/// [`Filter::closest_in_block`]: each triangle of the leaf in turn for all the block's rays at once, its
/// edge functions and [`Verdict`] lane by lane, then what [`closest_of_candidates`] does with each ray's
/// lane (the accepted lanes' checks eight at a time, the open lanes and ties one by one): each ray takes
/// the leaf's triangles in the order its own test takes them, each decided as the scalar test decides it
/// within the ray's range at that point, so each ray's answer is its own test's, bit for bit.
struct ClosestBlock<'a, 'b> {
    simd: V3,
    leaves: &'a [Leaf],
    first: usize,
    count: usize,
    t_min: f32,
    block: Block<'b, Found>,
}

impl Exact for ClosestBlock<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        let Self { simd, leaves, first, count, t_min, block } = self;
        let Block { lanes, axes, groups, sheared, t_max, kept } = block;
        let avx = simd.avx;
        let leaf = &leaves[first];
        let frame = BlockFrame::new(simd, groups, axes);
        let min = avx._mm256_set1_ps(t_min);
        for j in 0..count {
            let Some((e, Verdict { hit, open, close, t, delta_t, inv })) = frame.verdict(leaf, j, lanes, min, t_max)
            else {
                continue;
            };
            let bit = j as u32;
            // The close lanes by their plane distance, as the scalar test takes them: within the
            // distance's bound of the range (the verdict's check), the distance in the range and positive.
            if close != 0 {
                let (accepted, plane) = plane_decisions_of_rays(simd, leaf, j, groups, close);
                let plane: [f32; 8] = pulp::cast(plane);
                let b: [[f32; 8]; 3] = [e.u, e.v, e.w].map(|x| pulp::cast(avx._mm256_mul_ps(x, inv)));
                for lane in set_bits(accepted) {
                    let l = lane as usize;
                    let mut range = Interval::new(t_min, t_max[l]);
                    if range.contains(plane[l]) && plane[l] > 0.0 {
                        let h = TriangleHit { t: plane[l], b: [b[0][l], b[1][l], b[2][l]] };
                        Candidates { leaf, leaves, first, lanes: 0, ray: &sheared[l], range, found: &mut kept[l] }
                            .keep(bit, h, &mut range);
                        t_max[l] = range.max;
                    }
                }
            }
            // The other lanes the verdict leaves open: the scalar test.
            for lane in set_bits(open & !close) {
                let l = lane as usize;
                let mut range = Interval::new(t_min, t_max[l]);
                Candidates { leaf, leaves, first, lanes: 0, ray: &sheared[l], range, found: &mut kept[l] }
                    .decide(bit, &mut range);
                t_max[l] = range.max;
            }
            if hit == 0 {
                continue;
            }
            // The accepted lanes, as `Candidates::keep` takes them, for all lanes at once: within the
            // distance's bound of the range, the reported distance in the range, finite and positive.
            let decided = decided_distances_of_rays(simd, leaf, j, groups, t, hit);
            let mut ends = [0.0; 8];
            ends.copy_from_slice(&t_max[..8]);
            let ends: __m256 = pulp::cast(ends);
            // No closures here (see `Walk`).
            macro_rules! lanes {
                ($cmp:ident, $a:expr, $b:expr) => {
                    avx._mm256_movemask_ps(avx._mm256_cmp_ps::<$cmp>($a, $b)) as u32
                };
            }
            let accepted = hit
                & lanes!(_CMP_LE_OQ, avx._mm256_sub_ps(t, delta_t), ends)
                & lanes!(_CMP_LE_OQ, min, decided)
                & lanes!(_CMP_LE_OQ, decided, ends)
                & lanes!(_CMP_LT_OQ, decided, avx._mm256_set1_ps(f32::INFINITY))
                & lanes!(_CMP_LT_OQ, avx._mm256_setzero_ps(), decided);
            if accepted == 0 {
                continue;
            }
            // A lane's range ends at its closest hit so far, if it has one: a distance below that end
            // wins outright; one at it goes to the ids.
            let closer = accepted & lanes!(_CMP_LT_OQ, decided, ends);
            let decided: [f32; 8] = pulp::cast(decided);
            let b: [[f32; 8]; 3] = [e.u, e.v, e.w].map(|x| pulp::cast(avx._mm256_mul_ps(x, inv)));
            let hit_of = |l: usize| TriangleHit { t: decided[l], b: [b[0][l], b[1][l], b[2][l]] };
            for lane in set_bits(closer) {
                let l = lane as usize;
                kept[l] = Some((hit_of(l), first as u32, bit));
                t_max[l] = decided[l];
            }
            for lane in set_bits(accepted & !closer) {
                let l = lane as usize;
                let mut range = Interval::new(t_min, t_max[l]);
                Candidates { leaf, leaves, first, lanes: 0, ray: &sheared[l], range, found: &mut kept[l] }.keep(
                    bit,
                    hit_of(l),
                    &mut range,
                );
                t_max[l] = range.max;
            }
        }
    }
}

/// [`Filter::occluded_in_block`]: each triangle of the leaf in turn for the block's rays not yet
/// occluded, its [`Verdict`] lane by lane and the scalar test for the lanes it leaves open, as
/// [`Filter::leaf_occluded`] decides each ray's lanes.
struct OccludedBlock<'a, 'b> {
    simd: V3,
    leaf: &'a Leaf,
    count: usize,
    block: Block<'b, bool>,
}

impl Exact for OccludedBlock<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn run(self) {
        let Self { simd, leaf, count, block } = self;
        let Block { lanes, axes, groups, sheared, t_max, kept } = block;
        let frame = BlockFrame::new(simd, groups, axes);
        let zero = simd.avx._mm256_setzero_ps();
        let mut active = lanes;
        for j in 0..count {
            let Some((_, Verdict { hit, open, close, .. })) = frame.verdict(leaf, j, active, zero, t_max) else {
                continue;
            };
            let mut occluded = hit;
            if close != 0 {
                let (accepted, t) = plane_decisions_of_rays(simd, leaf, j, groups, close);
                let t: [f32; 8] = pulp::cast(t);
                for lane in set_bits(accepted) {
                    let (l, t) = (lane as usize, t[lane as usize]);
                    if Interval::new(0.0, t_max[l]).contains(t) && t > 0.0 {
                        occluded |= 1 << lane;
                    }
                }
            }
            for lane in set_bits(open & !close) {
                let l = lane as usize;
                if raylume_intersect::watertight_hits(
                    &leaf.triangle(j as u32),
                    &sheared[l],
                    Interval::new(0.0, t_max[l]),
                ) {
                    occluded |= 1 << lane;
                }
            }
            for lane in set_bits(occluded) {
                kept[lane as usize] = true;
                t_max[lane as usize] = f32::NEG_INFINITY;
            }
            active &= !occluded;
            if active == 0 {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;
    use raylume_geometry::{Triangle, Vec3A};

    use super::super::kernel::MAX_TRIANGLE_LEAF;
    use super::super::leaf::Portable;
    use super::super::triangles::tests::arb_point;
    use super::super::wide::BoxRay;
    use super::*;

    /// The vector verdict decides almost every hit and miss itself: of rays aimed at random points of
    /// random triangles (and of the plane around them), at most one lane in a hundred is left open.
    #[test]
    fn vector_verdict_leaves_few_lanes_open() {
        use rand_core::{Rng, SeedableRng};
        let Some(simd) = V3::try_new() else { return };
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        let mut unit = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        let (mut lanes, mut open, mut hits) = (0, 0, 0);
        for _ in 0..2000 {
            let tris: Vec<_> = (0..8)
                .map(|i| {
                    let mut p = || Vec3A::new(unit() * 4.0 - 2.0, unit() * 4.0 - 2.0, unit() * 4.0 - 2.0);
                    (Triangle::new(p(), p(), p()), i)
                })
                .collect();
            let (t, _) = tris[0];
            let (a, b) = (unit() * 1.5, unit() * 1.5);
            let target = t.p[0] + (t.p[1] - t.p[0]) * a + (t.p[2] - t.p[0]) * b;
            let o = Vec3A::new(unit() * 20.0 - 10.0, unit() * 20.0 - 10.0, 10.0);
            let ray = ShearedRay::new(&Ray::new(o, target - o)).unwrap();
            let leaf = Leaf::new(tris.iter().copied());
            let v = simd.vectorize(|| {
                let e = edges(simd, &leaf, &ray);
                verdict(simd, &e, candidate_lanes(simd, &e, 8), &ray, Interval::POSITIVE)
            });
            lanes += 8;
            open += v.open.count_ones();
            hits += v.hit.count_ones();
        }
        println!("{hits} hits and {open} open lanes of {lanes}");
        assert!(hits > lanes / 16, "too few hits to tell: {hits}");
        assert!(open * 100 <= lanes, "{open} of {lanes} lanes left to the scalar test");
    }

    /// A ray leaving a triangle's surface, spawned off its hit point as a renderer spawns it, finds
    /// that triangle too close to call in f32: the verdict marks it close, the plane distance puts
    /// the ray behind it, and no lane goes to the scalar test.
    #[test]
    fn rays_leaving_a_triangle_are_decided_in_vector_registers() {
        use rand_core::{Rng, SeedableRng};
        let Some(simd) = V3::try_new() else { return };
        let mut rng = rand_pcg::Pcg32::seed_from_u64(11);
        let mut unit = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        let (mut close, mut scalar) = (0, 0);
        for i in 0..2000 {
            let mut p = || Vec3A::new(unit() * 4.0 - 2.0, unit() * 4.0 - 2.0, unit() * 4.0 - 2.0);
            let tri = Triangle::new(p(), p(), p());
            if !raylume_intersect::has_unit_normal(&tri) {
                continue;
            }
            let at = TriangleHit { t: 1.0, b: [0.2, 0.3, 0.5] }.hit(&tri);
            let side = if i % 2 == 0 { at.normal } else { -at.normal };
            let o = raylume_geometry::offset_ray_origin(at.point, at.error, side);
            let dir = (p() + side * 3.0).normalize();
            let dir = if dir.dot(side) > 0.0 { dir } else { -dir };
            let ray = ShearedRay::new(&Ray::new(o, dir)).unwrap();
            let leaf = Leaf::new([(tri, 0)]);
            let (v, occluded, closest) = simd.vectorize(|| {
                let e = edges(simd, &leaf, &ray);
                let v = verdict(simd, &e, candidate_lanes(simd, &e, 1), &ray, Interval::POSITIVE);
                let (_, closest) = closest(simd, &leaf, 1, &ray, Interval::POSITIVE);
                (v, simd.leaf_occluded(&leaf, 1, &ray, Interval::POSITIVE), closest)
            });
            assert_eq!((v.hit, occluded, closest.is_some()), (0, false, false), "ray {i} meets the surface it leaves");
            close += v.close.count_ones();
            scalar += (v.open & !v.close).count_ones();
        }
        assert!(close > 1000, "{close} rays leaving their triangle marked close");
        assert!(scalar * 100 <= close, "{scalar} of them left to the scalar test");
    }

    /// `filter`'s closest hit among the candidate `lanes` of `leaf` (as leaf number 3), and the new end
    /// of the range.
    #[allow(clippy::type_complexity)]
    fn closest<F: Filter>(
        filter: F,
        leaf: &Leaf,
        lanes: u32,
        ray: &ShearedRay,
        range: Interval,
    ) -> (f32, Option<(TriangleHit, u32, u32)>) {
        let mut found = None;
        let leaves = std::slice::from_ref(leaf);
        let test = Candidates { leaf, leaves, first: 0, lanes, ray, range, found: &mut found };
        let (_, prepared) = filter.prepare(leaf, MAX_TRIANGLE_LEAF, ray);
        let end = filter.closest_of_candidates(test, &prepared);
        (end, found)
    }

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

    /// Checks an eight-wide box test's answer for `boxes` against `four`'s answer for each half.
    fn matches_halves(
        (near, mask): ([f32; 8], u32),
        boxes: &[(Vec3A, Vec3A)],
        four: impl Fn(&WideNode<4>) -> ([f32; 4], u32),
    ) -> Result<(), TestCaseError> {
        for half in 0..2 {
            let part = &boxes[(4 * half).min(boxes.len())..(4 * half + 4).min(boxes.len())];
            let (near4, mask4) = four(&WideNode::of_boxes(part));
            prop_assert_eq!((mask >> (4 * half)) & 15, mask4);
            for slot in 0..4 {
                if mask4 & (1 << slot) != 0 {
                    prop_assert_eq!(near[4 * half + slot].to_bits(), near4[slot].to_bits());
                }
            }
        }
        Ok(())
    }

    /// Up to eight boxes with small integer corners: shared faces and origins on faces are common.
    fn arb_boxes() -> impl Strategy<Value = Vec<(Vec3A, Vec3A)>> {
        let corner = || prop::array::uniform3(-3i8..=3).prop_map(|c| Vec3A::from_array(c.map(f32::from)));
        prop::collection::vec((corner(), corner()), 0..=8)
    }

    /// Zeros of both signs, a subnormal, small integers (origins on faces) and any value.
    fn arb_component() -> impl Strategy<Value = f32> {
        prop_oneof![Just(0.0f32), Just(-0.0f32), Just(1e-40f32), (-3i8..=3).prop_map(f32::from), -10.0f32..10.0]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The eight-wide box test gives each child the entry distance and the verdict of the four-wide
        /// one: axis-parallel and subnormal directions, origins on faces and empty slots included. The
        /// any-hit walks' test meets every child it meets, with the same verdicts and entry distances
        /// bit for bit wherever the direction crosses every slab (a direction parallel to a slab, its
        /// origin on one of the slab's planes, may let it meet more).
        #[test]
        fn eight_wide_box_test_is_the_four_wide_one(
            boxes in arb_boxes(),
            o in prop::array::uniform3(arb_component()),
            d in prop::array::uniform3(arb_component()),
            t_range in (0.0f32..2.0, prop_oneof![Just(f32::INFINITY), 0.0f32..20.0]),
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let ray = Ray::new(Vec3A::from_array(o), Vec3A::from_array(d));
            if !ray.is_valid() {
                return Ok(());
            }
            let node = WideNode::<8>::of_boxes(&boxes);
            let (eight, any) = simd.vectorize(|| {
                let r = BoxRay8::new(simd, &ray);
                (r.intersect(&node, t_range.0, t_range.1), r.intersect_any(&node, t_range.0, t_range.1))
            });
            let four = BoxRay::new(&ray);
            matches_halves(eight, &boxes, |node| four.intersect(node, t_range.0, t_range.1))?;
            prop_assert_eq!(eight.1 & !any.1, 0, "a child met only by the closest-hit walks' test");
            if super::super::wide::crosses_every_slab(ray.dir) {
                prop_assert_eq!(eight.1, any.1);
                for slot in set_bits(eight.1) {
                    prop_assert_eq!(eight.0[slot as usize].to_bits(), any.0[slot as usize].to_bits());
                }
            }
        }

        /// The spheres' roots compiled with AVX2 are the portable ones, bit for bit: rays from inside,
        /// from the surface and from far off, spheres from 1e-20 (beyond the f32 routine) to 1e6,
        /// empty and partial lanes, closest-hit and occlusion ranges.
        #[test]
        fn vector_sphere_roots_are_the_portable_ones(
            spheres in prop::collection::vec((prop::array::uniform3(-4.0f32..4.0), 0.01f32..3.0), 0..=4),
            scale in prop_oneof![Just(1.0f32), Just(1e-20), Just(1e-4), Just(1e6)],
            o in prop::array::uniform3(arb_component()),
            d in prop::array::uniform3(arb_component()),
            on in 0usize..5,
            aim in 0usize..5,
            t_range in (prop_oneof![Just(0.0f32), 0.0f32..2.0], prop_oneof![Just(f32::INFINITY), 0.0f32..20.0]),
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let spheres: Vec<raylume_geometry::Sphere> = spheres
                .iter()
                .map(|&(c, r)| raylume_geometry::Sphere { center: Vec3A::from_array(c) * scale, radius: r * scale })
                .collect();
            // Origins on a sphere (its surface along the direction) as often as off them, and
            // directions towards a point near a sphere as often as any.
            let d = match spheres.get(aim) {
                Some(s) => s.center + Vec3A::from_array(d) * (0.4 * s.radius) - Vec3A::from_array(o) * scale,
                None => Vec3A::from_array(d),
            };
            let o = match spheres.get(on) {
                Some(s) => s.center + d.normalize_or(Vec3A::X) * s.radius,
                None => Vec3A::from_array(o) * scale,
            };
            let Some((ray, _)) = Ray::new(o, d).canonical() else { return Ok(()) };
            let lanes = raylume_intersect::SphereLanes::new(&spheres);
            let vector = simd.vectorize(|| raylume_intersect::spheres_roots(&lanes, &ray, t_range.0, t_range.1));
            let portable = raylume_intersect::spheres_roots(&lanes, &ray, t_range.0, t_range.1);
            prop_assert_eq!((vector.hit, vector.undecided), (portable.hit, portable.undecided));
            for lane in set_bits(portable.hit) {
                prop_assert_eq!(vector.t.to_array()[lane as usize].to_bits(), portable.t.to_array()[lane as usize].to_bits());
            }
        }

        /// The AVX check of a run of rays answers as each ray's own checks.
        #[test]
        fn vector_canonical_signs_are_each_rays_checks(rays in super::super::stream::tests::arb_run()) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let frustum = canonical_frustum(simd, &rays);
            prop_assert_eq!(frustum.map(|f| f.negative), super::super::stream::tests::each_rays_checks(&rays));
        }

        /// The frustum gathered with the checks is the one made from the rays, bit for bit: origins
        /// anywhere (zeros of both signs among them), directions of one octant.
        #[test]
        fn vector_frustum_is_the_rays_frustum(
            rays in prop::collection::vec(
                (prop::array::uniform3(prop_oneof![Just(0.0f32), Just(-0.0f32), -8.0f32..8.0]), prop::array::uniform3(0.01f32..1.0)),
                1..=64,
            ),
            signs in prop::array::uniform3(any::<bool>()),
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let flip = Vec3A::from_array(signs.map(|s| if s { -1.0 } else { 1.0 }));
            let rays: Vec<Ray> = rays
                .iter()
                .map(|(o, d)| Ray::new(Vec3A::from_array(*o), (Vec3A::from_array(*d) * flip).normalize()))
                .collect();
            let Some(negative) = super::super::stream::canonical_signs(&rays) else { return Ok(()) };
            let vector = canonical_frustum(simd, &rays);
            prop_assert!(vector.is_some());
            // `Debug` writes every value exactly, zeros' signs included.
            prop_assert_eq!(format!("{:?}", vector.unwrap()), format!("{:?}", Frustum::new(&rays, negative)));
        }

        /// The packet's eight-wide box test is the four-wide one on each half of the children.
        #[test]
        fn eight_wide_frustum_is_the_four_wide_one(
            boxes in arb_boxes(),
            origins in prop::collection::vec(prop::array::uniform3(-6.0f32..6.0), 1..=6),
            dirs in prop::collection::vec(prop::array::uniform3(0.001f32..1.0), 1..=6),
            signs in prop::array::uniform3(any::<bool>()),
            t_range in (0.0f32..2.0, prop_oneof![Just(f32::INFINITY), 0.0f32..20.0]),
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let flip = Vec3A::from_array(signs.map(|s| if s { -1.0 } else { 1.0 }));
            let rays: Vec<Ray> = dirs.iter().zip(origins.iter().cycle()).map(|(d, o)| Ray::new(Vec3A::from_array(*o), Vec3A::from_array(*d) * flip)).collect();
            let node = WideNode::<8>::of_boxes(&boxes);
            let eight = simd.vectorize(|| Frustum8::new(simd, &Frustum::new(&rays, signs)).intersect(&node, t_range.0, t_range.1));
            let four = Frustum::new(&rays, signs);
            matches_halves(eight, &boxes, |node| four.intersect(node, t_range.0, t_range.1))?;
        }

        /// The eight-lane filter of a leaf of one to eight triangles finds the candidates the
        /// four-lane one finds, rays through vertices and edges included.
        #[test]
        fn eight_lanes_filter_as_four(
            verts in prop::collection::vec(prop::array::uniform3(arb_point()), 1..=8),
            o in arb_point(),
            target in arb_point(),
            through in prop::option::of((0usize..8, 0usize..3, prop_oneof![Just(0.0f32), Just(0.5f32), 0.0f32..1.0])),
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let target = match through {
                Some((t, e, s)) => {
                    let v = verts[t % verts.len()];
                    v[e] + (v[(e + 1) % 3] - v[e]) * s
                }
                None => target,
            };
            prop_assume!(target != o);
            let Some(ray) = ShearedRay::new(&Ray::new(o, target - o)) else { return Ok(()) };
            let tris: Vec<_> = verts.iter().enumerate().map(|(i, v)| (Triangle::new(v[0], v[1], v[2]), i as u32)).collect();
            let leaf = Leaf::new(tris.iter().copied());
            let expected = Portable.leaf_candidates(&leaf, tris.len(), &ray);
            let got = simd.vectorize(|| simd.leaf_candidates(&leaf, tris.len(), &ray));
            prop_assert_eq!(got, expected);
        }

        /// Each lane the vector verdict decides is decided as the scalar watertight test decides it, and
        /// the leaf's answer is the scalar one: rays through vertices and edges, rays starting on a
        /// triangle, large and small scales, meshes far from the origin and short ranges included.
        #[test]
        fn vector_verdict_is_the_scalar_one(
            verts in prop::collection::vec(prop::array::uniform3(arb_point()), 1..=8),
            scale in prop_oneof![Just(1.0f32), Just(1e-8f32), Just(1e8f32), Just(3e-4f32), Just(2f32.powi(60)), Just(2f32.powi(-60))],
            shift in prop_oneof![Just(Vec3A::ZERO), Just(Vec3A::new(1e5, -3e4, 7e4)), Just(Vec3A::splat(-1e-3))],
            o in arb_point(),
            target in arb_point(),
            through in prop::option::of((0usize..8, 0usize..3, prop_oneof![Just(0.0f32), Just(0.5f32), 0.0f32..1.0])),
            start in 0u8..4,
            range in (prop_oneof![Just(0.0f32), 0.0f32..2.0], prop_oneof![Just(f32::INFINITY), Just(f32::MAX), 0.0f32..20.0]),
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let tris: Vec<_> = verts
                .iter()
                .map(|v| Triangle::new((v[0] + shift) * scale, (v[1] + shift) * scale, (v[2] + shift) * scale))
                .filter(raylume_intersect::has_unit_normal)
                .enumerate()
                .map(|(i, t)| (t, i as u32))
                .collect();
            prop_assume!(!tris.is_empty());
            let aim = |i: usize, e: usize, s: f32| {
                let t = tris[i % tris.len()].0;
                t.p[e] + (t.p[(e + 1) % 3] - t.p[e]) * s
            };
            let target = match through {
                Some((i, e, s)) => aim(i, e, s),
                None => (target + shift) * scale,
            };
            // A ray leaving the first triangle's centroid (its own surface within the error bound), or
            // leaving it from either side as a renderer spawns it, off the point's error box.
            let centre = TriangleHit { t: 1.0, b: [1.0 / 3.0; 3] }.hit(&tris[0].0);
            let o = match start {
                0 => (o + shift) * scale,
                1 => (tris[0].0.p[0] + tris[0].0.p[1] + tris[0].0.p[2]) / 3.0,
                2 => raylume_geometry::offset_ray_origin(centre.point, centre.error, centre.normal),
                _ => raylume_geometry::offset_ray_origin(centre.point, centre.error, -centre.normal),
            };
            prop_assume!(target != o && (target - o).is_finite());
            let Some(ray) = ShearedRay::new(&Ray::new(o, target - o)) else { return Ok(()) };
            let range = Interval::new(range.0 * scale, range.1 * scale);
            let leaf = Leaf::new(tris.iter().copied());
            let Verdict { hit, open, .. } = simd.vectorize(|| {
                let e = edges(simd, &leaf, &ray);
                verdict(simd, &e, candidate_lanes(simd, &e, tris.len()), &ray, range)
            });
            prop_assert_eq!(hit & open, 0);
            prop_assert_eq!((hit | open) >> tris.len(), 0);
            for (bit, (t, _)) in tris.iter().enumerate() {
                let scalar = raylume_intersect::watertight_hits(t, &ray, range);
                if (hit | open) & (1 << bit) == 0 {
                    prop_assert!(!scalar, "lane {} rejected, the scalar test hits it", bit);
                }
                if hit & (1 << bit) != 0 {
                    prop_assert!(scalar, "lane {} accepted, the scalar test misses it", bit);
                }
            }
            let expected = Portable.leaf_occluded(&leaf, tris.len(), &ray, range);
            prop_assert_eq!(simd.vectorize(|| simd.leaf_occluded(&leaf, tris.len(), &ray, range)), expected);
            // The closest hit: the same hit, distance and barycentrics, bit for bit, and the same
            // end of the range, as the scalar loop over the candidates.
            let lanes = Portable.leaf_candidates(&leaf, tris.len(), &ray);
            let (end, scalar) = closest(Portable, &leaf, lanes, &ray, range);
            let (got, vector) = simd.vectorize(|| closest(simd, &leaf, lanes, &ray, range));
            let bits = |f: Option<(TriangleHit, u32, u32)>| {
                f.map(|(h, leaf, bit)| (h.t.to_bits(), h.b.map(f32::to_bits), leaf, bit))
            };
            prop_assert_eq!(got.to_bits(), end.to_bits());
            prop_assert_eq!(bits(vector), bits(scalar));
            // Ranges ending a few ulps around the hit, where the refined distance may fall outside the
            // range while the unrefined one is inside.
            if let Some((h, _, _)) = scalar {
                for ulps in -3i32..=3 {
                    let max = f32::from_bits((h.t.to_bits() as i32 + ulps) as u32);
                    let range = range.with_max(max);
                    let (end, scalar) = closest(Portable, &leaf, lanes, &ray, range);
                    let (got, vector) = simd.vectorize(|| closest(simd, &leaf, lanes, &ray, range));
                    prop_assert_eq!(got.to_bits(), end.to_bits());
                    prop_assert_eq!(bits(vector), bits(scalar));
                    let expected = Portable.leaf_occluded(&leaf, tris.len(), &ray, range);
                    prop_assert_eq!(simd.vectorize(|| simd.leaf_occluded(&leaf, tris.len(), &ray, range)), expected);
                }
            }
        }

        /// The vector push leaves the stack as the scalar one does in closest-hit walks (the nearest
        /// child returned, the others farthest first, equal distances and signed zeros included), and
        /// in any-hit walks returns the first hit child and pushes each other one once, with its
        /// distance; entries below the top are kept.
        #[test]
        fn vector_push_is_the_scalar_push(
            near in prop::array::uniform8(arb_distance()),
            mask in 1u32..256,
            below in 0usize..6,
        ) {
            let Some(simd) = V3::try_new() else { return Ok(()) };
            let ray = BoxRay8::new(simd, &Ray::new(Vec3A::ZERO, Vec3A::ONE));
            let mut node = WideNode::<8>::EMPTY;
            node.child = std::array::from_fn(|i| 100 + i as u32);
            let fresh = || ([7u32; 24], [-1.0f32; 24]);
            let run = |any: bool, scalar: bool| {
                let (mut child, mut dist) = fresh();
                let mut stack = Stack { child: &mut child, near: &mut dist };
                let mut sp = below;
                let go = match (any, scalar) {
                    (false, false) => simd.vectorize(|| ray.push::<false>(&node, near, mask, &mut stack, &mut sp)),
                    (true, false) => simd.vectorize(|| ray.push::<true>(&node, near, mask, &mut stack, &mut sp)),
                    (_, true) => Scalar.push::<false>(&node, near, mask, &mut stack, &mut sp),
                };
                (go, sp, child[..sp].to_vec(), dist[..sp].iter().map(|d| d.to_bits()).collect::<Vec<_>>())
            };
            prop_assert_eq!(run(false, false), run(false, true));
            let (go, sp, child, dist) = run(true, false);
            prop_assert_eq!(go, 100 + mask.trailing_zeros());
            prop_assert_eq!(sp, below + mask.count_ones() as usize - 1);
            prop_assert!(child[..below].iter().all(|&c| c == 7) && dist[..below].iter().all(|&d| d == (-1.0f32).to_bits()));
            let mut pushed: Vec<u32> = child[below..].to_vec();
            for (c, d) in pushed.iter().zip(&dist[below..]) {
                prop_assert_eq!(*d, near[(*c - 100) as usize].to_bits());
            }
            pushed.push(go);
            pushed.sort_unstable();
            let expected: Vec<u32> = (0..8).filter(|i| mask & (1 << i) != 0).map(|i| 100 + i).collect();
            prop_assert_eq!(pushed, expected);
        }

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
