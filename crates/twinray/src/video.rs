//! Video files through `ffmpeg`, run as a subprocess: frames are streamed to
//! its standard input as raw 8-bit RGB, one at a time, and encoded as H.264
//! (libx264) or HEVC (libx265), yuv420p, in an MP4 or Matroska file.
//!
//! Stereo metadata, as ffmpeg 5.1 (Debian 12) writes it (docs/animation.md):
//! * every side-by-side or top-bottom H.264 file carries the frame-packing
//!   arrangement SEI (x264's `frame-packing` 3 or 4); x265 has no such
//!   option, so an HEVC file has the container's metadata only;
//! * `.mkv`: the Matroska `StereoMode` element (`stereo_mode` metadata:
//!   `left_right`, `top_bottom`);
//! * `.mp4`: the `st3d` box of Google's spherical-video RFC. ffmpeg's MP4
//!   muxer writes it only from a stream's stereo side data, with
//!   `-strict unofficial`; raw frames carry none, so the frames are encoded
//!   into a Matroska file first and remuxed (copied, not re-encoded).
//!
//! The file appears only when the encode succeeded: ffmpeg writes
//! temporary files beside it, renamed at the end; a failed or dropped
//! encode removes them.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

mod spherical_video;

/// The video codec, and the ffmpeg encoder that writes it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Codec {
    /// H.264 (libx264): what every player decodes.
    #[default]
    H264,
    /// HEVC / H.265 (libx265): about half the size at the same quality.
    Hevc,
}

impl Codec {
    /// ffmpeg's encoder.
    pub fn encoder(self) -> &'static str {
        match self {
            Codec::H264 => "libx264",
            Codec::Hevc => "libx265",
        }
    }

    /// The constant rate factor that looks lossless (x264's 18; x265's
    /// scale gives the same quality about 2 higher).
    pub fn default_crf(self) -> u32 {
        match self {
            Codec::H264 => 18,
            Codec::Hevc => 20,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Codec::H264 => "h264",
            Codec::Hevc => "hevc",
        }
    }

    /// The encoder's own options (`-x264-params` / `-x265-params`): the
    /// frame-packing SEI where the encoder has one; `crf 0` lossless.
    fn params(self, packing: FramePacking, crf: u32) -> Option<(&'static str, String)> {
        let mut p: Vec<String> = Vec::new();
        match self {
            Codec::H264 => {
                if let Some((_, sei)) = packing.tags() {
                    p.push(format!("frame-packing={sei}"));
                }
                // x264 at crf 0 is lossless already.
            }
            Codec::Hevc => {
                // x265 prints its settings to stderr unless told not to.
                p.push("log-level=error".into());
                if crf == 0 {
                    p.push("lossless=1".into());
                }
            }
        }
        let flag = match self {
            Codec::H264 => "-x264-params",
            Codec::Hevc => "-x265-params",
        };
        (!p.is_empty()).then(|| (flag, p.join(":")))
    }
}

/// Largest constant rate factor of both encoders' 8-bit scales.
pub const MAX_CRF: u32 = 51;

/// How the two eyes share a frame, for the metadata.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FramePacking {
    /// No stereo metadata (one view, an anaglyph, a quilt).
    None,
    /// Left eye on the left half.
    SideBySide,
    /// Left eye on the top half.
    TopBottom,
}

impl FramePacking {
    /// Matroska `stereo_mode`, x264's `frame-packing`.
    fn tags(self) -> Option<(&'static str, u8)> {
        match self {
            FramePacking::None => None,
            FramePacking::SideBySide => Some(("left_right", 3)),
            FramePacking::TopBottom => Some(("top_bottom", 4)),
        }
    }
}

/// The container, by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    Mp4,
    Matroska,
}

impl Container {
    /// `.mp4`/`.m4v`/`.mov` or `.mkv`; `None` for anything else.
    pub fn of(path: &Path) -> Option<Container> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "mp4" | "m4v" | "mov" => Some(Container::Mp4),
            "mkv" => Some(Container::Matroska),
            _ => None,
        }
    }

    fn format(self) -> &'static str {
        match self {
            Container::Mp4 => "mp4",
            Container::Matroska => "matroska",
        }
    }
}

/// What to encode.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoSpec {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub fps: f64,
    pub packing: FramePacking,
    /// The encoder's constant rate factor, 0 to [`MAX_CRF`] (lower: better;
    /// 0 lossless in YUV; [`Codec::default_crf`] looks lossless).
    pub crf: u32,
    pub codec: Codec,
    /// A panorama's projection, for the MP4's `sv3d` box.
    pub spherical: Spherical,
}

/// What a video's frames are, as Google's Spherical Video V2 says it in
/// an MP4 (`sv3d`/`proj`/`equi`): each eye's picture an equirectangular
/// panorama, whole or its middle half across (VR180).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Spherical {
    /// A flat picture (and a fisheye, which `equi` cannot describe).
    #[default]
    None,
    Equirect360,
    Equirect180,
}

