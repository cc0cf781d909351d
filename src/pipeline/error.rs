//! Everything that can go wrong in the pipeline, as a value ([`PipelineError`]).

use std::fmt;

/// Largest width or height of any surface the pipeline accepts.
pub const MAX_DIMENSION: u32 = 16384;

/// Everything that can go wrong in the pipeline, as a value (never a panic).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PipelineError {
    /// A surface size of zero or above [`MAX_DIMENSION`].
    BadSize {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// Targets of one draw differ in size.
    SizeMismatch {
        /// Which target.
        what: &'static str,
        /// Size of the first target.
        expected: (u32, u32),
        /// Size of this one.
        got: (u32, u32),
    },
    /// The index buffer's length is not a multiple of 3.
    BadIndexCount(usize),
    /// An index points past the vertex buffer.
    IndexOutOfRange {
        /// Triangle number.
        triangle: usize,
        /// The bad index.
        index: u32,
        /// Vertex count.
        vertices: usize,
    },
    /// A fragment-list pool would have overflowed; nothing of this draw was appended.
    FragmentPoolFull {
        /// Pool capacity.
        capacity: usize,
        /// Nodes the pool would have needed.
        needed: usize,
    },
    /// A mip level that does not exist.
    BadMipLevel {
        /// Requested level.
        level: usize,
        /// Levels in the chain.
        levels: usize,
    },
    /// Any other invalid argument, described.
    BadArgument(String),
    /// A surface (or a set of them) would take the live surfaces past the memory budget
    /// ([`super::surface::set_memory_limit`]); nothing was allocated.
    OverBudget(OverBudget),
}

/// A request the memory budget refused: a surface, or a set of them (a cube map's faces, an
/// array's layers; `bytes` counts them all).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OverBudget {
    /// Requested width.
    pub width: u32,
    /// Requested height.
    pub height: u32,
    /// Its bytes.
    pub bytes: u64,
    /// Bytes of the surfaces alive when it was asked for.
    pub live: u64,
    /// The budget.
    pub limit: u64,
}

impl OverBudget {
    /// What was asked for: "WxH buffers of N MiB".
    pub fn what(&self) -> String {
        format!("{}x{} buffers of {}", self.width, self.height, size_text(self.bytes))
    }

    /// The live bytes it would have made (`live + bytes`, saturating: a request past `u64`
    /// is how some are refused).
    pub fn total(&self) -> u64 {
        self.live.saturating_add(self.bytes)
    }
}

impl fmt::Display for PipelineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PipelineError::BadSize { width, height } => {
                write!(
                    f,
                    "surface size {width}x{height} is invalid (each side must be 1..={MAX_DIMENSION})"
                )
            }
            PipelineError::SizeMismatch { what, expected, got } => write!(
                f,
                "{what} target is {}x{} but the draw's other targets are {}x{}",
                got.0, got.1, expected.0, expected.1
            ),
            PipelineError::BadIndexCount(n) => write!(f, "index count {n} is not a multiple of 3"),
            PipelineError::IndexOutOfRange {
                triangle,
                index,
                vertices,
            } => {
                write!(
                    f,
                    "triangle {triangle} uses vertex index {index} but there are only {vertices} vertices"
                )
            }
            PipelineError::FragmentPoolFull { capacity, needed } => {
                write!(
                    f,
                    "fragment-list pool full: capacity {capacity} nodes, the draw needed {needed}"
                )
            }
            PipelineError::BadMipLevel { level, levels } => {
                write!(f, "mip level {level} does not exist (the chain has {levels} levels)")
            }
            PipelineError::BadArgument(s) => write!(f, "{s}"),
            PipelineError::OverBudget(o) => write!(
                f,
                "{} would bring the buffers alive to {}, beyond the memory limit of {} (lower the map size, cascades, faces or resolution, or raise the memory limit)",
                o.what(),
                size_text(o.total()),
                size_text(o.limit)
            ),
        }
    }
}

impl std::error::Error for PipelineError {}

/// A byte count for messages, in the unit that shows its digits: `512 bytes`, `4.0 KiB`,
/// `1.5 MiB`, `4096 MiB` (a budget of 1K is not "0 MiB").
pub(crate) fn size_text(bytes: u64) -> String {
    let (kib, mib) = (bytes as f64 / 1024.0, bytes as f64 / (1u64 << 20) as f64);
    match bytes {
        0..1024 => format!("{bytes} bytes"),
        _ if mib < 1.0 && kib < 10.0 => format!("{kib:.1} KiB"),
        _ if mib < 1.0 => format!("{kib:.0} KiB"),
        _ if mib < 10.0 => format!("{mib:.1} MiB"),
        _ => format!("{mib:.0} MiB"),
    }
}
