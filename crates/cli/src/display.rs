//! Watching a render while it runs: the preview window ([`crate::preview`]) and streaming to the tev
//! image viewer ([`crate::tev`]).
//!
//! The render loop never waits for either. Its row tasks hand each finished row to
//! [`Display::rows_done`] (an [`Observer`]), which copies the row into a preview image behind a mutex
//! that only these copies and the display threads take, each for a copy of a few rows; after each
//! progressive pass, [`Display::show_pass`] copies the whole image. Each display thread wakes at most
//! [`FRAME_HZ`] times a second, copies the rows changed since its last frame and shows them.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use raylume_geometry::Vec3;
use raylume_integrator::{Film, Observer};

/// Most frames a second a display thread shows (or sends).
pub(crate) const FRAME_HZ: u32 = 30;

/// The time between two frames.
pub(crate) const FRAME: Duration = Duration::from_nanos(1_000_000_000 / FRAME_HZ as u64);

/// A line for the user (through the progress bar, so that it is not drawn over).
pub(crate) type Say = Arc<dyn Fn(&str) + Send + Sync>;

/// What a display shows besides the pixels (the window's title).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Status {
    /// Rows of the first pass finished.
    pub(crate) rows: u32,
    /// Samples per pixel of the image shown.
    pub(crate) spp: u64,
    /// Seconds rendered; `None` while rows come in (the display counts from its start).
    pub(crate) seconds: Option<f64>,
    /// The render's estimate of its error, once it has one.
    pub(crate) estimate: Option<f64>,
    /// The render is over and the image is final.
    pub(crate) done: bool,
}

/// The preview image and what the display threads have to know of it.
pub(crate) struct Frame {
    /// The image so far, row 0 at the top.
    pub(crate) pixels: Vec<Vec3>,
    /// For each row, the update that last changed it (0: never).
    pub(crate) row_update: Vec<u64>,
    /// The latest update.
    pub(crate) update: u64,
    /// Whether a pass was shown: rows of later passes (only that pass's samples) are then left out.
    pub(crate) passes: bool,
    /// The status shown with the image.
    pub(crate) status: Status,
}

/// What the render loop and the display threads share.
pub(crate) struct Shared {
    /// The image's width in pixels.
    pub(crate) width: u32,
    /// The image's height in pixels.
    pub(crate) height: u32,
    /// When the display started.
    pub(crate) start: Instant,
    frame: Mutex<Frame>,
    stop: AtomicBool,
    over: AtomicBool,
}

impl Shared {
    /// The frame, locked (a thread that panicked while holding it left whole rows).
    pub(crate) fn frame(&self) -> MutexGuard<'_, Frame> {
        self.frame.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Asks the render to stop (the window was closed or Esc pressed).
    pub(crate) fn request_stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Whether the render was asked to stop.
    pub(crate) fn stop_requested(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Whether the render is over (finished or stopped): the display threads show the last frame.
    pub(crate) fn over(&self) -> bool {
        self.over.load(Ordering::Acquire)
    }

    /// Copies into `mirror` (a whole image) the rows changed since update `seen`, which it then
    /// advances; returns the rows copied (in order) and the status.
    pub(crate) fn changes(&self, mirror: &mut [Vec3], seen: &mut u64) -> (Vec<u32>, Status) {
        let w = self.width as usize;
        let frame = self.frame();
        let mut rows = Vec::new();
        if frame.update != *seen {
            for (r, &u) in frame.row_update.iter().enumerate() {
                if u > *seen {
                    mirror[r * w..(r + 1) * w].copy_from_slice(&frame.pixels[r * w..(r + 1) * w]);
                    rows.push(r as u32);
                }
            }
            *seen = frame.update;
        }
        (rows, frame.status.clone())
    }
}

/// Where to show a render.
#[derive(Clone, Debug, Default)]
pub(crate) struct DisplayOptions {
    /// Open the preview window.
    pub(crate) preview: bool,
    /// Stream to the tev instance listening at this `HOST:PORT`.
    pub(crate) server: Option<String>,
    /// The output image (named in the window's title and tev's image name; snapshots go beside it).
    pub(crate) output: PathBuf,
}

/// Shows a render as it runs, in a window and/or in tev; an [`Observer`] of the render that
/// cancels it once the window is closed or Esc is pressed.
pub(crate) struct Display {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    window: bool,
    say: Say,
}

impl Display {
    /// Starts the displays `options` ask for, for an image of `width` x `height` rendered with `spp`
    /// samples per pixel: `Ok(None)` when they ask for none. A tev that cannot be reached is an
    /// error (before anything is rendered); a window that cannot be opened is said in one line, and
    /// the render goes on without it.
    pub(crate) fn start(
        options: &DisplayOptions,
        width: u32,
        height: u32,
        spp: u32,
        say: Say,
    ) -> Result<Option<Display>, String> {
        if !options.preview && options.server.is_none() {
            return Ok(None);
        }
        let n = width as usize * height as usize;
        let status = Status { rows: 0, spp: spp as u64, seconds: None, estimate: None, done: false };
        let frame = Frame {
            pixels: vec![Vec3::ZERO; n],
            row_update: vec![0; height as usize],
            update: 0,
            passes: false,
            status,
        };
        let shared = Arc::new(Shared {
            width,
            height,
            start: Instant::now(),
            frame: Mutex::new(frame),
            stop: AtomicBool::new(false),
            over: AtomicBool::new(false),
        });
        let name = options.output.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let mut threads = Vec::new();
        if let Some(server) = &options.server {
            let client = crate::tev::Client::connect(server).map_err(|e| format!("--display-server {server}: {e}"))?;
            let (shared, say) = (shared.clone(), say.clone());
            let image = format!("raylume {name}");
            let thread = std::thread::Builder::new()
                .name("raylume-tev".into())
                .spawn(move || crate::tev::stream(client, &image, &shared, &say))
                .map_err(|e| format!("--display-server {server}: {e}"))?;
            threads.push(thread);
        }
        let mut window = false;
        if options.preview {
            match crate::preview::open(shared.clone(), name, options.output.clone(), say.clone()) {
                Ok(thread) => {
                    threads.push(thread);
                    window = true;
                }
                Err(why) => say(&format!("raylume: --preview: no display ({why}); rendering without the window")),
            }
        }
        Ok(Some(Display { shared, threads, window, say }))
    }

