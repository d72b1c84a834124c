//! The stiff and extreme cases of raylume's intersection layer, in one table ([`CASES`]) shared by
//! `tests/stiff.rs`, which asserts each case's criterion, and `examples/robustness.rs`, which prints
//! each case's figures beside those of a naive routine.
//!
//! Ids are those of `../shared/robustness-cases.md` (T triangles, R spawning, S spheres, PL planes,
//! B boxes, X and G accelerators); O1–O5 are raylume's own cases. Each case builds its rays from its
//! own fixed seed, measures raylume on them and checks its criterion; where a textbook routine is
//! kept for comparison, it measures that routine on the same rays. Run in release mode.
//!
//! The naive routines are the textbook ones: Möller–Trumbore with `|det| < 1e-6` (and without any
//! determinant guard), the quadratic `b^2 - 4ac` for spheres, a slab test with `f32::min`/`max`, a
//! plane test with `t < tmin || t > tmax`, a fixed `p + 1e-4 n` spawn offset, and a box normal from
//! `(p - c) / half` with an epsilon.

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume::accel::{BvhBuild, BvhKernel, Grid, GridParams};
use raylume::geometry::{AaBox, Aabb, Plane, Sphere, Triangle, offset_ray_origin, spawn_ray_to};
use raylume::intersect::{intersect_moller_trumbore, intersect_watertight};
use raylume::prelude::*;
use raylume::scene::procedural::icosphere;

/// One case: the rays it builds, what it measures on them, and when it passes.
pub struct Case {
    /// The id in `../shared/robustness-cases.md` (O1–O5: raylume's own cases).
    pub id: &'static str,
    /// What the case is about.
    pub title: &'static str,
    /// The scene and the rays it builds.
    pub setup: &'static str,
    /// The pass criterion, which `run` checks.
    pub criterion: &'static str,
    /// Builds the rays, measures raylume (and the naive routine) on them, and checks the criterion.
    pub run: fn() -> Outcome,
}

/// What a case measured.
pub struct Outcome {
    /// raylume's figures.
    pub figure: String,
    /// The naive routine's figures on the same rays, for the cases that keep one.
    pub naive: Option<String>,
    /// The parts of the criterion that do not hold; empty when the case passes.
    pub failures: Vec<String>,
}

/// Every case, in the order of `../shared/robustness-cases.md`, raylume's own last.
pub const CASES: &[Case] = &[
    Case {
        id: "T1",
        title: "watertight closed icosphere",
        setup: "10^6 rays from inside a closed level-3 icosphere (642 vertices, 1280 triangles), 250 000 each at random \
                directions, vertices, edge points and edge midpoints; BVH in both kernels, brute force on 1 in 25",
        criterion: "0 leaks; triangles hit by one ray agree on t within 8 u·t; Möller–Trumbore leaks (the test sees leaks)",
        run: t1_watertight_closed_icosphere,
    },
    Case {
        id: "T4",
        title: "tiny and needle triangles",
        setup: "100 000 rotated right triangles of side 1e-5..1e2 at distance 1e-2..1e3 (s/L >= 1e-5), rays through \
                the centroid and 1e-3 of s beyond the hypotenuse; 100 000 needles of length 1..1e4, width/length \
                1e-6..1e-1",
        criterion: "hit/miss as the f64 reference, t within 8 u·t, never NaN or t <= 0; every needle hit",
        run: t4_tiny_and_needle_triangles,
    },
    Case {
        id: "T6",
        title: "degenerate and near-degenerate triangles",
        setup: "collinear, two-equal-vertex and three-equal-vertex triangles under 4 rays; 10^6 triangles whose third \
                vertex is 1e-12..1e-3 of the edge off it, rays aimed at the edge",
        criterion: "no hit on exact degenerates; every hit has finite t > 0, point, unit normal and uv, barycentrics in \
                    [-4u, 1+4u]",
        run: t6_degenerate_triangles_are_nan_free,
    },
    Case {
        id: "T7",
        title: "grazing and parallel rays",
        setup: "slope m = 1e-2..1e-8 onto the unit right triangle and the plane z = 0 (exact t = 0.5); parallel and \
                in-plane rays",
        criterion: "|t - 0.5| <= 1e-6 for m >= 1e-4, a hit within 5e-4 or a miss below; parallel and in-plane rays miss",
        run: t7_grazing_and_parallel_rays,
    },
    Case {
        id: "T8",
        title: "vertex-order invariance",
        setup: "250 000 rays at points on and within 2 ulps of the edges of triangles of size 1e-3..1e3 shifted up to \
                1e5, four vertex orders",
        criterion: "hit/miss identical for all orders; t within 2 ulps",
        run: t8_vertex_order_invariance,
    },
    Case {
        id: "R1",
        title: "self-intersection",
        setup: "triangles of size 1e-3..1e5 shifted by 0..1e5, hit from 10 S away; 1000 rays spawned from each hit \
                (up to 300 000 per size and shift)",
        criterion: "0 re-hits; the spawn offset within 512 ulp(max |p|) + 2^-15",
        run: r1_spawned_rays_never_rehit_their_surface,
    },
    Case {
        id: "R4",
        title: "shadow rays between two surfaces",
        setup: "facing triangles h = 1e-3..1e3 apart, shifted by 0 or 1e4; 10 000 shadow rays per pair between hit \
                points (spawn_ray_to), with and without an occluder half way",
        criterion: "no false occlusion where h >= 16 ulps of the coordinates; the occluder found where h >= 4096 ulps",
        run: r4_shadow_rays_between_surfaces,
    },
    Case {
        id: "R5",
        title: "hit-point error bound",
        setup: "10^6 rays at triangles and spheres of size 1e-3..1e3 shifted up to 1e5",
        criterion: "the f64 surface passes through point ± error; error <= 12 u·reach",
        run: r5_hit_point_error_bound_is_valid,
    },
    Case {
        id: "S1",
        title: "small sphere far away",
        setup: "100 000 rays per distance D = 1..1000 into 1.05 r of a sphere of radius 1e-3, unit and long directions",
        criterion: "hit/miss as the f64 reference outside a 16 u·D band; t within 16 u·t",
        run: s1_small_sphere_far_away,
    },
    Case {
        id: "S2",
        title: "large sphere, origin near its surface",
        setup: "20 000 rays per radius 1e2..1e6 and height 1e-2..1e2 above the surface, aimed within 3 h laterally",
        criterion: "t within 8 u·(|o-c|+r) of f64 for incidence cos >= 0.1 and h >= 8 u·(|o|+r); never NaN or t < 0",
        run: s2_large_sphere_origin_near_surface,
    },
    Case {
        id: "S3",
        title: "origin inside a huge sphere",
        setup: "10 000 random directions from the centre, 0.5 r and 0.999 r of a sphere of radius 1e5, and from the \
                centre of a unit sphere",
        criterion: "every ray finds the exit, back-facing, t within 8 u·(|o-c|+r) of f64",
        run: s3_origin_inside_a_huge_sphere,
    },
    Case {
        id: "S4",
        title: "tangent and silhouette rays",
        setup: "21x21 grids of parallel rays over spheres of radius 1 and 3 under random rotations and shifts up to \
                1e3, plus tangent rays and offsets r(1 ± 2^-k), k = 10..24; 40 spheres",
        criterion: "hit iff inside the disc outside a band of 8 u·r²·max(1, |c|/r); no NaN",
        run: s4_tangent_and_silhouette_rays,
    },
    Case {
        id: "PL1",
        title: "plane: near-parallel and in-plane rays",
        setup: "10^6 rays at heights ±1e-6..1e3 above a plane with slopes 0, -0, subnormal and 1e-30..1",
        criterion: "no hit with NaN or infinite t or point; parallel and in-plane rays miss",
        run: pl1_plane_nan_safety,
    },
    Case {
        id: "B1",
        title: "slab: in-face rays, flat and point boxes",
        setup: "24 rays lying in the faces of [0,1]^3 (±0 and ±subnormal components), a ray along an edge, through a \
                corner, into a flat box and a point box; a box primitive in a BVH hit along its edge",
        criterion: "every ray hits the node test; the BVH finds the box",
        run: b1_slab_in_face_rays,
    },
    Case {
        id: "B2",
        title: "conservative far traversal",
        setup: "10^6 rays at f32 points on faces of boxes of size 1e-4..1 at distance 1e2..1e5",
        criterion: "0 false misses of the node test",
        run: b2_conservative_far_traversal,
    },
    Case {
        id: "B3",
        title: "box primitive: edges, corners, inside",
        setup: "100 000 boxes of half-size 1e-3..1e3 centred up to 1e5 away; rays at edge points and corners from \
                outside, and from inside",
        criterion: "t >= 0, an axis-aligned unit normal facing the ray (outward from inside); the exit found from inside",
        run: b3_box_edges_corners_inside,
    },
    Case {
        id: "B4",
        title: "±0 direction components",
        setup: "50 scenes of 200 spheres, triangles and boxes (and a plane); 2000 rays each with one or two zero \
                direction components, as +0 and as -0",
        criterion: "brute force, BVH and grid give bit-identical answers for +0 and -0, and agree",
        run: b4_signed_zero_invariance,
    },
    Case {
        id: "X1",
        title: "accelerators on adversarial scenes",
        setup: "200 scenes of 1..400 primitives (log-uniform sizes, clusters, duplicates, flat triangles, lattice \
                centres, infinite planes); 50 rays each, from outside, lattice points, the max corner and inside",
        criterion: "BVH (both kernels), midpoint BVH and grid give brute force's closest t bit for bit and its occlusion",
        run: x1_accelerators_on_adversarial_scenes,
    },
    Case {
        id: "G3",
        title: "grid: lattice vertices and edges, max-face starts",
        setup: "spheres of radius 0.05 on the diagonal and an edge line of a 64-per-axis lattice, at scales 1 and 312.5; \
                rays along the diagonal and the edge line, from outside and from the max face, and along an axis",
        criterion: "closest hit and occlusion as brute force",
        run: g3_grid_lattice_rays,
    },
    Case {
        id: "X2",
        title: "NaN, infinite and zero-length rays",
        setup: "10 000 rays with NaN or infinite origin or direction components, or no direction, at 10 000 triangles",
        criterion: "no hit from BVH, grid or brute force",
        run: x2_invalid_rays,
    },
    Case {
        id: "O1",
        title: "images are scale-invariant",
        setup: "a lit sphere, triangle and floor at 64x48, camera, lights and geometry scaled by 1e-4..1e6",
        criterion: "at most 4 pixels differ from scale 1 by more than 0.02",
        run: o1_images_are_scale_invariant,
    },
    Case {
        id: "O2",
        title: "tiny and huge triangles",
        setup: "10 000 triangles per side 1e-6..1e6, rays at the centroid from 5 sides away",
        criterion: "every ray hits, t within 1e-4 relative",
        run: o2_tiny_and_huge_triangles,
    },
    Case {
        id: "O3",
        title: "moving spheres at the shutter ends",
        setup: "300 moving spheres; a ray at each at times 0, 0.5 and 1",
        criterion: "BVH and grid give brute force's t; all 900 rays hit",
        run: o3_moving_spheres_at_shutter_ends,
    },
    Case {
        id: "O4",
        title: "scene far from the origin",
        setup: "a lit sphere on a floor at 64x48, rendered at the origin and shifted by 1e3..1e5",
        criterion: "no lit pixel away from edges darkens to half its value at the origin",
        run: o4_scene_far_from_the_origin,
    },
    Case {
        id: "O5",
        title: "spheres and boxes never re-hit themselves",
        setup: "200 spheres and boxes per scale 1e-4..1e6, hit from 10 sizes away; 1000 rays spawned from each hit",
        criterion: "0 re-hits",
        run: o5_spheres_and_boxes_never_rehit_themselves,
    },
    Case {
        id: "O6",
        title: "nearly coincident spheres",
        setup: "40 spheres of radius 1 whose centres and radii step by 1e-7..1e-5 (the SPD shells scene's spiral), \
                seen from 60 away at 64x48, beside the largest alone",
        criterion: "no lit pixel away from edges is darker than half the lone sphere's",
        run: o6_nearly_coincident_spheres,
    },
];

