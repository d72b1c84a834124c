//! The wide trees: nodes of four or eight children whose boxes a ray tests together, collapsed from
//! the binary build, and the ordered traversal shared by both widths and every kind of leaf.

use glam::Vec4;
use raylume_geometry::{Aabb, Interval, Ray, Vec3A, gamma};

use super::build::Node;
use super::collapse::Plan;
use crate::Tally;

/// A child reference with this bit set is a leaf: `LEAF | (count - 1) << COUNT_SHIFT | first`.
pub(super) const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 28;
/// Largest `first` a leaf reference can hold.
pub(super) const MAX_FIRST: u32 = (1 << COUNT_SHIFT) - 1;
/// An unused child slot (its box is empty, so no ray reaches it).
const EMPTY: u32 = u32::MAX;
/// Traversal stack entries: enough for seven per level of a tree 70 levels deep (the binary build
/// stays below that depth); the walk clears only 40 or 64 when the tree is shallow enough.
const STACK: usize = 512;

/// pbrt's `1 + 2 gamma(3)`, which widens the far end of each slab against rounding.
pub(super) const WIDEN: f32 = 1.0 + 2.0 * raylume_geometry::gamma(3);

/// Most levels of inner nodes a tree may have: the binary build stays below this depth, and the
/// walk's stack is sized for it.
pub(super) const MAX_DEPTH: usize = 70;

/// One node of `W` children: their boxes stored by plane (`bounds[2 a]` the minima along axis `a`,
/// `bounds[2 a + 1]` the maxima, one lane per child) so that one ray tests all of them together,
/// picking each axis's near plane by index rather than by branch or select.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct WideNode<const W: usize> {
    pub bounds: [[f32; W]; 6],
    pub child: [u32; W],
}

const _: () = assert!(std::mem::size_of::<WideNode<4>>() == 128);
const _: () = assert!(std::mem::size_of::<WideNode<8>>() == 256);

impl<const W: usize> WideNode<W> {
    /// A node whose children are the given boxes (given by two opposite corners), slots past them
    /// empty.
    #[cfg(test)]
    pub fn of_boxes(boxes: &[(Vec3A, Vec3A)]) -> Self {
        let mut node = Self::EMPTY;
        for (slot, (a, b)) in boxes.iter().enumerate() {
            let (lo, hi) = (a.min(*b).to_array(), a.max(*b).to_array());
            for axis in 0..3 {
                node.bounds[2 * axis][slot] = lo[axis];
                node.bounds[2 * axis + 1][slot] = hi[axis];
            }
        }
        node
    }

    pub const EMPTY: Self = Self {
        bounds: [
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
        ],
        child: [EMPTY; W],
    };
}

/// How far past the closest hit so far, at distance `t`, a closest-hit walk tests boxes and keeps
/// entries: a box's entry distance rounds, and a primitive at the very distance of the hit (a tie the
/// lowest index wins) must still be reached.
#[inline(always)]
pub(crate) fn reach(t: f32) -> f32 {
    t + t.abs() * (2.0 * gamma(3))
}

/// The boxes of a few shapes (at most four), one per slot of a single node, tested by a ray at once,
/// then each shape whose box the ray meets tested exactly: for so few shapes, cheaper than a walk of
/// their tree, or of the cells of a grid, and exact as either (the box test is conservative).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FewShapes(WideNode<4>);

impl FewShapes {
    /// The most shapes one node holds.
    pub const MAX: usize = 4;

    /// The node of `boxes` (at most [`FewShapes::MAX`]), slot `i` holding box `i`.
    pub fn new(boxes: impl IntoIterator<Item = Aabb>) -> Self {
        let mut node = WideNode::EMPTY;
        for (slot, b) in boxes.into_iter().enumerate() {
            assert!(slot < Self::MAX, "at most {} shapes", Self::MAX);
            let (lo, hi) = (b.min.to_array(), b.max.to_array());
            for a in 0..3 {
                node.bounds[2 * a][slot] = lo[a];
                node.bounds[2 * a + 1][slot] = hi[a];
            }
        }
        Self(node)
    }

    /// Tests, in slot order, each shape whose box the ray meets within `t_range` (up to the few ulps
    /// past its end that a walk reaches, see [`WideTree::walk`], so that a hit at the end's distance
    /// still counts): `test(slot, t_range)` narrows `t_range` to the shape's hit within it.
    #[inline(always)]
    pub fn closest(&self, ray: &Ray, t_range: &mut Interval, test: impl FnMut(usize, &mut Interval)) {
        self.closest_prepared(&BoxRay::new(ray), t_range, test)
    }

    /// [`FewShapes::closest`] for a ray prepared once for many nodes.
    #[inline(always)]
    pub fn closest_prepared(&self, ray: &BoxRay, t_range: &mut Interval, mut test: impl FnMut(usize, &mut Interval)) {
        let mut range = *t_range;
        let (near, mask) = ray.intersect(&self.0, range.min, reach(range.max));
        for slot in set_bits(mask) {
            let i = slot as usize;
            // A slot in the mask has a near distance that is a number.
            if near[i] <= reach(range.max) {
                test(i, &mut range);
            }
        }
        *t_range = range;
    }

    /// Whether the ray meets a box within `[t_min, reach(t_max)]`: the reference [`OneBox`] answers as.
    #[cfg(test)]
    pub fn meets(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        BoxRay::new(ray).intersect(&self.0, t_min, reach(t_max)).1 != 0
    }

    /// Whether a ray of the packet `frustum` may meet a box within `[t_min, t_max]`: `false` only
    /// where none of its rays does ([`Frustum`]'s test is conservative).
    #[inline(always)]
    pub(super) fn meets_packet(&self, frustum: &Frustum, t_min: f32, t_max: f32) -> bool {
        frustum.intersect(&self.0, t_min, t_max).1 != 0
    }

    /// Whether `test(slot)` holds for a shape whose box the ray meets within `[0, t_max]` (up to the few
    /// ulps past it that a walk reaches), tried in slot order.
    #[inline(always)]
    pub fn any(&self, ray: &Ray, t_max: f32, test: impl FnMut(usize) -> bool) -> bool {
        self.any_prepared(&BoxRay::new(ray), t_max, test)
    }

