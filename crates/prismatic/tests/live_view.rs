//! The live view as a user meets it: `prismatic render --preview` opened in a real browser (headless Chromium),
//! and `--display-server` speaking tev's protocol to a minimal tev written here.
//!
//! The browser test needs Debian's `chromium` (`.ci/run` installs it when missing); without it the test fails and
//! says so, unless `PRISMATIC_SKIP_BROWSER=1` asks to skip it.

use std::io::{BufRead, BufReader, Read};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod support;

fn temp_dir(name: &str) -> PathBuf {
    support::temp_dir("live", name)
}

/// A camera in a uniform grey-green sky: every pixel converges to the same colour.
const SKY: &str = r#"LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" 30
Film "rgb" "integer xresolution" 40 "integer yresolution" 30 "string filename" "sky.exr"
Sampler "independent" "integer pixelsamples" 4
Integrator "path"
WorldBegin
LightSource "infinite" "rgb L" [ 0.3 0.5 0.2 ]
"#;

/// A render that kills itself when dropped (the test's end or a failed assertion).
struct Render(Child);

impl Drop for Render {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `prismatic render` in `dir` with `args`; returns it and the preview's address (host:port), read from its
/// stderr.
fn start_preview(dir: &Path, args: &[&str]) -> (Render, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .arg("render")
        .args(args)
        .current_dir(dir)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    let render = Render(child);
    let line = lines.next().expect("the preview's address").unwrap();
    let address = line
        .strip_prefix("preview: http://")
        .and_then(|a| a.strip_suffix('/'))
        .unwrap_or_else(|| panic!("unexpected first line: {line}"));
    // Keep reading stderr so the render never blocks on a full pipe.
    std::thread::spawn(move || for _ in lines {});
    (render, address.trim().to_string())
}

/// The browser: Debian's `chromium`, headless.
fn chromium(args: &[&str]) -> Option<std::process::Output> {
    Command::new("chromium")
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--force-color-profile=srgb", "--hide-scrollbars"])
        .args(args)
        .output()
        .ok()
}

/// The value of `data-<key>` on the page's statistics element in a DOM dump.
fn stat(dom: &str, key: &str) -> u64 {
    let Some(at) = dom.find(r#"id="stats""#) else {
        let error = dom.find("ERR_").map(|i| &dom[i..(i + 40).min(dom.len())]);
        panic!("no statistics element on the page (browser error: {error:?})");
    };
    let stats = &dom[at..];
    let at = stats.find(&format!(r#"data-{key}=""#)).unwrap_or_else(|| panic!("no data-{key}")) + key.len() + 7;
    stats[at..stats[at..].find('"').unwrap() + at].parse().unwrap()
}

/// Decodes an 8-bit RGB PNG (as `prismatic` and Chromium write them): (width, pixels).
fn decode_png(bytes: &[u8]) -> (u32, Vec<[u8; 3]>) {
    let mut reader = png::Decoder::new(bytes).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let step = info.color_type.samples();
    let px = buf[..info.buffer_size()].chunks(step).map(|c| [c[0], c[1], c[2]]).collect();
    (info.width, px)
}

/// An HTTP GET of `path` on `address` (host:port), the body only.
fn get(address: &str, path: &str) -> Vec<u8> {
    use std::io::Write;
    let mut s = std::net::TcpStream::connect(address).unwrap();
    write!(s, "GET {path} HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\n\r\n").unwrap();
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let at = all.windows(4).position(|w| w == b"\r\n\r\n").unwrap() + 4;
    assert!(all.starts_with(b"HTTP/1.1 200"), "{}", String::from_utf8_lossy(&all[..at]));
    all[at..].to_vec()
}

#[test]
fn the_preview_page_shows_the_film_in_a_browser_and_its_statistics_advance() {
    if chromium(&["--version"]).is_none() {
        if std::env::var_os("PRISMATIC_SKIP_BROWSER").is_some() {
            eprintln!("skipped: no chromium, and PRISMATIC_SKIP_BROWSER is set");
            return;
        }
        panic!("this test needs Debian's chromium (apt-get install chromium; .ci/run installs it)");
    }
    let dir = temp_dir("browser");
    std::fs::write(dir.join("sky.pbrt"), SKY).unwrap();
    let (_render, address) = start_preview(&dir, &["sky.pbrt", "--time", "120", "--preview", "--quiet"]);
    let url = format!("http://{address}/");
    // Two looks at the page a while apart: the statistics must have advanced (the page polls twice a second).
    let dump = || {
        let out = chromium(&["--virtual-time-budget=3000", "--dump-dom", &url]).unwrap();
        assert!(out.status.success(), "chromium: {}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let first = dump();
    // Wait (on a loaded machine passes take longer) until the server has a newer frame, then look again.
    let version_now = || {
        let status = String::from_utf8(get(&address, "/status")).unwrap();
        let at = status.find(r#""version":"#).unwrap() + 10;
        status[at..].split(',').next().unwrap().parse::<u64>().unwrap()
    };
    let start = Instant::now();
    while version_now() <= stat(&first, "version") && start.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(200));
    }
    let second = dump();
    let (v1, v2) = (stat(&first, "version"), stat(&second, "version"));
    let (d1, d2) = (stat(&first, "done"), stat(&second, "done"));
    assert!(v1 >= 1 && v2 > v1, "frames did not advance: {v1} then {v2}");
    assert!(d2 > d1, "samples did not advance: {d1} then {d2}");
    assert!(second.contains("elapsed") && second.contains("ETA"), "{second}");

    // A screenshot: the image sits at the page's top left at one pixel per pixel, and shows the film's colour.
    let shot = dir.join("shot.png");
    let out = chromium(&[
        "--virtual-time-budget=3000",
        "--window-size=120,90",
        &format!("--screenshot={}", shot.display()),
        &url,
    ])
    .unwrap();
    assert!(out.status.success(), "chromium: {}", String::from_utf8_lossy(&out.stderr));
    let (shot_width, shot_px) = decode_png(&std::fs::read(&shot).unwrap());
    let (frame_width, frame_px) = decode_png(&get(&address, "/frame.png"));
    assert_eq!(frame_width, 40);
    for (x, y) in [(1u32, 1u32), (20, 15), (38, 28), (5, 25)] {
        let (s, f) = (shot_px[(y * shot_width + x) as usize], frame_px[(y * frame_width + x) as usize]);
        for c in 0..3 {
            assert!((s[c] as i32 - f[c] as i32).abs() <= 4, "pixel ({x}, {y}): screenshot {s:?}, frame {f:?}");
        }
    }
    // And the frame is the film's: the sky's colour (linear sRGB 0.3, 0.5, 0.2, which the spectral round trip
    // keeps to about 1%) through the default view.
    let srgb = spectral::RgbColorSpace::srgb();
    let want = film::DisplayEncoding::new(&srgb, film::View::default()).encode_8bit(&[[0.3, 0.5, 0.2]], 1);
    let s = shot_px[(15 * shot_width + 20) as usize];
    for c in 0..3 {
        assert!((s[c] as i32 - want[c] as i32).abs() <= 6, "the sky shows as {s:?}, the film's colour is {want:?}");
    }
    // Outside the image: the page's background, not the sky.
    let outside = shot_px[(85 * shot_width + 100) as usize];
    assert_eq!(outside, [0x20, 0x20, 0x20], "the page's background");
}

/// One tev packet read from `stream`: (type, payload), or `None` at the end of the stream.
fn read_packet(stream: &mut impl Read) -> Option<(u8, Vec<u8>)> {
    let mut len = [0u8; 4];
    stream.read_exact(&mut len).ok()?;
    let len = u32::from_le_bytes(len) as usize;
    let mut body = vec![0u8; len - 4];
    stream.read_exact(&mut body).unwrap();
    Some((body[0], body[1..].to_vec()))
}

/// A reader of a packet's fields.
struct Fields<'a>(&'a [u8]);

impl Fields<'_> {
    fn u8(&mut self) -> u8 {
        let v = self.0[0];
        self.0 = &self.0[1..];
        v
    }
    fn i32(&mut self) -> i32 {
        let v = i32::from_le_bytes(self.0[..4].try_into().unwrap());
        self.0 = &self.0[4..];
        v
    }
    fn i64(&mut self) -> i64 {
        let v = i64::from_le_bytes(self.0[..8].try_into().unwrap());
        self.0 = &self.0[8..];
        v
    }
    fn string(&mut self) -> String {
        let end = self.0.iter().position(|&b| b == 0).unwrap();
        let s = String::from_utf8(self.0[..end].to_vec()).unwrap();
        self.0 = &self.0[end + 1..];
        s
    }
}

/// `--display-server` against a minimal tev: one `CreateImage` with the film's size and R, G, B, then `UpdateImage`
/// v3 tiles, the last of which add up to exactly the image the render writes.
#[test]
fn the_display_server_speaks_tevs_protocol() {
    let dir = temp_dir("tev");
    std::fs::write(
        dir.join("sky.pbrt"),
        SKY.replace("xresolution\" 40", "xresolution\" 150").replace("yresolution\" 30", "yresolution\" 140"),
    )
    .unwrap();
    let tev = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = tev.local_addr().unwrap().to_string();
    let render = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .args(["render", "sky.pbrt", "--spp", "64", "-o", "out.exr", "--quiet", "--display-server", &address])
        .current_dir(&dir)
        .spawn()
        .unwrap();
    let mut render = Render(render);
    let (mut stream, _) = tev.accept().unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let (kind, create) = read_packet(&mut stream).expect("a first packet");
    assert_eq!(kind, 4, "CreateImage first");
    let mut f = Fields(&create);
    let _grab_focus = f.u8();
    assert_eq!(f.string(), "out.exr");
    let (w, h) = (f.i32() as usize, f.i32() as usize);
    assert_eq!((w, h), (150, 140));
    assert_eq!(f.i32(), 3);
    assert_eq!([f.string(), f.string(), f.string()], ["R", "G", "B"]);
    let mut image = vec![[f32::NAN; 3]; w * h];
    let mut updates = 0;
    let start = Instant::now();
    while let Some((kind, body)) = read_packet(&mut stream) {
        assert_eq!(kind, 6, "UpdateImage v3");
        let mut f = Fields(&body);
        let _grab_focus = f.u8();
        assert_eq!(f.string(), "out.exr");
        let n = f.i32() as usize;
        assert_eq!(n, 3);
        let names: Vec<String> = (0..n).map(|_| f.string()).collect();
        assert_eq!(names, ["R", "G", "B"]);
        let (x, y, tw, th) = (f.i32() as usize, f.i32() as usize, f.i32() as usize, f.i32() as usize);
        assert!(x + tw <= w && y + th <= h && tw <= 128 && th <= 128);
        let offsets: Vec<i64> = (0..n).map(|_| f.i64()).collect();
        let strides: Vec<i64> = (0..n).map(|_| f.i64()).collect();
        assert_eq!(f.0.len(), tw * th * 12);
        let data: Vec<f32> = f.0.chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        for j in 0..th {
            for i in 0..tw {
                for c in 0..3 {
                    image[(y + j) * w + x + i][c] = data[(j * tw + i) * strides[c] as usize + offsets[c] as usize];
                }
            }
        }
        updates += 1;
        assert!(start.elapsed() < Duration::from_secs(120), "the render did not end");
    }
    assert!(render.0.wait().unwrap().success(), "the render failed");
    // 150×140 in 128-pixel tiles: 4 tiles a frame, and at least the last frame.
    assert!(updates >= 4 && updates % 4 == 0, "{updates} tiles");
    let (_, _, written) = film::read_exr_rgb(&dir.join("out.exr")).unwrap();
    assert_eq!(image, written, "the last frame tev got is the image written");
}

/// Viewers cannot hurt the render: with idle connections held open, a client that disconnects in the middle of its
/// request and one that reads a frame and goes away, the render ends as usual and writes exactly the image it
/// writes without a live view. A port that is taken is an error naming it.
#[test]
fn misbehaving_viewers_change_nothing_and_a_taken_port_is_named() {
    use std::io::Write;
    let dir = temp_dir("clients");
    std::fs::write(dir.join("sky.pbrt"), SKY).unwrap();
    let plain = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .args(["render", "sky.pbrt", "--spp", "4096", "-o", "plain.exr", "--quiet"])
        .current_dir(&dir)
        .status()
        .unwrap();
    assert!(plain.success());
    let (mut render, address) =
        start_preview(&dir, &["sky.pbrt", "--spp", "4096", "-o", "live.exr", "--preview", "--quiet"]);
    let idle: Vec<std::net::TcpStream> = (0..16).map(|_| std::net::TcpStream::connect(&address).unwrap()).collect();
    let mut half = std::net::TcpStream::connect(&address).unwrap();
    half.write_all(b"GET /frame.png HTTP/1.1\r\nHost: x").unwrap();
    drop(half);
    let mut quick = std::net::TcpStream::connect(&address).unwrap();
    quick.write_all(b"GET /frame.png HTTP/1.1\r\n\r\n").unwrap();
    let mut first = [0u8; 16];
    let _ = quick.read(&mut first);
    drop(quick);
    assert!(render.0.wait().unwrap().success(), "the render failed");
    drop(idle);
    let (_, _, a) = film::read_exr_rgb(&dir.join("plain.exr")).unwrap();
    let (_, _, b) = film::read_exr_rgb(&dir.join("live.exr")).unwrap();
    assert_eq!(a, b, "the live view changed the image");

    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let out = Command::new(env!("CARGO_BIN_EXE_prismatic"))
        .args(["render", "sky.pbrt", "--spp", "4", "-o", "x.exr", "--preview-port", &port])
        .current_dir(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && !err.contains("panicked"), "{err}");
    assert!(
        err.contains(&format!("cannot serve the preview on 127.0.0.1:{port}")) && err.contains("--preview-port"),
        "{err}"
    );
    assert!(!dir.join("x.exr").exists());
}
