//! stub
use super::{Generated, spheres};
pub(super) fn generate(seed: u64) -> Generated { spheres::generate(seed) }