    /// [`FewShapes::any`] for a ray prepared once for many nodes.
    #[inline(always)]
    pub fn any_prepared(&self, ray: &BoxRay, t_max: f32, test: impl FnMut(usize) -> bool) -> bool {
        let (_, mask) = ray.intersect(&self.0, 0.0, reach(t_max));
        set_bits(mask).map(|slot| slot as usize).any(test)
    }
}

/// One box, tested by one ray with [`FewShapes::meets`]'s operations on three coordinates at once
/// rather than four splatted slots: the same answer, for the price of one slot.
#[derive(Clone, Copy, Debug)]
pub(crate) struct OneBox {
    min: Vec3A,
    max: Vec3A,
}

impl OneBox {
    /// The test of `bounds`.
    pub fn new(bounds: Aabb) -> Self {
        Self { min: bounds.min, max: bounds.max }
    }

    /// Whether the ray (its direction's components at most 1 in magnitude, as a canonical ray's) meets
    /// the box within `[t_min, reach(t_max)]`: what `FewShapes::new([box])` answers, bit for bit
    /// ([`SlabRay`]'s reciprocals and planes; a product that is NaN, a ray parallel to a slab with its
    /// origin on a face, leaves the bound as it was).
    #[inline(always)]
    pub fn meets(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let d = ray.dir;
        // Past the box along an axis and moving away from it: the slab test's miss without its
        // division. That axis's far plane lies behind the origin by at least the least subnormal, and
        // its reciprocal is at least one (no component of the direction is larger, `debug_assert`
        // below), so the plane's distance is negative, not zero, and below a range's start at zero or
        // after.
        debug_assert!(d.abs().max_element() <= 1.0, "a direction of components at most 1 (a canonical ray)");
        let away =
            (ray.origin.cmpgt(self.max) & d.cmpgt(Vec3A::ZERO)) | (ray.origin.cmplt(self.min) & d.cmplt(Vec3A::ZERO));
        if away.any() && t_min >= 0.0 {
            return false;
        }
        let parallel = d.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE));
        let (inv, inv_far) = reciprocals(d);
        let (inv_near, inv_far) =
            (Vec3A::select(parallel, Vec3A::INFINITY, inv), Vec3A::select(parallel, Vec3A::INFINITY, inv_far));
        let negative = d.cmplt(Vec3A::ZERO) & !parallel;
        let (near_plane, far_plane) =
            (Vec3A::select(negative, self.max, self.min), Vec3A::select(negative, self.min, self.max));
        // maxps and minps return their second operand where the first is NaN: such an axis leaves the
        // bound at the range's end, as in the slab test's chain.
        let near = ((near_plane - ray.origin) * inv_near).max(Vec3A::splat(t_min)).max_element();
        let far = ((far_plane - ray.origin) * inv_far).min(Vec3A::splat(reach(t_max))).min_element();
        near <= far
    }
}

/// A leaf reference's first item and count.
#[inline(always)]
pub(super) fn leaf_range(r: u32) -> (usize, usize) {
    ((r & MAX_FIRST) as usize, ((r >> COUNT_SHIFT) & 7) as usize + 1)
}

/// A leaf reference; `count` is 1..=8 and `first` at most [`MAX_FIRST`].
#[inline]
pub(super) fn leaf_ref(first: usize, count: usize) -> u32 {
    debug_assert!((1..=8).contains(&count) && first <= MAX_FIRST as usize);
    LEAF | ((count as u32 - 1) << COUNT_SHIFT) | first as u32
}

/// A ray prepared for box tests: per axis, which plane is entered first and the reciprocal
/// direction for each end.
///
/// The test is conservative, like [`Aabb::hit_range`]: a direction component that is zero or
/// subnormal (the ray parallel to a slab) gives no constraint when the origin lies in the slab, faces
/// included, and a miss otherwise; the far end of each slab is widened by pbrt's `1 + 2 gamma(3)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxRay {
    origin: [Vec4; 3],
    inv_near: [Vec4; 3],
    inv_far: [Vec4; 3],
    negative: [bool; 3],
}

/// The box test of a node's `W` children, by one ray ([`BoxRay`], or `BoxRay8` in AVX registers) or
/// by a packet of rays ([`Frustum`]): the entry distances of the children and the mask of those met
/// within `[t_min, t_max]`.
pub(super) trait NodeTest<const W: usize> {
    fn intersect(&self, node: &WideNode<W>, t_min: f32, t_max: f32) -> ([f32; W], u32);

    /// [`NodeTest::intersect`] as an any-hit walk takes it: the same children met, its operations
    /// arranged for that walk.
    #[inline(always)]
    fn intersect_any(&self, node: &WideNode<W>, t_min: f32, t_max: f32) -> ([f32; W], u32) {
        self.intersect(node, t_min, t_max)
    }

    /// Starts loading `node` into the cache, where the test can (none by default).
    #[inline(always)]
    fn prefetch(&self, _node: &WideNode<W>) {}

    /// Pushes the children of `node` in `mask` (not empty) but one onto `stack` from `sp`, and returns
    /// the one to go on with: the nearest, the others pushed farthest first. With `ANY`, the first in
    /// slot order, the others pushed unsorted: any hit ends the walk, and ordering them cost more than
    /// it saved (docs/PERFORMANCE.md). May write up to `W - 1` entries past the new top.
    #[inline(always)]
    fn push<const ANY: bool>(
        &self,
        node: &WideNode<W>,
        near: [f32; W],
        mask: u32,
        stack: &mut Stack,
        sp: &mut usize,
    ) -> u32 {
        if ANY {
            let first = mask.trailing_zeros() as usize;
            for slot in set_bits(mask & (mask - 1)) {
                (stack.child[*sp], stack.near[*sp]) = (node.child[slot as usize], near[slot as usize]);
                *sp += 1;
            }
            return node.child[first];
        }
        push_children(self, node, near, mask, stack, sp)
    }