/// f32's unit roundoff, 2^-24.
const U: f64 = 1.0 / (1u64 << 24) as f64;

/// The failures a case finds, the first few with their details.
#[derive(Default)]
struct Checks {
    failures: Vec<String>,
    more: usize,
}

impl Checks {
    /// Records a failure, described by `what`, unless `ok`.
    fn check(&mut self, ok: bool, what: impl FnOnce() -> String) {
        if ok {
            return;
        }
        if self.failures.len() < 8 {
            self.failures.push(what());
        } else {
            self.more += 1;
        }
    }

    fn outcome(self, figure: String, naive: Option<String>) -> Outcome {
        let mut failures = self.failures;
        if self.more > 0 {
            failures.push(format!("and {} more", self.more));
        }
        Outcome { figure, naive, failures }
    }
}

fn rng(seed: u64) -> Pcg32 {
    Pcg32::new(seed, 0xda3e_39cb_94b9_5bdb)
}

fn unif(r: &mut Pcg32) -> f32 {
    (r.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn unit_vector(r: &mut Pcg32) -> Vec3A {
    let (a, b) = (unif(r), unif(r));
    raylume::geometry::sampling::uniform_sphere(Vec2::new(a, b))
}

/// A uniformly random rotation (from a random unit quaternion).
fn rotation(r: &mut Pcg32) -> glam::Mat3A {
    let q = glam::Quat::from_xyzw(unif(r) - 0.5, unif(r) - 0.5, unif(r) - 0.5, unif(r) - 0.5).normalize();
    glam::Mat3A::from_quat(q)
}

fn t1_watertight_closed_icosphere() -> Outcome {
    let mut c = Checks::default();
    let (v, f) = icosphere(3);
    c.check((v.len(), f.len()) == (642, 1280), || format!("icosphere(3) has {} vertices, {} faces", v.len(), f.len()));
    let tris: Vec<Triangle> =
        f.iter().map(|t| Triangle::new(v[t[0] as usize], v[t[1] as usize], v[t[2] as usize])).collect();
    let prims: Vec<Primitive> = tris.iter().map(|t| Primitive::Triangle(*t)).collect();
    let bvh = Bvh::new(prims.clone(), Interval::new(0.0, 0.0));
    // Both kernels: the eight-wide one where the CPU has AVX2, and the portable one.
    let portable = Bvh::with_kernel(prims, Interval::new(0.0, 0.0), BvhBuild::Sah, BvhKernel::Portable);
    // Edges for the edge-aimed rays.
    let edges: Vec<(u32, u32)> = f.iter().flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]).collect();
    let mut r = rng(1);
    let per_kind = 250_000;
    let (mut leaks, mut mt_leaks, mut naive_leaks, mut worst_spread) = ([0usize; 4], [0usize; 4], [0usize; 4], 0.0f64);
    for kind in 0..4 {
        for i in 0..per_kind {
            let o = unit_vector(&mut r) * (0.5 * unif(&mut r).cbrt());
            let target = match kind {
                0 => o + unit_vector(&mut r),
                1 => v[(r.next_u32() as usize) % v.len()],
                _ => {
                    let (a, b) = edges[(r.next_u32() as usize) % edges.len()];
                    let s = if kind == 2 { unif(&mut r) } else { 0.5 };
                    v[a as usize] + (v[b as usize] - v[a as usize]) * s
                }
            };
            let ray = Ray::new(o, (target - o).normalize());
            if bvh.closest_hit(&ray, Interval::POSITIVE).is_none() {
                leaks[kind] += 1;
            }
            if i % 5 == 0 && portable.closest_hit(&ray, Interval::POSITIVE).is_none() {
                leaks[kind] += 1;
            }
            // Brute force on a subset: every triangle reporting a hit agrees on t, and Möller–Trumbore's leaks.
            if i % 25 == 0 {
                let ts: Vec<f64> = tris
                    .iter()
                    .filter_map(|t| intersect_watertight(t, &ray, Interval::POSITIVE))
                    .map(|h| h.t as f64)
                    .collect();
                if ts.len() > 1 {
                    let (lo, hi) = ts.iter().fold((f64::MAX, f64::MIN), |(a, b), &t| (a.min(t), b.max(t)));
                    worst_spread = worst_spread.max((hi - lo) / (U * hi));
                }
                if !tris.iter().any(|t| intersect_moller_trumbore(t, &ray, Interval::POSITIVE).is_some()) {
                    mt_leaks[kind] += 1;
                }
                if !tris.iter().any(|t| naive_triangle(t, &ray).is_some()) {
                    naive_leaks[kind] += 1;
                }
            }
        }
    }
    c.check(leaks == [0; 4], || format!("leaks {leaks:?}"));
    c.check(worst_spread <= 8.0, || format!("multi-hit t spread {worst_spread:.1} u·t"));
    c.check(mt_leaks[1] + mt_leaks[2] + mt_leaks[3] > 0, || {
        "Möller–Trumbore shows no leak: the rays miss the edges".into()
    });
    let figure = format!(
        "watertight leaks {leaks:?} of {per_kind} per kind (random, vertex, edge, midpoint); \
         Möller–Trumbore leaks {mt_leaks:?} of {} per kind; worst multi-hit t spread {worst_spread:.1} u·t",
        per_kind / 25
    );
    let naive = format!("|det| < 1e-6: leaks {naive_leaks:?} of {} per kind", per_kind / 25);
    c.outcome(figure, Some(naive))
}

fn t4_tiny_and_needle_triangles() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(131);
    let (mut wrong, mut total, mut worst_t, mut naive_wrong) = (0usize, 0usize, 0.0f64, 0usize);
    // Needles missed, by w/l decade (1e-6, 1e-5, ... 1e-2): the f32 t bound alone would reject the
    // thinnest; the f64 re-check decides them.
    let (mut needle_misses, mut needles, mut naive_needle_misses) = ([0usize; 5], [0usize; 5], [0usize; 5]);
    for i in 0..200_000 {
        let rot = rotation(&mut r);
        if i % 2 == 0 {
            let s = 10f32.powf(-5.0 + 7.0 * unif(&mut r));
            let l = 10f32.powf(-2.0 + 5.0 * unif(&mut r));
            if (s / l) < 1e-5 {
                continue;
            }
            let centre = rot * Vec3A::new(0.0, 0.0, -l);
            let (e1, e2) = (rot * Vec3A::new(s, 0.0, 0.0), rot * Vec3A::new(0.0, s, 0.0));
            let tri = Triangle::new(centre, centre + e1, centre + e2);
            // The centroid; and 1e-3 of s beyond the hypotenuse, which f32 can only resolve when the
            // triangle spans many ulps of its position (s/L >= 1e-2).
            let mut targets = vec![centre + (e1 + e2) / 3.0];
            if s / l >= 1e-2 {
                targets.push(centre + (e1 + e2) * (0.5 + 1e-3));
            }
            for target in targets {
                // Classified against the f64 reference on the same f32 ray.
                let ray = Ray::new(Vec3A::ZERO, target.normalize());
                let Some((t_ref, margin)) = reference_triangle_hit(&tri, &ray) else { continue };
                if margin.abs() < 1e-9 {
                    continue;
                }
                total += 1;
                let hit = tri.intersect(&ray, Interval::POSITIVE);
                if let Some(h) = hit {
                    c.check(h.t.is_finite() && h.t > 0.0, || format!("s={s} L={l}: t = {}", h.t));
                    let e = (h.t as f64 - t_ref).abs() / (U * t_ref);
                    worst_t = worst_t.max(e);
                }
                if hit.is_some() != (margin > 0.0) {
                    wrong += 1;
                }
                if naive_triangle(&tri, &ray).is_some() != (margin > 0.0) {
                    naive_wrong += 1;
                }
            }
        } else {
            let len = 10f32.powf(4.0 * unif(&mut r));
            let ratio = 10f32.powf(-6.0 + 5.0 * unif(&mut r));
            let w = len * ratio;
            let centre = rot * Vec3A::new(0.0, 0.0, -3.0 * len);
            let (a, b) = (rot * Vec3A::new(len, 0.0, 0.0), rot * Vec3A::new(len, w, 0.0));
            let tri = Triangle::new(centre, centre + a, centre + b);
            let ray = Ray::new(Vec3A::ZERO, (centre + (a + b) / 3.0).normalize());
            let Some((_, margin)) = reference_triangle_hit(&tri, &ray) else { continue };
            if margin < 1e-3 {
                continue;
            }
            let decade = ((ratio.log10() + 6.0) as usize).min(4);
            needles[decade] += 1;
            match tri.intersect(&ray, Interval::POSITIVE) {
                Some(h) => c.check(h.t.is_finite() && h.t > 0.0, || format!("needle l={len} w={w}: t = {}", h.t)),
                None => needle_misses[decade] += 1,
            }
            if naive_triangle(&tri, &ray).is_none() {
                naive_needle_misses[decade] += 1;
            }
        }
    }
    c.check(wrong == 0, || format!("{wrong} tiny-triangle rays misclassified"));
    c.check(worst_t <= 8.0, || format!("t error {worst_t:.1} u·t"));
    c.check(needle_misses == [0; 5], || format!("needles missed {needle_misses:?}: down to w/l = 1e-6 they are hit"));
    let figure = format!(
        "{total} rays at tiny right triangles (s/L >= 1e-5): {wrong} misclassified against f64, worst dt error \
         {worst_t:.1} u·t; needles through the centroid missed, by w/l decade 1e-6..1e-2: {needle_misses:?} of {needles:?}"
    );
    let naive = format!(
        "|det| < 1e-6: {naive_wrong} of {total} tiny-triangle rays misclassified; needles missed {naive_needle_misses:?}"
    );
    c.outcome(figure, Some(naive))
}

