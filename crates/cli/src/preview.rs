//! The preview window (`render --preview`): the image as it renders, on a thread of its own.
//!
//! The window shows the image in 8 bits as the PNG output has it (one image pixel per screen pixel;
//! an image wider than [`MAX_WIDTH`] or taller than [`MAX_HEIGHT`] is shown every k-th pixel). Its
//! title gives the rows or samples per pixel done, the time and the error estimate. Closing it or
//! pressing Esc asks the render to stop; S writes a snapshot of what it shows beside the output.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use minifb::{Key, KeyRepeat, Window, WindowOptions};
use raylume_geometry::Vec3;
use raylume_integrator::Film;

use crate::display::{FRAME, Say, Shared, title, to_u8};

/// Widest window, in screen pixels.
pub(crate) const MAX_WIDTH: u32 = 1600;
/// Tallest window, in screen pixels.
pub(crate) const MAX_HEIGHT: u32 = 1000;

/// The longest time between two redraws of an unchanged image.
const REDRAW: Duration = Duration::from_secs(1);

/// Opens the window on a thread of its own (a window belongs to the thread that made it) and
/// returns that thread, or why no window could be opened (no display, no X11 library).
pub(crate) fn open(shared: Arc<Shared>, name: String, output: PathBuf, say: Say) -> Result<JoinHandle<()>, String> {
    let (ready, opened) = std::sync::mpsc::channel();
    let thread = std::thread::Builder::new()
        .name("raylume-preview".into())
        .spawn(move || {
            let step = shrink(shared.width, shared.height);
            let (w, h) = (shared.width.div_ceil(step) as usize, shared.height.div_ceil(step) as usize);
            let status = shared.frame().status.clone();
            let first = title(&name, &status, shared.height, 0.0, false);
            let options = WindowOptions::default();
            match Window::new(&first, w, h, options) {
                Ok(window) => {
                    let _ = ready.send(Ok(()));
                    show(window, &shared, step, &name, &output, &say);
                }
                Err(_) if std::env::var_os("DISPLAY").is_none() => {
                    let _ = ready.send(Err("DISPLAY is not set".into()));
                }
                Err(e) => {
                    let _ = ready.send(Err(e.to_string()));
                }
            }
        })
        .map_err(|e| e.to_string())?;
    match opened.recv() {
        Ok(Ok(())) => Ok(thread),
        Ok(Err(why)) => {
            let _ = thread.join();
            Err(why)
        }
        Err(_) => {
            let _ = thread.join();
            Err("the window's thread ended".into())
        }
    }
}

/// The step between the image pixels shown, so that the window fits [`MAX_WIDTH`] x [`MAX_HEIGHT`].
fn shrink(width: u32, height: u32) -> u32 {
    width.div_ceil(MAX_WIDTH).max(height.div_ceil(MAX_HEIGHT)).max(1)
}

/// The window's loop: at most one frame per [`FRAME`], until the window is closed or Esc pressed.
fn show(mut window: Window, shared: &Shared, step: u32, name: &str, output: &Path, say: &Say) {
    // The loop keeps its own pace (FRAME).
    window.set_target_fps(0);
    let (iw, ih) = (shared.width as usize, shared.height as usize);
    let (w, h) = (iw.div_ceil(step as usize), ih.div_ceil(step as usize));
    let mut mirror = vec![Vec3::ZERO; iw * ih];
    let mut buffer = vec![0u32; w * h];
    let mut seen = 0;
    let mut shown_title = String::new();
    let mut snapshots = 0;
    let mut drawn: Option<Instant> = None;
    loop {
        let tick = Instant::now();
        if !window.is_open() || window.is_key_down(Key::Escape) {
            if !shared.over() {
                shared.request_stop();
            }
            return;
        }
        if window.is_key_pressed(Key::S, KeyRepeat::No) {
            snapshots += 1;
            let path = snapshot_path(output, snapshots);
            let film = Film::from_pixels(shared.width, shared.height, mirror.clone());
            match film.write(&path) {
                Ok(()) => say(&format!("raylume: snapshot written to {}", path.display())),
                Err(e) => say(&format!("raylume: snapshot not written: {e}")),
            }
        }
        let (rows, status) = shared.changes(&mut mirror, &mut seen);
        for &r in rows.iter().filter(|&&r| r % step == 0) {
            let (src, dst) = (r as usize * iw, (r / step) as usize * w);
            for (x, px) in buffer[dst..dst + w].iter_mut().enumerate() {
                let c = mirror[src + x * step as usize];
                *px = (to_u8(c.x) as u32) << 16 | (to_u8(c.y) as u32) << 8 | to_u8(c.z) as u32;
            }
        }
        // The image goes to the X server only when it changed (and once a second, for a window
        // uncovered meanwhile); else only the window's events are read.
        let stale = drawn.is_none_or(|d| d.elapsed() >= REDRAW);
        if (!rows.is_empty() || stale) && window.update_with_buffer(&buffer, w, h).is_ok() {
            drawn = Some(Instant::now());
        } else {
            window.update();
        }
        // The title after the image: a title that says done comes with the final image shown.
        let elapsed = shared.start.elapsed().as_secs_f64();
        let t = title(name, &status, shared.height, elapsed, shared.stop_requested());
        if t != shown_title {
            window.set_title(&t);
            shown_title = t;
        }
        if let Some(rest) = FRAME.checked_sub(tick.elapsed()) {
            std::thread::sleep(rest);
        }
    }
}

/// The path of the `n`-th snapshot of `output`: `out.png` gives `out.snapshot-1.png`.
fn snapshot_path(output: &Path, n: u32) -> PathBuf {
    let stem = output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let ext = output.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "png".into());
    output.with_file_name(format!("{stem}.snapshot-{n}.{ext}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_images_are_shown_every_k_th_pixel() {
        assert_eq!(shrink(640, 400), 1);
        assert_eq!(shrink(1600, 1000), 1);
        assert_eq!(shrink(1601, 10), 2);
        assert_eq!(shrink(4000, 3000), 3);
        assert_eq!(shrink(0, 0), 1);
    }

    #[test]
    fn snapshots_go_beside_the_output() {
        assert_eq!(snapshot_path(Path::new("r/out.exr"), 2), Path::new("r/out.snapshot-2.exr"));
        assert_eq!(snapshot_path(Path::new("img.png"), 1), Path::new("img.snapshot-1.png"));
    }
}
