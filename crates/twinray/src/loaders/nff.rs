//! NFF, the Neutral File Format of Eric Haines' Standard Procedural Databases.
//!
//! NFF is a stream of whitespace-separated tokens: an entity keyword followed by
//! its numbers, which may be split across lines or share a line (the SPD writes a
//! cone on one line, the specification on two; both parse). `#` starts a comment
//! that runs to the end of the line wherever a token may start.
//!
//! | entity | numbers |
//! |--------|---------|
//! | `v` | `from x y z`, `at x y z`, `up x y z`, `angle deg`, `hither h`, `resolution w h` |
//! | `b r g b` | background colour |
//! | `l x y z [r g b]` | point light; the colour only counts on the keyword's line |
//! | `f r g b Kd Ks Shine T ior` | material of the shapes that follow |
//! | `c bx by bz br ax ay az ar` | truncated cone (cylinder) |
//! | `s x y z r` | sphere |
//! | `p n` + n × `x y z` | polygon |
//! | `pp n` + n × `x y z nx ny nz` | polygonal patch (per-vertex normals) |
//!
//! Malformed input gives one `Error::Parse` naming the line of the offending token
//! and what was expected there; degenerate geometry is left to [`Scene`] (skipped
//! with a warning).

use std::fmt::Write as _;
use std::path::Path;

use super::{LoadContext, LoadOptions};
use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::scene::{Light, Material, Scene, Viewpoint, MAX_COORDINATE};

const ENTITIES: &str = "v, b, l, f, c, s, p, pp";

/// Read and parse an NFF file.
pub fn load_nff(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let cx = LoadContext::new(path, opts);
    let bytes = cx.files.read_scene(&cx.memory)?;
    // A sphere is 10 bytes of text (`s 0 0 0 1`) and about 80 of shape.
    cx.memory.check(
        (bytes.len() as u64).saturating_mul(SHAPE_BYTES_PER_BYTE),
        &|| format!("parsing {}", path.display()),
    )?;
    Ok(cx.finish(parse_nff_bytes(&bytes, path, opts)?))
}

/// Bytes of shapes a byte of NFF text can become, at most.
const SHAPE_BYTES_PER_BYTE: u64 = 8;

/// Parse NFF from raw bytes, refusing what is not UTF-8 text.
fn parse_nff_bytes(bytes: &[u8], file: &Path, opts: &LoadOptions) -> Result<Scene> {
    match std::str::from_utf8(bytes) {
        Ok(text) => parse_nff(text, file, opts),
        Err(e) => {
            let at = e.valid_up_to();
            Err(Error::Parse {
                file: file.to_path_buf(),
                line: line_at(bytes, at),
                message: format!("not a text file: invalid UTF-8 (byte 0x{:02x})", bytes[at]),
            })
        }
    }
}

/// Parse NFF text. `file` is only used in messages and warnings.
pub fn parse_nff(text: &str, file: &Path, opts: &LoadOptions) -> Result<Scene> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // A DOS end-of-file mark is tolerated; other control characters mean binary data.
    let text = text.strip_suffix('\u{1a}').unwrap_or(text);
    if let Some(at) = text.bytes().position(is_binary) {
        return Err(Error::Parse {
            file: file.to_path_buf(),
            line: line_at(text.as_bytes(), at),
            message: format!(
                "not a text file: control character 0x{:02x}",
                text.as_bytes()[at]
            ),
        });
    }
    let prefix = format!("{}:", file.display());
    Parser {
        lex: Lexer::new(text),
        file,
        opts,
        scene: Scene::new(),
        prefix_len: prefix.len(),
        where_: prefix,
        vertices: Vec::new(),
        normals: Vec::new(),
        viewpoint_line: None,
    }
    .parse()
}

fn is_binary(b: u8) -> bool {
    (b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0c)) || b == 0x7f
}

/// 1-based line of byte `offset`, counting `\n`, `\r\n` and a lone `\r` as line
/// ends, like [`Lexer`].
fn line_at(bytes: &[u8], offset: usize) -> usize {
    let head = &bytes[..offset.min(bytes.len())];
    let mut line = 1;
    for (i, &b) in head.iter().enumerate() {
        if b == b'\n' || (b == b'\r' && bytes.get(i + 1) != Some(&b'\n')) {
            line += 1;
        }
    }
    line
}

/// Explains a token glued to a comment, e.g. `1#x`.
fn hint(token: &str) -> &'static str {
    if token.contains('#') {
        " (put a space before '#' to start a comment)"
    } else {
        ""
    }
}

/// A token quoted for a message: control and whitespace characters escaped, long
/// tokens shortened.
fn show(token: &str) -> String {
    const MAX: usize = 40;
    let mut s = String::new();
    for (i, c) in token.chars().enumerate() {
        if i == MAX {
            s.push('…');
            break;
        }
        if c.is_control() || c.is_whitespace() {
            s.extend(c.escape_unicode());
        } else {
            s.push(c);
        }
    }
    s
}

#[derive(Clone, Copy, Debug)]
struct Tok<'a> {
    text: &'a str,
    line: usize,
}