/// The ffmpeg program: `$TWINRAY_FFMPEG`, else `ffmpeg` on the PATH,
/// checked by running `-version`.
pub fn find_ffmpeg() -> Result<PathBuf> {
    let program = std::env::var_os("TWINRAY_FFMPEG")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("ffmpeg"));
    let ok = Command::new(&program)
        .arg("-version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return Err(Error::Invalid(format!(
            "video output needs ffmpeg, and '{}' cannot be run: install it (Debian/Ubuntu: apt-get install ffmpeg) or set TWINRAY_FFMPEG, or write frames as images (out_####.png)",
            program.display()
        )));
    }
    Ok(program)
}

/// The ffmpeg program, checked to have `codec`'s encoder: Debian's ffmpeg
/// has libx264 and libx265; a build without one is told so before anything
/// is rendered.
pub fn find_encoder(codec: Codec) -> Result<PathBuf> {
    let program = find_ffmpeg()?;
    let listed = Command::new(&program)
        .args(["-hide_banner", "-encoders"])
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output()
        .map_err(|e| Error::Invalid(format!("cannot run {}: {e}", program.display())))?;
    let encoders = String::from_utf8_lossy(&listed.stdout);
    let has = encoders
        .lines()
        .any(|l| l.split_whitespace().nth(1) == Some(codec.encoder()));
    if !has {
        return Err(Error::Invalid(format!(
            "--codec {} needs ffmpeg's {} encoder, and '{}' has none: install an ffmpeg built with it (Debian/Ubuntu's ffmpeg has it) or use --codec {}",
            codec.name(),
            codec.encoder(),
            program.display(),
            if codec == Codec::H264 { "hevc" } else { "h264" }
        )));
    }
    Ok(program)
}

/// An encode in progress: frames go to ffmpeg's standard input.
pub struct VideoWriter {
    ffmpeg: PathBuf,
    spec: VideoSpec,
    child: Option<Child>,
    stdin: Option<ChildStdin>,
    /// ffmpeg's own messages (a file, so that a full pipe never blocks it).
    log: tempfile::NamedTempFile,
    /// What ffmpeg writes: the file itself, or the Matroska file an MP4 with
    /// stereo metadata is remuxed from.
    encoded: Option<tempfile::TempPath>,
    frame_bytes: usize,
    frames: u64,
}

