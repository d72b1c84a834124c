//! A bounding volume hierarchy built with binned SAH, flattened into one array of 32-byte nodes.

use raylume_geometry::{Aabb, Interval, Ray, Vec3A};
use raylume_intersect::Intersect;

use crate::{AccelStats, Accelerator, PrimitiveHit, Tally};

/// Number of SAH bins per axis.
const BINS: usize = 12;
/// Largest leaf the SAH may choose.
const MAX_LEAF: usize = 4;
/// Cost of visiting a node relative to one primitive test.
const TRAVERSAL_COST: f32 = 1.0;
/// Depth of the traversal stack (the build never goes deeper than this).
const STACK: usize = 64;

/// How a [`Bvh`] chooses its splits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BvhBuild {
    /// Binned surface area heuristic (12 bins on the largest centroid axis); the SAH also decides
    /// when to stop (leaves of up to 8 primitives).
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
struct Node {
    min: [f32; 3],
    /// Leaf: first primitive. Inner: index of the first child (the second follows it).
    offset: u32,
    max: [f32; 3],
    /// Leaf: number of primitives (> 0). Inner: 0.
    count: u16,
    /// Inner: the split axis, used to visit the nearer child first.
    axis: u16,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

impl Node {
    #[inline]
    fn aabb(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }
}

/// A BVH over primitives. Unbounded primitives (infinite planes) are kept outside the tree and
/// tested directly by every ray.
#[derive(Clone, Debug)]
pub struct Bvh<P> {
    /// Bounded primitives in leaf order.
    prims: Vec<P>,
    /// For each entry of `prims`, its index in the input.
    ids: Vec<u32>,
    /// Unbounded primitives and their input indices.
    unbounded: Vec<(P, u32)>,
    nodes: Vec<Node>,
    bounds: Aabb,
}

struct BuildItem {
    bounds: Aabb,
    centroid: Vec3A,
    index: u32,
}

impl<P: Intersect + Clone> Bvh<P> {
    /// Builds the hierarchy over `prims` with binned SAH; moving primitives are bounded over all of
    /// `shutter`.
    pub fn new(prims: Vec<P>, shutter: Interval) -> Self {
        Self::with_build(prims, shutter, BvhBuild::Sah)
    }

    /// Builds the hierarchy with the given method.
    pub fn with_build(prims: Vec<P>, shutter: Interval, method: BvhBuild) -> Self {
        let mut items = Vec::with_capacity(prims.len());
        let mut unbounded = Vec::new();
        for (i, p) in prims.iter().enumerate() {
            let b = p.bounds_over(shutter);
            if b.is_finite() && !b.is_empty() {
                items.push(BuildItem { bounds: b, centroid: b.centroid(), index: i as u32 });
            } else if b.is_finite() {
                // Empty bounds: nothing can be hit.
            } else {
                unbounded.push((p.clone(), i as u32));
            }
        }
        let mut nodes = Vec::with_capacity((2 * items.len()).max(1));
        if !items.is_empty() {
            nodes.push(PLACEHOLDER);
            build(&mut items, &mut nodes, 0, 0, 0, method);
        }
        let bounds = nodes.first().map_or(Aabb::EMPTY, Node::aabb);
        let ids: Vec<u32> = items.iter().map(|it| it.index).collect();
        let prims_ordered = ids.iter().map(|&i| prims[i as usize].clone()).collect();
        Self { prims: prims_ordered, ids, unbounded, nodes, bounds }
    }

