use raylume_geometry::{Vec3, Vec3A};

/// What a ray that escapes the scene sees: a colour, or an environment cubemap.
#[derive(Clone, Debug, PartialEq)]
pub struct Background {
    /// The background colour (p3f `bclr`).
    pub color: Vec3,
    /// The environment cubemap (p3f `env`), if any; it takes precedence over the colour.
    pub env: Option<Cubemap>,
}

impl Background {
    /// A plain colour.
    pub fn color(color: Vec3) -> Self {
        Self { color, env: None }
    }

    /// The colour seen in direction `dir`.
    #[inline]
    pub fn eval(&self, dir: Vec3A) -> Vec3 {
        match &self.env {
            Some(env) => env.lookup(dir),
            None => self.color,
        }
    }
}

/// One face of a cubemap: RGB texels, row 0 at the bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct CubemapFace {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` texels, bottom row first.
    pub texels: Texels,
}

/// The texels of a [`CubemapFace`].
///
/// ```
/// use raylume_integrator::Texels;
/// let bytes = Texels::Rgb8(vec![255, 0, 51]);
/// assert_eq!(bytes.linear(0).to_array(), [1.0, 0.0, 0.2]);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    /// Eight bits a channel, as image files hold them, three bytes a texel (red, green, blue): a byte
    /// `b` is the linear value `b / 255`. A quarter of the memory of [`Texels::Linear`], and nothing to
    /// convert when a face is loaded.
    Rgb8(Vec<u8>),
    /// Linear values, any range (high dynamic range included).
    Linear(Vec<Vec3>),
}

/// Each byte's linear value `b / 255`, as dividing it gives.
const BYTE_VALUES: [f32; 256] = {
    let mut values = [0.0; 256];
    let mut b = 0;
    while b < values.len() {
        values[b] = b as f32 / 255.0;
        b += 1;
    }
    values
};

impl Texels {
    /// The linear colour of texel `i`.
    #[inline]
    pub fn linear(&self, i: usize) -> Vec3 {
        match self {
            Texels::Rgb8(bytes) => {
                let texel = &bytes[3 * i..3 * i + 3];
                Vec3::new(
                    BYTE_VALUES[texel[0] as usize],
                    BYTE_VALUES[texel[1] as usize],
                    BYTE_VALUES[texel[2] as usize],
                )
            }
            Texels::Linear(texels) => texels[i],
        }
    }
}

impl CubemapFace {
    #[inline]
    fn texel(&self, s: f32, t: f32) -> Vec3 {
        let col = (((self.width - 1) as f32 * s.clamp(0.0, 1.0)) as u32).min(self.width - 1);
        let row = (((self.height - 1) as f32 * t.clamp(0.0, 1.0)) as u32).min(self.height - 1);
        self.texels.linear((row * self.width + col) as usize)
    }
}

/// An environment cubemap with the course's face conventions (see p3f.md): faces in the order
/// `right, left, top, bottom, front, back` (the files of a cubemap folder are named so:
/// `raylume_scene::CUBEMAP_FACES`).
#[derive(Clone, Debug, PartialEq)]
pub struct Cubemap {
    /// The six faces: right, left, top, bottom, front, back.
    pub faces: [CubemapFace; 6],
}

impl Cubemap {
    /// The colour in direction `dir` (need not be unit length).
    ///
    /// The face is chosen by the largest component: `x >= 0` gives `left`, `x < 0` `right`, and so on,
    /// exactly as the course's program does.
    #[inline]
    pub fn lookup(&self, dir: Vec3A) -> Vec3 {
        let a = dir.abs();
        let (face, sc, tc, m) = if a.x >= a.y && a.x >= a.z {
            if dir.x >= 0.0 { (1, dir.z, dir.y, a.x) } else { (0, -dir.z, dir.y, a.x) }
        } else if a.y >= a.z {
            if dir.y >= 0.0 { (2, -dir.x, -dir.z, a.y) } else { (3, -dir.x, dir.z, a.y) }
        } else if dir.z >= 0.0 {
            (4, -dir.x, dir.y, a.z)
        } else {
            (5, dir.x, dir.y, a.z)
        };
        if m == 0.0 || !m.is_finite() {
            return Vec3::ZERO;
        }
        self.faces[face].texel((sc / m + 1.0) * 0.5, (tc / m + 1.0) * 0.5)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every byte reads as its quotient by 255, the value a face of linear texels made from the same
    /// bytes holds, so both kinds of face render alike.
    #[test]
    fn bytes_read_as_their_linear_values() {
        let bytes: Vec<u8> = (0..=255u8).flat_map(|b| [b, 255 - b, b / 2]).collect();
        let linear: Vec<Vec3> = bytes
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0] as f32 / 255.0, p[1] as f32 / 255.0, p[2] as f32 / 255.0))
            .collect();
        let (bytes, linear) = (Texels::Rgb8(bytes), Texels::Linear(linear));
        for i in 0..256 {
            assert_eq!(
                bytes.linear(i).to_array().map(f32::to_bits),
                linear.linear(i).to_array().map(f32::to_bits),
                "texel {i}"
            );
        }
    }
}
