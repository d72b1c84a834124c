//! Streaming a render to the tev image viewer (`render --display-server HOST:PORT`) over tev's
//! network protocol, as pbrt-v4 does.
//!
//! Every message is a little-endian `u32` length (of the whole message, these 4 bytes included),
//! a type byte, then its fields: strings end with a NUL byte, booleans are one byte. raylume sends
//! - CloseImage (2): the name, so that a render to the same output replaces the previous one;
//! - CreateImage (4): grab focus, the name, `i32` width and height, `i32` channel count, the channel
//!   names (`R`, `G`, `B`);
//! - UpdateImage, version 3 (6): grab focus, the name, `i32` channel count, the channel names,
//!   `i32` x, y, width, height of the block, `i64` offset and `i64` stride of each channel in the
//!   data, then the `f32` data: here RGB interleaved (offsets 0, 1, 2, strides 3), the film's linear
//!   values, row 0 at the top.

use std::io::Write;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::Duration;

use raylume_geometry::Vec3;

use crate::display::{FRAME, Say, Shared};

/// The port tev listens on by default.
pub(crate) const DEFAULT_PORT: u16 = 14158;

/// How long a connection or a send may take before the viewer is given up.
const TIMEOUT: Duration = Duration::from_secs(3);

/// Most pixels in one UpdateImage message.
const MAX_BLOCK_PIXELS: usize = 1 << 16;

const CLOSE_IMAGE: u8 = 2;
const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_V3: u8 = 6;

/// The host and port of a `HOST:PORT` (a bracketed IPv6 address, `[::1]:14158`, too), or why it is
/// not one.
///
/// ```text
/// localhost:14158 -> ("localhost", 14158)
/// ```
pub(crate) fn parse_address(s: &str) -> Result<(String, u16), String> {
    let (host, port) = s.rsplit_once(':').ok_or("expected HOST:PORT")?;
    let host = host.strip_prefix('[').and_then(|h| h.strip_suffix(']')).unwrap_or(host);
    if host.is_empty() || host.contains(char::is_whitespace) {
        return Err("expected HOST:PORT, with a host name or address before the colon".into());
    }
    if host.contains(':') && !s.starts_with('[') {
        return Err("expected HOST:PORT (an IPv6 address in brackets: [::1]:14158)".into());
    }
    match port.parse::<u16>() {
        Ok(p) if p > 0 => Ok((host.to_owned(), p)),
        _ => Err(format!("expected a port in 1..=65535 after the colon (tev's is {DEFAULT_PORT})")),
    }
}

/// A connection to tev.
pub(crate) struct Client {
    stream: TcpStream,
}

impl Client {
    /// Connects to tev at `address` (`HOST:PORT`), or says why it could not.
    pub(crate) fn connect(address: &str) -> Result<Client, String> {
        let (host, port) = parse_address(address)?;
        let addrs: Vec<SocketAddr> =
            (host.as_str(), port).to_socket_addrs().map_err(|e| format!("cannot resolve '{host}': {e}"))?.collect();
        let mut last = format!("'{host}' has no address");
        for addr in addrs {
            match TcpStream::connect_timeout(&addr, TIMEOUT) {
                Ok(stream) => {
                    let _ = stream.set_write_timeout(Some(TIMEOUT));
                    let _ = stream.set_nodelay(true);
                    return Ok(Client { stream });
                }
                Err(e) => last = format!("cannot connect to {addr}: {e} (is tev running and listening there?)"),
            }
        }
        Err(last)
    }

    fn send(&mut self, message: &[u8]) -> std::io::Result<()> {
        self.stream.write_all(message)
    }
}

/// A message under construction: its length is filled in by [`Message::finish`].
struct Message(Vec<u8>);

impl Message {
    fn new(kind: u8) -> Self {
        let mut m = Message(vec![0; 4]);
        m.0.push(kind);
        m
    }

    fn bool(&mut self, b: bool) -> &mut Self {
        self.0.push(b as u8);
        self
    }

