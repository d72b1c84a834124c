//! Samplers: where in the pixel, on the lens, on an area light and in the shutter each camera sample
//! falls.
//!
//! Every sample's numbers depend only on the seed, the pixel and the sample's index, so an image is
//! the same whatever the thread count or tile order, and a crop renders exactly the full image's
//! pixels.

use rand_core::Rng;
use rand_pcg::Pcg32;
use raylume_geometry::{Vec2, Vec3A};

/// Makes the sample sources of each pixel.
pub trait Sampler: Sync + Send {
    /// The per-sample source of numbers.
    type Source: SampleSource;

    /// Samples per pixel.
    fn samples_per_pixel(&self) -> u32;

    /// The source of sample `index` of pixel `(x, y)` (y counted from the bottom row).
    fn begin(&self, x: u32, y: u32, index: u32) -> Self::Source;
}

/// The numbers of one camera sample, one method per dimension the renderer uses.
pub trait SampleSource {
    /// Position within the pixel, in `[0, 1)^2`.
    fn film(&mut self) -> Vec2;
    /// Position on an area light, in `[0, 1)^2`.
    fn light(&mut self) -> Vec2;
    /// Position on the lens, in `[0, 1)^2`.
    fn lens(&mut self) -> Vec2;
    /// Fraction of the shutter interval, in `[0, 1)`.
    fn time(&mut self) -> f32;
    /// Three fresh uniform numbers in `[0, 1)` (fuzzy reflections draw as many as they need).
    fn uniform3(&mut self) -> Vec3A;
}

/// One sample at the centre of each pixel (no antialiasing); the other dimensions are uniform random.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Centre {
    seed: u64,
}

impl Centre {
    /// The sampler for a seed.
    pub fn new(seed: u64) -> Self {
        Self { seed }
    }
}

/// Every dimension uniform and independent: the baseline the stratified samplers are measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Independent {
    seed: u64,
    spp: u32,
}

impl Independent {
    /// `spp` independent samples per pixel.
    pub fn new(seed: u64, spp: u32) -> Self {
        Self { seed, spp: spp.max(1) }
    }
}

/// The course's jittered sampler: `n x n` strata per pixel with one random point in each. The area
/// light, the lens and the shutter are stratified too: each pixel stratum is tied to one stratum of
/// each of them through a random permutation per pixel and dimension (the course ties the light
/// stratum to the pixel stratum directly, which biases soft shadows), so no two dimensions are
/// correlated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Jittered {
    seed: u64,
    n: u32,
}

impl Jittered {
    /// `n x n` samples per pixel.
    pub fn new(seed: u64, n: u32) -> Self {
        Self { seed, n: n.max(1) }
    }
}

/// Random numbers of one sample, seeded by (seed, pixel, index). The generator is seeded at the first
/// number drawn, and the per-pixel scramble formed at each permutation: a sample that draws nothing (a
/// pixel centre without area lights or rough mirrors) costs no hashing. The light's stratum is
/// permuted at the first light point drawn and kept for the sample's later ones (one per light and
/// bounce).
#[derive(Clone, Debug)]
pub struct Source {
    rng: Option<Pcg32>,
    light_stratum: Option<u32>,
    seed: u64,
    /// The pixel, `y` in the high half.
    pixel: u64,
    /// The sample's index (its generator's seed) and its stratum, with the strata per side (1 for
    /// unstratified samplers).
    index: u32,
    stratum: u32,
    n: u32,
    centre: bool,
}

impl Source {
    fn new(seed: u64, x: u32, y: u32, index: u32, n: u32, centre: bool) -> Self {
        let pixel = ((y as u64) << 32) | x as u64;
        Self { rng: None, light_stratum: None, seed, pixel, index, stratum: index, n, centre }
    }

    /// The per-pixel scramble of the lens, light and time permutations.
    #[inline]
    fn scramble(&self) -> u32 {
        splitmix(self.seed ^ splitmix(self.pixel)) as u32
    }

