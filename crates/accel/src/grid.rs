//! A uniform grid with 3D-DDA traversal (Amanatides and Woo) and per-ray mailboxing.

use raylume_geometry::{Aabb, Interval, Ray, Triangle, Vec3A};
use raylume_intersect::{Intersect, ShearedRay, TriangleHit, watertight_decide, watertight_hits};

use crate::bvh::FewShapes;
use crate::bvh::triangles::{LANES, Packet, candidates};
use crate::{AccelStats, Accelerator, PrimitiveHit, Tally};

/// A triangle every ray tests before its walk (a floor under a model), with its plane in f64 for
/// [`DirectTriangle::behind`].
#[derive(Clone, Copy, Debug)]
struct DirectTriangle {
    tri: Triangle,
    /// The primitive index.
    id: u32,
    /// The first vertex, [`Triangle::normal64`], and the same cross product of the edges' magnitudes
    /// (each term taken positive), which bounds its rounding.
    p0: [f64; 3],
    normal: [f64; 3],
    magnitude: [f64; 3],
}

impl DirectTriangle {
    fn new(tri: Triangle, id: u32) -> Self {
        let p0 = tri.p[0];
        let p0 = [p0.x as f64, p0.y as f64, p0.z as f64];
        Self { tri, id, p0, normal: tri.normal64(), magnitude: raylume_intersect::normal64_magnitude(&tri) }
    }

    /// Whether the ray's origin lies strictly on one side of the triangle's plane and its direction
    /// strictly leads away from it, beyond the rounding of both products: its line then meets the
    /// plane at `t < 0`, where the watertight test never reports a hit (a hit it decides in f32 has
    /// `t` beyond the bound on its error, one it decides in f64 beyond that bound, so the exact
    /// distance is positive). The bounds, a relative 2^-46 of the sums of magnitudes, exceed the few
    /// f64 roundings of the normal, the offset and the sums many times over.
    #[inline(always)]
    fn behind(&self, ray: &Ray) -> bool {
        let (o, d) = (ray.origin, ray.dir);
        let q = [o.x as f64 - self.p0[0], o.y as f64 - self.p0[1], o.z as f64 - self.p0[2]];
        let d = [d.x as f64, d.y as f64, d.z as f64];
        let (n, m) = (&self.normal, &self.magnitude);
        let side = n[0] * q[0] + n[1] * q[1] + n[2] * q[2];
        let along = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
        const SLACK: f64 = 1.0 / (1u64 << 46) as f64;
        let side_error = (m[0] * q[0].abs() + m[1] * q[1].abs() + m[2] * q[2].abs()) * SLACK;
        let along_error = (m[0] * d[0].abs() + m[1] * d[1].abs() + m[2] * d[2].abs()) * SLACK;
        (side > side_error && along > along_error) || (side < -side_error && along < -along_error)
    }
}

/// How a [`Grid`] is sized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridParams {
    /// Density factor: the grid has about `k * N` cells for N primitives (cells per axis
    /// `extent * cbrt(k N / V)`, the course's formula). p3f.md gives no value; 2 is the classic one
    /// (Shirley).
    pub k: f32,
    /// Whether to test a primitive that spans several cells once per ray (true) or once per cell.
    pub mailbox: bool,
}

impl Default for GridParams {
    fn default() -> Self {
        Self { k: 2.0, mailbox: true }
    }
}

impl GridParams {
    /// Largest density accepted by [`GridParams::validate`] (cells per primitive).
    pub const MAX_K: f32 = 1000.0;

    /// Checks the density: a finite number in `(0, MAX_K]`; the message names the value.
    ///
    /// ```
    /// use raylume_accel::GridParams;
    /// assert!(GridParams::default().validate().is_ok());
    /// let nan = GridParams { k: f32::NAN, mailbox: true };
    /// assert_eq!(nan.validate().unwrap_err(), "grid density NaN: expected a number in (0, 1000]");
    /// ```
    pub fn validate(&self) -> Result<(), String> {
        let k = self.k;
        if k.is_finite() && k > 0.0 && k <= Self::MAX_K {
            Ok(())
        } else {
            Err(format!("grid density {k}: expected a number in (0, {}]", Self::MAX_K))
        }
    }
}

/// Largest number of cells per axis.
const MAX_CELLS_PER_AXIS: usize = 512;
/// Largest number of cells in all.
const MAX_CELLS: u64 = 1 << 25;
/// Most cell entries per bounded primitive, and in any case: a grid whose primitives overlap so
/// much that they would take more is built coarser, so its size stays bounded by its input's.
const ENTRIES_PER_PRIMITIVE: u64 = 64;
const MIN_ENTRY_BUDGET: u64 = 1 << 24;

/// Most primitives [`large_primitives`] takes out of the grid.
const MAX_LARGE: usize = 8;
/// How much smaller in volume the box of the other primitives must be for them to be taken out.
const LARGE_SHRINK: f64 = 8.0;
/// Most bounded primitives other than triangles that rays test from one node of their boxes
/// ([`FewShapes`]) rather than from the cells: the walk's setup and its mailbox cost more than the box
/// tests they save on so few.
const FEW_OTHERS: usize = FewShapes::MAX;
/// Mailbox slots per ray (direct-mapped by primitive index).
const MAILBOX: usize = 32;

