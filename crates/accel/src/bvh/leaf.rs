//! The triangles' leaf tests: how a leaf's candidate triangles are found ([`Filter`]: [`Portable`]
//! here, `pulp::x86::V3` in [`avx2`](super::avx2)), the exact decision of the candidates (the scalar
//! watertight test, each filter compiling it with its own target features), and the leaf tests the
//! walks call for one ray ([`ClosestLeaf`], [`OccludedLeaf`]) or per ray of a packet
//! ([`closest_in_leaf`], [`Filter::leaf_occluded`]).

use raylume_geometry::{Interval, Ray};
use raylume_intersect::{ShearedRay, TriangleHit};

use super::stream::{Block, Found};
use super::triangles::{LANES, Leaf, candidates_of};
use super::wide::{LeafTest, leaf_range, set_bits};
use crate::Tally;

/// How a leaf's candidate triangles are found: four lanes at a time ([`Portable`]), or eight in AVX
/// registers (`pulp::x86::V3`).
pub(super) trait Filter: Copy {
    /// What the filter forms of a leaf on its way to the candidates and hands to the exact test of
    /// those candidates, which would otherwise form it again (`()` for a filter that keeps nothing).
    type Prepared;

    /// The candidate triangles of a leaf holding `count`: bit `4 j + l` for lane `l` of packet `j`.
    fn leaf_candidates(self, leaf: &Leaf, count: usize, ray: &ShearedRay) -> u32 {
        self.prepare(leaf, count, ray).0
    }

    /// [`Filter::leaf_candidates`], with what the filter formed on the way to them.
    fn prepare(self, leaf: &Leaf, count: usize, ray: &ShearedRay) -> (u32, Self::Prepared);

    /// Starts loading `leaf` into the cache, where the filter can (none by default).
    #[inline(always)]
    fn prefetch(self, _leaf: &Leaf) {}

    /// Whether a triangle of a leaf holding `count` is hit within `range`: the answer of the scalar
    /// watertight test of its candidates.
    #[inline(always)]
    fn leaf_occluded(self, leaf: &Leaf, count: usize, ray: &ShearedRay, range: Interval) -> bool {
        occluded_in_leaf(self, leaf, self.leaf_candidates(leaf, count, ray), ray, range)
    }

    /// The closest hit of `test`'s candidates within its range, kept in its `found`; returns the new
    /// end of the range. The answer of the scalar watertight test of each candidate in turn, the range
    /// narrowing at each hit. `prepared` is what [`Filter::prepare`] formed of the leaf.
    #[inline(always)]
    fn closest_of_candidates(self, test: Candidates, prepared: &Self::Prepared) -> f32 {
        let _ = prepared;
        closest_of_candidates_scalar(test)
    }

    /// Whether the filter tests a block of rays a triangle at a time ([`Filter::closest_in_block`],
    /// [`Filter::occluded_in_block`]); otherwise a packet's rays test each leaf one by one.
    const BLOCKS: bool = false;

    /// [`closest_in_leaf`] for each ray of `block` within `[t_min, t_max]`, each ray's `t_max` set to
    /// the new end of its range.
    #[inline(always)]
    fn closest_in_block(self, leaves: &[Leaf], (first, count): (usize, usize), t_min: f32, block: Block<Found>) {
        for lane in set_bits(block.lanes) {
            let l = lane as usize;
            let range = Interval::new(t_min, block.t_max[l]);
            block.t_max[l] =
                closest_in_leaf(self, leaves, (first, count), &block.sheared[l], range, &mut block.kept[l]);
        }
    }

    /// [`Filter::leaf_occluded`] for each ray of `block` within `(0, t_max)`: an occluded ray is marked
    /// and retired (its `t_max` becomes `-inf`).
    #[inline(always)]
    fn occluded_in_block(self, leaf: &Leaf, count: usize, block: Block<bool>) {
        for lane in set_bits(block.lanes) {
            let l = lane as usize;
            if self.leaf_occluded(leaf, count, &block.sheared[l], Interval::new(0.0, block.t_max[l])) {
                block.kept[l] = true;
                block.t_max[l] = f32::NEG_INFINITY;
            }
        }
    }

    /// Runs a leaf's exact test compiled with the filter's target features (the test's function is not
    /// inlined into the walk, see `closest_of_candidates`, so it does not inherit them).
    #[inline(always)]
    fn exact<E: Exact>(self, test: E) -> E::Output {
        test.run()
    }
}

/// An exact test of a leaf's candidates, as a function object whose call is always inlined into the
/// function [`Filter::exact`] compiles it in.
pub(super) trait Exact {
    type Output;
    fn run(self) -> Self::Output;
}

/// The filter of baseline x86-64 (and of every other target): one packet at a time.
#[derive(Clone, Copy, Debug)]
pub(super) struct Portable;

impl Filter for Portable {
    type Prepared = ();

