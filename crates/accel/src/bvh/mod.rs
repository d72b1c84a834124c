//! A bounding volume hierarchy: built binary with binned SAH (or the course's midpoint splits), then
//! collapsed into wide nodes whose children's boxes a ray tests together: eight children in AVX
//! registers on CPUs with AVX2 ([`BvhKernel::Avx2`]), four in SSE2 registers elsewhere
//! ([`BvhKernel::Portable`]). Triangles live in their own tree, in leaves of up to eight laid out for
//! the watertight test; other bounded shapes in a second tree, of the kernel's width; unbounded ones
//! (planes) outside both.
//!
//! The parts, each using only those listed after it:
//! - this file: [`Bvh`], its constructor, its invariants ([`Bvh::validate`]) and its [`Accelerator`]
//!   queries;
//! - `avx2`: the AVX2 kernel: eight-wide box tests, pushes and the leaves' filter and exact test;
//! - `kernel`: the triangles' tree and [`BvhKernel`]: each query written once over a kernel, and the
//!   one match that picks the kernel (`TriangleTree::visit`);
//! - `stream`: packets of coherent rays walked down the triangles' tree together;
//! - `leaf`: the triangles' leaf tests: the [`Filter`](leaf::Filter) that finds a leaf's candidates
//!   ([`Portable`](leaf::Portable) here), the exact test of the candidates, the leaf tests of a walk;
//! - `triangles`: the leaves' layout (eight triangles coordinate by coordinate), the grid's packets of
//!   four, and the four-lane candidate filter;
//! - `wide`: wide nodes, the collapse of the binary tree into them, the box tests and the walk;
//! - `collapse`: which binary nodes become wide nodes, their children and leaves, by cost;
//! - `build`: the binary build.

#[cfg(target_arch = "x86_64")]
mod avx2;
mod build;
mod collapse;
mod kernel;
mod leaf;
mod stream;
pub(crate) mod triangles;
mod wide;

pub use build::BvhBuild;
use build::{BuildItem, build_binary};
use collapse::Plan;
pub use kernel::BvhKernel;
use kernel::Triangles;
use raylume_geometry::{Aabb, Interval, Ray, Sphere, Vec3A};
use raylume_intersect::{Intersect, LaneRoots, SphereLanes, has_unit_normal, spheres_roots};
use stream::PacketQuery;
use triangles::Leaf;
use wide::OneBox;
pub(crate) use wide::{BoxRay, FewShapes};
use wide::{Frustum, MAX_FIRST, WideTree, leaf_range, leaf_ref, reach, set_bits};

use crate::{AccelStats, Accelerator, PrimitiveHit, Tally, closest_ray_by_ray, occluded_ray_by_ray};

/// Largest leaf of primitives other than triangles.
const MAX_LEAF: usize = 4;
/// Largest leaf of primitives other than triangles that the SAH build makes: one, so that each shape's
/// own box, tested four at a time with its siblings', stands before its exact test, which costs many box
/// tests (a sphere's is in f64).
const SAH_LEAF: usize = 1;
/// Most primitives other than triangles that queries test without walking their tree: their boxes,
/// one per slot of a single node, tested together, then each shape whose box the ray meets. The walk's
/// stack and the ordering of the children cost more than the tests they save on so few.
const FLAT_OTHERS: usize = FewShapes::MAX;
/// Most spheres (and no other shapes but triangles) whose closest hit queries find from every sphere's
/// roots, four to a group of lanes, without walking their tree: for so few, the roots cost less than
/// the walk's set-up, its stack and the ordering of its nodes' children. (Any-hit queries walk it: its
/// boxes end most of them at the root.)
const FLAT_SPHERES: usize = 16;
/// Size of the triangles' structure (nodes, leaves and their boxes) above which walks prefetch the next
/// subtree and the leaves live on huge pages: a tree beyond the caches and beyond the reach of the
/// translation buffers' 4 KiB pages. Measured, random rays on bunny_loop3 (13 MB) gain 7–17 % from the
/// prefetch and 5–13 % from the huge pages, and camera rays on bunny_loop2 (3.4 MB) lose 3–5 % to the
/// prefetch (docs/PERFORMANCE.md).
const LARGE_TREE_BYTES: usize = 8 << 20;

/// The largest spread of the origins of a packet of rays from many points, in mean sizes of a leaf's
/// box. Wider, most leaves the packet reaches are crossed by few of its rays, and the packet costs
/// more than its rays one by one: measured on shadow rays, 4 does better than 1, 8 or 16 on
/// dragon.p3f (docs/PERFORMANCE.md).
const PACKET_SPREAD: f64 = 4.0;

/// A BVH over primitives. Its triangles are walked by the fastest kernel the CPU runs
/// ([`Bvh::kernel`]); every kernel finds the same hits (ties between primitives at one distance aside).
///
/// ```
/// use raylume_accel::{Accelerator, Bvh};
/// use raylume_geometry::{Interval, Ray, Sphere, Triangle, Vec3A};
/// use raylume_intersect::Primitive;
/// let prims = vec![
///     Primitive::Triangle(Triangle::new(Vec3A::new(-1.0, -1.0, 5.0), Vec3A::new(1.0, -1.0, 5.0), Vec3A::new(0.0, 1.0, 5.0))),
///     Primitive::Sphere(Sphere { center: Vec3A::new(0.0, 0.0, 9.0), radius: 1.0 }),
/// ];
/// let bvh = Bvh::new(prims, Interval::new(0.0, 0.0));
/// let hit = bvh.closest_hit(&Ray::new(Vec3A::ZERO, Vec3A::Z), Interval::POSITIVE).unwrap();
/// assert_eq!((hit.primitive, hit.hit.t), (0, 5.0));
/// ```
#[derive(Clone, Debug)]
pub struct Bvh<P> {
    triangles: Option<Triangles>,
    others: Option<(WideTree<4>, Vec<P>, Vec<u32>)>,
    /// Where the kernel is AVX2: the other shapes' tree with eight children to a node, which its
    /// queries walk (the four-wide one above, built from the same binary tree, serves the portable
    /// kernel, and tells the shapes' order and bounds).
    others8: Option<WideTree<8>>,
    /// The box of each primitive of `others`, in its order, as its tree was built on it
    /// (`[min, max]` by axis): packets of rays test a leaf's box against four rays at a time.
    other_boxes: Vec<[f32; 6]>,
    /// With at most [`FLAT_OTHERS`] primitives other than triangles: their boxes, slot `i` holding
    /// primitive `i` of `others`, tested instead of walking their tree.
    flat_others: Option<FewShapes>,
    /// With [`Bvh::flat_others`], where every one of those shapes is a sphere: the spheres, each ray
    /// finding its roots on all of them at once instead of testing them box by box.
    flat_spheres: Option<SphereLanes>,
    /// With more than [`FLAT_OTHERS`] and at most [`FLAT_SPHERES`] primitives other than triangles, all
    /// spheres: the spheres, four to a group (group `g`, lane `l` holding primitive `4 g + l` of
    /// `others`), each closest-hit query finding its roots on all of them at once.
    more_spheres: Option<Box<[SphereLanes]>>,
    /// Where the BVH's kernel is AVX2: its token, under which the few spheres' roots are found too.
    avx2: Avx2,
    /// Where other shapes lie outside the box around the triangles (or planes run past it): that box. Rays from those shapes, or bounded by their hits, often miss
    /// it, and skip the triangles' walk, whose setup costs more than this one test; where every other
    /// shape lies inside it (or there is none), rays mostly meet it, and go to the walk untested.
    /// Tested as one box (three coordinates at once), not as a node's four slots.
    triangles_box: Option<OneBox>,
    /// The box around the triangles, as a node of one shape: a packet whose rays all miss it skips
    /// the triangles' walk, and the making of its rays' state.
    triangles_node: Option<FewShapes>,
    /// Unbounded primitives and their input indices.
    unbounded: Vec<(P, u32)>,
    bounds: Aabb,
    /// The largest spread of origins (along any axis) with which rays from many points walk the
    /// triangles as a packet ([`Accelerator::occluded_each_within`]): [`PACKET_SPREAD`] times the
    /// mean size of a leaf's box.
    packet_spread: f32,
    /// The same for the shapes other than triangles ([`PACKET_SPREAD`] times the mean size of their
    /// boxes): shadow rays from points further apart test those shapes ray by ray.
    others_spread: f32,
}

