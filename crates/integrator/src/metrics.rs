//! Image error metrics on linear images, given as equally long slices of channel values (for a
//! [`Film`](crate::Film): `film.channels()`). Each returns `None` if the lengths differ or the
//! images are empty.
//!
//! ```
//! use raylume_integrator::metrics::{mae, mse, psnr, rel_mse, rmse};
//! let reference = [0.5, 0.5, 1.0, 0.0];
//! let image = [0.5, 0.0, 1.0, 0.5];
//! assert_eq!(mse(&image, &reference), Some(0.125));
//! assert_eq!(rmse(&image, &reference), Some(0.125f64.sqrt()));
//! assert_eq!(mae(&image, &reference), Some(0.25));
//! assert!((psnr(&image, &reference, 1.0).unwrap() - 9.0309).abs() < 1e-4);
//! // relMSE = mean((x - r)^2 / (r^2 + eps)).
//! let expected = (0.25 / (0.25 + 0.01) + 0.25 / 0.01) / 4.0;
//! assert!((rel_mse(&image, &reference, 0.01).unwrap() - expected).abs() < 1e-12);
//! ```

fn pairs<'a>(a: &'a [f32], b: &'a [f32]) -> Option<impl Iterator<Item = (f64, f64)> + 'a> {
    (a.len() == b.len() && !a.is_empty()).then(|| a.iter().zip(b).map(|(&x, &y)| (x as f64, y as f64)))
}

/// Mean squared error: `sum((a - b)^2) / n`.
pub fn mse(a: &[f32], b: &[f32]) -> Option<f64> {
    Some(pairs(a, b)?.map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64)
}

/// Root-mean-square error: `sqrt(sum((a - b)^2) / n)`.
///
/// ```
/// use raylume_integrator::metrics::rmse;
/// assert_eq!(rmse(&[0.0, 0.0, 0.0, 0.0], &[1.0, 1.0, 1.0, 1.0]), Some(1.0));
/// ```
pub fn rmse(a: &[f32], b: &[f32]) -> Option<f64> {
    mse(a, b).map(f64::sqrt)
}

/// Relative mean squared error, as pbrt and the rendering literature use it:
/// `sum((image - reference)^2 / (reference^2 + eps)) / n`. `eps` (e.g. 0.01) keeps black pixels of
/// the reference from dominating.
pub fn rel_mse(image: &[f32], reference: &[f32], eps: f64) -> Option<f64> {
    Some(pairs(image, reference)?.map(|(x, r)| (x - r).powi(2) / (r * r + eps)).sum::<f64>() / image.len() as f64)
}

/// Peak signal-to-noise ratio in decibels: `10 log10(peak^2 / MSE)` (infinite for equal images).
pub fn psnr(a: &[f32], b: &[f32], peak: f64) -> Option<f64> {
    mse(a, b).map(|m| 10.0 * (peak * peak / m).log10())
}

/// Mean absolute error: `sum(|a - b|) / n`.
pub fn mae(a: &[f32], b: &[f32]) -> Option<f64> {
    Some(pairs(a, b)?.map(|(x, y)| (x - y).abs()).sum::<f64>() / a.len() as f64)
}

/// The least-squares slope of `log(y)` against `log(x)` over the points with positive coordinates:
/// the exponent of a power law `y ~ x^slope` (e.g. -0.5 for RMSE against time of independent
/// sampling). `None` with fewer than two usable points.
///
/// ```
/// use raylume_integrator::metrics::log_log_slope;
/// let xs = [1.0, 4.0, 16.0, 64.0];
/// let ys: Vec<f64> = xs.iter().map(|x: &f64| 3.0 * x.powf(-0.5)).collect();
/// assert!((log_log_slope(&xs, &ys).unwrap() + 0.5).abs() < 1e-12);
/// ```
pub fn log_log_slope(xs: &[f64], ys: &[f64]) -> Option<f64> {
    let pts: Vec<(f64, f64)> =
        xs.iter().zip(ys).filter(|(x, y)| **x > 0.0 && **y > 0.0).map(|(x, y)| (x.ln(), y.ln())).collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}
