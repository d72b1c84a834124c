//! A uniform grid with 3D-DDA traversal (Amanatides and Woo) and per-ray mailboxing.

use raylume_geometry::{Aabb, Interval, Ray, Vec3A};
use raylume_intersect::Intersect;

use crate::{AccelStats, Accelerator, PrimitiveHit, Tally};

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
/// Mailbox slots per ray (direct-mapped by primitive index).
const MAILBOX: usize = 32;

/// A uniform grid over bounded primitives; unbounded ones (planes) are tested directly by every ray.
///
/// The course's mailbox (a ray id stored in each primitive) is not safe when several threads trace
/// at once. raylume's mailbox lives in the ray's traversal instead: a small direct-mapped table of the
/// last primitives tested, on the stack, so it needs no lock and no shared state. A primitive evicted
/// from it may be tested twice, which costs time but never changes the answer.
#[derive(Clone, Debug)]
pub struct Grid<P> {
    prims: Vec<P>,
    unbounded: Vec<u32>,
    bounds: Aabb,
    cells: [usize; 3],
    /// The lattice in f64: its corner, cell size and the size's reciprocal. Cells are entered and walked
    /// in f64, where neither the walk nor a far ray origin loses the cell a hit is in.
    corner: [f64; 3],
    cell_size: [f64; 3],
    inv_cell_size: [f64; 3],
    /// `cell_start[c]..cell_start[c + 1]` indexes `items` for cell `c`.
    cell_start: Vec<u32>,
    items: Vec<u32>,
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
    (((x - corner[a]) * inv[a]).max(0.0) as usize).min(cells[a] - 1)
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
        let mut bounds = Aabb::EMPTY;
        let mut unbounded = Vec::new();
        let mut prim_bounds = Vec::with_capacity(prims.len());
        for (i, p) in prims.iter().enumerate() {
            let b = p.bounds_over(shutter);
            if b.is_finite() {
                bounds = bounds.union(b);
            } else {
                unbounded.push(i as u32);
            }
            prim_bounds.push(b);
        }
        let bounded = prims.len() - unbounded.len();
        if bounds.is_empty() {
            bounds = Aabb::from_point(Vec3A::ZERO);
        }
        // Pad degenerate extents so every axis has a positive size.
        let extent = bounds.diagonal();
        let pad = Vec3A::splat(extent.max_element().max(1e-6) * 1e-3);
        let flat = extent.cmple(pad);
        bounds = Aabb::new(
            Vec3A::select(flat, bounds.min - pad, bounds.min),
            Vec3A::select(flat, bounds.max + pad, bounds.max),
        );
        let extent = bounds.diagonal();
        let volume = extent.x * extent.y * extent.z;
        let mut per_unit = (params.k.clamp(1e-3, 1e6) * bounded.max(1) as f32 / volume).cbrt();
        let budget =
            (bounded as u64).saturating_mul(ENTRIES_PER_PRIMITIVE).max(MIN_ENTRY_BUDGET).min(u32::MAX as u64 / 2);
        let cells = loop {
            let cells = [0, 1, 2].map(|a| ((extent[a] * per_unit).round() as usize).clamp(1, MAX_CELLS_PER_AXIS));
            let n_cells = cells.iter().map(|&c| c as u64).product::<u64>();
            if cells == [1, 1, 1] || (n_cells <= MAX_CELLS && entries(&prim_bounds, bounds, cells) <= budget) {
                break cells;
            }
            per_unit *= 0.8;
        };
        let [corner, cell_size, inv_cell_size] = lattice(bounds, cells);
        let mut grid = Self {
            prims,
            unbounded,
            bounds,
            cells,
            corner,
            cell_size,
            inv_cell_size,
            cell_start: Vec::new(),
            items: Vec::new(),
            mailbox: params.mailbox,
        };
        // Two passes: count the entries of each cell, then fill them (compressed rows).
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
        grid.cell_start = start;
        grid.items = items;
        grid
    }

    /// The number of cell entries, the length of its primitive lists.
    pub fn entries(&self) -> usize {
        self.items.len()
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

    /// Walks the cells the ray crosses within `[t_min, t_max]`, nearest first, calling `visit` with
    /// each cell's primitives and the ray parameter where the ray leaves the cell (rounded down, so
    /// that a hit beyond it is beyond the cell); `visit` returns false to stop. In f64: the cells are
    /// those the ray's exact line crosses, wherever its origin is.
    #[inline]
    fn walk(&self, ray: &Ray, t_min: f32, t_max: f32, mut visit: impl FnMut(&[u32], f32) -> bool) {
        let (o, d) = (ray.origin.to_array().map(f64::from), ray.dir.to_array().map(f64::from));
        let (mut t0, mut t1) = (t_min as f64, t_max as f64);
        for a in 0..3 {
            let (lo, hi) = (self.bounds.min[a] as f64, self.bounds.max[a] as f64);
            if d[a] == 0.0 {
                if o[a] < lo || o[a] > hi {
                    return;
                }
                continue;
            }
            let (ta, tb) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return;
        }
        let (corner, size, inv) = (&self.corner, &self.cell_size, &self.inv_cell_size);
        let mut cell = [0, 1, 2].map(|a| coord(o[a] + d[a] * t0, a, corner, inv, &self.cells));
        let mut next = [f64::INFINITY; 3];
        let mut delta = [f64::INFINITY; 3];
        let mut step = [0isize; 3];
        for a in 0..3 {
            // A zero component (0 or -0) never steps on that axis.
            if d[a] > 0.0 {
                step[a] = 1;
                next[a] = (corner[a] + (cell[a] + 1) as f64 * size[a] - o[a]) / d[a];
                delta[a] = size[a] / d[a];
            } else if d[a] < 0.0 {
                step[a] = -1;
                next[a] = (corner[a] + cell[a] as f64 * size[a] - o[a]) / d[a];
                delta[a] = -size[a] / d[a];
            }
        }
        loop {
            let axis = if next[0] < next[1] {
                if next[0] < next[2] { 0 } else { 2 }
            } else if next[1] < next[2] {
                1
            } else {
                2
            };
            let exit = next[axis].min(t1);
            let exit32 = exit as f32;
            let exit32 = if exit32 as f64 > exit { exit32.next_down() } else { exit32 };
            let c = self.cell_index(cell);
            let items = &self.items[self.cell_start[c] as usize..self.cell_start[c + 1] as usize];
            if !visit(items, exit32) || next[axis] > t1 {
                return;
            }
            let moved = cell[axis] as isize + step[axis];
            if moved < 0 || moved >= self.cells[axis] as isize {
                return;
            }
            cell[axis] = moved as usize;
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

impl<P: Intersect> Grid<P> {
    /// [`Accelerator::closest_hit_tally`] of a canonical ray.
    #[inline(always)]
    fn closest_canonical<T: Tally>(&self, ray: &Ray, mut t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        let mut best = None;
        for &i in &self.unbounded {
            tally.tested();
            if let Some(hit) = self.prims[i as usize].intersect_canonical(ray, t_range) {
                t_range = t_range.with_max(hit.t);
                best = PrimitiveHit::closer(best, PrimitiveHit { hit, primitive: i });
            }
        }
        let mut mailbox = Mailbox::new(self.mailbox);
        self.walk(ray, t_range.min, t_range.max, |items, exit| {
            tally.visited();
            for &i in items {
                if mailbox.first_visit(i) {
                    tally.tested();
                    if let Some(hit) = self.prims[i as usize].intersect_canonical(ray, t_range) {
                        t_range = t_range.with_max(hit.t);
                        best = PrimitiveHit::closer(best, PrimitiveHit { hit, primitive: i });
                    }
                }
            }
            // A hit beyond this cell may still be beaten by a primitive of a later cell.
            t_range.max > exit
        });
        best
    }

    /// [`Accelerator::occluded_tally`] of a canonical ray.
    #[inline(always)]
    fn occluded_canonical<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        for &i in &self.unbounded {
            tally.tested();
            if self.prims[i as usize].occluded_canonical(ray, t_max) {
                return true;
            }
        }
        let mut mailbox = Mailbox::new(self.mailbox);
        let mut hit = false;
        self.walk(ray, 0.0, t_max, |items, _| {
            tally.visited();
            for &i in items {
                if mailbox.first_visit(i) {
                    tally.tested();
                    if self.prims[i as usize].occluded_canonical(ray, t_max) {
                        hit = true;
                        return false;
                    }
                }
            }
            true
        });
        hit
    }
}

impl<P: Intersect + Sync + Send> Accelerator for Grid<P> {
    fn closest_hit_tally<T: Tally>(&self, ray: &Ray, t_range: Interval, tally: &mut T) -> Option<PrimitiveHit> {
        crate::closest_on_canonical(ray, t_range, |ray, t_range| self.closest_canonical(ray, t_range, tally))
    }

    fn occluded_tally<T: Tally>(&self, ray: &Ray, t_max: f32, tally: &mut T) -> bool {
        crate::occluded_on_canonical(ray, t_max, |ray, t_max| self.occluded_canonical(ray, t_max, tally))
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn stats(&self) -> AccelStats {
        let bytes = std::mem::size_of_val(self.prims.as_slice())
            + std::mem::size_of_val(self.cell_start.as_slice())
            + std::mem::size_of_val(self.items.as_slice())
            + std::mem::size_of_val(self.unbounded.as_slice());
        AccelStats { nodes: self.cells.iter().product(), bytes, primitives: self.prims.len() }
    }
}