    #[inline(always)]
    fn prepare(self, leaf: &Leaf, count: usize, ray: &ShearedRay) -> (u32, ()) {
        let mut lanes = 0;
        for j in 0..count.div_ceil(LANES) {
            lanes |= candidates_of(|k, a| leaf.quarter(k, a, j), ray, (count - j * LANES).min(LANES)) << (j * LANES);
        }
        (lanes, ())
    }
}

/// Tests leaf `first` (of `count` triangles) for the closest hit within `range`, keeping it in
/// `found` (the hit, its leaf and candidate bit); returns the new end of the range.
#[inline(always)]
pub(super) fn closest_in_leaf<F: Filter>(
    filter: F,
    leaves: &[Leaf],
    (first, count): (usize, usize),
    ray: &ShearedRay,
    range: Interval,
    found: &mut Option<(TriangleHit, u32, u32)>,
) -> f32 {
    let leaf = &leaves[first];
    let (lanes, prepared) = filter.prepare(leaf, count, ray);
    if lanes == 0 {
        range.max
    } else {
        let test = Candidates { leaf, leaves, first, lanes, ray, range, found };
        exact_out_of_line(filter, ClosestOfCandidates { filter, test, prepared })
    }
}

/// An exact test of a leaf, compiled with `filter`'s target features ([`Filter::exact`]) and not
/// inlined: the exact tests' many live values would otherwise take the registers the walk keeps its ray
/// in (docs/PERFORMANCE.md).
#[inline(never)]
pub(super) fn exact_out_of_line<F: Filter, E: Exact>(filter: F, test: E) -> E::Output {
    filter.exact(test)
}

/// A closest-hit test of a leaf's candidates: the candidate `lanes` of `leaf` (leaf number `first`),
/// the ray, its range, and the closest hit so far with its leaf and candidate bit.
pub(super) struct Candidates<'a> {
    pub leaf: &'a Leaf,
    /// Every leaf, to read the primitive of the hit so far (ties go to the lowest primitive index).
    pub leaves: &'a [Leaf],
    pub first: usize,
    pub lanes: u32,
    pub ray: &'a ShearedRay,
    pub range: Interval,
    pub found: &'a mut Option<(TriangleHit, u32, u32)>,
}

impl Candidates<'_> {
    /// Decides candidate `bit` by the scalar watertight test within `range`, keeping a hit in `found`
    /// and narrowing `range` to it.
    #[inline(always)]
    pub fn decide(&mut self, bit: u32, range: &mut Interval) {
        if let Some(h) = raylume_intersect::watertight_decide(&self.leaf.triangle(bit), self.ray, *range) {
            self.keep(bit, h, range);
        }
    }

    /// Keeps `h`, a hit of candidate `bit` within `range`, if it beats the hit so far: a hit at the
    /// same distance replaces it only if its primitive comes first.
    #[inline(always)]
    pub fn keep(&mut self, bit: u32, h: TriangleHit, range: &mut Interval) {
        let wins = match *self.found {
            Some((f, leaf, b)) if f.t == h.t => self.leaf.id(bit) < self.leaves[leaf as usize].id(b),
            _ => true,
        };
        if wins {
            *range = range.with_max(h.t);
            *self.found = Some((h, self.first as u32, bit));
        }
    }
}

/// [`Filter::closest_of_candidates`] by the scalar watertight test of each candidate in turn.
#[inline(always)]
pub(super) fn closest_of_candidates_scalar(mut test: Candidates) -> f32 {
    let mut range = test.range;
    for bit in set_bits(test.lanes) {
        test.decide(bit, &mut range);
    }
    range.max
}

/// [`closest_in_leaf`]'s test of a leaf with candidates, the filter that compiles it and what the filter
/// formed of the leaf.
struct ClosestOfCandidates<'a, F: Filter> {
    filter: F,
    test: Candidates<'a>,
    prepared: F::Prepared,
}

impl<F: Filter> Exact for ClosestOfCandidates<'_, F> {
    type Output = f32;

    #[inline(always)]
    fn run(self) -> f32 {
        self.filter.closest_of_candidates(self.test, &self.prepared)
    }
}

/// Whether any triangle among the candidate `lanes` of `leaf` is hit within `range`, by the scalar test.
#[inline(always)]
pub(super) fn occluded_in_leaf<F: Filter>(
    filter: F,
    leaf: &Leaf,
    lanes: u32,
    ray: &ShearedRay,
    range: Interval,
) -> bool {
    lanes != 0 && exact_out_of_line(filter, AnyCandidateHit { leaf, lanes, ray, range })
}

/// [`occluded_in_leaf`]'s test of a leaf with candidates.
pub(super) struct AnyCandidateHit<'a> {
    pub leaf: &'a Leaf,
    pub lanes: u32,
    pub ray: &'a ShearedRay,
    pub range: Interval,
}

