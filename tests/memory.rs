//! The surfaces' memory budget: every surface counts while it lives, whichever way it was
//! made, and a request past the budget is refused before anything is allocated. One test in
//! its own binary, because the budget is process-wide.

use penumbra::pipeline::{
    check_room, live_surface_bytes, set_memory_limit, CubeMap, MipChain, Surface, SurfaceArray, DEFAULT_MEMORY_LIMIT,
};

#[test]
fn surfaces_count_while_they_live_and_past_the_budget_are_refused() {
    let base = live_surface_bytes();
    {
        let a = Surface::new(64, 32, 0.0f32).unwrap();
        assert_eq!(live_surface_bytes(), base + 64 * 32 * 4);
        let b = a.clone();
        let c = a.map(|x| [x as u8; 4]);
        assert_eq!(live_surface_bytes(), base + 3 * 64 * 32 * 4);
        let chain = MipChain::build(b, |t| t[0]);
        let levels: u64 = chain.levels().iter().map(|l| l.data().len() as u64 * 4).sum();
        assert_eq!(live_surface_bytes(), base + 2 * 64 * 32 * 4 + levels);
        let cube = CubeMap::new(16, 0u16).unwrap();
        let arr = SurfaceArray::new(3, 8, 8, 0u32).unwrap();
        assert_eq!(
            live_surface_bytes(),
            base + 2 * 64 * 32 * 4 + levels + 6 * 16 * 16 * 2 + 3 * 8 * 8 * 4
        );
        drop((c, chain, cube, arr));
        assert_eq!(live_surface_bytes(), base + 64 * 32 * 4);
        let v = Surface::from_vec(4, 4, vec![1u8; 16]).unwrap();
        assert_eq!(live_surface_bytes(), base + 64 * 32 * 4 + 16);
        drop((a, v));
    }
    assert_eq!(live_surface_bytes(), base, "every byte returned");

    // A small budget: refused before allocating, nothing counted; sets checked as a whole.
    set_memory_limit(base + 10_000);
    let e = Surface::new(100, 100, 0.0f32).unwrap_err().to_string();
    assert!(
        e.contains("100x100") && e.contains("raise the memory limit") && !e.contains("--"),
        "{e}"
    );
    assert_eq!(live_surface_bytes(), base);
    let ok = Surface::new(40, 40, 0.0f32).unwrap(); // 6400 bytes
    assert!(
        CubeMap::new(20, 0.0f32).is_err(),
        "six faces of 1600 bytes do not fit beside 6400"
    );
    assert!(SurfaceArray::new(3, 20, 20, 0.0f32).is_err());
    assert!(check_room(20, 20, 4, 3).is_err() && check_room(20, 20, 4, 2).is_ok());
    assert_eq!(live_surface_bytes(), base + 6400);
    drop(ok);
    set_memory_limit(DEFAULT_MEMORY_LIMIT);
    assert_eq!(live_surface_bytes(), base);
}

/// Every technique with each ranged option at the top of its range, on a tiny scene under a
/// small budget: a result or the budget's error, and the process never grows past the budget
/// (its peak resident memory, less what any render takes without the technique).
#[cfg(all(target_os = "linux", feature = "cli"))]
#[test]
fn every_technique_at_its_largest_options_stays_in_the_budget() {
    const BUDGET_MIB: u64 = 512;
    // What the process holds beside the budget: its code, the tiny scene, the G-buffer.
    const BESIDE_MIB: u64 = 96;
    let dir = std::env::temp_dir().join(format!("penumbra-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A disk light's scene, a sun's and a terrain, each at 64x36: each technique on one it applies to.
    let scenes: Vec<(std::path::PathBuf, penumbra::scene::Scene)> = ["contact", "facing_sun", "terrain"]
        .iter()
        .map(|name| {
            let text = std::fs::read_to_string(format!("fixtures/scenes/{name}.toml"))
                .unwrap()
                .replace("resolution = [480, 270]", "resolution = [64, 36]");
            assert!(text.contains("[64, 36]"), "{name}");
            let path = dir.join(format!("{name}.toml"));
            std::fs::write(&path, text).unwrap();
            let scene = penumbra::scene::file::load(&path).unwrap();
            (path, scene)
        })
        .collect();
    let peak_mib = || {
        // SAFETY: getrusage writes the struct it is given, which is zeroed and ours.
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        assert_eq!(unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut u) }, 0);
        u.ru_maxrss as u64 / 1024
    };
    let mut cases = 0;
    for t in penumbra::shadow::registry::registry() {
        let (scene, _) = scenes
            .iter()
            .find(|(_, s)| t.applies_to(s))
            .unwrap_or_else(|| panic!("{}: no scene it applies to", t.name));
        for o in &t.options {
            let Some(range) = o.ty.split(" in ").nth(1) else {
                continue;
            };
            let hi = range.trim_end_matches(']').rsplit(", ").next().unwrap();
            let set = format!("{}={hi}", o.key);
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
                .args(["render", scene.to_str().unwrap(), "--technique", t.name, "--set", &set])
                .args([
                    "--reps",
                    "1",
                    "--threads",
                    "2",
                    "--max-memory",
                    &format!("{BUDGET_MIB}M"),
                ])
                .arg("--out")
                .arg(dir.join("out"))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!err.contains("panicked"), "{} {set}: {err}", t.name);
            assert!(
                out.status.success() || err.starts_with("penumbra: error: technique"),
                "{} {set}: neither a result nor a refusal: {err}",
                t.name
            );
            let peak = peak_mib();
            assert!(
                peak <= BUDGET_MIB + BESIDE_MIB,
                "{} {set}: the process reached {peak} MiB under a budget of {BUDGET_MIB} MiB",
                t.name
            );
            cases += 1;
        }
    }
    assert!(cases > 100, "{cases} cases");
    let _ = std::fs::remove_dir_all(&dir);
}
