//! # wedge
//!
//! A render-graph framework for *sample-and-filter* physically based rendering: effect nodes
//! (soft shadows, indirect light, defocus, motion, environment) declare their buffers and
//! Fourier-derived bandwidths; a RON pipeline wires them into a DAG of passes; backends run the
//! passes. This crate is the facade and the CLI's library: it re-exports the workspace crates and
//! adds sessions (pipeline + scene + overrides → a run), image I/O, heatmaps and metrics.

pub use wedge_backends as backends;
pub use wedge_effects as effects;
pub use wedge_graph as graph;
pub use wedge_scene as scene;

pub mod aov;
pub mod bench;
pub mod capture;
pub mod cli;
pub mod export;
pub mod farm;
pub mod heatmap;
pub mod image;
pub mod k8s;
pub mod merge;
pub mod metrics;
pub mod outputs;
pub mod progress;
pub mod session;
pub mod shard;
pub mod staging;
pub mod tiles;
/// `wedge view`, the interactive window (the `view` feature, on by default).
#[cfg(feature = "view")]
pub mod view;

pub use session::{Overrides, Registries, Session, WedgeError};
