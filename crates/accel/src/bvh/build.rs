//! The binary build: binned SAH (or the course's midpoint splits) into a tree of 32-byte nodes,
//! which [`wide`](super::wide) collapses into its wide nodes.

use glam::UVec3;
use raylume_geometry::{Aabb, Vec3A};

/// Number of SAH bins per axis.
const BINS: usize = 32;
const _: () = assert!(BINS <= 32, "a bin is a bit of a u32");
/// Cost of visiting a node relative to one leaf block test (docs/PERFORMANCE.md#binned-sah-build: with
/// blocks of four triangles, 0.5 and 1 lose a few percent on incoherent rays; with blocks of eight,
/// costs from 1 to 4 build the same tree).
const TRAVERSAL_COST: f32 = 2.0;

/// How a [`Bvh`](super::Bvh) chooses its splits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BvhBuild {
    /// Binned surface area heuristic (32 bins on each axis); the SAH also decides
    /// when to stop (leaves of up to two packets of four triangles, or up to 4 other primitives).
    #[default]
    Sah,
    /// The course's build: split the node's largest axis at its midpoint, fall back to the mean of the
    /// centroids when one side would be empty, leaves of at most 2 primitives.
    Midpoint,
}

/// One node: its bounds and either the range of its primitives (leaf) or the index of its first child
/// (inner node; the second child is next to it).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct Node {
    pub min: [f32; 3],
    /// Leaf: first primitive. Inner: index of the first child (the second follows it).
    pub offset: u32,
    pub max: [f32; 3],
    /// Leaf: number of primitives (> 0). Inner: 0.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

impl Node {
    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }
}

/// What the build needs of one primitive.
pub(super) struct BuildItem {
    pub bounds: Aabb,
    pub centroid: Vec3A,
    pub index: u32,
}

/// Builds the binary tree over `items` (reordering them into leaf order): its nodes, the root first. Leaves hold at most
/// `max_leaf` items; the SAH counts a leaf's cost in blocks of `block` items (a leaf of triangles is
/// tested four at a time).
///
/// Subtrees of at least [`PARALLEL_ITEMS`] items build their two children side by side on the
/// current rayon thread pool; the nodes are then laid out as the one-thread build lays them out, so
/// the tree is the same whatever the number of threads.
pub(super) fn build_binary(items: &mut [BuildItem], method: BvhBuild, block: usize, max_leaf: usize) -> Vec<Node> {
    let mut nodes = Vec::with_capacity((2 * items.len()).max(1));
    if !items.is_empty() {
        nodes.push(PLACEHOLDER);
        let params = Params { method, block, max_leaf };
        let subtree = build_subtree(items, 0, 0, &params);
        subtree.lay_out(&mut nodes, 0);
    }
    nodes
}

struct Params {
    method: BvhBuild,
    block: usize,
    max_leaf: usize,
}

/// Depth past which splits are object medians, so the depth stays bounded (below 70) for any input.
const MEDIAN_DEPTH: usize = 36;

/// Fewest items whose two children are built side by side: below, a subtree is built on one thread
/// (a split's binning over fewer items costs less than handing it to another thread).
pub(super) const PARALLEL_ITEMS: usize = 16 * 1024;

/// A subtree built on its own: the nodes of a subtree built on one thread (its root first, children
/// indexed within them), or a split whose children were built side by side.
enum Subtree {
    Serial(Vec<Node>),
    Split(Node, Box<[Subtree; 2]>),
}

impl Subtree {
    /// Writes the subtree's root into `nodes[slot]` and appends its other nodes in the order in which
    /// [`build`] appends them.
    fn lay_out(self, nodes: &mut Vec<Node>, slot: usize) {
        match self {
            Subtree::Serial(local) => {
                // Local node `i > 0` lands at `base + i - 1`.
                let base = nodes.len();
                let place = |node: Node| match node.count {
                    0 => Node { offset: node.offset + base as u32 - 1, ..node },
                    _ => node,
                };
                nodes[slot] = place(local[0]);
                nodes.extend(local[1..].iter().map(|&n| place(n)));
            }
            Subtree::Split(node, children) => {
                let left = nodes.len();
                nodes.extend([PLACEHOLDER; 2]);
                nodes[slot] = Node { offset: left as u32, count: 0, ..node };
                let [l, r] = *children;
                l.lay_out(nodes, left);
                r.lay_out(nodes, left + 1);
            }
        }
    }
}

/// The subtree over `items` (which start at primitive `first`) at `depth`.
fn build_subtree(items: &mut [BuildItem], first: usize, depth: usize, params: &Params) -> Subtree {
    if items.len() < PARALLEL_ITEMS {
        let mut local = Vec::with_capacity(2 * items.len());
        local.push(PLACEHOLDER);
        build(items, &mut local, 0, first, depth, params);
        return Subtree::Serial(local);
    }
    let (node, split) = node_and_split(items, first, depth, params);
    let Some(mid) = split else { return Subtree::Serial(vec![node]) };
    let (l, r) = items.split_at_mut(mid);
    let (l, r) =
        rayon::join(|| build_subtree(l, first, depth + 1, params), || build_subtree(r, first + mid, depth + 1, params));
    Subtree::Split(node, Box::new([l, r]))
}