    /// The sort keys of the children in `mask` by increasing entry distance `near`, each key
    /// carrying its child's slot in its low bits; those not in `mask` follow.
    #[inline(always)]
    fn order(&self, near: [f32; W], mask: u32) -> [u32; W] {
        let slot_mask = (W - 1) as u32;
        let mut k = [u32::MAX; W];
        for (i, k) in k.iter_mut().enumerate() {
            *k = if mask & (1 << i) != 0 { (order_key(near[i]) & !slot_mask) | i as u32 } else { u32::MAX };
        }
        if W == 4 {
            for (a, b) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                let (lo, hi) = (k[a].min(k[b]), k[a].max(k[b]));
                k[a] = lo;
                k[b] = hi;
            }
        } else {
            k.sort_unstable();
        }
        k
    }
}

impl NodeTest<4> for BoxRay {
    #[inline(always)]
    fn intersect(&self, node: &WideNode<4>, t_min: f32, t_max: f32) -> ([f32; 4], u32) {
        slabs(node, &self.negative, t_min, t_max, |a, lo, hi| {
            ((lo - self.origin[a]) * self.inv_near[a], (hi - self.origin[a]) * self.inv_far[a])
        })
    }
}

/// The reciprocals of a direction as [`BoxRay`] takes them for the near and the far planes; the
/// direction must not be parallel to any axis.
#[inline(always)]
pub(super) fn reciprocals(dir: Vec3A) -> (Vec3A, Vec3A) {
    let inv = Vec3A::ONE / dir;
    (inv, inv * WIDEN)
}

/// Whether `dir` can join a packet: no component zero or subnormal (parallel to a slab).
#[inline(always)]
pub(super) fn crosses_every_slab(dir: Vec3A) -> bool {
    dir.abs().cmpge(Vec3A::splat(f32::MIN_POSITIVE)).all()
}

/// A packet of rays prepared for box tests by interval arithmetic: per axis, the range of the rays'
/// origins and of their reciprocal directions. A box that any ray of the packet meets passes
/// ([`BoxRay`]'s test of each ray is bounded by this one: rounding is monotone), so a walk with it
/// reaches every node that one of the rays would reach, and some more.
///
/// The rays' directions have the same sign along each axis and cross every slab
/// ([`crosses_every_slab`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Frustum {
    /// The origin coordinate that gives the smallest entry distance (the largest along the
    /// direction), and the one that gives the largest exit distance.
    pub near_origin: [Vec4; 3],
    pub far_origin: [Vec4; 3],
    /// The smallest and largest reciprocal of the near planes, then of the far ones.
    pub inv_near: [[Vec4; 2]; 3],
    pub inv_far: [[Vec4; 2]; 3],
    pub negative: [bool; 3],
}

impl Frustum {
    /// The packet of `rays` (at least one), whose directions all have the signs `negative` and cross
    /// every slab.
    pub fn new(rays: &[Ray], negative: [bool; 3]) -> Self {
        let (mut o_min, mut o_max) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let (mut d_min, mut d_max) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        for ray in rays {
            o_min = o_min.min(ray.origin);
            o_max = o_max.max(ray.origin);
            d_min = d_min.min(ray.dir);
            d_max = d_max.max(ray.dir);
        }
        Self::from_extremes([o_min, o_max], [d_min, d_max], negative)
    }

    /// The packet of rays whose origins range over `[o_min, o_max]` and directions over
    /// `[d_min, d_max]` (each the minimum or maximum of the rays' coordinates, in any order), with the
    /// signs `negative`.
    #[inline(always)]
    pub fn from_extremes([o_min, o_max]: [Vec3A; 2], [d_min, d_max]: [Vec3A; 2], negative: [bool; 3]) -> Self {
        // The rays' reciprocals range between those of the extreme directions: on each side of zero
        // (each axis's components share a sign and none is zero) `1 / d` falls as `d` grows, rounding
        // included, and the far planes' factor is positive. So these are the smallest and largest of
        // the rays' own `reciprocals`, bit for bit, for two divisions instead of one per ray.
        let (near_min, far_min) = reciprocals(d_max);
        let (near_max, far_max) = reciprocals(d_min);
        // Zeros of either sign made positive, so that the frustum does not depend on the order in
        // which the extremes were gathered (`minps` of two zeros gives its second operand).
        let (o_min, o_max) = ((o_min + Vec3A::ZERO).to_array(), (o_max + Vec3A::ZERO).to_array());
        let (near_min, near_max, far_min, far_max) =
            (near_min.to_array(), near_max.to_array(), far_min.to_array(), far_max.to_array());
        // Along a positive direction the entry distance falls as the origin moves up the axis; along a
        // negative one, as it moves down.
        let pick = |a: usize, up: bool| Vec4::splat(if up { o_max[a] } else { o_min[a] });
        Self {
            near_origin: [0, 1, 2].map(|a| pick(a, !negative[a])),
            far_origin: [0, 1, 2].map(|a| pick(a, negative[a])),
            inv_near: [0, 1, 2].map(|a| [Vec4::splat(near_min[a]), Vec4::splat(near_max[a])]),
            inv_far: [0, 1, 2].map(|a| [Vec4::splat(far_min[a]), Vec4::splat(far_max[a])]),
            negative,
        }
    }
}

impl NodeTest<4> for Frustum {
    #[inline(always)]
    fn intersect(&self, node: &WideNode<4>, t_min: f32, t_max: f32) -> ([f32; 4], u32) {
        slabs(node, &self.negative, t_min, t_max, |a, lo, hi| {
            let [n0, n1] = self.inv_near[a];
            let [f0, f1] = self.inv_far[a];
            // The product's extremes over the reciprocals' range are at its ends.
            let x = lo - self.near_origin[a];
            let y = hi - self.far_origin[a];
            ((x * n0).min(x * n1), (y * f0).max(y * f1))
        })
    }
}

/// The slab test of a node's four children: `planes(axis, near planes, far planes)` gives the
/// distances to each axis's planes (the near ones chosen by the signs `negative`); returns the entry
/// distances and the mask of the children met within `[t_min, t_max]`.
#[inline(always)]
fn slabs(
    node: &WideNode<4>,
    negative: &[bool; 3],
    t_min: f32,
    t_max: f32,
    planes: impl Fn(usize, Vec4, Vec4) -> (Vec4, Vec4),
) -> ([f32; 4], u32) {
    let mut near = Vec4::splat(t_min);
    let mut far = Vec4::splat(t_max);
    for (a, &negative) in negative.iter().enumerate() {
        // A bool indexes without a bounds check: the planes' offsets are the ray's, not the node's.
        let neg = negative as usize;
        let plane = |i: usize| Vec4::from_array(node.bounds[i]);
        let (tn, tf) = planes(a, plane(2 * a + neg), plane(2 * a + 1 - neg));
        // maxps/minps return their second operand when either is NaN: a NaN product leaves the
        // bound as it was (glam's scalar fallback, f32::max/min, does the same).
        near = tn.max(near);
        far = tf.min(far);
    }
    (near.to_array(), near.cmple(far).bitmask())
}