    #[inline]
    fn u(&mut self) -> f32 {
        let (seed, pixel, index) = (self.seed, self.pixel, self.index);
        let rng = self.rng.get_or_insert_with(|| {
            Pcg32::new(splitmix(seed ^ splitmix(pixel ^ splitmix(index as u64 + 1))), 0x0a02_bdbf_7bb3_c0a7)
        });
        (rng.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    #[inline]
    fn u2(&mut self) -> Vec2 {
        Vec2::new(self.u(), self.u())
    }

    #[inline]
    fn stratified(&mut self, stratum: u32) -> Vec2 {
        let n = self.n as f32;
        (Vec2::new((stratum % self.n) as f32, (stratum / self.n) as f32) + self.u2()) / n
    }
}

impl SampleSource for Source {
    #[inline]
    fn film(&mut self) -> Vec2 {
        if self.centre { Vec2::splat(0.5) } else { self.stratified(self.stratum) }
    }

    #[inline]
    fn light(&mut self) -> Vec2 {
        // One light stratum per pixel stratum, through a per-pixel random permutation: the identity
        // (the course's tie) would only integrate the diagonal blocks of pixel x light and bias the
        // penumbra; a permutation keeps both stratified and the estimate unbiased.
        let s = match self.light_stratum {
            Some(s) => s,
            None => *self.light_stratum.insert(permute(self.stratum, self.n * self.n, self.scramble() ^ 0x68e3_1da4)),
        };
        self.stratified(s)
    }

    #[inline]
    fn lens(&mut self) -> Vec2 {
        let s = permute(self.stratum, self.n * self.n, self.scramble() ^ 0x51ed_270b);
        self.stratified(s)
    }

    #[inline]
    fn time(&mut self) -> f32 {
        let count = self.n * self.n;
        let s = permute(self.stratum, count, self.scramble() ^ 0x2545_f491);
        (s as f32 + self.u()) / count as f32
    }

    #[inline]
    fn uniform3(&mut self) -> Vec3A {
        Vec3A::new(self.u(), self.u(), self.u())
    }
}

impl Sampler for Centre {
    type Source = Source;
    fn samples_per_pixel(&self) -> u32 {
        1
    }
    #[inline]
    fn begin(&self, x: u32, y: u32, index: u32) -> Source {
        Source::new(self.seed, x, y, index, 1, true)
    }
}

impl Sampler for Independent {
    type Source = Source;
    fn samples_per_pixel(&self) -> u32 {
        self.spp
    }
    #[inline]
    fn begin(&self, x: u32, y: u32, index: u32) -> Source {
        // One stratum covering everything: each dimension is a plain uniform draw.
        let mut s = Source::new(self.seed, x, y, index, 1, false);
        s.stratum = 0;
        s
    }
}

impl Sampler for Jittered {
    type Source = Source;
    fn samples_per_pixel(&self) -> u32 {
        self.n * self.n
    }
    #[inline]
    fn begin(&self, x: u32, y: u32, index: u32) -> Source {
        Source::new(self.seed, x, y, index, self.n, false)
    }
}

/// SplitMix64's finaliser: a well-mixed 64-bit value from any `z` (seeds of independent streams
/// from neighbouring integers, such as the seeds of successive progressive passes).
///
/// ```
/// use raylume_integrator::sampler::splitmix;
/// assert_ne!(splitmix(1), splitmix(2));
/// assert_eq!(splitmix(0), 0xe220_a839_7b1d_cdaf);
/// ```
pub fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A pseudo-random permutation of `0..len` chosen by `key`, without memory (Kensler,
/// "Correlated Multi-Jittered Sampling", 2013): a hash applied until it lands inside the range.
#[inline]
pub fn permute(mut i: u32, len: u32, key: u32) -> u32 {
    if len <= 1 {
        return 0;
    }
    let mut w = len - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= key;
        i = i.wrapping_mul(0xe170_893d);
        i ^= key >> 16;
        i ^= (i & w) >> 4;
        i ^= key >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= key >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | key >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < len {
            break;
        }
    }
    (i.wrapping_add(key)) % len
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_is_a_permutation() {
        for len in [1u32, 2, 3, 16, 17, 100, 256] {
            for key in [0u32, 1, 0xdead_beef] {
                let mut seen = vec![false; len as usize];
                for i in 0..len {
                    let p = permute(i, len, key) as usize;
                    assert!(!seen[p], "len {len} key {key}: {p} twice");
                    seen[p] = true;
                }
            }
        }
    }

    /// Every light point of a sample lies in the one light stratum its pixel stratum is tied to, each
    /// with its own jitter: the first, and those of later lights and bounces.
    #[test]
    fn a_samples_light_points_keep_its_light_stratum() {
        let s = Jittered::new(11, 4);
        let stratum = |p: Vec2| (p.x * 4.0) as u32 + 4 * (p.y * 4.0) as u32;
        let mut tied = [0u32; 16];
        for i in 0..16 {
            let first = stratum(s.begin(2, 9, i).light());
            let mut src = s.begin(2, 9, i);
            let points: Vec<Vec2> = (0..4).map(|_| src.light()).collect();
            assert!(points.iter().all(|&p| stratum(p) == first), "sample {i}: {points:?}");
            assert!(points.windows(2).all(|w| w[0] != w[1]), "sample {i}: one jitter each");
            tied[first as usize] += 1;
        }
        assert!(tied.iter().all(|&c| c == 1), "{tied:?}");
    }

    #[test]
    fn jittered_puts_one_sample_in_each_stratum_of_every_dimension() {
        let s = Jittered::new(3, 4);
        let mut film = [0u32; 16];
        let mut light = [0u32; 16];
        let mut lens = [0u32; 16];
        let mut time = [0u32; 16];
        for i in 0..16 {
            let mut src = s.begin(5, 7, i);
            let f = src.film();
            let l = src.light();
            film[(f.x * 4.0) as usize + 4 * (f.y * 4.0) as usize] += 1;
            light[(l.x * 4.0) as usize + 4 * (l.y * 4.0) as usize] += 1;
            let le = src.lens();
            lens[(le.x * 4.0) as usize + 4 * (le.y * 4.0) as usize] += 1;
            time[(src.time() * 16.0) as usize] += 1;
        }
        assert!(film.iter().chain(&light).chain(&lens).chain(&time).all(|&c| c == 1));
    }

    #[test]
    fn sobol_is_stratified_in_every_dimension_pair() {
        // 16 Owen-scrambled Sobol points fill each 4x4 grid cell once, and each 16-row strip once
        // (elementary intervals of a (0,2)-sequence survive the scrambling), for film, lens and light.
        let s = Sobol::new(3, 16);
        for pixel in 0..5u32 {
            for dim in 0..3 {
                let (mut grid, mut rows, mut cols) = ([0u32; 16], [0u32; 16], [0u32; 16]);
                for i in 0..16 {
                    let mut src = s.begin(pixel, 2 * pixel, i);
                    let p = match dim {
                        0 => src.film(),
                        1 => src.light(),
                        _ => src.lens(),
                    };
                    assert!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0);
                    grid[(p.x * 4.0) as usize + 4 * (p.y * 4.0) as usize] += 1;
                    rows[(p.y * 16.0) as usize] += 1;
                    cols[(p.x * 16.0) as usize] += 1;
                }
                assert!(grid.iter().chain(&rows).chain(&cols).all(|&c| c == 1), "pixel {pixel} dim {dim}");
            }
        }
        // Different pixels and dimensions get different points.
        assert_ne!(s.begin(0, 0, 0).film(), s.begin(1, 0, 0).film());
        let mut a = s.begin(0, 0, 5);
        assert_ne!(a.film(), a.lens());
    }

    #[test]
    fn samples_depend_only_on_seed_pixel_and_index() {
        let s = Jittered::new(9, 3);
        let a: Vec<Vec2> = (0..9).map(|i| s.begin(10, 20, i).film()).collect();
        let b: Vec<Vec2> =
            (0..9).rev().map(|i| s.begin(10, 20, i).film()).collect::<Vec<_>>().into_iter().rev().collect();
        assert_eq!(a, b);
        assert_ne!(s.begin(10, 20, 0).film(), Jittered::new(10, 3).begin(10, 20, 0).film());
        assert_ne!(s.begin(10, 20, 0).uniform3(), s.begin(11, 20, 0).uniform3());
    }
}

/// An Owen-scrambled Sobol sampler (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020): each
/// pair of dimensions (film, lens, light) and the time take the first two Sobol dimensions, with the
/// sample index shuffled and the points scrambled by hashes of the pixel and the dimension, so the
/// dimensions are decorrelated and every pixel gets its own low-discrepancy set. Best with powers of
/// two samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sobol {
    seed: u64,
    spp: u32,
}

