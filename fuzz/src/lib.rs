//! # wedge-fuzz
//!
//! Mutation fuzzing of everything a user hands to wedge as a file, on the stable toolchain:
//! - [`targets`]: one `fn(&[u8]) -> Result<(), String>` per reader — `pipeline` (parse, validate with
//!   wedge's built-in nodes, expand, schedule), `gltf` and `glb` (scene loading), `obj` (OBJ with
//!   an MTL beside it), `exr` (`wedge::image::read_exr`, behind `wedge compare`);
//! - [`seeds`]: seed inputs generated in code (shipped pipelines, small glTF/GLB/OBJ scenes, EXR in
//!   every compression);
//! - [`mutate`]: byte- and token-level mutations, deterministic for a seed;
//! - [`driver`]: the loop — `catch_unwind` per input, a watchdog for hangs, crashers saved to disk;
//! - [`alloc`]: a counting global allocator that makes "live heap over the cap" a crasher.
//!
//! The `wedge-fuzz` binary runs a target from the command line (see `fuzz/README.md`); the crate's
//! tests replay the committed regression inputs and run every target briefly (the CI smoke run).

pub mod alloc;
pub mod driver;
pub mod mutate;
pub mod seeds;
pub mod targets;

pub use driver::{fuzz, run_one, Config, Crasher, Outcome, Report};
pub use targets::{by_name, Target, TARGETS};