/// A uniform grid over bounded primitives; unbounded ones (planes), and the few primitives as large as
/// the scene (a floor under a model, see `large_primitives`), are tested directly by every ray.
///
/// Each cell holds its triangles in packets of four, which a ray filters four at a time without
/// branches (the BVH's leaf filter), and its other primitives as a list of indices.
/// The exact test runs on the candidates and the other primitives only.
///
/// The course's mailbox (a ray id stored in each primitive) is not safe when several threads trace
/// at once. raylume's mailbox lives in the ray's traversal instead: a small direct-mapped table of the
/// last primitives given the exact test, on the stack, so it needs no lock and no shared state. A
/// primitive evicted from it may be tested twice, which costs time but never changes the answer.
#[derive(Clone, Debug)]
pub struct Grid<P> {
    prims: Vec<P>,
    /// The primitives every ray tests before its walk (unbounded ones and [`large_primitives`]): the
    /// triangles with their primitive index, and the indices of the others.
    direct_triangles: Vec<DirectTriangle>,
    direct_others: Vec<u32>,
    /// With at most [`FEW_OTHERS`] bounded primitives other than triangles (outside
    /// `direct_others`): their boxes, and their indices in slot order (increasing), tested before the
    /// walk instead of entered in the cells.
    few_others: Option<(FewShapes, Vec<u32>)>,
    /// The box of the cells, and of the few other shapes.
    bounds: Aabb,
    cells: [usize; 3],
    /// The lattice in f64: its corner, cell size and the size's reciprocal. Cells are entered and walked
    /// in f64, where neither the walk nor a far ray origin loses the cell a hit is in.
    corner: [f64; 3],
    cell_size: [f64; 3],
    /// The far corner of the box in f64.
    upper: [f64; 3],
    inv_cell_size: [f64; 3],
    /// `starts[c]` and `starts[c + 1]` bound cell `c`'s packets (`[0]`, in `packets`) and its other
    /// primitives (`[1]`, in `others`).
    starts: Vec<[u32; 2]>,
    /// The cells' triangles, in cell order, each packet with the primitive indices of its triangles.
    packets: Vec<Packet>,
    /// The mask of the lanes of each of `packets` that hold a triangle.
    used: Vec<u8>,
    /// The indices of the cells' other primitives, in cell order.
    others: Vec<u32>,
    /// The number of cell entries (a primitive in each of its cells).
    entries: usize,
    mailbox: bool,
}

/// The lattice of `cells` over `bounds`, in f64: corner, cell size, reciprocal.
fn lattice(bounds: Aabb, cells: [usize; 3]) -> [[f64; 3]; 3] {
    let corner = bounds.min.to_array().map(f64::from);
    let size = [0, 1, 2].map(|a| (bounds.max[a] as f64 - corner[a]) / cells[a] as f64);
    [corner, size, size.map(f64::recip)]
}

/// The cell of coordinate `x` along axis `a` of a lattice, clamped to the grid.
#[inline(always)]
fn coord(x: f64, a: usize, corner: &[f64; 3], inv: &[f64; 3], cells: &[usize; 3]) -> usize {
    // Through u32 (at most 512 cells per axis): a shorter saturating conversion than to u64.
    (((x - corner[a]) * inv[a]).max(0.0) as u32 as usize).min(cells[a] - 1)
}

/// The part of a ray's line (origin `o`, direction `d` along one axis, `inv` its reciprocal) within
/// `[lo, hi]` on that axis: `(near, far)`, empty (near beyond far) where a ray parallel to the axis's
/// planes is outside.
#[inline(always)]
fn slab(lo: f64, hi: f64, o: f64, d: f64, inv: f64) -> (f64, f64) {
    if d == 0.0 {
        if o < lo || o > hi { (f64::INFINITY, f64::NEG_INFINITY) } else { (f64::NEG_INFINITY, f64::INFINITY) }
    } else {
        let (ta, tb) = ((lo - o) * inv, (hi - o) * inv);
        (min(ta, tb), max(ta, tb))
    }
}