fn t6_degenerate_triangles_are_nan_free() -> Outcome {
    let mut c = Checks::default();
    let down = |x: f32, y: f32| Ray::new(Vec3A::new(x, y, 1.0), -Vec3A::Z);
    let degenerate = [
        Triangle::new(Vec3A::ZERO, Vec3A::ONE, Vec3A::splat(2.0)),
        Triangle::new(Vec3A::ZERO, Vec3A::ZERO, Vec3A::X),
        Triangle::new(Vec3A::ONE, Vec3A::ONE, Vec3A::ONE),
    ];
    let non_finite = |h: Option<(f32, Vec3A)>| h.is_some_and(|(t, n)| !t.is_finite() || !n.is_finite());
    let mut naive_degenerate = 0;
    for t in &degenerate {
        for ray in [
            down(0.5, 0.5),
            down(1.0, 1.0),
            down(0.0, 0.0),
            Ray::new(Vec3A::new(-1.0, -1.0, -1.0), Vec3A::ONE.normalize()),
        ] {
            c.check(intersect_watertight(t, &ray, Interval::POSITIVE).is_none(), || format!("{t:?} hit by {ray:?}"));
            c.check(intersect_moller_trumbore(t, &ray, Interval::POSITIVE).is_none(), || {
                format!("{t:?} hit by {ray:?} (Möller–Trumbore)")
            });
            naive_degenerate += non_finite(unguarded_triangle(t, &ray)) as usize;
        }
    }
    let mut r = rng(6);
    let (mut hits, mut bad, mut naive_bad) = (0, 0, 0);
    for _ in 0..1_000_000 {
        let v0 = Vec3A::new(unif(&mut r), unif(&mut r), 0.0) * 4.0;
        let v1 = v0 + unit_vector(&mut r);
        let s = unif(&mut r);
        let h = 10f32.powf(-12.0 + 9.0 * unif(&mut r)) * (v1 - v0).length();
        let perp = (v1 - v0).cross(Vec3A::Z).normalize_or_zero();
        let v2 = v0.lerp(v1, s) + perp * h;
        let aim = v0.lerp(v1, unif(&mut r));
        let o = aim + unit_vector(&mut r) * 3.0;
        let ray = Ray::new(o, (aim - o).normalize());
        let tri = Triangle::new(v0, v1, v2);
        if let Some(hit) = intersect_watertight(&tri, &ray, Interval::POSITIVE) {
            hits += 1;
            let ok = hit.t.is_finite()
                && hit.t > 0.0
                && hit.point.is_finite()
                && hit.normal.is_finite()
                && hit.uv.is_finite();
            let b = [1.0 - hit.uv.x - hit.uv.y, hit.uv.x, hit.uv.y];
            let inside = b.iter().all(|&x| x >= -4.0 * U as f32 && x <= 1.0 + 4.0 * U as f32);
            if !ok || !inside || (hit.normal.length() - 1.0).abs() > 1e-5 {
                bad += 1;
            }
        }
        naive_bad += non_finite(unguarded_triangle(&tri, &ray)) as usize;
    }
    c.check(bad == 0, || format!("{bad} hits with NaN, inf, t <= 0 or barycentrics outside [-4u, 1+4u]"));
    let figure = format!(
        "1e6 near-degenerate triangles: {hits} hits, {bad} with NaN, inf, t <= 0 or barycentrics outside [-4u, 1+4u]"
    );
    let naive = format!(
        "no determinant guard: {naive_bad} hits with a NaN or infinite t or normal; {naive_degenerate} of 12 rays at \
         exact degenerates"
    );
    c.outcome(figure, Some(naive))
}

fn t7_grazing_and_parallel_rays() -> Outcome {
    let mut c = Checks::default();
    let tri = Triangle::new(Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let plane = Plane { point: Vec3A::ZERO, normal: Vec3A::Z };
    let (mut table, mut naive) = (Vec::new(), Vec::new());
    for m in [1e-2f32, 1e-4, 1e-6, 1e-7, 1e-8] {
        let ray = Ray::new(Vec3A::new(0.0, 0.25, m / 2.0), Vec3A::new(1.0, 0.0, -m));
        for (name, hit) in [
            ("triangle", tri.intersect(&ray, Interval::POSITIVE)),
            ("plane", plane.intersect(&ray, Interval::POSITIVE)),
        ] {
            match hit {
                Some(h) => {
                    let err = (h.t - 0.5).abs();
                    let allowed = if m >= 1e-4 { 1e-6 } else { 5e-4 };
                    c.check(h.t.is_finite() && err <= allowed, || format!("{name} m={m}: t={}", h.t));
                    table.push(format!("{name} m={m:e}: t={}", h.t));
                }
                None => {
                    c.check(m < 1e-4, || format!("{name} must hit at m={m}"));
                    table.push(format!("{name} m={m:e}: miss"));
                }
            }
        }
        let shown = naive_triangle(&tri, &ray).map_or("miss".to_owned(), |t| format!("t={t}"));
        naive.push(format!("triangle m={m:e}: {shown}"));
    }
    for ray in [Ray::new(Vec3A::new(0.0, 0.25, 0.1), Vec3A::X), Ray::new(Vec3A::new(-1.0, 0.25, 0.0), Vec3A::X)] {
        c.check(tri.intersect(&ray, Interval::POSITIVE).is_none(), || format!("triangle hit by {ray:?}"));
        c.check(plane.intersect(&ray, Interval::POSITIVE).is_none(), || format!("plane hit by {ray:?}"));
    }
    c.outcome(table.join("; "), Some(format!("|det| < 1e-6: {}", naive.join("; "))))
}

fn t8_vertex_order_invariance() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(141);
    let (mut mismatches, mut worst_dt, mut naive_mismatches) = (0usize, 0u32, 0usize);
    for _ in 0..250_000 {
        let scale = 10f32.powf(-3.0 + 6.0 * unif(&mut r));
        let shift = unit_vector(&mut r) * 1e5 * unif(&mut r);
        let v = [0, 1, 2].map(|_| shift + unit_vector(&mut r) * scale);
        let (a, b) = (r.next_u32() as usize % 3, unif(&mut r));
        let mut target = v[a].lerp(v[(a + 1) % 3], b);
        let k = (r.next_u32() % 3) as usize;
        for _ in 0..(r.next_u32() % 3) {
            target[k] = if unif(&mut r) < 0.5 { target[k].next_up() } else { target[k].next_down() };
        }
        let o = target + unit_vector(&mut r) * (3.0 * scale);
        let ray = Ray::new(o, (target - o).normalize());
        let orders = [[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1]];
        let tri = |o: &[usize; 3]| Triangle::new(v[o[0]], v[o[1]], v[o[2]]);
        let hits: Vec<Option<f32>> =
            orders.iter().map(|o| intersect_watertight(&tri(o), &ray, Interval::POSITIVE).map(|h| h.t)).collect();
        if hits.iter().any(|h| h.is_some() != hits[0].is_some()) {
            mismatches += 1;
        } else if let Some(t0) = hits[0] {
            for t in hits.iter().flatten() {
                worst_dt = worst_dt.max((t.to_bits() as i64 - t0.to_bits() as i64).unsigned_abs() as u32);
            }
        }
        let naive: Vec<bool> = orders.iter().map(|o| naive_triangle(&tri(o), &ray).is_some()).collect();
        naive_mismatches += naive.iter().any(|&h| h != naive[0]) as usize;
    }
    c.check(mismatches == 0, || format!("{mismatches} hit/miss mismatches"));
    c.check(worst_dt <= 2, || format!("t differs by {worst_dt} ulps"));
    let figure = format!(
        "250 000 near-edge rays, 4 vertex orders: {mismatches} hit/miss mismatches, worst dt error {worst_dt} ulps"
    );
    c.outcome(figure, Some(format!("|det| < 1e-6: {naive_mismatches} rays whose hit/miss depends on the order")))
}

fn r1_spawned_rays_never_rehit_their_surface() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(11);
    let (mut report, mut naive_report) = (Vec::new(), Vec::new());
    for s in [1e-3f32, 1.0, 1e3, 1e5] {
        for shift in [0.0f32, 1e3, 1e5] {
            let (mut rehits, mut naive_rehits, mut spawned, mut worst_offset) = (0usize, 0usize, 0usize, 0.0f64);
            for _ in 0..300 {
                let base = Vec3A::splat(shift) + unit_vector(&mut r) * shift * 0.1;
                let tri = Triangle::new(base, base + unit_vector(&mut r) * s, base + unit_vector(&mut r) * s);
                let n = tri.normal();
                if n.length() < 0.05 * s * s {
                    continue;
                }
                let n = n.normalize();
                let (b1, b2) = (unif(&mut r) * 0.8 + 0.1, unif(&mut r) * 0.8 + 0.1);
                let (b1, b2) = if b1 + b2 > 0.95 { (b1 * 0.5, b2 * 0.5) } else { (b1, b2) };
                let aim = tri.p[0] * (1.0 - b1 - b2) + tri.p[1] * b1 + tri.p[2] * b2;
                let side = if unif(&mut r) < 0.5 { 1.0 } else { -1.0 };
                let o = aim + (n * side + unit_vector(&mut r) * 0.5).normalize() * (10.0 * s);
                let Some(hit) = tri.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else {
                    continue;
                };
                let facing = if (o - hit.point).dot(hit.normal) > 0.0 { hit.normal } else { -hit.normal };
                let origin = offset_ray_origin(hit.point, hit.error, facing);
                let naive_origin = hit.point + facing * 1e-4;
                let p_max = hit.point.abs().max_element() as f64;
                let ulp = (p_max as f32).max(f32::MIN_POSITIVE).to_bits();
                let ulp = (f32::from_bits(ulp + 1) - f32::from_bits(ulp)) as f64;
                worst_offset = worst_offset.max((origin - hit.point).length() as f64 / (512.0 * ulp + 1.0 / 32768.0));
                for _ in 0..1000 {
                    let mut d = unit_vector(&mut r);
                    if d.dot(facing) < 0.0 {
                        d = -d;
                    }
                    spawned += 1;
                    if tri.intersect(&Ray::new(origin, d), Interval::POSITIVE).is_some() {
                        rehits += 1;
                    }
                    naive_rehits += naive_triangle(&tri, &Ray::new(naive_origin, d)).is_some() as usize;
                }
            }
            report.push(format!("S={s:e} T={shift:e}: {rehits}/{spawned}"));
            naive_report.push(format!("S={s:e} T={shift:e}: {naive_rehits}/{spawned}"));
            c.check(rehits == 0, || format!("S={s} T={shift}: {rehits} re-hits"));
            c.check(worst_offset <= 1.0, || format!("S={s} T={shift}: offset {worst_offset} of the allowance"));
        }
    }
    c.outcome(
        format!("re-hits {}", report.join(", ")),
        Some(format!("p + 1e-4 n: re-hits {}", naive_report.join(", "))),
    )
}