/// What a ray's box test needs per axis, before it is splatted across lanes: the origin, the
/// reciprocal direction for the near and the far planes, and whether the direction is negative.
pub(super) struct SlabRay {
    pub origin: [f32; 3],
    pub inv_near: [f32; 3],
    pub inv_far: [f32; 3],
    pub negative: [bool; 3],
}

impl SlabRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        // All three axes at once, without branches.
        let d = ray.dir;
        // Parallel: (min - o) * inf is +inf (a miss) when the origin is below the slab, and
        // (max - o) * inf is -inf when above; on a face the product is NaN, which the comparisons of
        // `intersect` ignore.
        let parallel = d.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE));
        let (inv, inv_far) = reciprocals(d);
        let negative = (d.cmplt(Vec3A::ZERO) & !parallel).bitmask();
        Self {
            origin: ray.origin.to_array(),
            inv_near: Vec3A::select(parallel, Vec3A::INFINITY, inv).to_array(),
            inv_far: Vec3A::select(parallel, Vec3A::INFINITY, inv_far).to_array(),
            negative: [negative & 1 != 0, negative & 2 != 0, negative & 4 != 0],
        }
    }
}

impl BoxRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let r = SlabRay::new(ray);
        Self {
            origin: r.origin.map(Vec4::splat),
            inv_near: r.inv_near.map(Vec4::splat),
            inv_far: r.inv_far.map(Vec4::splat),
            negative: r.negative,
        }
    }
}

/// Number of bits set in each four-bit mask.
const HIT_COUNT: [u8; 16] = {
    let mut t = [0u8; 16];
    let mut m = 0;
    while m < t.len() {
        t[m] = (m as u32).count_ones() as u8;
        m += 1;
    }
    t
};

/// What a walk does at each leaf it reaches: tests the leaf's items and returns the new end of the
/// ray's range (below `t_min` ends an any-hit walk). Closures are leaf tests; the triangles' tests are
/// types whose method is always inlined, so that they are compiled with the walk's target features.
pub(super) trait LeafTest<T> {
    fn test(&mut self, leaf: u32, t_max: f32, tally: &mut T) -> f32;

    /// Starts loading the leaf's triangles into the cache, where the leaf test can (none by default).
    #[inline(always)]
    fn prefetch(&self, _leaf: u32) {}
}

impl<T, F: FnMut(u32, f32, &mut T) -> f32> LeafTest<T> for F {
    #[inline(always)]
    fn test(&mut self, leaf: u32, t_max: f32, tally: &mut T) -> f32 {
        self(leaf, t_max, tally)
    }
}

/// The traversal stack: the children still to visit and their entry distances, in two arrays so that
/// a node's children can be pushed with one vector store each.
pub(super) struct Stack<'a> {
    pub child: &'a mut [u32],
    pub near: &'a mut [f32],
}

/// The bits set in `mask`, lowest first: the children of a node's hit mask, or the lanes of a leaf's
/// candidate or hit mask in the order the scalar loops take them.
#[inline(always)]
pub(super) fn set_bits(mut mask: u32) -> impl Iterator<Item = u32> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let bit = mask.trailing_zeros();
            mask &= mask - 1;
            bit
        })
    })
}

/// [`set_bits`] of a mask of up to 64 bits (a packet's rays), as indices. (`set_bits` keeps its own
/// loop on 32 bits: through this one, the dragon's render took 1.9 % more instructions.)
#[inline(always)]
pub(super) fn set_bits64(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let bit = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            bit
        })
    })
}

/// `f`'s bits mapped so that unsigned integer order is float order (NaN aside).
#[inline(always)]
pub(super) fn order_key(f: f32) -> u32 {
    let b = f.to_bits();
    b ^ (((b as i32) >> 31) as u32 | 0x8000_0000)
}

/// A wide tree of nodes of `W` children: nodes and the reference of the root (an inner node or a
/// single leaf).
#[derive(Clone, Debug)]
pub(super) struct WideTree<const W: usize> {
    nodes: Vec<WideNode<W>>,
    root: u32,
    bounds: Aabb,
    /// Levels of inner nodes on the longest path.
    depth: usize,
    /// Whether walks prefetch the next entry of their stack ([`WideTree::prefetch_when_larger`]).
    prefetch: bool,
}

impl<const W: usize> WideTree<W> {
    /// Collapses the binary tree `bin` (non-empty) greedily: each wide node takes the binary node's
    /// children and opens the largest inner ones until it has `W`. `leaf` turns a binary leaf's item
    /// range and box into a leaf reference. The reference [`WideTree::collapse`]'s cost is held to.
    #[cfg(test)]
    pub fn collapse_greedily(bin: &[Node], mut leaf: impl FnMut(usize, usize, Aabb) -> u32) -> Self {
        let mut nodes = Vec::with_capacity(bin.len() / (W - 1) + 1);
        let root = collapse_node(bin, 0, &mut nodes, &mut leaf);
        let mut tree = Self { nodes, root, bounds: bin[0].aabb(), depth: 0, prefetch: false };
        tree.depth = tree.depth_below(root);
        tree
    }

    /// Collapses the binary tree `bin` (non-empty) as `plan` says: its leaves are the plan's, each
    /// wide node's children the binary nodes the plan gives it. `leaf` turns a leaf's item range and
    /// box into a leaf reference.
    pub fn collapse(bin: &[Node], plan: &Plan<W>, mut leaf: impl FnMut(usize, usize, Aabb) -> u32) -> Self {
        let mut nodes = Vec::with_capacity(bin.len() / (W - 1) + 1);
        let root = planned_node(bin, plan, 0, &mut nodes, &mut leaf);
        let mut tree = Self { nodes, root, bounds: bin[0].aabb(), depth: 0, prefetch: false };
        tree.depth = tree.depth_below(root);
        tree
    }

