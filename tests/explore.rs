//! `penumbra explore` on loopback: the page, the runs, a pixel's steps against `inspect
//! --json` and the image, the images, hostile requests, concurrent runs, Ctrl-C.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_penumbra");
const SCENE: &str = "fixtures/scenes/contact.toml";

/// A running server; interrupted (SIGINT) and reaped when dropped.
struct Server {
    child: Child,
    addr: String,
    out: std::path::PathBuf,
}

impl Server {
    fn start(technique: &str) -> Server {
        Server::start_with(technique, &[])
    }

    /// A server started with `extra` arguments too.
    fn start_with(technique: &str, extra: &[&str]) -> Server {
        let out = std::env::temp_dir().join(format!(
            "penumbra-explore-test-{}-{technique}-{}",
            std::process::id(),
            extra.len()
        ));
        let mut child = Command::new(BIN)
            .args([
                "explore",
                SCENE,
                "--technique",
                technique,
                "--port",
                "0",
                "--threads",
                "2",
                "--out",
            ])
            .arg(&out)
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("the binary starts");
        let mut line = String::new();
        BufReader::new(child.stdout.as_mut().unwrap())
            .read_line(&mut line)
            .unwrap();
        let url = line
            .split_whitespace()
            .find(|w| w.starts_with("http://"))
            .unwrap_or_else(|| panic!("no URL in '{line}'"));
        let addr = url.trim_start_matches("http://").trim_end_matches('/').to_string();
        assert!(addr.starts_with("127.0.0.1:"), "bound to loopback only: {addr}");
        Server { child, addr, out }
    }

    /// Sends raw bytes; returns the status and the body.
    fn raw(&self, request: &[u8]) -> (u16, Vec<u8>) {
        let mut s = TcpStream::connect(&self.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(300))).unwrap();
        // A server may answer (and close) before an oversized request is all sent.
        let _ = s.write_all(request);
        let mut buf = Vec::new();
        let _ = s.read_to_end(&mut buf);
        let text = String::from_utf8_lossy(&buf);
        let status = text.split_whitespace().nth(1).and_then(|c| c.parse().ok()).unwrap_or(0);
        let body = buf
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .map(|i| buf[i + 4..].to_vec())
            .unwrap_or_default();
        (status, body)
    }

    fn get(&self, target: &str) -> (u16, Vec<u8>) {
        self.raw(format!("GET {target} HTTP/1.1\r\nHost: {}\r\n\r\n", self.addr).as_bytes())
    }

    fn json(&self, target: &str) -> (u16, serde_json::Value) {
        let (status, body) = self.get(target);
        let v = serde_json::from_slice(&body)
            .unwrap_or_else(|e| panic!("{target}: {e}: {}", String::from_utf8_lossy(&body)));
        (status, v)
    }

    /// Ctrl-C: the server must stop and exit 0.
    fn interrupt(mut self) -> (bool, String) {
        let ok = Command::new("kill")
            .args(["-INT", &self.child.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok);
        let status = self.child.wait().unwrap();
        let mut rest = String::new();
        self.child.stdout.take().unwrap().read_to_string(&mut rest).unwrap();
        (status.success(), rest)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.out);
    }
}

