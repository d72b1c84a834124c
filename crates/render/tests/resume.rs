//! A render stopped anywhere, between passes or in the middle of one, and resumed from the state a
//! `Recorder` kept makes the image and variance of the render that never stopped, bit for bit.

use std::ops::ControlFlow;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use raylume_accel::AccelKind;
use raylume_render::{CancelToken, Recorder, RenderOptions, RenderOutput, RenderScene, RenderState};
use raylume_scene::p3f::{LoadOptions, parse};
use raylume_scene::{DEFAULT_SCENE, Scene, SceneError};

fn default_scene() -> Scene {
    parse(DEFAULT_SCENE, "default", &LoadOptions::default()).unwrap().scene
}

/// Cancels the render once `after` rows have been finished.
struct StopAfterRows {
    rows: AtomicUsize,
    after: usize,
    cancel: CancelToken,
}

impl raylume_render::Observer for StopAfterRows {
    fn row_done(&self) {
        if self.rows.fetch_add(1, Ordering::SeqCst) + 1 >= self.after {
            self.cancel.cancel();
        }
    }

    fn cancelled(&self) -> bool {
        self.cancel.is_cancelled()
    }
}

/// Renders with `options`, stopped once `after` rows (counted over all passes) are done: the state
/// the recorder kept, or the output if the render ended first.
fn stopped(scene: &Scene, options: &RenderOptions, after: usize) -> Result<RenderState, Box<RenderOutput>> {
    let (w, h) = options.resolution.unwrap();
    let [x0, y0, x1, y1] = options.settings.crop.unwrap_or([0, 0, w, h]);
    let recorder = match &options.resume {
        Some(state) => Recorder::resuming((**state).clone()),
        None => Recorder::new(x1 - x0, y1 - y0, options.pass_range.map_or(0, |r| r.0)),
    };
    let stop = StopAfterRows { rows: AtomicUsize::new(0), after, cancel: CancelToken::new() };
    let result = scene.render_progressive(options, &(recorder.clone(), stop), |p| {
        recorder.on_pass(p);
        ControlFlow::Continue(())
    });
    match result {
        Ok(out) => Err(Box::new(out)),
        Err(SceneError::Cancelled) => Ok(recorder.state()),
        Err(e) => panic!("{e}"),
    }
}

fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(f)
}

#[test]
fn a_render_stopped_anywhere_resumes_to_the_image_of_the_render_that_never_stopped() {
    let scene = default_scene();
    for (accel, spp, threads) in [(AccelKind::Bvh, 16, 1), (AccelKind::None, 16, 2), (AccelKind::Bvh, 1, 2)] {
        let options = RenderOptions {
            resolution: Some((40, 25)),
            spp: Some(spp),
            accel: Some(accel),
            ..RenderOptions::default()
        };
        let whole = scene.render(&options, &()).unwrap();
        let passes = whole.passes as usize;
        let mut stops = 0;
        // Stops before any row, in the middle of the first pass, at a pass's end and in later passes.
        for after in [1, 9, 25, 33, 60, 99] {
            let state = match on_threads(threads, || stopped(&scene, &options, after)) {
                Ok(state) => state,
                Err(_) => continue,
            };
            stops += 1;
            assert!(state.next_pass < passes as u32);
            let resumed = RenderOptions { resume: Some(Arc::new(state.clone())), ..options.clone() };
            let out = on_threads(3 - threads, || scene.render(&resumed, &())).unwrap();
            let what = format!("{accel:?}, {spp} spp, stopped after {after} rows at pass {}", state.next_pass);
            assert_eq!(out.film, whole.film, "{what}");
            assert_eq!(out.variance, whole.variance, "{what}");
            assert_eq!(out.passes, whole.passes, "{what}");
            // Only what was left is rendered again.
            let rows_left = (passes - state.next_pass as usize) * 25 - state.rows_done();
            assert!(out.stats.camera <= (rows_left * 40 * spp.div_ceil(passes as u32) as usize) as u64, "{what}");
        }
        assert!(stops >= 2, "{accel:?}, {spp} spp: stopped {stops} times");
    }
}

#[test]
fn a_resumed_render_can_stop_and_resume_again_on_a_crop_and_a_share_of_passes() {
    let scene = default_scene();
    let options = RenderOptions {
        resolution: Some((48, 30)),
        spp: Some(32),
        passes: 8,
        pass_range: Some((2, 7)),
        settings: raylume_integrator::RenderSettings { crop: Some([5, 3, 41, 27]), ..Default::default() },
        ..RenderOptions::default()
    };
    let whole = scene.render(&options, &()).unwrap();
    assert_eq!(whole.passes, 5);
    let first = stopped(&scene, &options, 30).expect("stopped in pass 3");
    assert_eq!((first.next_pass, first.rows_done() > 0), (3, true));
    let again = RenderOptions { resume: Some(Arc::new(first)), ..options.clone() };
    let second = stopped(&scene, &again, 40).expect("stopped again");
    assert!(second.next_pass >= 4, "{}", second.next_pass);
    let last = RenderOptions { resume: Some(Arc::new(second)), ..options.clone() };
    let out = scene.render(&last, &()).unwrap();
    assert_eq!((out.film, out.variance), (whole.film, whole.variance));
}

#[test]
fn a_state_of_another_render_is_refused() {
    let scene = default_scene();
    let options = RenderOptions { resolution: Some((16, 10)), spp: Some(16), ..RenderOptions::default() };
    let other_size = RenderState::new(8, 10, 0);
    let refused = scene.render(&RenderOptions { resume: Some(Arc::new(other_size)), ..options.clone() }, &());
    assert_eq!(
        refused.unwrap_err().to_string(),
        "resuming a render: the state is of another render (expected 16 x 10 pixels and a pass from 0 to 3)"
    );
    let finished = RenderState::new(16, 10, 4);
    assert!(scene.render(&RenderOptions { resume: Some(Arc::new(finished)), ..options.clone() }, &()).is_err());
    let budget =
        RenderOptions { resume: Some(Arc::new(RenderState::new(16, 10, 0))), time_limit: Some(1.0), ..options };
    assert_eq!(
        scene.render(&budget, &()).unwrap_err().to_string(),
        "resuming a render: expected no budget or adaptive sampling"
    );
}
