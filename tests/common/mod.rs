//! Helpers shared by the integration tests that run the CLI (each test binary uses some).
#![allow(dead_code)]

use std::process::Command;

/// Runs the CLI; returns (success, stdout + stderr). A panic is a test failure whatever the
/// exit status.
pub fn cli(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("panicked"), "the CLI panicked on {args:?}:\n{text}");
    (out.status.success(), text)
}

/// Writes `body` to `name` in this test process's folder `tag` under the temp dir; returns
/// its path.
pub fn temp_file(tag: &str, name: &str, body: &str) -> String {
    let dir = std::env::temp_dir().join(format!("penumbra-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, body).unwrap();
    p.to_string_lossy().into_owned()
}
