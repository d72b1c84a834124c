//! How far a render is from the image it converges to, estimated from its own samples.
//!
//! A render is made of passes, each a complete set of samples per pixel drawn with its own
//! independent randomisation (its own seed: a new jitter, a new Owen scramble). The pass images are
//! then independent, identically distributed estimates of the same image, whatever the sampler does
//! inside a pass, so the spread between them gives an unbiased estimate of the variance of their
//! mean: per pixel and channel `s² / K` over `K` passes, with `s²` the passes' sample variance. (The
//! sample variance of single samples would not do: stratified and low-discrepancy samples are
//! negatively correlated within a pass, and it overestimates their error.)
//!
//! [`Accumulator`] keeps, per pixel, the mean of its passes and their spread (Welford's update);
//! [`Estimate`] is the image's estimated MSE, RMSE and relMSE with a 95 % confidence interval.
//!
//! ```
//! use raylume_geometry::Vec3;
//! use raylume_integrator::{Accumulator, Film};
//! let mut acc = Accumulator::new(2, 1);
//! acc.add_pass(&Film::from_pixels(2, 1, vec![Vec3::splat(0.5), Vec3::splat(1.0)]), None);
//! assert!(acc.estimate().is_none(), "one pass says nothing of the spread");
//! acc.add_pass(&Film::from_pixels(2, 1, vec![Vec3::splat(0.7), Vec3::splat(1.0)]), None);
//! let e = acc.estimate().unwrap();
//! // Pixel 0: passes 0.5 and 0.7, sample variance 0.02, variance of their mean 0.01; pixel 1: 0.
//! assert!((e.mse - 0.005).abs() < 1e-7);
//! assert_eq!(acc.film().pixel(0, 0), Vec3::splat(0.6));
//! ```

use raylume_geometry::{LargeBuffer, Vec3};

use crate::Film;

/// The `eps` of the relative MSE: `(x - r)² / (r² + eps)`, as in [`metrics::rel_mse`](crate::metrics::rel_mse).
pub const REL_MSE_EPS: f64 = 0.01;

/// Per-pixel statistics of a render's passes: the running mean of the pass images (the image), the
/// sum of squared deviations from it (for the variance), and the passes each pixel has had
/// (adaptive sampling gives noisy pixels more).
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulator {
    /// The image: each pixel's mean over its passes.
    mean: Film,
    m2: LargeBuffer<Vec3>,
    passes: LargeBuffer<u32>,
    /// No pixel has had a pass yet.
    fresh: bool,
}

/// The estimated variance of a pixel's value per channel (`s² / K`) from its sum of squared
/// deviations `m2` over `k` passes, `None` before its second pass.
#[inline]
fn variance(m2: Vec3, k: u32) -> Option<Vec3> {
    (k >= 2).then(|| m2 / (k as f32 * (k - 1) as f32))
}

/// The variance of one pass's value of a pixel (the passes' sample variance `s²`, averaged over
/// channels) from `m2` over `k` passes, `None` before its second pass.
#[inline]
fn pass_variance(m2: Vec3, k: u32) -> Option<f32> {
    (k >= 2).then(|| m2.element_sum() / (3.0 * (k - 1) as f32))
}

/// The estimated error of an image against the one its render converges to: the mean over pixels
/// and channels of the variance of each pixel's value, as [`metrics::mse`](crate::metrics::mse)
/// would measure it against a perfect reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Estimated mean squared error over pixels and channels (linear RGB).
    pub mse: f64,
    /// Its square root.
    pub rmse: f64,
    /// A 95 % confidence interval of the RMSE (from the spread of the per-pixel estimates).
    pub rmse_interval: (f64, f64),
    /// Estimated relative MSE, `var / (value² + 0.01)` averaged over pixels and channels, with
    /// the pixel's own value standing for the unknown reference.
    pub rel_mse: f64,
    /// Fewest passes any pixel has had (the estimate needs 2).
    pub min_passes: u32,
}

