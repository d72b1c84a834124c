//! Fresnel against published values, Schlick within its known error, Snell's law, and the shading's
//! shared and shortened forms against the plain ones, bit for bit.

use approx::assert_relative_eq;
use raylume_geometry::{Vec3, Vec3A};
use raylume_material::{FresnelMode, Material, Phong, fresnel_dielectric, fresnel_refract, reflect, refract, schlick};

#[test]
fn glass_reflects_four_percent_at_normal_incidence() {
    assert_relative_eq!(fresnel_dielectric(1.0, 1.0 / 1.5), 0.04, max_relative = 1e-5);
    // And from inside the glass, the same 4 %.
    assert_relative_eq!(fresnel_dielectric(1.0, 1.5), 0.04, max_relative = 1e-5);
    // Water (n = 1.333): ((n-1)/(n+1))^2 = 0.02037.
    assert_relative_eq!(fresnel_dielectric(1.0, 1.0 / 1.333), 0.020_37, max_relative = 1e-3);
}

#[test]
fn brewster_angle_gives_zero_p_reflectance() {
    // At Brewster's angle Rp = 0, so the unpolarised reflectance is Rs / 2; for glass Rs = 0.1479.
    let theta = 1.5f32.atan();
    let r = fresnel_dielectric(theta.cos(), 1.0 / 1.5);
    assert_relative_eq!(r, 0.147_93 / 2.0, max_relative = 2e-3);
    // It is the minimum of Rp: slightly off Brewster the mean is larger than Rs/2 there would give.
    let rs_only = |t: f32| {
        let ct = (1.0 - (t.sin() / 1.5).powi(2)).sqrt();
        ((t.cos() - 1.5 * ct) / (t.cos() + 1.5 * ct)).powi(2)
    };
    for d in [-0.1f32, 0.1] {
        let t = theta + d;
        assert!(fresnel_dielectric(t.cos(), 1.0 / 1.5) > rs_only(t) / 2.0);
    }
}

#[test]
fn total_internal_reflection_beyond_the_critical_angle() {
    let critical = (1.0f32 / 1.5).asin();
    let beyond = critical + 0.01;
    assert_eq!(fresnel_dielectric(beyond.cos(), 1.5), 1.0);
    assert_eq!(schlick(beyond.cos(), 1.5), 1.0);
    let below = critical - 0.01;
    assert!(fresnel_dielectric(below.cos(), 1.5) < 1.0);
    let d = Vec3A::new(beyond.sin(), -beyond.cos(), 0.0);
    assert_eq!(refract(d, Vec3A::Y, 1.5), None);
    assert!(refract(Vec3A::new(below.sin(), -below.cos(), 0.0), Vec3A::Y, 1.5).is_some());
}

#[test]
fn grazing_incidence_reflects_everything() {
    assert_relative_eq!(fresnel_dielectric(0.0, 1.0 / 1.5), 1.0, max_relative = 1e-6);
    assert_relative_eq!(schlick(0.0, 1.0 / 1.5), 1.0, max_relative = 1e-6);
}

/// The exact unpolarised reflectance from air into a medium of index `n`, in f64, written from the
/// textbook equations independently of the library.
fn fresnel_f64(cos_i: f64, n: f64) -> f64 {
    let sin_t = (1.0 - cos_i * cos_i).max(0.0).sqrt() / n;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)).powi(2);
    let rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)).powi(2);
    0.5 * (rs + rp)
}

#[test]
fn exact_fresnel_matches_an_f64_reference_at_every_angle() {
    for i in 0..=1000 {
        let cos = i as f64 / 1000.0;
        let got = fresnel_dielectric(cos as f32, 1.0 / 1.5) as f64;
        assert!((got - fresnel_f64(cos, 1.5)).abs() < 1e-5, "cos {cos}: {got} vs {}", fresnel_f64(cos, 1.5));
    }
}

