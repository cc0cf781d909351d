//! `penumbra explore`: a local HTTP server and one page that show a technique's images, its
//! stages and one pixel's steps, with a technique and option picker and two techniques side by
//! side.
//!
//! The server binds 127.0.0.1 only. Each connection has its own thread (at most
//! [`MAX_CONNECTIONS`] at once; past that a connection gets a 503) and two deadlines for its
//! whole life, one for the request ([`REQUEST_DEADLINE`]) and one for the answer
//! ([`ANSWER_DEADLINE`]), so a client that trickles its request or reads its answer slowly
//! holds only its own thread, and only until then. Renders run one at a time (a second
//! `/api/run` waits for the first); the page, the images, pixels and values are served while a
//! render runs. Every answer is built in memory: the page (one file, no network resources),
//! JSON, and PNGs of the current runs; no file is ever read from a request's path. A request is
//! read into a buffer of at most [`MAX_REQUEST`] bytes and parsed by `httparse`; query values
//! are checked like the CLI's (a bad pixel or option gets a 400 with the CLI's message).
//!
//! Against other web pages (DNS rebinding, cross-site requests): a request whose `Host` is not
//! the address the server printed (`127.0.0.1:PORT`, `localhost:PORT` or `[::1]:PORT`) gets a
//! 421, and one whose `Origin` is not that address over `http` gets a 403, before anything
//! runs. A render is held to the same memory budget as the command line's.

use crate::error::CliError;
use crate::scene::{self, check_pixel, parse_pixel, pixel_json, pixel_steps};
use penumbra::frame::{self, Frame};
use penumbra::image_io::encode_png;
use penumbra::pipeline::{Pipeline, Rgba8, Surface};
use penumbra::reference::ReferenceOptions;
use penumbra::report::{self, DirCache};
use penumbra::run;
use penumbra::scene::Scene;
use penumbra::shadow::{self, ShadowTechnique, Stage, Step, Value};
use penumbra::visibility::Visibility;
use rayon::prelude::*;
use serde_json::json;
use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The largest request read (request line and headers): beyond it the answer is 431.
pub const MAX_REQUEST: usize = 16 * 1024;
/// How long a connection may take to send its whole request.
pub const REQUEST_DEADLINE: Duration = Duration::from_secs(5);
/// How long a connection may take to receive its whole answer (from the end of the render).
pub const ANSWER_DEADLINE: Duration = Duration::from_secs(60);
/// Connections served at once; a connection past them gets a 503 at once.
pub const MAX_CONNECTIONS: usize = 32;
/// Bytes of a refused request read and dropped at most before the connection is closed.
const DRAIN_LIMIT: usize = 1 << 20;
/// How long the rest of a refused request is read and dropped at most.
const DRAIN_DEADLINE: Duration = Duration::from_secs(1);
/// Query parameters in one request at most.
const MAX_PARAMS: usize = 64;
/// The page.
const PAGE: &str = include_str!("explore.html");

/// What `penumbra explore` was asked for.
pub struct ExploreOpts {
    /// The scene file.
    pub scene: PathBuf,
    /// The technique shown first.
    pub technique: String,
    /// Its `key=value` settings.
    pub sets: Vec<String>,
    /// The port (0: a free one).
    pub port: u16,
    /// Worker threads.
    pub threads: usize,
    /// Where the reference cache lives.
    pub out: PathBuf,
}