impl Sobol {
    /// `spp` samples per pixel.
    pub fn new(seed: u64, spp: u32) -> Self {
        Self { seed, spp: spp.max(1) }
    }
}

/// The per-sample state of [`Sobol`].
#[derive(Clone, Debug)]
pub struct SobolSource {
    index: u32,
    pixel_key: u32,
    /// Next dimension for the uniform draws (fuzzy reflections).
    next_dim: u32,
}

/// The Laine–Karras permutation, applied to bit-reversed values: a nested uniform (Owen) scramble.
#[inline]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits();
    v = v.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
}

/// The second Sobol dimension of index `i` (generator v_k = v_(k-1) ^ (v_(k-1) >> 1)).
#[inline]
fn sobol_dim1(mut i: u32) -> u32 {
    let (mut x, mut v) = (0u32, 1u32 << 31);
    while i != 0 {
        if i & 1 != 0 {
            x ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    x
}

#[inline]
fn hash32(a: u32, b: u32) -> u32 {
    (splitmix(((a as u64) << 32) | b as u64) >> 32) as u32
}

#[inline]
fn to_unit(x: u32) -> f32 {
    // 24 bits, so the value stays below 1 in f32.
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

impl SobolSource {
    /// The 2D point of dimension pair `dim`.
    #[inline]
    fn pair(&self, dim: u32) -> Vec2 {
        let key = hash32(self.pixel_key, dim);
        let i = owen_scramble(self.index, key);
        let x = owen_scramble(i.reverse_bits(), hash32(key, 1));
        let y = owen_scramble(sobol_dim1(i), hash32(key, 2));
        Vec2::new(to_unit(x), to_unit(y))
    }
}

impl SampleSource for SobolSource {
    #[inline]
    fn film(&mut self) -> Vec2 {
        self.pair(0)
    }
    #[inline]
    fn light(&mut self) -> Vec2 {
        self.pair(1)
    }
    #[inline]
    fn lens(&mut self) -> Vec2 {
        self.pair(2)
    }
    #[inline]
    fn time(&mut self) -> f32 {
        self.pair(3).x
    }
    #[inline]
    fn uniform3(&mut self) -> Vec3A {
        let (a, b) = (self.pair(self.next_dim), self.pair(self.next_dim + 1));
        self.next_dim += 2;
        Vec3A::new(a.x, a.y, b.x)
    }
}

impl Sampler for Sobol {
    type Source = SobolSource;
    fn samples_per_pixel(&self) -> u32 {
        self.spp
    }
    #[inline]
    fn begin(&self, x: u32, y: u32, index: u32) -> SobolSource {
        let pixel = ((y as u64) << 32) | x as u64;
        let pixel_key = splitmix(self.seed ^ splitmix(pixel)) as u32;
        SobolSource { index, pixel_key, next_dim: 4 }
    }
}
