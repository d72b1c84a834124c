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

/// One face of a cubemap: linear RGB texels, row 0 at the bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct CubemapFace {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` texels, bottom row first.
    pub texels: Vec<Vec3>,
}

impl CubemapFace {
    #[inline]
    fn texel(&self, s: f32, t: f32) -> Vec3 {
        let col = (((self.width - 1) as f32 * s.clamp(0.0, 1.0)) as u32).min(self.width - 1);
        let row = (((self.height - 1) as f32 * t.clamp(0.0, 1.0)) as u32).min(self.height - 1);
        self.texels[(row * self.width + col) as usize]
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