impl<P: Intersect + Clone> Bvh<P> {
    /// Builds the hierarchy over `prims` with binned SAH; moving primitives are bounded over all of
    /// `shutter`. Large subtrees build side by side on the current rayon thread pool (inside a pool of
    /// one thread's `install`, the build runs on that thread); the tree is the same at any number of
    /// threads.
    pub fn new(prims: Vec<P>, shutter: Interval) -> Self {
        Self::with_build(prims, shutter, BvhBuild::Sah)
    }

    /// Builds the hierarchy with the given method.
    ///
    /// # Panics
    /// With more than 2^28 bounded primitives of one kind (triangles, or the others).
    pub fn with_build(prims: Vec<P>, shutter: Interval, method: BvhBuild) -> Self {
        Self::with_kernel(prims, shutter, method, BvhKernel::best())
    }

    /// Builds the hierarchy with the given method for the given kernel; a kernel the CPU does not
    /// run falls back to [`BvhKernel::Portable`] ([`Bvh::kernel`] tells which one answers).
    ///
    /// ```
    /// use raylume_accel::{Bvh, BvhBuild, BvhKernel};
    /// use raylume_geometry::{Interval, Triangle, Vec3A};
    /// use raylume_intersect::Primitive;
    /// let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    /// let prims = vec![Primitive::Triangle(tri)];
    /// let bvh = Bvh::with_kernel(prims, Interval::new(0.0, 0.0), BvhBuild::Sah, BvhKernel::Portable);
    /// assert_eq!(bvh.kernel(), BvhKernel::Portable);
    /// ```
    ///
    /// # Panics
    /// With more than 2^28 bounded primitives of one kind (triangles, or the others).
    pub fn with_kernel(prims: Vec<P>, shutter: Interval, method: BvhBuild, kernel: BvhKernel) -> Self {
        Self::build(prims, shutter, method, kernel, LARGE_TREE_BYTES)
    }

    /// [`Bvh::with_kernel`], with walks that prefetch the next subtree when the triangles' structure
    /// is larger than `large_bytes`, and its leaves on huge pages.
    fn build(prims: Vec<P>, shutter: Interval, method: BvhBuild, kernel: BvhKernel, large_bytes: usize) -> Self {
        let mut tri_items = Vec::new();
        let mut tris = Vec::new();
        let mut items = Vec::new();
        let mut unbounded = Vec::new();
        for (i, p) in prims.iter().enumerate() {
            let b = p.bounds_over(shutter);
            if b.is_finite() && !b.is_empty() {
                if let Some(t) = p.as_triangle() {
                    // A triangle without a unit normal is never hit: leaving it out lets the leaves' vector
                    // test skip that check.
                    if !has_unit_normal(&t) {
                        continue;
                    }
                    tri_items.push(BuildItem { bounds: b, centroid: b.centroid(), index: tris.len() as u32 });
                    tris.push((t, i as u32));
                } else {
                    items.push(BuildItem { bounds: b, centroid: b.centroid(), index: i as u32 });
                }
            } else if !b.is_finite() {
                unbounded.push((p.clone(), i as u32));
            }
            // Finite but empty bounds: nothing can be hit.
        }
        assert!(tri_items.len().max(items.len()) <= MAX_FIRST as usize, "a BVH holds at most 2^28 primitives");
        let triangles =
            (!tri_items.is_empty()).then(|| Triangles::build(&mut tri_items, &tris, method, kernel, large_bytes));
        let avx2 = Avx2::new(kernel);
        let mut others8 = None;
        let others = (!items.is_empty()).then(|| {
            let bin = build_binary(&mut items, method, 1, SAH_LEAF);
            // The binary tree's leaves stay leaves: each shape's box culls its exact test.
            let tree =
                WideTree::collapse(&bin, &Plan::new(&bin, SAH_LEAF, 1), |first, count, _| leaf_ref(first, count));
            if avx2.is_some() {
                let plan = Plan::new(&bin, SAH_LEAF, 1);
                others8 = Some(WideTree::collapse(&bin, &plan, |first, count, _| leaf_ref(first, count)));
            }
            let ids: Vec<u32> = items.iter().map(|it| it.index).collect();
            let prims: Vec<P> = ids.iter().map(|&i| prims[i as usize].clone()).collect();
            (tree, prims, ids)
        });
        let other_boxes: Vec<[f32; 6]> = items
            .iter()
            .map(|it| {
                let (lo, hi) = (it.bounds.min, it.bounds.max);
                [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]
            })
            .collect();
        let flat_others = others
            .as_ref()
            .filter(|(_, p, _)| p.len() <= FLAT_OTHERS)
            .map(|_| FewShapes::new(items.iter().map(|item| item.bounds)));
        let flat_spheres = others.as_ref().filter(|_| flat_others.is_some()).and_then(|(_, p, _)| {
            let spheres: Option<Vec<Sphere>> = p.iter().map(Intersect::as_sphere).collect();
            spheres.map(|s| SphereLanes::new(&s))
        });
        let more_spheres = others
            .as_ref()
            .filter(|(_, p, _)| (FLAT_OTHERS + 1..=FLAT_SPHERES).contains(&p.len()))
            .and_then(|(_, p, _)| {
                let spheres: Option<Vec<Sphere>> = p.iter().map(Intersect::as_sphere).collect();
                spheres.map(|s| s.chunks(SPHERE_LANES).map(SphereLanes::new).collect())
            });
        let triangles_box = triangles.as_ref().map(Triangles::bounds).and_then(|b| {
            let inside = |o: &BuildItem| o.bounds.min.cmpge(b.min).all() && o.bounds.max.cmple(b.max).all();
            if unbounded.is_empty() && items.iter().all(inside) {
                return None;
            }
            Some(OneBox::new(b))
        });
        let triangles_node = triangles.as_ref().map(|t| FewShapes::new([t.bounds()]));
        let bounds = triangles
            .iter()
            .map(Triangles::bounds)
            .chain(others.iter().map(|(t, _, _)| t.bounds()))
            .fold(Aabb::EMPTY, Aabb::union);
        let packet_spread = triangles.as_ref().map_or(0.0, |t| mean_size(&t.leaf_bounds) * PACKET_SPREAD as f32);
        let others_spread = mean_size(&other_boxes) * PACKET_SPREAD as f32;
        Self {
            triangles,
            others,
            others8,
            other_boxes,
            flat_others,
            flat_spheres,
            more_spheres,
            avx2,
            triangles_box,
            triangles_node,
            unbounded,
            bounds,
            packet_spread,
            others_spread,
        }
    }
}

