//! The wide tree: nodes of four children whose boxes a ray tests together, collapsed from the binary
//! build, and the ordered traversal shared by every kind of leaf.

use glam::Vec4;
use raylume_geometry::{Aabb, Ray, Vec3A};

use super::build::Node;
use crate::Tally;

/// Children per node.
pub(super) const WIDTH: usize = 4;
/// A child reference with this bit set is a leaf: `LEAF | (count - 1) << COUNT_SHIFT | first`.
pub(super) const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 28;
/// Largest `first` a leaf reference can hold.
pub(super) const MAX_FIRST: u32 = (1 << COUNT_SHIFT) - 1;
/// An unused child slot (its box is empty, so no ray reaches it).
const EMPTY: u32 = u32::MAX;
/// Traversal stack entries: three per level of a tree at most 70 levels deep.
const STACK: usize = 256;
/// The stacks of trees at most 10 and 21 levels deep, which spare most queries clearing the large one.
const SHORTEST_STACK: usize = 32;
const SHORT_STACK: usize = 64;

/// pbrt's `1 + 2 gamma(3)`, which widens the far end of each slab against rounding.
const WIDEN: f32 = 1.0 + 2.0 * raylume_geometry::gamma(3);

/// One node: the boxes of its four children, stored by plane (`bounds[0..3]` the minima along x, y,
/// z, `bounds[3..6]` the maxima, one lane per child) so that one ray tests all four together.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct WideNode {
    bounds: [Vec4; 6],
    child: [u32; WIDTH],
}

const _: () = assert!(std::mem::size_of::<WideNode>() == 128);

const EMPTY_NODE: WideNode = WideNode {
    bounds: [
        Vec4::INFINITY,
        Vec4::INFINITY,
        Vec4::INFINITY,
        Vec4::NEG_INFINITY,
        Vec4::NEG_INFINITY,
        Vec4::NEG_INFINITY,
    ],
    child: [EMPTY; WIDTH],
};

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
pub(super) struct BoxRay {
    origin: [Vec4; 3],
    inv_near: [Vec4; 3],
    inv_far: [Vec4; 3],
    negative: [bool; 3],
}

impl BoxRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        // All three axes at once, without branches.
        let d = ray.dir;
        // Parallel: (min - o) * inf is +inf (a miss) when the origin is below the slab, and
        // (max - o) * inf is -inf when above; on a face the product is NaN, which the comparisons of
        // `intersect` ignore.
        let parallel = d.abs().cmplt(Vec3A::splat(f32::MIN_POSITIVE));
        let inv = Vec3A::ONE / d;
        let inv_near = Vec3A::select(parallel, Vec3A::INFINITY, inv).to_array();
        let inv_far = Vec3A::select(parallel, Vec3A::INFINITY, inv * WIDEN).to_array();
        let negative = (d.cmplt(Vec3A::ZERO) & !parallel).bitmask();
        Self {
            origin: ray.origin.to_array().map(Vec4::splat),
            inv_near: inv_near.map(Vec4::splat),
            inv_far: inv_far.map(Vec4::splat),
            negative: [negative & 1 != 0, negative & 2 != 0, negative & 4 != 0],
        }
    }

    /// The entry distances of the four children and the mask of those the ray meets within
    /// `[t_min, t_max]`.
    #[inline(always)]
    fn intersect(&self, node: &WideNode, t_min: f32, t_max: f32) -> (Vec4, u32) {
        let mut near = Vec4::splat(t_min);
        let mut far = Vec4::splat(t_max);
        for a in 0..3 {
            let (lo, hi) = if self.negative[a] {
                (node.bounds[a + 3], node.bounds[a])
            } else {
                (node.bounds[a], node.bounds[a + 3])
            };
            let tn = (lo - self.origin[a]) * self.inv_near[a];
            let tf = (hi - self.origin[a]) * self.inv_far[a];
            // maxps/minps return their second operand when either is NaN: a NaN product leaves the
            // bound as it was (glam's scalar fallback, f32::max/min, does the same).
            near = tn.max(near);
            far = tf.min(far);
        }
        (near, near.cmple(far).bitmask())
    }
}

/// Number of bits set in each four-bit mask.
const HIT_COUNT: [u8; 1 << WIDTH] = {
    let mut t = [0u8; 1 << WIDTH];
    let mut m = 0;
    while m < t.len() {
        t[m] = (m as u32).count_ones() as u8;
        m += 1;
    }
    t
};

/// `f`'s bits mapped so that unsigned integer order is float order (NaN aside).
#[inline(always)]
fn order_key(f: f32) -> u32 {
    let b = f.to_bits();
    b ^ (((b as i32) >> 31) as u32 | 0x8000_0000)
}

/// A wide tree: nodes and the reference of the root (an inner node or a single leaf).
#[derive(Clone, Debug)]
pub(super) struct WideTree {
    nodes: Vec<WideNode>,
    root: u32,
    bounds: Aabb,
    /// Levels of inner nodes on the longest path.
    depth: usize,
}

impl WideTree {
    /// Collapses the binary tree `bin` (non-empty): each wide node takes the binary node's children
    /// and opens the largest inner ones until it has four. `leaf` turns a binary leaf's item range
    /// into a leaf reference.
    pub fn collapse(bin: &[Node], mut leaf: impl FnMut(usize, usize) -> u32) -> Self {
        let mut nodes = Vec::with_capacity(bin.len() / 2 + 1);
        let root = collapse_node(bin, 0, &mut nodes, &mut leaf);
        let mut tree = Self { nodes, root, bounds: bin[0].aabb(), depth: 0 };
        tree.depth = tree.depth_below(root);
        tree
    }

