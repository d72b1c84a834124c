//! Triangles laid out for the watertight test, coordinate by coordinate: the BVH's leaves of up to
//! eight and the grid's packets of four. One ray finds, for four triangles at once (or eight, in AVX
//! registers), those whose edge functions do not rule it out; [`watertight_decide`] then decides those
//! few exactly as the scalar test does.
//!
//! [`watertight_decide`]: raylume_intersect::watertight_decide

use glam::Vec4;
use raylume_geometry::{Triangle, Vec3A, gamma};
use raylume_intersect::ShearedRay;

/// Triangles per packet.
pub(crate) const LANES: usize = 4;
/// The id of an unused lane.
pub(super) const NO_ID: u32 = u32::MAX;

/// Up to four triangles, coordinate by coordinate: `v[vertex][axis][lane]`, and their input indices.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct Packet {
    pub v: [[[f32; LANES]; 3]; 3],
    id: [u32; LANES],
}

const _: () = assert!(std::mem::size_of::<Packet>() == 160);

impl Packet {
    /// A packet of the first four of `tris` with their ids; unused lanes hold zeros and no id (the
    /// candidate mask leaves them out).
    pub fn new(tris: impl IntoIterator<Item = (Triangle, u32)>) -> Self {
        let mut p = Self { v: [[[0.0; LANES]; 3]; 3], id: [NO_ID; LANES] };
        for (lane, (t, id)) in tris.into_iter().take(LANES).enumerate() {
            for (k, vertex) in t.p.iter().enumerate() {
                for a in 0..3 {
                    p.v[k][a][lane] = vertex[a];
                }
            }
            p.id[lane] = id;
        }
        p
    }

    /// The triangle in `lane`, with the very coordinates it was built from.
    #[inline]
    pub fn triangle(&self, lane: u32) -> Triangle {
        let l = lane as usize;
        let vertex = |k: usize| Vec3A::new(self.v[k][0][l], self.v[k][1][l], self.v[k][2][l]);
        Triangle::new(vertex(0), vertex(1), vertex(2))
    }

    /// The input index of the triangle in `lane`.
    #[inline]
    pub fn id(&self, lane: u32) -> u32 {
        self.id[lane as usize]
    }

    /// The mask of the lanes that hold a triangle, without branches.
    #[inline(always)]
    pub fn used(&self) -> u32 {
        (0..LANES).fold(0, |mask, lane| mask | ((self.id[lane] != NO_ID) as u32) << lane)
    }
}

/// Triangles per leaf at most.
pub(super) const LEAF_LANES: usize = 2 * LANES;

/// The triangles of one leaf: up to eight, coordinate by coordinate (`v[vertex][axis][lane]`), so that
/// a coordinate of all eight is one 32-byte row (the four-lane filter takes each half in turn), and
/// their input indices; aligned to a cache line so that a leaf spans five lines wherever the allocator
/// puts them. Unused lanes hold zeros and no id.
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(64))]
pub(super) struct Leaf {
    pub v: [[[f32; LEAF_LANES]; 3]; 3],
    id: [u32; LEAF_LANES],
}

const _: () = assert!(std::mem::size_of::<Leaf>() == 320);

impl Leaf {
    /// The leaf of `tris` (at most eight) with their ids.
    pub fn new(tris: impl IntoIterator<Item = (Triangle, u32)>) -> Self {
        let mut leaf = Self { v: [[[0.0; LEAF_LANES]; 3]; 3], id: [NO_ID; LEAF_LANES] };
        let mut tris = tris.into_iter();
        for (lane, (t, id)) in tris.by_ref().take(LEAF_LANES).enumerate() {
            for (k, vertex) in t.p.iter().enumerate() {
                for a in 0..3 {
                    leaf.v[k][a][lane] = vertex[a];
                }
            }
            leaf.id[lane] = id;
        }
        debug_assert!(tris.next().is_none(), "a leaf holds at most eight triangles");
        leaf
    }

    /// The triangle of candidate bit `bit` ([`Filter::leaf_candidates`](super::leaf::Filter::leaf_candidates)),
    /// with the very coordinates it was built from.
    #[inline]
    pub fn triangle(&self, bit: u32) -> Triangle {
        let l = bit as usize % LEAF_LANES;
        let vertex = |k: usize| Vec3A::new(self.v[k][0][l], self.v[k][1][l], self.v[k][2][l]);
        Triangle::new(vertex(0), vertex(1), vertex(2))
    }

    /// The input index of the triangle of candidate bit `bit`.
    #[inline]
    pub fn id(&self, bit: u32) -> u32 {
        self.id[bit as usize % LEAF_LANES]
    }

    /// Number of triangles held.
    pub fn len(&self) -> usize {
        self.id.iter().filter(|&&id| id != NO_ID).count()
    }

    /// Coordinate `axis` of vertex `k` of the four lanes of half `half` (0 or 1).
    #[inline(always)]
    pub fn quarter(&self, k: usize, axis: usize, half: usize) -> [f32; LANES] {
        let halves: [[f32; LANES]; 2] = pulp::cast(self.v[k][axis]);
        halves[half]
    }
}

/// The mask of the first `count` lanes that the watertight test may accept: it rejects a triangle
/// only when two of its edge functions have opposite signs beyond their rounding error
/// ([`edge_error`](raylume_intersect::edge_error)), computed with the very operations of
/// [`ShearedRay::transform`] and `watertight_decide`, so a lane left out here is one the exact
/// decision rejects too.
#[inline(always)]
pub(crate) fn candidates(p: &Packet, ray: &ShearedRay, count: usize) -> u32 {
    candidates_of(|k, a| p.v[k][a], ray, count)
}

