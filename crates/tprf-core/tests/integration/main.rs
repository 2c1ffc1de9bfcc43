//! tprf-core's integration tests, one test binary (one link, not one per file), each
//! file a module. They use `tprf_core` alone: the tests that run the `tprf` command or
//! the window stay in the root package's `tests/`, whose helpers (`tests/common`) these
//! share. Run them with `cargo test --release --test integration [NAME]` (from the root:
//! `-p tprf-core` alone would resolve the dependencies' features apart and rebuild them).

#[path = "../../../../tests/common/mod.rs"]
mod common;

/// The repository's root, which holds `assets/` and `tests/data/`.
pub const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

mod adaptive;
mod analytic;
mod builtin_assets;
mod dispersion;
mod film_store;
mod gltf_load;
mod gradients;
mod invariance;
mod left_out;
mod lidar_returns;
mod luminescence;
mod media;
mod nlos_reconstruct;
mod sensor_gradients;
mod spad;
mod spectral;
mod window;
