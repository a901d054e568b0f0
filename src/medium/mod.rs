//! Participating media: for now only the heterogeneous density grid (`grid`).

pub mod grid;