/// The larger of two numbers that are not NaN (one instruction, where `f64::max` takes several).
#[inline(always)]
fn max(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// The smaller of two numbers that are not NaN.
#[inline(always)]
fn min(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// Where a ray's walk starts along one axis.
struct AxisStart {
    /// The cell the ray enters the grid in, along the axis.
    cell: usize,
    /// The ray parameter where it leaves that cell along the axis.
    next: f64,
    /// The ray parameter across one cell along the axis.
    delta: f64,
    /// The step of the cell index to the next cell along the axis.
    stride: usize,
    /// How many steps are left along the axis before the ray leaves the grid.
    left: usize,
}

/// The cells a box is entered in, per axis: its f64 extent widened by a relative 2^-40, far more than
/// the walk's f64 roundings.
#[inline]
fn cell_range(b: &Aabb, [corner, _, inv]: &[[f64; 3]; 3], cells: &[usize; 3]) -> [(usize, usize); 3] {
    [0, 1, 2].map(|a| {
        let (lo, hi) = (b.min[a] as f64, b.max[a] as f64);
        let slack = (lo.abs().max(hi.abs()) + corner[a].abs()) * (1.0 / (1u64 << 40) as f64);
        (coord(lo - slack, a, corner, inv, cells), coord(hi + slack, a, corner, inv, cells))
    })
}

/// The primitives to test directly rather than enter in the grid: at most [`MAX_LARGE`] boxes that each
/// span more than half the scene's box along some axis (a floor under a model), when the box of the
/// others is at most [`LARGE_SHRINK`] times smaller in volume. Such a primitive would stretch the
/// lattice over the whole scene, and crowd the rest into a few cells; tested by every ray it costs one
/// test a ray, and its hit shortens the ray's walk.
fn large_primitives(prim_bounds: &[Aabb]) -> Vec<u32> {
    let finite = || prim_bounds.iter().filter(|b| b.is_finite() && !b.is_empty());
    let all = finite().fold(Aabb::EMPTY, |a, b| a.union(*b));
    if all.is_empty() {
        return Vec::new();
    }
    let half = all.diagonal() * 0.5;
    let spans = |b: &Aabb| b.is_finite() && !b.is_empty() && b.diagonal().cmpgt(half).any();
    let large: Vec<u32> = (0..prim_bounds.len() as u32).filter(|&i| spans(&prim_bounds[i as usize])).collect();
    if large.is_empty() || large.len() > MAX_LARGE {
        return Vec::new();
    }
    let rest = finite().filter(|b| !spans(b)).fold(Aabb::EMPTY, |a, b| a.union(*b));
    let volume = |b: Aabb| {
        let d = b.diagonal().as_dvec3();
        d.x * d.y * d.z
    };
    if rest.is_empty() || volume(rest) * LARGE_SHRINK <= volume(all) { large } else { Vec::new() }
}

/// How many cell entries the bounded boxes of `prim_bounds` make in a grid of `cells` over `bounds`.
fn entries(prim_bounds: &[Aabb], bounds: Aabb, cells: [usize; 3]) -> u64 {
    let lattice = lattice(bounds, cells);
    prim_bounds
        .iter()
        .filter(|b| b.is_finite() && !b.is_empty())
        .map(|b| cell_range(b, &lattice, &cells).iter().map(|&(lo, hi)| (hi - lo + 1) as u64).product::<u64>())
        .fold(0u64, u64::saturating_add)
}

impl<P: Intersect> Grid<P> {
    /// Builds the grid over `prims`; moving primitives are entered in every cell their motion
    /// during `shutter` covers.
    pub fn new(prims: Vec<P>, shutter: Interval, params: GridParams) -> Self {
        let prim_bounds: Vec<Aabb> = prims.iter().map(|p| p.bounds_over(shutter)).collect();
        let mut direct_ids: Vec<u32> =
            (0..prims.len() as u32).filter(|&i| !prim_bounds[i as usize].is_finite()).collect();
        let large = large_primitives(&prim_bounds);
        direct_ids.extend(&large);
        direct_ids.sort_unstable();
        let mut bounds = Aabb::EMPTY;
        let mut prim_bounds = prim_bounds;
        for i in &large {
            prim_bounds[*i as usize] = Aabb::EMPTY;
        }
        let other_ids: Vec<u32> = (0..prims.len() as u32)
            .filter(|&i| {
                let b = &prim_bounds[i as usize];
                b.is_finite() && !b.is_empty() && prims[i as usize].as_triangle().is_none()
            })
            .collect();
        let few_others = (!other_ids.is_empty() && other_ids.len() <= FEW_OTHERS).then(|| {
            let few = FewShapes::new(other_ids.iter().map(|&i| prim_bounds[i as usize]));
            (few, other_ids)
        });
        let mut few_bounds = Aabb::EMPTY;
        for &i in few_others.iter().flat_map(|(_, ids)| ids) {
            few_bounds = few_bounds.union(prim_bounds[i as usize]);
            prim_bounds[i as usize] = Aabb::EMPTY;
        }
        let few = few_others.as_ref().map_or(0, |(_, ids)| ids.len());
        for b in prim_bounds.iter().filter(|b| b.is_finite()) {
            bounds = bounds.union(*b);
        }
        let bounded = prims.len() - direct_ids.len() - few;
        if bounds.is_empty() {
            bounds = Aabb::from_point(Vec3A::ZERO);
        }
        // Pad degenerate extents so every axis has a positive size, in proportion to the scene, so the
        // grid of a scene scaled by any factor is the same grid scaled.
        let extent = bounds.diagonal();
        let size = if extent.max_element() > 0.0 {
            extent.max_element()
        } else {
            bounds.min.abs().max(bounds.max.abs()).max_element()
        };
        let pad = Vec3A::splat((size * 1e-3).max(f32::MIN_POSITIVE));
        let flat = extent.cmple(pad);
        let (mut min, mut max) = (
            Vec3A::select(flat, bounds.min - pad, bounds.min).to_array(),
            Vec3A::select(flat, bounds.max + pad, bounds.max).to_array(),
        );
        // A pad below the coordinates' spacing (a flat scene far from the origin) leaves the axis flat:
        // widen it to the neighbouring floats.
        for a in 0..3 {
            if max[a] - min[a] <= 0.0 {
                (min[a], max[a]) = (min[a].next_down(), max[a].next_up());
            }
        }
        bounds = Aabb::new(Vec3A::from_array(min), Vec3A::from_array(max));
        // Cells per axis in proportion to the extents relative to the largest, in f64: the same cells at
        // any scale (in f32 the volume of a scene below about 1e-13 across, or above 1e13, leaves f32's
        // range).
        let extent = bounds.diagonal();
        let relative = [0, 1, 2].map(|a| extent[a] as f64 / extent.max_element() as f64);
        let volume = relative[0] * relative[1] * relative[2];
        let mut per_unit = (params.k.clamp(1e-3, 1e6) as f64 * bounded.max(1) as f64 / volume).cbrt();
        let budget =
            (bounded as u64).saturating_mul(ENTRIES_PER_PRIMITIVE).max(MIN_ENTRY_BUDGET).min(u32::MAX as u64 / 2);
        let cells = loop {
            let cells = [0, 1, 2].map(|a| ((relative[a] * per_unit).round() as usize).clamp(1, MAX_CELLS_PER_AXIS));
            let n_cells = cells.iter().map(|&c| c as u64).product::<u64>();
            if cells == [1, 1, 1] || (n_cells <= MAX_CELLS && entries(&prim_bounds, bounds, cells) <= budget) {
                break cells;
            }
            per_unit *= 0.8;
        };
        let [corner, cell_size, inv_cell_size] = lattice(bounds, cells);
        // u32::MAX marks an empty lane of a packet and an empty mailbox slot.
        assert!(prims.len() < u32::MAX as usize, "a grid holds fewer than 2^32 - 1 primitives");
        let (mut direct_triangles, mut direct_others) = (Vec::new(), Vec::new());
        for &i in &direct_ids {
            match prims[i as usize].as_triangle() {
                Some(t) => direct_triangles.push(DirectTriangle::new(t, i)),
                None => direct_others.push(i),
            }
        }
        let mut grid = Self {
            prims,
            direct_triangles,
            direct_others,
            few_others,
            bounds: if few_bounds.is_empty() { bounds } else { bounds.union(few_bounds) },
            cells,
            corner,
            cell_size,
            upper: bounds.max.to_array().map(f64::from),
            inv_cell_size,
            starts: Vec::new(),
            packets: Vec::new(),
            used: Vec::new(),
            others: Vec::new(),
            entries: 0,
            mailbox: params.mailbox,
        };
        // Two passes: count the entries of each cell, then fill them (compressed rows), in primitive order.
        let n_cells = cells[0] * cells[1] * cells[2];
        let mut counts = vec![0u32; n_cells + 1];
        for b in prim_bounds.iter().filter(|b| b.is_finite() && !b.is_empty()) {
            grid.for_cells(b, |c| counts[c] += 1);
        }
        let mut start = Vec::with_capacity(n_cells + 1);
        let mut acc = 0u32;
        for c in &counts[..n_cells] {
            start.push(acc);
            acc += c;
        }
        start.push(acc);
        let mut fill = start.clone();
        let mut items = vec![0u32; acc as usize];
        for (i, b) in prim_bounds.iter().enumerate() {
            if b.is_finite() && !b.is_empty() {
                grid.for_cells(b, |c| {
                    items[fill[c] as usize] = i as u32;
                    fill[c] += 1;
                });
            }
        }
        // Each cell's triangles into packets, its other primitives into a list.
        let mut starts = Vec::with_capacity(n_cells + 1);
        let (mut packets, mut others) = (Vec::new(), Vec::new());
        let mut triangles = Vec::new();
        for c in 0..n_cells {
            starts.push([packets.len() as u32, others.len() as u32]);
            triangles.clear();
            for &i in &items[start[c] as usize..start[c + 1] as usize] {
                match grid.prims[i as usize].as_triangle() {
                    Some(t) => triangles.push((t, i)),
                    None => others.push(i),
                }
            }
            packets.extend(triangles.chunks(LANES).map(|chunk| Packet::new(chunk.iter().copied())));
        }
        starts.push([packets.len() as u32, others.len() as u32]);
        assert!(packets.len() <= u32::MAX as usize && others.len() <= u32::MAX as usize);
        grid.starts = starts;
        grid.used = packets.iter().map(|p| p.used() as u8).collect();
        grid.packets = packets;
        grid.others = others;
        grid.entries = acc as usize;
        grid
    }

    /// The number of cell entries: each bounded primitive once in each of its cells.
    pub fn entries(&self) -> usize {
        self.entries
    }

    /// Cells per axis.
    pub fn resolution(&self) -> [usize; 3] {
        self.cells
    }

    #[inline]
    fn cell_index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.cells[1] + c[1]) * self.cells[0] + c[0]
    }

    fn for_cells(&self, b: &Aabb, mut f: impl FnMut(usize)) {
        let lattice = [self.corner, self.cell_size, self.inv_cell_size];
        let [(x0, x1), (y0, y1), (z0, z1)] = cell_range(b, &lattice, &self.cells);
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    f(self.cell_index([x, y, z]));
                }
            }
        }
    }

    /// Where the walk of a ray with origin `o` and direction `d` (`inv` its reciprocal) along axis `a`
    /// starts, entering the grid at `t0`. Without branches on the direction's sign, which rays in
    /// every direction would mispredict.
    #[inline(always)]
    fn start(&self, a: usize, o: f64, d: f64, inv: f64, t0: f64) -> AxisStart {
        let (corner, size, n) = (self.corner[a], self.cell_size[a], self.cells[a]);
        let cell = coord(o + d * t0, a, &self.corner, &self.inv_cell_size, &self.cells);
        let stride = [1, self.cells[0], self.cells[0] * self.cells[1]][a];
        // A zero component (0 or -0) never steps on that axis.
        if d == 0.0 {
            return AxisStart { cell, next: f64::INFINITY, delta: f64::INFINITY, stride: 0, left: 0 };
        }
        let up = d > 0.0;
        // The plane the ray leaves the cell by: its far one going up, its near one going down.
        let next = (corner + (cell + up as usize) as f64 * size - o) * inv;
        let (stride, left) = if up { (stride, n - 1 - cell) } else { (stride.wrapping_neg(), cell) };
        AxisStart { cell, next, delta: size * inv.abs(), stride, left }
    }

    /// Walks the cells the ray crosses within `[t_min, t_max]`, nearest first, calling `visit` with the
    /// packets (with the masks of their lanes in use) and the other primitives of each cell that has
    /// some; `visit` returns the end of the ray's range so far (the closest hit's distance, or minus
    /// infinity to stop), and the walk stops at the first cell that starts at or beyond it. In f64: the cells are those the ray's exact line crosses, wherever its
    /// origin is. Returns the number of cells walked.
    #[inline]
    fn walk(&self, ray: &Ray, t_min: f32, t_max: f32, mut visit: impl FnMut(&[Packet], &[u8], &[u32]) -> f32) -> u32 {
        // Written out per axis: array maps and loops over axes here are left as calls and loops.
        let (o, d) = (ray.origin, ray.dir);
        let (o, d) = ([o.x as f64, o.y as f64, o.z as f64], [d.x as f64, d.y as f64, d.z as f64]);
        // A NaN end leaves the range open on that side, to the grid's box.
        let t0 = if t_min.is_nan() { f64::NEG_INFINITY } else { t_min as f64 };
        let t1 = if t_max.is_nan() { f64::INFINITY } else { t_max as f64 };
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        let slab = |a: usize| slab(self.corner[a], self.upper[a], o[a], d[a], inv[a]);
        let ((n0, f0), (n1, f1), (n2, f2)) = (slab(0), slab(1), slab(2));
        let t0 = max(max(t0, n0), max(n1, n2));
        let t1 = min(min(t1, f0), min(f1, f2));
        if t0 > t1 {
            return 0;
        }
        let start = |a: usize| self.start(a, o[a], d[a], inv[a], t0);
        let (s0, s1, s2) = (start(0), start(1), start(2));
        let mut index = s0.cell + s1.cell * self.cells[0] + s2.cell * self.cells[0] * self.cells[1];
        let mut next = [s0.next, s1.next, s2.next];
        let delta = [s0.delta, s1.delta, s2.delta];
        let stride = [s0.stride, s1.stride, s2.stride];
        let mut left = [s0.left, s1.left, s2.left];
        let mut end = f64::INFINITY;
        let mut walked = 0;
        loop {
            walked += 1;
            let (first, last) = (self.starts[index], self.starts[index + 1]);
            if first != last {
                let others = &self.others[first[1] as usize..last[1] as usize];
                // Cells of shapes other than triangles skip the packets' slicing.
                let (packets, used) = if first[0] == last[0] {
                    (&[][..], &[][..])
                } else {
                    let packets = first[0] as usize..last[0] as usize;
                    (&self.packets[packets.clone()], &self.used[packets])
                };
                end = visit(packets, used, others) as f64;
            }
            let axis = if next[0] < next[1] {
                if next[0] < next[2] { 0 } else { 2 }
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            // A hit within this cell (up to its far side) is closer than any in the next.
            if next[axis] > t1 || next[axis] >= end || left[axis] == 0 {
                return walked;
            }
            left[axis] -= 1;
            index = index.wrapping_add(stride[axis]);
            next[axis] += delta[axis];
        }
    }
}

