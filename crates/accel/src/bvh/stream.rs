//! Packets of coherent rays (the primary rays of a tile, say) walked down the triangle tree, and the
//! tree of the other shapes, together: one box test per node for the whole packet
//! ([`Frustum`](super::wide::Frustum)), then at each leaf the leaf's box tested for four rays at a time
//! and the leaf's triangles or shapes tested for each ray that meets the box, exactly as that ray alone
//! would test them. Where eight neighbouring rays meet a leaf's box, at least as many as it has
//! triangles, and share their watertight frame's axes, the AVX2 kernel tests each triangle once for
//! all of them ([`Block`]), each ray's lane decided as its own test decides it. Every ray gets the
//! answer of the single-ray query.

use glam::{BVec3A, Mat4, Vec4};
use raylume_geometry::{Interval, Ray, Vec3A, gamma};
use raylume_intersect::{Intersect, RayLanes, ShearedRay, TriangleHit};

use super::leaf::{Filter, closest_in_leaf};
use super::triangles::Leaf;
use super::wide::{Frustum, LeafTest, NodeTest, WIDEN, WideTree, crosses_every_slab, leaf_range, set_bits, set_bits64};
use crate::PrimitiveHit;

/// Rays per packet.
pub(super) const PACKET: usize = 64;
/// Groups of four rays per packet.
const GROUPS: usize = PACKET / 4;

/// The signs of the directions of `rays` along each axis, if every ray can be traced and they agree
/// (and cross every slab): the rays that can share a [`Frustum`](super::wide::Frustum).
pub(super) fn common_signs(rays: &[Ray]) -> Option<[bool; 3]> {
    let first = rays.first()?;
    let signs = first.dir.cmplt(Vec3A::ZERO).bitmask();
    rays.iter()
        .all(|r| r.is_valid() && crosses_every_slab(r.dir) && r.dir.cmplt(Vec3A::ZERO).bitmask() == signs)
        .then_some([signs & 1 != 0, signs & 2 != 0, signs & 4 != 0])
}

/// [`common_signs`] of rays that are each canonical already ([`Ray::is_canonical`]), checked in one
/// pass: the rays the packet query walks as they are (the primary rays of a camera, whose directions
/// are unit vectors, mostly are); `None` if one is not.
pub(super) fn canonical_signs(rays: &[Ray]) -> Option<[bool; 3]> {
    let first = rays.first()?;
    let first_negative = first.dir.cmplt(Vec3A::ZERO);
    // The checks of `Ray::is_valid`, `Ray::is_canonical`, `crosses_every_slab` and the signs, gathered
    // over the rays in registers without a branch or a mask per ray (the rays are read once, in one
    // stream). A direction is canonical when each component is below 1 in magnitude and the largest
    // reaches 0.5: inside `is_valid`'s range, and finite. The comparisons fail on NaN, as `is_finite`.
    let (infinity, smallest, one) = (Vec3A::INFINITY, Vec3A::splat(f32::MIN_POSITIVE), Vec3A::ONE);
    let mut in_range = BVec3A::TRUE;
    let mut other_signs = BVec3A::FALSE;
    let mut smallest_largest = f32::INFINITY;
    let mut time_nan = false;
    for r in rays {
        let d = r.dir.abs();
        in_range &= r.origin.abs().cmplt(infinity) & d.cmpge(smallest) & d.cmplt(one);
        other_signs |= r.dir.cmplt(Vec3A::ZERO) ^ first_negative;
        // A NaN component fails `in_range`: a plain comparison keeps the minimum without `f32::min`'s
        // care for NaN.
        let largest = d.max_element();
        smallest_largest = if largest < smallest_largest { largest } else { smallest_largest };
        time_nan |= r.time.is_nan();
    }
    let signs = first_negative.bitmask();
    (in_range.all() && !other_signs.any() && smallest_largest >= 0.5 && !time_nan).then_some([
        signs & 1 != 0,
        signs & 2 != 0,
        signs & 4 != 0,
    ])
}

/// The [`Frustum`] of `rays` if [`canonical_signs`] finds they can walk as they are: the portable
/// kernel's (the AVX2 one gathers both in one pass).
pub(super) fn canonical_frustum(rays: &[Ray]) -> Option<Frustum> {
    canonical_signs(rays).map(|negative| Frustum::new(rays, negative))
}

/// Four rays of a packet, lane by lane, for the box test of a leaf: each lane's answer is the one
/// [`BoxRay`](super::wide::BoxRay) gives that ray, with the same operations.
#[derive(Clone, Copy, Debug)]
pub(super) struct RayGroup {
    /// The rays' origins and directions by axis, as the shapes that test four rays at once take them
    /// ([`Intersect::lane_roots`]).
    pub lanes: RayLanes,
    inv_near: [Vec4; 3],
    inv_far: [Vec4; 3],
}

