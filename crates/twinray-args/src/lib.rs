//! The flags of `twinray render` and the job spec they describe, both ways,
//! in one place: the command line parses them ([`RenderArgs::spec`]), the
//! preview shows the command that reproduces what its page renders
//! ([`ToArgs::to_args`]), and the flags that were removed are refused with
//! what replaced them ([`refuse_removed`]). The library knows nothing of
//! flags: it takes a [`twinray::JobSpec`].
//!
//! The flags come in the groups `render --help` shows: output, camera, views
//! and rig, sampling, speed, colour, animation, surroundings, limits.

mod groups;
mod removed;
mod to_args;
mod values;

pub use groups::{
    AnimationArgs, CameraArgs, ColourArgs, LimitArgs, OutputArgs, RenderArgs, RigArgs,
    SamplingArgs, SpeedArgs, StudioArgs,
};
pub use removed::{refuse_removed, Removed, REMOVED};
pub use to_args::ToArgs;
pub use values::{parse_size, parse_vec3};
