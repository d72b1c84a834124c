//! Checkpoints: `render --checkpoint STATE` writes, when a signal stops the render (a scheduler's
//! time limit), the state it needs to finish; `render --resume STATE` with the same scene and
//! flags renders only what is left, and writes the image the render that never stopped makes, bit
//! for bit. See docs/FARM.md.
//!
//! A state is an OpenEXR file: `R`, `G`, `B` hold the image of the passes finished (it can be
//! looked at), `state.m2.*` and `state.passes.*` the rest of each pixel's statistics, and
//! `state.partial.*` the finished rows of the pass that was stopped (named by the attribute
//! `raylume.rows_done`). A state of a share of the samples (`--samples`) also holds the images of
//! the passes it finished (`pass<k>.*`), which the share's part needs.

use std::path::Path;

use raylume_geometry::Vec3;
use raylume_integrator::{Accumulator, Extras, Film, ImageFormat, MAX_IMAGE_PIXELS, MetaValue, Window};
use raylume_render::{PartialPass, RenderState};

use crate::farm::{SCENE_HASH, read_exr, rgb_channels};
use crate::{Failure, bad_input};

/// Header attribute that makes a file a state: the pass to render next.
const NEXT_PASS: &str = "raylume.next_pass";
/// Header attribute: the passes of the render this state belongs to, `FIRST..END`.
const PASS_RANGE: &str = "raylume.pass_range";
/// Header attribute: the rows of the stopped pass that were finished, as ranges `a-b` (inclusive).
const ROWS_DONE: &str = "raylume.rows_done";
/// Header attribute: the pixels of the render, `X0 Y0 X1 Y1` in its full image.
const PIXELS: &str = "raylume.pixels";
/// Header attribute: seconds spent rendering before the state was written, over every stop.
const SECONDS: &str = "raylume.seconds";

/// What identifies the render a state belongs to.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Identity {
    /// The scene and the settings that change pixels ([`crate::farm::scene_hash`]).
    pub(crate) hash: String,
    /// The pixels rendered (the crop, or the whole image), `X0 Y0 X1 Y1`.
    pub(crate) pixels: [u32; 4],
    /// The full image's size.
    pub(crate) full: (u32, u32),
    /// The passes rendered, `first..end`.
    pub(crate) passes: (u32, u32),
}

/// A state read back: the render's state, the images of the passes it finished when it is a share
/// of the samples, and the seconds spent so far.
pub(crate) struct Saved {
    pub(crate) state: RenderState,
    pub(crate) pass_films: Vec<Film>,
    pub(crate) seconds: f64,
}

/// Writes `state` (with, for a share, the images of its finished passes) to `path`, atomically.
pub(crate) fn write(path: &Path, id: &Identity, saved: &Saved) -> Result<(), Failure> {
    let state = &saved.state;
    let (w, h) = (state.accumulator.width(), state.accumulator.height());
    let (mean, m2, passes) = state.accumulator.parts();
    let image = Film::from_pixels(w, h, mean.to_vec());
    let m2 = Film::from_pixels(w, h, m2.to_vec());
    let passes = Film::from_pixels(w, h, passes.iter().map(|&k| Vec3::splat(k as f32)).collect());
    let [x0, y0, x1, y1] = id.pixels;
    let text = |k: &str, v: String| (k.to_owned(), MetaValue::Text(v));
    let mut attributes = vec![
        text(SCENE_HASH, id.hash.clone()),
        text(PASS_RANGE, format!("{}..{}", id.passes.0, id.passes.1)),
        text(PIXELS, format!("{x0} {y0} {x1} {y1}")),
        (NEXT_PASS.to_owned(), MetaValue::Number(state.next_pass as f64)),
        (SECONDS.to_owned(), MetaValue::Number(saved.seconds)),
    ];
    let mut layers = vec![("state.m2".to_owned(), &m2), ("state.passes".to_owned(), &passes)];
    if let Some(p) = &state.partial {
        attributes.push(text(ROWS_DONE, row_ranges(&p.rows_done)));
        layers.push(("state.partial".to_owned(), &p.film));
    }
    for (k, film) in saved.pass_films.iter().enumerate() {
        layers.push((format!("pass{}", id.passes.0 as usize + k), film));
    }
    let window = Some(Window { origin: (x0, y0), full: id.full });
    let extras = Extras { variance: None, attributes, window, layers };
    image.write_with(path, &extras).map_err(|e| Failure { code: 1, message: e.to_string() })
}