/// `penumbra explore`: serves until Ctrl-C.
pub fn explore(o: ExploreOpts) -> Result<(), CliError> {
    let sets = shadow::registry::parse_sets(&o.sets)?;
    shadow::registry::create(&o.technique, &sets)?;
    let (s, text) = scene::load(&o.scene)?;
    let p = scene::pipeline(o.threads)?;
    let listener =
        TcpListener::bind(("127.0.0.1", o.port)).map_err(|e| format!("cannot listen on 127.0.0.1:{}: {e}", o.port))?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    listener
        .set_nonblocking(true)
        .map_err(|e| format!("cannot listen on {addr}: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    // The first Ctrl-C stops the server after the request in hand; a second one, during a
    // long render, exits at once.
    ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    })
    .map_err(|e| format!("cannot catch Ctrl-C: {e}"))?;
    let state = State::new(
        &p,
        &s,
        &text,
        &o.scene,
        scene::cache(&o.out),
        o.technique.clone(),
        sets,
        addr.port(),
    );
    println!("penumbra explore: {} at http://{addr}/ (Ctrl-C stops)", s.name);
    std::io::stdout().flush().ok();
    let active = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        while !stop.load(Ordering::SeqCst) {
            let stream = match listener.accept() {
                Ok((stream, _)) => stream,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(20));
                    continue;
                }
                Err(e) => {
                    eprintln!("penumbra explore: accept: {e}");
                    continue;
                }
            };
            if active.load(Ordering::SeqCst) >= MAX_CONNECTIONS {
                busy(stream);
                continue;
            }
            active.fetch_add(1, Ordering::SeqCst);
            let (state, active) = (&state, &active);
            let spawned = std::thread::Builder::new()
                .name("explore-connection".into())
                .spawn_scoped(scope, move || {
                    if let Err(e) = serve(state, stream) {
                        eprintln!("penumbra explore: {e}");
                    }
                    active.fetch_sub(1, Ordering::SeqCst);
                });
            if let Err(e) = spawned {
                active.fetch_sub(1, Ordering::SeqCst);
                eprintln!("penumbra explore: cannot start a connection's thread: {e}");
            }
        }
    });
    println!("penumbra explore: stopped");
    Ok(())
}

/// A mutex's guard, also after a thread panicked while holding it (the state it guards is
/// replaced whole, never left half-written).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Answers a connection past [`MAX_CONNECTIONS`] with a 503 (within a short deadline).
fn busy(stream: TcpStream) {
    let reply = Reply::error(
        503,
        format!("{MAX_CONNECTIONS} connections are being served: try again"),
    );
    let _ = answer(stream, &reply, Instant::now() + Duration::from_millis(200));
}

/// An answer: status, content type, body.
struct Reply {
    status: u16,
    kind: &'static str,
    body: Vec<u8>,
}

impl Reply {
    fn json(v: &serde_json::Value) -> Reply {
        Reply {
            status: 200,
            kind: "application/json",
            body: serde_json::to_vec(v).unwrap_or_default(),
        }
    }

    fn error(status: u16, message: impl Into<String>) -> Reply {
        Reply {
            status,
            kind: "application/json",
            body: serde_json::to_vec(&json!({ "error": message.into() })).unwrap_or_default(),
        }
    }
}

impl From<CliError> for Reply {
    fn from(e: CliError) -> Reply {
        Reply::error(400, e.0)
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        404 => "Not Found",
        403 => "Forbidden",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        413 => "Payload Too Large",
        421 => "Misdirected Request",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "Internal Server Error",
    }
}

/// Reads one request from `stream` (bounded in size and time), answers it (bounded in time),
/// closes the connection.
fn serve(state: &State, mut stream: TcpStream) -> std::io::Result<()> {
    stream.set_nonblocking(false)?;
    let reply = match read_request(&mut stream, Instant::now() + REQUEST_DEADLINE) {
        Ok(r) => match state.refusal(&r) {
            Some(refused) => refused,
            None if r.method == "GET" || r.method == "HEAD" => {
                let mut reply = state.route(&r.target);
                if r.method == "HEAD" {
                    reply.body.clear();
                }
                reply
            }
            None => Reply::error(405, format!("method {} is not served: GET only", r.method)),
        },
        Err(r) => r,
    };
    answer(stream, &reply, Instant::now() + ANSWER_DEADLINE)
}

/// Writes `reply` to `stream` by `deadline`, then closes the connection.
fn answer(mut stream: TcpStream, reply: &Reply, deadline: Instant) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        reply.status,
        reason(reply.status),
        reply.kind,
        reply.body.len()
    );
    write_by(&mut stream, head.as_bytes(), deadline)?;
    write_by(&mut stream, &reply.body, deadline)?;
    // Closing with unread bytes would reset the connection and lose the answer: the rest of
    // an oversized request is read and dropped (bounded in bytes and time) first.
    stream.shutdown(std::net::Shutdown::Write).ok();
    let until = Instant::now() + DRAIN_DEADLINE;
    let mut sink = [0u8; 4096];
    let mut drained = 0;
    while drained < DRAIN_LIMIT {
        let Some(left) = remaining(until) else { break };
        stream.set_read_timeout(Some(left))?;
        match stream.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => drained += n,
        }
    }
    Ok(())
}