fn inspect_json(technique: &str, sets: &[&str], x: u32, y: u32) -> serde_json::Value {
    let mut c = Command::new(BIN);
    c.args([
        "inspect",
        SCENE,
        "--technique",
        technique,
        "--pixel",
        &format!("{x},{y}"),
        "--json",
        "--threads",
        "2",
    ]);
    for s in sets {
        c.args(["--set", s]);
    }
    let out = c.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn cli_error(args: &[&str]) -> String {
    let out = Command::new(BIN).args(args).output().unwrap();
    assert!(!out.status.success());
    String::from_utf8_lossy(&out.stderr)
        .trim()
        .trim_start_matches("penumbra: error: ")
        .to_string()
}

/// The pixel's steps without the explorer's own keys: `inspect --json`'s document.
fn as_inspect(mut doc: serde_json::Value) -> serde_json::Value {
    let m = doc.as_object_mut().unwrap();
    for k in ["read", "gen", "frame"] {
        m.remove(k);
    }
    doc
}

#[test]
fn a_pixels_steps_are_inspects_and_its_result_is_the_image() {
    let s = Server::start("pcss");
    let (st, page) = s.get("/");
    assert_eq!(st, 200);
    let page = String::from_utf8(page).unwrap();
    assert!(page.contains("penumbra explore"));
    // One file with no network resources (the SVG namespace is a name, not a request).
    for bad in ["src=\"http", "href=\"http", "url(http", "@import"] {
        assert!(!page.contains(bad), "the page asks for a resource elsewhere: {bad}");
    }

    let (st, info) = s.json("/api/info");
    assert_eq!(st, 200);
    let names: Vec<&str> = info["techniques"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["name"].as_str().unwrap())
        .collect();
    let reg: Vec<&str> = penumbra::shadow::registry::registry().iter().map(|t| t.name).collect();
    assert_eq!(names, reg);
    assert_eq!(info["technique"], "pcss");

    for (technique, sets) in [("pcss", vec![]), ("shadow-map", vec!["filter=poisson", "size=512"])] {
        let mut q = format!("/api/run?slot=0&technique={technique}");
        for kv in &sets {
            q += &format!("&set={}", kv.replace('=', "%3D"));
        }
        let (st, run) = s.json(&q);
        assert_eq!(st, 200, "{run}");
        assert_eq!(run["technique"], technique);
        // Every image is a PNG.
        for im in run["images"].as_array().unwrap() {
            let (st, png) = s.get(im["url"].as_str().unwrap());
            assert_eq!(st, 200);
            assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{}", im["name"]);
        }
        let (_, values) = s.json("/api/values?slot=0");
        let w = values["width"].as_u64().unwrap() as u32;
        // A penumbra pixel, a lit one, a shadowed one, and one without geometry.
        let vals = values["values"].as_array().unwrap();
        let find = |f: &dyn Fn(f64) -> bool| vals.iter().position(|v| v.as_f64().is_some_and(f));
        let picks = [
            find(&|v| v > 0.1 && v < 0.9),
            find(&|v| v == 1.0),
            find(&|v| v == 0.0),
            vals.iter().position(|v| v.is_null()),
        ];
        for i in picks.into_iter().flatten() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let (st, doc) = s.json(&format!("/api/pixel?slot=0&pixel={x},{y}"));
            assert_eq!(st, 200);
            assert!(doc["read"].is_object());
            let doc = as_inspect(doc);
            assert_eq!(doc, inspect_json(technique, &sets, x, y), "{technique} at {x},{y}");
            let result = doc["steps"]
                .as_array()
                .unwrap()
                .iter()
                .find(|st| st["name"] == "result");
            match (result, vals[i].as_f64()) {
                (Some(r), Some(v)) => {
                    let shown = r["values"][0][1].as_f64().unwrap();
                    assert!(
                        (shown - v).abs() < 1e-6,
                        "{technique} at {x},{y}: steps {shown}, image {v}"
                    );
                }
                (None, None) => {}
                (r, v) => panic!("{technique} at {x},{y}: result step {r:?}, image {v:?}"),
            }
        }
    }

    // What a light-space step read is marked: the texel, and the kernel's taps.
    let (_, values) = s.json("/api/values?slot=0");
    let w = values["width"].as_u64().unwrap() as usize;
    let i = values["values"]
        .as_array()
        .unwrap()
        .iter()
        .position(|v| v.as_f64().is_some_and(|v| v > 0.1 && v < 0.9))
        .unwrap();
    let (_, doc) = s.json(&format!("/api/pixel?slot=0&pixel={},{}", i % w, i / w));
    let kinds: Vec<&str> = doc["read"]["marks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["kind"].as_str().unwrap())
        .collect();
    assert!(
        kinds.contains(&"texel") && kinds.contains(&"tap") && kinds.contains(&"kernel"),
        "{kinds:?}"
    );

    let (ok, rest) = s.interrupt();
    assert!(ok, "Ctrl-C: the server exits 0");
    assert!(rest.contains("stopped"), "{rest}");
}

#[test]
fn hostile_requests_get_4xx_and_change_nothing() {
    let s = Server::start("shadow-map");
    let (st, first) = s.json("/api/run?slot=0&technique=shadow-map");
    assert_eq!(st, 200);
    let gen = first["gen"].clone();
    let (_, before) = s.json("/api/pixel?slot=0&pixel=240,200");

    // The same messages the CLI gives.
    let same_as_cli = [
        (
            "/api/pixel?slot=0&pixel=NaN,1",
            cli_error(&["inspect", SCENE, "--pixel", "NaN,1"]),
        ),
        (
            "/api/pixel?slot=0&pixel=99999999999999999999,1",
            cli_error(&["inspect", SCENE, "--pixel", "99999999999999999999,1"]),
        ),
        (
            "/api/pixel?slot=0&pixel=4000000,3",
            cli_error(&["inspect", SCENE, "--pixel", "4000000,3"]),
        ),
        (
            "/api/run?technique=no-such",
            cli_error(&["render", SCENE, "--technique", "no-such"]),
        ),
        (
            "/api/run?technique=shadow-map&set=no_such%3D1",
            cli_error(&["render", SCENE, "--set", "no_such=1"]),
        ),
        (
            "/api/run?technique=shadow-map&set=units%3DNaN",
            cli_error(&["render", SCENE, "--set", "units=NaN"]),
        ),
        (
            "/api/run?technique=shadow-map&set=size%3D1e30",
            cli_error(&["render", SCENE, "--set", "size=1e30"]),
        ),
        (
            "/api/run?technique=shadow-map&set=noequals",
            cli_error(&["render", SCENE, "--set", "noequals"]),
        ),
    ];
    for (target, message) in &same_as_cli {
        let (st, body) = s.json(target);
        assert_eq!(st, 400, "{target}");
        assert_eq!(body["error"].as_str().unwrap(), message, "{target}");
    }

    let big = format!("GET /api/info HTTP/1.1\r\nX-Padding: {}\r\n\r\n", "a".repeat(64 * 1024));
    let many: Vec<String> = (0..100).map(|i| format!("a{i}=1")).collect();
    let cases: Vec<(Vec<u8>, u16)> = vec![
        (b"GET /../Cargo.toml HTTP/1.1\r\n\r\n".to_vec(), 404),
        (b"GET /%2e%2e/Cargo.toml HTTP/1.1\r\n\r\n".to_vec(), 404),
        (b"GET /img/0/1/../../../../etc/passwd HTTP/1.1\r\n\r\n".to_vec(), 404),
        (b"GET /etc/passwd HTTP/1.1\r\n\r\n".to_vec(), 404),
        (
            b"GET /img/0/1/../../fixtures/scenes/contact.toml HTTP/1.1\r\n\r\n".to_vec(),
            404,
        ),
        (b"GET /img/9/1/0.png HTTP/1.1\r\n\r\n".to_vec(), 404),
        (
            b"GET /img/0/99999999999999999999999/0.png HTTP/1.1\r\n\r\n".to_vec(),
            404,
        ),
        (
            b"GET /api/run?frame=99999999999999999999 HTTP/1.1\r\n\r\n".to_vec(),
            400,
        ),
        (b"GET /api/run?frame=-1 HTTP/1.1\r\n\r\n".to_vec(), 400),
        (b"GET /api/run?slot=2 HTTP/1.1\r\n\r\n".to_vec(), 400),
        (b"GET /api/pixel?slot=1&pixel=1,1 HTTP/1.1\r\n\r\n".to_vec(), 400),
        (b"GET /api/values?name=../../etc HTTP/1.1\r\n\r\n".to_vec(), 400),
        (b"GET /api/run?set=%ZZ HTTP/1.1\r\n\r\n".to_vec(), 400),
        (b"GET /api/run?set=%FF%FE HTTP/1.1\r\n\r\n".to_vec(), 400),
        (
            format!("GET /api/run?{} HTTP/1.1\r\n\r\n", many.join("&")).into_bytes(),
            400,
        ),
        (big.into_bytes(), 431),
        (
            b"POST /api/run HTTP/1.1\r\nContent-Length: 5\r\n\r\nhello".to_vec(),
            413,
        ),
        (b"DELETE / HTTP/1.1\r\n\r\n".to_vec(), 405),
        (b"this is not http\r\n\r\n".to_vec(), 400),
        (b"GET / HTTP/1.1\r\nbroken header line\r\n\r\n".to_vec(), 400),
    ];
    for (request, want) in &cases {
        let (st, _) = s.raw(request);
        assert_eq!(
            st,
            *want,
            "{}",
            String::from_utf8_lossy(&request[..request.len().min(80)])
        );
    }
    // A client that connects and sends nothing does not stop the server (it times out).
    let idle = TcpStream::connect(&s.addr).unwrap();

    // Nothing changed: the same run, the same steps.
    let (_, after) = s.json("/api/pixel?slot=0&pixel=240,200");
    assert_eq!(after["gen"], gen);
    assert_eq!(after, before);
    drop(idle);
}

#[test]
fn runs_wait_for_each_other() {
    let s = Server::start("shadow-map");
    let addr = s.addr.clone();
    let threads: Vec<_> = (0..3)
        .map(|k| {
            let addr = addr.clone();
            std::thread::spawn(move || {
                let mut c = TcpStream::connect(&addr).unwrap();
                let slot = k % 2;
                write!(
                    c,
                    "GET /api/run?slot={slot}&technique=shadow-map&set=size%3D{} HTTP/1.1\r\n\r\n",
                    256 << k
                )
                .unwrap();
                let mut buf = String::new();
                c.read_to_string(&mut buf).unwrap();
                buf
            })
        })
        .collect();
    let mut gens: Vec<u64> = threads
        .into_iter()
        .map(|t| {
            let r = t.join().unwrap();
            assert!(r.starts_with("HTTP/1.1 200"), "{r}");
            let body = &r[r.find("\r\n\r\n").unwrap() + 4..];
            serde_json::from_str::<serde_json::Value>(body).unwrap()["gen"]
                .as_u64()
                .unwrap()
        })
        .collect();
    gens.sort();
    assert_eq!(gens, [1, 2, 3], "one run at a time, each its own generation");
}

/// Fetches the page on a fresh connection and returns how long it took.
fn page_time(addr: &str) -> Duration {
    let t = std::time::Instant::now();
    let mut c = TcpStream::connect(addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    write!(c, "GET / HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut buf = Vec::new();
    c.read_to_end(&mut buf).unwrap();
    assert!(
        buf.starts_with(b"HTTP/1.1 200"),
        "{}",
        String::from_utf8_lossy(&buf[..buf.len().min(200)])
    );
    t.elapsed()
}

#[test]
fn slow_clients_and_renders_do_not_lock_others_out() {
    let s = Server::start("shadow-map");
    let addr = s.addr.clone();
    // A request sent one byte at a time, slower than any per-read timeout would notice.
    let trickle = {
        let addr = addr.clone();
        std::thread::spawn(move || {
            let mut c = TcpStream::connect(&addr).unwrap();
            for b in b"GET / HTTP/1.1\r\nX-Slow: yes, very".iter() {
                if c.write_all(&[*b]).is_err() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(300));
            }
        })
    };
    // A client that asks and does not read its answer.
    let mut unread = TcpStream::connect(&addr).unwrap();
    write!(unread, "GET /api/info HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    // Twelve connections that send nothing.
    let idle: Vec<TcpStream> = (0..12).map(|_| TcpStream::connect(&addr).unwrap()).collect();
    std::thread::sleep(Duration::from_millis(500));
    for _ in 0..3 {
        let t = page_time(&addr);
        assert!(t < Duration::from_secs(2), "the page took {t:?} beside slow clients");
    }
    // The trickled request is cut at its deadline (408), not served when it ends.
    trickle.join().unwrap();
    drop(idle);
    drop(unread);

    // A long render in one connection; the page and info are served meanwhile.
    let render = {
        let addr = addr.clone();
        std::thread::spawn(move || {
            let mut c = TcpStream::connect(&addr).unwrap();
            write!(
                c,
                "GET /api/run?technique=reference&set=samples%3D4096 HTTP/1.1\r\nHost: {addr}\r\n\r\n"
            )
            .unwrap();
            let mut buf = String::new();
            c.read_to_string(&mut buf).unwrap();
            buf
        })
    };
    std::thread::sleep(Duration::from_millis(300));
    let t = page_time(&addr);
    let still = !render.is_finished();
    assert!(t < Duration::from_secs(2), "the page took {t:?} during a render");
    let (st, _) = s.get("/api/info");
    assert_eq!(st, 200);
    let r = render.join().unwrap();
    assert!(r.starts_with("HTTP/1.1 200"), "{}", &r[..r.len().min(300)]);
    // (If the render ended before the page was asked, the check above is weaker, not wrong.)
    eprintln!("page asked while the render ran: {still}");
}

#[test]
fn requests_for_other_sites_are_refused() {
    let s = Server::start("shadow-map");
    let (st, run) = s.json("/api/run?technique=shadow-map");
    assert_eq!(st, 200);
    let gen = run["gen"].as_u64().unwrap();
    let port = s.addr.rsplit(':').next().unwrap().to_string();
    let ask = |host: &str, origin: Option<&str>, target: &str| {
        let origin = origin.map(|o| format!("Origin: {o}\r\n")).unwrap_or_default();
        s.raw(format!("GET {target} HTTP/1.1\r\nHost: {host}\r\n{origin}\r\n").as_bytes())
    };
    // DNS rebinding: another name for the address.
    for host in [
        "evil.example",
        "evil.example:80",
        &format!("evil.example:{port}"),
        "127.0.0.1:1",
    ] {
        for target in ["/", "/api/info", "/api/run?technique=izb"] {
            let (st, body) = ask(host, None, target);
            assert_eq!(st, 421, "{host} {target}");
            assert!(
                String::from_utf8_lossy(&body).contains("answers to 127.0.0.1:"),
                "{host}"
            );
        }
    }
    // Another site's page.
    for origin in [
        "http://evil.example",
        "null",
        "https://127.0.0.1",
        &format!("http://evil.example:{port}"),
    ] {
        let (st, _) = ask(&s.addr, Some(origin), "/api/run?technique=izb");
        assert_eq!(st, 403, "{origin}");
    }
    // Nothing ran for them.
    let (_, px) = s.json("/api/pixel?slot=0&pixel=10,10");
    assert_eq!(px["gen"].as_u64(), Some(gen));
    // The names of the loopback address, and its own page's origin, are served.
    for host in [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        format!("[::1]:{port}"),
    ] {
        let (st, _) = ask(&host, Some(&format!("http://{host}")), "/api/info");
        assert_eq!(st, 200, "{host}");
    }
}

#[test]
fn a_run_past_the_memory_budget_is_refused_and_the_server_goes_on() {
    let s = Server::start_with("shadow-map", &["--max-memory", "256M"]);
    for target in [
        "/api/run?technique=izb&set=size%3D16384",
        "/api/run?technique=hybrid&set=grid%3D16384",
        "/api/run?technique=shadow-map&set=size%3D16384",
    ] {
        let (st, body) = s.json(target);
        assert_eq!(st, 400, "{target}");
        let e = body["error"].as_str().unwrap();
        assert!(e.contains("memory limit of 256 MiB"), "{target}: {e}");
    }
    assert!(page_time(&s.addr) < Duration::from_secs(2));
    let (st, _) = s.json("/api/run?technique=izb");
    assert_eq!(st, 200);
}