/// Four rays of a packet for the triangles' tests, lane by lane: their [`RayGroup`] and their
/// watertight frames' shears ([`ShearedRay::shear`]) by component.
#[derive(Clone, Copy, Debug)]
pub(super) struct FrameGroup {
    pub rays: RayGroup,
    pub shear: [Vec4; 3],
}

impl RayGroup {
    /// The group of `rays` (one to four; missing lanes repeat the first ray).
    #[inline(always)]
    fn new(rays: &[Ray]) -> Self {
        let lane = |i: usize| rays.get(i).unwrap_or(&rays[0]);
        let (r0, r1, r2, r3) = (lane(0), lane(1), lane(2), lane(3));
        // Each axis's coordinates of the four rays in one register: a transpose.
        let by_axis = |a: Vec3A, b: Vec3A, c: Vec3A, d: Vec3A| {
            let m = Mat4::from_cols(a.extend(0.0), b.extend(0.0), c.extend(0.0), d.extend(0.0)).transpose();
            [m.x_axis, m.y_axis, m.z_axis]
        };
        let dir = by_axis(r0.dir, r1.dir, r2.dir, r3.dir);
        // `reciprocals` lane by lane.
        let inv_near = dir.map(|d| Vec4::ONE / d);
        Self {
            lanes: RayLanes { origin: by_axis(r0.origin, r1.origin, r2.origin, r3.origin), dir },
            inv_near,
            inv_far: inv_near.map(|inv| inv * WIDEN),
        }
    }

    /// The lanes whose ray meets the box with near planes `near` and far planes `far` (by the rays'
    /// common signs) within `[t_min, t_max]`, lane by lane.
    #[inline(always)]
    fn hits(&self, near_plane: [Vec4; 3], far_plane: [Vec4; 3], t_min: Vec4, t_max: Vec4) -> u32 {
        let (mut near, mut far) = (t_min, t_max);
        for a in 0..3 {
            let tn = (near_plane[a] - self.lanes.origin[a]) * self.inv_near[a];
            let tf = (far_plane[a] - self.lanes.origin[a]) * self.inv_far[a];
            near = tn.max(near);
            far = tf.min(far);
        }
        near.cmple(far).bitmask()
    }
}

/// The watertight frames of `rays` (one to four, directions `dir` by axis) into `frames`, each the
/// one [`ShearedRay::new`] makes, with its operations lane by lane; the end of range of a ray that
/// has none becomes `-inf` (its frame is left as it was). Returns the frames' shears lane by lane.
#[inline(always)]
fn sheared_frames(rays: &[Ray], [dx, dy, dz]: [Vec4; 3], frames: &mut [ShearedRay], ends: &mut [f32]) -> [Vec4; 3] {
    let (ax, ay, az) = (dx.abs(), dy.abs(), dz.abs());
    // The axis of the largest component, ties as `ShearedRay::new` breaks them.
    let (x_over_y, x_over_z, y_over_z) = (ax.cmpgt(ay), ax.cmpgt(az), ay.cmpgt(az));
    let (along_x, along_y) = (x_over_y & x_over_z, !x_over_y & y_over_z);
    let pick = |x: Vec4, y: Vec4, z: Vec4| Vec4::select(along_x, x, Vec4::select(along_y, y, z));
    let d_z = pick(dx, dy, dz);
    // The next two axes in turn, swapped where the largest component is negative.
    let (next, after) = (pick(dy, dz, dx), pick(dz, dx, dy));
    let negative = d_z.cmplt(Vec4::ZERO);
    let (d_x, d_y) = (Vec4::select(negative, after, next), Vec4::select(negative, next, after));
    let sz = Vec4::ONE / d_z;
    let shears = [d_x * sz, d_y * sz, sz];
    let [sx, sy, sz] = shears.map(|s| s.to_array());
    let usable = (d_z.cmpne(Vec4::ZERO) & d_z.abs().cmplt(Vec4::INFINITY)).bitmask();
    let (along_x, along_y, negative) = (along_x.bitmask(), along_y.bitmask(), negative.bitmask());
    for (l, ((frame, end), ray)) in frames.iter_mut().zip(ends).zip(rays).enumerate() {
        if usable & (1 << l) == 0 {
            *end = f32::NEG_INFINITY;
            continue;
        }
        let kz = if along_x & (1 << l) != 0 {
            0
        } else if along_y & (1 << l) != 0 {
            1
        } else {
            2
        };
        let (kx, ky) = ([1, 2, 0][kz], [2, 0, 1][kz]);
        let (kx, ky) = if negative & (1 << l) != 0 { (ky, kx) } else { (kx, ky) };
        *frame = ShearedRay { origin: ray.origin, dir: ray.dir, axes: [kx, ky, kz], shear: [sx[l], sy[l], sz[l]] };
    }
    shears
}

