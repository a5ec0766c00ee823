//! The live view of a render: a page the binary serves on 127.0.0.1 (`--preview`), which shows the image as it
//! converges through the display view with samples, elapsed time and ETA, and pbrt-v4's `--display-server`, which
//! sends the linear image to a running tev (its TCP protocol: `CreateImage`, then `UpdateImage` v3 tiles).
//!
//! The render never waits for a viewer. After a pass, the render thread copies the film's RGB into a [`Frame`]
//! when an update is due and swaps it into shared state (a pointer swap under a lock); encoding PNGs for the page
//! and sending tiles to tev happen on their own threads, from the latest frame, and a client that is slow or gone
//! only delays itself. Updates are spaced so that copying and encoding stay a small share of the render: at least
//! [`MIN_INTERVAL`] apart and at least [`COST_FACTOR`] times their own measured cost.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use spectral::RgbColorSpace;

/// The page, served as it is (no external resources).
const PAGE: &str = include_str!("preview.html");
/// The shortest time between two updates.
pub const MIN_INTERVAL: Duration = Duration::from_millis(500);
/// Updates are spaced by at least this many times what the last one cost: the copy (render thread, wall time) plus
/// the encoding (one viewer thread, its CPU time where the system says, else wall time). The encoding takes CPU
/// from a render on N cores for about cost/N of wall time, so the live view slows a 2-core render by at most
/// 1/(2·COST_FACTOR) ≈ 1.7% (less on more cores), plus the copy's own 1/COST_FACTOR of a short stall.
pub const COST_FACTOR: u32 = 30;
/// A request head larger than this is refused.
const MAX_REQUEST: usize = 8192;
/// Connections answered at once; more are closed at once (each holds a thread until it ends or times out).
const MAX_CLIENTS: usize = 64;
/// Tile size of tev updates (tev's own Python client uses the same).
const TEV_TILE: u32 = 128;

/// One published state of the film and the render's progress.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Linear RGB in the film's colour space, row-major from the top.
    pub rgb: Arc<Vec<[f32; 3]>>,
    /// Size in pixels.
    pub width: u32,
    /// Size in pixels.
    pub height: u32,
    /// How far the render had come.
    pub progress: Progress,
    /// Increases with every frame.
    pub version: u64,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A viewer thread that panicked leaves its state as it was; the data is still whole.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// What the render thread and the viewer threads share.
struct Shared {
    frame: Mutex<Option<Frame>>,
    /// The film's colour space (the source of the display transform).
    color_space: RgbColorSpace,
    /// The last PNG encoded: (frame version, view, exposure) and its bytes, so a frame is encoded once per view.
    png: Mutex<Option<(String, Arc<Vec<u8>>)>>,
    /// What PNG encoding has cost.
    encoding: Mutex<EncodingCost>,
}

/// What PNG encoding has cost: the last encoding (for spacing updates) and all of them (for the account).
#[derive(Clone, Copy, Debug, Default)]
struct EncodingCost {
    last: Duration,
    count: u32,
    total: Duration,
}

/// The frames waiting for the tev sender: the latest only (a slow connection skips frames, never the render).
struct TevQueue {
    latest: Mutex<Option<Frame>>,
    ready: Condvar,
}

/// The live view of one render: the page's server and the tev sender, if asked for.
pub struct LiveView {
    shared: Arc<Shared>,
    tev: Option<(Arc<TevQueue>, JoinHandle<()>)>,
    last: Option<Instant>,
    copy_cost: Duration,
    copy_total: Duration,
    version: u64,
}