fn r4_shadow_rays_between_surfaces() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(111);
    let mut report = Vec::new();
    for h in [1e-3f32, 1.0, 1e3] {
        for shift in [0.0f32, 1e4] {
            let base = Vec3A::splat(shift);
            let size = h.max(1.0) * 4.0;
            let a = Triangle::new(
                base + Vec3A::new(-size, -size, 0.0),
                base + Vec3A::new(size, -size, 0.0),
                base + Vec3A::new(0.0, size, 0.0),
            );
            let b = Triangle::new(
                base + Vec3A::new(-size, -size, h),
                base + Vec3A::new(0.0, size, h),
                base + Vec3A::new(size, -size, h),
            );
            let mid = Triangle::new(
                base + Vec3A::new(-size, -size, h / 2.0),
                base + Vec3A::new(size, -size, h / 2.0),
                base + Vec3A::new(0.0, size, h / 2.0),
            );
            let (mut false_occlusions, mut missed) = (0, 0);
            let prims = vec![Primitive::Triangle(a), Primitive::Triangle(b)];
            let with_mid = vec![Primitive::Triangle(a), Primitive::Triangle(b), Primitive::Triangle(mid)];
            let (plain, blocked) = (BruteForce::new(prims), BruteForce::new(with_mid));
            for _ in 0..10_000 {
                let point = |r: &mut Pcg32, z: f32| {
                    let (u, v) = (unif(r) * 0.5, unif(r) * 0.5);
                    base + Vec3A::new((u - v) * size, (u + v) * size - size * 0.5, z)
                };
                let (pa, pb) = (point(&mut r, 0.0), point(&mut r, h));
                // Both ends come from hits, so their error bounds are those of the routine.
                let hit_a = a.intersect(&Ray::new(pa + Vec3A::Z * (h * 0.5), -Vec3A::Z), Interval::POSITIVE);
                let hit_b = b.intersect(&Ray::new(pb - Vec3A::Z * (h * 0.5), Vec3A::Z), Interval::POSITIVE);
                let (Some(ha), Some(hb)) = (hit_a, hit_b) else { continue };
                let (ray, dist) = spawn_ray_to(ha.point, ha.error, Vec3A::Z, hb.point, hb.error, -Vec3A::Z);
                if plain.occluded(&ray, dist) {
                    false_occlusions += 1;
                }
                if !blocked.occluded(&ray, dist) {
                    missed += 1;
                }
            }
            report.push(format!("h={h:e} T={shift:e}: {false_occlusions} false, {missed} missed"));
            // ulp of the coordinates; surfaces closer than a few ulps are not distinct in f32.
            let ulp = (shift.max(size) as f64) * U * 2.0;
            if h as f64 >= 16.0 * ulp {
                c.check(false_occlusions == 0, || format!("h={h} T={shift}: {false_occlusions} false occlusions"));
            }
            if h as f64 >= 4096.0 * ulp {
                c.check(missed == 0, || format!("h={h} T={shift}: occluder missed {missed} times"));
            }
        }
    }
    let figure = format!(
        "{} (surfaces closer than 16 ulps of their coordinates are not distinct in f32 and not asserted)",
        report.join(", ")
    );
    c.outcome(figure, None)
}

fn r5_hit_point_error_bound_is_valid() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(151);
    let (mut violations, mut too_large, mut triangle_hits, mut naive_violations) = (0usize, 0usize, 0usize, 0usize);
    for i in 0..1_000_000 {
        let s = 10f32.powf(-3.0 + 6.0 * unif(&mut r));
        let shift = unit_vector(&mut r) * 1e5 * unif(&mut r);
        if i % 2 == 0 {
            let tri = Triangle::new(shift, shift + unit_vector(&mut r) * s, shift + unit_vector(&mut r) * s);
            let n = tri.normal();
            if n.length() < 0.05 * s * s {
                continue;
            }
            let (b1, b2) = (unif(&mut r) * 0.5, unif(&mut r) * 0.5);
            let aim = tri.p[0] * (1.0 - b1 - b2) + tri.p[1] * b1 + tri.p[2] * b2;
            let o = aim + unit_vector(&mut r) * (10.0 * s);
            let ray = Ray::new(o, (aim - o).normalize());
            let Some(h) = tri.intersect(&ray, Interval::POSITIVE) else { continue };
            // f64 distance from a point to the plane through the f32 vertices, and a bound's reach along the normal.
            let n64 = normal64(&tri);
            let p0 = tri.p[0].to_array().map(f64::from);
            let dist = |p: Vec3A| (0..3).map(|a| (p[a] as f64 - p0[a]) * n64[a]).sum::<f64>().abs();
            let allowed = |e: Vec3A| (0..3).map(|a| n64[a].abs() * e[a] as f64).sum::<f64>();
            if dist(h.point) > allowed(h.error) {
                violations += 1;
            }
            let reach: f64 =
                tri.p.iter().map(|v| v.abs().to_array().iter().map(|&x| x as f64).sum::<f64>()).sum::<f64>() + s as f64;
            if h.error.max_element() as f64 > 12.0 * U * reach {
                too_large += 1;
            }
            // Naive: p = o + t d with gamma(7)|p| as its bound.
            let p_naive = ray.at(h.t);
            triangle_hits += 1;
            naive_violations += (dist(p_naive) > allowed(p_naive.abs() * raylume::geometry::gamma(7))) as usize;
        } else {
            let sphere = Sphere { center: shift, radius: s };
            let o = shift + unit_vector(&mut r) * (s * (1.5 + 10.0 * unif(&mut r)));
            let aim = shift + unit_vector(&mut r) * (s * 0.5);
            let Some(h) = sphere.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else { continue };
            let pc = (0..3).map(|a| (h.point[a] as f64 - shift[a] as f64).powi(2)).sum::<f64>().sqrt();
            let n = h.normal.to_array().map(f64::from);
            let allowed: f64 = (0..3).map(|a| n[a].abs() * h.error[a] as f64).sum();
            if (pc - s as f64).abs() > allowed {
                violations += 1;
            }
        }
    }
    c.check(violations == 0, || format!("{violations} points outside their error bound"));
    c.check(too_large == 0, || format!("{too_large} bounds over 12 u·reach"));
    let figure = format!(
        "1e6 triangle and sphere hits: {violations} points outside their error bound, {too_large} bounds over 12 u·reach"
    );
    let naive = format!("o + t d bounded by γ(7)·|p|: {naive_violations} of {triangle_hits} triangle points outside");
    c.outcome(figure, Some(naive))
}

fn s1_small_sphere_far_away() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(21);
    let (mut report, mut naive_report) = (Vec::new(), Vec::new());
    for dist in [1.0f32, 10.0, 100.0, 1000.0] {
        let (mut wrong, mut worst_t, mut naive_wrong, mut naive_worst_t) = (0usize, 0.0f64, 0usize, 0.0f64);
        for _ in 0..100_000 {
            let radius = 1e-3f32;
            let centre = unit_vector(&mut r) * dist;
            let (s, t) = raylume::geometry::orthonormal_basis(centre.normalize());
            let a = std::f32::consts::TAU * unif(&mut r);
            let rr = 1.05 * radius * unif(&mut r).sqrt();
            let aim = centre + (s * a.cos() + t * a.sin()) * rr;
            let dir = if unif(&mut r) < 0.5 { aim.normalize() } else { aim * 3.7 };
            let ray = Ray::new(Vec3A::ZERO, dir);
            // f64 reference.
            let d = [dir.x as f64, dir.y as f64, dir.z as f64];
            let cc = [centre.x as f64, centre.y as f64, centre.z as f64];
            let dd = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let dn = [d[0] / dd, d[1] / dd, d[2] / dd];
            let proj = cc[0] * dn[0] + cc[1] * dn[1] + cc[2] * dn[2];
            let perp2 = (cc[0] * cc[0] + cc[1] * cc[1] + cc[2] * cc[2]) - proj * proj;
            let l_ref = perp2.max(0.0).sqrt();
            let sphere = Sphere { center: centre, radius };
            let hit = sphere.intersect(&ray, Interval::POSITIVE).map(|h| h.t);
            let naive = naive_sphere(&sphere, &ray);
            let expect = l_ref < radius as f64;
            if (l_ref - radius as f64).abs() > 16.0 * U * dist as f64 {
                let t_ref = (proj - (radius as f64 * radius as f64 - perp2).sqrt()) / dd;
                for (hit, wrong, worst_t) in
                    [(hit, &mut wrong, &mut worst_t), (naive, &mut naive_wrong, &mut naive_worst_t)]
                {
                    if hit.is_some() != expect {
                        *wrong += 1;
                    }
                    if let Some(t) = hit.filter(|_| expect) {
                        *worst_t = worst_t.max((t as f64 - t_ref).abs() / (U * t_ref));
                    }
                }
            }
        }
        report.push(format!("D={dist}: {wrong} wrong, worst dt error {worst_t:.1} u·t"));
        naive_report.push(format!("D={dist}: {naive_wrong} wrong, worst dt error {naive_worst_t:.1} u·t"));
        c.check(wrong == 0, || format!("D={dist}: {wrong} wrong"));
        c.check(worst_t <= 16.0, || format!("D={dist}: t error {worst_t:.1} u·t"));
    }
    c.outcome(report.join("; "), Some(format!("b² - 4ac: {}", naive_report.join("; "))))
}

