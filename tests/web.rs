//! The web page in a real browser (docs/web.md): `ci/web-build.sh` builds the page, a small
//! std::net server here hosts it (and `models/` from `FRAGTRACE_MODEL_PATH`), headless
//! Chromium (Debian's `chromium`; SwiftShader's WebGL when there is no GPU) opens it on a
//! shipped scene at 64x48, and the page POSTs its finished linear image back with the
//! passes, time and WebGL limits it met. The image must equal the f32 CPU render of the same
//! scene, camera, size and grid within the GL tests' bound (tests/gpu_backend.rs,
//! `RMSE_VS_F32`). Nothing here skips: without Chromium or the wasm toolchain it fails,
//! naming what to install (`ci/test.sh` installs both).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use fragtrace::compare::compare;
use fragtrace::image_io::Image;
use fragtrace::options::{Precision, RenderOptions};
use fragtrace::render::render_cpu;
use fragtrace::scene::load_scene;

/// The GL tests' colour RMSE bound against the f32 CPU (tests/gpu_backend.rs
/// `RMSE_VS_F32`, measured there at most 4.3e-7 on llvmpipe). Measured here: see
/// docs/web.md (SwiftShader in headless Chromium).
const RMSE_VS_F32: f64 = 2e-5;
const W: u32 = 64;
const H: u32 = 48;
/// How long the page may take: building the page is done before the browser starts;
/// SwiftShader renders the 64x48 whitted scene in a few seconds.
const PAGE_TIMEOUT: Duration = Duration::from_secs(240);

/// What the page POSTed.
enum Posted {
    Report { json: String, body: Vec<u8> },
    Error(String),
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn build_page() -> PathBuf {
    let out = root().join("target/web-test");
    let status = Command::new("bash")
        .arg(root().join("ci/web-build.sh"))
        .arg(&out)
        .status()
        .expect("run ci/web-build.sh");
    assert!(status.success(), "ci/web-build.sh failed");
    out
}

fn chromium() -> String {
    let candidates = ["chromium", "chromium-browser", "google-chrome"];
    if let Ok(c) = std::env::var("FRAGTRACE_CHROMIUM") {
        return c;
    }
    for c in candidates {
        if Command::new(c)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
        {
            return c.to_string();
        }
    }
    panic!("no Chromium ({candidates:?} or FRAGTRACE_CHROMIUM): apt-get install -y chromium");
}

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()) {
        Some("html") => "text/html",
        Some("js") => "text/javascript",
        Some("wasm") => "application/wasm",
        _ => "application/octet-stream",
    }
}