/// A per-ray mailbox: the last primitives tested, direct-mapped by index.
struct Mailbox {
    slots: [u32; MAILBOX],
    enabled: bool,
}

impl Mailbox {
    #[inline]
    fn new(enabled: bool) -> Self {
        Self { slots: [u32::MAX; MAILBOX], enabled }
    }

    /// Whether `id` still has to be tested by this ray (and records it).
    #[inline]
    fn first_visit(&mut self, id: u32) -> bool {
        if !self.enabled {
            return true;
        }
        let slot = &mut self.slots[id as usize % MAILBOX];
        if *slot == id {
            return false;
        }
        *slot = id;
        true
    }
}

/// The closest hit of a query so far: of a triangle (kept as its decision, with the triangle and its
/// primitive index) and of another primitive, each the closest of its kind; the range narrows to both.
struct Closest {
    triangle: Option<(TriangleHit, Triangle, u32)>,
    other: Option<PrimitiveHit>,
}

impl Closest {
    /// Decides triangle `tri` (primitive `id`) for a closer hit than the one found within `t_range`, and
    /// narrows the range to it.
    #[inline(always)]
    fn triangle(&mut self, tri: &Triangle, id: u32, sheared: &ShearedRay, t_range: &mut Interval) {
        if let Some(h) = watertight_decide(tri, sheared, *t_range) {
            let wins = match self.triangle {
                Some((f, _, k)) if f.t == h.t => id < k,
                _ => true,
            };
            if wins {
                *t_range = t_range.with_max(h.t);
                self.triangle = Some((h, *tri, id));
            }
        }
    }