    fn str(&mut self, s: &str) -> &mut Self {
        // A NUL would end the string early: tev's names have none.
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }

    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn finish(&mut self) -> Vec<u8> {
        let len = self.0.len() as u32;
        self.0[..4].copy_from_slice(&len.to_le_bytes());
        std::mem::take(&mut self.0)
    }
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// The CloseImage message for image `name`.
pub(crate) fn close_image(name: &str) -> Vec<u8> {
    Message::new(CLOSE_IMAGE).str(name).finish()
}

/// The CreateImage message for an RGB image `name` of `width` x `height`.
pub(crate) fn create_image(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut m = Message::new(CREATE_IMAGE);
    m.bool(true).str(name).i32(width as i32).i32(height as i32).i32(3);
    for c in CHANNELS {
        m.str(c);
    }
    m.finish()
}

/// The UpdateImage (version 3) message that sets the block of `width` pixels by `pixels.len() /
/// width` rows at (`x`, `y`) of image `name` to `pixels`.
pub(crate) fn update_image(name: &str, x: u32, y: u32, width: u32, pixels: &[Vec3]) -> Vec<u8> {
    let height = pixels.len() / width.max(1) as usize;
    let mut m = Message::new(UPDATE_IMAGE_V3);
    m.bool(false).str(name).i32(3);
    for c in CHANNELS {
        m.str(c);
    }
    m.i32(x as i32).i32(y as i32).i32(width as i32).i32(height as i32);
    for offset in 0..3 {
        m.i64(offset);
    }
    for _ in 0..3 {
        m.i64(3);
    }
    m.0.reserve(pixels.len() * 12);
    for p in pixels {
        for v in p.to_array() {
            m.0.extend_from_slice(&v.to_le_bytes());
        }
    }
    m.finish()
}

/// Sends the render to tev until it is over: the image first (replacing one of the same name),
/// then at most [`crate::display::FRAME_HZ`] times a second the rows changed, as blocks of whole
/// rows. A failed send is said once and ends the streaming; the render goes on.
pub(crate) fn stream(mut client: Client, name: &str, shared: &Shared, say: &Say) {
    let (w, h) = (shared.width, shared.height);
    let mut mirror = vec![Vec3::ZERO; w as usize * h as usize];
    let mut seen = 0;
    let opened = client.send(&close_image(name)).and_then(|()| client.send(&create_image(name, w, h)));
    if let Err(e) = opened {
        say(&format!("raylume: --display-server: lost the connection to tev ({e}); rendering goes on"));
        return;
    }
    let rows_per_block = (MAX_BLOCK_PIXELS / w.max(1) as usize).max(1);
    loop {
        let tick = std::time::Instant::now();
        // Whether the render was over before this frame's copy: then the copy is the last image.
        let last = shared.over();
        let (rows, _) = shared.changes(&mut mirror, &mut seen);
        let mut i = 0;
        while i < rows.len() {
            // A run of consecutive rows, at most `rows_per_block` of them.
            let first = rows[i];
            let mut n = 1;
            while i + n < rows.len() && rows[i + n] == first + n as u32 && n < rows_per_block {
                n += 1;
            }
            let block = &mirror[first as usize * w as usize..(first as usize + n) * w as usize];
            if let Err(e) = client.send(&update_image(name, 0, first, w, block)) {
                say(&format!("raylume: --display-server: lost the connection to tev ({e}); rendering goes on"));
                return;
            }
            i += n;
        }
        if last {
            let _ = client.stream.flush();
            return;
        }
        if let Some(rest) = FRAME.checked_sub(tick.elapsed()) {
            std::thread::sleep(rest);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_are_host_colon_port() {
        assert_eq!(parse_address("localhost:14158").unwrap(), ("localhost".to_owned(), 14158));
        assert_eq!(parse_address("[::1]:99").unwrap(), ("::1".to_owned(), 99));
        assert_eq!(parse_address("127.0.0.1:1").unwrap(), ("127.0.0.1".to_owned(), 1));
        for bad in ["localhost", ":14158", "host:", "host:0", "host:65536", "host:x", "::1:5", "a b:1"] {
            assert!(parse_address(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn messages_are_laid_out_as_tev_reads_them() {
        let c = close_image("im");
        assert_eq!(c, [8, 0, 0, 0, 2, b'i', b'm', 0]);
        let m = create_image("im", 5, 7);
        let mut want = vec![0u8; 4];
        want.extend([4, 1, b'i', b'm', 0, 5, 0, 0, 0, 7, 0, 0, 0, 3, 0, 0, 0, b'R', 0, b'G', 0, b'B', 0]);
        want[0] = want.len() as u8;
        assert_eq!(m, want);
        let u = update_image("im", 0, 2, 2, &[Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 5.0, 6.0)]);
        let head = 4 + 1 + 1 + 3 + 4 + 6 + 16 + 48;
        assert_eq!(u.len(), head + 6 * 4);
        assert_eq!(u32::from_le_bytes(u[..4].try_into().unwrap()) as usize, u.len());
        assert_eq!(u[4], 6);
        assert_eq!(&u[13..19], b"R\0G\0B\0");
        let ints: Vec<i32> = u[19..35].chunks(4).map(|b| i32::from_le_bytes(b.try_into().unwrap())).collect();
        assert_eq!(ints, [0, 2, 2, 1]);
        let longs: Vec<i64> = u[35..83].chunks(8).map(|b| i64::from_le_bytes(b.try_into().unwrap())).collect();
        assert_eq!(longs, [0, 1, 2, 3, 3, 3]);
        let data: Vec<f32> = u[head..].chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        assert_eq!(data, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }
}