/// A packet's rays and what the walk keeps for each of them (`K`, see [`RayTest::Kept`]), made when
/// the walk reaches its first leaf (most packets of a camera's rays reach none).
struct Rays<'a, K> {
    rays: &'a [Ray],
    groups: [FrameGroup; GROUPS],
    /// Each ray's end of range: it shrinks with the hits found; `-inf` retires the ray.
    t_max: [f32; PACKET],
    /// Each ray's watertight frame ([`NO_FRAME`] where a ray has none: it is retired).
    sheared: [ShearedRay; PACKET],
    /// What the test keeps for each ray.
    kept: [K; PACKET],
}

/// Up to eight rays of a packet that meet a leaf's box and share their frame's axes, given to a test
/// that takes them together ([`RayTest::test_block`]): rays `8 b..8 b + 8` of a packet, those of
/// `lanes`.
pub(super) struct Block<'a, K> {
    /// The rays in the block (bit `l`: the block's ray `l`).
    pub lanes: u32,
    /// The axes every ray of `lanes` has in its frame.
    pub axes: [usize; 3],
    /// The block's two groups of four rays, lane by lane.
    pub groups: &'a [FrameGroup],
    /// The block's frames, ends of range and what the test keeps.
    pub sheared: &'a [ShearedRay],
    pub t_max: &'a mut [f32],
    pub kept: &'a mut [K],
}

/// The frame held for a ray that has none (and for the slots past a short packet's rays): never
/// tested, its ray is retired from the start.
const NO_FRAME: ShearedRay = ShearedRay { origin: Vec3A::ZERO, dir: Vec3A::Z, axes: [0, 1, 2], shear: [0.0, 0.0, 1.0] };

/// `[$f(0, args), $f(1, args), …]`: one call per group of a packet, an array literal of calls to an
/// `#[inline(always)]` function, so that each group is written in place (`array::from_fn`'s closure
/// compiles out of line, outside the AVX2 function, and its groups are copied into place).
macro_rules! per_group {
    ($f:ident($($arg:expr),*)) => {{
        const _: () = assert!(GROUPS == 16, "one call per group");
        [$f(0, $($arg),*), $f(1, $($arg),*), $f(2, $($arg),*), $f(3, $($arg),*), $f(4, $($arg),*),
         $f(5, $($arg),*), $f(6, $($arg),*), $f(7, $($arg),*), $f(8, $($arg),*), $f(9, $($arg),*),
         $f(10, $($arg),*), $f(11, $($arg),*), $f(12, $($arg),*), $f(13, $($arg),*), $f(14, $($arg),*),
         $f(15, $($arg),*)]
    }};
}

/// Group `g` of a packet's `rays` with its rays' frames written into `sheared` and, for a ray
/// without one, its end of range into `ends`; a group past the rays, never tested, repeats the first
/// ray.
#[inline(always)]
fn frame_group(g: usize, rays: &[Ray], sheared: &mut [ShearedRay; PACKET], ends: &mut [f32; PACKET]) -> FrameGroup {
    let Some(rays) = rays.get(4 * g..).filter(|rest| !rest.is_empty()) else {
        return FrameGroup { rays: RayGroup::new(&rays[..1]), shear: [Vec4::ZERO; 3] };
    };
    let rays = &rays[..rays.len().min(4)];
    let group = RayGroup::new(rays);
    let (frames, ends) = (&mut sheared[4 * g..4 * g + 4], &mut ends[4 * g..4 * g + 4]);
    FrameGroup { rays: group, shear: sheared_frames(rays, group.lanes.dir, frames, ends) }
}

impl<'a, K: Copy> Rays<'a, K> {
    /// The state of `rays` (one to [`PACKET`]) with the ends of range `t_max`, each ray keeping `kept`.
    #[inline(always)]
    fn new(rays: &'a [Ray], t_max: &[f32], kept: K) -> Self {
        let mut ends = [f32::NEG_INFINITY; PACKET];
        ends[..rays.len()].copy_from_slice(t_max);
        let mut sheared = [NO_FRAME; PACKET];
        let groups = per_group!(frame_group(rays, &mut sheared, &mut ends));
        Self { rays, groups, t_max: ends, sheared, kept: [kept; PACKET] }
    }