    /// Makes walks prefetch the entry on top of their stack after each push (the child a walk goes on
    /// with when the one it took ends) when the whole structure, `bytes` with the leaves, is larger than
    /// `threshold`: the memory reads of the next subtree then overlap the walk of this one. Below it the
    /// structure stays in the caches and the prefetch is only a cost.
    pub fn prefetch_when_larger(&mut self, bytes: usize, threshold: usize) {
        self.prefetch = bytes > threshold;
    }

    fn depth_below(&self, r: u32) -> usize {
        if r & LEAF != 0 || r == EMPTY {
            return 0;
        }
        1 + self.nodes[r as usize].child.iter().map(|&c| self.depth_below(c)).max().unwrap_or(0)
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The closest-hit walk: [`WideTree::walk`] without `ANY`.
    #[inline(always)]
    pub fn closest<T: Tally>(
        &self,
        ray: &impl NodeTest<W>,
        t_min: f32,
        t_max: f32,
        tally: &mut T,
        leaf: &mut impl LeafTest<T>,
    ) {
        self.walk::<false, T>(ray, t_min, t_max, tally, leaf)
    }

    /// Visits the leaves the ray meets within `[t_min, t_max]`, nearest box first, skipping boxes
    /// entered beyond the closest hit so far. `leaf` tests one leaf and returns the new `t_max`. With
    /// `ANY`, an any-hit walk: children are taken in slot order (see [`NodeTest::push`]) and the walk
    /// stops as soon as `leaf` returns a `t_max` below `t_min`.
    #[inline(always)]
    pub fn walk<const ANY: bool, T: Tally>(
        &self,
        ray: &impl NodeTest<W>,
        t_min: f32,
        mut t_max: f32,
        tally: &mut T,
        leaf: &mut impl LeafTest<T>,
    ) {
        // Down to the first node with two children or more, no stack is needed: many rays (those that
        // miss the mesh near its silhouette) end on that path, and clearing a stack is a large part
        // of their cost.
        // Boxes are tested, and entries kept, up to the `reach` of the closest hit so far (of the
        // query's end, for an any-hit walk: a box entered just past it, as rounded, may hold a hit at
        // the end itself).
        let mut end = reach(t_max);
        let mut cur = self.root;
        let (near, mask) = loop {
            if cur & LEAF != 0 {
                leaf.test(cur, t_max, tally);
                return;
            }
            let node = &self.nodes[cur as usize];
            tally.visited();
            let (near, mask) = if ANY { ray.intersect_any(node, t_min, end) } else { ray.intersect(node, t_min, end) };
            if mask & mask.wrapping_sub(1) != 0 {
                break (near, mask);
            }
            if mask == 0 {
                return;
            }
            cur = node.child[mask.trailing_zeros() as usize];
        };
        // Each level pushes at most W - 1 entries (and writes up to W - 1 past the top). One walk for
        // every stack size, so that the walk's code exists once per query.
        let need = (W - 1) * (self.depth + 1);
        let (mut short_child, mut short_near) = ([0u32; 40], [0.0f32; 40]);
        let (mut medium, mut long, mut huge);
        let mut stack = if need <= 40 {
            Stack { child: &mut short_child, near: &mut short_near }
        } else if need <= 64 {
            medium = ([0u32; 64], [0.0f32; 64]);
            Stack { child: &mut medium.0, near: &mut medium.1 }
        } else if need <= STACK {
            long = ([0u32; STACK], [0.0f32; STACK]);
            Stack { child: &mut long.0, near: &mut long.1 }
        } else {
            // Deeper than the binary build makes trees: not reached, but no panic if it were.
            huge = (vec![0u32; need], vec![0.0f32; need]);
            Stack { child: &mut huge.0, near: &mut huge.1 }
        };
        let mut sp = 0;
        cur = ray.push::<ANY>(&self.nodes[cur as usize], near, mask, &mut stack, &mut sp);
        self.prefetch_top(ray, leaf, &stack, sp);
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                tally.visited();
                let (near, mask) =
                    if ANY { ray.intersect_any(node, t_min, end) } else { ray.intersect(node, t_min, end) };
                if mask != 0 {
                    cur = ray.push::<ANY>(node, near, mask, &mut stack, &mut sp);
                    self.prefetch_top(ray, leaf, &stack, sp);
                    continue;
                }
            } else {
                t_max = leaf.test(cur, t_max, tally);
                if ANY && t_max < t_min {
                    // An any-hit query has its answer.
                    return;
                }
                end = reach(t_max);
            }
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                if stack.near[sp] <= end {
                    cur = stack.child[sp];
                    break;
                }
            }
        }
    }

    /// Checks the tree's invariants: every node reached once from the root, each child's box inside
    /// its parent's (the root's inside the tree's bounds), unused slots empty and last, the depth the
    /// one recorded and at most [`MAX_DEPTH`]. `leaf(reference, box)` checks each leaf against the box
    /// its parent holds for it.
    pub fn validate(&self, mut leaf: impl FnMut(u32, Aabb) -> Result<(), String>) -> Result<(), String> {
        let mut reached = vec![false; self.nodes.len()];
        let depth = self.validate_below(self.root, self.bounds, &mut reached, &mut leaf)?;
        if depth != self.depth {
            return Err(format!("depth {depth}, recorded as {}", self.depth));
        }
        if depth > MAX_DEPTH {
            return Err(format!("depth {depth} beyond {MAX_DEPTH}"));
        }
        match reached.iter().position(|r| !r) {
            Some(n) => Err(format!("node {n} not reached from the root")),
            None => Ok(()),
        }
    }

    /// [`WideTree::validate`] of the subtree `r` inside `outer`; returns its depth.
    fn validate_below(
        &self,
        r: u32,
        outer: Aabb,
        reached: &mut [bool],
        leaf: &mut impl FnMut(u32, Aabb) -> Result<(), String>,
    ) -> Result<usize, String> {
        if r & LEAF != 0 {
            leaf(r, outer)?;
            return Ok(0);
        }
        let Some(seen) = reached.get_mut(r as usize) else { return Err(format!("child {r} past the nodes")) };
        if std::mem::replace(seen, true) {
            return Err(format!("node {r} reached twice"));
        }
        let node = &self.nodes[r as usize];
        let mut depth = 0;
        let mut used = 0;
        for slot in 0..W {
            let bound = |i: usize| node.bounds[i][slot];
            let inner = Aabb::new(Vec3A::new(bound(0), bound(2), bound(4)), Vec3A::new(bound(1), bound(3), bound(5)));
            let child = node.child[slot];
            if child == EMPTY {
                if (0..6).any(|i| bound(i) != WideNode::<W>::EMPTY.bounds[i][0]) {
                    return Err(format!("node {r}: unused slot {slot} with a box"));
                }
                continue;
            }
            if used != slot {
                return Err(format!("node {r}: slot {slot} used after an unused one"));
            }
            used += 1;
            if inner.is_empty() || !outer.contains(inner.min) || !outer.contains(inner.max) {
                return Err(format!("node {r}: the box of slot {slot} {inner:?} is not inside {outer:?}"));
            }
            depth = depth.max(self.validate_below(child, inner, reached, leaf)?);
        }
        if used < 2 {
            return Err(format!("node {r} with {used} children"));
        }
        Ok(depth + 1)
    }

    /// Prefetches the node or leaf on top of the stack, if the tree prefetches.
    #[inline(always)]
    fn prefetch_top<T>(&self, ray: &impl NodeTest<W>, leaf: &impl LeafTest<T>, stack: &Stack, sp: usize) {
        if self.prefetch && sp > 0 {
            let top = stack.child[sp - 1];
            if top & LEAF == 0 {
                ray.prefetch(&self.nodes[top as usize]);
            } else {
                leaf.prefetch(top);
            }
        }
    }
}