#[test]
fn schlick_stays_within_its_known_error() {
    // For glass seen from air, Schlick's approximation is exact at normal and grazing incidence and
    // its worst error is 0.0357 near 85 degrees (computed here in f64 from the exact equations).
    let (mut worst, mut worst_cos) = (0.0f64, 0.0);
    for i in 0..=10_000 {
        let cos = i as f64 / 10_000.0;
        let e = (fresnel_f64(cos, 1.5) - schlick(cos as f32, 1.0 / 1.5) as f64).abs();
        if e > worst {
            (worst, worst_cos) = (e, cos);
        }
    }
    assert!((worst - 0.0357).abs() < 1e-3, "worst Schlick error {worst}");
    assert!((worst_cos.acos().to_degrees() - 85.0).abs() < 1.0, "at {} degrees", worst_cos.acos().to_degrees());
    assert!((schlick(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
    assert_eq!(FresnelMode::Schlick.reflectance(0.7, 0.8), schlick(0.7, 0.8));
    assert_eq!(FresnelMode::Exact.reflectance(0.7, 0.8), fresnel_dielectric(0.7, 0.8));
}

#[test]
fn snell_law_holds() {
    let theta_i = 0.6f32;
    let d = Vec3A::new(theta_i.sin(), -theta_i.cos(), 0.0);
    let t = refract(d, Vec3A::Y, 1.0 / 1.5).unwrap();
    assert_relative_eq!(t.length(), 1.0, max_relative = 1e-6);
    // sin(theta_t) = sin(theta_i) / 1.5
    assert_relative_eq!(t.x, theta_i.sin() / 1.5, max_relative = 1e-5);
    assert!(t.y < 0.0);
    let r = reflect(d, Vec3A::Y);
    assert_relative_eq!(r.y, theta_i.cos(), max_relative = 1e-6);
}

/// A spread of unit vectors (a golden-angle spiral over the sphere).
fn directions(count: u32) -> impl Iterator<Item = Vec3A> {
    (0..count).map(move |i| {
        let z = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
        let phi = i as f32 * 2.399_963;
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3A::new(r * phi.cos(), r * phi.sin(), z).normalize()
    })
}

#[test]
fn fresnel_and_refraction_together_are_the_two_apart_bit_for_bit() {
    let normals: Vec<Vec3A> = directions(37).collect();
    let mut compared = 0;
    for d in directions(2000) {
        for &n in &normals {
            let cos_i = (-d).dot(n);
            if cos_i < 0.0 {
                continue;
            }
            for eta in [1.0 / 1.5, 1.5, 1.0, 1.0 / 2.4, 2.4, 1.0 / 1.333, 1.333, 0.999, 1.001] {
                let (kr, dir) = fresnel_refract(d, n, cos_i, eta);
                let (kr_apart, dir_apart) = (fresnel_dielectric(cos_i.max(0.0), eta), refract(d, n, eta));
                assert_eq!(kr.to_bits(), kr_apart.to_bits(), "d {d}, n {n}, eta {eta}");
                assert_eq!(
                    dir.map(|v| v.to_array().map(f32::to_bits)),
                    dir_apart.map(|v| v.to_array().map(f32::to_bits))
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 100_000, "{compared} cases");
    // Grazing and head-on incidence, where the cosine is 0 or rounds past 1.
    for (d, n) in [(Vec3A::X, Vec3A::Y), (-Vec3A::Y, Vec3A::Y), (Vec3A::new(0.6, -0.8, 0.0), Vec3A::new(0.6, 0.8, 0.0))]
    {
        for eta in [1.0 / 1.5, 1.5] {
            let cos_i = (-d).dot(n);
            let (kr, dir) = fresnel_refract(d, n, cos_i, eta);
            assert_eq!((kr, dir), (fresnel_dielectric(cos_i.max(0.0), eta), refract(d, n, eta)));
        }
    }
}

/// Blinn-Phong with glam's `normalize_or_zero` for the half vector, as the shading defines it.
fn blinn_phong_reference(m: &Phong, n: Vec3A, wo: Vec3A, wi: Vec3A) -> Vec3 {
    let n_dot_l = n.dot(wi);
    if n_dot_l <= 0.0 {
        return Vec3::ZERO;
    }
    let h = (wi + wo).normalize_or_zero();
    let n_dot_h = n.dot(h).max(0.0);
    m.diffuse * (m.kd * n_dot_l) + m.specular * (m.ks * m.specular_scale * n_dot_h.powf(m.shine))
}

#[test]
fn phong_highlights_are_those_of_the_plain_half_vector_bit_for_bit() {
    let m = Phong {
        diffuse: Vec3::new(0.9, 0.5, 0.1),
        kd: 0.7,
        specular: Vec3::ONE,
        ks: 0.4,
        shine: 37.0,
        ..Phong::default()
    };
    let n = Vec3A::new(0.2, 0.9, 0.1).normalize();
    let views: Vec<Vec3A> = directions(61).collect();
    for wi in directions(500) {
        // The view opposite the light makes the half vector zero.
        for wo in views.iter().copied().chain([-wi]) {
            let (got, want) = (m.local(n, wo, wi), blinn_phong_reference(&m, n, wo, wi));
            assert_eq!(got.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "wo {wo}, wi {wi}");
        }
    }
}

#[test]
fn equal_indices_neither_reflect_nor_bend() {
    let normals: Vec<Vec3A> = directions(37).collect();
    for d in directions(2000) {
        for &n in &normals {
            let cos_i = (-d).dot(n);
            if cos_i < 0.0 {
                continue;
            }
            assert_eq!(fresnel_refract(d, n, cos_i, 1.0), (0.0, Some(d)), "d {d}, n {n}");
            assert_eq!(fresnel_dielectric(cos_i, 1.0), 0.0);
            assert_eq!(refract(d, n, 1.0), Some(d));
            // Indices a little apart reflect a little, away from grazing incidence.
            if cos_i > 0.5 {
                for eta in [0.999, 1.001] {
                    assert!(fresnel_dielectric(cos_i, eta) < 1e-5, "d {d}, n {n}, eta {eta}");
                }
            }
        }
    }
}

#[test]
fn reflected_and_refracted_directions_stay_unit_without_normalising() {
    // Neither direction is normalised again: of unit `d` and `n` they come out unit to within the
    // rounding of their few terms, and a chain of bounces (each spawned ray the next one's `d`)
    // drifts by no more than the sum of those roundings.
    let normals: Vec<Vec3A> = directions(61).collect();
    let (mut worst_one, mut worst_chain) = (0.0f32, 0.0f32);
    for (k, d0) in directions(4001).enumerate() {
        let mut d = d0;
        for bounce in 0..8 {
            let n = normals[(k * 7 + bounce * 13) % normals.len()];
            // The normal on the side the ray comes from, as shading turns it.
            let n = if d.dot(n) > 0.0 { -n } else { n };
            let eta = if bounce % 2 == 0 { 1.0 / 1.6 } else { 1.6 };
            let reflected = reflect(d, n);
            let refracted = refract(d, n, eta);
            let (_, shared) = fresnel_refract(d, n, (-d).dot(n), eta);
            assert_eq!(refracted, shared);
            for v in [Some(reflected), refracted].into_iter().flatten() {
                let e = (v.length() - 1.0).abs();
                if bounce == 0 {
                    worst_one = worst_one.max(e);
                }
                worst_chain = worst_chain.max(e);
            }
            d = refracted.unwrap_or(reflected);
        }
    }
    assert!(worst_one < 4.0 * f32::EPSILON, "one bounce: |v| off 1 by {worst_one}");
    assert!(worst_chain < 24.0 * f32::EPSILON, "eight bounces: |v| off 1 by {worst_chain}");
    assert!(worst_chain > 0.0, "the test sees no rounding at all");
}
