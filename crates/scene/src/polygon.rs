//! Triangles of a planar polygon (p3f and NFF `p`, `pp`): a fan for a convex one, ear clipping for
//! one that is not, so that concave NFF polygons render as drawn.

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
    let mut left: Vec<usize> = (0..n).collect();
    let mut out = Vec::with_capacity(n - 2);
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&k| {
            let (a, b, c) = (left[(k + m - 1) % m], left[k], left[(k + 1) % m]);
            if cross(p[a], p[b], p[c]) <= 0.0 {
                return false;
            }
            // No other corner inside (or on) the candidate ear.
            !left.iter().any(|&q| {
                q != a
                    && q != b
                    && q != c
                    && p[q] != p[a]
                    && p[q] != p[b]
                    && p[q] != p[c]
                    && cross(p[a], p[b], p[q]) >= 0.0
                    && cross(p[b], p[c], p[q]) >= 0.0
                    && cross(p[c], p[a], p[q]) >= 0.0
            })
        });
        // A polygon that crosses itself has no ear left: the rest as a fan.
        let Some(k) = ear else { break };
        out.push([left[(k + m - 1) % m], left[k], left[(k + 1) % m]].map(|i| i as u32));
        left.remove(k);
    }
    for i in 1..left.len() - 1 {
        out.push([left[0], left[i], left[i + 1]].map(|i| i as u32));
    }
    out
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
}
