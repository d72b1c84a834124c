//! Watching a render: the preview window under a virtual X server (Xvfb), and the stream to tev
//! received by a test server on localhost.
//!
//! The window tests need an `Xvfb` binary (Debian's `xvfb`): without one they print why and pass,
//! except under CI (`CI` set), where they fail.

use std::io::{BufRead, BufReader, Read};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use raylume_integrator::Film;
use x11rb::connection::Connection;
use x11rb::protocol::xproto::{self, AtomEnum, ConnectionExt, EventMask, ImageFormat};
use x11rb::rust_connection::RustConnection;

fn raylume() -> Command {
    Command::new(env!("CARGO_BIN_EXE_raylume"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("raylume-display-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A virtual X server, stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Xvfb on a free display, or says why not (and fails under CI, which installs it).
fn xvfb(test: &str) -> Option<Xvfb> {
    let found =
        std::env::var_os("PATH").map(|p| std::env::split_paths(&p).any(|d| d.join("Xvfb").is_file())).unwrap_or(false);
    if !found {
        assert!(std::env::var_os("CI").is_none(), "{test}: no Xvfb binary under CI (.ci/run installs xvfb)");
        eprintln!("skipped {test}: no Xvfb binary found (apt-get install xvfb)");
        return None;
    }
    // -displayfd: Xvfb picks a free display and writes its number to stdout once it accepts clients.
    let mut child = Command::new("Xvfb")
        .args(["-displayfd", "1", "-screen", "0", "800x600x24", "-nolisten", "tcp"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let number: u32 = line.trim().parse().unwrap_or_else(|_| panic!("Xvfb printed {line:?}"));
    Some(Xvfb { child, display: format!(":{number}") })
}

/// The top-level window whose title starts with `prefix`, and the title.
fn find_window(conn: &RustConnection, prefix: &str) -> Option<(xproto::Window, String)> {
    let root = conn.setup().roots[0].root;
    let tree = conn.query_tree(root).ok()?.reply().ok()?;
    for w in tree.children {
        let Ok(cookie) = conn.get_property(false, w, AtomEnum::WM_NAME, AtomEnum::ANY, 0, 1024) else { continue };
        let Ok(name) = cookie.reply() else { continue };
        let title = String::from_utf8_lossy(&name.value).into_owned();
        if title.starts_with(prefix) {
            return Some((w, title));
        }
    }
    None
}

/// Waits (at most `limit`) for a window whose title starts with `prefix` and satisfies `ready`.
fn wait_for_window(
    conn: &RustConnection,
    prefix: &str,
    limit: Duration,
    ready: impl Fn(&str) -> bool,
) -> (xproto::Window, String) {
    let start = Instant::now();
    loop {
        if let Some((w, title)) = find_window(conn, prefix) {
            if ready(&title) {
                return (w, title);
            }
        }
        assert!(start.elapsed() < limit, "no window '{prefix}...' ready within {limit:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The window's pixels as 8-bit RGB.
fn screenshot(conn: &RustConnection, w: xproto::Window, width: u16, height: u16) -> Vec<u8> {
    let image = conn.get_image(ImageFormat::Z_PIXMAP, w, 0, 0, width, height, !0).unwrap().reply().unwrap();
    assert_eq!(image.depth, 24);
    assert_eq!(conn.setup().image_byte_order, xproto::ImageOrder::LSB_FIRST);
    // 32 bits a pixel: blue, green, red, unused.
    image.data.chunks_exact(4).flat_map(|p| [p[2], p[1], p[0]]).collect()
}

/// Closes the window as a window manager does when its close button is clicked.
fn close(conn: &RustConnection, w: xproto::Window) {
    let atom = |name: &[u8]| conn.intern_atom(false, name).unwrap().reply().unwrap().atom;
    let (protocols, delete) = (atom(b"WM_PROTOCOLS"), atom(b"WM_DELETE_WINDOW"));
    let event = xproto::ClientMessageEvent::new(32, w, protocols, [delete, 0, 0, 0, 0]);
    conn.send_event(false, w, EventMask::NO_EVENT, event).unwrap();
    conn.flush().unwrap();
}

/// Waits (at most `limit`) for `child` to end; kills it and fails if it does not.
fn wait_exit(child: &mut Child, limit: Duration) -> (i32, String) {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
            return (status.code().unwrap_or(-1), stderr);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("raylume did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn rgb8(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().into_rgb8().into_raw()
}

#[test]
fn the_preview_window_shows_the_final_image_as_written() {
    let Some(x) = xvfb("the_preview_window_shows_the_final_image_as_written") else { return };
    let dir = temp_dir("final");
    let out = dir.join("final.png");
    let mut child = raylume()
        .args(["render", "--width", "120", "--height", "80", "--spp", "16", "--threads", "2", "--preview", "-o"])
        .arg(&out)
        .env("DISPLAY", &x.display)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let conn = RustConnection::connect(Some(&x.display)).unwrap().0;
    let (w, title) = wait_for_window(&conn, "raylume: final.png", Duration::from_secs(120), |t| t.contains("(done"));
    assert!(out.exists(), "the image is written before the window says done");
    assert!(title.starts_with("raylume: final.png: 16 spp, "), "{title}");
    let shown = screenshot(&conn, w, 120, 80);
    assert_eq!(shown.len(), rgb8(&out).len());
    let differ = shown.iter().zip(rgb8(&out)).filter(|(a, b)| **a != *b).count();
    assert_eq!(differ, 0, "{differ} channel values of the window differ from the PNG's");
    close(&conn, w);
    let (code, stderr) = wait_exit(&mut child, Duration::from_secs(20));
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("close it (or press Esc) to exit"), "{stderr}");
}

#[test]
fn closing_the_preview_window_mid_render_writes_the_rows_done() {
    let Some(x) = xvfb("closing_the_preview_window_mid_render_writes_the_rows_done") else { return };
    let dir = temp_dir("close");
    let out = dir.join("partial.pfm");
    let flags = ["--width", "160", "--height", "120", "--spp", "1024", "--threads", "2"];
    let mut child = raylume()
        .arg("render")
        .args(flags)
        .arg("--preview")
        .arg("-o")
        .arg(&out)
        .env("DISPLAY", &x.display)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let conn = RustConnection::connect(Some(&x.display)).unwrap().0;
    let rows_done = |t: &str| t.split(": ").nth(2).and_then(|s| s.split('/').next()?.parse::<u32>().ok());
    let (w, title) =
        wait_for_window(&conn, "raylume: partial.pfm", Duration::from_secs(120), |t| rows_done(t).unwrap_or(0) >= 8);
    assert!(rows_done(&title).unwrap() < 120, "{title}");
    close(&conn, w);
    let (code, stderr) = wait_exit(&mut child, Duration::from_secs(120));
    assert_eq!(code, 3, "{stderr}");
    assert!(stderr.contains("stopped from the preview window: wrote the rows done to"), "{stderr}");
    let partial = Film::read(&out).unwrap();
    assert_eq!((partial.width(), partial.height()), (160, 120));
    let row = |f: &Film, y: u32| (0..f.width()).map(|x| f.pixel(x, y)).collect::<Vec<_>>();
    let done: Vec<u32> = (0..120).filter(|&y| row(&partial, y).iter().any(|p| *p != glam::Vec3::ZERO)).collect();
    assert!(!done.is_empty() && done.len() < 120, "a partial image: rows {done:?} done");
    // The first run of rows done is exactly the first pass's (1024 samples are 4 passes of 256, the
    // first with the render's seed: a one-pass render of 256), and a crop renders the same pixels.
    let first = done[0];
    let end = (first..120).find(|y| !done.contains(y)).unwrap_or(120);
    let crop = dir.join("crop.pfm");
    let first_pass = ["--width", "160", "--height", "120", "--spp", "256", "--passes", "1", "--threads", "2"];
    let reference = raylume()
        .arg("render")
        .args(first_pass)
        .args(["--crop", "0", &first.to_string(), "160", &end.to_string(), "-o"])
        .arg(&crop)
        .output()
        .unwrap();
    assert!(reference.status.success(), "{}", String::from_utf8_lossy(&reference.stderr));
    let crop = Film::read(&crop).unwrap();
    for y in first..end {
        assert_eq!(row(&partial, y), row(&crop, y - first), "row {y}");
    }
    // The rows not done are black.
    let black = (0..120).filter(|y| !done.contains(y)).all(|y| row(&partial, y).iter().all(|p| *p == glam::Vec3::ZERO));
    assert!(black);
}

/// Takes the README's picture of the window mid-render (assets/preview.png) and prints its title:
/// `cargo test --release -p raylume-cli --test display -- --ignored readme`.
#[test]
#[ignore = "writes assets/preview.png for the README"]
fn readme_screenshot_of_the_window_mid_render() {
    let Some(x) = xvfb("readme_screenshot_of_the_window_mid_render") else { return };
    let dir = temp_dir("readme");
    let mut child = raylume()
        .args(["render", "--width", "320", "--height", "200", "--spp", "256", "--threads", "2", "--preview", "-o"])
        .arg(dir.join("out.png"))
        .env("DISPLAY", &x.display)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let conn = RustConnection::connect(Some(&x.display)).unwrap().0;
    let rows_done = |t: &str| t.split(": ").nth(2).and_then(|s| s.split('/').next()?.parse::<u32>().ok());
    let (w, title) =
        wait_for_window(&conn, "raylume: out.png", Duration::from_secs(300), |t| rows_done(t).unwrap_or(0) >= 112);
    let shot = screenshot(&conn, w, 320, 200);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/preview.png");
    image::RgbImage::from_raw(320, 200, shot).unwrap().save(&path).unwrap();
    println!("{}: the window titled '{title}'", path.display());
    close(&conn, w);
    let (code, stderr) = wait_exit(&mut child, Duration::from_secs(120));
    assert_eq!(code, 3, "{stderr}");
}

#[test]
fn without_a_display_the_preview_says_so_in_one_line_and_the_render_goes_on() {
    let dir = temp_dir("nodisplay");
    let out = dir.join("out.png");
    let run = raylume()
        .args(["render", "--width", "40", "--height", "25", "--preview", "-o"])
        .arg(&out)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let lines: Vec<_> = stderr.lines().filter(|l| l.contains("--preview")).collect();
    assert_eq!(lines, ["raylume: --preview: no display (DISPLAY is not set); rendering without the window"]);
    assert!(out.exists());
}

/// A message of tev's protocol, as a test server reads it.
#[derive(Debug)]
enum Message {
    Close(String),
    Create { name: String, width: i32, height: i32, channels: Vec<String> },
    Update { name: String, channels: Vec<String>, x: i32, y: i32, width: i32, height: i32, rgb: Vec<[f32; 3]> },
}

/// Reads the fields of one message (its length already read).
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        let (a, b) = self.0.split_at(n);
        self.0 = b;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn str(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).expect("a NUL-terminated string");
        let s = String::from_utf8(self.take(end).to_vec()).unwrap();
        self.take(1);
        s
    }
}

fn parse(body: &[u8]) -> Message {
    let mut f = Fields(body);
    match f.u8() {
        2 => Message::Close(f.str()),
        4 => {
            let _focus = f.u8();
            let name = f.str();
            let (width, height, n) = (f.i32(), f.i32(), f.i32());
            Message::Create { name, width, height, channels: (0..n).map(|_| f.str()).collect() }
        }
        6 => {
            let _focus = f.u8();
            let name = f.str();
            let n = f.i32() as usize;
            let channels = (0..n).map(|_| f.str()).collect();
            let (x, y, width, height) = (f.i32(), f.i32(), f.i32(), f.i32());
            let offsets: Vec<i64> = (0..n).map(|_| f.i64()).collect();
            let strides: Vec<i64> = (0..n).map(|_| f.i64()).collect();
            let data: Vec<f32> = f.0.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
            let pixels = (width * height) as usize;
            let at = |c: usize, i: usize| data[(offsets[c] + i as i64 * strides[c]) as usize];
            let rgb = (0..pixels).map(|i| [at(0, i), at(1, i), at(2, i)]).collect();
            Message::Update { name, channels, x, y, width, height, rgb }
        }
        t => panic!("unexpected message type {t}"),
    }
}

/// Accepts one connection on `listener` and reads its messages until it is closed.
fn receive(listener: TcpListener) -> Vec<Message> {
    let (mut stream, _) = listener.accept().unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
    let mut messages = Vec::new();
    loop {
        let mut len = [0u8; 4];
        match stream.read_exact(&mut len) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => return messages,
            Err(e) => panic!("{e}"),
        }
        let len = u32::from_le_bytes(len) as usize;
        let mut body = vec![0; len - 4];
        stream.read_exact(&mut body).unwrap();
        messages.push(parse(&body));
    }
}

#[test]
fn a_tev_server_receives_the_image_as_it_renders_and_rebuilds_it_exactly() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || receive(listener));
    let dir = temp_dir("tev");
    let out = dir.join("streamed.pfm");
    let run = raylume()
        .args(["render", "--width", "96", "--height", "64", "--spp", "256", "--threads", "2"])
        .args(["--display-server", &address, "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let messages = server.join().unwrap();
    let name = "raylume streamed.pfm";
    assert!(matches!(&messages[0], Message::Close(n) if n == name), "{:?}", messages[0]);
    match &messages[1] {
        Message::Create { name: n, width: 96, height: 64, channels } if n == name => {
            assert_eq!(channels, &["R", "G", "B"])
        }
        other => panic!("expected CreateImage of 96 x 64, got {other:?}"),
    }
    let mut image = vec![[f32::NAN; 3]; 96 * 64];
    let mut updates = 0;
    for m in &messages[2..] {
        let Message::Update { name: n, channels, x, y, width, height, rgb } = m else { panic!("{m:?}") };
        assert_eq!(n, name);
        assert_eq!(channels, &["R", "G", "B"]);
        assert!(*x >= 0 && *y >= 0 && x + width <= 96 && y + height <= 64, "{x} {y} {width} {height}");
        for r in 0..*height {
            for c in 0..*width {
                image[((y + r) * 96 + x + c) as usize] = rgb[(r * width + c) as usize];
            }
        }
        updates += 1;
    }
    assert!(updates >= 2, "the image came in {updates} update(s), not as it rendered");
    let film = Film::read(&out).unwrap();
    let written: Vec<[f32; 3]> = film.pixels().iter().map(|p| p.to_array()).collect();
    let bits = |v: &[[f32; 3]]| v.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
    assert!(bits(&image) == bits(&written), "the image rebuilt from tev's messages differs from the output");
}

#[test]
fn a_display_server_that_goes_away_leaves_the_render_going_on() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    // The viewer reads the first message, then closes the connection.
    let server = std::thread::spawn(move || {
        let (mut stream, _) = listener.accept().unwrap();
        let mut first = [0u8; 5];
        stream.read_exact(&mut first).unwrap();
        first[4]
    });
    let dir = temp_dir("gone");
    let out = dir.join("out.png");
    let run = raylume()
        .args(["render", "--width", "96", "--height", "64", "--spp", "256", "--threads", "2"])
        .args(["--display-server", &address, "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert_eq!(server.join().unwrap(), 2, "the first message is CloseImage");
    assert!(out.exists());
    assert!(stderr.matches("lost the connection to tev").count() <= 1, "{stderr}");
}

#[test]
fn an_unreachable_or_malformed_display_server_is_refused_before_rendering() {
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    // The listener is dropped: nothing listens on the port.
    let dir = temp_dir("refused");
    let out = dir.join("out.png");
    for (address, code, said) in [
        (
            format!("127.0.0.1:{port}"),
            1,
            format!("--display-server 127.0.0.1:{port}: cannot connect to 127.0.0.1:{port}"),
        ),
        ("localhost".to_owned(), 2, "--display-server localhost: expected HOST:PORT".to_owned()),
        ("localhost:0".to_owned(), 2, "--display-server localhost:0: expected a port in 1..=65535".to_owned()),
    ] {
        let run = raylume().args(["render", "--display-server", &address, "-o"]).arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(code), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with(&format!("raylume: error: {said}")), "{stderr}");
        assert!(!out.exists());
    }
}
