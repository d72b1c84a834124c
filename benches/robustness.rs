//! The cost of robustness, routine by routine: the watertight triangle test against Möller–Trumbore,
//! and the conservative slab test against a plain one (`cargo bench --bench robustness`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume::geometry::{Aabb, Triangle};
use raylume::intersect::{intersect_moller_trumbore, intersect_watertight};
use raylume::prelude::*;

const N: usize = 4096;

fn unif(r: &mut Pcg32) -> f32 {
    (r.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

fn point(r: &mut Pcg32) -> Vec3A {
    Vec3A::new(unif(r), unif(r), unif(r)) * 2.0 - Vec3A::ONE
}

/// The slab test without the ±0, NaN and widening care.
fn plain_slab(b: &Aabb, ray: &Ray, inv: Vec3A) -> bool {
    let lo = (b.min - ray.origin) * inv;
    let hi = (b.max - ray.origin) * inv;
    lo.min(hi).max_element().max(0.0) <= lo.max(hi).min_element()
}

fn routines(c: &mut Criterion) {
    let mut r = Pcg32::new(5, 6);
    // Rays from a sphere of radius 3 at random triangles and boxes near the origin: about half hit.
    let tris: Vec<Triangle> = (0..N)
        .map(|_| {
            let a = point(&mut r) * 0.5;
            Triangle::new(a, a + point(&mut r) * 0.5, a + point(&mut r) * 0.5)
        })
        .collect();
    let boxes: Vec<Aabb> = (0..N)
        .map(|_| {
            let a = point(&mut r) * 0.5;
            Aabb::new(a, a + (point(&mut r).abs() + Vec3A::splat(0.05)) * 0.5)
        })
        .collect();
    let rays: Vec<Ray> = (0..N)
        .map(|_| {
            let o = point(&mut r).normalize_or(Vec3A::X) * 3.0;
            Ray::new(o, (point(&mut r) * 0.5 - o).normalize())
        })
        .collect();
    let mut group = c.benchmark_group("robustness");
    group.throughput(Throughput::Elements(N as u64));
    group.bench_function("triangle/watertight", |b| {
        b.iter(|| {
            tris.iter().zip(&rays).filter(|(t, r)| intersect_watertight(t, r, Interval::POSITIVE).is_some()).count()
        })
    });
    group.bench_function("triangle/moller_trumbore", |b| {
        b.iter(|| {
            tris.iter()
                .zip(&rays)
                .filter(|(t, r)| intersect_moller_trumbore(t, r, Interval::POSITIVE).is_some())
                .count()
        })
    });
    let invs: Vec<Vec3A> = rays.iter().map(|r| r.dir.recip()).collect();
    group.bench_function("slab/conservative", |b| {
        b.iter(|| {
            boxes
                .iter()
                .zip(&rays)
                .zip(&invs)
                .filter(|((bx, r), inv)| bx.hit_range(r, **inv, 0.0, f32::INFINITY).is_some())
                .count()
        })
    });
    group.bench_function("slab/plain", |b| {
        b.iter(|| boxes.iter().zip(&rays).zip(&invs).filter(|((bx, r), inv)| plain_slab(bx, r, **inv)).count())
    });
    group.finish();
}

criterion_group!(benches, routines);
criterion_main!(benches);