impl std::fmt::Display for Estimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "RMSE {:.3e} (95 % interval {:.3e} to {:.3e}), relMSE {:.3e}",
            self.rmse, self.rmse_interval.0, self.rmse_interval.1, self.rel_mse
        )
    }
}

impl Accumulator {
    /// An accumulator for `width x height` pixels, with no pass yet. Its buffers are zeroed by the
    /// system, not written over ([`LargeBuffer`]): a render of one pass writes no spread.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        let (m2, passes) = (LargeBuffer::zeroed(n), LargeBuffer::zeroed(n));
        Self { mean: Film::black(width, height), m2, passes, fresh: true }
    }

    /// An accumulator with the state [`parts`](Accumulator::parts) gave: each pixel's mean, sum of
    /// squared deviations and passes, top row first. Passes added to it then give, bit for bit, what
    /// they give the accumulator the parts came from (a render resumed from a saved state). `None`
    /// if a slice is not `width * height` long.
    ///
    /// ```
    /// use raylume_geometry::Vec3;
    /// use raylume_integrator::{Accumulator, Film};
    /// let mut a = Accumulator::new(2, 1);
    /// a.add_pass(&Film::from_pixels(2, 1, vec![Vec3::ONE, Vec3::ZERO]), None);
    /// let (mean, m2, passes) = a.parts();
    /// let mut b = Accumulator::from_parts(2, 1, mean.to_vec(), m2.to_vec(), passes.to_vec()).unwrap();
    /// let pass = Film::from_pixels(2, 1, vec![Vec3::ZERO, Vec3::ONE]);
    /// a.add_pass(&pass, None);
    /// b.add_pass(&pass, None);
    /// assert_eq!(a, b);
    /// ```
    pub fn from_parts(width: u32, height: u32, mean: Vec<Vec3>, m2: Vec<Vec3>, passes: Vec<u32>) -> Option<Self> {
        let n = width as usize * height as usize;
        (mean.len() == n && m2.len() == n && passes.len() == n).then(|| Self {
            fresh: passes.iter().all(|&k| k == 0),
            mean: Film::from_pixels(width, height, mean),
            m2: m2.into(),
            passes: passes.into(),
        })
    }

    /// The state: each pixel's mean, sum of squared deviations from it, and passes, top row first.
    pub fn parts(&self) -> (&[Vec3], &[Vec3], &[u32]) {
        (self.mean.pixels(), &self.m2, &self.passes)
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.mean.width()
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.mean.height()
    }

    /// Adds a pass: each pixel's value (of the pixels `active` marks, all without a mask) joins that
    /// pixel's mean. Panics if the film's size differs.
    pub fn add_pass(&mut self, pass: &Film, active: Option<&[bool]>) {
        assert_eq!((pass.width(), pass.height()), (self.width(), self.height()), "a pass of another size");
        let (mean, m2, passes) = (self.mean.pixels_mut(), &mut *self.m2, &mut *self.passes);
        for (i, &x) in pass.pixels().iter().enumerate() {
            if active.is_some_and(|a| !a[i]) {
                continue;
            }
            self.fresh = false;
            let k = passes[i] + 1;
            passes[i] = k;
            if k == 1 {
                // The first pass is the image as it is, bit for bit.
                mean[i] = x;
                continue;
            }
            let before = mean[i];
            let after = before + (x - before) / k as f32;
            mean[i] = after;
            m2[i] += (x - before) * (x - after);
        }
    }

    /// [`Accumulator::add_pass`] of a pass given away: the first pass of every pixel becomes the image
    /// itself, without a copy. Returns the pass where it is still its own (`None`: it is the image,
    /// [`Accumulator::image`], bit for bit).
    ///
    /// ```
    /// use raylume_geometry::Vec3;
    /// use raylume_integrator::{Accumulator, Film};
    /// let mut acc = Accumulator::new(2, 1);
    /// let first = Film::from_pixels(2, 1, vec![Vec3::splat(0.5), Vec3::ONE]);
    /// assert!(acc.add_film(first.clone(), None).is_none());
    /// assert_eq!(acc.image(), &first);
    /// let second = Film::from_pixels(2, 1, vec![Vec3::splat(0.7), Vec3::ONE]);
    /// assert_eq!(acc.add_film(second.clone(), None), Some(second));
    /// assert_eq!(acc.image().pixel(0, 0), Vec3::splat(0.6));
    /// ```
    pub fn add_film(&mut self, pass: Film, active: Option<&[bool]>) -> Option<Film> {
        assert_eq!((pass.width(), pass.height()), (self.width(), self.height()), "a pass of another size");
        if active.is_none() && self.fresh {
            self.fresh = false;
            self.passes.fill(1);
            self.mean = pass;
            return None;
        }
        self.add_pass(&pass, active);
        Some(pass)
    }

    /// The image: each pixel's mean over its passes.
    pub fn image(&self) -> &Film {
        &self.mean
    }

    /// The image: each pixel's mean over its passes (a copy of [`Accumulator::image`]).
    pub fn film(&self) -> Film {
        self.mean.clone()
    }

    /// The image, the accumulator given away.
    pub fn into_film(self) -> Film {
        self.mean
    }

    /// Passes per pixel, top row first.
    pub fn passes(&self) -> &[u32] {
        &self.passes
    }

    /// Fewest passes any pixel has had.
    pub fn min_passes(&self) -> u32 {
        self.passes.iter().copied().min().unwrap_or(0)
    }

    /// The estimated variance of pixel `i`'s value per channel (`s² / K`), `None` before its second pass.
    pub fn variance(&self, i: usize) -> Option<Vec3> {
        variance(self.m2[i], self.passes[i])
    }

    /// The variance of one pass's value of pixel `i` (the passes' sample variance `s²`, averaged
    /// over channels), `None` before its second pass.
    pub fn pass_variance(&self, i: usize) -> Option<f32> {
        pass_variance(self.m2[i], self.passes[i])
    }

    /// The estimated variance of each pixel's value per channel, as an image (for an EXR's
    /// variance channels), `None` until every pixel has had two passes.
    pub fn variance_film(&self) -> Option<Film> {
        let pixels =
            self.m2.iter().zip(self.passes.iter()).map(|(&m2, &k)| variance(m2, k)).collect::<Option<Vec<_>>>()?;
        Some(Film::from_pixels(self.width(), self.height(), pixels))
    }

    /// The image's estimated error, `None` until every pixel has had two passes.
    pub fn estimate(&self) -> Option<Estimate> {
        let min_passes = self.min_passes();
        if min_passes < 2 || self.passes.is_empty() {
            return None;
        }
        let n = self.passes.len() as f64;
        let (mut sum, mut sum_sq, mut rel) = (0.0f64, 0.0f64, 0.0f64);
        let pixels = self.mean.pixels().iter().zip(self.m2.iter()).zip(self.passes.iter());
        for ((m, &m2), &k) in pixels {
            let v = variance(m2, k).expect("every pixel has two passes");
            let per_pixel = v.element_sum() as f64 / 3.0;
            sum += per_pixel;
            sum_sq += per_pixel * per_pixel;
            for c in 0..3 {
                rel += v[c] as f64 / ((m[c] as f64).powi(2) + REL_MSE_EPS);
            }
        }
        let mse = sum / n;
        // The per-pixel estimates are independent (each pixel draws its own numbers): the standard
        // error of their mean from their spread.
        let spread = ((sum_sq / n - mse * mse).max(0.0) / (n - 1.0).max(1.0)).sqrt();
        let (lo, hi) = ((mse - 1.96 * spread).max(0.0), mse + 1.96 * spread);
        Some(Estimate {
            mse,
            rmse: mse.sqrt(),
            rmse_interval: (lo.sqrt(), hi.sqrt()),
            rel_mse: rel / (3.0 * n),
            min_passes,
        })
    }

    /// The pixels worth another pass, for adaptive sampling: those whose expected fall in squared
    /// error from one more pass is at least the image's mean fall. A pixel's spread is taken as the
    /// mean over its 3x3 neighbourhood (a few passes say little of one pixel alone), and the chosen
    /// pixels are dilated by one pixel, so that the neighbours of a noisy pixel keep sampling too.
    /// Giving passes by the fall in error per pass leads towards each pixel's pass count in
    /// proportion to its standard deviation, the allocation that minimises the image's MSE for a
    /// given number of samples. `None` until every pixel has had two passes.
    pub fn noisy_pixels(&self) -> Option<Vec<bool>> {
        if self.min_passes() < 2 {
            return None;
        }
        let (w, h) = (self.width() as usize, self.height() as usize);
        let passes = &*self.passes;
        let spread: Vec<f32> =
            self.m2.iter().zip(passes).map(|(&m2, &k)| pass_variance(m2, k).expect("two passes")).collect();
        let gain: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let (mut sum, mut count) = (0.0f64, 0.0f64);
                for ny in y.saturating_sub(1)..(y + 2).min(h) {
                    for nx in x.saturating_sub(1)..(x + 2).min(w) {
                        sum += spread[ny * w + nx] as f64;
                        count += 1.0;
                    }
                }
                let k = passes[i] as f64;
                sum / count / (k * (k + 1.0))
            })
            .collect();
        let mean_gain = gain.iter().sum::<f64>() / gain.len() as f64;
        if mean_gain <= 0.0 {
            return Some(vec![false; w * h]);
        }
        let chosen: Vec<bool> = gain.iter().map(|&g| g >= mean_gain).collect();
        let mut dilated = chosen.clone();
        for y in 0..h {
            for x in 0..w {
                if chosen[y * w + x] {
                    for ny in y.saturating_sub(1)..(y + 2).min(h) {
                        for nx in x.saturating_sub(1)..(x + 2).min(w) {
                            dilated[ny * w + nx] = true;
                        }
                    }
                }
            }
        }
        Some(dilated)
    }
}

