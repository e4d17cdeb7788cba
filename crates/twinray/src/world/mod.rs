//! The scene made ready to trace: its hierarchy (`hierarchy.rs`), the
//! paper's cut of the object tree (`cut.rs`), and the hierarchy as instances
//! over meshes (`two_level.rs`, an animation's).

mod cut;
mod hierarchy;
mod two_level;

pub use cut::Cut;
pub use hierarchy::{InstanceCounts, World};
pub use two_level::{Instance, InstanceTrees};

/// A ray goes on past at most this many cut-away hits (alpha MASK), then
/// stops at the last: the renderer's rays and the depth pass alike.
pub const MAX_CUTOUT_LAYERS: u32 = 64;

#[cfg(test)]
impl World {
    /// The world of an NFF scene given as text (the unit tests' scenes).
    pub(crate) fn from_nff_text(text: &str) -> World {
        let options = crate::loaders::LoadOptions::default();
        let path = std::path::Path::new("t.nff");
        let scene = crate::loaders::nff::parse_nff(text, path, &options).expect("test scene");
        World::new(scene)
    }
}