    /// The closer of the two hits (the lower primitive index at one distance).
    #[inline(always)]
    fn answer(self) -> Option<PrimitiveHit> {
        let triangle = self.triangle.map(|(h, tri, id)| PrimitiveHit { hit: h.hit(&tri), primitive: id });
        match (triangle, self.other) {
            (Some(t), other) => PrimitiveHit::closer(other, t),
            (None, other) => other,
        }
    }
}

/// The lanes of `mask`, lowest first.
#[inline(always)]
fn lanes(mut mask: u32) -> impl Iterator<Item = u32> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let lane = mask.trailing_zeros();
            mask &= mask - 1;
            lane
        })
    })
}

impl<P: Intersect> Grid<P> {
    /// Tests other primitive `id` for a closer hit than `found`'s within `t_range`, and narrows the range
    /// to it.
    #[inline(always)]
    fn closest_other(&self, id: u32, ray: &Ray, t_range: &mut Interval, found: &mut Closest) {
        if let Some(hit) = self.prims[id as usize].intersect_canonical(ray, *t_range) {
            *t_range = t_range.with_max(hit.t);
            PrimitiveHit::keep_closer(&mut found.other, PrimitiveHit { hit, primitive: id });
        }
    }

    /// [`Accelerator::closest_hit_tally`] of a canonical ray.
    #[inline(always)]
    fn closest_canonical<const FEW: bool, T: Tally>(
        &self,
        ray: &Ray,
        mut t_range: Interval,
        tally: &mut T,
    ) -> Option<PrimitiveHit> {
        let sheared = ShearedRay::new(ray);
        let sheared = sheared.as_ref();
        let mut found = Closest { triangle: None, other: None };
        if let Some(sheared) = sheared {
            for direct in &self.direct_triangles {
                if !direct.behind(ray) {
                    tally.tested();
                    found.triangle(&direct.tri, direct.id, sheared, &mut t_range);
                }
            }
        }
        for &id in &self.direct_others {
            tally.tested();
            self.closest_other(id, ray, &mut t_range, &mut found);
        }
        if let Some((few, ids)) = self.few_others.as_ref().filter(|_| FEW) {
            few.closest(ray, &mut t_range, |slot, t_range| {
                tally.tested();
                self.closest_other(ids[slot], ray, t_range, &mut found);
            });
            // Without triangles in the cells, no walk.
            if self.entries == 0 {
                return found.answer();
            }
        }
        let mut mailbox = Mailbox::new(self.mailbox);
        let walked = self.walk(ray, t_range.min, t_range.max, |packets, used, others| {
            if let Some(sheared) = sheared {
                for (packet, &used) in packets.iter().zip(used) {
                    for lane in lanes(candidates(packet, sheared, LANES) & used as u32) {
                        let id = packet.id(lane);
                        if mailbox.first_visit(id) {
                            tally.tested();
                            found.triangle(&packet.triangle(lane), id, sheared, &mut t_range);
                        }
                    }
                }
            }
            for &id in others {
                if mailbox.first_visit(id) {
                    tally.tested();
                    self.closest_other(id, ray, &mut t_range, &mut found);
                }
            }
            t_range.max
        });
        (0..walked).for_each(|_| tally.visited());
        found.answer()
    }