    /// Calls `test.test(kept, first, count, sheared ray, t_max)` for each ray that meets the box
    /// `bounds` of the leaf `(first, count)` within `[t_min, t_max[i]]` and sets its `t_max` to what
    /// `test` returns; returns the new largest one.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn each_in_box<R: RayTest<Kept = K>>(
        &mut self,
        bounds: &[f32; 6],
        first: usize,
        count: usize,
        negative: [bool; 3],
        t_min: f32,
        test: &mut R,
    ) -> f32 {
        let (near_plane, far_plane) = leaf_planes(std::slice::from_ref(bounds), negative);
        let t_min_lanes = Vec4::splat(t_min);
        let mut largest = Vec4::NEG_INFINITY;
        let groups = self.rays.len().div_ceil(4);
        // The rays in the box: bit `i` for ray `i`.
        let mut in_box = 0u64;
        for g in 0..groups {
            // A few ulps past each ray's closest hit, as the single-ray walk reaches (ties included).
            let ends = Vec4::from_slice(&self.t_max[4 * g..4 * g + 4]);
            let ends = ends + ends.abs() * Vec4::splat(2.0 * gamma(3));
            in_box |= (self.groups[g].rays.hits(near_plane, far_plane, t_min_lanes, ends) as u64) << (4 * g);
        }
        if R::BLOCKS {
            // Blocks of eight rays with at least as many in the box as the leaf has triangles, sharing
            // their frame's axes, test each triangle once for all of them, where each ray would test
            // every one.
            for b in 0..groups.div_ceil(2) {
                let (base, lanes) = (8 * b, (in_box >> (8 * b)) as u32 & 0xFF);
                if lanes.count_ones() as usize >= count
                    && let Some(axes) = shared_axes(&self.sheared[base..base + 8], lanes)
                {
                    let block = Block {
                        lanes,
                        axes,
                        groups: &self.groups[2 * b..2 * b + 2],
                        sheared: &self.sheared[base..base + 8],
                        t_max: &mut self.t_max[base..base + 8],
                        kept: &mut self.kept[base..base + 8],
                    };
                    test.test_block(block, first, count);
                    in_box &= !((lanes as u64) << base);
                }
            }
        }
        for i in set_bits64(in_box) {
            self.t_max[i] = test.test(&mut self.kept[i], first, count, &self.sheared[i], self.t_max[i]);
        }
        for g in 0..groups {
            largest = largest.max(Vec4::from_slice(&self.t_max[4 * g..4 * g + 4]));
        }
        largest.max_element()
    }
}

/// The axes of the frames of the rays `lanes` among `frames`, if they all share them.
#[inline(always)]
fn shared_axes(frames: &[ShearedRay], lanes: u32) -> Option<[usize; 3]> {
    let axes = frames[lanes.trailing_zeros() as usize].axes;
    set_bits(lanes).all(|l| frames[l as usize].axes == axes).then_some(axes)
}

/// Whether each ray of a packet hits one of `prims` (the shapes other than triangles, their tree
/// `tree`, `boxes[i]` the box of `prims[i]` as the tree was built on it) within `(0, t_max[i])`: sets
/// `occluded[i]` for those that do, and leaves the rays already occluded (and those whose end is NaN)
/// as they are. The packet walks the tree once with its `frustum`; at each leaf, the rays that meet
/// its box, four at a time, test its shapes as the single-ray query does. The answer is each ray's
/// own: a shape's hit lies inside its box, which every walk tests conservatively.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn occluded_by_shapes<P: Intersect, const W: usize>(
    frustum: &Frustum,
    (tree, nodes): (&WideTree<W>, &impl NodeTest<W>),
    prims: &[P],
    boxes: &[[f32; 6]],
    rays: &[Ray],
    t_max: &[f32],
    occluded: &mut [bool],
) {
    let n = rays.len();
    let mut ends = [f32::NEG_INFINITY; PACKET];
    for ((end, &t), &o) in ends.iter_mut().zip(t_max).zip(occluded.iter()) {
        if !o && !t.is_nan() {
            *end = t;
        }
    }
    let start = largest(&ends[..n]);
    if start == f32::NEG_INFINITY {
        return;
    }
    let groups = ray_groups(rays);
    let mut leaf = |leaf: u32, _: f32, _: &mut ()| {
        let (first, count) = leaf_range(leaf);
        let shapes = &prims[first..first + count];
        let (near_plane, far_plane) = leaf_planes(&boxes[first..first + count], frustum.negative);
        let mut largest_end = Vec4::NEG_INFINITY;
        for (g, group) in groups[..n.div_ceil(4)].iter().enumerate() {
            let lanes = Vec4::from_slice(&ends[4 * g..4 * g + 4]);
            // Shape by shape for the group's rays in the box: each ray's answer is its own.
            let in_box = group.hits(near_plane, far_plane, Vec4::ZERO, lanes);
            let mut live = in_box;
            for p in shapes {
                if live == 0 {
                    break;
                }
                let roots = p.lane_roots(&group.lanes, Vec4::ZERO, lanes);
                let mut hit = live & roots.hit;
                for lane in set_bits(live & roots.undecided) {
                    let i = 4 * g + lane as usize;
                    hit |= (p.occluded_canonical(&rays[i], t_max[i]) as u32) << lane;
                }
                live &= !hit;
            }
            for lane in set_bits(in_box & !live) {
                let i = 4 * g + lane as usize;
                occluded[i] = true;
                ends[i] = f32::NEG_INFINITY;
            }
            largest_end = largest_end.max(Vec4::from_slice(&ends[4 * g..4 * g + 4]));
        }
        // Below zero once every ray is occluded: the walk ends.
        largest_end.max_element()
    };
    tree.walk::<true, ()>(nodes, 0.0, start, &mut (), &mut leaf);
}