impl<P> Bvh<P> {
    /// Number of nodes in the trees.
    pub fn node_count(&self) -> usize {
        self.triangles.as_ref().map_or(0, Triangles::node_count)
            + self.others.as_ref().map_or(0, |(t, _, _)| t.node_count())
            + self.others8.as_ref().map_or(0, WideTree::node_count)
    }

    /// Checks the hierarchy's invariants: each bounded primitive reached exactly once (each primitive
    /// kept at most once over the trees and the unbounded list), every child's box inside its
    /// parent's, leaves of one to the largest leaf size, the trees no deeper than the walk's stack
    /// allows; for triangles, each leaf's box around its triangles. `Err` tells the first one broken.
    ///
    /// ```
    /// use raylume_accel::Bvh;
    /// use raylume_geometry::{Interval, Triangle, Vec3A};
    /// use raylume_intersect::Primitive;
    /// let prims: Vec<Primitive> = (0..100)
    ///     .map(|i| Vec3A::new(i as f32, 0.0, 0.0))
    ///     .map(|p| Primitive::Triangle(Triangle::new(p, p + Vec3A::X, p + Vec3A::Y)))
    ///     .collect();
    /// assert_eq!(Bvh::new(prims, Interval::new(0.0, 0.0)).validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), String> {
        let mut ids = Vec::new();
        if let Some(tris) = &self.triangles {
            tris.validate(&mut ids)?;
        }
        if let Some((tree, prims, prim_ids)) = &self.others {
            if prims.len() != prim_ids.len() {
                return Err(format!("{} ids for {} primitives", prim_ids.len(), prims.len()));
            }
            // Each tree of them (four-wide, and eight-wide where the kernel is AVX2) reaches each once.
            let mut reached = vec![0usize; prims.len()];
            let mut leaf = |r, _| {
                let (first, count) = leaf_range(r);
                if count > MAX_LEAF || first + count > prims.len() {
                    return Err(format!("leaf {first} of {count} primitives, of {}", prims.len()));
                }
                reached[first..first + count].iter_mut().for_each(|n| *n += 1);
                Ok(())
            };
            tree.validate(&mut leaf)?;
            let trees = 1 + self.others8.as_ref().map(|t| t.validate(&mut leaf)).transpose()?.is_some() as usize;
            if let Some(i) = reached.iter().position(|&n| n != trees) {
                return Err(format!("primitive {i} of the other shapes reached {} times in {trees} trees", reached[i]));
            }
            ids.extend(prim_ids);
        }
        ids.extend(self.unbounded.iter().map(|(_, id)| *id));
        ids.sort_unstable();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("primitive {} held twice", w[0]));
        }
        Ok(())
    }

    /// Whether coherent rays walk the trees as packets: where there are triangles or other bounded
    /// shapes.
    fn walks_packets(&self) -> bool {
        self.triangles.is_some() || self.others.is_some()
    }

    /// The frustum of `rays` if [`stream::canonical_signs`] finds they can walk as they are, by the
    /// triangles' kernel where there are triangles.
    fn canonical_frustum(&self, rays: &[Ray]) -> Option<Frustum> {
        match &self.triangles {
            Some(tris) => tris.canonical_frustum(rays),
            None => stream::canonical_frustum(rays),
        }
    }

    /// The kernel of single-ray and batch queries over the triangles.
    pub fn kernel(&self) -> BvhKernel {
        self.triangles.as_ref().map_or(BvhKernel::Portable, Triangles::kernel)
    }
}

impl<P: Intersect> Bvh<P> {
    /// The closest hit within `t_range` among the planes and the shapes other than triangles, written
    /// to `best` (`None` if there is none): in place, where the caller keeps it.
    #[inline(always)]
    fn closest_other<T: Tally>(
        &self,
        ray: &Ray,
        mut t_range: Interval,
        tally: &mut T,
        best: &mut Option<PrimitiveHit>,
    ) {
        (0..self.unbounded.len()).for_each(|_| tally.tested());
        self.closest_unbounded(ray, t_range, best);
        if let Some(b) = best {
            t_range = t_range.with_max(b.hit.t);
        }
        if let (Some(spheres), Some((_, _, ids))) = (&self.flat_spheres, &self.others)
            && closest_sphere(
                spheres,
                self.avx2.run(|| spheres_roots(spheres, ray, t_range.min, t_range.max)),
                ids,
                ray,
                t_range,
                best,
            )
        {
            tally.visited();
            (0..spheres.used.count_ones()).for_each(|_| tally.tested());
            return;
        }
        if let (Some(groups), Some((_, prims, ids))) = (&self.more_spheres, &self.others) {
            tally.visited();
            (0..prims.len()).for_each(|_| tally.tested());
            let roots = self.avx2.run(|| FewRoots::of(groups, ray, t_range));
            closest_of_spheres(groups, &roots, prims, ids, ray, t_range, best);
            return;
        }
        if let (Some(flat), Some((_, prims, ids))) = (&self.flat_others, &self.others) {
            tally.visited();
            flat.closest(ray, &mut t_range, |i, t_range| {
                tally.tested();
                if let Some(hit) = prims[i].intersect_canonical(ray, *t_range) {
                    *t_range = t_range.with_max(hit.t);
                    PrimitiveHit::keep_closer(best, PrimitiveHit { hit, primitive: ids[i] });
                }
            });
        } else if let Some((tree, prims, ids)) = &self.others {
            let mut leaf = |leaf, t_max, tally: &mut T| {
                let (first, count) = leaf_range(leaf);
                let mut range = t_range.with_max(t_max);
                for i in first..first + count {
                    tally.tested();
                    if let Some(hit) = prims[i].intersect_canonical(ray, range) {
                        range = range.with_max(hit.t);
                        PrimitiveHit::keep_closer(best, PrimitiveHit { hit, primitive: ids[i] });
                    }
                }
                range.max
            };
            if !self.avx2.walk::<false, T, _>(self.others8.as_ref(), ray, (t_range.min, t_range.max), tally, &mut leaf)
            {
                tree.closest(&BoxRay::new(ray), t_range.min, t_range.max, tally, &mut leaf);
            }
        }
    }

    /// The closest hit within `t_range` among the planes (the unbounded primitives), written to
    /// `best` (`None` if there is none).
    #[inline(always)]
    fn closest_unbounded(&self, ray: &Ray, mut t_range: Interval, best: &mut Option<PrimitiveHit>) {
        *best = None;
        for (p, id) in &self.unbounded {
            if let Some(hit) = p.intersect_canonical(ray, t_range) {
                t_range = t_range.with_max(hit.t);
                PrimitiveHit::keep_closer(best, PrimitiveHit { hit, primitive: *id });
            }
        }
    }

