//! twinray: a stereoscopic and multi-view Whitted ray tracer.
//!
//! Data flows one way: load a scene (`loaders`) → build the hierarchy (`bvh`) →
//! trace the views of a rig (`render`, with `camera`, `rig` and `shading`) →
//! compose and write images (`output`). A whole render, as front ends run
//! it, is a [`job::Job`] made from a serialisable [`job::JobSpec`].

pub mod animation;
pub mod bvh;
pub mod environment;
pub mod error;
pub mod image;
pub mod job;
pub mod lights;
pub mod loaders;
pub mod math;
pub mod memory;
mod named;
pub mod output;
pub mod render;
pub mod rig;
pub mod scene;
pub mod shading;
pub mod shapes;
pub mod stats;
pub mod surface_maps;
pub mod texture;
pub mod video;
pub mod world;

pub use error::{Error, Result};
pub use image::{Image, Rgb8Image};
pub use job::{Job, JobSpec};
pub use scene::Scene;
pub use world::World;
