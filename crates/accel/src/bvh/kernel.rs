//! The triangles' tree and its kernel, and the one place that tells the kernels apart
//! ([`TriangleTree::visit`]): each query is written once, generic over a [`Kernel`], and compiled
//! once per kernel, with no dynamic dispatch per ray.

use raylume_geometry::{Aabb, LargeBuffer, Ray, Triangle, Vec3A};
use raylume_intersect::{TriangleHit, unit_normal};

use super::build::{BuildItem, BvhBuild, build_binary};
use super::collapse::Plan;
use super::leaf::{ClosestLeaf, Filter, OccludedLeaf, Portable};
use super::stream::{self, PacketQuery, Report};
use super::triangles::{LANES, Leaf};
use super::wide::{BoxRay, Frustum, LeafTest, WideTree, leaf_range, leaf_ref};
use crate::{PrimitiveHit, Tally};

/// Largest leaf of triangles: eight, one AVX register's lanes.
pub(super) const MAX_TRIANGLE_LEAF: usize = 2 * LANES;

/// The kernel a [`Bvh`](super::Bvh) answers queries with over its triangles
/// ([`Bvh::kernel`](super::Bvh::kernel)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BvhKernel {
    /// Nodes of four children tested in 128-bit registers, leaves filtered four triangles at a time:
    /// baseline x86-64 (SSE2) and every other target.
    Portable,
    /// Nodes of eight children tested in 256-bit registers, leaves of eight triangles filtered at
    /// once: the choice of [`Bvh::new`](super::Bvh::new) on x86-64 CPUs with AVX2 (with FMA, BMI1/2
    /// and LZCNT: the x86-64-v3 level). The shapes other than triangles keep the portable kernel.
    Avx2,
}

impl BvhKernel {
    /// The fastest kernel this CPU runs.
    pub fn best() -> Self {
        #[cfg(target_arch = "x86_64")]
        if pulp::x86::V3::is_available() {
            return Self::Avx2;
        }
        Self::Portable
    }
}

/// A kernel over a tree of `W`-wide nodes: the leaves' [`Filter`] and the walks down the tree, of one
/// ray and of a packet, compiled with the kernel's target features. [`Portable`] walks four-wide
/// trees; `pulp::x86::V3` eight-wide ones, in AVX registers.
pub(super) trait Kernel<const W: usize>: Filter {
    /// The kernel's name.
    const KIND: BvhKernel;

    /// [`WideTree::walk`] of `tree` for `ray` within `[t_min, t_max]`, testing leaves with `leaf`.
    fn walk<const ANY: bool, T: Tally, L: LeafTest<T>>(
        self,
        tree: &WideTree<W>,
        ray: &Ray,
        t_range: (f32, f32),
        tally: &mut T,
        leaf: &mut L,
    );

    /// Answers `query` for a packet of `rays` whose frustum is `frustum` ([`stream::Leaves::answer`]).
    fn answer_packet(
        self,
        tree: &WideTree<W>,
        tris: &Triangles,
        rays: &[Ray],
        frustum: &Frustum,
        query: PacketQuery<impl Report>,
    );
}

impl Kernel<4> for Portable {
    const KIND: BvhKernel = BvhKernel::Portable;

    #[inline(always)]
    fn walk<const ANY: bool, T: Tally, L: LeafTest<T>>(
        self,
        tree: &WideTree<4>,
        ray: &Ray,
        (t_min, t_max): (f32, f32),
        tally: &mut T,
        leaf: &mut L,
    ) {
        tree.walk::<ANY, _>(&BoxRay::new(ray), t_min, t_max, tally, leaf)
    }

    #[inline(always)]
    fn answer_packet(
        self,
        tree: &WideTree<4>,
        tris: &Triangles,
        rays: &[Ray],
        frustum: &Frustum,
        query: PacketQuery<impl Report>,
    ) {
        let leaves = stream::Leaves {
            tree,
            frustum: *frustum,
            filter: self,
            leaves: &tris.leaves,
            leaf_bounds: &tris.leaf_bounds,
        };
        leaves.answer(rays, frustum.negative, query)
    }
}

/// What to do with the triangles' tree and its kernel: [`TriangleTree::visit`] calls
/// [`visit`](KernelVisitor::visit) with the kernel and the tree of its width.
pub(super) trait KernelVisitor {
    type Output;

    fn visit<const W: usize, K: Kernel<W>>(self, kernel: K, tree: &WideTree<W>) -> Self::Output;
}

/// The triangles' nodes, as the kernel walks them.
#[derive(Clone, Debug)]
pub(super) enum TriangleTree {
    /// Four-wide nodes, for [`BvhKernel::Portable`].
    Portable(WideTree<4>),
    /// Eight-wide nodes and the token that proves the CPU runs [`BvhKernel::Avx2`].
    #[cfg(target_arch = "x86_64")]
    Avx2(pulp::x86::V3, WideTree<8>),
}