fn s2_large_sphere_origin_near_surface() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(91);
    let (mut worst, mut naive_worst, mut naive_missed) = (0.0f64, 0.0f64, 0usize);
    let mut checked = 0;
    for radius in [1e2f32, 1e4, 1e6] {
        for h in [1e-2f32, 1.0, 1e2] {
            let sphere = Sphere { center: Vec3A::ZERO, radius };
            for _ in 0..20_000 {
                let up = unit_vector(&mut r);
                let o = up * (radius + h);
                let (s, t) = raylume::geometry::orthonormal_basis(up);
                let lateral = (s * (unif(&mut r) - 0.5) + t * (unif(&mut r) - 0.5)) * (6.0 * h);
                let target = up * radius + lateral;
                let d = (target - o).normalize();
                let cos = -d.dot(up);
                let bound = 8.0 * U * (o.length() as f64 + radius as f64);
                let ray = Ray::new(o, d);
                let hit = sphere.intersect(&ray, Interval::POSITIVE);
                if let Some(hit) = hit {
                    c.check(hit.t.is_finite() && hit.t >= 0.0, || format!("r={radius} h={h}: t = {}", hit.t));
                }
                if cos < 0.1 || (h as f64) < bound {
                    continue;
                }
                let Some((t_ref, _)) = sphere_roots64(o, d, radius) else { continue };
                let unit = U * (o.length() as f64 + radius as f64);
                let Some(got) = hit else {
                    c.check(false, || format!("r={radius} h={h}: a ray aimed at the sphere below misses it"));
                    continue;
                };
                worst = worst.max((got.t as f64 - t_ref).abs() / unit);
                checked += 1;
                match naive_sphere(&sphere, &ray) {
                    Some(t) => naive_worst = naive_worst.max((t as f64 - t_ref).abs() / unit),
                    None => naive_missed += 1,
                }
            }
        }
    }
    c.check(worst <= 8.0, || format!("t error {worst:.2} u·(|o-c|+r)"));
    let figure = format!("{checked} rays: worst t error {worst:.2} u·(|o-c|+r)");
    c.outcome(figure, Some(format!("b² - 4ac: worst t error {naive_worst:.2} u·(|o-c|+r), {naive_missed} misses")))
}

fn s3_origin_inside_a_huge_sphere() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(31);
    let (mut found, mut worst, mut naive_missed, mut naive_worst) = (0usize, 0.0f64, 0usize, 0.0f64);
    for (radius, frac) in [(1e5f32, 0.0f32), (1e5, 0.5), (1e5, 0.999), (1.0, 0.0)] {
        let sphere = Sphere { center: Vec3A::ZERO, radius };
        for _ in 0..10_000 {
            let o = unit_vector(&mut r) * radius * frac;
            let d = unit_vector(&mut r);
            let ray = Ray::new(o, d);
            let hit = sphere.intersect(&ray, Interval::POSITIVE);
            let Some((_, t_ref)) = sphere_roots64(o, d, radius) else {
                c.check(false, || format!("r={radius} frac={frac}: the f64 reference misses from inside"));
                continue;
            };
            let unit = U * (o.length() as f64 + radius as f64);
            match naive_sphere(&sphere, &ray) {
                Some(t) => naive_worst = naive_worst.max((t as f64 - t_ref).abs() / unit),
                None => naive_missed += 1,
            }
            let Some(hit) = hit else {
                c.check(false, || format!("r={radius} frac={frac}: no exit (o {o:?}, d {d:?})"));
                continue;
            };
            c.check(!hit.front_face(&ray), || format!("r={radius} frac={frac}: the exit faces the ray"));
            let err = (hit.t as f64 - t_ref).abs() / unit;
            c.check(err <= 8.0, || format!("r={radius} frac={frac}: t {} vs {t_ref} (o {o:?}, d {d:?})", hit.t));
            worst = worst.max(err);
            found += 1;
        }
    }
    let figure = format!(
        "40 000 rays from inside spheres of radius 1 and 1e5: {found} found their exit, worst t error {worst:.1} u·(|o-c|+r)"
    );
    c.outcome(
        figure,
        Some(format!("b² - 4ac: {naive_missed} exits missed, worst t error {naive_worst:.1} u·(|o-c|+r)")),
    )
}

fn s4_tangent_and_silhouette_rays() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(101);
    let (mut wrong, mut naive_wrong, mut naive_nan) = (0, 0, 0);
    for radius in [1.0f32, 3.0] {
        for _ in 0..20 {
            let centre = unit_vector(&mut r) * 1e3 * unif(&mut r);
            let w = unit_vector(&mut r);
            let (s, t) = raylume::geometry::orthonormal_basis(w);
            let sphere = Sphere { center: centre, radius };
            let band = 8.0 * U * (radius as f64).powi(2) * (centre.length() as f64 / radius as f64).max(1.0);
            let mut offsets: Vec<(f32, f32)> = Vec::new();
            for i in 0..21 {
                for j in 0..21 {
                    offsets.push((radius * (i as f32 / 10.0 - 1.0), radius * (j as f32 / 10.0 - 1.0)));
                }
            }
            for k in 10..=24 {
                let e = 2f32.powi(-k);
                offsets.push((radius * (1.0 + e), 0.0));
                offsets.push((radius * (1.0 - e), 0.0));
            }
            offsets.push((radius, 0.0));
            for (x, y) in offsets {
                let o = centre + s * x + t * y - w * (8.0 * radius);
                let ray = Ray::new(o, w);
                let hit = sphere.intersect(&ray, Interval::POSITIVE);
                if let Some(h) = hit {
                    c.check(h.t.is_finite() && h.point.is_finite() && h.normal.is_finite(), || {
                        format!("r={radius} offset ({x}, {y}): t {}, point {:?}, normal {:?}", h.t, h.point, h.normal)
                    });
                }
                let naive = naive_sphere(&sphere, &ray);
                naive_nan += naive.is_some_and(|t| !t.is_finite()) as usize;
                // The f64 offset of the actual f32 ray from the centre.
                let oc = (o - centre).to_array().map(f64::from);
                let w64 = w.to_array().map(f64::from);
                let along: f64 = (0..3).map(|a| oc[a] * w64[a]).sum();
                let d2: f64 = (0..3).map(|a| (oc[a] - along * w64[a]).powi(2)).sum();
                let r2 = (radius as f64).powi(2);
                if (d2 - r2).abs() > band {
                    wrong += (hit.is_some() != (d2 < r2)) as usize;
                    naive_wrong += (naive.is_some() != (d2 < r2)) as usize;
                }
            }
        }
    }
    c.check(wrong == 0, || format!("{wrong} rays misclassified outside the band"));
    let figure =
        format!("21x21 grids and tangent rays over 40 spheres: {wrong} misclassified outside the band, no NaN");
    c.outcome(figure, Some(format!("b² - 4ac: {naive_wrong} misclassified outside the band, {naive_nan} NaN")))
}

fn pl1_plane_nan_safety() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(41);
    let plane = Plane { point: Vec3A::new(0.0, -2.0, 0.0), normal: Vec3A::Y };
    let (mut bad, mut naive_bad) = (0, 0);
    for _ in 0..1_000_000 {
        let h = 10f32.powf(-6.0 + 9.0 * unif(&mut r)) * if unif(&mut r) < 0.5 { 1.0 } else { -1.0 };
        let m = match r.next_u32() % 5 {
            0 => 0.0,
            1 => -0.0,
            2 => 1e-40,
            _ => 10f32.powf(-30.0 + 30.0 * unif(&mut r)),
        } * if unif(&mut r) < 0.5 { 1.0 } else { -1.0 };
        let ray = Ray::new(Vec3A::new(0.0, -2.0 + h, 0.0), Vec3A::new(1.0, m, 0.0));
        if let Some(hit) = plane.intersect(&ray, Interval::POSITIVE) {
            if !hit.t.is_finite() || !hit.point.is_finite() || m == 0.0 {
                bad += 1;
            }
        }
        naive_bad += naive_plane(&plane, &ray).is_some_and(|t| !t.is_finite() || m == 0.0) as usize;
    }
    let in_plane = Ray::new(Vec3A::new(0.0, -2.0, 0.0), Vec3A::X);
    c.check(plane.intersect(&in_plane, Interval::POSITIVE).is_none(), || "the in-plane ray hits".into());
    c.check(bad == 0, || format!("{bad} NaN, infinite or parallel hits"));
    let figure = format!("1e6 near-parallel rays: {bad} NaN, infinite or parallel hits");
    c.outcome(figure, Some(format!("t < tmin || t > tmax: {naive_bad} NaN, infinite or parallel hits")))
}

fn b1_slab_in_face_rays() -> Outcome {
    let mut c = Checks::default();
    let unit = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    let node_hit = |b: &Aabb, ray: &Ray| b.hit_range(ray, ray.dir.recip(), 0.0, f32::INFINITY).is_some();
    let (mut hits, mut naive_hits) = (0, 0);
    for axis in 0..3 {
        for face in [0.0f32, 1.0] {
            for zero in [0.0f32, -0.0, 1e-40, -1e-40] {
                let travel = (axis + 1) % 3;
                let mut o = Vec3A::splat(0.5);
                o[axis] = face;
                o[travel] = -1.0;
                let mut d = Vec3A::ZERO;
                d[travel] = 1.0;
                d[axis] = zero;
                let ray = Ray::new(o, d);
                let hit = node_hit(&unit, &ray);
                c.check(hit, || format!("axis {axis} face {face} zero {zero}"));
                hits += hit as usize;
                naive_hits += naive_slab(&unit, &ray) as usize;
            }
        }
    }
    c.check(node_hit(&unit, &Ray::new(Vec3A::new(1.0, 1.0, -1.0), Vec3A::Z)), || "along an edge".into());
    let corner_box = Aabb::new(Vec3A::ONE, Vec3A::splat(2.0));
    c.check(node_hit(&corner_box, &Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize())), || "through the corner".into());
    let flat = Aabb::new(Vec3A::new(0.0, 0.0, 0.5), Vec3A::new(1.0, 1.0, 0.5));
    c.check(node_hit(&flat, &Ray::new(Vec3A::new(0.5, 0.5, 2.0), -Vec3A::Z)), || "into the flat box".into());
    c.check(node_hit(&flat, &Ray::new(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::new(1.0, 0.0, -0.0))), || {
        "in the flat box's plane".into()
    });
    let point = Aabb::from_point(Vec3A::splat(3.0));
    c.check(node_hit(&point, &Ray::new(Vec3A::ZERO, Vec3A::ONE.normalize())), || "through the point box".into());
    // And the box primitive in the BVH: a ray along an edge of a box finds it.
    let bvh = Bvh::new(vec![Primitive::Box(AaBox { bounds: unit })], Interval::new(0.0, 0.0));
    let along_edge = Ray::new(Vec3A::new(1.0, 1.0, -1.0), Vec3A::new(-0.0, 0.0, 1.0));
    c.check(bvh.closest_hit(&along_edge, Interval::POSITIVE).is_some(), || {
        "the BVH misses the box along its edge".into()
    });
    let figure = format!(
        "{hits} of 24 in-face rays (±0 and ±subnormal components) hit the node test; edge, corner, flat and point boxes too"
    );
    c.outcome(figure, Some(format!("f32::min/max slab: {naive_hits} of 24 in-face rays hit")))
}

