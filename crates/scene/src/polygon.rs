//! Triangles of a planar polygon (p3f and NFF `p`, `pp`): a fan for a convex one, ear clipping
//! (earcut) for one that is not, so that concave NFF polygons render as drawn.

use raylume_geometry::Vec3A;

/// The triangles, as indices into `vertices`, that cover the polygon; each keeps the polygon's
/// winding. A convex polygon gives the fan `(0, i, i + 1)`.
///
/// ```
/// use raylume_geometry::Vec3A;
/// // An L: the fan from its first vertex would cover the notch.
/// let l = [(1.0, 0.0), (1.0, 1.0), (0.5, 1.0), (0.5, 2.0), (0.0, 2.0), (0.0, 0.0)]
///     .map(|(x, y)| Vec3A::new(x, y, 0.0));
/// let tris = raylume_scene::triangulate(&l);
/// assert_eq!(tris.len(), 4);
/// assert!(!tris.contains(&[0, 2, 3]));
/// ```
pub fn triangulate(vertices: &[Vec3A]) -> Vec<[u32; 3]> {
    let n = vertices.len();
    let fan = || (1..n.saturating_sub(1)).map(|i| [0, i as u32, i as u32 + 1]).collect::<Vec<_>>();
    if n <= 3 {
        return fan();
    }
    // Newell's normal, then the 2-D coordinates of the plane that drops its largest axis.
    let mut normal = [0.0f64; 3];
    for i in 0..n {
        let (a, b) = (vertices[i].as_dvec3(), vertices[(i + 1) % n].as_dvec3());
        normal[0] += (a.y - b.y) * (a.z + b.z);
        normal[1] += (a.z - b.z) * (a.x + b.x);
        normal[2] += (a.x - b.x) * (a.y + b.y);
    }
    let axis = (0..3).max_by(|&i, &j| normal[i].abs().total_cmp(&normal[j].abs())).unwrap_or(2);
    if normal[axis] == 0.0 || !normal[axis].is_finite() {
        return fan();
    }
    let (u, v) = [(1, 2), (2, 0), (0, 1)][axis];
    let sign = normal[axis].signum();
    let p: Vec<(f64, f64)> = vertices
        .iter()
        .map(|q| {
            let q = q.as_dvec3().to_array();
            (q[u], q[v] * sign)
        })
        .collect();
    let cross = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
    if (0..n).all(|i| cross(p[(i + n - 1) % n], p[i], p[(i + 1) % n]) >= 0.0) {
        return fan();
    }
    // Ear clipping as earcut does it: a linked ring, ears found where the last was cut, and the
    // corners inside a candidate ear looked up by z-order, so large polygons take O(n log n).
    let mut out: Vec<u32> = Vec::with_capacity(3 * (n - 2));
    earcut::Earcut::new().earcut(p.iter().map(|&(x, y)| [x, y]), &[] as &[u32], &mut out);
    // Each triangle keeps the polygon's winding (positive in the plane's coordinates).
    let mut tris: Vec<[u32; 3]> = out
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]];
            if cross(p[a as usize], p[b as usize], p[c as usize]) < 0.0 { [a, c, b] } else { [a, b, c] }
        })
        .collect();
    // A polygon that crosses itself may leave corners no triangle covers: the fan stands in for it.
    if tris.is_empty() {
        tris = fan();
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(v: &[Vec3A], tris: &[[u32; 3]]) -> f32 {
        tris.iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| v[i as usize]);
                (b - a).cross(c - a).length() / 2.0
            })
            .sum()
    }

    #[test]
    fn concave_polygons_are_covered_exactly_once() {
        // A comb with three teeth, in a tilted plane, in both windings.
        let flat = [(0.0, 0.0), (5.0, 0.0), (5.0, 3.0), (4.0, 3.0), (4.0, 1.0), (3.0, 1.0), (3.0, 3.0), (2.0, 3.0)];
        let flat = [&flat[..], &[(2.0, 1.0), (1.0, 1.0), (1.0, 3.0), (0.0, 3.0)]].concat();
        let tilt = |(x, y): (f32, f32)| Vec3A::new(x, y * 0.6, y * 0.8 + 7.0);
        let mut v: Vec<Vec3A> = flat.iter().copied().map(tilt).collect();
        let expected = 5.0 + 3.0 * 2.0;
        for _ in 0..2 {
            let tris = triangulate(&v);
            assert_eq!(tris.len(), v.len() - 2);
            assert!((area(&v, &tris) - expected).abs() < 1e-4, "{}", area(&v, &tris));
            let n = (v[1] - v[0]).cross(v[v.len() - 1] - v[0]);
            for t in &tris {
                let [a, b, c] = t.map(|i| v[i as usize]);
                assert!((b - a).cross(c - a).dot(n) > 0.0, "every triangle keeps the winding");
            }
            v.reverse();
        }
    }

    #[test]
    fn convex_polygons_keep_their_fan() {
        let square = [Vec3A::ZERO, Vec3A::X, Vec3A::new(1.0, 1.0, 0.0), Vec3A::Y, Vec3A::new(-0.5, 0.5, 0.0)];
        assert_eq!(triangulate(&square), [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    /// Twice the signed area of `v` in the xy plane (shoelace), in f64.
    fn shoelace(v: &[Vec3A]) -> f64 {
        (0..v.len())
            .map(|i| {
                let (a, b) = (v[i].as_dvec3(), v[(i + 1) % v.len()].as_dvec3());
                a.x * b.y - a.y * b.x
            })
            .sum()
    }

    proptest::proptest! {
        /// A star-shaped polygon (corners at rising angles, each at its own distance from the
        /// centre) is simple: its triangles cover exactly its area, each turning as it does.
        #[test]
        fn star_shaped_polygons_are_covered_exactly_once(
            radii in proptest::collection::vec(0.05f32..1.0, 4..400),
            clockwise in proptest::bool::ANY,
        ) {
            let n = radii.len();
            let mut v: Vec<Vec3A> = radii
                .iter()
                .enumerate()
                .map(|(i, r)| {
                    let a = std::f32::consts::TAU * i as f32 / n as f32;
                    Vec3A::new(r * a.cos(), r * a.sin(), 0.0)
                })
                .collect();
            if clockwise {
                v.reverse();
            }
            let tris = triangulate(&v);
            proptest::prop_assert!(tris.len() <= n - 2);
            let expected = shoelace(&v).abs() / 2.0;
            let covered: f64 = tris.iter().map(|t| shoelace(&t.map(|i| v[i as usize])) / 2.0).sum();
            proptest::prop_assert!((covered.abs() - expected).abs() <= 1e-9 * expected.max(1.0), "{covered} of {expected}");
            for t in &tris {
                let twice = shoelace(&t.map(|i| v[i as usize]));
                proptest::prop_assert!(twice == 0.0 || (twice > 0.0) != clockwise, "every triangle keeps the winding");
            }
        }
    }

    #[test]
    fn a_finely_sampled_concave_outline_is_covered_once() {
        // 100 000 corners, alternately on two circles, written with seven significant digits as a
        // scene file would hold them: earcut's z-order lookup keeps this to a moment.
        let n = 100_000;
        let v: Vec<Vec3A> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = if i % 2 == 0 { 1.0 } else { 0.999 };
                let round = |x: f64| format!("{x:.7}").parse::<f32>().unwrap();
                Vec3A::new(round(r * a.cos()), round(r * a.sin()), 0.0)
            })
            .collect();
        let tris = triangulate(&v);
        let expected = shoelace(&v) / 2.0;
        let covered: f64 = tris.iter().map(|t| shoelace(&t.map(|i| v[i as usize])) / 2.0).sum();
        assert!((covered - expected).abs() <= 1e-9 * expected, "{covered} of {expected}");
        assert!(tris.iter().all(|t| shoelace(&t.map(|i| v[i as usize])) >= 0.0));
    }
}