    /// [`Accelerator::occluded_tally`] of a canonical ray.
    #[inline(always)]
    fn occluded_canonical<const FEW: bool, T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        let sheared = ShearedRay::new(ray);
        let sheared = sheared.as_ref();
        let range = Interval::new(0.0, t_max);
        if let Some(sheared) = sheared {
            for direct in &self.direct_triangles {
                if !direct.behind(ray) {
                    tally.tested();
                    if watertight_hits(&direct.tri, sheared, range) {
                        return true;
                    }
                }
            }
        }
        for &id in &self.direct_others {
            tally.tested();
            if self.prims[id as usize].occluded_canonical(ray, t_max) {
                return true;
            }
        }
        if let Some((few, ids)) = self.few_others.as_ref().filter(|_| FEW) {
            let occluded = few.any(ray, t_max, |slot| {
                tally.tested();
                self.prims[ids[slot] as usize].occluded_canonical(ray, t_max)
            });
            if occluded || self.entries == 0 {
                return occluded;
            }
        }
        let mut mailbox = Mailbox::new(self.mailbox);
        let mut hit = false;
        let walked = self.walk(ray, 0.0, t_max, |packets, used, others| {
            if let Some(sheared) = sheared {
                for (packet, &used) in packets.iter().zip(used) {
                    for lane in lanes(candidates(packet, sheared, LANES) & used as u32) {
                        let id = packet.id(lane);
                        if mailbox.first_visit(id) {
                            tally.tested();
                            if watertight_hits(&packet.triangle(lane), sheared, range) {
                                hit = true;
                                return f32::NEG_INFINITY;
                            }
                        }
                    }
                }
            }
            for &id in others {
                if mailbox.first_visit(id) {
                    tally.tested();
                    if self.prims[id as usize].occluded_canonical(ray, t_max) {
                        hit = true;
                        return f32::NEG_INFINITY;
                    }
                }
            }
            f32::INFINITY
        });
        (0..walked).for_each(|_| tally.visited());
        hit
    }
}