impl Exact for AnyCandidateHit<'_> {
    type Output = bool;

    #[inline(always)]
    fn run(self) -> bool {
        let Self { leaf, lanes, ray, range } = self;
        set_bits(lanes).any(|bit| raylume_intersect::watertight_hits(&leaf.triangle(bit), ray, range))
    }
}

/// One ray's view of the triangles' leaves: their candidates for the ray, with the ray's watertight
/// frame prepared at the first leaf it reaches (many rays reach none).
struct RayLeaves<'a, F> {
    filter: F,
    leaves: &'a [Leaf],
    ray: &'a Ray,
    sheared: Option<Option<ShearedRay>>,
}

impl<'a, F: Filter> RayLeaves<'a, F> {
    fn new(filter: F, leaves: &'a [Leaf], ray: &'a Ray) -> Self {
        Self { filter, leaves, ray, sheared: None }
    }

    /// The leaf's index, its number of triangles and the prepared ray; `None` for a ray without a
    /// watertight frame (it hits no triangle).
    #[inline(always)]
    fn prepared<T: Tally>(&mut self, leaf: u32, tally: &mut T) -> Option<(usize, usize, &ShearedRay)> {
        let (first, count) = leaf_range(leaf);
        for _ in 0..count {
            tally.tested();
        }
        let sheared = self.sheared.get_or_insert_with(|| ShearedRay::new(self.ray)).as_ref()?;
        Some((first, count, sheared))
    }

    /// Starts loading leaf `leaf`'s triangles into the cache.
    #[inline(always)]
    fn prefetch(&self, leaf: u32) {
        if let Some(l) = self.leaves.get(leaf_range(leaf).0) {
            self.filter.prefetch(l);
        }
    }
}

/// The triangles' leaf test of one ray's closest-hit walk.
pub(super) struct ClosestLeaf<'a, F> {
    leaves: RayLeaves<'a, F>,
    t_min: f32,
    /// The closest hit so far, its leaf and candidate bit.
    found: Option<(TriangleHit, u32, u32)>,
}

impl<'a, F: Filter> ClosestLeaf<'a, F> {
    /// The test of `leaves` for `ray` by `filter`, of hits from `t_min` on.
    #[inline(always)]
    pub fn new(filter: F, leaves: &'a [Leaf], ray: &'a Ray, t_min: f32) -> Self {
        Self { leaves: RayLeaves::new(filter, leaves, ray), t_min, found: None }
    }

    /// The closest hit found, its leaf and candidate bit.
    #[inline(always)]
    pub fn found(self) -> Option<(TriangleHit, u32, u32)> {
        self.found
    }
}

impl<T: Tally, F: Filter> LeafTest<T> for ClosestLeaf<'_, F> {
    #[inline(always)]
    fn prefetch(&self, leaf: u32) {
        self.leaves.prefetch(leaf);
    }

    #[inline(always)]
    fn test(&mut self, leaf: u32, t_max: f32, tally: &mut T) -> f32 {
        let (filter, leaves) = (self.leaves.filter, self.leaves.leaves);
        let Some((first, count, sheared)) = self.leaves.prepared(leaf, tally) else { return t_max };
        closest_in_leaf(filter, leaves, (first, count), sheared, Interval::new(self.t_min, t_max), &mut self.found)
    }
}

/// The triangles' leaf test of one ray's any-hit walk within `(0, t_max)`: ends the walk at the first
/// hit.
pub(super) struct OccludedLeaf<'a, F> {
    leaves: RayLeaves<'a, F>,
    hit: bool,
}

impl<'a, F: Filter> OccludedLeaf<'a, F> {
    /// The test of `leaves` for `ray` by `filter`.
    #[inline(always)]
    pub fn new(filter: F, leaves: &'a [Leaf], ray: &'a Ray) -> Self {
        Self { leaves: RayLeaves::new(filter, leaves, ray), hit: false }
    }

    /// Whether the walk met a hit.
    #[inline(always)]
    pub fn hit(&self) -> bool {
        self.hit
    }
}

impl<T: Tally, F: Filter> LeafTest<T> for OccludedLeaf<'_, F> {
    #[inline(always)]
    fn prefetch(&self, leaf: u32) {
        self.leaves.prefetch(leaf);
    }

    #[inline(always)]
    fn test(&mut self, leaf: u32, t_max: f32, tally: &mut T) -> f32 {
        let (filter, leaves) = (self.leaves.filter, self.leaves.leaves);
        let Some((first, count, sheared)) = self.leaves.prepared(leaf, tally) else { return t_max };
        // An any-hit walk's range ends where the query's does until the first hit, which ends the walk.
        self.hit = filter.leaf_occluded(&leaves[first], count, sheared, Interval::new(0.0, t_max));
        if self.hit { f32::NEG_INFINITY } else { t_max }
    }
}