/// Answers one request: GET a file under `dir` (`/models/...` under the model path), or
/// POST the page's report to the channel.
fn serve(mut stream: TcpStream, dir: &Path, models: &[PathBuf], tx: &mpsc::Sender<Posted>) {
    let mut reader = BufReader::new(stream.try_clone().unwrap());
    let mut line = String::new();
    if reader.read_line(&mut line).is_err() {
        return;
    }
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
    let mut headers = Vec::new();
    loop {
        let mut h = String::new();
        if reader.read_line(&mut h).unwrap_or(0) == 0 || h.trim().is_empty() {
            break;
        }
        if let Some((k, v)) = h.split_once(':') {
            headers.push((k.trim().to_ascii_lowercase(), v.trim().to_string()));
        }
    }
    let header = |k: &str| headers.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    let path = target.split('?').next().unwrap_or("/");
    if method == "POST" {
        let len: usize = header("content-length")
            .and_then(|v| v.parse().ok())
            .unwrap_or(0);
        let mut body = vec![0; len];
        let _ = reader.read_exact(&mut body);
        let _ = stream.write_all(b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\n\r\n");
        let posted = match (header("x-fragtrace-report"), header("x-fragtrace-error")) {
            (Some(json), _) => Posted::Report { json, body },
            (None, Some(e)) => Posted::Error(e),
            (None, None) => Posted::Error(format!("a POST to {path} without a report")),
        };
        let _ = tx.send(posted);
        return;
    }
    let rel = path.trim_start_matches('/');
    let rel = if rel.is_empty() { "index.html" } else { rel };
    let file = match rel.strip_prefix("models/") {
        Some(m) => models.iter().map(|d| d.join(m)).find(|p| p.is_file()),
        None => Some(dir.join(rel)),
    };
    let reply = file
        .filter(|_| !rel.contains(".."))
        .and_then(|f| std::fs::read(&f).ok().map(|b| (b, content_type(&f))));
    let _ = match reply {
        Some((bytes, ty)) => stream
            .write_all(
                format!(
                    "HTTP/1.1 200 OK\r\nContent-Type: {ty}\r\nContent-Length: {}\r\n\
                     Connection: close\r\n\r\n",
                    bytes.len()
                )
                .as_bytes(),
            )
            .and_then(|_| stream.write_all(&bytes)),
        None => stream.write_all(b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\n\r\n"),
    };
}

/// Kills the browser's process group (it was started as its own group) when dropped.
struct Browser(Child);

impl Drop for Browser {
    fn drop(&mut self) {
        let pid = self.0.id();
        let _ = Command::new("kill")
            .args(["-KILL", "--", &format!("-{pid}")])
            .status();
        let _ = self.0.wait();
    }
}

/// Opens the page on `query` in headless Chromium and returns what it POSTed.
fn open_page(dir: &Path, query: &str, timeout: Duration) -> Posted {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let (tx, rx) = mpsc::channel();
    let models: Vec<PathBuf> = std::env::var_os("FRAGTRACE_MODEL_PATH")
        .map(|v| std::env::split_paths(&v).collect())
        .unwrap_or_default();
    let dir = dir.to_path_buf();
    std::thread::spawn(move || {
        for stream in listener.incoming().flatten() {
            serve(stream, &dir, &models, &tx);
        }
    });
    let profile = std::env::temp_dir().join(format!("fragtrace-chromium-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&profile);
    let url = format!("http://127.0.0.1:{port}/index.html?{query}&report=/result");
    use std::os::unix::process::CommandExt;
    let child = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(&url)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .process_group(0)
        .spawn()
        .expect("start Chromium");
    let mut browser = Browser(child);
    // The console (errors, panics) for the failure message.
    let stderr = browser.0.stderr.take().unwrap();
    let log = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
    let sink = log.clone();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            // The page's console (its errors and panics); not Chromium's own noise (D-Bus).
            if line.contains("CONSOLE") {
                sink.lock().unwrap().push_str(&line);
                sink.lock().unwrap().push('\n');
            }
        }
    });
    let posted = rx.recv_timeout(timeout);
    drop(browser);
    let _ = std::fs::remove_dir_all(&profile);
    posted.unwrap_or_else(|_| {
        panic!(
            "the page ({url}) posted nothing within {timeout:?}; browser log:\n{}",
            log.lock().unwrap()
        )
    })
}

fn json_number(json: &str, key: &str) -> f64 {
    let at = json
        .find(&format!("\"{key}\":"))
        .unwrap_or_else(|| panic!("{key} missing in {json}"));
    let rest = &json[at + key.len() + 3..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    rest[..end]
        .trim()
        .parse()
        .unwrap_or_else(|_| panic!("{key} in {json}"))
}

/// The default scene in bands of 16 rows (three renders of the whole walk) on `query`'s
/// context and kernel equals the f32 CPU render; the page used `dialect`.
fn page_matches_f32_cpu(query: &str, dialect: &str) {
    // One build and one browser at a time (they share target/web-test and the profile).
    static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one = ONE.lock().unwrap_or_else(|e| e.into_inner());
    let dir = build_page();
    let t = std::time::Instant::now();
    let posted = open_page(
        &dir,
        &format!("scene=whitted&size={W}x{H}&band=16&{query}"),
        PAGE_TIMEOUT,
    );
    let wall = t.elapsed();
    let (json, body) = match posted {
        Posted::Report { json, body } => (json, body),
        Posted::Error(e) => panic!("the page failed: {e}"),
    };
    println!("page report ({wall:.1?} from browser start): {json}");
    assert!(
        json.contains(&format!("\"dialect\":\"{dialect}\"")),
        "{json}"
    );
    assert_eq!(body.len(), (W * H * 3 * 4) as usize, "image bytes");
    let data: Vec<f32> = body
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let web = Image::from_rgb(W, H, data);
    // Multipass: thousands of passes; looped: a few per wave.
    assert!(json_number(&json, "passes") > 10.0, "{json}");
    assert!(json_number(&json, "max_draw_buffers") >= 4.0, "{json}");

    let scene = load_scene(&root().join("scenes/whitted.toml")).unwrap();
    let mut o = RenderOptions::for_scene(&scene);
    o.width = W;
    o.height = H;
    o.precision = Precision::F32;
    let cpu = render_cpu(&scene, &o).unwrap();
    let c = compare(&web, &cpu.image, 0.02, true).unwrap();
    println!(
        "web vs f32 CPU: RMSE {:.3e}, {:.2}% of pixels above 0.02",
        c.rmse,
        c.share_above * 100.0
    );
    assert!(
        c.rmse <= RMSE_VS_F32,
        "web vs f32 CPU RMSE {:.3e} > {RMSE_VS_F32:e}",
        c.rmse
    );
}

/// The thesis's multipass kernel on WebGL 1 (GLSL ES 1.00).
#[test]
fn page_renders_whitted_like_the_f32_cpu() {
    page_matches_f32_cpu("webgl=1&kernel=multipass", "GLSL ES 1.00");
}

/// The `looped` kernel on WebGL 2 (GLSL ES 3.00).
#[test]
fn page_renders_whitted_looped_on_webgl2_like_the_f32_cpu() {
    page_matches_f32_cpu("webgl=2&kernel=looped", "GLSL ES 3.00");
}

/// The figures of docs/web.md: passes and time of the default scene and bunny.toml at
/// 512x512 (or `FRAGTRACE_WEB_FIGURE_SIZE`) in one band (the whole image per pass, as natively), and the limits the page
/// met. Needs `FRAGTRACE_MODEL_PATH` for the bunny (served as `models/`). Run with
/// `cargo test --release --test web -- --ignored --nocapture`.
#[test]
#[ignore = "minutes of software rendering; run by hand for docs/web.md"]
fn web_figures_512() {
    let dir = build_page();
    // FRAGTRACE_WEB_FIGURE_SIZE=WxH renders smaller (512x512 took 17 minutes here).
    let size = std::env::var("FRAGTRACE_WEB_FIGURE_SIZE").unwrap_or_else(|_| "512x512".into());
    // FRAGTRACE_WEB_FIGURE_SCENES=a,b picks the scenes.
    let scenes =
        std::env::var("FRAGTRACE_WEB_FIGURE_SCENES").unwrap_or_else(|_| "whitted,bunny".into());
    for scene in scenes.split(',') {
        let t = std::time::Instant::now();
        // FRAGTRACE_WEB_FIGURE_QUERY adds to the query (`webgl=2&kernel=looped`).
        let extra = std::env::var("FRAGTRACE_WEB_FIGURE_QUERY").unwrap_or_default();
        let query = format!("scene={scene}&size={size}&band=full&{extra}");
        match open_page(&dir, &query, Duration::from_secs(1800)) {
            Posted::Report { json, .. } => {
                println!(
                    "{scene}: {json} (browser start to report {:.1?})",
                    t.elapsed()
                )
            }
            Posted::Error(e) => panic!("{scene}: {e}"),
        }
    }
}