/// [`NodeTest::push`] by scalar code: the children in `mask` but the nearest pushed farthest first.
#[inline(always)]
fn push_children<const W: usize>(
    ray: &(impl NodeTest<W> + ?Sized),
    node: &WideNode<W>,
    near: [f32; W],
    mut mask: u32,
    stack: &mut Stack,
    sp: &mut usize,
) -> u32 {
    let first = mask.trailing_zeros() as usize;
    mask &= mask - 1;
    if mask == 0 {
        return node.child[first];
    }
    let second = mask.trailing_zeros() as usize;
    mask &= mask - 1;
    if mask == 0 {
        // Two children, the most common case: order them without a branch.
        let (a, b) = if near[second] < near[first] { (second, first) } else { (first, second) };
        (stack.child[*sp], stack.near[*sp]) = (node.child[b], near[b]);
        *sp += 1;
        return node.child[a];
    }
    // Three children or more: sort them by entry distance, push all but the nearest, farthest first
    // (W - 1 entries written, those past the hit ones above the stack's top), and go on with the nearest.
    mask |= (1 << first) | (1 << second);
    let slot_mask = (W - 1) as u32;
    let k = ray.order(near, mask);
    // A table for four bits: without the popcnt instruction (baseline x86-64) count_ones is a long
    // sequence; the eight-wide walk runs where popcnt is.
    let n = if W == 4 { HIT_COUNT[mask as usize & 15] as usize } else { mask.count_ones() as usize };
    for j in 0..W - 1 {
        let slot = (k[(n + W - 1 - j) % W] & slot_mask) as usize;
        (stack.child[*sp + j], stack.near[*sp + j]) = (node.child[slot], near[slot]);
    }
    *sp += n - 1;
    node.child[(k[0] & slot_mask) as usize]
}

fn planned_node<const W: usize>(
    bin: &[Node],
    plan: &Plan<W>,
    b: usize,
    out: &mut Vec<WideNode<W>>,
    leaf: &mut impl FnMut(usize, usize, Aabb) -> u32,
) -> u32 {
    if let Some((first, count)) = plan.leaf(b) {
        return leaf(first, count, bin[b].aabb());
    }
    let mut children = [0usize; W];
    let n = plan.children(bin, b, &mut children);
    wide_node(bin, &children[..n], out, |c, out| planned_node(bin, plan, c, out, leaf))
}

/// Appends the wide node whose children are the binary nodes `children`, each made by `child`, after
/// them in `out`; its index.
fn wide_node<const W: usize>(
    bin: &[Node],
    children: &[usize],
    out: &mut Vec<WideNode<W>>,
    mut child: impl FnMut(usize, &mut Vec<WideNode<W>>) -> u32,
) -> u32 {
    let me = out.len();
    out.push(WideNode::EMPTY);
    let mut wide = WideNode::EMPTY;
    for (slot, &c) in children.iter().enumerate() {
        let b = &bin[c];
        for a in 0..3 {
            wide.bounds[2 * a][slot] = b.min[a];
            wide.bounds[2 * a + 1][slot] = b.max[a];
        }
        wide.child[slot] = child(c, out);
    }
    out[me] = wide;
    me as u32
}

