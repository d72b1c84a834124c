//! Image error metrics.

/// Root-mean-square error between two images given as equally long slices of channel values:
/// `sqrt(sum((a - b)^2) / n)`. Returns `None` if the lengths differ or the slices are empty.
///
/// ```
/// use raylume_integrator::metrics::rmse;
/// assert_eq!(rmse(&[0.0, 0.0, 0.0, 0.0], &[1.0, 1.0, 1.0, 1.0]), Some(1.0));
/// assert_eq!(rmse(&[0.5, 0.5], &[0.5, 0.0]), Some((0.125f64).sqrt()));
/// ```
pub fn rmse(a: &[f32], b: &[f32]) -> Option<f64> {
    if a.len() != b.len() || a.is_empty() {
        return None;
    }
    let sum: f64 = a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum();
    Some((sum / a.len() as f64).sqrt())
}