impl LiveView {
    /// Starts the page's server on 127.0.0.1:`port` (0: any free port; the address is printed) when `port` is
    /// given, and the tev sender to `display_server` (`host:port`) when that is. `image_name` names the image in tev.
    /// A port that cannot be bound is an error naming it.
    pub fn start(
        port: Option<u16>,
        display_server: Option<&str>,
        color_space: RgbColorSpace,
        image_name: &str,
    ) -> Result<Self> {
        let shared = Arc::new(Shared {
            frame: Mutex::new(None),
            color_space,
            png: Mutex::new(None),
            encoding: Mutex::new(EncodingCost::default()),
        });
        if let Some(port) = port {
            let listener = TcpListener::bind(("127.0.0.1", port)).with_context(|| {
                format!("cannot serve the preview on 127.0.0.1:{port} (choose another port with --preview-port)")
            })?;
            let addr = listener.local_addr().context("the preview's address")?;
            eprintln!("preview: http://{addr}/");
            let shared = Arc::clone(&shared);
            std::thread::Builder::new()
                .name("preview".into())
                .spawn(move || serve(listener, shared))
                .context("cannot start the preview server")?;
        }
        let tev = match display_server {
            None => None,
            Some(address) => {
                let queue = Arc::new(TevQueue { latest: Mutex::new(None), ready: Condvar::new() });
                let (q, address, name) = (Arc::clone(&queue), address.to_string(), image_name.to_string());
                let handle = std::thread::Builder::new()
                    .name("display-server".into())
                    .spawn(move || send_to_tev(&address, &name, &q))
                    .context("cannot start the display-server sender")?;
                Some((queue, handle))
            }
        };
        Ok(Self { shared, tev, last: None, copy_cost: Duration::ZERO, copy_total: Duration::ZERO, version: 0 })
    }

    /// Whether an update is due: the first one, or [`MIN_INTERVAL`] and [`COST_FACTOR`] times the last update's
    /// cost since the last.
    pub fn due(&self) -> bool {
        let Some(last) = self.last else { return true };
        let cost = self.copy_cost + lock(&self.shared.encoding).last;
        last.elapsed() >= MIN_INTERVAL.max(cost * COST_FACTOR)
    }

    /// Publishes the film's current image and the progress (`done` of `total` passes of `unit`) to the viewers.
    pub fn publish(&mut self, film: &film::Film, progress: Progress) {
        let start = Instant::now();
        let rgb = Arc::new(film.to_rgb_image());
        self.version += 1;
        let bounds = film.bounds();
        let frame = Frame { rgb, width: bounds.width(), height: bounds.height(), progress, version: self.version };
        if let Some((queue, _)) = &self.tev {
            *lock(&queue.latest) = Some(frame.clone());
            queue.ready.notify_one();
        }
        *lock(&self.shared.frame) = Some(frame);
        self.copy_cost = start.elapsed();
        self.copy_total += self.copy_cost;
        self.last = Some(Instant::now());
    }

    /// Publishes the last frame, waits until tev has it (each write is bounded by a timeout), and says what the
    /// live view cost: frames, time copying the film (render thread) and encoding PNGs (viewer threads).
    pub fn finish(mut self, film: &film::Film, progress: Progress) -> String {
        self.publish(film, Progress { finished: true, ..progress });
        if let Some((_, handle)) = self.tev.take() {
            let _ = handle.join();
        }
        let encoding = *lock(&self.shared.encoding);
        format!(
            "live view: {} frames, {:.1} ms copying the film, {} PNGs encoded in {:.1} ms of CPU",
            self.version,
            self.copy_total.as_secs_f64() * 1e3,
            encoding.count,
            encoding.total.as_secs_f64() * 1e3
        )
    }
}

/// The render's progress as a [`Frame`] reports it.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Passes done.
    pub done: u32,
    /// Passes in all, if fixed.
    pub total: Option<u32>,
    /// What a pass is.
    pub unit: &'static str,
    /// Seconds since the render started.
    pub elapsed: f64,
    /// Seconds left, when known.
    pub eta: Option<f64>,
    /// Whether the render has ended.
    pub finished: bool,
}

// ----------------------------------------------------------------------------------------------------------------
// The page
// ----------------------------------------------------------------------------------------------------------------

