//! A stable 64-bit FNV-1a hash of outputs, for golden tests and the CLI's image hash.
//! (`std`'s hasher is not guaranteed stable across Rust releases; this one is.)

/// FNV-1a over bytes, continuing from `h` (start with [`FNV_OFFSET`]).
pub fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x100_0000_01b3);
    }
    h
}

/// FNV-1a 64 offset basis.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// Hashes a slice of `f32` by bit pattern.
pub fn hash_f32(data: &[f32]) -> u64 {
    data.iter()
        .fold(FNV_OFFSET, |h, v| fnv1a(h, &v.to_bits().to_le_bytes()))
}

/// Hashes RGBA8 texels.
pub fn hash_rgba8(data: &[[u8; 4]]) -> u64 {
    data.iter().fold(FNV_OFFSET, |h, v| fnv1a(h, v))
}