impl<P: Intersect + Sync + Send> Accelerator for Grid<P> {
    fn closest_hit_tally<T: Tally>(&self, ray: &Ray, t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        // Grids without the few other shapes query without their test.
        if self.few_others.is_some() {
            crate::closest_on_canonical(ray, t_range, |ray, t_range| {
                self.closest_canonical::<true, T>(ray, t_range, tally)
            })
        } else {
            crate::closest_on_canonical(ray, t_range, |ray, t_range| {
                self.closest_canonical::<false, T>(ray, t_range, tally)
            })
        }
    }

    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        if self.few_others.is_some() {
            crate::occluded_on_canonical(ray, t_max, |ray, t_max| self.occluded_canonical::<true, T>(ray, t_max, tally))
        } else {
            crate::occluded_on_canonical(ray, t_max, |ray, t_max| {
                self.occluded_canonical::<false, T>(ray, t_max, tally)
            })
        }
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn stats(&self) -> AccelStats {
        let bytes = std::mem::size_of_val(self.prims.as_slice())
            + std::mem::size_of_val(self.starts.as_slice())
            + std::mem::size_of_val(self.packets.as_slice())
            + std::mem::size_of_val(self.used.as_slice())
            + std::mem::size_of_val(self.others.as_slice())
            + std::mem::size_of_val(self.direct_triangles.as_slice())
            + std::mem::size_of_val(self.direct_others.as_slice())
            + self
                .few_others
                .as_ref()
                .map_or(0, |(few, ids)| std::mem::size_of_val(few) + std::mem::size_of_val(ids.as_slice()));
        AccelStats { nodes: self.cells.iter().product(), bytes, primitives: self.prims.len() }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    // Small integer coordinates make axis-aligned planes and origins on them common.
    use crate::bvh::triangles::tests::arb_point;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The plane-side test never rules out a triangle the watertight test hits, rays starting on
        /// its plane, an offset away from it, or anywhere.
        #[test]
        fn behind_keeps_every_hit(
            v in prop::array::uniform3(arb_point()),
            o in arb_point(),
            target in arb_point(),
            nudge in prop_oneof![Just(0.0f32), -1e-6f32..1e-6],
            onto_plane in any::<bool>(),
        ) {
            let tri = Triangle::new(v[0], v[1], v[2]);
            // Half the origins lie on the triangle's plane (up to f32), nudged off it.
            let o = if onto_plane {
                let (a, b) = (v[1] - v[0], v[2] - v[0]);
                let n = a.cross(b);
                prop_assume!(n.length_squared() > 0.0);
                o - n * ((o - v[0]).dot(n) / n.length_squared()) + n.normalize() * nudge
            } else {
                o
            };
            let dir = target - o;
            prop_assume!(dir != Vec3A::ZERO && o.is_finite());
            let ray = Ray::new(o, dir);
            let Some((canonical, _)) = ray.canonical() else { return Ok(()) };
            let Some(sheared) = ShearedRay::new(&canonical) else { return Ok(()) };
            let hit = watertight_decide(&tri, &sheared, Interval::new(0.0, f32::MAX)).is_some();
            prop_assert!(!hit || !DirectTriangle::new(tri, 0).behind(&canonical));
        }
    }

    /// A scene scaled by 2^k (k from -50 to 50) gets the same grid, its cells and entries, and the
    /// same answers as brute force, as many hits at every scale. (A padding of at least 1e-6, or the
    /// scene's volume in f32, would make other cells below 1e-9 and above 1e13.)
    #[test]
    fn the_grid_of_a_scaled_scene_is_the_same_grid() {
        use rand_core::Rng;
        use raylume_intersect::Primitive;

        use crate::BruteForce;

        let mut rng = rand_pcg::Pcg32::new(5, 9);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut point = move |scale: f32| Vec3A::new(unit(), unit(), unit()) * (2.0 * scale) - Vec3A::splat(scale);
        let corners: Vec<[Vec3A; 3]> = (0..500)
            .map(|_| {
                let c = point(1.0);
                [c, c + point(0.05), c + point(0.05)]
            })
            .collect();
        let rays: Vec<Ray> = (0..2000)
            .map(|_| {
                let origin = point(3.0);
                Ray::new(origin, point(1.0) - origin)
            })
            .collect();
        let unit_grid = |s: f32| {
            let prims: Vec<Primitive> =
                corners.iter().map(|v| Primitive::Triangle(Triangle::new(v[0] * s, v[1] * s, v[2] * s))).collect();
            (Grid::new(prims.clone(), Interval::new(0.0, 0.0), GridParams::default()), BruteForce::new(prims))
        };
        let (reference, _) = unit_grid(1.0);
        assert!(reference.cells.iter().product::<usize>() >= 1000, "{:?}", reference.cells);
        let mut hits_at_scale_one = None;
        for k in [0, -50, -40, -20, 20, 40, 50] {
            let s = 2.0f32.powi(k);
            let (grid, brute) = unit_grid(s);
            assert_eq!((grid.cells, grid.entries()), (reference.cells, reference.entries()), "scale 2^{k}");
            let mut hits = 0;
            for r in &rays {
                let ray = Ray::new(r.origin * s, r.dir);
                let (a, b) = (grid.closest_hit(&ray, Interval::POSITIVE), brute.closest_hit(&ray, Interval::POSITIVE));
                assert_eq!(a.map(|h| (h.primitive, h.hit.t.to_bits())), b.map(|h| (h.primitive, h.hit.t.to_bits())));
                hits += a.is_some() as usize;
            }
            assert!(hits > 50, "scale 2^{k}: {hits} hits");
            assert_eq!(hits, *hits_at_scale_one.get_or_insert(hits), "scale 2^{k}");
        }
    }

    /// A flat scene far from the origin, whose flat axis no pad in proportion to the scene can widen
    /// (a thousandth of it is below the spacing of floats there), gets a grid, and answers as brute force.
    #[test]
    fn a_flat_scene_far_from_the_origin_gets_a_grid() {
        use raylume_intersect::Primitive;

        use crate::BruteForce;

        let prims: Vec<Primitive> = (0..200)
            .map(|i| {
                let (x, y) = ((i % 10) as f32 * 0.01, (i / 10) as f32 * 0.005);
                let z = 1.0e6;
                Primitive::Triangle(Triangle::new(
                    Vec3A::new(x, y, z),
                    Vec3A::new(x + 0.9, y, z),
                    Vec3A::new(x, y + 0.9, z),
                ))
            })
            .collect();
        // With its flat axis left flat the build would refine its cells forever: bounded here, so the
        // test fails rather than hangs.
        let (send, receive) = std::sync::mpsc::channel();
        let scene = prims.clone();
        std::thread::spawn(move || {
            send.send(Box::new(Grid::new(scene, Interval::new(0.0, 0.0), GridParams::default())))
        });
        let grid = receive.recv_timeout(std::time::Duration::from_secs(60)).expect("the grid is built");
        assert!(grid.bounds.diagonal().z > 0.0 && grid.entries() > 0, "{:?}", grid.cells);
        let brute = BruteForce::new(prims);
        let mut hits = 0;
        for i in 0..400 {
            let target = Vec3A::new((i % 20) as f32 * 0.05, (i / 20) as f32 * 0.05, 1.0e6);
            let ray = Ray::new(target + Vec3A::new(0.3, -0.2, 5.0), Vec3A::new(-0.3, 0.2, -5.0));
            let (a, b) = (grid.closest_hit(&ray, Interval::POSITIVE), brute.closest_hit(&ray, Interval::POSITIVE));
            assert_eq!(a.map(|h| (h.primitive, h.hit.t.to_bits())), b.map(|h| (h.primitive, h.hit.t.to_bits())));
            hits += a.is_some() as usize;
        }
        assert!(hits > 100, "{hits} hits");
    }

