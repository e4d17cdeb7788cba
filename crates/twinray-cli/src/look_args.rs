//! How a render looks: the colour of 8-bit outputs, and what surrounds a model.

use clap::ValueEnum;
use twinray::job::{LightSpec, StudioSpec, TonemapSpec, UpAxisSpec};
use twinray::math::Vec3;

use crate::render_args::parse_vec3;

/// What surrounds the scene.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Surroundings")]
pub struct StudioArgs {
    /// Background colour R,G,B, linear (default: the file's; black for OBJ and glTF).
    #[arg(long, value_name = "R,G,B", value_parser = parse_vec3)]
    pub background: Option<Vec3>,
    /// Which axis is up in a file without a camera: y (glTF's), z (CAD and
    /// robotics models: pybullet's, most STL files) or auto: y for glTF; for
    /// OBJ, STL and PLY the axis along which the model's base is widest,
    /// said in a note.
    #[arg(long, value_enum, default_value_t = UpAxisArg::Auto)]
    pub up_axis: UpAxisArg,
    /// A point light at X,Y,Z (scene units), white or of colour R,G,B (linear),
    /// without falloff; repeat for more. For a file without lights they
    /// replace the default key, fill and rim lights.
    #[arg(
        long = "light",
        value_name = "X,Y,Z[:R,G,B]",
        value_parser = parse_light,
        allow_hyphen_values = true
    )]
    pub lights: Vec<LightSpec>,
    /// A diffuse grey floor just below the model (along --up-axis), so that
    /// its shadows show. Framing still fits the model alone.
    #[arg(long)]
    pub ground: bool,
    /// An equirectangular environment image (.hdr or .exr, linear): seen
    /// where rays leave the scene (the background, mirrors, glass) and
    /// lighting surfaces as ambient light (no shadows). Its top is up
    /// (--up-axis), its centre is what the default camera looks toward.
    #[arg(long, value_name = "FILE", conflicts_with = "background")]
    pub env: Option<std::path::PathBuf>,
}

/// `X,Y,Z` or `X,Y,Z:R,G,B`.
fn parse_light(s: &str) -> Result<LightSpec, String> {
    let (position, color) = match s.split_once(':') {
        Some((p, c)) => (p, Some(c)),
        None => (s, None),
    };
    let bad = |_| {
        format!("'{s}' is not X,Y,Z[:R,G,B] (three finite numbers, then optionally three more)")
    };
    let position = parse_vec3(position).map_err(bad)?.to_array();
    let color = match color {
        Some(c) => parse_vec3(c).map_err(bad)?.to_array(),
        None => [1.0; 3],
    };
    Ok(LightSpec { position, color })
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum UpAxisArg {
    Y,
    Z,
    #[default]
    Auto,
}

impl StudioArgs {
    pub fn spec(&self) -> StudioSpec {
        StudioSpec {
            background: self.background.map(|v| v.to_array()),
            up_axis: match self.up_axis {
                UpAxisArg::Y => UpAxisSpec::Y,
                UpAxisArg::Z => UpAxisSpec::Z,
                UpAxisArg::Auto => UpAxisSpec::Auto,
            },
            lights: self.lights.clone(),
            ground: self.ground,
            env: self.env.clone(),
        }
    }
}

/// Colour of 8-bit outputs (PNG, JPEG, MPO, anaglyphs, quilts).
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Colour of 8-bit outputs (.exr and .pfm stay as rendered)")]
pub struct ColourArgs {
    /// Store linear values in 8-bit outputs. The default applies the sRGB
    /// curve, as image viewers expect.
    #[arg(long, conflicts_with = "srgb")]
    pub linear: bool,
    /// The default (sRGB-encoded 8-bit outputs); kept so older commands run.
    #[arg(long, hide = true)]
    pub srgb: bool,
    /// Exposure in stops: values times 2^EV before the tone curve.
    #[arg(
        long,
        value_name = "EV",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub exposure: f32,
    /// Tone curve: clamp (values above 1 clip; the default), aces (filmic
    /// shoulder, Narkowicz's fit) or agx (Blender's default view).
    #[arg(long, value_enum, default_value_t = TonemapArg::Clamp)]
    pub tonemap: TonemapArg,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum TonemapArg {
    #[default]
    Clamp,
    Aces,
    Agx,
}

impl From<TonemapArg> for TonemapSpec {
    fn from(t: TonemapArg) -> TonemapSpec {
        match t {
            TonemapArg::Clamp => TonemapSpec::Clamp,
            TonemapArg::Aces => TonemapSpec::Aces,
            TonemapArg::Agx => TonemapSpec::Agx,
        }
    }
}