/// Fills the preallocated node `me` from `items` (which start at primitive `first`): a leaf, or an
/// inner node whose two children are allocated next to each other and built recursively.
fn build(items: &mut [BuildItem], nodes: &mut Vec<Node>, me: usize, first: usize, depth: usize, params: &Params) {
    let (node, split) = node_and_split(items, first, depth, params);
    nodes[me] = node;
    if let Some(mid) = split {
        finish_inner(items, nodes, me, first, depth, params, mid);
    }
}

/// The leaf over `items` (which start at primitive `first`) and, if they are to be split, the number
/// of them (reordered) that go to the first child.
fn node_and_split(items: &mut [BuildItem], first: usize, depth: usize, params: &Params) -> (Node, Option<usize>) {
    // The bounds of the items and of their centroids, in one pass.
    let (bounds, cb) =
        items.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, c), it| (b.union(it.bounds), c.union_point(it.centroid)));
    let node = Node {
        min: bounds.min.to_array(),
        offset: first as u32,
        max: bounds.max.to_array(),
        count: items.len() as u32,
    };
    let n = items.len();
    if n <= 1 {
        return (node, None);
    }
    if params.method == BvhBuild::Midpoint {
        if n <= MIDPOINT_LEAF {
            return (node, None);
        }
        let mid = if depth < MEDIAN_DEPTH { midpoint_split(items, &bounds, &cb) } else { median_split(items, &cb) };
        return (node, Some(mid));
    }
    let mid = if cb.diagonal().max_element() <= 0.0 {
        // All centroids coincide: split by count if the leaf would be too large.
        if n <= params.max_leaf {
            return (node, None);
        }
        n / 2
    } else {
        let sah = if depth < MEDIAN_DEPTH { sah_split(items, &bounds, &cb, params) } else { None };
        match sah {
            Some(mid) => mid,
            None if n <= params.max_leaf => return (node, None),
            None => median_split(items, &cb),
        }
    };
    (node, Some(mid))
}

/// Puts the half of `items` with the smaller centroids along the centroids' longest axis first.
fn median_split(items: &mut [BuildItem], cb: &Aabb) -> usize {
    let (axis, n) = (cb.longest_axis(), items.len());
    items.select_nth_unstable_by(n / 2, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    n / 2
}

/// Builds both children of node `me` from `items` split at `mid`, side by side at the end of `nodes`,
/// and makes `me` an inner node pointing at the first.
fn finish_inner(
    items: &mut [BuildItem],
    nodes: &mut Vec<Node>,
    me: usize,
    first: usize,
    depth: usize,
    params: &Params,
    mid: usize,
) {
    let left = nodes.len();
    nodes.extend([PLACEHOLDER; 2]);
    let (l, r) = items.split_at_mut(mid);
    build(l, nodes, left, first, depth + 1, params);
    build(r, nodes, left + 1, first + mid, depth + 1, params);
    let node = &mut nodes[me];
    node.offset = left as u32;
    node.count = 0;
}

const PLACEHOLDER: Node = Node { min: [0.0; 3], offset: 0, max: [0.0; 3], count: 0 };

/// Largest leaf of the course's build.
const MIDPOINT_LEAF: usize = 2;

/// The course's split: the midpoint of the node's largest axis; if every centroid falls on one side,
/// the mean of the centroids on that axis; if they all coincide, half of the primitives each side.
fn midpoint_split(items: &mut [BuildItem], bounds: &Aabb, cb: &Aabb) -> usize {
    let n = items.len();
    let axis = bounds.longest_axis();
    let partition = |items: &mut [BuildItem], at: f32| {
        let mut mid = 0;
        for i in 0..items.len() {
            if items[i].centroid[axis] < at {
                items.swap(i, mid);
                mid += 1;
            }
        }
        mid
    };
    let mut mid = partition(items, bounds.centroid()[axis]);
    if mid == 0 || mid == n {
        let mean = items.iter().map(|it| it.centroid[axis]).sum::<f32>() / n as f32;
        mid = partition(items, mean);
    }
    if mid == 0 || mid == n || cb.diagonal().max_element() <= 0.0 {
        // All centroids coincide: no position separates them.
        mid = n / 2;
    }
    mid
}

/// Partitions `items` at the cheapest SAH bin boundary of the three axes; `None` if a leaf is cheaper.
/// Returns the number of items put on the lower side.
fn sah_split(items: &mut [BuildItem], bounds: &Aabb, cb: &Aabb, params: &Params) -> Option<usize> {
    let blocks = |n: usize| n.div_ceil(params.block) as f32;
    let n = items.len();
    // An axis along which the centroids do not spread gets scale 0: every item in its bin 0, and no
    // boundary to weigh.
    let extent = cb.diagonal();
    let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), BINS as f32 / extent, Vec3A::ZERO);
    let mut bin_bounds = [[Aabb::EMPTY; BINS]; 3];
    let mut bin_count = [[0u32; BINS]; 3];
    // Bit `b` of an axis set: its bin `b` holds an item.
    let mut occupied = [0u32; 3];
    for it in items.iter() {
        // The bins of the three axes at once, each `(x as u32).min(BINS - 1)`: a saturating conversion, NaN to 0.
        let bins = ((it.centroid - cb.min) * scale).as_uvec3().min(UVec3::splat(BINS as u32 - 1)).to_array();
        for axis in 0..3 {
            let b = bins[axis] as usize;
            bin_bounds[axis][b] = bin_bounds[axis][b].union(it.bounds);
            bin_count[axis][b] += 1;
            occupied[axis] |= 1 << b;
        }
    }
    // (cost, axis, boundary)
    let mut best = (f32::INFINITY, 0, 0);
    for axis in 0..3 {
        let (bin_bounds, bin_count) = (&bin_bounds[axis], &bin_count[axis]);
        // The boundaries between two occupied bins with only empty ones between them all split the items
        // alike, at one cost: the sweeps visit the occupied bins only, and the lowest boundary of each gap.
        // Sweep from the right for the area and count at and above each occupied bin.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        let mut rest = occupied[axis];
        while rest != 0 {
            let b = 31 - rest.leading_zeros() as usize;
            rest &= !(1 << b);
            acc = acc.union(bin_bounds[b]);
            cnt += bin_count[b] as usize;
            right_area[b] = acc.surface_area();
            right_count[b] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        let mut rest = occupied[axis];
        while rest & (rest - 1) != 0 {
            let b = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let above = rest.trailing_zeros() as usize;
            acc = acc.union(bin_bounds[b]);
            cnt += bin_count[b] as usize;
            let cost = acc.surface_area() * blocks(cnt) + right_area[above] * blocks(right_count[above]);
            if cost < best.0 {
                best = (cost, axis, b + 1);
            }
        }
    }
    let (cost, axis, boundary) = best;
    if boundary == 0 {
        return None;
    }
    let split_cost = TRAVERSAL_COST + cost / bounds.surface_area().max(f32::MIN_POSITIVE);
    if n <= params.max_leaf && split_cost >= blocks(n) {
        return None;
    }
    // Partition in place: items in bins below the boundary first. A bin `(x as u32).min(BINS - 1)` of
    // `x >= 0` is below the whole number `boundary < BINS` exactly where `x` is (NaN in bin 0).
    let (lo, scale, edge) = (cb.min[axis], scale[axis], boundary as f32);
    let mut mid = 0;
    for i in 0..n {
        let x = (items[i].centroid[axis] - lo) * scale;
        if x < edge || x.is_nan() {
            items.swap(i, mid);
            mid += 1;
        }
    }
    (mid > 0 && mid < n).then_some(mid)
}