    /// Number of nodes in the tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}

/// Depth past which splits are object medians, so the depth stays below [`STACK`] for any input.
const MEDIAN_DEPTH: usize = 36;

/// Fills the preallocated node `me` from `items` (which start at primitive `first`): a leaf, or an
/// inner node whose two children are allocated next to each other and built recursively.
fn build(items: &mut [BuildItem], nodes: &mut Vec<Node>, me: usize, first: usize, depth: usize, method: BvhBuild) {
    let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(it.bounds));
    nodes[me] = Node {
        min: bounds.min.to_array(),
        offset: first as u32,
        max: bounds.max.to_array(),
        count: items.len() as u16,
        axis: 0,
    };
    let n = items.len();
    if n <= 1 {
        return;
    }
    let cb = items.iter().fold(Aabb::EMPTY, |b, it| b.union_point(it.centroid));
    if method == BvhBuild::Midpoint {
        if n <= MIDPOINT_LEAF {
            return;
        }
        let (axis, mid) = if depth < MEDIAN_DEPTH {
            midpoint_split(items, &bounds, &cb)
        } else {
            let axis = cb.longest_axis();
            items.select_nth_unstable_by(n / 2, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
            (axis, n / 2)
        };
        return finish_inner(items, nodes, me, first, depth, method, axis, mid);
    }
    let axis = cb.longest_axis();
    let extent = cb.diagonal()[axis];
    let mid = if extent <= 0.0 {
        // All centroids coincide: split by count if the leaf would be too large.
        if n <= MAX_LEAF {
            return;
        }
        n / 2
    } else {
        let sah = if depth < MEDIAN_DEPTH { sah_split(items, &bounds, &cb, axis, extent) } else { None };
        match sah {
            Some(mid) => mid,
            None if n <= MAX_LEAF => return,
            None => {
                items.select_nth_unstable_by(n / 2, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
                n / 2
            }
        }
    };
    finish_inner(items, nodes, me, first, depth, method, axis, mid)
}

/// Builds both children of node `me` from `items` split at `mid`, side by side at the end of `nodes`,
/// and makes `me` an inner node pointing at the first.
#[allow(clippy::too_many_arguments)]
fn finish_inner(
    items: &mut [BuildItem],
    nodes: &mut Vec<Node>,
    me: usize,
    first: usize,
    depth: usize,
    method: BvhBuild,
    axis: usize,
    mid: usize,
) {
    let left = nodes.len();
    nodes.extend([PLACEHOLDER; 2]);
    let (l, r) = items.split_at_mut(mid);
    build(l, nodes, left, first, depth + 1, method);
    build(r, nodes, left + 1, first + mid, depth + 1, method);
    let node = &mut nodes[me];
    node.offset = left as u32;
    node.count = 0;
    node.axis = axis as u16;
}

const PLACEHOLDER: Node = Node { min: [0.0; 3], offset: 0, max: [0.0; 3], count: 0, axis: 0 };

/// Largest leaf of the course's build.
const MIDPOINT_LEAF: usize = 2;

/// The course's split: the midpoint of the node's largest axis; if every centroid falls on one side,
/// the mean of the centroids on that axis; if they all coincide, half of the primitives each side.
fn midpoint_split(items: &mut [BuildItem], bounds: &Aabb, cb: &Aabb) -> (usize, usize) {
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
    (axis, mid)
}

/// Partitions `items` at the cheapest SAH bin boundary on `axis`; `None` if a leaf is cheaper.
fn sah_split(items: &mut [BuildItem], bounds: &Aabb, cb: &Aabb, axis: usize, extent: f32) -> Option<usize> {
    let n = items.len();
    let lo = cb.min[axis];
    let scale = BINS as f32 / extent;
    let bin_of = |c: Vec3A| (((c[axis] - lo) * scale) as usize).min(BINS - 1);
    let mut bin_bounds = [Aabb::EMPTY; BINS];
    let mut bin_count = [0usize; BINS];
    for it in items.iter() {
        let b = bin_of(it.centroid);
        bin_bounds[b] = bin_bounds[b].union(it.bounds);
        bin_count[b] += 1;
    }
    // Sweep from the right to get the area and count right of each boundary.
    let mut right_area = [0.0f32; BINS];
    let mut right_count = [0usize; BINS];
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    for i in (1..BINS).rev() {
        acc = acc.union(bin_bounds[i]);
        cnt += bin_count[i];
        right_area[i] = acc.surface_area();
        right_count[i] = cnt;
    }
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    let mut best = (f32::INFINITY, 0);
    for i in 1..BINS {
        acc = acc.union(bin_bounds[i - 1]);
        cnt += bin_count[i - 1];
        if cnt == 0 || right_count[i] == 0 {
            continue;
        }
        let cost = acc.surface_area() * cnt as f32 + right_area[i] * right_count[i] as f32;
        if cost < best.0 {
            best = (cost, i);
        }
    }
    if best.1 == 0 {
        return None;
    }
    let split_cost = TRAVERSAL_COST + best.0 / bounds.surface_area().max(f32::MIN_POSITIVE);
    if n <= MAX_LEAF && split_cost >= n as f32 {
        return None;
    }
    // Partition in place: items in bins below the boundary first.
    let mut mid = 0;
    for i in 0..n {
        if bin_of(items[i].centroid) < best.1 {
            items.swap(i, mid);
            mid += 1;
        }
    }
    (mid > 0 && mid < n).then_some(mid)
}

impl<P: Intersect + Sync + Send> Accelerator for Bvh<P> {
    fn closest_hit_tally<T: Tally>(&self, ray: &Ray, mut t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        if !ray.is_valid() {
            return None;
        }
        let mut best = None;
        for (p, id) in &self.unbounded {
            tally.tested();
            if let Some(hit) = p.intersect(ray, t_range) {
                t_range = t_range.with_max(hit.t);
                best = Some(PrimitiveHit { hit, primitive: *id });
            }
        }
        if self.nodes.is_empty() {
            return best;
        }
        let inv = ray.dir.recip();
        let neg = [ray.dir.x < 0.0, ray.dir.y < 0.0, ray.dir.z < 0.0];
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut idx = 0usize;
        loop {
            let node = &self.nodes[idx];
            if node.aabb().hit_range(ray, inv, t_range.min, t_range.max).is_some() {
                if node.count > 0 {
                    let start = node.offset as usize;
                    for i in start..start + node.count as usize {
                        tally.tested();
                        if let Some(hit) = self.prims[i].intersect(ray, t_range) {
                            t_range = t_range.with_max(hit.t);
                            best = Some(PrimitiveHit { hit, primitive: self.ids[i] });
                        }
                    }
                } else {
                    // Visit the child on the ray's near side first.
                    let first = node.offset as usize;
                    let (near, far) = if neg[node.axis as usize] { (first + 1, first) } else { (first, first + 1) };
                    stack[sp] = far as u32;
                    sp += 1;
                    idx = near;
                    continue;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            idx = stack[sp] as usize;
        }
        best
    }

    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        if !ray.is_valid() || t_max.is_nan() {
            return false;
        }
        if self.unbounded.iter().any(|(p, _)| {
            tally.tested();
            p.occluded(ray, t_max)
        }) {
            return true;
        }
        if self.nodes.is_empty() {
            return false;
        }
        let inv = ray.dir.recip();
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut idx = 0usize;
        loop {
            let node = &self.nodes[idx];
            if node.aabb().hit_range(ray, inv, 0.0, t_max).is_some() {
                if node.count > 0 {
                    let start = node.offset as usize;
                    if self.prims[start..start + node.count as usize].iter().any(|p| {
                        tally.tested();
                        p.occluded(ray, t_max)
                    }) {
                        return true;
                    }
                } else {
                    stack[sp] = node.offset + 1;
                    sp += 1;
                    idx = node.offset as usize;
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            idx = stack[sp] as usize;
        }
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn stats(&self) -> AccelStats {
        let bytes = std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.prims.as_slice())
            + std::mem::size_of_val(self.ids.as_slice())
            + self.unbounded.len() * std::mem::size_of::<(P, u32)>();
        AccelStats { nodes: self.nodes.len(), bytes, primitives: self.prims.len() + self.unbounded.len() }
    }
}
