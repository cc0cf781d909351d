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