#[cfg(test)]
mod tests {
    use rand_core::{Rng, SeedableRng};

    use super::*;

    /// Boxes of many sizes scattered through a cube, some of them in clusters of equal centroids.
    fn scattered(count: u32, seed: u64) -> Vec<BuildItem> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut unit = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        (0..count)
            .map(|index| {
                let c = if index % 97 == 0 { Vec3A::splat(0.5) } else { Vec3A::new(unit(), unit(), unit()) * 100.0 };
                let half = Vec3A::new(unit(), unit(), unit()) * 2.0f32.powi((unit() * 8.0) as i32 - 6);
                let bounds = Aabb::new(c - half, c + half);
                BuildItem { bounds, centroid: bounds.centroid(), index }
            })
            .collect()
    }

    /// The tree as the one-thread recursion lays it out: the root first, each inner node's children
    /// appended side by side before the first child's subtree.
    fn one_thread(items: &mut [BuildItem], method: BvhBuild) -> Vec<Node> {
        let mut nodes = vec![PLACEHOLDER];
        let params = Params { method, block: 8, max_leaf: 8 };
        build(items, &mut nodes, 0, 0, 0, &params);
        nodes
    }

    fn bits(nodes: &[Node]) -> Vec<([u32; 3], u32, [u32; 3], u32)> {
        nodes.iter().map(|n| (n.min.map(f32::to_bits), n.offset, n.max.map(f32::to_bits), n.count)).collect()
    }

    /// Subtrees built side by side on two threads give the one-thread tree, node for node and bit for
    /// bit, with the items in the same order, for both builds.
    #[test]
    fn subtrees_built_side_by_side_lay_out_the_one_thread_tree() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for method in [BvhBuild::Sah, BvhBuild::Midpoint] {
            let count = 5 * PARALLEL_ITEMS as u32 + 123;
            let mut serial = scattered(count, 7);
            let mut parallel = scattered(count, 7);
            let expected = one_thread(&mut serial, method);
            let nodes = pool.install(|| build_binary(&mut parallel, method, 8, 8));
            assert!(nodes.len() > 2 * count as usize / 8, "{method:?}: a tree of many leaves");
            assert_eq!(bits(&nodes), bits(&expected), "{method:?}");
            let order = |items: &[BuildItem]| items.iter().map(|it| it.index).collect::<Vec<_>>();
            assert_eq!(order(&parallel), order(&serial), "{method:?}");
        }
    }
}