fn b2_conservative_far_traversal() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(61);
    let (mut misses, mut naive_misses) = (0, 0);
    for _ in 0..1_000_000 {
        let size = 10f32.powf(-4.0 + 4.0 * unif(&mut r));
        let centre = unit_vector(&mut r) * 10f32.powf(2.0 + 3.0 * unif(&mut r));
        let b = Aabb::new(centre - Vec3A::splat(size), centre + Vec3A::splat(size));
        let axis = (r.next_u32() % 3) as usize;
        let mut target = b.min + (b.max - b.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
        target[axis] = if unif(&mut r) < 0.5 { b.min[axis] } else { b.max[axis] };
        let ray = Ray::new(Vec3A::ZERO, target.normalize());
        if b.hit_range(&ray, ray.dir.recip(), 0.0, f32::INFINITY).is_none() {
            misses += 1;
        }
        naive_misses += !naive_slab(&b, &ray) as usize;
    }
    c.check(misses == 0, || format!("{misses} false misses"));
    let figure = format!("1e6 rays at points on far box faces: {misses} false misses");
    c.outcome(figure, Some(format!("slab without widening: {naive_misses} false misses")))
}

fn b3_box_edges_corners_inside() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(71);
    let (mut bad, mut edge_hits, mut naive_bad) = (0, 0, 0);
    for i in 0..100_000 {
        let half = Vec3A::new(
            10f32.powf(-3.0 + 6.0 * unif(&mut r)),
            10f32.powf(-3.0 + 6.0 * unif(&mut r)),
            10f32.powf(-3.0 + 6.0 * unif(&mut r)),
        );
        let centre = unit_vector(&mut r) * 10f32.powf(5.0 * unif(&mut r));
        let b = AaBox { bounds: Aabb::new(centre - half, centre + half) };
        let pick = |r: &mut Pcg32, a: usize| if unif(r) < 0.5 { b.bounds.min[a] } else { b.bounds.max[a] };
        let (ray, inside) = match i % 4 {
            0 => {
                // An edge point: two coordinates on the bounds.
                let mut t =
                    b.bounds.min + (b.bounds.max - b.bounds.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
                let a = (r.next_u32() % 3) as usize;
                t[a] = pick(&mut r, a);
                t[(a + 1) % 3] = pick(&mut r, (a + 1) % 3);
                let o = t + unit_vector(&mut r).abs().max(Vec3A::splat(0.1)) * (half * 4.0) * (t - centre).signum();
                (Ray::new(o, (t - o).normalize()), false)
            }
            1 => {
                let t = Vec3A::new(pick(&mut r, 0), pick(&mut r, 1), pick(&mut r, 2));
                let o = t + (t - centre) * 3.0;
                (Ray::new(o, (t - o).normalize()), false)
            }
            _ => {
                let o =
                    b.bounds.min + (b.bounds.max - b.bounds.min) * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r));
                (Ray::new(o, unit_vector(&mut r)), true)
            }
        };
        match b.intersect(&ray, Interval::POSITIVE) {
            Some(h) => {
                let axis_aligned = h.normal.abs().max_element() == 1.0 && h.normal.abs().min_element() == 0.0;
                let facing = if inside { h.normal.dot(ray.dir) > 0.0 } else { h.normal.dot(ray.dir) <= 0.0 };
                if h.t.is_nan() || h.t < 0.0 || !axis_aligned || !facing {
                    bad += 1;
                }
                if !inside {
                    // The textbook normal: the components of (p - c) / half within an epsilon of ±1.
                    let q = (h.point - centre) / half;
                    let naive_normal = Vec3A::select(q.abs().cmpgt(Vec3A::splat(1.0 - 1e-4)), q.signum(), Vec3A::ZERO);
                    edge_hits += 1;
                    naive_bad += (naive_normal.length_squared() != 1.0) as usize;
                }
            }
            None => {
                // An origin that rounded onto a face is on the surface, not inside: a ray leaving through
                // that face meets the box at t = 0, which is no hit.
                let strictly_inside = ray.origin.cmpgt(b.bounds.min).all() && ray.origin.cmplt(b.bounds.max).all();
                if inside && strictly_inside {
                    bad += 1;
                }
            }
        }
    }
    c.check(bad == 0, || format!("{bad} with negative t, a bad normal or a missed exit"));
    let figure = format!("1e5 edge, corner and inside rays: {bad} with negative t, a bad normal or a missed exit");
    let naive = format!(
        "(p - c)/half with a 1e-4 epsilon: {naive_bad} of {edge_hits} edge and corner hits get a zero or diagonal normal"
    );
    c.outcome(figure, Some(naive))
}

fn b4_signed_zero_invariance() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(81);
    let mut mismatches = 0;
    for scene in 0..50 {
        let mut prims: Vec<Primitive> = (0..200)
            .map(|i| {
                let centre = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 8.0;
                match i % 3 {
                    0 => Primitive::Sphere(Sphere { center: centre, radius: 0.3 }),
                    1 => Primitive::Triangle(Triangle::new(centre, centre + Vec3A::X, centre + Vec3A::Y)),
                    _ => Primitive::Box(AaBox { bounds: Aabb::new(centre, centre + Vec3A::splat(0.5)) }),
                }
            })
            .collect();
        if scene % 2 == 0 {
            prims.push(Primitive::Plane(Plane { point: Vec3A::new(0.0, -1.0, 0.0), normal: Vec3A::Y }));
        }
        let shutter = Interval::new(0.0, 0.0);
        let bvh = Bvh::new(prims.clone(), shutter);
        let grid = Grid::new(prims.clone(), shutter, GridParams::default());
        let brute = BruteForce::new(prims);
        for _ in 0..2000 {
            let o = Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)) * 10.0 - Vec3A::splat(1.0);
            let mut d = unit_vector(&mut r);
            let zeroed = (r.next_u32() % 3) as usize;
            d[zeroed] = 0.0;
            if r.next_u32() % 2 == 0 {
                d[(zeroed + 1) % 3] = 0.0;
            }
            if d == Vec3A::ZERO {
                continue;
            }
            let mut neg = d;
            for a in 0..3 {
                if neg[a] == 0.0 {
                    neg[a] = -0.0;
                }
            }
            let key = |h: Option<raylume::accel::PrimitiveHit>| h.map(|h| (h.primitive, h.hit.t.to_bits()));
            let a = (Ray::new(o, d), Ray::new(o, neg));
            let answers = [
                (key(brute.closest_hit(&a.0, Interval::POSITIVE)), key(brute.closest_hit(&a.1, Interval::POSITIVE))),
                (key(bvh.closest_hit(&a.0, Interval::POSITIVE)), key(bvh.closest_hit(&a.1, Interval::POSITIVE))),
                (key(grid.closest_hit(&a.0, Interval::POSITIVE)), key(grid.closest_hit(&a.1, Interval::POSITIVE))),
            ];
            if answers.iter().any(|(x, y)| x != y) || answers[0].0 != answers[1].0 || answers[0].0 != answers[2].0 {
                mismatches += 1;
            }
        }
    }
    c.check(mismatches == 0, || format!("{mismatches} rays with differing answers"));
    let figure = format!(
        "50 scenes x 2000 axis-parallel rays: {mismatches} differences between +0 and -0 or between accelerators"
    );
    c.outcome(figure, None)
}

fn x1_accelerators_on_adversarial_scenes() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(161);
    let mut mismatches = 0usize;
    let mut rays_traced = 0usize;
    for scene in 0..200 {
        let n = 1 + (r.next_u32() % 400) as usize;
        let mut prims = Vec::with_capacity(n + 2);
        let cluster = unit_vector(&mut r) * 10.0;
        for i in 0..n {
            let size = 10f32.powf(-4.0 + 8.0 * unif(&mut r)).min(50.0);
            // Centres on a coarse lattice (split planes and cell boundaries) half the time.
            let centre =
                if i % 2 == 0 { (unit_vector(&mut r) * 8.0).round() } else { cluster + unit_vector(&mut r) * size };
            let p = match i % 5 {
                0 => Primitive::Sphere(Sphere { center: centre, radius: size }),
                1 => Primitive::Triangle(Triangle::new(centre, centre + Vec3A::X * size, centre + Vec3A::Y * size)),
                2 => Primitive::Box(AaBox { bounds: Aabb::new(centre, centre + Vec3A::splat(size)) }),
                3 => Primitive::Triangle(Triangle::new(
                    centre,
                    centre + unit_vector(&mut r) * size,
                    centre + unit_vector(&mut r) * size,
                )),
                _ => prims.last().copied().unwrap_or(Primitive::Sphere(Sphere { center: centre, radius: size })),
            };
            prims.push(p);
        }
        for _ in 0..(scene % 3) {
            prims.push(Primitive::Plane(Plane {
                point: Vec3A::new(0.0, -20.0 - unif(&mut r), 0.0),
                normal: unit_vector(&mut r),
            }));
        }
        let shutter = Interval::new(0.0, 0.0);
        let brute = BruteForce::new(prims.clone());
        let bvh = Bvh::new(prims.clone(), shutter);
        let portable = Bvh::with_kernel(prims.clone(), shutter, BvhBuild::Sah, BvhKernel::Portable);
        let mid = Bvh::with_build(prims.clone(), shutter, BvhBuild::Midpoint);
        let grid = Grid::new(prims, shutter, GridParams::default());
        let bounds = bvh.bounds();
        for k in 0..50 {
            let o = match k % 4 {
                0 => unit_vector(&mut r) * 40.0,
                1 => (unit_vector(&mut r) * 8.0).round(),
                2 => bounds.max,
                _ => bounds.min + bounds.diagonal() * Vec3A::new(unif(&mut r), unif(&mut r), unif(&mut r)),
            };
            let mut d = if k % 3 == 0 { Vec3A::X } else { unit_vector(&mut r) };
            if k % 6 == 1 {
                d = Vec3A::new(0.0, -0.0, 1.0);
            }
            let ray = Ray::new(o, if k % 2 == 0 { -d } else { d });
            rays_traced += 1;
            let key = |h: Option<raylume::accel::PrimitiveHit>| h.map(|h| h.hit.t.to_bits());
            let expected = key(brute.closest_hit(&ray, Interval::POSITIVE));
            let occluded = brute.occluded(&ray, 30.0);
            let got = [
                (key(bvh.closest_hit(&ray, Interval::POSITIVE)), bvh.occluded(&ray, 30.0)),
                (key(portable.closest_hit(&ray, Interval::POSITIVE)), portable.occluded(&ray, 30.0)),
                (key(mid.closest_hit(&ray, Interval::POSITIVE)), mid.occluded(&ray, 30.0)),
                (key(grid.closest_hit(&ray, Interval::POSITIVE)), grid.occluded(&ray, 30.0)),
            ];
            // Ties between primitives at the same t are allowed, so t is compared bit for bit.
            mismatches += got.iter().filter(|g| **g != (expected, occluded)).count();
        }
    }
    c.check(mismatches == 0, || format!("{mismatches} answers differ from brute force"));
    let figure = format!(
        "200 adversarial scenes, {rays_traced} rays, 4 accelerators (BVH in both kernels): {mismatches} answers differ \
         from brute force"
    );
    c.outcome(figure, None)
}