/// Accepts connections, each on its own thread (at most [`MAX_CLIENTS`] at once), for as long as the process lives.
fn serve(listener: TcpListener, shared: Arc<Shared>) {
    let active = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        if active.fetch_add(1, Ordering::SeqCst) >= MAX_CLIENTS {
            active.fetch_sub(1, Ordering::SeqCst);
            continue; // dropping the stream closes it
        }
        let (shared, mine) = (Arc::clone(&shared), Arc::clone(&active));
        let spawned = std::thread::Builder::new().name("preview-client".into()).spawn(move || {
            // A client that vanishes mid-answer is simply dropped.
            let _ = answer(stream, &shared);
            mine.fetch_sub(1, Ordering::SeqCst);
        });
        if spawned.is_err() {
            active.fetch_sub(1, Ordering::SeqCst);
        }
    }
}

/// Reads one request and writes its answer.
fn answer(mut stream: TcpStream, shared: &Shared) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    stream.set_write_timeout(Some(Duration::from_secs(10)))?;
    let mut head = Vec::new();
    let mut buf = [0u8; 1024];
    while !head.windows(4).any(|w| w == b"\r\n\r\n") {
        let n = stream.read(&mut buf)?;
        if n == 0 {
            return Ok(());
        }
        head.extend_from_slice(&buf[..n]);
        if head.len() > MAX_REQUEST {
            return respond(&mut stream, "431 Request Header Fields Too Large", "text/plain", b"request too large");
        }
    }
    let head = String::from_utf8_lossy(&head);
    let mut words = head.lines().next().unwrap_or("").split_whitespace();
    let (method, target) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
    if method != "GET" {
        return respond(&mut stream, "405 Method Not Allowed", "text/plain", b"only GET");
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    match path {
        "/" | "/index.html" => respond(&mut stream, "200 OK", "text/html; charset=utf-8", PAGE.as_bytes()),
        "/status" => {
            let json = status_json(lock(&shared.frame).as_ref());
            respond(&mut stream, "200 OK", "application/json", json.as_bytes())
        }
        "/frame.png" => match frame_png(shared, query) {
            Ok(Some(png)) => respond(&mut stream, "200 OK", "image/png", &png),
            Ok(None) => respond(&mut stream, "503 Service Unavailable", "text/plain", b"no pass has finished yet"),
            Err(message) => respond(&mut stream, "400 Bad Request", "text/plain", message.as_bytes()),
        },
        _ => respond(&mut stream, "404 Not Found", "text/plain", b"not found"),
    }
}

fn respond(stream: &mut TcpStream, status: &str, content_type: &str, body: &[u8]) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         Connection: close\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()
}

/// The progress as JSON (numbers, or `null` where unknown).
fn status_json(frame: Option<&Frame>) -> String {
    let Some(f) = frame else {
        return r#"{"version":0,"done":0,"total":0,"unit":"","elapsed":0,"eta":null,"finished":false}"#.into();
    };
    let p = &f.progress;
    let number = |v: Option<f64>| v.filter(|v| v.is_finite()).map_or("null".to_string(), |v| format!("{v:.3}"));
    format!(
        r#"{{"version":{},"done":{},"total":{},"unit":"{}","elapsed":{},"eta":{},"finished":{},"width":{},"height":{}}}"#,
        f.version,
        p.done,
        p.total.unwrap_or(0),
        p.unit,
        number(Some(p.elapsed)),
        number(p.eta),
        p.finished,
        f.width,
        f.height
    )
}