/// Reads the state at `path`, refusing, with the file's name, a file that is not a state or is the
/// state of another render than `id`.
pub(crate) fn read(path: &Path, id: &Identity) -> Result<Saved, Failure> {
    use exr::prelude::*;
    let fail = |m: String| bad_input(format!("{}: {m}", path.display()));
    let not_state = |what: &str| fail(format!("{what}: not a state written by raylume render --checkpoint"));
    let meta = std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
    if !meta.is_file() {
        return Err(fail("not a regular file".to_owned()));
    }
    let passes_held = (id.passes.1 - id.passes.0) as u64;
    if meta.len() > MAX_IMAGE_PIXELS * 12 * (passes_held + 4) + (1 << 20) {
        return Err(fail(format!("{} bytes is more than a state can be", meta.len())));
    }
    if ImageFormat::from_path(path).ok() != Some(ImageFormat::Exr) {
        return Err(not_state("not an .exr file"));
    }
    let image = read_exr(path).map_err(|e| fail(format!("unreadable OpenEXR state (truncated or damaged?): {e}")))?;
    let layer = &image.layer_data;
    let attribute = |name: &str| layer.attributes.other.get(&Text::from(name));
    let text = |name: &str| match attribute(name) {
        Some(AttributeValue::Text(t)) => Ok(t.to_string()),
        _ => Err(not_state(&format!("no {name} attribute"))),
    };
    let number = |name: &str| match attribute(name) {
        Some(AttributeValue::F64(x)) if x.is_finite() && *x >= 0.0 => Ok(*x),
        _ => Err(not_state(&format!("no {name} attribute"))),
    };
    let next_pass = number(NEXT_PASS)?;
    let [x0, y0, x1, y1] = id.pixels;
    let range = format!("{}..{}", id.passes.0, id.passes.1);
    let pixels = format!("{x0} {y0} {x1} {y1}");
    if text(SCENE_HASH)? != id.hash {
        return Err(fail(
            "the state of another render: its scene hash differs (another scene file, or other settings: \
             resume with the flags of the render that stopped)"
                .to_owned(),
        ));
    }
    if text(PIXELS)? != pixels || text(PASS_RANGE)? != range {
        return Err(fail(format!(
            "the state of another part of the render: pixels {} and passes {}, where this render has pixels {pixels} \
             and passes {range}",
            text(PIXELS)?,
            text(PASS_RANGE)?
        )));
    }
    let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
    if (w, h) != (x1 - x0, y1 - y0) {
        return Err(fail(format!("{w}x{h} pixels, where its attributes say {}x{}", x1 - x0, y1 - y0)));
    }
    if next_pass.fract() != 0.0 || !(id.passes.0 as f64..id.passes.1 as f64).contains(&next_pass) {
        return Err(fail(format!("{NEXT_PASS} {next_pass}: expected a pass in {range}")));
    }
    let n = w as usize * h as usize;
    let rgb = |name: &str| rgb_channels(layer, name);
    let missing = |name: &str| not_state(&format!("no {name}.R, .G, .B channels"));
    let mean = rgb("").ok_or_else(|| missing("image"))?;
    let m2 = rgb("state.m2").ok_or_else(|| missing("state.m2"))?;
    let counts = rgb("state.passes").ok_or_else(|| missing("state.passes"))?;
    let passes_done = next_pass as u32 - id.passes.0;
    let mut passes = Vec::with_capacity(n);
    for c in &counts {
        if c.x.fract() != 0.0 || !(0.0..=passes_done as f32).contains(&c.x) {
            return Err(fail(format!("state.passes holds {}: expected whole passes from 0 to {passes_done}", c.x)));
        }
        passes.push(c.x as u32);
    }
    let accumulator = Accumulator::from_parts(w, h, mean, m2, passes).ok_or_else(|| missing("state"))?;
    let partial = match attribute(ROWS_DONE) {
        None => None,
        Some(_) => {
            let rows_done = parse_row_ranges(&text(ROWS_DONE)?, h).map_err(|e| fail(format!("{ROWS_DONE}: {e}")))?;
            let film = Film::from_pixels(w, h, rgb("state.partial").ok_or_else(|| missing("state.partial"))?);
            Some(PartialPass { film, rows_done })
        }
    };
    let mut pass_films = Vec::new();
    for k in id.passes.0..next_pass as u32 {
        match rgb(&format!("pass{k}")) {
            Some(pixels) => pass_films.push(Film::from_pixels(w, h, pixels)),
            None => break,
        }
    }
    let state = RenderState { accumulator, next_pass: next_pass as u32, partial };
    Ok(Saved { state, pass_films, seconds: number(SECONDS)? })
}

/// The rows marked done, as ranges `a-b` (inclusive) separated by commas ("" for none).
fn row_ranges(done: &[bool]) -> String {
    let mut out = Vec::new();
    let mut y = 0;
    while y < done.len() {
        if !done[y] {
            y += 1;
            continue;
        }
        let start = y;
        while y < done.len() && done[y] {
            y += 1;
        }
        out.push(if y == start + 1 { start.to_string() } else { format!("{start}-{}", y - 1) });
    }
    out.join(",")
}

/// The rows of `row_ranges`'s text, one flag per row of `height`.
fn parse_row_ranges(text: &str, height: u32) -> Result<Vec<bool>, String> {
    let mut done = vec![false; height as usize];
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = part.split_once('-').unwrap_or((part, part));
        let row = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("'{part}' is not a row range such as 0-7"));
        let (a, b) = (row(a)?, row(b)?);
        if a > b || b >= height {
            return Err(format!("rows {a}-{b}: expected rows from 0 to {}", height.saturating_sub(1)));
        }
        done[a as usize..=b as usize].fill(true);
    }
    Ok(done)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_done_are_written_as_ranges_and_read_back() {
        let done = [true, true, false, true, false, false, true, true, true];
        assert_eq!(row_ranges(&done), "0-1,3,6-8");
        assert_eq!(parse_row_ranges("0-1,3,6-8", 9).unwrap(), done);
        assert_eq!(row_ranges(&[false; 3]), "");
        assert!(parse_row_ranges("3-9", 9).unwrap_err().contains("expected rows from 0 to 8"));
        assert!(parse_row_ranges("x", 9).is_err());
    }
}