fn g3_grid_lattice_rays() -> Outcome {
    let mut c = Checks::default();
    let mut agree = 0;
    for scale in [1.0f32, 312.5] {
        let mut prims = Vec::new();
        for i in 0..64 {
            let at = i as f32 * scale;
            prims.push(Primitive::Sphere(Sphere { center: Vec3A::splat(at), radius: 0.05 * scale }));
            prims.push(Primitive::Sphere(Sphere { center: Vec3A::new(at, at, 0.0), radius: 0.05 * scale }));
        }
        let brute = BruteForce::new(prims.clone());
        let grid =
            Grid::new(prims, Interval::new(0.0, 0.0), GridParams { k: 64.0 * 64.0 * 64.0 / 128.0, mailbox: true });
        let rays = [
            Ray::new(Vec3A::splat(-1.0) * scale, Vec3A::ONE.normalize()),
            Ray::new(Vec3A::new(-1.0, -1.0, 0.0) * scale, Vec3A::new(1.0, 1.0, 0.0).normalize()),
            Ray::new(Vec3A::splat(63.0) * scale, -Vec3A::ONE.normalize()),
            Ray::new(Vec3A::new(63.0, 63.0, 0.0) * scale, Vec3A::new(-1.0, -1.0, -0.0).normalize()),
            Ray::new(Vec3A::new(31.0 * scale, 31.0 * scale, -10.0 * scale), Vec3A::Z),
        ];
        for ray in rays {
            let (a, b) = (brute.closest_hit(&ray, Interval::POSITIVE), grid.closest_hit(&ray, Interval::POSITIVE));
            let (a, b) = (a.map(|h| (h.primitive, h.hit.t)), b.map(|h| (h.primitive, h.hit.t)));
            let occlusion = (brute.occluded(&ray, f32::INFINITY), grid.occluded(&ray, f32::INFINITY));
            c.check(a == b, || format!("scale {scale}, {ray:?}: brute force {a:?}, grid {b:?}"));
            c.check(occlusion.0 == occlusion.1, || format!("scale {scale}, {ray:?}: occlusion {occlusion:?}"));
            agree += (a == b && occlusion.0 == occlusion.1) as usize;
        }
    }
    let figure = format!(
        "{agree} of 10 diagonal, lattice-edge, max-face and axis rays agree with brute force on a 64-per-axis lattice"
    );
    c.outcome(figure, None)
}

fn x2_invalid_rays() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(51);
    let tris: Vec<Triangle> = (0..10_000)
        .map(|_| {
            let centre = unit_vector(&mut r) * 10.0 * unif(&mut r);
            Triangle::new(centre, centre + unit_vector(&mut r) * 0.2, centre + unit_vector(&mut r) * 0.2)
        })
        .collect();
    let prims: Vec<Primitive> = tris.iter().map(|t| Primitive::Triangle(*t)).collect();
    let shutter = Interval::new(0.0, 0.0);
    let bvh = Bvh::new(prims.clone(), shutter);
    let grid = Grid::new(prims.clone(), shutter, GridParams::default());
    let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    let mut invalid = Vec::new();
    for i in 0..10_000 {
        let mut o = unit_vector(&mut r) * 20.0;
        let mut d = unit_vector(&mut r);
        match i % 4 {
            0 => o[i % 3] = specials[i % 3],
            1 => d[i % 3] = specials[(i / 3) % 3],
            2 => d = Vec3A::ZERO,
            _ => o = Vec3A::splat(f32::NAN),
        }
        invalid.push(Ray::new(o, d));
    }
    let valid: Vec<Ray> = (0..10_000).map(|_| Ray::new(unit_vector(&mut r) * 20.0, unit_vector(&mut r))).collect();
    let time = |rays: &[Ray]| {
        let start = std::time::Instant::now();
        let hits = rays
            .iter()
            .filter(|ray| bvh.closest_hit(ray, Interval::POSITIVE).is_some() || grid.occluded(ray, f32::INFINITY))
            .count();
        (hits, start.elapsed().as_secs_f64())
    };
    let (bad_hits, t_invalid) = time(&invalid);
    let (_, t_valid) = time(&valid);
    let brute = BruteForce::new(prims);
    let brute_hits = invalid.iter().filter(|ray| brute.closest_hit(ray, Interval::POSITIVE).is_some()).count();
    c.check(bad_hits == 0, || format!("{bad_hits} hits from the BVH or the grid"));
    c.check(brute_hits == 0, || format!("{brute_hits} hits from brute force"));
    // The textbook triangle test over every triangle, on one invalid ray in ten.
    let naive_hits =
        invalid.iter().step_by(10).filter(|ray| tris.iter().any(|t| naive_triangle(t, ray).is_some())).count();
    let figure = format!(
        "10 000 invalid rays: {bad_hits} hits, {:.2} ms (valid rays: {:.2} ms)",
        t_invalid * 1e3,
        t_valid * 1e3
    );
    c.outcome(figure, Some(format!("|det| < 1e-6 over every triangle: {naive_hits} of 1000 invalid rays report a hit")))
}

/// A lit scene at 64x48 through the library's default render.
fn render_64x48(builder: SceneBuilder) -> Film {
    builder.build().unwrap().render(&RenderOptions::default(), &|| {}).unwrap().film
}

fn o1_images_are_scale_invariant() -> Outcome {
    let mut c = Checks::default();
    let render = |k: f32| {
        render_64x48(
            SceneBuilder::new()
                .camera(Vec3A::new(0.0, 1.5, 5.0) * k, Vec3A::new(0.0, 0.5, 0.0) * k, Vec3A::Y, 40.0, 64, 48)
                .background(Vec3::new(0.2, 0.3, 0.5))
                .light(Vec3A::new(3.0, 5.0, 4.0) * k, Vec3::ONE)
                .material(Phong {
                    diffuse: Vec3::splat(0.8),
                    kd: 0.9,
                    specular: Vec3::ONE,
                    ks: 0.3,
                    shine: 30.0,
                    ..Phong::default()
                })
                .plane([Vec3A::ZERO, Vec3A::new(0.0, 0.0, -k), Vec3A::new(-k, 0.0, 0.0)])
                .sphere(Vec3A::new(0.0, 1.0, 0.0) * k, k)
                .triangle(Vec3A::new(1.2, 0.0, 1.0) * k, Vec3A::new(2.2, 0.0, 1.0) * k, Vec3A::new(1.7, 1.0, 1.0) * k),
        )
    };
    let reference = render(1.0);
    let mut report = Vec::new();
    for k in [1e-4f32, 1e-2, 1e2, 1e4, 1e6] {
        let film = render(k);
        let differing = film
            .pixels()
            .iter()
            .zip(reference.pixels())
            .filter(|(a, b)| (**a - **b).abs().max_element() > 0.02)
            .count();
        report.push(format!("scale {k:e}: {differing} pixels differ"));
        // A pixel or two on silhouettes may round differently; acne would darken hundreds.
        c.check(differing <= 4, || format!("scale {k}: {differing} pixels differ from scale 1"));
    }
    c.outcome(format!("{} (of {} pixels)", report.join(", "), 64 * 48), None)
}

fn o2_tiny_and_huge_triangles() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(121);
    let (mut rays, mut hits, mut worst) = (0usize, 0usize, 0.0f32);
    for side in [1e-6f32, 1e-3, 1.0, 1e3, 1e6] {
        for _ in 0..10_000 {
            let a = unit_vector(&mut r) * side;
            let tri = Triangle::new(a, a + unit_vector(&mut r) * side, a + unit_vector(&mut r) * side);
            if tri.normal().length() < 0.1 * side * side {
                continue;
            }
            let centroid = (tri.p[0] + tri.p[1] + tri.p[2]) / 3.0;
            let o = centroid + unit_vector(&mut r) * (5.0 * side);
            let ray = Ray::new(o, (centroid - o).normalize());
            if tri.normal().normalize().dot(ray.dir).abs() < 0.05 {
                continue;
            }
            rays += 1;
            let Some(hit) = tri.intersect(&ray, Interval::POSITIVE) else {
                c.check(false, || format!("side {side}: a ray at the centroid misses"));
                continue;
            };
            hits += 1;
            let t_ref = (centroid - o).length();
            let err = (hit.t - t_ref).abs() / t_ref;
            c.check(err <= 1e-4, || format!("side {side}: t {} vs {t_ref}", hit.t));
            worst = worst.max(err);
        }
    }
    let figure = format!(
        "{hits} of {rays} rays at the centroids of triangles of side 1e-6 to 1e6 hit, worst t error {worst:.1e} relative"
    );
    c.outcome(figure, None)
}

fn o3_moving_spheres_at_shutter_ends() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(171);
    let prims: Vec<Primitive> = (0..300)
        .map(|_| {
            let centre = unit_vector(&mut r) * 10.0;
            Primitive::MovingSphere(raylume::geometry::MovingSphere {
                center0: centre,
                center1: centre + unit_vector(&mut r) * 5.0,
                radius: 0.3,
                time0: 0.0,
                time1: 1.0,
            })
        })
        .collect();
    let shutter = Interval::new(0.0, 1.0);
    let brute = BruteForce::new(prims.clone());
    let bvh = Bvh::new(prims.clone(), shutter);
    let grid = Grid::new(prims.clone(), shutter, GridParams::default());
    let mut found = 0;
    for (i, p) in prims.iter().enumerate() {
        let Primitive::MovingSphere(m) = p else { unreachable!() };
        for time in [0.0f32, 1.0, 0.5] {
            let centre = m.center_at(time);
            let o = centre + unit_vector(&mut r) * 30.0;
            let ray = Ray::with_time(o, (centre - o).normalize(), time);
            let key = |h: Option<raylume::accel::PrimitiveHit>| h.map(|h| h.hit.t.to_bits());
            let e = key(brute.closest_hit(&ray, Interval::POSITIVE));
            let (b, g) =
                (key(bvh.closest_hit(&ray, Interval::POSITIVE)), key(grid.closest_hit(&ray, Interval::POSITIVE)));
            c.check(b == e, || format!("sphere {i} at {time}: BVH {b:?}, brute force {e:?}"));
            c.check(g == e, || format!("sphere {i} at {time}: grid {g:?}, brute force {e:?}"));
            found += e.is_some() as usize;
        }
    }
    c.check(found == 900, || format!("{found} of 900 rays hit"));
    let figure =
        format!("900 rays at moving spheres at t = 0, 0.5 and 1: BVH and grid agree with brute force ({found} hits)");
    c.outcome(figure, None)
}