/// The time left until `deadline` (`None` once it has passed).
fn remaining(deadline: Instant) -> Option<Duration> {
    Some(deadline.saturating_duration_since(Instant::now())).filter(|d| !d.is_zero())
}

/// Writes all of `bytes` by `deadline`: each write waits at most the time left, so a client
/// that reads slowly cannot stretch the answer past it.
fn write_by(stream: &mut TcpStream, mut bytes: &[u8], deadline: Instant) -> std::io::Result<()> {
    while !bytes.is_empty() {
        let left = remaining(deadline).ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                "the client did not take its answer in time",
            )
        })?;
        stream.set_write_timeout(Some(left))?;
        match stream.write(bytes) {
            Ok(0) => return Err(std::io::ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    stream.flush()
}

/// What the server reads of a request.
struct Request {
    method: String,
    target: String,
    /// The `Host` header, if any.
    host: Option<String>,
    /// The `Origin` header, if any.
    origin: Option<String>,
}

/// The request on `stream`, read by `deadline`, or the error answer: 408 past the deadline,
/// 431 past [`MAX_REQUEST`] bytes, 413 with a body, 400 when it does not parse.
fn read_request(stream: &mut TcpStream, deadline: Instant) -> Result<Request, Reply> {
    let late = || {
        Reply::error(
            408,
            format!("the request took longer than {} s", REQUEST_DEADLINE.as_secs()),
        )
    };
    let mut buf = vec![0u8; MAX_REQUEST];
    let mut len = 0;
    loop {
        if len == buf.len() {
            return Err(Reply::error(
                431,
                format!("the request is larger than {MAX_REQUEST} bytes"),
            ));
        }
        let left = remaining(deadline).ok_or_else(late)?;
        stream
            .set_read_timeout(Some(left))
            .map_err(|e| Reply::error(400, format!("cannot read the request: {e}")))?;
        let n = match stream.read(&mut buf[len..]) {
            Ok(0) => return Err(Reply::error(400, "the request ended before its headers did")),
            Ok(n) => n,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                return Err(late())
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Reply::error(400, format!("cannot read the request: {e}"))),
        };
        len += n;
        let mut headers = [httparse::EMPTY_HEADER; 64];
        let mut req = httparse::Request::new(&mut headers);
        match req.parse(&buf[..len]) {
            Ok(httparse::Status::Complete(_)) => {
                let has_body = req.headers.iter().any(|h| {
                    (h.name.eq_ignore_ascii_case("content-length") && h.value != b"0")
                        || h.name.eq_ignore_ascii_case("transfer-encoding")
                });
                if has_body {
                    return Err(Reply::error(413, "requests carry no body here"));
                }
                let header = |name: &str| {
                    req.headers
                        .iter()
                        .find(|h| h.name.eq_ignore_ascii_case(name))
                        .map(|h| String::from_utf8_lossy(h.value).trim().to_string())
                };
                return Ok(Request {
                    method: req.method.unwrap_or("").to_string(),
                    target: req.path.unwrap_or("/").to_string(),
                    host: header("host"),
                    origin: header("origin"),
                });
            }
            Ok(httparse::Status::Partial) => continue,
            Err(e) => return Err(Reply::error(400, format!("the request does not parse: {e}"))),
        }
    }
}

/// `%XX` and `+` decoded; `None` for a bad escape or bytes that are not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' => {
                let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
                out.push(u8::from_str_radix(hex, 16).ok()?);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            c => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// A request target's path and query parameters (in order; keys may repeat).