impl TriangleTree {
    /// Hands the kernel and its tree to `visitor`: the one match on the kernel.
    #[inline(always)]
    pub fn visit<V: KernelVisitor>(&self, visitor: V) -> V::Output {
        match self {
            TriangleTree::Portable(tree) => visitor.visit(Portable, tree),
            #[cfg(target_arch = "x86_64")]
            TriangleTree::Avx2(simd, tree) => visitor.visit(*simd, tree),
        }
    }
}

/// The triangles' tree: its nodes, each leaf's triangles, each leaf's box (the packet walk tests
/// it for four rays at a time) and the unit normals of each leaf's triangles (read once per query,
/// for the closest hit's record).
#[derive(Clone, Debug)]
pub(super) struct Triangles {
    pub tree: TriangleTree,
    pub leaves: LargeBuffer<Leaf>,
    pub leaf_bounds: LargeBuffer<[f32; 6]>,
    pub leaf_normals: LargeBuffer<LeafNormals>,
}

/// The [`unit_normal`] of each triangle of a leaf, by candidate bit (unused bits hold zeros).
pub(super) type LeafNormals = [[f32; 3]; MAX_TRIANGLE_LEAF];

/// The unit normals of `leaf`'s triangles.
fn leaf_normals(leaf: &Leaf) -> LeafNormals {
    std::array::from_fn(|bit| {
        let bit = bit as u32;
        if leaf.id(bit) == super::triangles::NO_ID {
            [0.0; 3]
        } else {
            unit_normal(&leaf.triangle(bit)).unwrap_or(Vec3A::Z).to_array()
        }
    })
}

/// The tree's size figures and kernel.
struct Summary;

impl KernelVisitor for Summary {
    /// Bounds, nodes, bytes of the nodes, kernel.
    type Output = (Aabb, usize, usize, BvhKernel);

    fn visit<const W: usize, K: Kernel<W>>(self, _: K, tree: &WideTree<W>) -> Self::Output {
        (tree.bounds(), tree.node_count(), tree.bytes(), K::KIND)
    }
}

/// A triangles' tree of `W`-wide nodes collapsed from the binary tree `bin` of `items` (triangle
/// `i` of the items is `tris[i]`) by cost ([`Plan`]), with its leaves' triangles, boxes and unit
/// normals in the order the walk down the tree meets them. The leaves' arrays are on huge pages when
/// the leaves and their boxes take more than `large_bytes`.
fn collapse<const W: usize>(
    bin: &[super::build::Node],
    items: &[BuildItem],
    tris: &[(Triangle, u32)],
    block: usize,
    large_bytes: usize,
) -> (WideTree<W>, LargeBuffer<Leaf>, LargeBuffer<[f32; 6]>, LargeBuffer<LeafNormals>) {
    let plan = Plan::<W>::new(bin, MAX_TRIANGLE_LEAF, block);
    let leaf_count = plan.leaf_count(bin);
    // The leaves' arrays are the largest part of a mesh's tree, and a walk jumps between them: on
    // huge pages, where the system has them, far fewer of those jumps miss the translation buffers
    // once the tree is beyond their reach. A smaller tree does not gain that, and a fresh huge page
    // is zeroed whole (on some virtual machines, slowly), so it stays on ordinary pages.
    let large = leaf_count.saturating_mul(size_of::<Leaf>() + size_of::<[f32; 6]>()) > large_bytes;
    let mut leaves = zeroed(leaf_count, large);
    let mut leaf_bounds = zeroed(leaf_count, large);
    let mut next = 0;
    let mut tree = WideTree::collapse(bin, &plan, |first: usize, count: usize, bounds: Aabb| {
        leaves[next] = Leaf::new(items[first..first + count].iter().map(|it| tris[it.index as usize]));
        let (min, max) = (bounds.min.to_array(), bounds.max.to_array());
        leaf_bounds[next] = [min[0], min[1], min[2], max[0], max[1], max[2]];
        next += 1;
        leaf_ref(next - 1, count)
    });
    let bytes = tree.bytes() + std::mem::size_of_val(&*leaves) + std::mem::size_of_val(&*leaf_bounds);
    tree.prefetch_when_larger(bytes, large_bytes);
    let mut normals = zeroed(leaf_count, large);
    for (n, leaf) in normals.iter_mut().zip(leaves.iter()) {
        *n = leaf_normals(leaf);
    }
    (tree, leaves, leaf_bounds, normals)
}

/// `len` zeroed values, on huge pages if `huge`.
fn zeroed<T: bytemuck::Pod>(len: usize, huge: bool) -> LargeBuffer<T> {
    if huge { LargeBuffer::zeroed_on_huge_pages(len) } else { LargeBuffer::zeroed(len) }
}