/// The closest hit of each ray of a packet among `prims` (the shapes other than triangles, as for
/// [`occluded_by_shapes`]; `ids` their input indices) within `[t_min, t_max[i]]`, kept in `hits[i]`
/// as [`PrimitiveHit::keep_closer`] keeps it, `t_max[i]` narrowed to its distance. The packet walks
/// the tree once, nearest box first; at each leaf, the rays that meet its box (up to the few ulps past
/// their closest hit that the single-ray walk reaches), four at a time, test its shapes. Each ray gets
/// the closest of its shapes' hits, ties to the lowest index, as the single-ray query does in any order.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn closest_by_shapes<P: Intersect, const W: usize>(
    frustum: &Frustum,
    (tree, nodes): (&WideTree<W>, &impl NodeTest<W>),
    (prims, ids, boxes): (&[P], &[u32], &[[f32; 6]]),
    rays: &[Ray],
    t_min: f32,
    t_max: &mut [f32],
    hits: &mut [Option<PrimitiveHit>],
) {
    let n = rays.len();
    let mut ends = [f32::NEG_INFINITY; PACKET];
    ends[..n].copy_from_slice(t_max);
    let groups = ray_groups(rays);
    let t_min_lanes = Vec4::splat(t_min);
    let start = largest(&ends[..n]);
    let mut leaf = |leaf: u32, _: f32, _: &mut ()| {
        let (first, count) = leaf_range(leaf);
        let (near_plane, far_plane) = leaf_planes(&boxes[first..first + count], frustum.negative);
        let mut largest_end = Vec4::NEG_INFINITY;
        for (g, group) in groups[..n.div_ceil(4)].iter().enumerate() {
            let lanes = Vec4::from_slice(&ends[4 * g..4 * g + 4]);
            let reach = lanes + lanes.abs() * Vec4::splat(2.0 * gamma(3));
            let live = group.hits(near_plane, far_plane, t_min_lanes, reach);
            if live == 0 {
                largest_end = largest_end.max(lanes);
                continue;
            }
            // Shape by shape for the group's rays in the box: each ray takes the shapes in the order
            // it takes them alone, each within its range at that point.
            for k in first..first + count {
                let roots = prims[k].lane_roots(&group.lanes, t_min_lanes, Vec4::from_slice(&ends[4 * g..4 * g + 4]));
                let t = roots.t.to_array();
                for lane in set_bits(live & (roots.hit | roots.undecided)) {
                    let i = 4 * g + lane as usize;
                    let range = Interval::new(t_min, ends[i]);
                    let hit = if roots.hit & (1 << lane) != 0 {
                        prims[k].hit_at_root(&rays[i], t[lane as usize], range)
                    } else {
                        prims[k].intersect_canonical(&rays[i], range)
                    };
                    if let Some(hit) = hit {
                        ends[i] = hit.t;
                        PrimitiveHit::keep_closer(&mut hits[i], PrimitiveHit { hit, primitive: ids[k] });
                    }
                }
            }
            largest_end = largest_end.max(Vec4::from_slice(&ends[4 * g..4 * g + 4]));
        }
        largest_end.max_element()
    };
    tree.walk::<false, ()>(nodes, t_min, start, &mut (), &mut leaf);
    t_max.copy_from_slice(&ends[..n]);
}

/// The box-test groups of a packet's `rays` (one to [`PACKET`]). Those past the rays, never tested,
/// repeat the first ray: each group is written once, with no clearing of the array first.
#[inline(always)]
fn ray_groups(rays: &[Ray]) -> [RayGroup; GROUPS] {
    per_group!(ray_group(rays))
}

/// Group `g` of a packet's `rays`, or the first ray repeated past them.
#[inline(always)]
fn ray_group(g: usize, rays: &[Ray]) -> RayGroup {
    let group = rays.get(4 * g..).filter(|rest| !rest.is_empty()).unwrap_or(&rays[..1]);
    RayGroup::new(&group[..group.len().min(4)])
}