    /// Whether a bounded shape other than a triangle is hit within `(0, t_max)`.
    #[inline(always)]
    fn occluded_other<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        let Some((tree, prims, _)) = &self.others else { return false };
        if let Some(spheres) = &self.flat_spheres {
            tally.visited();
            let roots = self.avx2.run(|| spheres_roots(spheres, ray, 0.0, t_max));
            (0..spheres.used.count_ones()).for_each(|_| tally.tested());
            return roots.hit != 0
                || set_bits(roots.undecided).any(|slot| prims[slot as usize].occluded_canonical(ray, t_max));
        }
        if let Some(flat) = &self.flat_others {
            tally.visited();
            return flat.any(ray, t_max, |i| {
                tally.tested();
                prims[i].occluded_canonical(ray, t_max)
            });
        }
        let mut hit = false;
        let mut leaf = |leaf, end, tally: &mut T| {
            let (first, count) = leaf_range(leaf);
            hit = prims[first..first + count].iter().any(|p| {
                tally.tested();
                p.occluded_canonical(ray, t_max)
            });
            if hit { f32::NEG_INFINITY } else { end }
        };
        if !self.avx2.walk::<true, T, _>(self.others8.as_ref(), ray, (0.0, t_max), tally, &mut leaf) {
            tree.walk::<true, T>(&BoxRay::new(ray), 0.0, t_max, tally, &mut leaf);
        }
        hit
    }
}