/// The PNG of the latest frame for the query's `view` (default `oklab`) and `exposure` (stops, default 0), encoded
/// once per frame and setting; `None` before the first frame, an error message for a bad query.
fn frame_png(shared: &Shared, query: &str) -> Result<Option<Arc<Vec<u8>>>, String> {
    let mut view = film::View::default();
    let mut exposure = 0.0f64;
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
        match key {
            "view" => {
                view = film::View::by_name(value)
                    .ok_or_else(|| format!("unknown view '{value}'; valid views: {}", film::View::NAMES.join(", ")))?
            }
            "exposure" => {
                exposure =
                    value.parse().ok().filter(|e: &f64| e.is_finite() && e.abs() <= 64.0).ok_or_else(|| {
                        format!("exposure must be a number of stops between -64 and 64, got '{value}'")
                    })?
            }
            _ => {}
        }
    }
    let Some(frame) = lock(&shared.frame).clone() else { return Ok(None) };
    let key = format!("{}/{}/{exposure}", frame.version, view.name());
    if let Some((k, png)) = lock(&shared.png).as_ref() {
        if *k == key {
            return Ok(Some(Arc::clone(png)));
        }
    }
    let start = Instant::now();
    let cpu_start = thread_cpu_time();
    // A copy only when the exposure changes the pixels.
    let scaled: Vec<[f32; 3]>;
    let pixels: &[[f32; 3]] = if exposure == 0.0 {
        &frame.rgb
    } else {
        let scale = 2f64.powf(exposure) as f32;
        scaled = frame.rgb.iter().map(|p| p.map(|c| c * scale)).collect();
        &scaled
    };
    let display = film::DisplayEncoding::new(&shared.color_space, view).for_live_view();
    let png =
        film::encode_display_png("preview", frame.width, frame.height, pixels, &display).map_err(|e| e.to_string())?;
    let png = Arc::new(png);
    let took = match (cpu_start, thread_cpu_time()) {
        (Some(a), Some(b)) if b >= a => b - a,
        _ => start.elapsed(),
    };
    {
        let mut cost = lock(&shared.encoding);
        *cost = EncodingCost { last: took, count: cost.count + 1, total: cost.total + took };
    }
    *lock(&shared.png) = Some((key, Arc::clone(&png)));
    Ok(Some(png))
}

/// The CPU time the calling thread has used, where the system says (Linux's `/proc/thread-self/schedstat`, in
/// nanoseconds): what encoding takes from the render, without the time it waits for a core the render holds.
fn thread_cpu_time() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(Duration::from_nanos(stat.split_whitespace().next()?.parse().ok()?))
}

// ----------------------------------------------------------------------------------------------------------------
// tev
// ----------------------------------------------------------------------------------------------------------------

/// A tev packet: its total length (u32, little-endian, the length field included), then type and payload.
fn tev_packet(kind: u8, payload: &[u8]) -> Vec<u8> {
    let mut p = Vec::with_capacity(5 + payload.len());
    p.extend_from_slice(&((5 + payload.len()) as u32).to_le_bytes());
    p.push(kind);
    p.extend_from_slice(payload);
    p
}

fn push_string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(s.as_bytes());
    out.push(0);
}

/// tev's `CreateImage` (type 4): grab focus, name, width, height, channel count and names.
pub fn tev_create_image(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut p = vec![1u8];
    push_string(&mut p, name);
    p.extend_from_slice(&(width as i32).to_le_bytes());
    p.extend_from_slice(&(height as i32).to_le_bytes());
    p.extend_from_slice(&3i32.to_le_bytes());
    for c in ["R", "G", "B"] {
        push_string(&mut p, c);
    }
    tev_packet(4, &p)
}

