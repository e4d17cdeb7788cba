//! The crate's integration tests as one binary (one link instead of one
//! per file): `cargo test --release -p twinray --test all`, or
//! `... --test all MODULE::` for one file's tests.

mod approximations;
mod bvh_build;
mod colour_output;
mod common;
mod compressed_gltf;
mod cone_pieces;
mod depth_budget;
mod environment;
mod epipolar_views;
mod exactness;
mod eye_traversal;
mod fast_budget;
mod formats;
mod framing;
mod fuzz;
mod fuzz_loaders;
mod hardening;
mod instances;
mod job;
mod job_preview;
mod lanes_at_once;
mod lights;
mod material_maps;
mod materials;
mod oracle;
mod packet_lanes;
mod panorama;
mod real_models;
mod render;
mod reprojection_cost;
mod rgb8_views;
mod sampling;
mod shared_shading;
mod stereo;
mod stl_ply;
mod studio;
mod up_axis;
mod wide_bvh;