    /// Up to [`FEW_OTHERS`] bounded shapes other than triangles are tested from one node of their boxes
    /// rather than from the cells (with no walk where no triangle is left in them); more go to the
    /// cells. Every query answers as brute force, bit for bit, ties between identical spheres included.
    #[test]
    fn a_few_other_shapes_answer_as_brute_force() {
        use rand_core::Rng;
        use raylume_geometry::{AaBox, Sphere};
        use raylume_intersect::Primitive;

        use crate::BruteForce;

        let mut rng = rand_pcg::Pcg32::new(21, 5);
        let mut unit = move || (rng.next_u32() >> 8) as f32 / (1 << 24) as f32;
        let mut point = |scale: f32| Vec3A::new(unit(), unit(), unit()) * (2.0 * scale) - Vec3A::splat(scale);
        // Small triangles among the shapes, or a floor under them (tested directly, leaving the cells empty).
        for floor in [false, true] {
            for n in 1..=FEW_OTHERS + 1 {
                let mut prims: Vec<Primitive> = if floor {
                    let [a, b, c, d] = [(-20.0, -20.0), (20.0, -20.0), (20.0, 20.0), (-20.0, 20.0)]
                        .map(|(x, z)| Vec3A::new(x, -6.0, z));
                    vec![Primitive::Triangle(Triangle::new(a, b, c)), Primitive::Triangle(Triangle::new(a, c, d))]
                } else {
                    (0..6)
                        .map(|_| {
                            let c = point(4.0);
                            Primitive::Triangle(Triangle::new(c, c + point(1.0), c + point(1.0)))
                        })
                        .collect()
                };
                let triangles = prims.len();
                // Overlapping shapes, the first sphere twice (a tie at every hit), a box among them.
                let first = Sphere { center: point(1.0), radius: 0.5 + point(0.5).x.abs() };
                prims.extend((0..n).map(|i| match i {
                    0 | 1 => Primitive::Sphere(first),
                    2 => Primitive::Box(AaBox { bounds: Aabb::new(point(1.0), Vec3A::splat(1.5)) }),
                    _ => Primitive::Sphere(Sphere { center: point(1.0), radius: 0.5 + point(0.5).x.abs() }),
                }));
                let grid = Grid::new(prims.clone(), Interval::new(0.0, 0.0), GridParams::default());
                assert_eq!(grid.few_others.is_some(), n <= FEW_OTHERS, "floor {floor}, {n} shapes");
                assert_eq!(grid.entries() == 0, floor && n <= FEW_OTHERS);
                let brute = BruteForce::new(prims.clone());
                let mut hits = 0;
                for _ in 0..4000 {
                    let origin = point(6.0);
                    let ray = Ray::new(origin, point(0.5) - origin);
                    let (a, b) =
                        (grid.closest_hit(&ray, Interval::POSITIVE), brute.closest_hit(&ray, Interval::POSITIVE));
                    let bits =
                        |h: Option<PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits(), h.hit.point.to_array()));
                    assert_eq!(bits(a), bits(b), "floor {floor}, {n} other shapes, {ray:?}");
                    for t_max in [0.5, 3.0, f32::INFINITY] {
                        assert_eq!(grid.occluded(&ray, t_max), brute.occluded(&ray, t_max));
                    }
                    hits += a.is_some_and(|h| h.primitive >= triangles as u32) as usize;
                }
                assert!(hits > 200, "the rays meet the other shapes ({hits} hits of {n} shapes)");
            }
        }
    }

    /// Rays leaving a floor upwards, or passing above it upwards, are ruled out; rays towards it are not.
    #[test]
    fn behind_rules_out_rays_leaving_a_floor() {
        let floor = DirectTriangle::new(
            Triangle::new(Vec3A::new(-5.0, -1.0, -5.0), Vec3A::new(5.0, -1.0, 5.0), Vec3A::new(-5.0, -1.0, 5.0)),
            0,
        );
        let up = Vec3A::new(0.3, 0.8, -0.1);
        assert!(floor.behind(&Ray::new(Vec3A::new(0.5, (-1.0f32).next_up(), 0.5), up)));
        assert!(floor.behind(&Ray::new(Vec3A::new(0.5, 2.0, 0.5), up)));
        assert!(!floor.behind(&Ray::new(Vec3A::new(0.5, 2.0, 0.5), -up)));
        // On the plane, or parallel to it: not ruled out.
        assert!(!floor.behind(&Ray::new(Vec3A::new(0.5, -1.0, 0.5), up)));
        assert!(!floor.behind(&Ray::new(Vec3A::new(0.5, 2.0, 0.5), Vec3A::X)));
    }
}