fn parse_target(target: &str) -> Result<(String, Vec<(String, String)>), Reply> {
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    let path = percent_decode(path).ok_or_else(|| Reply::error(400, "the path is not valid percent-encoded UTF-8"))?;
    let mut params = Vec::new();
    for pair in query.split('&').filter(|p| !p.is_empty()) {
        if params.len() == MAX_PARAMS {
            return Err(Reply::error(400, format!("more than {MAX_PARAMS} query parameters")));
        }
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        let (Some(k), Some(v)) = (percent_decode(k), percent_decode(v)) else {
            return Err(Reply::error(
                400,
                format!("query parameter '{pair}' is not valid percent-encoded UTF-8"),
            ));
        };
        params.push((k, v));
    }
    Ok((path, params))
}

fn param<'p>(params: &'p [(String, String)], key: &str) -> Option<&'p str> {
    params.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

/// The first number in a stage's name: the light view it belongs to (`depth_map3`: 3;
/// `slice1_04_optical_depth`: 1), by the stages' naming convention; `None` without one.
pub fn stage_view(name: &str) -> Option<usize> {
    let start = name.find(|c: char| c.is_ascii_digit())?;
    let digits: String = name[start..].chars().take_while(char::is_ascii_digit).collect();
    digits.parse().ok()
}

/// What a pixel's steps read in light space, for the page to mark on the stages: the texels
/// looked up (`texel`), the kernel's footprint (`width in texels`) and taps (`tap K offset`),
/// the blocker search disk (`search width in texels`), each with the light view and map size
/// the steps named before it; and a volumetric texel's curve (`node K depth`, `node K T`).
pub fn marks(steps: &[Step]) -> serde_json::Value {
    let mut view: Option<i64> = None;
    let mut size: Option<f64> = None;
    let mut at: Option<(f64, f64)> = None;
    let mut depth: Option<f64> = None;
    let mut out = Vec::new();
    let mut curve: Vec<(f64, f64)> = Vec::new();
    let mark = |kind: &str, step: &str, view, size, x: f64, y: f64, r: f64| json!({ "kind": kind, "step": step, "view": view, "size": size, "x": x, "y": y, "r": r });
    for st in steps {
        for (k, v) in &st.values {
            let num = match v {
                Value::Num(x) => Some(*x),
                Value::Int(i) => Some(*i as f64),
                Value::Vec(c) if !c.is_empty() => Some(c[0]),
                _ => None,
            };
            match (k.as_str(), v) {
                ("view", Value::Int(i)) => view = Some(*i),
                ("size", _) if num.is_some() => size = num,
                ("depth", Value::Num(d)) => depth = Some(*d),
                ("texel", Value::Vec(c)) if c.len() == 2 => {
                    at = Some((c[0], c[1]));
                    out.push(mark("texel", &st.name, view, size, c[0], c[1], 0.0));
                }
                ("search width in texels" | "width in texels", Value::Num(w)) => {
                    if let Some((x, y)) = at {
                        let kind = if k.starts_with("search") { "search" } else { "kernel" };
                        out.push(mark(kind, &st.name, view, size, x, y, w / 2.0));
                    }
                }
                (key, Value::Vec(o)) if key.starts_with("tap ") && key.ends_with(" offset") && o.len() == 2 => {
                    if let Some((x, y)) = at {
                        out.push(mark("tap", &st.name, view, size, x + o[0], y + o[1], 0.0));
                    }
                }
                (key, Value::Num(d)) if key.starts_with("node ") && key.ends_with(" depth") => {
                    curve.push((*d, f64::NAN));
                }
                (key, _) if key.starts_with("node ") && key.ends_with(" T") => {
                    if let (Some(last), Some(t)) = (curve.last_mut(), num) {
                        last.1 = t;
                    }
                }
                _ => {}
            }
        }
    }
    json!({
        "marks": out,
        "curve": curve.iter().filter(|c| c.1.is_finite()).map(|c| [c.0, c.1]).collect::<Vec<_>>(),
        "depth": depth,
    })
}

