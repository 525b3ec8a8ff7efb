//! Occluders: the preprocessed occluder database and per-frame selection.

pub mod database;
mod draw;
pub mod selection;

pub use database::{Occluder, OccluderDb, OccluderDbConfig, Verdict};
pub(crate) use draw::draw_occluders;
pub use selection::{OccluderSelector, SelectionConfig, SelectionMode, SelectionStats};