impl VideoWriter {
    /// Starts ffmpeg for `spec` (ffmpeg from [`find_ffmpeg`]).
    pub fn start(spec: VideoSpec) -> Result<VideoWriter> {
        if spec.crf > MAX_CRF {
            return Err(Error::Invalid(format!(
                "--crf {} is beyond the encoders' 0..{MAX_CRF}",
                spec.crf
            )));
        }
        let ffmpeg = find_encoder(spec.codec)?;
        let container = Container::of(&spec.path).ok_or_else(|| {
            Error::Invalid(format!("{}: a video is .mp4 or .mkv", spec.path.display()))
        })?;
        if spec.width == 0 || spec.height == 0 || !(spec.fps.is_finite() && spec.fps > 0.0) {
            return Err(Error::Invalid(format!(
                "a video of {}x{} at {} fps",
                spec.width, spec.height, spec.fps
            )));
        }
        let remux = container == Container::Mp4 && spec.packing != FramePacking::None;
        let io = |source| Error::Io {
            path: spec.path.clone(),
            source,
        };
        let encoded = temporary_beside(&spec.path, if remux { ".mkv" } else { "" }).map_err(io)?;
        let log = tempfile::NamedTempFile::new().map_err(io)?;
        let mut cmd = Command::new(&ffmpeg);
        cmd.args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y"])
            .args(["-f", "rawvideo", "-pix_fmt", "rgb24"])
            .arg("-s")
            .arg(format!("{}x{}", spec.width, spec.height))
            .arg("-r")
            .arg(format!("{}", spec.fps))
            .args(["-i", "pipe:0"])
            // yuv420p (what players decode) needs even sizes: an odd edge
            // gets one black row or column.
            .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
            .args(["-c:v", spec.codec.encoder()])
            .args(["-pix_fmt", "yuv420p", "-preset", "medium"])
            .arg("-crf")
            .arg(spec.crf.to_string());
        if let Some((flag, params)) = spec.codec.params(spec.packing, spec.crf) {
            cmd.arg(flag).arg(params);
        }
        if let Some((mode, _)) = spec.packing.tags() {
            if remux || container == Container::Matroska {
                cmd.arg("-metadata:s:v:0")
                    .arg(format!("stereo_mode={mode}"));
            }
        }
        let format = if remux {
            "matroska"
        } else {
            container.format()
        };
        if format == "mp4" {
            cmd.args(["-movflags", "+faststart"]);
            cmd.args(hevc_tag(spec.codec));
        }
        cmd.args(["-f", format]).arg(encoded.as_os_str());
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::from(log.reopen().map_err(io)?))
            .spawn()
            .map_err(|e| Error::Invalid(format!("cannot start {}: {e}", ffmpeg.display())))?;
        let stdin = child.stdin.take();
        Ok(VideoWriter {
            ffmpeg,
            frame_bytes: spec.width as usize * spec.height as usize * 3,
            spec,
            child: Some(child),
            stdin,
            log,
            encoded: Some(encoded),
            frames: 0,
        })
    }

    /// Sends one frame: `width * height` RGB triples, top row first.
    pub fn push(&mut self, rgb: &[u8]) -> Result<()> {
        if rgb.len() != self.frame_bytes {
            return Err(Error::Invalid(format!(
                "a video frame of {} bytes, {} expected ({}x{} RGB)",
                rgb.len(),
                self.frame_bytes,
                self.spec.width,
                self.spec.height
            )));
        }
        let Some(stdin) = self.stdin.as_mut() else {
            return Err(self.failure("ffmpeg's input is closed"));
        };
        if let Err(e) = stdin.write_all(rgb) {
            // ffmpeg stopped: its own message says why.
            self.stdin = None;
            if let Some(mut c) = self.child.take() {
                let _ = c.wait();
            }
            return Err(self.failure(&format!("ffmpeg stopped reading frames ({e})")));
        }
        self.frames += 1;
        Ok(())
    }

    /// Frames sent so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Ends the stream, waits for ffmpeg, remuxes an MP4 with stereo
    /// metadata, and puts the file in place; returns its path.
    pub fn finish(mut self) -> Result<PathBuf> {
        drop(self.stdin.take());
        let status = match self.child.take() {
            Some(mut c) => c.wait().map_err(|e| self.failure(&e.to_string()))?,
            None => return Err(self.failure("ffmpeg is not running")),
        };
        if !status.success() {
            return Err(self.failure(&format!("ffmpeg failed ({status})")));
        }
        if self.frames == 0 {
            return Err(Error::Invalid("a video of no frames".into()));
        }
        let io = |source| Error::Io {
            path: self.spec.path.clone(),
            source,
        };
        let remux = Container::of(&self.spec.path) == Some(Container::Mp4)
            && self.spec.packing != FramePacking::None;
        let encoded = self
            .encoded
            .take()
            .ok_or_else(|| self.failure("no encoded file"))?;
        let finished = if remux {
            let mp4 = temporary_beside(&self.spec.path, "").map_err(io)?;
            let status = Command::new(&self.ffmpeg)
                .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y", "-i"])
                .arg(encoded.as_os_str())
                .args(["-c", "copy", "-strict", "unofficial"])
                .args(hevc_tag(self.spec.codec))
                .args(["-movflags", "+faststart", "-f", "mp4"])
                .arg(mp4.as_os_str())
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::from(self.log.reopen().map_err(io)?))
                .status()
                .map_err(io)?;
            if !status.success() {
                return Err(self.failure(&format!("ffmpeg failed remuxing to MP4 ({status})")));
            }
            mp4
        } else {
            encoded
        };
        if Container::of(&self.spec.path) == Some(Container::Mp4)
            && self.spec.spherical != Spherical::None
        {
            let bytes = std::fs::read(&finished).map_err(io)?;
            let tagged = spherical_video::with_sv3d(&bytes, self.spec.spherical)
                .map_err(|e| self.failure(&format!("writing the spherical metadata: {e}")))?;
            std::fs::write(&finished, tagged).map_err(io)?;
        }
        finished.persist(&self.spec.path).map_err(|e| io(e.error))?;
        Ok(self.spec.path.clone())
    }

    /// An error with the end of ffmpeg's messages.
    fn failure(&self, what: &str) -> Error {
        let log = std::fs::read_to_string(self.log.path()).unwrap_or_default();
        let tail: Vec<&str> = log.lines().rev().take(4).collect();
        let said: Vec<&str> = tail.into_iter().rev().collect();
        Error::Invalid(format!(
            "{}: {what}{}{}",
            self.spec.path.display(),
            if said.is_empty() { "" } else { ": " },
            said.join(" / ")
        ))
    }
}

impl Drop for VideoWriter {
    /// An unfinished encode: ffmpeg stopped, its files removed (the
    /// temporary paths delete themselves).
    fn drop(&mut self) {
        drop(self.stdin.take());
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// HEVC in MP4 tagged `hvc1` (parameter sets in the sample entry), the tag
/// Apple's players require; ffmpeg's default `hev1` plays elsewhere only.
fn hevc_tag(codec: Codec) -> &'static [&'static str] {
    match codec {
        Codec::Hevc => &["-tag:v", "hvc1"],
        Codec::H264 => &[],
    }
}

/// A new empty temporary file beside `path`, hidden, removed when dropped.
fn temporary_beside(path: &Path, suffix: &str) -> std::io::Result<tempfile::TempPath> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (prefix, suffix) = (format!(".{name}.twinray-"), format!(".tmp{suffix}"));
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(&suffix);
    // Readable as any other output (tempfile's own default is 0600).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    Ok(builder.tempfile_in(dir)?.into_temp_path())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn containers_by_extension() {
        assert_eq!(Container::of(Path::new("a.MP4")), Some(Container::Mp4));
        assert_eq!(Container::of(Path::new("a.mkv")), Some(Container::Matroska));
        assert_eq!(Container::of(Path::new("a.png")), None);
    }
}