/// [`candidates`] of the four triangles whose coordinate `a` of vertex `k` is `v(k, a)`, lane by lane.
#[inline(always)]
pub(crate) fn candidates_of(v: impl Fn(usize, usize) -> [f32; LANES], ray: &ShearedRay, count: usize) -> u32 {
    let [kx, ky, kz] = ray.axes.map(|k| k.min(2));
    let [sx, sy, _] = ray.shear.map(Vec4::splat);
    let o = ray.origin.to_array();
    let (ox, oy, oz) = (Vec4::splat(o[kx]), Vec4::splat(o[ky]), Vec4::splat(o[kz]));
    let sheared = |k: usize| {
        let az = Vec4::from_array(v(k, kz)) - oz;
        ((Vec4::from_array(v(k, kx)) - ox) - sx * az, (Vec4::from_array(v(k, ky)) - oy) - sy * az)
    };
    let ((ax, ay), (bx, by), (cx, cy)) = (sheared(0), sheared(1), sheared(2));
    // Each edge function with its error bound (the scalar `edge_error`, lane by lane).
    let edge = |p: Vec4, q: Vec4, r: Vec4, s: Vec4| {
        let (pq, rs) = (p * q, r * s);
        (pq - rs, (pq.abs() + rs.abs()) * Vec4::splat(gamma(3)) + Vec4::splat(f32::MIN_POSITIVE))
    };
    let ((u, eu), (v, ev), (w, ew)) = (edge(cx, by, cy, bx), edge(ax, cy, ay, cx), edge(bx, ay, by, ax));
    let negative = u.cmplt(-eu) | v.cmplt(-ev) | w.cmplt(-ew);
    let positive = u.cmpgt(eu) | v.cmpgt(ev) | w.cmpgt(ew);
    let rejected = (negative & positive).bitmask();
    !rejected & ((1 << count) - 1)
}

#[cfg(test)]
pub(crate) mod tests {
    use proptest::prelude::*;
    use raylume_geometry::{Interval, Ray};
    use raylume_intersect::watertight_decide;

    use super::*;

    /// Points with small integer coordinates (shared vertices, axis-parallel edges, exact zeros) or any.
    pub fn arb_point() -> impl Strategy<Value = Vec3A> {
        // Small integers make shared vertices, axis-parallel edges and exact zeros common.
        prop_oneof![
            prop::array::uniform3(-3i8..=3).prop_map(|a| Vec3A::new(a[0] as f32, a[1] as f32, a[2] as f32)),
            prop::array::uniform3(-10.0f32..10.0).prop_map(Vec3A::from_array),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        /// The packet filter never leaves out a triangle the scalar watertight test accepts.
        #[test]
        fn candidates_keep_every_hit(
            verts in prop::collection::vec(prop::array::uniform3(arb_point()), 1..=LANES),
            o in arb_point(),
            target in arb_point(),
            on_edge in prop::option::of((0usize..3, prop_oneof![Just(0.0f32), 0.0f32..1.0])),
        ) {
            // Half the rays aim at a vertex or a point of an edge of the first triangle, where edge
            // functions round to zero or to either sign.
            let target = match on_edge {
                Some((e, s)) => verts[0][e] + (verts[0][(e + 1) % 3] - verts[0][e]) * s,
                None => target,
            };
            let dir = target - o;
            prop_assume!(dir != Vec3A::ZERO);
            let ray = Ray::new(o, dir);
            let Some(sheared) = ShearedRay::new(&ray) else { return Ok(()) };
            let tris: Vec<(Triangle, u32)> =
                verts.iter().enumerate().map(|(i, v)| (Triangle::new(v[0], v[1], v[2]), i as u32)).collect();
            let packet = Packet::new(tris.iter().copied());
            let mask = candidates(&packet, &sheared, tris.len());
            for (lane, (t, id)) in tris.iter().enumerate() {
                prop_assert_eq!(packet.triangle(lane as u32), *t);
                prop_assert_eq!(packet.id(lane as u32), *id);
                let accepted = watertight_decide(t, &sheared, Interval::new(f32::MIN, f32::MAX)).is_some();
                prop_assert!(!accepted || mask & (1 << lane) != 0, "lane {} left out", lane);
            }
            prop_assert_eq!(mask >> tris.len(), 0);
        }

        /// A leaf keeps each triangle's very coordinates and id in its lane, and its halves are the
        /// packets of its first and last four triangles: the four-lane filter gives each half the
        /// candidates it gives that packet.
        #[test]
        fn leaf_halves_are_packets(
            verts in prop::collection::vec(prop::array::uniform3(arb_point()), 1..=LEAF_LANES),
            o in arb_point(),
            target in arb_point(),
        ) {
            let dir = target - o;
            prop_assume!(dir != Vec3A::ZERO);
            let Some(sheared) = ShearedRay::new(&Ray::new(o, dir)) else { return Ok(()) };
            let tris: Vec<(Triangle, u32)> =
                verts.iter().enumerate().map(|(i, v)| (Triangle::new(v[0], v[1], v[2]), 7 * i as u32 + 3)).collect();
            let leaf = Leaf::new(tris.iter().copied());
            prop_assert_eq!(leaf.len(), tris.len());
            for (bit, (t, id)) in tris.iter().enumerate() {
                prop_assert_eq!(leaf.triangle(bit as u32), *t);
                prop_assert_eq!(leaf.id(bit as u32), *id);
            }
            for (half, chunk) in tris.chunks(LANES).enumerate() {
                let packet = Packet::new(chunk.iter().copied());
                prop_assert_eq!(
                    candidates_of(|k, a| leaf.quarter(k, a, half), &sheared, chunk.len()),
                    candidates(&packet, &sheared, chunk.len())
                );
            }
        }
    }
}