/// tev's `UpdateImage` v3 (type 6) for the tile at (x, y) of size w×h of `rgb` (the whole image, `width` wide):
/// no focus grab, name, channel count and names, the tile, each channel's offset and stride in the interleaved
/// data that follows (R, G, B per pixel, f32 little-endian).
pub fn tev_update_tile(name: &str, rgb: &[[f32; 3]], width: u32, (x, y, w, h): (u32, u32, u32, u32)) -> Vec<u8> {
    let mut p = vec![0u8];
    push_string(&mut p, name);
    p.extend_from_slice(&3i32.to_le_bytes());
    for c in ["R", "G", "B"] {
        push_string(&mut p, c);
    }
    for v in [x, y, w, h] {
        p.extend_from_slice(&(v as i32).to_le_bytes());
    }
    for offset in 0..3i64 {
        p.extend_from_slice(&offset.to_le_bytes());
    }
    for _ in 0..3 {
        p.extend_from_slice(&3i64.to_le_bytes());
    }
    for row in y..y + h {
        for col in x..x + w {
            for c in rgb[(row * width + col) as usize] {
                p.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    tev_packet(6, &p)
}

/// Sends every frame the queue holds to tev at `address`, creating the image on each new connection; a failure
/// is reported once and the next frame tries again. Returns after the last frame.
fn send_to_tev(address: &str, name: &str, queue: &TevQueue) {
    let mut connection: Option<TcpStream> = None;
    let mut warned = false;
    loop {
        let frame = {
            let mut latest = lock(&queue.latest);
            loop {
                if let Some(f) = latest.take() {
                    break f;
                }
                latest = queue.ready.wait(latest).unwrap_or_else(|e| e.into_inner());
            }
        };
        let sent = (|| -> std::io::Result<()> {
            if connection.is_none() {
                let addr: SocketAddr = address
                    .to_socket_addrs()?
                    .next()
                    .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "no address"))?;
                let mut stream = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
                stream.set_write_timeout(Some(Duration::from_secs(10)))?;
                stream.write_all(&tev_create_image(name, frame.width, frame.height))?;
                connection = Some(stream);
            }
            let stream = connection.as_mut().expect("connected above");
            for ty in (0..frame.height).step_by(TEV_TILE as usize) {
                for tx in (0..frame.width).step_by(TEV_TILE as usize) {
                    let tile = (tx, ty, TEV_TILE.min(frame.width - tx), TEV_TILE.min(frame.height - ty));
                    stream.write_all(&tev_update_tile(name, &frame.rgb, frame.width, tile))?;
                }
            }
            stream.flush()
        })();
        if let Err(e) = sent {
            connection = None;
            if !warned {
                eprintln!("warning: display server {address}: {e}; the render goes on (retrying with the next update)");
                warned = true;
            }
        }
        if frame.progress.finished {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_is_json_with_nulls_for_the_unknown() {
        assert!(status_json(None).contains(r#""version":0"#));
        let progress = Progress { done: 4, total: None, unit: "spp", elapsed: 1.5, eta: None, finished: false };
        let f = Frame { rgb: Arc::new(vec![[0.0; 3]; 6]), width: 3, height: 2, progress, version: 2 };
        let s = status_json(Some(&f));
        assert_eq!(
            s,
            r#"{"version":2,"done":4,"total":0,"unit":"spp","elapsed":1.500,"eta":null,"finished":false,"width":3,"height":2}"#
        );
    }

    #[test]
    fn tev_packets_carry_their_length_and_tiles_their_pixels() {
        let create = tev_create_image("a.exr", 5, 4);
        assert_eq!(u32::from_le_bytes(create[..4].try_into().unwrap()) as usize, create.len());
        assert_eq!(create[4], 4);
        let rgb: Vec<[f32; 3]> = (0..20).map(|i| [i as f32, 0.5, -1.0]).collect();
        let tile = tev_update_tile("a.exr", &rgb, 5, (3, 1, 2, 2));
        assert_eq!(u32::from_le_bytes(tile[..4].try_into().unwrap()) as usize, tile.len());
        // The data is the tile's pixels (8, 9, 13, 14), three floats each, at the end.
        let data: Vec<f32> =
            tile[tile.len() - 48..].chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        assert_eq!(data.iter().step_by(3).copied().collect::<Vec<_>>(), [8.0, 9.0, 13.0, 14.0]);
    }
}
