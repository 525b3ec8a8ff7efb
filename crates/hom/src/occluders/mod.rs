//! Occluders: the preprocessed occluder database and per-frame selection.

pub mod database;
pub mod selection;

pub use database::{Occluder, OccluderDb, OccluderDbConfig, Verdict};
pub use selection::{Hole, OccluderSelector, SelectionConfig, SelectionMode, SelectionStats};