/// Whitespace-separated tokens with their line numbers; comments dropped.
struct Lexer<'a> {
    /// Text after the current line.
    rest: &'a str,
    words: std::str::SplitAsciiWhitespace<'a>,
    /// Number of the current line (0 before the first).
    line: usize,
    peeked: Option<Option<Tok<'a>>>,
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        Lexer {
            rest: text,
            words: "".split_ascii_whitespace(),
            line: 0,
            peeked: None,
        }
    }

    fn next_line(&mut self) -> bool {
        if self.rest.is_empty() {
            return false;
        }
        let b = self.rest.as_bytes();
        let (end, next) = match b.iter().position(|&c| c == b'\n' || c == b'\r') {
            Some(i) if b[i] == b'\r' && b.get(i + 1) == Some(&b'\n') => (i, i + 2),
            Some(i) => (i, i + 1),
            None => (b.len(), b.len()),
        };
        // Both cuts are next to ASCII bytes, hence on character boundaries.
        self.words = self.rest[..end].split_ascii_whitespace();
        self.rest = &self.rest[next..];
        self.line += 1;
        true
    }

    fn advance(&mut self) -> Option<Tok<'a>> {
        loop {
            if let Some(w) = self.words.next() {
                if w.starts_with('#') {
                    self.words = "".split_ascii_whitespace();
                    continue;
                }
                return Some(Tok {
                    text: w,
                    line: self.line,
                });
            }
            if !self.next_line() {
                return None;
            }
        }
    }

    fn next(&mut self) -> Option<Tok<'a>> {
        match self.peeked.take() {
            Some(t) => t,
            None => self.advance(),
        }
    }

    fn peek(&mut self) -> Option<Tok<'a>> {
        match self.peeked {
            Some(t) => t,
            None => {
                let t = self.advance();
                self.peeked = Some(t);
                t
            }
        }
    }

    /// The last line read (at end of input: the last line of the file), at least 1.
    fn last_line(&self) -> usize {
        self.line.max(1)
    }
}

/// What a group of numbers is, for messages.
#[derive(Clone, Copy)]
struct What {
    name: &'static str,
    /// `(i, n)`: vertex `i` (1-based) of `n`.
    vertex: Option<(usize, usize)>,
}

impl What {
    fn of(name: &'static str) -> Self {
        What { name, vertex: None }
    }

    /// Short form, after "expected N numbers for".
    fn short(&self) -> String {
        match self.vertex {
            Some((i, _)) => format!("vertex {i} of {}", self.name),
            None => self.name.to_string(),
        }
    }

    /// Long form, in parentheses.
    fn long(&self) -> String {
        match self.vertex {
            Some((i, n)) => format!("vertex {i} of {n} of {}", self.name),
            None => self.name.to_string(),
        }
    }
}

/// Parses a positive whole number written as digits; saturates on overflow.
fn whole_number(text: &str) -> Option<u64> {
    let digits = text.strip_prefix('+').unwrap_or(text);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some(digits.parse::<u64>().unwrap_or(u64::MAX))
}

/// Unit vector along `v`, `None` for a zero (or non-finite) vector; safe for huge
/// components.
fn direction(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    (v / m).try_normalize()
}

const VIEW_KEYS: [&str; 6] = ["from", "at", "up", "angle", "hither", "resolution"];

struct Parser<'a, 'o> {
    lex: Lexer<'a>,
    file: &'a Path,
    opts: &'o LoadOptions,
    scene: Scene,
    /// `"{file}:"` followed by the line of the current entity.
    where_: String,
    prefix_len: usize,
    vertices: Vec<Vec3>,
    normals: Vec<Vec3>,
    viewpoint_line: Option<usize>,
}

impl Parser<'_, '_> {
    fn err(&self, line: usize, message: String) -> Error {
        Error::Parse {
            file: self.file.to_path_buf(),
            line,
            message,
        }
    }

    fn set_where(&mut self, line: usize) {
        self.where_.truncate(self.prefix_len);
        let _ = write!(self.where_, "{line}");
    }

    fn parse(mut self) -> Result<Scene> {
        while let Some(tok) = self.lex.next() {
            let line = tok.line;
            match tok.text {
                "v" => self.viewpoint(line)?,
                "b" => {
                    self.scene.background =
                        self.vec3(line, What::of("background colour (r g b)"))?
                }
                "l" => self.light(line)?,
                "f" => self.material(line)?,
                "c" => self.cone(line)?,
                "s" => {
                    let [x, y, z, r] = self.numbers(line, What::of("sphere (x y z radius)"))?;
                    self.set_where(line);
                    self.scene.add_sphere(Vec3::new(x, y, z), r, &self.where_);
                }
                "p" => self.polygon(line, false)?,
                "pp" => self.polygon(line, true)?,
                _ => return Err(self.unexpected(tok)),
            }
        }
        if self.viewpoint_line.is_none() {
            return Err(self.err(
                self.lex.last_line(),
                "no viewpoint ('v') in the scene".to_string(),
            ));
        }
        self.scene.finish();
        Ok(self.scene)
    }

    /// The error for a token where an entity keyword should be.
    fn unexpected(&self, tok: Tok) -> Error {
        let t = show(tok.text);
        let message = if tok.text.parse::<f64>().is_ok() {
            format!(
                "unexpected number '{t}' where an entity should start (expected one of \
                 {ENTITIES}); too many numbers in the entity before it?"
            )
        } else if VIEW_KEYS.contains(&tok.text) {
            format!("'{t}' outside a viewpoint ('v') (expected one of {ENTITIES})")
        } else if tok.text.eq_ignore_ascii_case("nff") {
            format!(
                "unknown entity '{t}': this looks like Sense8 NFF, a different format; only \
                 Eric Haines' NFF (SPD) is supported (expected one of {ENTITIES})"
            )
        } else {
            format!(
                "unknown entity '{t}'{} (expected one of {ENTITIES})",
                hint(tok.text)
            )
        };
        self.err(tok.line, message)
    }