/// The range a scalar stage is shown over: the technique's `[lo, hi]` narrowed to the values
/// the stage holds, so that a depth map whose depths all lie near 1 still shows its shapes.
pub fn shown_range(data: &[f32], lo: f32, hi: f32) -> (f32, f32) {
    let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
    for &v in data.iter().filter(|v| v.is_finite()) {
        min = min.min(v);
        max = max.max(v);
    }
    let (a, b) = (lo.max(min), hi.min(max));
    if a < b {
        (a, b)
    } else {
        (lo, hi)
    }
}

/// An image of a run before encoding: name, group, pixels, the range it is shown over.
type Picture = (String, &'static str, Surface<Rgba8>, Option<(f32, f32)>);

/// An image of a run, encoded.
struct Image {
    name: String,
    /// `frame` (the camera's pixels) or `stage`.
    group: &'static str,
    w: u32,
    h: u32,
    range: Option<(f32, f32)>,
    png: Vec<u8>,
}

/// A technique's run on one frame: what the page shows and what a pixel's steps come from.
struct Run<'a> {
    gen: u64,
    technique: String,
    sets: Vec<(String, String)>,
    frame: Frame<'a>,
    t: Box<dyn ShadowTechnique>,
    v: Visibility,
    reference: Visibility,
    images: Vec<Image>,
    summary: serde_json::Value,
}

/// The server's state, shared by the connections' threads: the scene, its frames'
/// references, and the two runs shown (each behind its own lock, held while a run is read
/// or replaced, never while one renders).
struct State<'a> {
    p: &'a Pipeline,
    scene: &'a Scene,
    text: &'a str,
    path: &'a Path,
    cache: DirCache,
    references: Mutex<HashMap<usize, Visibility>>,
    runs: [Mutex<Option<Run<'a>>>; 2],
    generation: AtomicU64,
    /// Held for the whole of a render: one at a time.
    rendering: Mutex<()>,
    technique: String,
    sets: Vec<(String, String)>,
    /// The port the server listens on (the `Host` and `Origin` it answers).
    port: u16,
}

