//! The motion: coordinate tables filtered and splined into per-frame q, u, u̇.
pub mod checks;
pub mod coordinates;
pub mod filter;
pub mod generate;
pub mod states;
pub mod stream;