/// The token of the AVX2 kernel, where the BVH runs it: code that runs inside [`Avx2::run`] is
/// compiled with AVX2 enabled (the same operations, so the same bits, three operands and four f64
/// lanes to a register).
#[derive(Clone, Copy, Debug)]
struct Avx2(#[cfg(target_arch = "x86_64")] Option<pulp::x86::V3>);

impl Avx2 {
    fn new(kernel: BvhKernel) -> Self {
        #[cfg(target_arch = "x86_64")]
        return Self(pulp::x86::V3::try_new().filter(|_| kernel == BvhKernel::Avx2));
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = kernel;
            Self()
        }
    }

    /// Whether the token is there.
    fn is_some(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return self.0.is_some();
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// The walk of the eight-wide `tree` by `ray` in the AVX2 kernel, testing leaves with `leaf`:
    /// `false`, with nothing walked, without the token or the tree.
    #[inline(always)]
    fn walk<const ANY: bool, T: Tally, L: wide::LeafTest<T>>(
        self,
        tree: Option<&WideTree<8>>,
        ray: &Ray,
        t_range: (f32, f32),
        tally: &mut T,
        leaf: &mut L,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let (Some(simd), Some(tree)) = (self.0, tree) {
            kernel::Kernel::<8>::walk::<ANY, T, L>(simd, tree, ray, t_range, tally, leaf);
            return true;
        }
        let _ = (tree, ray, t_range, tally, leaf);
        false
    }

    /// `f()`, compiled with AVX2 enabled where the token is there (everything `f` inlines).
    #[inline(always)]
    fn run<R>(self, f: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        if let Some(simd) = self.0 {
            return simd.vectorize(f);
        }
        f()
    }
}

/// The closest hit within `t_range` of the few spheres `spheres` ([`Bvh::flat_spheres`], with ids
/// `ids`) whose roots within that range are `roots`, kept in `best` if it
/// [beats](PrimitiveHit::beats) it. The hit is made for the closest root only (ties to the lowest id):
/// the answer of the spheres tested one by one with the range shrinking to each hit, as a sphere's
/// root within a smaller range is the same root or none. `false`, with `best` untouched, when a
/// sphere's sizes leave it to the one-sphere routine's f64 path.
#[inline(always)]
fn closest_sphere(
    spheres: &SphereLanes,
    roots: LaneRoots,
    ids: &[u32],
    ray: &Ray,
    t_range: Interval,
    best: &mut Option<PrimitiveHit>,
) -> bool {
    if roots.undecided != 0 {
        return false;
    }
    let t = roots.t.to_array();
    let mut hits = roots.hit;
    while hits != 0 {
        let mut pick = hits.trailing_zeros() as usize;
        for lane in set_bits(hits & (hits - 1)) {
            let l = lane as usize;
            if t[l] < t[pick] || (t[l] == t[pick] && ids[l] < ids[pick]) {
                pick = l;
            }
        }
        // A root whose point cannot be formed is no hit, and the next closest root stands.
        if let Some(hit) = spheres.sphere(pick).hit_at_root(ray, t[pick], t_range) {
            PrimitiveHit::keep_closer(best, PrimitiveHit { hit, primitive: ids[pick] });
            return true;
        }
        hits &= !(1 << pick);
    }
    true
}

/// Spheres to a group of [`SphereLanes`].
const SPHERE_LANES: usize = 4;

/// The roots of a BVH's spheres ([`Bvh::more_spheres`]) for one ray, bit `i` of the masks and
/// slot `i` of `t` for primitive `i` of its other shapes.
struct FewRoots {
    t: [f32; FLAT_SPHERES],
    hit: u32,
    undecided: u32,
}

impl FewRoots {
    /// The roots of every sphere of `groups` within `t_range`, as [`spheres_roots`] finds each group's.
    #[inline(always)]
    fn of(groups: &[SphereLanes], ray: &Ray, t_range: Interval) -> Self {
        let mut all = Self { t: [0.0; FLAT_SPHERES], hit: 0, undecided: 0 };
        for (g, group) in groups.iter().enumerate() {
            let roots = spheres_roots(group, ray, t_range.min, t_range.max);
            let first = g * SPHERE_LANES;
            if roots.hit != 0 {
                all.t[first..first + SPHERE_LANES].copy_from_slice(&roots.t.to_array());
            }
            all.hit |= roots.hit << first;
            all.undecided |= roots.undecided << first;
        }
        all
    }
}

/// The closest hit within `t_range` of the spheres `groups` ([`Bvh::more_spheres`]: `prims`, with
/// ids `ids`) whose roots within that range are `roots`, kept in `best` if it
/// [beats](PrimitiveHit::beats) it. A sphere whose sizes leave it to the one-sphere routine's f64 path
/// runs that routine; of the others, the hit is made for the closest root only (ties to the lowest
/// id): the answer of the spheres tested one by one with the range shrinking to each hit, as a
/// sphere's root within a smaller range is the same root or none. (Up to four spheres keep
/// [`closest_sphere`], on one group's roots: through this function, mount_low's render took 3 % more
/// instructions.)
#[inline(always)]
fn closest_of_spheres<P: Intersect>(
    groups: &[SphereLanes],
    roots: &FewRoots,
    prims: &[P],
    ids: &[u32],
    ray: &Ray,
    t_range: Interval,
    best: &mut Option<PrimitiveHit>,
) {
    for lane in set_bits(roots.undecided) {
        let l = lane as usize;
        if let Some(hit) = prims[l].intersect_canonical(ray, t_range) {
            PrimitiveHit::keep_closer(best, PrimitiveHit { hit, primitive: ids[l] });
        }
    }
    let t = &roots.t;
    let mut hits = roots.hit;
    while hits != 0 {
        let mut pick = hits.trailing_zeros() as usize;
        for lane in set_bits(hits & (hits - 1)) {
            let l = lane as usize;
            if t[l] < t[pick] || (t[l] == t[pick] && ids[l] < ids[pick]) {
                pick = l;
            }
        }
        // A root whose point cannot be formed is no hit, and the next closest root stands.
        let sphere = groups[pick / SPHERE_LANES].sphere(pick % SPHERE_LANES);
        if let Some(hit) = sphere.hit_at_root(ray, t[pick], t_range) {
            PrimitiveHit::keep_closer(best, PrimitiveHit { hit, primitive: ids[pick] });
            return;
        }
        hits &= !(1 << pick);
    }
}

/// The mean of the largest extent of `boxes` (`[min, max]` by axis); zero for none.
fn mean_size(boxes: &[[f32; 6]]) -> f32 {
    let size = |b: &[f32; 6]| (b[3] - b[0]).max(b[4] - b[1]).max(b[5] - b[2]) as f64;
    (boxes.iter().map(size).sum::<f64>() / boxes.len().max(1) as f64) as f32
}

/// Whether the directions of `rays` (at least one) have the same sign along each axis, as their
/// canonical forms then do (a power of two keeps the signs): rays whose signs differ never walk as a
/// packet, and are not worth their canonical forms.
#[inline]
fn same_signs(rays: &[Ray]) -> bool {
    let signs = rays[0].dir.cmplt(Vec3A::ZERO).bitmask();
    rays.iter().all(|r| r.dir.cmplt(Vec3A::ZERO).bitmask() == signs)
}

/// The canonical forms of up to a packet of `rays` ([`Ray::canonical`]) and their common scale; `None`
/// if a ray is not valid or the scales differ.
fn same_scale(rays: &[Ray]) -> Option<([Ray; stream::PACKET], f32)> {
    let mut canonical = [Ray::new(Vec3A::ZERO, Vec3A::ZERO); stream::PACKET];
    let mut scale = None;
    for (ray, c) in rays.iter().zip(&mut canonical) {
        let (r, s) = ray.canonical()?;
        if *scale.get_or_insert(s) != s {
            return None;
        }
        *c = r;
    }
    scale.map(|s| (canonical, s))
}

impl<P: Intersect> Bvh<P> {
    /// [`Accelerator::closest_hits`] for a packet of rays whose frustum is `frustum`.
    fn closest_packet(
        &self,
        tris: Option<&Triangles>,
        rays: &[Ray],
        frustum: &Frustum,
        t_range: Interval,
        hits: &mut [Option<PrimitiveHit>],
    ) {
        // The planes ray by ray, then the other shapes as a packet: their hits bound the triangles' walk.
        let (n, t_min) = (rays.len(), t_range.min);
        let mut t_max = [t_range.max; stream::PACKET];
        hits.fill(None);
        if !self.unbounded.is_empty() {
            for ((ray, hit), t) in rays.iter().zip(hits.iter_mut()).zip(&mut t_max) {
                self.closest_unbounded(ray, t_range, hit);
                *t = hit.map_or(t_range.max, |h| h.hit.t);
            }
        }
        if let Some((tree, prims, ids)) = &self.others {
            let shapes = (&prims[..], &ids[..], &self.other_boxes[..]);
            let t_max = &mut t_max[..n];
            #[cfg(target_arch = "x86_64")]
            if let (Some(simd), Some(tree8)) = (self.avx2.0, &self.others8) {
                avx2::closest_by_shapes(simd, frustum, tree8, shapes, rays, t_min, t_max, hits);
            } else {
                stream::closest_by_shapes(frustum, (tree, frustum), shapes, rays, t_min, t_max, hits);
            }
            #[cfg(not(target_arch = "x86_64"))]
            stream::closest_by_shapes(frustum, (tree, frustum), shapes, rays, t_min, t_max, hits);
        }
        let Some(tris) = tris else { return };
        if self.triangles_node.is_none_or(|node| node.meets_packet(frustum, t_min, reach(stream::largest(&t_max[..n]))))
        {
            let report = |i: usize, found| hits[i] = Some(tris.hit(found));
            tris.answer_packet(rays, frustum, PacketQuery::Closest { t_min, t_max: &t_max[..n], report });
        }
    }

    /// [`Accelerator::occluded_each_within`] for a packet of rays whose frustum is `frustum`; the
    /// shapes other than triangles as a packet too if `others_together`, else ray by ray.
    fn occluded_packet(
        &self,
        tris: Option<&Triangles>,
        rays: &[Ray],
        frustum: &Frustum,
        t_max: &[f32],
        occluded: &mut [bool],
        others_together: bool,
    ) {
        // Planes first, as the single-ray query does; rays they occlude leave the walk, and so do rays
        // with a NaN end, which nothing occludes.
        let mut ends = [f32::NEG_INFINITY; stream::PACKET];
        if self.unbounded.is_empty() {
            // No planes: every ray walks but those with a NaN end, in a loop without branches.
            occluded.fill(false);
            for (end, &t) in ends.iter_mut().zip(t_max) {
                *end = if t.is_nan() { f32::NEG_INFINITY } else { t };
            }
        } else {
            for (((ray, o), end), &t) in rays.iter().zip(occluded.iter_mut()).zip(&mut ends).zip(t_max) {
                *o = !t.is_nan() && self.unbounded.iter().any(|(p, _)| p.occluded_canonical(ray, t));
                if !*o && !t.is_nan() {
                    *end = t;
                }
            }
        }
        if let Some(tris) = tris
            && self.triangles_node.is_none_or(|node| node.meets_packet(frustum, 0.0, reach(stream::largest(&ends))))
        {
            let query: PacketQuery<()> = PacketQuery::Occluded { t_max: &ends[..rays.len()], occluded };
            tris.answer_packet(rays, frustum, query);
        }
        match &self.others {
            Some((tree, prims, _)) if others_together => {
                let boxes = &self.other_boxes;
                #[cfg(target_arch = "x86_64")]
                if let (Some(simd), Some(tree8)) = (self.avx2.0, &self.others8) {
                    avx2::occluded_by_shapes(simd, frustum, tree8, prims, boxes, rays, t_max, occluded);
                } else {
                    stream::occluded_by_shapes(frustum, (tree, frustum), prims, boxes, rays, t_max, occluded);
                }
                #[cfg(not(target_arch = "x86_64"))]
                stream::occluded_by_shapes(frustum, (tree, frustum), prims, boxes, rays, t_max, occluded);
            }
            Some(_) => {
                for ((ray, o), &t) in rays.iter().zip(occluded).zip(t_max) {
                    *o = *o || (!t.is_nan() && self.occluded_other(ray, t, &mut ()));
                }
            }
            None => {}
        }
    }
}

impl<P: Intersect + Sync + Send> Bvh<P> {
    /// [`Accelerator::occluded_each_within`] for up to a packet of rays, walked as a packet if their
    /// origins spread no more than `spread` along each axis.
    fn occluded_chunk(&self, rays: &[Ray], t_max: &[f32], occluded: &mut [bool], spread: f32) {
        let origins = if spread == f32::INFINITY && self.others.is_none() {
            0.0
        } else {
            let (lo, hi) = rays
                .iter()
                .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), r| (lo.min(r.origin), hi.max(r.origin)));
            (hi - lo).max_element()
        };
        // Each kind of shape as a packet only where the origins lie close for the size of its leaves
        // (NaN: not).
        let (tris, others_together) = (self.triangles.as_ref(), origins <= self.others_spread);
        let together = match tris {
            Some(_) => spread == f32::INFINITY || origins <= spread,
            None => others_together && self.others.is_some(),
        };
        if !together {
            occluded_ray_by_ray(self, rays, t_max, occluded);
            return;
        }
        if let Some(frustum) = self.canonical_frustum(rays) {
            self.occluded_packet(tris, rays, &frustum, t_max, occluded, others_together);
            return;
        }
        let scaled = if same_signs(rays) { same_scale(rays) } else { None };
        let Some((canonical, s)) = &scaled else {
            occluded_ray_by_ray(self, rays, t_max, occluded);
            return;
        };
        let canonical = &canonical[..rays.len()];
        match stream::common_signs(canonical) {
            Some(negative) => {
                let mut ends = [0.0; stream::PACKET];
                for (end, &t) in ends.iter_mut().zip(t_max) {
                    *end = Interval::new(0.0, t).on_canonical(*s).max;
                }
                let frustum = Frustum::new(canonical, negative);
                self.occluded_packet(tris, canonical, &frustum, &ends[..rays.len()], occluded, others_together);
            }
            None => occluded_ray_by_ray(self, rays, t_max, occluded),
        }
    }
}