    /// Shows the image after a pass: `film` is the whole image so far (all passes), of `spp`
    /// samples per pixel after `seconds` of rendering, with the render's error estimate if it has
    /// one. Rows of later passes are not shown one by one: they hold only their pass's samples.
    pub(crate) fn show_pass(&self, film: &Film, spp: u64, seconds: f64, estimate: Option<f64>) {
        let mut frame = self.shared.frame();
        if film.pixels().len() != frame.pixels.len() {
            return;
        }
        frame.pixels.copy_from_slice(film.pixels());
        frame.update += 1;
        let update = frame.update;
        frame.row_update.fill(update);
        frame.passes = true;
        frame.status.spp = spp;
        frame.status.seconds = Some(seconds);
        frame.status.estimate = estimate;
    }

    /// Whether the window was closed or Esc pressed: the render is to stop and write what it has.
    pub(crate) fn stop_requested(&self) -> bool {
        self.shared.stop_requested()
    }

    /// The image as shown: the rows finished so far (the last pass shown, once there is one),
    /// black where no row has come in yet.
    pub(crate) fn image_so_far(&self) -> Film {
        let frame = self.shared.frame();
        Film::from_pixels(self.shared.width, self.shared.height, frame.pixels.clone())
    }

    /// Ends the display once the render is over: the last image is shown (and sent), then, if the
    /// render finished with the window open, the window stays until it is closed or Esc is pressed.
    pub(crate) fn finish(self) {
        self.shared.frame().status.done = true;
        self.shared.over.store(true, Ordering::Release);
        if self.window && !self.shared.stop_requested() {
            (self.say)("raylume: the image is in the preview window; close it (or press Esc) to exit");
        }
        for thread in self.threads {
            let _ = thread.join();
        }
    }
}

impl Observer for &Display {
    fn rows_done(&self, first_row: u32, width: u32, pixels: &[Vec3]) {
        (**self).rows_done(first_row, width, pixels)
    }

    fn cancelled(&self) -> bool {
        (**self).cancelled()
    }
}

impl Observer for Display {
    fn rows_done(&self, first_row: u32, width: u32, pixels: &[Vec3]) {
        if width != self.shared.width || width == 0 {
            return;
        }
        let rows = (pixels.len() / width as usize) as u32;
        let start = first_row as usize * width as usize;
        let mut frame = self.shared.frame();
        let end = start + pixels.len();
        if frame.passes || end > frame.pixels.len() {
            return;
        }
        frame.pixels[start..end].copy_from_slice(pixels);
        frame.update += 1;
        let update = frame.update;
        frame.row_update[first_row as usize..(first_row + rows) as usize].fill(update);
        frame.status.rows += rows;
    }

    /// A window closed during the first pass stops it at once (its rows done are the image); after
    /// a pass has been shown, the render stops at the end of the pass instead.
    fn cancelled(&self) -> bool {
        self.shared.stop_requested() && !self.shared.frame().passes
    }
}

/// The 8-bit value of a colour channel, as [`Film::to_rgb8`] (and so the PNG output) makes it.
pub(crate) fn to_u8(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.99).floor().min(255.0) as u8
}

