//! Allocation policy for programs that draw many frames.
//!
//! A draw allocates its vertex, triangle and bin buffers afresh. With glibc's defaults, buffers
//! above 128 KiB are `mmap`ed and returned to the kernel on free, so the next draw page-faults
//! every page back in (and the kernel zeroes it). On virtual machines a page fault is costly:
//! measured here, the vertex stage of a 300k-vertex draw took 7-9 ms, nearly all of it faults.
//! [`keep_freed_memory`] tells glibc to serve large blocks from the heap and never trim it, so
//! steady-state frames reuse warm pages.

/// Makes glibc keep freed memory for reuse (no-op on other platforms). Call once at start-up,
/// before large allocations; the CLI and the benchmarks do.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes allocator tuning parameters.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 30);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}