fn o4_scene_far_from_the_origin() -> Outcome {
    let mut c = Checks::default();
    let render = |shift: Vec3A| {
        render_64x48(
            SceneBuilder::new()
                .camera(shift + Vec3A::new(0.0, 1.5, 5.0), shift + Vec3A::new(0.0, 0.5, 0.0), Vec3A::Y, 40.0, 64, 48)
                .background(Vec3::new(0.2, 0.3, 0.5))
                .light(shift + Vec3A::new(3.0, 5.0, 4.0), Vec3::ONE)
                .material(Phong { diffuse: Vec3::splat(0.8), kd: 0.9, ..Phong::default() })
                .plane([shift, shift + Vec3A::new(0.0, 0.0, -1.0), shift + Vec3A::new(-1.0, 0.0, 0.0)])
                .sphere(shift + Vec3A::new(0.0, 1.0, 0.0), 1.0),
        )
    };
    let reference = render(Vec3A::ZERO);
    let mut report = Vec::new();
    for shift in [1e3f32, 1e4, 1e5] {
        let film = render(Vec3A::new(shift, 0.0, shift));
        let black = darkened_lit_pixels(&film, &reference);
        report.push(format!("offset {shift:e}: {black} darkened pixels"));
        c.check(black == 0, || format!("offset {shift}: {black} darkened pixels"));
    }
    c.outcome(format!("{} (acne would darken lit pixels)", report.join(", ")), None)
}

/// The pixels of a 64x48 `film` darker than half their value in `reference`, among those that
/// `reference` shows lit and away from its edges (where f32 quantisation may move a silhouette or a
/// shadow by a fraction of a pixel, and at the terminator, where N.L is near zero and tiny values
/// vary relatively): what acne, or a ray starting inside a surface, darkens.
fn darkened_lit_pixels(film: &Film, reference: &Film) -> usize {
    let flat = |x: u32, y: u32| {
        let here = reference.pixel(x, y);
        [(0i32, 1i32), (1, 0), (0, -1), (-1, 0)].iter().all(|&(dx, dy)| {
            let (nx, ny) = ((x as i32 + dx).clamp(0, 63) as u32, (y as i32 + dy).clamp(0, 47) as u32);
            (reference.pixel(nx, ny) - here).abs().max_element() < 0.1
        })
    };
    (0..48u32)
        .flat_map(|y| (0..64u32).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let (got, want) = (film.pixel(x, y).max_element(), reference.pixel(x, y).max_element());
            flat(x, y) && want > 0.05 && got < 0.5 * want
        })
        .count()
}

fn o6_nearly_coincident_spheres() -> Outcome {
    let mut c = Checks::default();
    let render = |spheres: &[(Vec3A, f32)]| {
        let mut builder = SceneBuilder::new()
            .camera(Vec3A::new(-6.0, -60.0, 3.0), Vec3A::ZERO, Vec3A::Z, 3.0, 64, 48)
            .background(Vec3::new(0.1, 0.3, 0.7))
            .light(Vec3A::new(-100.0, -100.0, 100.0), Vec3::ONE)
            .material(Phong { diffuse: Vec3::new(1.0, 0.8, 0.4), kd: 0.8, ..Phong::default() });
        for &(centre, radius) in spheres {
            builder = builder.sphere(centre, radius);
        }
        render_64x48(builder)
    };
    let mut report = Vec::new();
    for step in [1e-7f32, 1e-6, 1e-5] {
        // Each sphere a step along a turn of a spiral from the last, and a step larger: the visible
        // surface changes sphere every few pixels, each less than the rays' rounding from the next.
        let spheres: Vec<(Vec3A, f32)> = (0..40)
            .map(|i| {
                let a = i as f32 * 0.7;
                (Vec3A::new(a.cos(), a.sin(), i as f32) * step, 1.0 + i as f32 * step)
            })
            .collect();
        let film = render(&spheres);
        let reference = render(&spheres[39..]);
        let black = darkened_lit_pixels(&film, &reference);
        report.push(format!("step {step:e}: {black} darkened pixels"));
        c.check(black == 0, || format!("step {step}: {black} darkened pixels"));
    }
    c.outcome(format!("{} (a ray leaving one sphere inside the next would darken lit pixels)", report.join(", ")), None)
}

fn o5_spheres_and_boxes_never_rehit_themselves() -> Outcome {
    let mut c = Checks::default();
    let mut r = rng(181);
    let mut report = Vec::new();
    for scale in [1e-4f32, 1.0, 1e3, 1e6] {
        let (mut rehits, mut spawned) = (0usize, 0usize);
        for i in 0..200 {
            let centre = unit_vector(&mut r) * scale * 3.0;
            let prim = if i % 2 == 0 {
                Primitive::Sphere(Sphere { center: centre, radius: scale })
            } else {
                Primitive::Box(AaBox { bounds: Aabb::new(centre - Vec3A::splat(scale), centre + Vec3A::splat(scale)) })
            };
            let o = centre + unit_vector(&mut r) * (scale * 10.0);
            let aim = centre + unit_vector(&mut r) * (scale * 0.5);
            let Some(hit) = prim.intersect(&Ray::new(o, (aim - o).normalize()), Interval::POSITIVE) else { continue };
            let n = if hit.normal.dot(o - hit.point) > 0.0 { hit.normal } else { -hit.normal };
            let origin = offset_ray_origin(hit.point, hit.error, n);
            for _ in 0..1000 {
                let mut d = unit_vector(&mut r);
                if d.dot(n) < 0.0 {
                    d = -d;
                }
                spawned += 1;
                // Leaving a convex solid outwards: nothing of it can be hit.
                if prim.intersect(&Ray::new(origin, d), Interval::POSITIVE).is_some() {
                    rehits += 1;
                }
            }
        }
        report.push(format!("scale {scale:e}: {rehits}/{spawned}"));
        c.check(rehits == 0, || format!("scale {scale}: {rehits} re-hits"));
    }
    c.outcome(format!("re-hits of spheres and boxes {}", report.join(", ")), None)
}

/// Möller–Trumbore as it is usually written: an absolute determinant epsilon, no NaN guards.
#[allow(clippy::manual_range_contains)]
fn naive_triangle(t: &Triangle, ray: &Ray) -> Option<f32> {
    let (e1, e2) = (t.p[1] - t.p[0], t.p[2] - t.p[0]);
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-6 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - t.p[0];
    let u = s.dot(p) * inv;
    if u < 0.0 || u > 1.0 {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > 0.0).then_some(t)
}

/// Möller–Trumbore with no determinant guard, and the normal normalised without a check.
#[allow(clippy::manual_range_contains)]
fn unguarded_triangle(t: &Triangle, ray: &Ray) -> Option<(f32, Vec3A)> {
    let (e1, e2) = (t.p[1] - t.p[0], t.p[2] - t.p[0]);
    let p = ray.dir.cross(e2);
    let inv = 1.0 / e1.dot(p);
    let s = ray.origin - t.p[0];
    let u = s.dot(p) * inv;
    if u < 0.0 || u > 1.0 {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t_hit = e2.dot(q) * inv;
    if t_hit < 0.0 {
        return None;
    }
    let n = e1.cross(e2);
    Some((t_hit, n / n.length()))
}

/// The textbook quadratic.
fn naive_sphere(s: &Sphere, ray: &Ray) -> Option<f32> {
    let oc = ray.origin - s.center;
    let a = ray.dir.dot(ray.dir);
    let b = 2.0 * oc.dot(ray.dir);
    let c = oc.dot(oc) - s.radius * s.radius;
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let t0 = (-b - disc.sqrt()) / (2.0 * a);
    let t1 = (-b + disc.sqrt()) / (2.0 * a);
    if t0 > 0.0 {
        Some(t0)
    } else if t1 > 0.0 {
        Some(t1)
    } else {
        None
    }
}

/// A slab test with `f32::min`/`max` and no widening.
fn naive_slab(b: &Aabb, ray: &Ray) -> bool {
    let inv = ray.dir.recip();
    let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
    for a in 0..3 {
        let lo = (b.min[a] - ray.origin[a]) * inv[a];
        let hi = (b.max[a] - ray.origin[a]) * inv[a];
        t0 = t0.max(lo.min(hi));
        t1 = t1.min(lo.max(hi));
    }
    t0 <= t1
}

/// A plane test whose range check lets NaN and infinity through (as written on purpose).
#[allow(clippy::manual_range_contains)]
fn naive_plane(p: &Plane, ray: &Ray) -> Option<f32> {
    let t = p.normal.dot(p.point - ray.origin) / p.normal.dot(ray.dir);
    if t < 0.0 || t > f32::INFINITY { None } else { Some(t) }
}

/// The two roots `(near, far)` of a ray (origin `o`, direction `d`) with the sphere of radius `r`
/// centred at the origin, in f64 from the f32 inputs; `None` if the ray misses it.
fn sphere_roots64(o: Vec3A, d: Vec3A, r: f32) -> Option<(f64, f64)> {
    let (o64, d64) = (o.to_array().map(f64::from), d.to_array().map(f64::from));
    let od: f64 = (0..3).map(|a| o64[a] * d64[a]).sum();
    let oo: f64 = (0..3).map(|a| o64[a] * o64[a]).sum();
    let dd: f64 = (0..3).map(|a| d64[a] * d64[a]).sum();
    let disc = od * od - dd * (oo - (r as f64).powi(2));
    (disc >= 0.0).then(|| ((-od - disc.sqrt()) / dd, (-od + disc.sqrt()) / dd))
}

/// The unit normal of a triangle's f32 vertices, computed in f64.
fn normal64(tri: &Triangle) -> [f64; 3] {
    let p = tri.p.map(|v| v.to_array().map(f64::from));
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    let c = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
    let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    [c[0] / l, c[1] / l, c[2] / l]
}

/// The f64 intersection of a ray with the plane of a triangle's f32 vertices: the distance, and the
/// smallest barycentric (positive inside, negative outside).
fn reference_triangle_hit(tri: &Triangle, ray: &Ray) -> Option<(f64, f64)> {
    let p = tri.p.map(|v| v.to_array().map(f64::from));
    let o = ray.origin.to_array().map(f64::from);
    let d = ray.dir.to_array().map(f64::from);
    let n = normal64(tri);
    let den: f64 = (0..3).map(|a| n[a] * d[a]).sum();
    if den == 0.0 {
        return None;
    }
    let t = (0..3).map(|a| n[a] * (p[0][a] - o[a])).sum::<f64>() / den;
    let x = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
    // Signed areas of the sub-triangles, projected on the normal.
    let area = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        let e1 = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let e2 = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2]
    };
    let total = area(p[0], p[1], p[2]);
    let b = [area(x, p[1], p[2]), area(p[0], x, p[2]), area(p[0], p[1], x)];
    let margin = b.iter().fold(f64::INFINITY, |m, &v| m.min(v)) / total;
    (t > 0.0).then_some((t, margin))
}