impl Triangles {
    /// The tree over `items` (not empty; item `i` is triangle `tris[i]`), built with `method` for
    /// `kernel` (the portable one where the CPU does not run it); walks prefetch when the structure
    /// is larger than `large_bytes`, and the leaves' arrays live on huge pages when the leaves and their
    /// boxes alone are.
    pub fn build(
        items: &mut [BuildItem],
        tris: &[(Triangle, u32)],
        method: BvhBuild,
        kernel: BvhKernel,
        large_bytes: usize,
    ) -> Self {
        #[cfg(target_arch = "x86_64")]
        let simd = pulp::x86::V3::try_new().filter(|_| kernel == BvhKernel::Avx2);
        #[cfg(not(target_arch = "x86_64"))]
        let simd: Option<()> = {
            // Only the portable kernel on this target.
            let _ = kernel;
            None
        };
        // The SAH counts a leaf's cost in the blocks its filter tests at once: eight triangles in AVX
        // registers, else four.
        let block = if simd.is_some() { 2 * LANES } else { LANES };
        let bin = build_binary(items, method, block, MAX_TRIANGLE_LEAF);
        match simd {
            #[cfg(target_arch = "x86_64")]
            Some(simd) => {
                let (tree, leaves, leaf_bounds, leaf_normals) = collapse::<8>(&bin, items, tris, block, large_bytes);
                Self { tree: TriangleTree::Avx2(simd, tree), leaves, leaf_bounds, leaf_normals }
            }
            _ => {
                let (tree, leaves, leaf_bounds, leaf_normals) = collapse::<4>(&bin, items, tris, block, large_bytes);
                Self { tree: TriangleTree::Portable(tree), leaves, leaf_bounds, leaf_normals }
            }
        }
    }

    /// The box of every triangle.
    pub fn bounds(&self) -> Aabb {
        self.tree.visit(Summary).0
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.tree.visit(Summary).1
    }

    /// Bytes of the nodes, the leaves, their boxes and their normals.
    pub fn bytes(&self) -> usize {
        self.tree.visit(Summary).2
            + std::mem::size_of_val(&*self.leaves)
            + std::mem::size_of_val(&*self.leaf_bounds)
            + std::mem::size_of_val(&*self.leaf_normals)
    }

    /// The kernel that walks the tree.
    pub fn kernel(&self) -> BvhKernel {
        self.tree.visit(Summary).3
    }

    /// Checks the tree ([`WideTree::validate`]) and its leaves: each leaf reached once, holding one to
    /// [`MAX_TRIANGLE_LEAF`] triangles, its box inside the one its parent holds for it and around its
    /// triangles. Pushes the input index of each triangle onto `ids`.
    pub fn validate(&self, ids: &mut Vec<u32>) -> Result<(), String> {
        if self.leaf_bounds.len() != self.leaves.len() || self.leaf_normals.len() != self.leaves.len() {
            return Err(format!(
                "{} leaf boxes and {} leaves' normals for {} leaves",
                self.leaf_bounds.len(),
                self.leaf_normals.len(),
                self.leaves.len()
            ));
        }
        if let Some(l) = self.leaves.iter().zip(self.leaf_normals.iter()).position(|(leaf, n)| leaf_normals(leaf) != *n)
        {
            return Err(format!("leaf {l}: its normals are not its triangles'"));
        }
        let mut reached = vec![0usize; self.leaves.len()];
        self.tree.visit(Validate { tris: self, reached: &mut reached, ids })?;
        match reached.iter().position(|&n| n != 1) {
            Some(l) => Err(format!("leaf {l} reached {} times", reached[l])),
            None => Ok(()),
        }
    }

    /// The frustum of `rays` if [`stream::canonical_signs`] finds they can walk as they are, by the
    /// kernel's instructions.
    #[inline(always)]
    pub fn canonical_frustum(&self, rays: &[Ray]) -> Option<Frustum> {
        match &self.tree {
            #[cfg(target_arch = "x86_64")]
            TriangleTree::Avx2(simd, _) => super::avx2::canonical_frustum(*simd, rays),
            _ => stream::canonical_frustum(rays),
        }
    }

    /// Starts loading `items` into the cache where the kernel can (on CPUs of the AVX2 kernel): batch
    /// queries load the next run's rays and answers while they answer this run.
    #[inline(always)]
    pub fn prefetch<T>(&self, items: &[T]) {
        #[cfg(target_arch = "x86_64")]
        if let TriangleTree::Avx2(simd, _) = &self.tree {
            super::avx2::prefetch_slice(*simd, items);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = items;
    }

    /// The hit and primitive of `found` (a hit, its leaf and candidate bit), as the queries report it.
    #[inline(always)]
    pub fn hit(&self, (h, leaf, bit): (TriangleHit, u32, u32)) -> PrimitiveHit {
        let (normals, leaf) = (&self.leaf_normals[leaf as usize], &self.leaves[leaf as usize]);
        let hit = h.hit_with_normal(&leaf.triangle(bit), Vec3A::from_array(normals[bit as usize]));
        PrimitiveHit { hit, primitive: leaf.id(bit) }
    }

    /// The closest hit of `ray` within `[t_min, t_max]`, its leaf and candidate bit.
    #[inline(always)]
    pub fn closest<T: Tally>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        tally: &mut T,
    ) -> Option<(TriangleHit, u32, u32)> {
        self.tree.visit(Closest { tris: self, ray, t_range: (t_min, t_max), tally })
    }