impl<'a> State<'a> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        p: &'a Pipeline,
        scene: &'a Scene,
        text: &'a str,
        path: &'a Path,
        cache: DirCache,
        technique: String,
        sets: Vec<(String, String)>,
        port: u16,
    ) -> State<'a> {
        State {
            p,
            scene,
            text,
            path,
            cache,
            references: Mutex::new(HashMap::new()),
            runs: [Mutex::new(None), Mutex::new(None)],
            generation: AtomicU64::new(0),
            rendering: Mutex::new(()),
            technique,
            sets,
            port,
        }
    }

    /// The hosts this server answers to: the loopback address and port it printed.
    fn hosts(&self) -> [String; 3] {
        let port = self.port;
        [
            format!("127.0.0.1:{port}"),
            format!("localhost:{port}"),
            format!("[::1]:{port}"),
        ]
    }

    /// The refusal of a request sent for another site: a `Host` that is not this server's
    /// (DNS rebinding: 421) or an `Origin` that is not this server's page (403). A request
    /// without either (a command-line client) is served.
    fn refusal(&self, r: &Request) -> Option<Reply> {
        let hosts = self.hosts();
        if let Some(host) = &r.host {
            if !hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) {
                return Some(Reply::error(
                    421,
                    format!(
                        "this server answers to {} only, not to Host {}",
                        hosts.join(", "),
                        penumbra::error::quoted(host)
                    ),
                ));
            }
        }
        if let Some(origin) = &r.origin {
            if !hosts
                .iter()
                .any(|h| origin.eq_ignore_ascii_case(&format!("http://{h}")))
            {
                return Some(Reply::error(
                    403,
                    format!(
                        "requests from other sites are refused (Origin {})",
                        penumbra::error::quoted(origin)
                    ),
                ));
            }
        }
        None
    }

    fn route(&self, target: &str) -> Reply {
        let (path, params) = match parse_target(target) {
            Ok(x) => x,
            Err(r) => return r,
        };
        let r = match path.as_str() {
            "/" | "/index.html" => Ok(Reply {
                status: 200,
                kind: "text/html; charset=utf-8",
                body: PAGE.as_bytes().to_vec(),
            }),
            "/api/info" => Ok(Reply::json(&self.info())),
            "/api/run" => self.run(&params).map(|v| Reply::json(&v)),
            "/api/pixel" => self.pixel(&params).map(|v| Reply::json(&v)),
            "/api/values" => self.values(&params).map(|v| Reply::json(&v)),
            p if p.starts_with("/img/") => return self.image(p),
            _ => return Reply::error(404, format!("nothing is served at '{path}'")),
        };
        r.unwrap_or_else(Reply::from)
    }

    /// The scene and the registry: techniques, their options (type, range, default), and
    /// which apply to the scene.
    fn info(&self) -> serde_json::Value {
        let techniques: Vec<_> = shadow::registry::registry()
            .iter()
            .map(|t| {
                json!({
                    "name": t.name,
                    "family": t.family.title(),
                    "summary": t.summary,
                    "applies": t.applies_to(self.scene),
                    "options": t.options.iter().map(|o| json!({
                        "key": o.key, "type": o.ty, "default": o.default, "doc": o.doc,
                        "choices": o.choices,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        json!({
            "scene": self.scene.name,
            "file": self.path.display().to_string(),
            "width": self.scene.camera.width,
            "height": self.scene.camera.height,
            "frames": self.scene.frame_count(),
            "techniques": techniques,
            "technique": self.technique,
            "settings": self.sets.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>(),
        })
    }

    fn slot(params: &[(String, String)]) -> Result<usize, CliError> {
        match param(params, "slot").unwrap_or("0") {
            "0" => Ok(0),
            "1" => Ok(1),
            s => Err(format!("slot '{s}' is not 0 or 1").into()),
        }
    }

    /// The slot's run, locked, for `read`.
    fn current<T>(
        &self,
        params: &[(String, String)],
        read: impl FnOnce(&Run<'a>) -> Result<T, CliError>,
    ) -> Result<T, CliError> {
        let slot = Self::slot(params)?;
        let run = lock(&self.runs[slot]);
        let r = run
            .as_ref()
            .ok_or_else(|| CliError::from(format!("slot {slot} has no run yet: ask /api/run first")))?;
        read(r)
    }

    /// Runs a technique on a frame into a slot: `slot`, `technique`, `set` (repeatable,
    /// `key=value`), `frame`.
    fn run(&self, params: &[(String, String)]) -> Result<serde_json::Value, CliError> {
        let slot = Self::slot(params)?;
        let _one_at_a_time = lock(&self.rendering);
        let technique = param(params, "technique").unwrap_or(&self.technique).to_string();
        let sets: Vec<String> = params
            .iter()
            .filter(|(k, _)| k == "set")
            .map(|(_, v)| v.clone())
            .collect();
        let sets = shadow::registry::parse_sets(&sets)?;
        let count = self.scene.frame_count();
        let index = match param(params, "frame") {
            None => 0,
            Some(s) => s.parse::<usize>().ok().filter(|&i| i < count).ok_or_else(|| {
                format!(
                    "frame '{s}' is not a frame of scene '{}' (0 to {})",
                    self.scene.name,
                    count - 1
                )
            })?,
        };
        let mut t = shadow::registry::create(&technique, &sets)?;
        let f = frame::frame(self.p, self.scene, 0, index)?;
        let known = lock(&self.references).get(&index).cloned();
        let reference = match known {
            Some(r) => r,
            None => {
                let key = run::reference_key(self.text, &f, 0, &ReferenceOptions::default());
                let (r, _, _) = run::reference(self.p, &f, key, Some(&self.cache))?;
                lock(&self.references).insert(index, r.clone());
                r
            }
        };
        let (v, ms) = run::time_technique(self.p, &f, t.as_mut(), false, 1)?;
        let stages = t.stages(self.p, &f)?;
        let (w, h) = (f.width(), f.height());
        let mask = f.metric_mask();
        let errors = penumbra::metrics::compare(&v, &reference, &mask);
        let mut pictures: Vec<Picture> = vec![
            ("shaded".into(), "frame", frame::shade(&f, &v), None),
            (
                "visibility".into(),
                "frame",
                report::visibility_image(&v, w, h),
                Some((0.0, 1.0)),
            ),
            (
                "reference".into(),
                "frame",
                report::visibility_image(&reference, w, h),
                Some((0.0, 1.0)),
            ),
            (
                "error".into(),
                "frame",
                report::error_image(&v, &reference, &mask, w, h),
                Some((-1.0, 1.0)),
            ),
        ];
        for st in stages {
            match st {
                Stage::Scalar { name, data, lo, hi } => {
                    let (a, b) = shown_range(data.data(), lo, hi);
                    let img = scene::false_color(&data, a, b);
                    pictures.push((name, "stage", img, Some((a, b))));
                }
                Stage::Color { name, data } => pictures.push((name, "stage", data, None)),
            }
        }
        let images = self.p.install(|| {
            pictures
                .into_par_iter()
                .map(|(name, group, img, range)| {
                    let png = encode_png(&img).map_err(|e| format!("cannot encode stage {name}: {e}"))?;
                    Ok(Image {
                        name,
                        group,
                        w: img.width(),
                        h: img.height(),
                        range,
                        png,
                    })
                })
                .collect::<Result<Vec<_>, String>>()
        })?;
        let gen = self.generation.fetch_add(1, Ordering::SeqCst) + 1;
        let settings: Vec<String> = sets.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let sets_args: String = settings.iter().map(|s| format!(" --set {s}")).collect();
        let summary = json!({
            "slot": slot,
            "gen": gen,
            "technique": technique,
            "settings": settings,
            "label": run::label(&technique, &run::settings_text(&sets)),
            "frame": index,
            "width": w,
            "height": h,
            "ms": ms,
            "errors": {
                "rmse": errors.rmse, "mae": errors.mae, "wrong_pct": errors.wrong_pct,
                "penumbra_rmse": errors.penumbra_rmse, "penumbra_pixels": errors.penumbra_pixels,
                "pixels": errors.pixels,
            },
            "timings": t.timings(),
            "counters": t.counters(),
            "notes": t.notes(),
            "inspect": format!("penumbra inspect {} --technique {technique}{sets_args} --pixel X,Y --json", self.path.display()),
            "images": images.iter().enumerate().map(|(k, im)| json!({
                "name": im.name,
                "group": im.group,
                "width": im.w,
                "height": im.h,
                "lo": im.range.map(|r| r.0),
                "hi": im.range.map(|r| r.1),
                "view": stage_view(&im.name),
                "url": format!("/img/{slot}/{gen}/{k}.png"),
            })).collect::<Vec<_>>(),
        });
        *lock(&self.runs[slot]) = Some(Run {
            gen,
            technique,
            sets,
            frame: f,
            t,
            v,
            reference,
            images,
            summary: summary.clone(),
        });
        Ok(summary)
    }

    /// One pixel's steps in a slot's run (`inspect --json`'s document) and what they read.
    fn pixel(&self, params: &[(String, String)]) -> Result<serde_json::Value, CliError> {
        self.current(params, |r| {
            let (x, y) = parse_pixel(param(params, "pixel").unwrap_or(""))?;
            check_pixel(&r.frame, x, y)?;
            let steps = pixel_steps(&r.frame, r.t.as_ref(), &r.v, x, y);
            let mut doc = pixel_json(&self.scene.name, &r.technique, &r.sets, x, y, &steps);
            doc["read"] = marks(&steps);
            doc["gen"] = json!(r.gen);
            doc["frame"] = r.summary["frame"].clone();
            Ok(doc)
        })
    }

    /// A slot's visibility or reference values, row-major (`null` where no geometry).
    fn values(&self, params: &[(String, String)]) -> Result<serde_json::Value, CliError> {
        self.current(params, |r| {
            let v = match param(params, "name").unwrap_or("visibility") {
                "visibility" => &r.v,
                "reference" => &r.reference,
                other => return Err(format!("values '{other}' are not visibility or reference").into()),
            };
            let n = (r.frame.width() * r.frame.height()) as usize;
            let values: Vec<Option<f32>> = (0..n)
                .map(|i| Some(v.value(i)).filter(|x| x.is_finite() && r.frame.points()[i].is_some()))
                .collect();
            Ok(json!({ "gen": r.gen, "width": r.frame.width(), "height": r.frame.height(), "values": values }))
        })
    }

    /// `/img/SLOT/GEN/K.png`: image K of the slot's current run (404 for any other path, or a
    /// run that has been replaced).
    fn image(&self, path: &str) -> Reply {
        let parts: Vec<&str> = path.trim_start_matches("/img/").split('/').collect();
        let found = (|| {
            let [slot, gen, file] = parts.as_slice() else {
                return None;
            };
            let slot: usize = slot.parse().ok().filter(|&s| s < 2)?;
            let gen: u64 = gen.parse().ok()?;
            let k: usize = file.strip_suffix(".png")?.parse().ok()?;
            let run = lock(&self.runs[slot]);
            let r = run.as_ref().filter(|r| r.gen == gen)?;
            r.images.get(k).map(|im| im.png.clone())
        })();
        match found {
            Some(png) => Reply {
                status: 200,
                kind: "image/png",
                body: png,
            },
            None => Reply::error(404, format!("no image at '{path}' (runs replace their images)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stage_views_are_the_first_number() {
        assert_eq!(stage_view("depth_map3"), Some(3));
        assert_eq!(stage_view("slice1_04_optical_depth"), Some(1));
        assert_eq!(stage_view("encoded12_m2"), Some(12));
        assert_eq!(stage_view("penumbra_texels"), None);
    }

    #[test]
    fn stages_are_shown_over_the_values_they_hold() {
        assert_eq!(shown_range(&[0.999, 1.0, f32::NAN], 0.0, 1.0), (0.999, 1.0));
        assert_eq!(shown_range(&[-5.0, 9.0], 0.0, 1.0), (0.0, 1.0));
        assert_eq!(shown_range(&[0.5, 0.5], 0.0, 1.0), (0.0, 1.0));
        assert_eq!(shown_range(&[], 0.0, 2.0), (0.0, 2.0));
    }

    #[test]
    fn percent_decoding_refuses_bad_escapes() {
        assert_eq!(percent_decode("filter%3Dtent+x").as_deref(), Some("filter=tent x"));
        assert_eq!(percent_decode("%zz"), None);
        assert_eq!(percent_decode("%4"), None);
        assert_eq!(percent_decode("%ff%fe"), None);
    }

    #[test]
    fn too_many_parameters_are_refused() {
        let q: Vec<String> = (0..=MAX_PARAMS).map(|i| format!("a{i}=1")).collect();
        let r = parse_target(&format!("/api/run?{}", q.join("&")))
            .err()
            .map(|r| r.status);
        assert_eq!(r, Some(400));
    }

    #[test]
    fn marks_follow_the_view_and_the_texel() {
        let steps = vec![
            Step::new("maps", "").int("size", 512),
            Step::new("light view", "").int("view", 2),
            Step::new("light-space position", "")
                .vec2("texel", glam::Vec2::new(10.5, 20.25))
                .num("depth", 0.5),
            Step::new("kernel", "")
                .num("width in texels", 4.0)
                .vec2("tap 0 offset", glam::Vec2::new(1.0, -1.0)),
            Step::new("curve", "")
                .num("node 0 depth", 0.25)
                .vec3("node 0 T", glam::Vec3::splat(0.5))
                .num("node 1 depth", 0.75)
                .num("node 1 T", 0.0),
        ];
        let m = marks(&steps);
        let kinds: Vec<&str> = m["marks"]
            .as_array()
            .unwrap()
            .iter()
            .map(|k| k["kind"].as_str().unwrap())
            .collect();
        assert_eq!(kinds, ["texel", "kernel", "tap"]);
        assert_eq!(m["marks"][0]["view"], 2);
        assert_eq!(m["marks"][0]["size"], 512.0);
        assert_eq!(m["marks"][1]["r"], 2.0);
        assert_eq!(m["marks"][2]["x"], 11.5);
        assert_eq!(m["curve"], json!([[0.25, 0.5], [0.75, 0.0]]));
        assert_eq!(m["depth"], 0.5);
    }
}
