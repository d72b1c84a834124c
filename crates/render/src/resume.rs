//! Stopping a render and finishing it later: a [`Recorder`] keeps, as the render goes, what a
//! [`RenderState`] needs (the passes finished, accumulated per pixel, and the rows finished of the
//! pass under way); a render given that state in [`RenderOptions::resume`](crate::RenderOptions::resume)
//! renders only what is left and makes, bit for bit, the image of the render that was never stopped.
//!
//! ```
//! use raylume_render::{CancelToken, Recorder, RenderOptions, RenderScene};
//! use raylume_scene::{p3f, DEFAULT_SCENE};
//! use std::ops::ControlFlow;
//! let scene = p3f::parse(DEFAULT_SCENE, "default", &Default::default()).unwrap().scene;
//! let options = RenderOptions { resolution: Some((24, 16)), spp: Some(16), ..RenderOptions::default() };
//! let whole = scene.render(&options, &()).unwrap();
//!
//! // Stopped after its second pass (a signal could stop it at any row):
//! let recorder = Recorder::new(24, 16, 0);
//! let cancel = CancelToken::new();
//! let stopped = scene.render_progressive(&options, &(recorder.clone(), cancel.clone()), |p| {
//!     recorder.on_pass(p);
//!     if p.pass == 1 {
//!         cancel.cancel();
//!     }
//!     ControlFlow::Continue(())
//! });
//! assert!(stopped.is_err());
//! let state = recorder.state();
//! assert_eq!(state.next_pass, 2);
//!
//! let resumed = RenderOptions { resume: Some(std::sync::Arc::new(state)), ..options };
//! assert_eq!(scene.render(&resumed, &()).unwrap().film, whole.film);
//! ```

use std::sync::{Arc, Mutex};

use raylume_geometry::Vec3;
use raylume_integrator::{Accumulator, Film, Observer};

use crate::Progress;

/// Where a render stopped: what [`RenderOptions::resume`](crate::RenderOptions::resume) needs to
/// finish it. Its pixels are those of the render's image, or of its crop.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderState {
    /// The passes finished, accumulated per pixel.
    pub accumulator: Accumulator,
    /// The pass under way when the render stopped (its index among the render's passes): the
    /// first pass the resumed render renders.
    pub next_pass: u32,
    /// The rows of pass `next_pass` that were finished, if any.
    pub partial: Option<PartialPass>,
}

/// The finished rows of a pass that was stopped.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialPass {
    /// The pass's image: the rows marked done hold their final pixels; the others are unused.
    pub film: Film,
    /// One flag per row, top row first: whether the row was finished.
    pub rows_done: Vec<bool>,
}

impl RenderState {
    /// The state of a render of `width x height` pixels that has rendered nothing from pass
    /// `first_pass` on.
    pub fn new(width: u32, height: u32, first_pass: u32) -> Self {
        Self { accumulator: Accumulator::new(width, height), next_pass: first_pass, partial: None }
    }

    /// Rows of pass `next_pass` already finished.
    pub fn rows_done(&self) -> usize {
        self.partial.as_ref().map_or(0, |p| p.rows_done.iter().filter(|&&d| d).count())
    }

    /// Whether the state's parts agree in size, for an image or crop of `width x height`.
    pub(crate) fn fits(&self, width: u32, height: u32) -> bool {
        let a = &self.accumulator;
        let partial = self.partial.as_ref().is_none_or(|p| {
            (p.film.width(), p.film.height()) == (width, height) && p.rows_done.len() == height as usize
        });
        (a.width(), a.height()) == (width, height) && partial
    }
}

/// Records a render's [`RenderState`] as it goes. Give a clone of it to the render as its observer
/// (or in a pair with another observer) to keep the finished rows of the pass under way, and call
/// [`on_pass`](Recorder::on_pass) from the progressive callback to keep the passes finished. Clones
/// share one record.
#[derive(Clone, Debug)]
pub struct Recorder(Arc<Mutex<Record>>);

#[derive(Debug)]
struct Record {
    state: RenderState,
    /// The pass under way, as its rows come in.
    pixels: Vec<Vec3>,
    rows_done: Vec<bool>,
}

impl Recorder {
    /// A recorder for a render of `width x height` pixels (the image, or its crop) whose first pass
    /// is `first_pass` (0, or the first of a share of passes).
    pub fn new(width: u32, height: u32, first_pass: u32) -> Self {
        Self::resuming(RenderState::new(width, height, first_pass))
    }

    /// A recorder for a render resumed from `state`: the rows `state` holds of its pass count as done.
    pub fn resuming(state: RenderState) -> Self {
        let (w, h) = (state.accumulator.width(), state.accumulator.height());
        let (pixels, rows_done) = match &state.partial {
            Some(p) => (p.film.pixels().to_vec(), p.rows_done.clone()),
            None => (vec![Vec3::ZERO; w as usize * h as usize], vec![false; h as usize]),
        };
        Self(Arc::new(Mutex::new(Record { state, pixels, rows_done })))
    }

    /// Takes in a finished pass (call it from the callback of
    /// [`render_progressive`](crate::RenderScene::render_progressive)).
    pub fn on_pass(&self, progress: &Progress) {
        let mut r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        r.state.accumulator.clone_from(progress.accumulator);
        r.state.next_pass = progress.pass as u32 + 1;
        r.rows_done.fill(false);
    }

    /// The state so far: the passes finished and the rows finished of the pass under way.
    pub fn state(&self) -> RenderState {
        let r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let mut state = r.state.clone();
        state.partial = r.rows_done.contains(&true).then(|| PartialPass {
            film: Film::from_pixels(state.accumulator.width(), state.accumulator.height(), r.pixels.clone()),
            rows_done: r.rows_done.clone(),
        });
        state
    }
}

impl Observer for Recorder {
    fn rows_done(&self, first_row: u32, width: u32, pixels: &[Vec3]) {
        let mut r = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let Record { pixels: image, rows_done, .. } = &mut *r;
        let width = width.max(1) as usize;
        // A row done before stays as it was: a resumed pass leaves it out (black) where it renders
        // the rest of its band.
        for (k, row) in pixels.chunks_exact(width).enumerate() {
            let y = first_row as usize + k;
            match (rows_done.get_mut(y), image.get_mut(y * width..(y + 1) * width)) {
                (Some(done), Some(dst)) if !*done => {
                    dst.copy_from_slice(row);
                    *done = true;
                }
                _ => {}
            }
        }
    }
}