/// The near and far planes, by the rays' signs `negative`, of the box around `boxes` (`[min, max]`
/// by axis), as [`RayGroup::hits`] takes them.
#[inline(always)]
fn leaf_planes(boxes: &[[f32; 6]], negative: [bool; 3]) -> ([Vec4; 3], [Vec4; 3]) {
    let mut bounds = boxes[0];
    for b in &boxes[1..] {
        for a in 0..3 {
            bounds[a] = bounds[a].min(b[a]);
            bounds[3 + a] = bounds[3 + a].max(b[3 + a]);
        }
    }
    let plane = |a: usize, far: bool| Vec4::splat(bounds[3 * (negative[a] != far) as usize + a]);
    ([plane(0, false), plane(1, false), plane(2, false)], [plane(0, true), plane(1, true), plane(2, true)])
}

/// The largest of `ends` (NaN ignored, as `f32::max` ignores it; `-inf` for none; either zero where
/// the largest is zero), four at a time
/// rather than in one chain of dependent maxima.
#[inline(always)]
pub(super) fn largest(ends: &[f32]) -> f32 {
    let chunks = ends.chunks_exact(4);
    let rest = chunks.remainder().iter().fold(f32::NEG_INFINITY, |m, &t| m.max(t));
    // maxps returns its second operand where the first is NaN.
    let lanes = chunks.fold(Vec4::NEG_INFINITY, |m, c| Vec4::from_slice(c).max(m));
    lanes.max_element().max(rest)
}

/// What a packet walk does for each ray that meets a leaf's box: `test(kept, first, count, sheared ray,
/// t_max)` tests the leaf (its index, triangle count) for the ray, whose record is `kept`, and returns
/// the ray's new `t_max` (`-inf` retires the ray). Types whose method is always inlined, as
/// [`LeafTest`]'s.
trait RayTest {
    /// What the walk keeps for each ray, [`RayTest::START`] at first.
    type Kept: Copy;
    const START: Self::Kept;
    /// Whether the test takes the rays that meet a leaf's box eight at a time ([`RayTest::test_block`]).
    const BLOCKS: bool = false;

    fn test(&mut self, kept: &mut Self::Kept, first: usize, count: usize, sheared: &ShearedRay, t_max: f32) -> f32;

    /// [`RayTest::test`] for each ray of `block` (with [`RayTest::BLOCKS`]), each ray's `t_max` set to
    /// what it returns.
    fn test_block(&mut self, block: Block<Self::Kept>, first: usize, count: usize);
}

/// The leaf test of a packet walk: the leaf's box for the packet's rays, then `test` for each ray in it.
struct PacketLeaf<'a, 'r, R: RayTest> {
    rays: &'r [Ray],
    t_max: &'r [f32],
    /// The rays' state, made at the first leaf.
    state: Option<Rays<'r, R::Kept>>,
    leaf_bounds: &'a [[f32; 6]],
    negative: [bool; 3],
    t_min: f32,
    test: R,
}

impl<R: RayTest> LeafTest<()> for PacketLeaf<'_, '_, R> {
    #[inline(always)]
    fn test(&mut self, leaf: u32, _: f32, _: &mut ()) -> f32 {
        let (first, count) = leaf_range(leaf);
        let state = match &mut self.state {
            Some(state) => state,
            state => state.insert(Rays::new(self.rays, self.t_max, R::START)),
        };
        state.each_in_box(&self.leaf_bounds[first], first, count, self.negative, self.t_min, &mut self.test)
    }
}

/// The triangles a packet walks: the tree (of either width, with the packet's box test for it), the
/// leaves' filter, the leaves' triangles and each leaf's box.
pub(super) struct Leaves<'a, const W: usize, N, F> {
    pub tree: &'a WideTree<W>,
    pub frustum: N,
    pub filter: F,
    pub leaves: &'a [Leaf],
    pub leaf_bounds: &'a [[f32; 6]],
}

/// A ray's closest hit so far, its leaf and candidate bit, as [`closest_in_leaf`] keeps it.
pub(super) type Found = Option<(TriangleHit, u32, u32)>;

/// Each ray's closest hit, kept as [`closest_in_leaf`] keeps it.
struct Closest<'a, F> {
    filter: F,
    leaves: &'a [Leaf],
    t_min: f32,
}

impl<F: Filter> RayTest for Closest<'_, F> {
    type Kept = Found;
    const START: Found = None;
    const BLOCKS: bool = F::BLOCKS;

    #[inline(always)]
    fn test(&mut self, found: &mut Found, first: usize, count: usize, sheared: &ShearedRay, t_max: f32) -> f32 {
        closest_in_leaf(self.filter, self.leaves, (first, count), sheared, Interval::new(self.t_min, t_max), found)
    }

    #[inline(always)]
    fn test_block(&mut self, block: Block<Found>, first: usize, count: usize) {
        self.filter.closest_in_block(self.leaves, (first, count), self.t_min, block);
    }
}

/// Whether each ray is occluded; an occluded ray retires.
struct Occluded<'a, F> {
    filter: F,
    leaves: &'a [Leaf],
}