impl<P: Intersect> Bvh<P> {
    /// [`Accelerator::closest_hit_tally`] of a canonical ray.
    fn closest_canonical<T: Tally>(&self, ray: &Ray, mut t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        if self.others.is_none() && self.unbounded.is_empty() {
            // A mesh: its triangles alone, and no hit to carry over.
            let tris = self.triangles.as_ref()?;
            if !self.may_meet_triangles(ray, t_range.min, t_range.max) {
                return None;
            }
            return tris.closest(ray, t_range.min, t_range.max, tally).map(|found| tris.hit(found));
        }
        let mut best = None;
        self.closest_other(ray, t_range, tally, &mut best);
        if let Some(b) = &best {
            t_range = t_range.with_max(b.hit.t);
        }
        if let Some(tris) = &self.triangles
            && self.may_meet_triangles(ray, t_range.min, t_range.max)
        {
            if let Some(found) = tris.closest(ray, t_range.min, t_range.max, tally) {
                PrimitiveHit::keep_closer(&mut best, tris.hit(found));
            }
        }
        best
    }

    /// [`Accelerator::occluded_tally`] of a canonical ray.
    fn occluded_canonical<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        if self.unbounded.iter().any(|(p, _)| {
            tally.tested();
            p.occluded_canonical(ray, t_max)
        }) {
            return true;
        }
        if self.occluded_other(ray, t_max, tally) {
            return true;
        }
        self.triangles
            .as_ref()
            .is_some_and(|tris| self.may_meet_triangles(ray, 0.0, t_max) && tris.occluded(ray, t_max, tally))
    }

    /// Whether `ray` meets the box around the triangles within `[t_min, t_max]` (up to the few ulps
    /// past `t_max` that the closest-hit walk reaches): the test the walk makes of the root's children,
    /// on a box around all of them, so never `false` where the walk would reach a leaf.
    /// Always `true` without the box ([`Bvh::triangles_box`]).
    #[inline(always)]
    fn may_meet_triangles(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.triangles_box.as_ref().is_none_or(|b| b.meets(ray, t_min, t_max))
    }
}

impl<P: Intersect + Sync + Send> Accelerator for Bvh<P> {
    #[inline(always)]
    fn closest_hit_tally<T: Tally>(&self, ray: &Ray, t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        crate::closest_on_canonical(ray, t_range, |ray, t_range| self.closest_canonical(ray, t_range, tally))
    }

    #[inline(always)]
    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        crate::occluded_on_canonical(ray, t_max, |ray, t_max| self.occluded_canonical(ray, t_max, tally))
    }

    fn gathers_coherent_rays(&self) -> bool {
        self.walks_packets()
    }

    fn closest_hits(&self, rays: &[Ray], t_range: Interval, hits: &mut [Option<PrimitiveHit>]) {
        assert_eq!(rays.len(), hits.len(), "one answer per ray");
        let n = rays.len();
        for start in (0..n).step_by(stream::PACKET) {
            let (end, next) = ((start + stream::PACKET).min(n), (start + 2 * stream::PACKET).min(n));
            if let Some(tris) = &self.triangles {
                // The next run's rays and answers load while this run's rays walk.
                tris.prefetch(&rays[end..next]);
                tris.prefetch(&hits[end..next]);
            }
            let (rays, hits) = (&rays[start..end], &mut hits[start..end]);
            if !self.walks_packets() || t_range.min.is_nan() || t_range.max.is_nan() {
                closest_ray_by_ray(self, rays, t_range, hits);
                continue;
            }
            let tris = self.triangles.as_ref();
            // Canonical rays (unit directions mostly are) walk as they are; others walk their
            // canonical forms when those share one scale.
            if let Some(frustum) = self.canonical_frustum(rays) {
                self.closest_packet(tris, rays, &frustum, t_range, hits);
                continue;
            }
            let scaled = if same_signs(rays) { same_scale(rays) } else { None };
            let Some((canonical, s)) = &scaled else {
                closest_ray_by_ray(self, rays, t_range, hits);
                continue;
            };
            let canonical = &canonical[..rays.len()];
            match stream::common_signs(canonical) {
                Some(negative) => {
                    let frustum = Frustum::new(canonical, negative);
                    self.closest_packet(tris, canonical, &frustum, t_range.on_canonical(*s), hits);
                    for h in hits.iter_mut().flatten() {
                        h.hit.t *= s;
                    }
                }
                None => closest_ray_by_ray(self, rays, t_range, hits),
            }
        }
    }

    fn occluded_each(&self, rays: &[Ray], t_max: f32, occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one answer per ray");
        let ends = [t_max; stream::PACKET];
        for (rays, occluded) in rays.chunks(stream::PACKET).zip(occluded.chunks_mut(stream::PACKET)) {
            self.occluded_chunk(rays, &ends[..rays.len()], occluded, f32::INFINITY);
        }
    }

    fn occluded_each_within(&self, rays: &[Ray], t_max: &[f32], occluded: &mut [bool]) {
        assert!(rays.len() == t_max.len() && rays.len() == occluded.len(), "one end and one answer per ray");
        let chunks = rays.chunks(stream::PACKET).zip(t_max.chunks(stream::PACKET));
        for ((rays, t_max), occluded) in chunks.zip(occluded.chunks_mut(stream::PACKET)) {
            self.occluded_chunk(rays, t_max, occluded, self.packet_spread);
        }
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn stats(&self) -> AccelStats {
        let mut bytes = self.unbounded.len() * std::mem::size_of::<(P, u32)>();
        let mut primitives = self.unbounded.len();
        if let Some(t) = &self.triangles {
            bytes += t.bytes();
            primitives += t.leaves.iter().map(Leaf::len).sum::<usize>();
        }
        if let Some((tree, prims, ids)) = &self.others {
            bytes += tree.bytes() + std::mem::size_of_val(prims.as_slice()) + std::mem::size_of_val(ids.as_slice());
            bytes += std::mem::size_of_val(self.other_boxes.as_slice());
            bytes += self.others8.as_ref().map_or(0, WideTree::bytes);
            primitives += prims.len();
        }
        AccelStats { nodes: self.node_count(), bytes, primitives }
    }
}

#[cfg(test)]
mod tests {
    use rand_core::Rng;
    use rand_pcg::Pcg32;
    use raylume_geometry::{Triangle, Vec3A};
    use raylume_intersect::Primitive;

    use super::*;

    /// Random triangles around the origin (`n` of them, each up to `size` across) and a few spheres.
    fn random_scene(seed: u64, n: usize, size: f32) -> Vec<Primitive> {
        let mut rng = Pcg32::new(seed, 11);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut point = |scale: f32| Vec3A::new(unit(), unit(), unit()) * (2.0 * scale) - Vec3A::splat(scale);
        let mut prims: Vec<Primitive> = (0..n)
            .map(|_| {
                let c = point(10.0);
                Primitive::Triangle(Triangle::new(c, c + point(size), c + point(size)))
            })
            .collect();
        for _ in 0..n / 10 {
            prims.push(Primitive::Sphere(raylume_geometry::Sphere { center: point(10.0), radius: 0.5 }));
        }
        prims
    }