    /// Whether `ray` hits a triangle within `(0, t_max)`.
    #[inline(always)]
    pub fn occluded<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        self.tree.visit(Occluded { tris: self, ray, t_max, tally })
    }

    /// Answers `query` for a packet of `rays` whose frustum is `frustum`.
    pub fn answer_packet(&self, rays: &[Ray], frustum: &Frustum, query: PacketQuery<impl Report>) {
        self.tree.visit(Packet { tris: self, rays, frustum, query })
    }
}

/// [`Triangles::validate`] of the tree and of each leaf it reaches.
struct Validate<'a> {
    tris: &'a Triangles,
    reached: &'a mut [usize],
    ids: &'a mut Vec<u32>,
}

impl KernelVisitor for Validate<'_> {
    type Output = Result<(), String>;

    fn visit<const W: usize, K: Kernel<W>>(self, _: K, tree: &WideTree<W>) -> Self::Output {
        let Self { tris, reached, ids } = self;
        tree.validate(|r, outer| {
            let (first, count) = leaf_range(r);
            if count > MAX_TRIANGLE_LEAF || first >= tris.leaves.len() {
                return Err(format!("leaf {first} of {count} triangles, of {} leaves", tris.leaves.len()));
            }
            reached[first] += 1;
            let leaf = &tris.leaves[first];
            if leaf.len() != count {
                return Err(format!("leaf {first} holds {} triangles, its reference {count}", leaf.len()));
            }
            let b = tris.leaf_bounds[first];
            let bounds = Aabb::new(Vec3A::new(b[0], b[1], b[2]), Vec3A::new(b[3], b[4], b[5]));
            if !outer.contains(bounds.min) || !outer.contains(bounds.max) {
                return Err(format!("leaf {first}: its box {bounds:?} is not inside {outer:?}"));
            }
            for bit in 0..count as u32 {
                if !leaf.triangle(bit).p.iter().all(|p| bounds.contains(*p)) {
                    return Err(format!("leaf {first}: triangle {bit} outside the leaf's box"));
                }
                ids.push(leaf.id(bit));
            }
            Ok(())
        })
    }
}

/// [`Triangles::closest`]'s walk.
struct Closest<'a, T> {
    tris: &'a Triangles,
    ray: &'a Ray,
    t_range: (f32, f32),
    tally: &'a mut T,
}

impl<T: Tally> KernelVisitor for Closest<'_, T> {
    type Output = Option<(TriangleHit, u32, u32)>;

    #[inline(always)]
    fn visit<const W: usize, K: Kernel<W>>(self, kernel: K, tree: &WideTree<W>) -> Self::Output {
        let mut leaf = ClosestLeaf::new(kernel, &self.tris.leaves, self.ray, self.t_range.0);
        kernel.walk::<false, _, _>(tree, self.ray, self.t_range, self.tally, &mut leaf);
        leaf.found()
    }
}

/// [`Triangles::occluded`]'s walk.
struct Occluded<'a, T> {
    tris: &'a Triangles,
    ray: &'a Ray,
    t_max: f32,
    tally: &'a mut T,
}

impl<T: Tally> KernelVisitor for Occluded<'_, T> {
    type Output = bool;

    #[inline(always)]
    fn visit<const W: usize, K: Kernel<W>>(self, kernel: K, tree: &WideTree<W>) -> bool {
        let mut leaf = OccludedLeaf::new(kernel, &self.tris.leaves, self.ray);
        kernel.walk::<true, _, _>(tree, self.ray, (0.0, self.t_max), self.tally, &mut leaf);
        leaf.hit()
    }
}

/// [`Triangles::answer_packet`]'s walk.
struct Packet<'a, 'q, R> {
    tris: &'a Triangles,
    rays: &'a [Ray],
    frustum: &'a Frustum,
    query: PacketQuery<'q, R>,
}

impl<R: Report> KernelVisitor for Packet<'_, '_, R> {
    type Output = ();

    #[inline(always)]
    fn visit<const W: usize, K: Kernel<W>>(self, kernel: K, tree: &WideTree<W>) {
        kernel.answer_packet(tree, self.tris, self.rays, self.frustum, self.query)
    }
}