impl<F: Filter> RayTest for Occluded<'_, F> {
    /// Whether the ray is occluded.
    type Kept = bool;
    const START: bool = false;

    const BLOCKS: bool = F::BLOCKS;

    #[inline(always)]
    fn test(&mut self, occluded: &mut bool, first: usize, count: usize, sheared: &ShearedRay, t_max: f32) -> f32 {
        if self.filter.leaf_occluded(&self.leaves[first], count, sheared, Interval::new(0.0, t_max)) {
            *occluded = true;
            f32::NEG_INFINITY
        } else {
            t_max
        }
    }

    #[inline(always)]
    fn test_block(&mut self, block: Block<bool>, first: usize, count: usize) {
        self.filter.occluded_in_block(&self.leaves[first], count, block);
    }
}

/// What a closest-hit packet query does with each ray's hit: `report(i, hit)` for ray `i`, the hit as
/// [`closest_in_leaf`] keeps it. Closures are reports; the queries' one report is known where the
/// packet walk is compiled, so each call is a direct one.
pub(super) trait Report {
    fn report(&mut self, i: usize, found: (TriangleHit, u32, u32));
}

/// The report of an occlusion query, which has no hits to report.
impl Report for () {
    #[inline(always)]
    fn report(&mut self, _: usize, _: (TriangleHit, u32, u32)) {}
}

impl<F: FnMut(usize, (TriangleHit, u32, u32))> Report for F {
    #[inline(always)]
    fn report(&mut self, i: usize, found: (TriangleHit, u32, u32)) {
        self(i, found)
    }
}

/// A packet query over the triangles, with its own arguments: the closest hit of each ray within
/// `[t_min, t_max[i]]` (`report(i, hit)` for each ray `i` with one, the hit as [`closest_in_leaf`]
/// keeps it), or whether each ray is occluded within `(0, t_max[i])` (sets `occluded[i]` for those
/// that are).
pub(super) enum PacketQuery<'a, R> {
    Closest { t_min: f32, t_max: &'a [f32], report: R },
    Occluded { t_max: &'a [f32], occluded: &'a mut [bool] },
}