/// The title of the window: the output's name and the status.
pub(crate) fn title(name: &str, status: &Status, height: u32, elapsed: f64, stopping: bool) -> String {
    let mut t = format!("raylume: {name}: ");
    if status.seconds.is_none() {
        t += &format!("{}/{height} rows, {} spp, {elapsed:.1} s", status.rows, status.spp);
    } else {
        t += &format!("{} spp, {:.1} s", status.spp, status.seconds.unwrap_or(elapsed));
    }
    if let Some(e) = status.estimate {
        t += &format!(", error {e:.4}");
    }
    if stopping {
        t += " (stopping)";
    } else if status.done {
        t += " (done: close or Esc to exit)";
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn display(width: u32, height: u32) -> Display {
        let options = DisplayOptions { preview: false, server: None, output: "x.png".into() };
        assert!(Display::start(&options, width, height, 1, Arc::new(|_: &str| {})).unwrap().is_none());
        let frame = Frame {
            pixels: vec![Vec3::ZERO; (width * height) as usize],
            row_update: vec![0; height as usize],
            update: 0,
            passes: false,
            status: Status { rows: 0, spp: 1, seconds: None, estimate: None, done: false },
        };
        let shared = Arc::new(Shared {
            width,
            height,
            start: Instant::now(),
            frame: Mutex::new(frame),
            stop: AtomicBool::new(false),
            over: AtomicBool::new(false),
        });
        Display { shared, threads: Vec::new(), window: false, say: Arc::new(|_: &str| {}) }
    }

    #[test]
    fn the_8_bit_values_are_the_films() {
        let values: Vec<f32> = (-20..1300).map(|i| i as f32 / 1000.0).chain([f32::NAN, 1e9, -1e9]).collect();
        let film = Film::from_pixels(values.len() as u32, 1, values.iter().map(|&v| Vec3::splat(v)).collect());
        let ours: Vec<u8> = values.iter().flat_map(|&v| [to_u8(v); 3]).collect();
        assert_eq!(ours, film.to_rgb8());
    }

    #[test]
    fn rows_reach_each_reader_once_and_passes_replace_them() {
        let d = display(3, 4);
        let mut mirror = vec![Vec3::ZERO; 12];
        let mut seen = 0;
        d.rows_done(1, 3, &[Vec3::ONE; 6]);
        let (rows, status) = d.shared.changes(&mut mirror, &mut seen);
        assert_eq!(rows, [1, 2]);
        assert_eq!(status.rows, 2);
        assert_eq!(&mirror[3..9], &[Vec3::ONE; 6]);
        assert_eq!(mirror[0], Vec3::ZERO);
        assert!(d.shared.changes(&mut mirror, &mut seen).0.is_empty(), "nothing new");
        d.rows_done(0, 3, &[Vec3::splat(0.5); 3]);
        assert_eq!(d.shared.changes(&mut mirror, &mut seen).0, [0]);
        let film = Film::from_pixels(3, 4, vec![Vec3::splat(0.25); 12]);
        d.show_pass(&film, 16, 2.0, Some(0.01));
        d.rows_done(3, 3, &[Vec3::ONE; 3]);
        let (rows, status) = d.shared.changes(&mut mirror, &mut seen);
        assert_eq!(rows, [0, 1, 2, 3]);
        assert_eq!(mirror, vec![Vec3::splat(0.25); 12], "rows of a later pass are left out");
        assert_eq!((status.spp, status.estimate), (16, Some(0.01)));
        assert_eq!(d.image_so_far().pixels(), film.pixels());
    }

    #[test]
    fn a_stop_request_cancels_the_render() {
        let d = display(2, 2);
        assert!(!d.cancelled());
        d.shared.request_stop();
        assert!(d.cancelled() && d.stop_requested());
    }

    #[test]
    fn the_title_tells_rows_samples_time_and_error() {
        let mut s = Status { rows: 7, spp: 4, seconds: None, estimate: None, done: false };
        assert_eq!(title("out.png", &s, 40, 1.26, false), "raylume: out.png: 7/40 rows, 4 spp, 1.3 s");
        s.seconds = Some(3.0);
        s.estimate = Some(0.0123);
        s.done = true;
        assert_eq!(
            title("a.png", &s, 40, 9.0, false),
            "raylume: a.png: 4 spp, 3.0 s, error 0.0123 (done: close or Esc to exit)"
        );
        assert!(title("a.png", &s, 40, 9.0, true).ends_with("(stopping)"));
    }
}
