//! The collapse of a binary tree into wide nodes by cost: which binary nodes become a wide node's
//! children, and which subtrees become leaves, chosen for the least surface area cost over the whole
//! tree (the dynamic programme of Ylitie, Karras and Laine, *Efficient Incoherent Ray Traversal on
//! GPUs Through Compressed Wide BVHs*, 2017).

use super::build::Node;

/// Cost of visiting a wide node, relative to one leaf block test. The trees of the bench's meshes are
/// the same for any cost from 0.5 to 4 (docs/PERFORMANCE.md#collapse-to-wide-nodes-by-cost).
pub(super) const NODE_COST: f64 = 1.0;

/// What the collapse makes of each binary node: for a node taken as one child, whether it becomes a
/// leaf or a wide node; for a node whose subtree fills `i` slots of its parent, how those slots are
/// shared between its two children.
pub(super) struct Plan<const W: usize> {
    /// The subtree's items: first and count (a binary subtree's items are one run).
    range: Vec<(u32, u32)>,
    /// Whether the node, taken as one child, becomes a leaf of its subtree's items.
    as_leaf: Vec<bool>,
    /// For a subtree given `i` slots (entry `i - 1`): the slots its first child takes, the rest going
    /// to the second; 0 when the node itself takes one slot.
    split: Vec<[u8; W]>,
    /// For a node that becomes a wide node: the slots of its `W` its first child takes.
    inner: Vec<u8>,
}

impl<const W: usize> Plan<W> {
    /// The plan of least cost for `bin` (non-empty, the root first, children after their parent):
    /// a leaf of up to `max_leaf` items costs its box's area for each block of `block` items, a wide
    /// node [`NODE_COST`] times its box's area.
    pub fn new(bin: &[Node], max_leaf: usize, block: usize) -> Self {
        let len = bin.len();
        let mut plan =
            Self { range: vec![(0, 0); len], as_leaf: vec![false; len], split: vec![[0; W]; len], inner: vec![0; len] };
        let mut cost = vec![[0.0f64; W]; len];
        let leaf_cost = |area: f64, count: u32| area * (count as usize).div_ceil(block) as f64;
        for b in (0..len).rev() {
            let node = &bin[b];
            let area = surface_area(node);
            if node.count > 0 {
                plan.range[b] = (node.offset, node.count);
                plan.as_leaf[b] = true;
                cost[b] = [leaf_cost(area, node.count); W];
                continue;
            }
            let (l, r) = (node.offset as usize, node.offset as usize + 1);
            debug_assert!(l > b, "children follow their parent");
            let ((first, left), (_, right)) = (plan.range[l], plan.range[r]);
            debug_assert_eq!(first + left, plan.range[r].0, "a subtree's items are one run");
            let count = left + right;
            plan.range[b] = (first, count);
            // The least cost of the two children sharing `slots` slots, and the first child's share.
            let (cl, cr) = (cost[l], cost[r]);
            let shared = |slots: usize| {
                (1..slots)
                    .map(|k| (cl[k - 1] + cr[slots - k - 1], k as u8))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .unwrap_or((f64::INFINITY, 0))
            };
            let (children, k) = shared(W);
            plan.inner[b] = k;
            let as_node = NODE_COST * area + children;
            let as_leaf = (count as usize <= max_leaf).then(|| leaf_cost(area, count));
            plan.as_leaf[b] = as_leaf.is_some_and(|c| c <= as_node);
            cost[b][0] = as_leaf.map_or(as_node, |c| c.min(as_node));
            for i in 2..=W {
                let (c, k) = shared(i);
                if c < cost[b][i - 2] {
                    cost[b][i - 1] = c;
                    plan.split[b][i - 1] = k;
                } else {
                    cost[b][i - 1] = cost[b][i - 2];
                    plan.split[b][i - 1] = plan.split[b][i - 2];
                }
            }
        }
        plan
    }

    /// Whether binary node `b` becomes a leaf; its items' first index and count.
    pub fn leaf(&self, b: usize) -> Option<(usize, usize)> {
        let (first, count) = self.range[b];
        self.as_leaf[b].then_some((first as usize, count as usize))
    }

    /// The binary nodes that become the children of wide node `b` (not a leaf), in `children`; their
    /// number.
    pub fn children(&self, bin: &[Node], b: usize, children: &mut [usize; W]) -> usize {
        let mut n = 0;
        let first = bin[b].offset as usize;
        let k = self.inner[b] as usize;
        self.fill(bin, first, k, children, &mut n);
        self.fill(bin, first + 1, W - k, children, &mut n);
        n
    }

    fn fill(&self, bin: &[Node], b: usize, slots: usize, children: &mut [usize; W], n: &mut usize) {
        let k = if bin[b].count > 0 { 0 } else { self.split[b][slots - 1] as usize };
        if k == 0 {
            children[*n] = b;
            *n += 1;
        } else {
            let first = bin[b].offset as usize;
            self.fill(bin, first, k, children, n);
            self.fill(bin, first + 1, slots - k, children, n);
        }
    }

    /// Number of leaves the plan makes of `bin`.
    pub fn leaf_count(&self, bin: &[Node]) -> usize {
        let mut count = 0;
        let mut stack = vec![0usize];
        let mut children = [0; W];
        while let Some(b) = stack.pop() {
            if self.as_leaf[b] {
                count += 1;
            } else {
                let n = self.children(bin, b, &mut children);
                stack.extend_from_slice(&children[..n]);
            }
        }
        count
    }
}

/// The surface area of `node`'s box, in f64: boxes of any finite size have an area above zero (unless
/// flat along two axes) and below infinity, so the costs compare at every scale.
pub(super) fn surface_area(node: &Node) -> f64 {
    let [x, y, z] = std::array::from_fn(|a| node.max[a] as f64 - node.min[a] as f64);
    2.0 * (x * y + y * z + z * x)
}