impl<const W: usize, N: NodeTest<W>, F: Filter> Leaves<'_, W, N, F> {
    /// Answers `query` for the packet `rays` (signs `negative`, see [`common_signs`]).
    #[inline(always)]
    pub fn answer(&self, rays: &[Ray], negative: [bool; 3], query: PacketQuery<impl Report>) {
        match query {
            PacketQuery::Closest { t_min, t_max, mut report } => {
                let test = Closest { filter: self.filter, leaves: self.leaves, t_min };
                self.walk::<false, _>(rays, negative, t_min, t_max, test, |kept| {
                    for (i, found) in kept.iter().enumerate() {
                        if let Some(found) = *found {
                            report.report(i, found);
                        }
                    }
                });
            }
            PacketQuery::Occluded { t_max, occluded } => {
                let test = Occluded { filter: self.filter, leaves: self.leaves };
                self.walk::<true, _>(rays, negative, 0.0, t_max, test, |kept| {
                    for (o, &kept) in occluded.iter_mut().zip(kept) {
                        *o |= kept;
                    }
                });
            }
        }
    }

    /// Walks the packet `rays` (signs `negative`) down the tree; `test` tests each leaf for each ray
    /// that meets its box. With `ANY`, the walk stops once every ray is retired. Then, if the walk
    /// reached a leaf, `finish` gets what the test kept for each ray.
    #[inline(always)]
    fn walk<const ANY: bool, R: RayTest>(
        &self,
        rays: &[Ray],
        negative: [bool; 3],
        t_min: f32,
        t_max: &[f32],
        test: R,
        finish: impl FnOnce(&[R::Kept]),
    ) {
        let mut leaf = PacketLeaf { rays, t_max, state: None, leaf_bounds: self.leaf_bounds, negative, t_min, test };
        // The largest end of range: no node entered beyond it can hold a closer hit for any ray.
        let start = largest(t_max);
        self.tree.walk::<ANY, _>(&self.frustum, t_min, start, &mut (), &mut leaf);
        if let Some(state) = &leaf.state {
            finish(&state.kept[..rays.len()]);
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use proptest::prelude::*;

    use super::*;

    /// A component of a direction: zeros of both signs, subnormals, the ends of the canonical range,
    /// infinities, NaN and any value.
    fn arb_component() -> impl Strategy<Value = f32> {
        prop_oneof![
            Just(0.0f32),
            Just(-0.0f32),
            Just(1e-40f32),
            Just(0.5f32),
            Just(-0.5f32),
            Just(0.49999997f32),
            Just(0.99999994f32),
            Just(1.0f32),
            Just(-1.0f32),
            Just(f32::INFINITY),
            Just(f32::NAN),
            -1.0f32..1.0,
            any::<f32>(),
        ]
    }

    /// Up to a packet's worth of rays around one direction (so that their signs mostly agree), one
    /// component of one ray's direction or origin, or its time, maybe replaced by an odd value: zeros
    /// of both signs, subnormals, the ends of the canonical range, infinities, NaN.
    pub(in crate::bvh) fn arb_run() -> impl Strategy<Value = Vec<Ray>> {
        (
            prop::array::uniform3(arb_component()),
            prop::collection::vec(prop::array::uniform3(prop_oneof![Just(1.0f32), 0.5f32..2.0]), 1..=9),
            prop::option::of((0usize..9, 0usize..7, arb_component())),
            prop::array::uniform3(prop_oneof![Just(0.0f32), -5.0f32..5.0]),
            any::<bool>(),
        )
            .prop_map(|(base, scales, odd, origin, unit)| {
                scales
                    .iter()
                    .enumerate()
                    .map(|(i, scale)| {
                        let mut d = Vec3A::from_array(base) * Vec3A::from_array(*scale);
                        let mut ray = Ray::new(Vec3A::from_array(origin), d);
                        if let Some((which, part, c)) = odd
                            && which == i
                        {
                            match part {
                                0..3 => d[part] = c,
                                3..6 => ray.origin[part - 3] = c,
                                _ => ray.time = c,
                            }
                        }
                        ray.dir = if unit && d.length() > 0.0 && d.length().is_finite() { d.normalize() } else { d };
                        ray
                    })
                    .collect()
            })
    }

    /// [`canonical_signs`] by each ray's own checks.
    pub(in crate::bvh) fn each_rays_checks(rays: &[Ray]) -> Option<[bool; 3]> {
        let signs = |r: &Ray| r.dir.cmplt(Vec3A::ZERO).bitmask();
        let each = rays
            .iter()
            .all(|r| r.is_valid() && r.is_canonical() && crosses_every_slab(r.dir) && signs(r) == signs(&rays[0]));
        each.then(|| {
            let s = signs(&rays[0]);
            [s & 1 != 0, s & 2 != 0, s & 4 != 0]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The largest end of a packet is the one `f32::max` folds to, NaN ignored (zeros of either
        /// sign are one end: the walk only compares it).
        #[test]
        fn largest_end_is_the_folded_maximum(
            ends in prop::collection::vec(prop_oneof![Just(f32::NAN), Just(f32::NEG_INFINITY), Just(f32::INFINITY), any::<f32>()], 0..=PACKET),
        ) {
            let folded = ends.iter().fold(f32::NEG_INFINITY, |m, &t| m.max(t));
            prop_assert_eq!(largest(&ends), folded);
        }

        /// The frames made four rays at a time are each ray's own, bit for bit, and a ray without one
        /// retires: ties between the largest components, zeros, subnormals, infinities and NaN included.
        #[test]
        fn frames_of_a_group_are_each_rays(
            dirs in prop::collection::vec(prop::array::uniform3(arb_component()), 1..=4),
            ties in prop::collection::vec((0usize..3, 0usize..3, any::<bool>()), 4),
        ) {
            let rays: Vec<Ray> = dirs
                .iter()
                .zip(&ties)
                .map(|(d, &(from, to, flip))| {
                    let mut d = *d;
                    d[to] = if flip { -d[from] } else { d[from] };
                    Ray::new(Vec3A::new(1.0, -2.0, 3.0), Vec3A::from_array(d))
                })
                .collect();
            let dir = RayGroup::new(&rays).lanes.dir;
            let (mut frames, mut ends) = ([NO_FRAME; 4], [1.0f32; 4]);
            sheared_frames(&rays, dir, &mut frames, &mut ends);
            for (i, ray) in rays.iter().enumerate() {
                match ShearedRay::new(ray) {
                    Some(f) => {
                        prop_assert_eq!(ends[i], 1.0);
                        prop_assert_eq!(frames[i].axes, f.axes);
                        prop_assert_eq!(frames[i].shear.map(f32::to_bits), f.shear.map(f32::to_bits));
                        prop_assert_eq!(frames[i].origin.to_array().map(f32::to_bits), f.origin.to_array().map(f32::to_bits));
                        prop_assert_eq!(frames[i].dir.to_array().map(f32::to_bits), f.dir.to_array().map(f32::to_bits));
                    }
                    None => prop_assert_eq!(ends[i], f32::NEG_INFINITY),
                }
            }
        }

        /// The one-pass check answers as each ray's own checks: validity, a canonical direction,
        /// crossing every slab and the first ray's signs.
        #[test]
        fn canonical_signs_are_each_rays_checks(rays in arb_run()) {
            prop_assert_eq!(canonical_signs(&rays), each_rays_checks(&rays));
        }
    }
}