    fn depth_below(&self, r: u32) -> usize {
        if r & LEAF != 0 {
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

    /// Visits the leaves the ray meets within `[t_min, t_max]`, nearest box first, skipping boxes
    /// entered beyond the closest hit so far. `leaf` tests one leaf and returns the new `t_max`; with
    /// `ANY`, the walk stops as soon as it returns a `t_max` below `t_min`.
    #[inline(always)]
    pub fn closest<const ANY: bool, T: Tally>(
        &self,
        ray: &BoxRay,
        t_min: f32,
        t_max: f32,
        tally: &mut T,
        leaf: impl FnMut(u32, f32, &mut T) -> f32,
    ) {
        // Each level pushes at most three entries. One walk for every stack size, so that the leaf
        // test has one call site (and is inlined).
        let mut short = [(0u32, 0.0f32); SHORTEST_STACK];
        let mut medium;
        let mut long;
        let stack: &mut [(u32, f32)] = if 3 * self.depth < SHORTEST_STACK {
            &mut short
        } else if 3 * self.depth < SHORT_STACK {
            medium = [(0u32, 0.0f32); SHORT_STACK];
            &mut medium
        } else {
            long = [(0u32, 0.0f32); STACK];
            &mut long
        };
        self.walk::<ANY, T>(stack, ray, t_min, t_max, tally, leaf)
    }

    #[inline(always)]
    fn walk<const ANY: bool, T: Tally>(
        &self,
        stack: &mut [(u32, f32)],
        ray: &BoxRay,
        t_min: f32,
        mut t_max: f32,
        tally: &mut T,
        mut leaf: impl FnMut(u32, f32, &mut T) -> f32,
    ) {
        let mut sp = 0;
        let mut cur = self.root;
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                tally.visited();
                let (near, mut mask) = ray.intersect(node, t_min, t_max);
                if mask != 0 {
                    let first = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        cur = node.child[first];
                        continue;
                    }
                    let near = near.to_array();
                    let second = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        // Two children, the most common case: order them without a branch.
                        let (a, b) = if near[second] < near[first] { (second, first) } else { (first, second) };
                        stack[sp] = (node.child[b], near[b]);
                        sp += 1;
                        cur = node.child[a];
                        continue;
                    }
                    // Three or four children: sort the four slots by entry distance with a network
                    // (keys carry the slot in their two low bits; missed slots sort last), push the
                    // hit ones but the nearest, farthest first, and go on with the nearest.
                    mask |= (1 << first) | (1 << second);
                    let mut k = [u32::MAX; WIDTH];
                    for (i, key) in k.iter_mut().enumerate() {
                        if mask & (1 << i) != 0 {
                            *key = (order_key(near[i]) & !3) | i as u32;
                        }
                    }
                    for (a, b) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                        let (lo, hi) = (k[a].min(k[b]), k[a].max(k[b]));
                        k[a] = lo;
                        k[b] = hi;
                    }
                    // A table: without the popcnt instruction (baseline x86-64) count_ones is a long sequence.
                    let n = HIT_COUNT[mask as usize] as usize;
                    for j in 0..WIDTH - 1 {
                        let slot = (k[(n - 1).saturating_sub(j).max(1)] & 3) as usize;
                        stack[sp + j] = (node.child[slot], near[slot]);
                    }
                    sp += n - 1;
                    cur = node.child[(k[0] & 3) as usize];
                    continue;
                }
            } else {
                t_max = leaf(cur, t_max, tally);
                if ANY && t_max < t_min {
                    // An any-hit query has its answer.
                    return;
                }
            }
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (c, d) = stack[sp];
                if d <= t_max {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Whether any leaf the ray meets within `[0, t_max]` reports a hit (`leaf` returns `true`); the
    /// nearest boxes are visited first, as shadow rays towards closed meshes meet them first.
    #[inline(always)]
    pub fn any<T: Tally>(
        &self,
        ray: &BoxRay,
        t_max: f32,
        tally: &mut T,
        mut leaf: impl FnMut(u32, &mut T) -> bool,
    ) -> bool {
        let mut hit = false;
        self.closest::<true, T>(ray, 0.0, t_max, tally, |r, t, tally| {
            if leaf(r, tally) {
                hit = true;
                f32::NEG_INFINITY
            } else {
                t
            }
        });
        hit
    }
}

fn collapse_node(bin: &[Node], b: usize, out: &mut Vec<WideNode>, leaf: &mut impl FnMut(usize, usize) -> u32) -> u32 {
    let node = &bin[b];
    if node.count > 0 {
        return leaf(node.offset as usize, node.count as usize);
    }
    let mut children = [0usize; WIDTH];
    children[0] = node.offset as usize;
    children[1] = node.offset as usize + 1;
    let mut n = 2;
    while n < WIDTH {
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
    let me = out.len();
    out.push(EMPTY_NODE);
    let mut wide = EMPTY_NODE;
    for (slot, &c) in children[..n].iter().enumerate() {
        let b = &bin[c];
        for a in 0..3 {
            wide.bounds[a][slot] = b.min[a];
            wide.bounds[a + 3][slot] = b.max[a];
        }
        wide.child[slot] = collapse_node(bin, c, out, leaf);
    }
    out[me] = wide;
    me as u32
}