#[cfg(test)]
fn collapse_node<const W: usize>(
    bin: &[Node],
    b: usize,
    out: &mut Vec<WideNode<W>>,
    leaf: &mut impl FnMut(usize, usize, Aabb) -> u32,
) -> u32 {
    let node = &bin[b];
    if node.count > 0 {
        return leaf(node.offset as usize, node.count as usize, node.aabb());
    }
    let mut children = [0usize; W];
    children[0] = node.offset as usize;
    children[1] = node.offset as usize + 1;
    let mut n = 2;
    while n < W {
        // Open the inner child with the largest surface area.
        let largest = (0..n)
            .filter(|&i| bin[children[i]].count == 0)
            .max_by(|&i, &j| bin[children[i]].aabb().surface_area().total_cmp(&bin[children[j]].aabb().surface_area()));
        let Some(i) = largest else { break };
        let c = children[i];
        children[i] = bin[c].offset as usize;
        children[n] = bin[c].offset as usize + 1;
        n += 1;
    }
    wide_node(bin, &children[..n], out, |c, out| collapse_node(bin, c, out, leaf))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::super::build::{BuildItem, BvhBuild, build_binary};
    use super::*;

    /// [`WideTree::validate`] accepts a collapsed tree and finds each way of breaking it: a child's box
    /// outside its parent's, a wrong depth, a node reached twice.
    #[test]
    fn validate_finds_broken_nodes() {
        let mut items: Vec<BuildItem> = (0..64u32)
            .map(|i| {
                let c = Vec3A::new(i as f32, (i * 7 % 13) as f32, (i % 5) as f32);
                let bounds = Aabb::new(c, c + Vec3A::ONE);
                BuildItem { bounds, centroid: bounds.centroid(), index: i }
            })
            .collect();
        let bin = build_binary(&mut items, BvhBuild::Sah, 1, 4);
        let tree = WideTree::<4>::collapse(&bin, &Plan::new(&bin, 4, 1), |first, count, _| leaf_ref(first, count));
        let leaves = || |_, _| Ok(());
        assert_eq!(tree.validate(leaves()), Ok(()));
        assert!(tree.nodes.len() > 2 && tree.nodes[0].child[0] == 1, "a root with an inner first child");
        let mut grown = tree.clone();
        grown.nodes[1].bounds[1][0] += 1000.0;
        assert!(grown.validate(leaves()).is_err());
        let mut deeper = tree.clone();
        deeper.depth += 1;
        assert!(deeper.validate(leaves()).is_err());
        let mut twice = tree.clone();
        twice.nodes[0].child[1] = 1;
        assert!(twice.validate(leaves()).is_err());
    }

    /// The surface area cost of `tree` as [`Plan`] weighs it, in f64: each node's box area times the
    /// node cost, each leaf's box area for each block of `block` items.
    fn cost<const W: usize>(tree: &WideTree<W>, block: usize) -> f64 {
        fn below<const W: usize>(tree: &WideTree<W>, r: u32, area: f64, block: usize) -> f64 {
            if r & LEAF != 0 {
                return area * leaf_range(r).1.div_ceil(block) as f64;
            }
            let node = &tree.nodes[r as usize];
            let children: f64 = (0..W)
                .filter(|&slot| node.child[slot] != EMPTY)
                .map(|slot| {
                    let lo = Vec3A::new(node.bounds[0][slot], node.bounds[2][slot], node.bounds[4][slot]);
                    let hi = Vec3A::new(node.bounds[1][slot], node.bounds[3][slot], node.bounds[5][slot]);
                    below(tree, node.child[slot], area_f64(lo, hi), block)
                })
                .sum();
            super::super::collapse::NODE_COST * area + children
        }
        fn area_f64(lo: Vec3A, hi: Vec3A) -> f64 {
            let [x, y, z] = (hi - lo).to_array().map(f64::from);
            2.0 * (x * y + y * z + z * x)
        }
        below(tree, tree.root, area_f64(tree.bounds.min, tree.bounds.max), block)
    }

    /// `count` boxes of random places and sizes in a flat slab `scale` wide (at 3e38, the areas of
    /// the larger boxes overflow f32), from `seed`.
    fn scattered_boxes(seed: u64, count: usize, scale: f32) -> Vec<BuildItem> {
        use rand_core::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut unit = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        (0..count as u32)
            .map(|index| {
                let c = Vec3A::new(unit() - 0.5, unit() - 0.5, (unit() - 0.5) * 0.1) * scale;
                let half = Vec3A::new(unit(), unit(), unit()) * 0.015 * scale;
                let bounds = Aabb::new(c - half, c + half);
                BuildItem { bounds, centroid: bounds.centroid(), index }
            })
            .collect()
    }

    /// Checks the collapse by cost of `items`' binary tree: each item in exactly one leaf, inside the
    /// leaf's box; no leaf larger than `max_leaf` items or the binary tree's largest leaf; as many
    /// leaves as the plan counts; a cost no higher than the greedy collapse's. Returns both costs.
    fn check_planned<const W: usize>(
        items: &mut [BuildItem],
        method: BvhBuild,
        block: usize,
        max_leaf: usize,
    ) -> (f64, f64) {
        let boxes: Vec<Aabb> = {
            let mut b = vec![Aabb::EMPTY; items.len()];
            for it in items.iter() {
                b[it.index as usize] = it.bounds;
            }
            b
        };
        let bin = build_binary(items, method, block, max_leaf);
        let largest = bin.iter().map(|node| node.count as usize).max().unwrap_or(0).max(max_leaf);
        let plan = Plan::<W>::new(&bin, max_leaf, block);
        let planned = WideTree::<W>::collapse(&bin, &plan, |first, count, _| leaf_ref(first, count));
        let greedy = WideTree::<W>::collapse_greedily(&bin, |first, count, _| leaf_ref(first, count));
        let mut seen = vec![0u32; items.len()];
        let mut leaves = 0;
        planned
            .validate(|r, bounds| {
                let (first, count) = leaf_range(r);
                leaves += 1;
                if count > largest {
                    return Err(format!("a leaf of {count} items"));
                }
                for it in &items[first..first + count] {
                    seen[it.index as usize] += 1;
                    let b = boxes[it.index as usize];
                    if !(bounds.contains(b.min) && bounds.contains(b.max)) {
                        return Err(format!("item {} outside its leaf's box", it.index));
                    }
                }
                Ok(())
            })
            .unwrap();
        assert!(seen.iter().all(|&n| n == 1), "each item in one leaf");
        assert_eq!(leaves, plan.leaf_count(&bin));
        let (by_cost, greedily) = (cost(&planned, block), cost(&greedy, block));
        assert!(by_cost <= greedily * (1.0 + 1e-9), "by cost {by_cost}, greedily {greedily}");
        (by_cost, greedily)
    }

    /// On a thousand scattered boxes, the collapse by cost is cheaper than the greedy one, in both
    /// widths and with either build.
    #[test]
    fn collapse_by_cost_beats_the_greedy_collapse() {
        for method in [BvhBuild::Sah, BvhBuild::Midpoint] {
            let (by_cost, greedily) = check_planned::<8>(&mut scattered_boxes(7, 1000, 20.0), method, 8, 8);
            assert!(by_cost < 0.95 * greedily, "{method:?}: by cost {by_cost}, greedily {greedily}");
            let (by_cost, greedily) = check_planned::<4>(&mut scattered_boxes(7, 1000, 20.0), method, 4, 8);
            assert!(by_cost < greedily, "{method:?}: by cost {by_cost}, greedily {greedily}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        /// The collapse by cost holds every item once, in leaves around it, and costs no more than
        /// the greedy collapse, whatever the boxes, their number, the build and the width.
        #[test]
        fn collapse_by_cost_is_sound_and_no_dearer(
            seed in any::<u64>(),
            count in 1usize..400,
            scale in prop_oneof![Just(20.0f32), Just(1e-30), Just(3e38)],
            midpoint in any::<bool>(),
            max_leaf in 1usize..=8,
        ) {
            let method = if midpoint { BvhBuild::Midpoint } else { BvhBuild::Sah };
            check_planned::<8>(&mut scattered_boxes(seed, count, scale), method, 8, max_leaf);
            check_planned::<4>(&mut scattered_boxes(seed, count, scale), method, 4, max_leaf);
        }
    }

    fn arb_vec(range: f32) -> impl Strategy<Value = Vec3A> {
        prop::array::uniform3(-range..range).prop_map(Vec3A::from_array)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(5_000))]
        /// A packet's reciprocal bounds are the smallest and largest of its rays' own `reciprocals`,
        /// bit for bit: tiny, huge and equal components of either sign included.
        #[test]
        fn frustum_bounds_are_the_rays_reciprocals(
            dirs in prop::collection::vec(prop::array::uniform3(prop_oneof![
                Just(f32::MIN_POSITIVE), Just(1.0f32), Just(f32::MAX), 1e-30f32..1e-20, 0.0001f32..1.0, 1e20f32..1e30,
            ]), 1..=8),
            signs in prop::array::uniform3(any::<bool>()),
        ) {
            let flip = Vec3A::from_array(signs.map(|s| if s { -1.0 } else { 1.0 }));
            let rays: Vec<Ray> = dirs.iter().map(|d| Ray::new(Vec3A::ZERO, Vec3A::from_array(*d) * flip)).collect();
            let f = Frustum::new(&rays, signs);
            for a in 0..3 {
                let ends = |i: usize, far: bool| {
                    let (near, far_inv) = reciprocals(rays[i].dir);
                    if far { far_inv[a] } else { near[a] }
                };
                for (far, [lo, hi]) in [(false, f.inv_near[a]), (true, f.inv_far[a])] {
                    let lowest = (0..rays.len()).map(|i| ends(i, far)).fold(f32::INFINITY, f32::min);
                    let highest = (0..rays.len()).map(|i| ends(i, far)).fold(f32::NEG_INFINITY, f32::max);
                    prop_assert_eq!((lo.x.to_bits(), hi.x.to_bits()), (lowest.to_bits(), highest.to_bits()));
                }
            }
        }

        /// One box answers as the node of that one box, bit for bit: rays parallel to slabs, origins on
        /// faces, one ulp past them and inside, ranges that are empty, infinite or NaN.
        #[test]
        fn one_box_answers_as_its_node(
            (lo, hi) in (arb_vec(10.0), arb_vec(10.0)),
            origin in prop_oneof![arb_vec(20.0), Just(Vec3A::ZERO)],
            on_face in 0..4u32,
            dir in prop::array::uniform3(prop_oneof![Just(0.0f32), Just(-0.0), Just(1e-40), Just(1.0), Just(-1.0), -1.0f32..1.0]),
            t_range in (prop_oneof![Just(0.0f32), Just(f32::NAN), -5.0f32..5.0], prop_oneof![Just(f32::INFINITY), Just(f32::NAN), 0.0f32..50.0]),
        ) {
            let b = Aabb::new(lo.min(hi), lo.max(hi));
            let past = |x: f32, up: bool| f32::from_bits(if (x >= 0.0) == up { x.to_bits() + 1 } else { x.to_bits() - 1 });
            let origin = match on_face {
                0 => Vec3A::new(b.min.x, origin.y, origin.z),
                1 if b.max.y != 0.0 => Vec3A::new(origin.x, past(b.max.y, true), origin.z),
                2 if b.min.z != 0.0 => Vec3A::new(origin.x, origin.y, past(b.min.z, false)),
                _ => origin,
            };
            let ray = Ray::new(origin, Vec3A::from_array(dir));
            let node = FewShapes::new([b]);
            prop_assert_eq!(OneBox::new(b).meets(&ray, t_range.0, t_range.1), node.meets(&ray, t_range.0, t_range.1));
        }

        /// A packet's box test passes every child that one of its rays passes, whatever the spread
        /// of the rays' origins and directions (one sign per axis), with entry distances no larger.
        #[test]
        fn frustum_passes_what_any_ray_passes(
            boxes in prop::collection::vec((arb_vec(10.0), arb_vec(10.0)), 1..=4),
            origins in prop::collection::vec(arb_vec(20.0), 1..=8),
            dirs in prop::collection::vec(prop::array::uniform3(0.0001f32..1.0), 1..=8),
            signs in prop::array::uniform3(any::<bool>()),
            spread in prop_oneof![Just(0.0f32), Just(1e-6), 0.0f32..1.0],
            t_range in (0.0f32..5.0, prop_oneof![Just(f32::INFINITY), 0.0f32..50.0]),
        ) {
            let base = origins[0];
            let rays: Vec<Ray> = dirs
                .iter()
                .zip(origins.iter().cycle())
                .map(|(d, o)| {
                    let d = Vec3A::from_array(*d) * Vec3A::from_array(signs.map(|s| if s { -1.0 } else { 1.0 }));
                    Ray::new(base + (*o - base) * spread, d)
                })
                .collect();
            let node = WideNode::<4>::of_boxes(&boxes);
            let (near, mask) = Frustum::new(&rays, signs).intersect(&node, t_range.0, t_range.1);
            for ray in &rays {
                let (ray_near, ray_mask) = BoxRay::new(ray).intersect(&node, t_range.0, t_range.1);
                prop_assert_eq!(ray_mask & !mask, 0, "a child {:b} passed by {:?} but not by the packet {:b}", ray_mask, ray, mask);
                for slot in 0..4 {
                    if ray_mask & (1 << slot) != 0 {
                        prop_assert!(near[slot] <= ray_near[slot]);
                    }
                }
            }
        }
    }
}