    /// One finite number and its line; `n` is the size of the group, for messages.
    fn number_at(&mut self, kw_line: usize, n: usize, what: What) -> Result<(f32, usize)> {
        let Some(tok) = self.lex.next() else {
            let count = if n == 1 {
                "a number".to_string()
            } else {
                format!("{n} numbers")
            };
            return Err(self.err(
                kw_line,
                format!("expected {count} for {}, found end of file", what.short()),
            ));
        };
        match tok.text.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok((x, tok.line)),
            Ok(_) => Err(self.err(
                tok.line,
                format!(
                    "expected a finite number, found '{}' ({})",
                    show(tok.text),
                    what.long()
                ),
            )),
            Err(_) => Err(self.err(
                tok.line,
                format!(
                    "expected a number ({}), found '{}'{}",
                    what.long(),
                    show(tok.text),
                    hint(tok.text)
                ),
            )),
        }
    }

    fn numbers<const N: usize>(&mut self, kw_line: usize, what: What) -> Result<[f32; N]> {
        let mut out = [0.0; N];
        for x in &mut out {
            *x = self.number_at(kw_line, N, what)?.0;
        }
        Ok(out)
    }

    fn vec3(&mut self, kw_line: usize, what: What) -> Result<Vec3> {
        Ok(Vec3::from_array(self.numbers::<3>(kw_line, what)?))
    }

    fn viewpoint(&mut self, v_line: usize) -> Result<()> {
        if let Some(first) = self.viewpoint_line {
            return Err(self.err(
                v_line,
                format!("a second viewpoint ('v'); the first is at line {first}"),
            ));
        }
        self.viewpoint_line = Some(v_line);
        let mut seen: [Option<usize>; 6] = [None; 6];
        let mut vp = Viewpoint::default();
        while let Some(missing) = seen.iter().position(Option::is_none) {
            let next = self.lex.peek();
            let key = next.and_then(|t| VIEW_KEYS.iter().position(|k| *k == t.text));
            let (Some(key), Some(kw)) = (key, next) else {
                let missing = VIEW_KEYS[missing];
                return Err(match next {
                    None => self.err(
                        v_line,
                        format!("expected '{missing}' for the viewpoint ('v'), found end of file"),
                    ),
                    Some(t) => self.err(
                        t.line,
                        format!(
                            "expected '{missing}' for the viewpoint ('v'), found '{}'",
                            show(t.text)
                        ),
                    ),
                });
            };
            self.lex.next();
            if let Some(prev) = seen[key] {
                return Err(self.err(
                    kw.line,
                    format!(
                        "'{}' given twice in the viewpoint (first at line {prev})",
                        VIEW_KEYS[key]
                    ),
                ));
            }
            seen[key] = Some(kw.line);
            match key {
                0 => vp.from = self.vec3(kw.line, What::of("viewpoint 'from'"))?,
                1 => vp.at = self.vec3(kw.line, What::of("viewpoint 'at'"))?,
                2 => vp.up = self.vec3(kw.line, What::of("viewpoint 'up'"))?,
                3 => {
                    let (a, line) = self.number_at(kw.line, 1, What::of("viewpoint 'angle'"))?;
                    if !(a > 0.0 && a < 180.0) {
                        return Err(self.err(
                            line,
                            format!(
                                "viewpoint angle must be between 0 and 180 degrees \
                                 (exclusive), found {a}"
                            ),
                        ));
                    }
                    vp.angle_deg = a;
                }
                4 => {
                    let (h, line) = self.number_at(kw.line, 1, What::of("viewpoint 'hither'"))?;
                    if h < 0.0 {
                        return Err(self.err(
                            line,
                            format!("viewpoint hither distance must not be negative, found {h}"),
                        ));
                    }
                    vp.hither = h;
                }
                _ => (vp.width, vp.height) = self.resolution(kw.line)?,
            }
        }
        let [from_line, at_line, up_line, ..] = seen.map(|l| l.unwrap_or(v_line));
        let Some(dir) = direction(vp.at - vp.from) else {
            return Err(self.err(
                at_line,
                "viewpoint 'from' and 'at' are the same point (or too far apart)".to_string(),
            ));
        };
        let Some(up) = direction(vp.up) else {
            return Err(self.err(up_line, "viewpoint 'up' is the zero vector".to_string()));
        };
        if up.cross(dir).length() < 1e-6 {
            return Err(self.err(
                up_line,
                "viewpoint 'up' is parallel to the viewing direction (at - from)".to_string(),
            ));
        }
        for (p, line) in [(vp.from, from_line), (vp.at, at_line)] {
            if p.abs().max_element() > MAX_COORDINATE {
                return Err(self.err(
                    line,
                    format!(
                        "viewpoint beyond {MAX_COORDINATE:e} (single precision would overflow)"
                    ),
                ));
            }
        }
        self.scene.viewpoint = vp;
        self.scene.viewpoint_given = true;
        Ok(())
    }

    fn resolution(&mut self, kw_line: usize) -> Result<(u32, u32)> {
        let mut sides = [(0u64, Tok { text: "", line: 0 }); 2];
        for (side, name) in sides.iter_mut().zip(["width", "height"]) {
            let Some(tok) = self.lex.next() else {
                return Err(self.err(
                    kw_line,
                    "expected 2 numbers for viewpoint 'resolution' (width height), found end of \
                     file"
                        .to_string(),
                ));
            };
            match whole_number(tok.text) {
                Some(n) if n > 0 => *side = (n, tok),
                _ => {
                    return Err(self.err(
                        tok.line,
                        format!(
                            "expected a positive whole number (resolution {name}), found '{}'",
                            show(tok.text)
                        ),
                    ))
                }
            }
        }
        let max = self.opts.max_resolution;
        if let Some(&(_, tok)) = sides.iter().find(|(n, _)| *n > u64::from(max)) {
            return Err(self.err(
                tok.line,
                format!(
                    "resolution {}x{} exceeds the limit of {max} per side (raise it with \
                     --max-resolution)",
                    show(sides[0].1.text),
                    show(sides[1].1.text)
                ),
            ));
        }
        // Both fit in `max`, a u32.
        Ok((sides[0].0 as u32, sides[1].0 as u32))
    }

    fn light(&mut self, line: usize) -> Result<()> {
        let position = self.vec3(line, What::of("light position"))?;
        // The colour is optional: it counts only when it starts on the `l` line.
        let color = match self.lex.peek() {
            Some(t) if t.line == line && t.text.parse::<f32>().is_ok() => {
                Some(self.vec3(line, What::of("light colour (r g b)"))?)
            }
            _ => None,
        };
        if position.abs().max_element() > MAX_COORDINATE {
            return Err(self.err(
                line,
                format!(
                    "light position beyond {MAX_COORDINATE:e} (single precision would overflow)"
                ),
            ));
        }
        // Light colours in 0..=1e6: a colour of 3e38 overflowed to infinite pixels.
        let color = color.map(|c| {
            let clamped = c.clamp(Vec3::ZERO, Vec3::splat(1e6));
            if clamped != c {
                self.set_where(line);
                let warning = format!("{}: light colour {c} clamped to {clamped}", self.where_);
                self.scene.warnings.push(warning);
            }
            clamped
        });
        self.scene.lights.push(Light::point(position, color));
        Ok(())
    }

    fn material(&mut self, line: usize) -> Result<()> {
        let [r, g, b, kd, ks, shine, t, ior] =
            self.numbers(line, What::of("material (r g b Kd Ks Shine T ior)"))?;
        let (material, changed) = Material {
            color: Vec3::new(r, g, b),
            kd,
            ks,
            shine,
            t,
            ior,
            ..Material::default()
        }
        .clamped();
        // NFF's Ks is both the highlight and the mirror weight.
        let material = Material {
            mirror: material.ks,
            ..material
        };
        if !changed.is_empty() {
            self.set_where(line);
            let warning = format!("{}: material {}", self.where_, changed.join(", "));
            self.scene.warnings.push(warning);
        }
        self.scene.add_material(material);
        Ok(())
    }

    fn cone(&mut self, line: usize) -> Result<()> {
        let [bx, by, bz, br] = self.numbers(line, What::of("cone base (x y z radius)"))?;
        let [ax, ay, az, ar] = self.numbers(line, What::of("cone apex (x y z radius)"))?;
        self.set_where(line);
        self.scene.add_cone(
            Vec3::new(bx, by, bz),
            br,
            Vec3::new(ax, ay, az),
            ar,
            &self.where_,
        );
        Ok(())
    }

    fn vertex_count(&mut self, kw_line: usize, name: &str) -> Result<usize> {
        let Some(tok) = self.lex.next() else {
            return Err(self.err(
                kw_line,
                format!("expected a vertex count for {name}, found end of file"),
            ));
        };
        let t = show(tok.text);
        let Some(n) = whole_number(tok.text) else {
            return Err(self.err(
                tok.line,
                format!(
                    "expected a vertex count (a whole number of at least 3) for {name}, found \
                     '{t}'"
                ),
            ));
        };
        if n < 3 {
            return Err(self.err(
                tok.line,
                format!("a {name} needs at least 3 vertices, found a count of {t}"),
            ));
        }
        let max = self.opts.max_vertices;
        if n > max as u64 {
            return Err(self.err(
                tok.line,
                format!(
                    "{name} of {t} vertices exceeds the limit of {max} (raise it with \
                     --max-vertices)"
                ),
            ));
        }
        Ok(n as usize)
    }

    fn polygon(&mut self, line: usize, patch: bool) -> Result<()> {
        let name = if patch { "patch" } else { "polygon" };
        let n = self.vertex_count(line, name)?;
        self.vertices.clear();
        self.normals.clear();
        for i in 1..=n {
            let what = What {
                name,
                vertex: Some((i, n)),
            };
            if patch {
                let [x, y, z, nx, ny, nz] = self.numbers(line, what)?;
                self.vertices.push(Vec3::new(x, y, z));
                self.normals.push(Vec3::new(nx, ny, nz));
            } else {
                let v = self.vec3(line, what)?;
                self.vertices.push(v);
            }
        }
        self.set_where(line);
        if patch {
            self.scene
                .add_patch(&self.vertices, &self.normals, &self.where_);
        } else {
            self.scene.add_polygon(&self.vertices, &self.where_);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;
    use crate::shapes::{Shape, TriangleNormals};

    fn parse(text: &str) -> Result<Scene> {
        parse_nff(text, Path::new("t.nff"), &LoadOptions::default())
    }

    #[track_caller]
    fn parse_ok(text: &str) -> Scene {
        match parse(text) {
            Ok(s) => s,
            Err(e) => panic!("unexpected error: {e}"),
        }
    }

    #[track_caller]
    fn parse_err_with(text: &str, opts: &LoadOptions) -> (usize, String) {
        match parse_nff(text, Path::new("t.nff"), opts) {
            Err(Error::Parse {
                file,
                line,
                message,
            }) => {
                assert_eq!(file, Path::new("t.nff"));
                assert!(!message.contains('\n'), "multi-line message: {message}");
                (line, message)
            }
            Err(e) => panic!("not a parse error: {e:?}"),
            Ok(_) => panic!("parsed without error:\n{text}"),
        }
    }

    /// Asserts a parse error at `line` whose message contains `fragment`.
    #[track_caller]
    fn assert_err(text: &str, line: usize, fragment: &str) {
        let (l, m) = parse_err_with(text, &LoadOptions::default());
        assert!(m.contains(fragment), "message {m:?} lacks {fragment:?}");
        assert_eq!(l, line, "wrong line for {m:?}");
    }

    /// A valid viewpoint, 7 lines: what follows it starts at line 8.
    const VIEW: &str =
        "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.1\nresolution 32 24\n";

    fn view(rest: &str) -> String {
        format!("{VIEW}{rest}")
    }

    const SCENE: &str = "\
# a small scene
b 0.1 0.2 0.3
v
from 0 -5 1   # trailing comment
at 0 0 1
up 0 0 1
angle 40
hither 0.5
resolution 64 48
l 1 2 3
l 4 5 6 0.5 0.25 1
l 7 8 9
f 1 0 0 0.7 0.3 20 0 1
s 0 0 1 0.5
f 0 1 0 0.5 0.5 3 0.9 1.5
p 4
0 0 0
1 0 0
1 1 0
0 1 0
c 0 0 0 0.1 0 0 1 0.1
c 0 0 0 0.2
0 0 2 0
pp 3
0 0 0 0 0 1
1 0 0 0 0 1
0 1 0 0 1 1
";

    #[test]
    fn small_scene_parses() {
        let s = parse_ok(SCENE);
        assert_eq!(s.background, Vec3::new(0.1, 0.2, 0.3));
        let vp = &s.viewpoint;
        assert_eq!(vp.from, Vec3::new(0.0, -5.0, 1.0));
        assert_eq!(vp.at, Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(vp.up, Vec3::Z);
        assert_eq!(vp.angle_deg, 40.0);
        assert_eq!(vp.hither, 0.5);
        assert_eq!((vp.width, vp.height), (64, 48));
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);

        // Three lights: colourless ones get the SPD default 1/sqrt(3).
        assert_eq!(s.lights.len(), 3);
        let d = Color::splat(1.0 / 3f32.sqrt());
        assert_eq!(s.lights[0].position(), Some(Vec3::new(1.0, 2.0, 3.0)));
        assert_eq!(s.lights[0].color, Some(d));
        assert_eq!(s.lights[1].position(), Some(Vec3::new(4.0, 5.0, 6.0)));
        assert_eq!(s.lights[1].color, Some(Vec3::new(0.5, 0.25, 1.0)));
        assert_eq!(s.lights[2].color, Some(d));

        assert_eq!(s.materials.len(), 2);
        assert_eq!(
            s.materials[1],
            Material {
                color: Vec3::new(0.0, 1.0, 0.0),
                kd: 0.5,
                ks: 0.5,
                shine: 3.0,
                t: 0.9,
                ior: 1.5,
                mirror: 0.5,
                ..Material::default()
            }
        );

        // Sphere, 2 triangles of the square, 2 cones, 1 patch triangle.
        assert_eq!(s.shapes.len(), 6);
        assert_eq!(s.shape_material, vec![0, 1, 1, 1, 1, 1]);
        let Shape::Sphere(sp) = &s.shapes[0] else {
            panic!("{:?}", s.shapes[0])
        };
        assert_eq!((sp.center, sp.radius), (Vec3::Z, 0.5));
        for sh in &s.shapes[1..3] {
            let Shape::Triangle(t) = sh else {
                panic!("{sh:?}")
            };
            assert_eq!(t.face_normal, Vec3::Z);
            assert_eq!(t.normals, TriangleNormals::Flat);
        }
        let Shape::Cone(one_line) = &s.shapes[3] else {
            panic!("{:?}", s.shapes[3])
        };
        assert_eq!((one_line.apex, one_line.apex_radius), (Vec3::Z, 0.1));
        let Shape::Cone(two_lines) = &s.shapes[4] else {
            panic!("{:?}", s.shapes[4])
        };
        assert_eq!(two_lines.base_radius, 0.2);
        assert_eq!(
            (two_lines.apex, two_lines.apex_radius),
            (Vec3::Z * 2.0, 0.0)
        );
        let Shape::Triangle(pt) = &s.shapes[5] else {
            panic!("{:?}", s.shapes[5])
        };
        assert_eq!(pt.normals, TriangleNormals::Patch(0));
        assert_eq!(s.corners.len(), 1);
        let [n0, n1, n2] = s.corners[0].normals.unwrap();
        assert_eq!((n0, n1), (Vec3::Z, Vec3::Z));
        assert!((n2 - Vec3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn everything_on_one_line() {
        let s = parse_ok(
            "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 10 20 \
             l 1 1 1 s 0 0 0 1 p 3 0 0 0 1 0 0 0 1 0 c 0 0 0 1 0 0 1 1",
        );
        assert_eq!((s.viewpoint.width, s.viewpoint.height), (10, 20));
        assert_eq!(s.lights.len(), 1);
        assert_eq!(s.lights[0].color, Some(Color::ONE));
        assert_eq!(s.shapes.len(), 3);
    }

    #[test]
    fn viewpoint_keywords_in_any_order() {
        let s = parse_ok("v\nresolution 8 4\nup 0 0 1\nat 1 0 0\nhither 2\nangle 30\nfrom 0 0 0\n");
        let vp = &s.viewpoint;
        assert_eq!(
            (vp.width, vp.height, vp.hither, vp.angle_deg),
            (8, 4, 2.0, 30.0)
        );
        assert_eq!((vp.from, vp.at, vp.up), (Vec3::ZERO, Vec3::X, Vec3::Z));
    }

    #[test]
    fn light_colour_only_on_the_keyword_line() {
        // Colour on the same line, even split inside.
        let s = parse_ok(&view("l 0 0 9 0.2\n0.3 0.4\n"));
        assert_eq!(s.lights[0].color, Some(Vec3::new(0.2, 0.3, 0.4)));
        // Position split over lines: the colour still has to start on the `l` line.
        let s = parse_ok(&view("l 0\n0 9\nl 1 1 1 1 1 1\n"));
        assert_eq!(s.lights[0].color, Some(Color::splat(1.0 / 2f32.sqrt())));
        assert_eq!(s.lights[1].color, Some(Color::ONE));
        // Three numbers on the next line are not a colour.
        assert_err(&view("l 0 0 9\n1 1 1\n"), 9, "unexpected number '1'");
        // A truncated colour.
        assert_err(
            &view("l 0 0 9 1 1\ns 0 0 0 1\n"),
            9,
            "expected a number (light colour (r g b)), found 's'",
        );
    }

    #[test]
    fn comments_anywhere() {
        let s = parse_ok(&view(
            "#comment\n  # indented\np 3 # a triangle\n0 0 0 #first\n#between\n1 0 0\n0 1 0 #x\n\
             s 0 0 0 1 #",
        ));
        assert_eq!(s.shapes.len(), 2);
        // A comment starts only where a token may start.
        assert_err(
            &view("s 0 0 0 1#x\n"),
            8,
            "found '1#x' (put a space before '#' to start a comment)",
        );
        assert_err(
            &view("s#x\n"),
            8,
            "unknown entity 's#x' (put a space before '#'",
        );
    }

    #[test]
    fn crlf_and_cr_line_ends() {
        let crlf = view("s 0 0 0 1\n\ns 0 0 0 0\n").replace('\n', "\r\n");
        let s = parse_ok(&crlf);
        assert_eq!(s.warnings, vec!["t.nff:10: sphere of radius 0 skipped"]);
        let cr = view("s 0 0 0 0\nxyz\n").replace('\n', "\r");
        assert_err(&cr, 9, "unknown entity 'xyz'");
    }

    #[test]
    fn degenerate_geometry_warns_with_location() {
        let s = parse_ok(&view(
            "s 1 1 1 0\np 3\n0 0 0\n1 0 0\n2 0 0\nc 0 0 0 1\n0 0 0 1\ns 0 0 0 1\n",
        ));
        assert_eq!(s.shapes.len(), 1);
        assert_eq!(s.warnings.len(), 3);
        assert!(s.warnings[0].starts_with("t.nff:8:"), "{:?}", s.warnings);
        assert!(s.warnings[1].starts_with("t.nff:9:"), "{:?}", s.warnings);
        assert!(s.warnings[2].starts_with("t.nff:13:"), "{:?}", s.warnings);
    }

    #[test]
    fn default_material_and_bom() {
        let s = parse_ok(&format!("\u{feff}{VIEW}s 0 0 0 1\n\u{1a}"));
        assert_eq!(s.shape_material, vec![0]);
        assert_eq!(s.materials, vec![Material::default()]);
    }

    #[test]
    fn display_is_file_line_message() {
        let e = parse(&view("s 0 0 0\n")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.nff:8: expected 4 numbers for sphere (x y z radius), found end of file"
        );
    }

    #[test]
    fn truncated_entities() {
        assert_err(
            &view("p 3\n0 0 0\n1 0"),
            8,
            "expected 3 numbers for vertex 2 of polygon, found end of file",
        );
        assert_err(
            &view("p"),
            8,
            "expected a vertex count for polygon, found end of file",
        );
        assert_err(
            &view("pp 3\n0 0 0 0 0 1\n"),
            8,
            "expected 6 numbers for vertex 2 of patch, found end of file",
        );
        assert_err(
            &view("\n\nc 0 0 0 1\n0 0"),
            10,
            "cone apex (x y z radius), found end of file",
        );
        assert_err(&view("f 1 1 1 1"), 8, "expected 8 numbers for material");
        assert_err(&view("b 1"), 8, "background colour");
        assert_err(&view("l 1 2"), 8, "light position, found end of file");
        assert_err("v\nfrom 0 0", 2, "viewpoint 'from', found end of file");
        assert_err(
            "v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle",
            5,
            "expected a number for viewpoint 'angle'",
        );
        assert_err(
            "v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 9\nhither 0\nresolution 9",
            7,
            "resolution",
        );
        assert_err(
            "\n\nv\n",
            3,
            "expected 'from' for the viewpoint ('v'), found end of file",
        );
    }

    #[test]
    fn wrong_vertex_counts() {
        assert_err(
            &view("p 4\n0 0 0\n1 0 0\n1 1 0\ns 0 0 0 1\n"),
            12,
            "expected a number (vertex 4 of 4 of polygon), found 's'",
        );
        assert_err(
            &view("p 3\n0 0 0\n1 0 0\n1 1 0\n0 1 0\ns 0 0 0 1\n"),
            12,
            "unexpected number '0' where an entity should start",
        );
        assert_err(
            &view("pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0\n"),
            8,
            "expected 6 numbers for vertex 3 of patch, found end of file",
        );
        assert_err(
            &view("pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0\nf"),
            12,
            "expected a number (vertex 3 of 3 of patch), found 'f'",
        );
    }

    #[test]
    fn bad_counts() {
        let at_least_3 = "(a whole number of at least 3) for polygon";
        assert_err(&view("p -3\n"), 8, &format!("{at_least_3}, found '-3'"));
        assert_err(&view("p 3.5\n"), 8, &format!("{at_least_3}, found '3.5'"));
        assert_err(&view("p 3.0\n"), 8, &format!("{at_least_3}, found '3.0'"));
        assert_err(&view("p x\n"), 8, &format!("{at_least_3}, found 'x'"));
        assert_err(&view("p\n\ns"), 10, &format!("{at_least_3}, found 's'"));
        assert_err(
            &view("p 0\n"),
            8,
            "a polygon needs at least 3 vertices, found a count of 0",
        );
        assert_err(
            &view("p 2\n0 0 0\n1 1 1\n"),
            8,
            "a polygon needs at least 3 vertices",
        );
        assert_err(
            &view("pp 1\n0 0 0 0 0 1\n"),
            8,
            "a patch needs at least 3 vertices",
        );
        assert_err(
            &view("p 1000001\n"),
            8,
            "polygon of 1000001 vertices exceeds the limit of 1000000 (raise it with \
             --max-vertices)",
        );
        assert_err(
            &view("pp 99999999999999999999999\n"),
            8,
            "exceeds the limit",
        );
        let opts = LoadOptions {
            max_vertices: 3,
            ..LoadOptions::default()
        };
        let (line, m) = parse_err_with(&view("p 4 0 0 0 1 0 0 1 1 0 0 1 0"), &opts);
        assert_eq!(line, 8);
        assert!(m.contains("limit of 3"), "{m}");
        assert!(parse_nff(&view("p 3 0 0 0 1 0 0 1 1 0"), Path::new("t.nff"), &opts).is_ok());
    }

    #[test]
    fn non_finite_numbers() {
        for bad in ["nan", "NaN", "inf", "-inf", "infinity", "1e39"] {
            assert_err(
                &view(&format!("s 0 0\n{bad} 1\n")),
                9,
                &format!("expected a finite number, found '{bad}'"),
            );
        }
        assert_err(
            &view("f 1 1 1 nan 0 0 0 1"),
            8,
            "expected a finite number, found 'nan' (material",
        );
        assert_err(&view("l 0 0 0 1 inf 1"), 8, "found 'inf' (light colour");
        assert_err("v from 0 0 nan", 1, "found 'nan' (viewpoint 'from')");
    }

    #[test]
    fn not_numbers() {
        assert_err(
            &view("s 0 0 1,5 1\n"),
            8,
            "expected a number (sphere (x y z radius)), found '1,5'",
        );
        assert_err(&view("c 0 0 0 1 0 0 1 one\n"), 8, "cone apex");
        assert_err(
            &view("f 1 1 1 0.5 0.5 3 0 s"),
            8,
            "expected a number (material",
        );
    }

    #[test]
    fn unknown_keywords() {
        assert_err(
            &view("s 0 0 0 1\nxyz 1 2 3\n"),
            9,
            "unknown entity 'xyz' (expected one of v, b, l, f, c, s, p, pp)",
        );
        assert_err(&view("S 0 0 0 1\n"), 8, "unknown entity 'S'");
        assert_err(&view("hither 1\n"), 8, "'hither' outside a viewpoint ('v')");
        assert_err("nff\nversion 2.0\n", 1, "Sense8");
        // Control characters are escaped, long tokens shortened.
        let long = "y".repeat(100);
        let (_, m) = parse_err_with(&view(&long), &LoadOptions::default());
        assert!(m.len() < 150, "{m}");
        assert_err(&view("\u{85}x"), 8, "unknown entity '\\u{85}x'");
    }

    #[test]
    fn binary_garbage() {
        let opts = LoadOptions::default();
        let bytes = [VIEW.as_bytes(), b"s 0 0 0 1\n\xff\xfe\x00\x01"].concat();
        match parse_nff_bytes(&bytes, Path::new("t.nff"), &opts) {
            Err(Error::Parse { line, message, .. }) => {
                assert_eq!(line, 9);
                assert!(
                    message.contains("not a text file: invalid UTF-8"),
                    "{message}"
                );
            }
            other => panic!("{other:?}"),
        }
        assert_err(
            &view("s 0 0 0 1\n\ns 0\0 0 0 1"),
            10,
            "not a text file: control character 0x00",
        );
        assert_err("\x7fELF\x02\x01", 1, "not a text file");
    }

    #[test]
    fn missing_viewpoint() {
        assert_err(
            "s 0 0 0 1\n\ns 1 1 1 1\n",
            3,
            "no viewpoint ('v') in the scene",
        );
        assert_err("s 0 0 0 1\ns 1 1 1 1", 2, "no viewpoint ('v') in the scene");
        assert_err("", 1, "no viewpoint ('v') in the scene");
        assert_err("# nothing\n", 1, "no viewpoint ('v') in the scene");
    }

    #[test]
    fn bad_viewpoints() {
        const V: &str = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\n";
        let tail = "hither 0\nresolution 8 8\n";
        assert_err(
            &format!("{V}angle 0\n{tail}"),
            5,
            "between 0 and 180 degrees",
        );
        assert_err(&format!("{V}angle 180\n{tail}"), 5, "found 180");
        assert_err(&format!("{V}angle -5\n{tail}"), 5, "between 0 and 180");
        assert_err(
            &format!("{V}angle 45\nhither -1\nresolution 8 8\n"),
            6,
            "hither",
        );
        assert_err(
            &format!("{V}angle 45\nresolution 8 8\ns 0 0 0 1\n"),
            7,
            "expected 'hither' for the viewpoint ('v'), found 's'",
        );
        assert_err(
            &format!("{V}angle 45\nresolution 8 8\n"),
            1,
            "expected 'hither' for the viewpoint ('v'), found end of file",
        );
        assert_err(
            &format!("{V}from 1 1 1\n"),
            5,
            "'from' given twice in the viewpoint (first at line 2)",
        );
        assert_err(
            "v\nfrom 1 2 3\nat 1 2 3\nup 0 1 0\nangle 9\nhither 0\nresolution 8 8\n",
            3,
            "'from' and 'at' are the same point",
        );
        assert_err(
            "v\nfrom 0 0 0\nat 0 5 0\nup 0 -2 0\nangle 9\nhither 0\nresolution 8 8\n",
            4,
            "parallel",
        );
        assert_err(
            "v\nfrom 0 0 0\nat 0 5 0\nup 0 0 0\nangle 9\nhither 0\nresolution 8 8\n",
            4,
            "zero vector",
        );
        assert_err(
            "v\nfrom 0 0 -3e38\nat 0 0 3e38\nup 0 1 0\nangle 9\nhither 0\nresolution 8 8\n",
            3,
            "too far apart",
        );
        assert_err(
            &format!("{V}angle 45\nhither 0\nresolution 0 8\n"),
            7,
            "expected a positive whole number (resolution width), found '0'",
        );
        assert_err(
            &format!("{V}angle 45\nhither 0\nresolution 8\n-8\n"),
            8,
            "(resolution height), found '-8'",
        );
        assert_err(
            &format!("{V}angle 45\nhither 0\nresolution 8 12.5\n"),
            7,
            "found '12.5'",
        );
        assert_err(
            &format!("{VIEW}s 0 0 0 1\n\n{VIEW}"),
            10,
            "a second viewpoint ('v'); the first is at line 1",
        );
    }

    #[test]
    fn resolution_limit() {
        let text = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\n\
                    resolution 100000 100000\n";
        assert_err(
            text,
            7,
            "resolution 100000x100000 exceeds the limit of 16384 per side (raise it with \
             --max-resolution)",
        );
        let huge = text.replace("100000 100000", "16384 99999999999999999999999");
        assert_err(&huge, 7, "exceeds the limit of 16384");
        let opts = LoadOptions {
            max_resolution: 100_000,
            ..LoadOptions::default()
        };
        let s = parse_nff(text, Path::new("t.nff"), &opts).unwrap();
        assert_eq!((s.viewpoint.width, s.viewpoint.height), (100_000, 100_000));
        let opts = LoadOptions {
            max_resolution: 100,
            ..LoadOptions::default()
        };
        let (line, m) = parse_err_with(VIEW.replace("32 24", "32\n240").as_str(), &opts);
        assert_eq!(line, 8);
        assert!(
            m.contains("32x240 exceeds the limit of 100 per side"),
            "{m}"
        );
    }

    /// The outcome must be a scene or a one-line parse error with a sane line.
    #[track_caller]
    fn check_no_panic(result: Result<Scene>, text_lines: usize) {
        match result {
            Ok(_) => {}
            Err(Error::Parse { line, message, .. }) => {
                assert!(
                    line >= 1 && line <= text_lines.max(1),
                    "line {line}: {message}"
                );
                assert!(!message.contains('\n'), "{message}");
            }
            Err(e) => panic!("unexpected error kind {e:?}"),
        }
    }

    fn count_lines(bytes: &[u8]) -> usize {
        line_at(bytes, bytes.len())
    }

    #[test]
    fn every_prefix_of_a_scene() {
        let opts = LoadOptions::default();
        for n in 0..=SCENE.len() {
            let prefix = &SCENE.as_bytes()[..n];
            let r = parse_nff_bytes(prefix, Path::new("t.nff"), &opts);
            check_no_panic(r, count_lines(prefix));
        }
        assert!(parse(SCENE).is_ok());
    }

    #[test]
    fn random_bytes_do_not_panic() {
        let opts = LoadOptions::default();
        let mut rng = fastrand::Rng::with_seed(42);
        let alphabet = b"vblfcsp0123456789.-+e \n\r\t#nai";
        for round in 0..3000 {
            let len = rng.usize(..200);
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    if round % 2 == 0 {
                        rng.u8(..)
                    } else {
                        alphabet[rng.usize(..alphabet.len())]
                    }
                })
                .collect();
            let mut with_view = VIEW.as_bytes().to_vec();
            with_view.extend_from_slice(&bytes);
            for b in [&bytes, &with_view] {
                let r = parse_nff_bytes(b, Path::new("t.nff"), &opts);
                check_no_panic(r, count_lines(b));
            }
        }
    }

    #[test]
    fn random_token_soup_does_not_panic() {
        const WORDS: &[&str] = &[
            "v",
            "from",
            "at",
            "up",
            "angle",
            "hither",
            "resolution",
            "b",
            "l",
            "f",
            "c",
            "s",
            "p",
            "pp",
            "0",
            "1",
            "-1",
            "2",
            "3",
            "4",
            "0.5",
            "90",
            "1e30",
            "-3e38",
            "nan",
            "inf",
            "#",
            "#x",
            "\n",
            "\n",
            "\n",
            "\r\n",
            "\r",
            "x",
            "100000",
            "-0",
            "1e-45",
        ];
        let opts = LoadOptions {
            max_vertices: 50,
            ..LoadOptions::default()
        };
        let mut rng = fastrand::Rng::with_seed(7);
        let mut oks = 0;
        for round in 0..5000 {
            let mut text = if round % 2 == 0 {
                String::new()
            } else {
                VIEW.to_string()
            };
            for _ in 0..rng.usize(..120) {
                text.push_str(WORDS[rng.usize(..WORDS.len())]);
                text.push(' ');
            }
            let r = parse_nff(&text, Path::new("t.nff"), &opts);
            oks += r.is_ok() as usize;
            check_no_panic(r, count_lines(text.as_bytes()));
        }
        assert!(oks > 0);
    }
}