#[cfg(test)]
mod tests {
    use rand_core::Rng;
    use rand_pcg::Pcg32;

    use super::*;

    fn normal(rng: &mut Pcg32) -> f32 {
        // Box-Muller from two uniforms in (0, 1].
        let u = |r: &mut Pcg32| ((r.next_u32() >> 8) as f64 + 1.0) / (1u64 << 24) as f64;
        let (a, b) = (u(rng), u(rng));
        ((-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()) as f32
    }

    /// Passes whose pixel values are drawn around known means with known variances: the estimate
    /// finds the variance of the mean, `sigma² / K`, and its interval holds it.
    #[test]
    fn the_estimate_finds_a_known_variance() {
        let (w, h, k) = (64u32, 48u32, 4u32);
        let sigma = |i: usize| 0.05 + 0.2 * (i % 7) as f32 / 7.0;
        let truth: f64 =
            (0..(w * h) as usize).map(|i| (sigma(i) as f64).powi(2) / k as f64).sum::<f64>() / (w * h) as f64;
        let mut covered = 0;
        let trials = 40;
        for trial in 0..trials {
            let mut rng = Pcg32::new(trial, 7);
            let mut acc = Accumulator::new(w, h);
            for _ in 0..k {
                let pixels = (0..(w * h) as usize)
                    .map(|i| Vec3::splat(0.5 + (i % 3) as f32) + Vec3::splat(sigma(i)) * normal(&mut rng))
                    .collect();
                acc.add_pass(&Film::from_pixels(w, h, pixels), None);
            }
            let e = acc.estimate().unwrap();
            assert!((e.mse / truth - 1.0).abs() < 0.1, "trial {trial}: {} against {truth}", e.mse);
            if (e.rmse_interval.0..=e.rmse_interval.1).contains(&truth.sqrt()) {
                covered += 1;
            }
        }
        assert!(covered >= trials * 85 / 100, "the 95 % interval held {covered} times in {trials}");
    }

    #[test]
    fn masked_pixels_keep_their_passes_and_noisy_ones_are_chosen() {
        let (w, h) = (9u32, 9u32);
        let mut acc = Accumulator::new(w, h);
        for pass in 0..3 {
            // Only the centre pixel varies between passes.
            let mut pixels = vec![Vec3::splat(0.25); 81];
            pixels[40] = Vec3::splat(pass as f32);
            acc.add_pass(&Film::from_pixels(w, h, pixels), None);
        }
        let noisy = acc.noisy_pixels().unwrap();
        let chosen: Vec<usize> = (0..81).filter(|&i| noisy[i]).collect();
        // The centre's 3x3 neighbourhood share its spread, dilated by one: a 5x5 block.
        let block: Vec<usize> = (2..7).flat_map(|y| (2..7).map(move |x| y * 9 + x)).collect();
        assert_eq!(chosen, block);
        let mask = noisy.clone();
        acc.add_pass(&Film::from_pixels(w, h, vec![Vec3::splat(9.0); 81]), Some(&mask));
        assert_eq!(acc.passes()[0], 3);
        assert_eq!(acc.passes()[40], 4);
        assert_eq!(acc.film().pixel(0, 0), Vec3::splat(0.25), "a masked pixel keeps its value");
        assert_eq!(acc.film().pixel(4, 4), Vec3::splat(3.0));
    }

    /// Passes given away are accumulated as passes lent are, bit for bit, masked or not, and from a
    /// state restored by its parts: only the copy of a first pass is left out.
    #[test]
    fn passes_given_away_accumulate_as_passes_lent() {
        let (w, h) = (7u32, 5u32);
        let mut rng = Pcg32::new(3, 11);
        let mut pass = || {
            let pixels = (0..w * h).map(|_| Vec3::new(normal(&mut rng), normal(&mut rng), normal(&mut rng))).collect();
            Film::from_pixels(w, h, pixels)
        };
        let mask: Vec<bool> = (0..w * h).map(|i| i % 3 != 0).collect();
        let (mut lent, mut given) = (Accumulator::new(w, h), Accumulator::new(w, h));
        for k in 0..5 {
            let film = pass();
            let active = (k == 3).then_some(mask.as_slice());
            lent.add_pass(&film, active);
            let back = given.add_film(film.clone(), active);
            assert_eq!(back.is_none(), k == 0, "pass {k}: only the first is kept as the image");
            assert_eq!(given, lent, "pass {k}");
            if k == 1 {
                let (mean, m2, passes) = given.parts();
                given = Accumulator::from_parts(w, h, mean.to_vec(), m2.to_vec(), passes.to_vec()).unwrap();
            }
        }
        assert_eq!(given.estimate(), lent.estimate());
        // A first pass over some pixels only is accumulated in place.
        let mut masked = Accumulator::new(w, h);
        assert!(masked.add_film(pass(), Some(&mask)).is_some());
        assert_eq!(masked.passes().iter().filter(|&&k| k == 1).count(), mask.iter().filter(|&&a| a).count());
        // A pass over no pixel leaves the accumulator as it was: the next pass is still a first.
        let mut untouched = Accumulator::new(w, h);
        untouched.add_pass(&pass(), Some(&vec![false; (w * h) as usize]));
        assert_eq!(untouched, Accumulator::new(w, h));
        assert!(untouched.add_film(pass(), None).is_none());
    }

    #[test]
    fn a_constant_image_has_no_error_and_no_noisy_pixels() {
        let mut acc = Accumulator::new(3, 2);
        for _ in 0..2 {
            acc.add_pass(&Film::from_pixels(3, 2, vec![Vec3::new(0.1, 0.2, 0.3); 6]), None);
        }
        let e = acc.estimate().unwrap();
        assert_eq!((e.mse, e.rmse_interval), (0.0, (0.0, 0.0)));
        assert!(acc.noisy_pixels().unwrap().iter().all(|&c| !c));
    }
}
