//! stokes: a research testbed for fluorescence in spectral light transport.
// `!(x > 0.0)` deliberately rejects NaN too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// A build without fluorescence or media exists only to measure what they cost
// (docs/performance.md); what it leaves unused is not worth a warning.
#![cfg_attr(
    not(all(feature = "fluorescence", feature = "media")),
    allow(unused, clippy::ptr_arg)
)]
/// An enum of named choices, the values of an option in configs and on the command line. Each
/// variant is written `Variant = "name"` after its doc comment; the name is its serde name too
/// (`#[serde(rename)]`, so the enum must derive serde's traits). Generates `ALL` (the variants
/// in order), `name()` and `help()` (the variant's doc comment, one line per line), from which
/// the command line builds its possible values.
macro_rules! named_enum {
    (@doc) => { "" };
    (@doc #[doc = $d:literal] $($rest:tt)*) => {
        concat!($d, "\n", named_enum!(@doc $($rest)*))
    };
    (@doc #[$($other:tt)*] $($rest:tt)*) => { named_enum!(@doc $($rest)*) };
    (
        $(#[$meta:meta])*
        $vis:vis enum $ty:ident {
            $( $(#[$($attr:tt)*])* $variant:ident = $name:literal ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        $vis enum $ty {
            $( $(#[$($attr)*])* #[serde(rename = $name)] $variant, )+
        }

        impl $ty {
            /// Every variant, in the order of declaration.
            pub const ALL: [$ty; [$($name),+].len()] = [$($ty::$variant),+];

            /// The variant's name in configs and on the command line.
            pub const fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }

            /// The variant's doc comment (empty without one), one line per line.
            pub const fn help(self) -> &'static str {
                match self {
                    $($ty::$variant => named_enum!(@doc $(#[$($attr)*])*),)+
                }
            }
        }
    };
}

pub mod cli;
pub mod error;
pub mod experiment;
pub mod film;
pub mod geometry;
pub mod gmm;
pub mod integrator;
pub mod io;
pub mod material;
pub mod medium;
pub mod scene;
pub mod spectrum;
pub mod transport;

pub use error::{Error, ErrorKind};