    /// Each way of breaking a tree is caught: a leaf held twice, a leaf's box not around its triangles,
    /// a leaf's normals not its triangles', a primitive twice among the other shapes.
    #[test]
    fn validate_finds_broken_trees() {
        let prims = random_scene(3, 400, 1.0);
        for kernel in [BvhKernel::Portable, BvhKernel::best()] {
            let bvh = Bvh::with_kernel(prims.clone(), Interval::new(0.0, 0.0), BvhBuild::Sah, kernel);
            assert_eq!(bvh.validate(), Ok(()));
            let mut twice = bvh.clone();
            let tris = twice.triangles.as_mut().unwrap();
            tris.leaves[0] = tris.leaves[1];
            assert!(twice.validate().is_err());
            let mut small = bvh.clone();
            small.triangles.as_mut().unwrap().leaf_bounds[2][3] = f32::NEG_INFINITY;
            assert!(small.validate().is_err());
            let mut turned = bvh.clone();
            turned.triangles.as_mut().unwrap().leaf_normals[1][0][0] += 0.5;
            assert!(turned.validate().is_err());
            let mut other = bvh.clone();
            let (_, _, ids) = other.others.as_mut().unwrap();
            ids[1] = ids[0];
            assert!(other.validate().is_err());
        }
    }

