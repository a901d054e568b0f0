//! The instruction set of the traversal and leaf kernels, chosen once per process: AVX-512
//! where the CPU has it, then AVX2, then portable code. `STOKES_ISA=avx512|avx2|portable`
//! forces a path the CPU supports, so that each can be tested and timed on one machine.
//!
//! Every path gives the same hits, to the bit: the kernels perform the same operations in the
//! same order lane by lane (`tests.rs` checks each available path against brute force).

use std::sync::OnceLock;

/// The environment variable that forces an instruction set.
pub const ISA_VAR: &str = "STOKES_ISA";

/// An instruction set the BVH kernels are written for, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// Plain Rust, on any CPU.
    Portable,
    /// AVX2 with FMA, POPCNT and BMI1: 8-wide node visits and packet tests.
    Avx2,
    /// AVX-512 (F, VL, DQ, BW) at the AVX2 kernels' 256-bit width: EVEX encodings, 32 vector
    /// registers, node tests compared into mask registers. Wider kernels (16-lane packet tests,
    /// compressed 512-bit stack pushes) were measured and slowed renders down on an AVX-512
    /// Xeon, where 512-bit instructions slow the 256-bit code around them (docs/performance.md
    /// §1, "AVX-512").
    Avx512,
}

impl Isa {
    /// Every instruction set, best first.
    pub const ALL: [Isa; 3] = [Isa::Avx512, Isa::Avx2, Isa::Portable];

    /// The name `STOKES_ISA` takes.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// The instruction set named `s` (as [`Isa::name`] writes it).
    pub fn parse(s: &str) -> Option<Isa> {
        Isa::ALL.into_iter().find(|i| i.name() == s)
    }

    /// Whether this CPU can run the kernels of `self`.
    pub fn supported(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::is_x86_feature_detected!("avx2")
                    && std::is_x86_feature_detected!("fma")
                    && std::is_x86_feature_detected!("popcnt")
                    && std::is_x86_feature_detected!("bmi1")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                Isa::Avx2.supported()
                    && std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512vl")
                    && std::is_x86_feature_detected!("avx512dq")
                    && std::is_x86_feature_detected!("avx512bw")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The instruction sets this CPU supports, best first.
    pub fn available() -> Vec<Isa> {
        Isa::ALL.into_iter().filter(|i| i.supported()).collect()
    }

    /// The best instruction set this CPU supports.
    pub fn best() -> Isa {
        Isa::ALL
            .into_iter()
            .find(|i| i.supported())
            .unwrap_or(Isa::Portable)
    }

    /// The instruction set `STOKES_ISA` asks for, or the best supported one when it is unset
    /// or empty; an error names the variable and the value when the value is no instruction
    /// set or one this CPU lacks.
    pub fn from_env() -> Result<Isa, IsaError> {
        match std::env::var(ISA_VAR) {
            Err(std::env::VarError::NotPresent) => Ok(Isa::best()),
            Err(std::env::VarError::NotUnicode(v)) => Err(IsaError::Unknown(format!("{v:?}"))),
            Ok(v) if v.trim().is_empty() => Ok(Isa::best()),
            Ok(v) => match Isa::parse(v.trim()) {
                Some(isa) if isa.supported() => Ok(isa),
                Some(isa) => Err(IsaError::Unsupported(isa)),
                None => Err(IsaError::Unknown(v)),
            },
        }
    }

    /// The instruction set of this process: [`Isa::from_env`], decided at the first call. An
    /// invalid `STOKES_ISA` (which the command line refuses before any scene is loaded) is
    /// reported once on standard error and the best supported set is used.
    pub fn active() -> Isa {
        static ACTIVE: OnceLock<Isa> = OnceLock::new();
        *ACTIVE.get_or_init(|| {
            Isa::from_env().unwrap_or_else(|e| {
                eprintln!("warning: {e}; using {}", Isa::best().name());
                Isa::best()
            })
        })
    }
}

impl std::fmt::Display for Isa {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A `STOKES_ISA` that cannot be honoured.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IsaError {
    /// The value names no instruction set.
    Unknown(String),
    /// The instruction set exists but this CPU lacks it.
    Unsupported(Isa),
}

impl std::fmt::Display for IsaError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names = |v: Vec<Isa>| v.iter().map(|i| i.name()).collect::<Vec<_>>().join(", ");
        match self {
            IsaError::Unknown(v) => write!(
                f,
                "{ISA_VAR}={v}: not an instruction set (expected one of {})",
                names(Isa::ALL.to_vec())
            ),
            IsaError::Unsupported(isa) => write!(
                f,
                "{ISA_VAR}={isa}: this CPU does not support {isa} (it supports {})",
                names(Isa::available())
            ),
        }
    }
}

impl std::error::Error for IsaError {}

/// [`Isa`] as the const parameter of the kernels (`const ISA: u8`).
pub(super) const ISA_PORTABLE: u8 = 0;
pub(super) const ISA_AVX2: u8 = 1;
pub(super) const ISA_AVX512: u8 = 2;
