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

/// A small deterministic generator (SplitMix64) for benchmark and test inputs.
#[derive(Clone, Debug)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A fast fingerprint of a triangle mesh's positions (by bit pattern) and indices: three
/// independent lanes of multiply and xor-shift per 32-bit word, folded with the lengths. For
/// recognising a mesh seen before (a technique's cache of what it derived from it), not for
/// golden files.
pub fn mesh_fingerprint(positions: &[glam::Vec3], indices: &[u32]) -> u64 {
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    #[inline(always)]
    fn mix(h: u64, w: u32) -> u64 {
        let h = (h ^ w as u64).wrapping_mul(K);
        h ^ (h >> 32)
    }
    let mut l = [1u64, 2, 3];
    for p in positions {
        l = [
            mix(l[0], p.x.to_bits()),
            mix(l[1], p.y.to_bits()),
            mix(l[2], p.z.to_bits()),
        ];
    }
    for t in indices.chunks(3) {
        for (h, &i) in l.iter_mut().zip(t) {
            *h = mix(*h, i);
        }
    }
    let mut h = fnv1a(FNV_OFFSET, &(positions.len() as u64).to_le_bytes());
    h = fnv1a(h, &(indices.len() as u64).to_le_bytes());
    for x in l {
        h = fnv1a(h, &x.to_le_bytes());
    }
    h
}