    /// Up to [`FLAT_OTHERS`] shapes other than triangles are tested from one node of their boxes (all
    /// at once where they are all spheres), up to [`FLAT_SPHERES`] spheres all at once for the closest
    /// hit, more through their tree; every way answers every query as the tree's walk, bit for bit:
    /// overlapping spheres, one held twice (a tie), one too small for the lanes' routine, rays from
    /// outside and from their surfaces, ranges with and without a minimum.
    #[test]
    fn a_few_other_shapes_answer_as_their_tree() {
        let mut rng = Pcg32::new(5, 11);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut point = |scale: f32| Vec3A::new(unit(), unit(), unit()) * (2.0 * scale) - Vec3A::splat(scale);
        for n in 1..=FLAT_SPHERES + 1 {
            let mut prims: Vec<Primitive> = (0..6)
                .map(|_| {
                    let c = point(4.0);
                    Primitive::Triangle(Triangle::new(c, c + point(2.0), c + point(2.0)))
                })
                .collect();
            // Overlapping spheres, so that rays meet several boxes and ties stay possible.
            let spheres: Vec<raylume_geometry::Sphere> = (0..n)
                .map(|_| raylume_geometry::Sphere { center: point(1.0), radius: 0.5 + point(0.5).x.abs() })
                .collect();
            prims.extend(spheres.iter().map(|&s| Primitive::Sphere(s)));
            if n % 4 == 3 {
                prims.push(Primitive::Sphere(spheres[1]));
            }
            if n % 5 == 2 {
                // Undecided in their lanes (radii beyond the f32 routine's), answered by the routine: a
                // tiny sphere in the cluster and a huge one below it, its top 2^28 down.
                prims.push(Primitive::Sphere(raylume_geometry::Sphere { center: spheres[0].center, radius: 1e-16 }));
                let (r, below) = (2f32.powi(51), 2f32.powi(28));
                prims.push(Primitive::Sphere(raylume_geometry::Sphere {
                    center: Vec3A::new(0.0, 0.0, -(r + below)),
                    radius: r,
                }));
            }
            let flat = Bvh::new(prims.clone(), Interval::new(0.0, 0.0));
            let count = prims.len() - 6;
            let few = count <= FLAT_OTHERS;
            let more = !few && count <= FLAT_SPHERES;
            assert_eq!(
                (flat.flat_others.is_some(), flat.flat_spheres.is_some(), flat.more_spheres.is_some()),
                (few, few, more)
            );
            let by_box = Bvh { flat_spheres: None, more_spheres: None, ..flat.clone() };
            let walked =
                Bvh { flat_others: None, flat_spheres: None, more_spheres: None, triangles_box: None, ..flat.clone() };
            let mut hits = 0;
            for k in 0..4000 {
                let origin = if k % 4 == 0 {
                    let s = spheres[k % n];
                    s.center + point(1.0).normalize_or(Vec3A::X) * s.radius
                } else {
                    point(8.0)
                };
                let ray = Ray::new(origin, point(0.5) - origin);
                let bits =
                    |h: Option<PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.point.to_array()));
                for range in [Interval::POSITIVE, Interval::new(1.0, 9.0)] {
                    let expected = bits(walked.closest_hit(&ray, range));
                    assert_eq!(bits(flat.closest_hit(&ray, range)), expected, "{ray:?} in {range:?}");
                    assert_eq!(bits(by_box.closest_hit(&ray, range)), expected, "{ray:?} in {range:?}");
                    hits += expected.is_some_and(|h| h.0 >= 6) as usize;
                }
                for t_max in [0.5, 3.0, f32::INFINITY] {
                    let expected = walked.occluded(&ray, t_max);
                    assert_eq!(flat.occluded(&ray, t_max), expected);
                    assert_eq!(by_box.occluded(&ray, t_max), expected);
                }
            }
            assert!(hits > 400, "the rays meet the spheres ({hits} hits of {n} spheres)");
        }
    }

    /// Queries walk the other shapes' eight-wide tree where the kernel is AVX2: every single-ray query
    /// answers as the four-wide walk, bit for bit (distance,
    /// point, primitive; occlusion), over spheres, boxes, cones and moving spheres of sizes from 1/100
    /// to 10 among triangles, with rays from outside, from shapes' surfaces and from inside them, at
    /// times across the shutter, in ranges with and without a minimum.
    #[test]
    fn other_shapes_answer_alike_in_either_tree() {
        use raylume_geometry::{AaBox, Cone, MovingSphere, Sphere};
        let mut rng = Pcg32::new(17, 5);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut prims = random_scene(9, 200, 2.0);
        let mut centres = Vec::new();
        for k in 0..600 {
            let c = Vec3A::new(unit(), unit(), unit()) * 24.0 - Vec3A::splat(12.0);
            let size = 0.01 * 1000f32.powf(unit());
            centres.push((c, size));
            prims.push(match k % 4 {
                0 => Primitive::Sphere(Sphere { center: c, radius: size }),
                1 => {
                    Primitive::Box(AaBox { bounds: Aabb::new(c - Vec3A::splat(size), c + Vec3A::splat(size) * unit()) })
                }
                2 => Primitive::Cone(Cone {
                    base: c,
                    base_radius: size,
                    apex: c + Vec3A::new(unit(), 1.0, unit()) * size,
                    apex_radius: size * unit(),
                }),
                _ => Primitive::MovingSphere(MovingSphere {
                    center0: c,
                    center1: c + Vec3A::new(unit(), unit(), unit()) * size,
                    radius: size,
                    time0: 0.0,
                    time1: 1.0,
                }),
            });
        }
        let eight = Bvh::new(prims, Interval::new(0.0, 1.0));
        let Some(tree) = &eight.others8 else {
            eprintln!("skipped: the kernel is not AVX2 here, and no eight-wide tree of other shapes is built");
            return;
        };
        assert!(tree.node_count() > 10);
        assert_eq!(eight.validate(), Ok(()));
        let four = Bvh { others8: None, ..eight.clone() };
        let (mut hits, mut occluded) = (0, 0);
        for k in 0..20_000 {
            let (c, size) = centres[k % centres.len()];
            let aim = Vec3A::new(unit(), unit(), unit()) * 24.0 - Vec3A::splat(12.0);
            let origin = match k % 3 {
                0 => Vec3A::new(unit(), unit(), unit()) * 40.0 - Vec3A::splat(20.0),
                1 => c + (aim - c).normalize_or(Vec3A::X) * size,
                _ => c + Vec3A::new(unit(), unit(), unit()) * (0.5 * size),
            };
            let mut ray = Ray::new(origin, aim - origin);
            ray.time = unit();
            let bits = |h: Option<PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.point.to_array()));
            // Ranges ending at the closest hit and just short of it as well.
            let first = four.closest_hit(&ray, Interval::POSITIVE).map_or(1.0, |h| h.hit.t);
            let short = f32::from_bits(first.to_bits() - 1);
            for range in
                [Interval::POSITIVE, Interval::new(0.5, 6.0), Interval::new(0.0, first), Interval::new(0.0, short)]
            {
                let expected = bits(four.closest_hit(&ray, range));
                assert_eq!(bits(eight.closest_hit(&ray, range)), expected, "{ray:?} in {range:?}");
                hits += expected.is_some_and(|h| h.0 >= 200) as usize;
            }
            for t_max in [0.5, 4.0, f32::INFINITY] {
                let expected = four.occluded(&ray, t_max);
                assert_eq!(eight.occluded(&ray, t_max), expected, "{ray:?} to {t_max}");
                occluded += expected as usize;
            }
        }
        assert!(hits > 20_000 && occluded > 10_000, "the rays meet the shapes ({hits} hits, {occluded} occluded)");
    }

    /// Rays that miss the box around the triangles skip their walk where other shapes lie outside that
    /// box, and every query answers as without the test, bit for bit.
    #[test]
    fn rays_missing_the_triangles_box_answer_as_with_the_walk() {
        let mut rng = Pcg32::new(9, 11);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut point = |scale: f32| Vec3A::new(unit(), unit(), unit()) * (2.0 * scale) - Vec3A::splat(scale);
        // A floor of triangles below spheres.
        let mut prims: Vec<Primitive> = (0..40)
            .map(|_| {
                let c = point(4.0) * Vec3A::new(1.0, 1.0, 0.1) - Vec3A::new(0.0, 0.0, 2.0);
                Primitive::Triangle(Triangle::new(c, c + point(1.0), c + point(1.0)))
            })
            .collect();
        prims.extend((0..6).map(|_| Primitive::Sphere(raylume_geometry::Sphere { center: point(1.5), radius: 0.6 })));
        let tested = Bvh::new(prims.clone(), Interval::new(0.0, 0.0));
        assert!(tested.triangles_box.is_some(), "the spheres lie outside the triangles' box");
        let walked = Bvh { triangles_box: None, ..tested.clone() };
        let mut hits = [0; 2];
        for _ in 0..20_000 {
            let origin = point(6.0);
            let ray = Ray::new(origin, point(3.0) - origin);
            let (a, b) = (tested.closest_hit(&ray, Interval::POSITIVE), walked.closest_hit(&ray, Interval::POSITIVE));
            let bits = |h: Option<PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.point.to_array()));
            assert_eq!(bits(a), bits(b));
            for t_max in [1.0, 5.0, f32::INFINITY] {
                assert_eq!(tested.occluded(&ray, t_max), walked.occluded(&ray, t_max));
            }
            if let Some(h) = a {
                hits[(h.primitive >= 40) as usize] += 1;
            }
        }
        assert!(hits[0] > 1000 && hits[1] > 1000, "the rays meet both triangles and spheres: {hits:?}");
    }

    /// A large tree's leaves live on huge pages where the system has them (as do their boxes and
    /// normals, from a mebibyte); the same tree with them on the heap (a clone's) answers every query
    /// bit for bit.
    #[test]
    fn leaves_on_huge_pages_answer_as_on_the_heap() {
        let prims = random_scene(13, 40_000, 0.3);
        let rays: Vec<Ray> = random_scene(14, 20_000, 20.0)
            .iter()
            .filter_map(Primitive::as_triangle)
            .map(|t| Ray::new(t.p[1] * 2.0, t.p[0] - t.p[1] * 2.0))
            .collect();
        for kernel in [BvhKernel::Portable, BvhKernel::best()] {
            // Every tree counts as large here.
            let mapped = Bvh::build(prims.clone(), Interval::new(0.0, 0.0), BvhBuild::Sah, kernel, 0);
            let heap = mapped.clone();
            let (m, h) = (mapped.triangles.as_ref().unwrap(), heap.triangles.as_ref().unwrap());
            #[cfg(target_os = "linux")]
            assert!(
                m.leaves.is_mapped() && m.leaves.as_ptr() as usize % (2 << 20) == 0,
                "{} bytes of leaves on huge pages",
                size_of_val(&*m.leaves)
            );
            assert!(!h.leaves.is_mapped() && !h.leaf_bounds.is_mapped() && !h.leaf_normals.is_mapped());
            assert_eq!((mapped.validate(), heap.validate()), (Ok(()), Ok(())));
            let mut hits = 0;
            for ray in &rays {
                let bits =
                    |h: Option<PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.normal.to_array()));
                let a = mapped.closest_hit(ray, Interval::POSITIVE);
                assert_eq!(bits(a), bits(heap.closest_hit(ray, Interval::POSITIVE)));
                assert_eq!(mapped.occluded(ray, 10.0), heap.occluded(ray, 10.0));
                hits += a.is_some() as usize;
            }
            assert!(hits > 5000, "the rays meet the triangles ({hits} hits)");
        }
    }

    /// A walk that prefetches the next entry of its stack (as trees larger than [`LARGE_TREE_BYTES`] do)
    /// answers every query as the same tree without prefetches, bit for bit.
    #[test]
    fn prefetching_walks_answer_as_plain_ones() {
        let mut rng = Pcg32::new(7, 11);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut point = |scale: f32| Vec3A::new(unit(), unit(), unit()) * (2.0 * scale) - Vec3A::splat(scale);
        let prims: Vec<Primitive> = (0..3000)
            .map(|_| {
                let c = point(10.0);
                Primitive::Triangle(Triangle::new(c, c + point(1.0), c + point(1.0)))
            })
            .collect();
        let rays: Vec<Ray> = (0..20_000).map(|_| Ray::new(point(20.0), point(10.0) - point(20.0))).collect();
        for kernel in [BvhKernel::Portable, BvhKernel::best()] {
            let still = Interval::new(0.0, 0.0);
            let plain = Bvh::build(prims.clone(), still, BvhBuild::Sah, kernel, usize::MAX);
            let prefetching = Bvh::build(prims.clone(), still, BvhBuild::Sah, kernel, 0);
            assert_eq!((plain.validate(), prefetching.validate()), (Ok(()), Ok(())));
            let mut hits = 0;
            for ray in &rays {
                let (a, b) =
                    (plain.closest_hit(ray, Interval::POSITIVE), prefetching.closest_hit(ray, Interval::POSITIVE));
                assert_eq!(a.map(|h| (h.primitive, h.hit.t.to_bits())), b.map(|h| (h.primitive, h.hit.t.to_bits())));
                assert_eq!(plain.occluded(ray, f32::INFINITY), prefetching.occluded(ray, f32::INFINITY));
                hits += a.is_some() as usize;
            }
            assert!(hits > 1000, "the rays meet the triangles ({hits} hits)");
        }
    }
}
