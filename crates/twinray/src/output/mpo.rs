//! MPO: CIPA DC-007 Multi-Picture Object, the stereo format of 3D cameras
//! (Fujifilm W1/W3, Nintendo 3DS), read by 3D TVs, StereoPhoto Maker and
//! exiftool.
//!
//! The file is two baseline JPEGs (quality 95) one after the other, left eye
//! first. Each carries an APP2 segment `"MPF\0"` followed by a big-endian
//! TIFF structure (the *MP header*; every offset inside it counts from its
//! `MM` byte-order mark), spliced in after the encoder's leading APP0/APP1
//! segments:
//!
//! * Left (first) image: the **MP Index IFD** — `MPFVersion` "0100",
//!   `NumberOfImages` 2, `MPEntry` (2 × 16 bytes) — whose next-IFD pointer
//!   leads to its **MP Attribute IFD**.
//! * Right (second) image: an MP Attribute IFD only.
//!
//! MP entries: individual image attribute = type 0x020002 *Multi-Frame Image,
//! Disparity*, data format 0 (JPEG); the first entry also has the
//! *representative image* flag (bit 29). The *dependent parent / child* flags
//! (bits 31, 30) stay clear: DC-007 sets them only for images that have
//! dependent images (e.g. a primary with large thumbnails), which disparity
//! frames do not; likewise the dependent image entry numbers are 0. Size is
//! the whole individual image, SOI to EOI. Offset is 0 for the first image
//! and, for the second, its distance from the first image's MP header.
//!
//! MP Attribute IFD (both images): `MPFVersion`, `MPIndividualNum` (1, 2),
//! `BaseViewpointNum` 1 (the left eye is the base viewpoint),
//! `ConvergenceAngle` 0° (assumes parallel optical axes: a rig that converges
//! by shifting the image planes, not by toe-in), `BaselineLength` in metres,
//! and `AxisDistanceX/Y/Z` in metres of this viewpoint from the base one
//! (left 0; right +interaxial along X, i.e. to the right).

use std::path::Path;

use crate::output::atomic::{write_atomically, Failure};
use crate::output::check_pair;
use crate::output::encode::{jpeg_bytes, WriteOptions};
use crate::{Error, Image, Result};

/// MP type code of a stereo frame: Multi-Frame Image, Disparity.
pub const MP_TYPE_DISPARITY: u32 = 0x02_0002;
/// Flag of the representative image in the individual image attribute.
pub const MP_FLAG_REPRESENTATIVE: u32 = 1 << 29;

const APP2: u8 = 0xE2;

// Tags (DC-007 §5.2).
const TAG_MPF_VERSION: u16 = 0xB000;
const TAG_NUMBER_OF_IMAGES: u16 = 0xB001;
const TAG_MP_ENTRY: u16 = 0xB002;
const TAG_MP_INDIVIDUAL_NUM: u16 = 0xB101;
const TAG_BASE_VIEWPOINT_NUM: u16 = 0xB204;
const TAG_CONVERGENCE_ANGLE: u16 = 0xB205;
const TAG_BASELINE_LENGTH: u16 = 0xB206;
const TAG_AXIS_DISTANCE_X: u16 = 0xB208;
const TAG_AXIS_DISTANCE_Y: u16 = 0xB209;
const TAG_AXIS_DISTANCE_Z: u16 = 0xB20A;

// TIFF field types.
const UNDEFINED: u16 = 7;
const LONG: u16 = 4;
const RATIONAL: u16 = 5;
const SRATIONAL: u16 = 10;

/// Writes the stereo pair as an MPO at `path`, atomically.
///
/// `interaxial_m` is the distance between the two viewpoints **in metres**
/// (finite, ≥ 0, below ~4 km); it is stored as `BaselineLength` and as the
/// right image's `AxisDistanceX`. `opts` applies to the 8-bit quantisation
/// of both JPEGs (sRGB curve or not).
pub fn write_mpo(
    path: &Path,
    left: &Image,
    right: &Image,
    interaxial_m: f64,
    opts: &WriteOptions,
) -> Result<()> {
    check_pair(left, right)?;
    if !interaxial_m.is_finite() || !(0.0..4.0e3).contains(&interaxial_m) {
        return Err(Error::Invalid(format!(
            "an MPO's interaxial (its BaselineLength) must be a finite length in metres \
             between 0 and 4000, not {interaxial_m}"
        )));
    }
    write_atomically(path, |w| {
        let bytes = mpo_bytes(left, right, interaxial_m, opts)?;
        w.write_all(&bytes)?;
        Ok(())
    })
}

fn mpo_bytes(
    left: &Image,
    right: &Image,
    interaxial_m: f64,
    opts: &WriteOptions,
) -> std::result::Result<Vec<u8>, Failure> {
    let jpeg_l = jpeg_bytes(left, opts)?;
    let jpeg_r = jpeg_bytes(right, opts)?;
    let pos_l = insertion_point(&jpeg_l)?;
    let pos_r = insertion_point(&jpeg_r)?;

    let attr_r = attribute_ifd_entries(2, interaxial_m, interaxial_m);
    let seg_r = app2_segment(&mp_header(&[], &attr_r))?;
    let size_r = jpeg_r.len() + seg_r.len();

    // Pass 1 with placeholder entries gives the sizes (every field has a
    // fixed length); pass 2 fills in the real sizes and offsets.
    let attr_l = attribute_ifd_entries(1, interaxial_m, 0.0);
    let placeholder = index_ifd_entries(&[[0; 16]; 2]);
    let seg_l_len = app2_segment(&mp_header(&placeholder, &attr_l))?.len();
    let size_l = jpeg_l.len() + seg_l_len;
    // The MP header starts after the marker (2), length (2) and "MPF\0" (4).
    let mp_header_start = pos_l + 8;
    let offset_r = size_l - mp_header_start;
    let entries = [
        mp_entry(MP_FLAG_REPRESENTATIVE | MP_TYPE_DISPARITY, size_l, 0)?,
        mp_entry(MP_TYPE_DISPARITY, size_r, offset_r)?,
    ];
    let seg_l = app2_segment(&mp_header(&index_ifd_entries(&entries), &attr_l))?;
    if seg_l.len() != seg_l_len {
        return Err(Failure::encode("internal error: MPF segment changed size"));
    }

    let mut out = Vec::with_capacity(size_l + size_r);
    out.extend_from_slice(&jpeg_l[..pos_l]);
    out.extend_from_slice(&seg_l);
    out.extend_from_slice(&jpeg_l[pos_l..]);
    out.extend_from_slice(&jpeg_r[..pos_r]);
    out.extend_from_slice(&seg_r);
    out.extend_from_slice(&jpeg_r[pos_r..]);
    Ok(out)
}

/// Where the MPF segment goes: after SOI and any APP0 (JFIF) / APP1 (Exif)
/// segments directly following it, as DC-007 places it.
fn insertion_point(jpeg: &[u8]) -> std::result::Result<usize, Failure> {
    if jpeg.get(..2) != Some(&[0xFF, 0xD8]) {
        return Err(Failure::encode(
            "JPEG encoder output does not start with SOI",
        ));
    }
    let mut pos = 2;
    while let Some(&[0xFF, marker, hi, lo]) = jpeg.get(pos..pos + 4) {
        if marker != 0xE0 && marker != 0xE1 {
            break;
        }
        pos += 2 + u16::from_be_bytes([hi, lo]) as usize;
    }
    if pos > jpeg.len() {
        return Err(Failure::encode(
            "JPEG encoder output has a truncated segment",
        ));
    }
    Ok(pos)
}

fn mp_entry(attribute: u32, size: usize, offset: usize) -> std::result::Result<[u8; 16], Failure> {
    let too_big = |_| Failure::encode("MPO image larger than 4 GiB");
    let size = u32::try_from(size).map_err(too_big)?;
    let offset = u32::try_from(offset).map_err(too_big)?;
    let mut e = [0u8; 16];
    e[0..4].copy_from_slice(&attribute.to_be_bytes());
    e[4..8].copy_from_slice(&size.to_be_bytes());
    e[8..12].copy_from_slice(&offset.to_be_bytes());
    // Dependent image 1 and 2 entry numbers: none.
    Ok(e)
}

/// A TIFF field: tag, type, count and the value bytes (big-endian).
struct Field {
    tag: u16,
    kind: u16,
    count: u32,
    value: Vec<u8>,
}

fn long(tag: u16, v: u32) -> Field {
    Field {
        tag,
        kind: LONG,
        count: 1,
        value: v.to_be_bytes().to_vec(),
    }
}

fn rational_field(tag: u16, kind: u16, (num, den): (u32, u32)) -> Field {
    let mut value = num.to_be_bytes().to_vec();
    value.extend_from_slice(&den.to_be_bytes());
    Field {
        tag,
        kind,
        count: 1,
        value,
    }
}

fn version() -> Field {
    Field {
        tag: TAG_MPF_VERSION,
        kind: UNDEFINED,
        count: 4,
        value: b"0100".to_vec(),
    }
}

/// A non-negative length in metres as a fraction with a power-of-ten
/// denominator (micrometre precision while the numerator stays at most
/// `max`: `u32::MAX` for RATIONAL, `i32::MAX` for SRATIONAL), reduced.
fn rational(v: f64, max: u32) -> (u32, u32) {
    let mut den: u32 = 1_000_000;
    while den > 1 && v * den as f64 > max as f64 {
        den /= 10;
    }
    let num = (v * den as f64).round().clamp(0.0, max as f64) as u32;
    let g = gcd(num, den);
    (num / g, den / g)
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 {
        a.max(1)
    } else {
        gcd(b, a % b)
    }
}

fn index_ifd_entries(entries: &[[u8; 16]]) -> Vec<Field> {
    vec![
        version(),
        Field {
            tag: TAG_NUMBER_OF_IMAGES,
            kind: LONG,
            count: 1,
            value: (entries.len() as u32).to_be_bytes().to_vec(),
        },
        Field {
            tag: TAG_MP_ENTRY,
            kind: UNDEFINED,
            count: (entries.len() * 16) as u32,
            value: entries.concat(),
        },
    ]
}

/// The MP Attribute IFD of image `individual`, `axis_x_m` metres to the
/// right of the base viewpoint.
fn attribute_ifd_entries(individual: u32, interaxial_m: f64, axis_x_m: f64) -> Vec<Field> {
    let signed_max = i32::MAX as u32;
    vec![
        version(),
        long(TAG_MP_INDIVIDUAL_NUM, individual),
        long(TAG_BASE_VIEWPOINT_NUM, 1),
        rational_field(TAG_CONVERGENCE_ANGLE, SRATIONAL, (0, 1)),
        rational_field(
            TAG_BASELINE_LENGTH,
            RATIONAL,
            rational(interaxial_m, u32::MAX),
        ),
        rational_field(
            TAG_AXIS_DISTANCE_X,
            SRATIONAL,
            rational(axis_x_m, signed_max),
        ),
        rational_field(TAG_AXIS_DISTANCE_Y, SRATIONAL, (0, 1)),
        rational_field(TAG_AXIS_DISTANCE_Z, SRATIONAL, (0, 1)),
    ]
}

/// Appends an IFD at `out.len()` (offsets relative to `out[0]`, the TIFF
/// header) with its out-of-line values right after it; returns the position
/// of its next-IFD pointer so the caller can link another IFD.
fn write_ifd(out: &mut Vec<u8>, fields: &[Field]) -> usize {
    let start = out.len();
    let ifd_len = 2 + 12 * fields.len() + 4;
    let mut data_pos = start + ifd_len;
    let mut data = Vec::new();
    out.extend_from_slice(&(fields.len() as u16).to_be_bytes());
    for f in fields {
        out.extend_from_slice(&f.tag.to_be_bytes());
        out.extend_from_slice(&f.kind.to_be_bytes());
        out.extend_from_slice(&f.count.to_be_bytes());
        if f.value.len() <= 4 {
            let mut inline = [0u8; 4];
            inline[..f.value.len()].copy_from_slice(&f.value);
            out.extend_from_slice(&inline);
        } else {
            out.extend_from_slice(&(data_pos as u32).to_be_bytes());
            data.extend_from_slice(&f.value);
            data_pos += f.value.len();
            if data_pos % 2 == 1 {
                // TIFF values start on word boundaries.
                data.push(0);
                data_pos += 1;
            }
        }
    }
    let next_pointer = out.len();
    out.extend_from_slice(&0u32.to_be_bytes());
    out.extend_from_slice(&data);
    next_pointer
}

/// The MP header (TIFF structure): the index IFD (if any) linked to the
/// attribute IFD.
fn mp_header(index: &[Field], attributes: &[Field]) -> Vec<u8> {
    let mut out = b"MM\x00\x2A\x00\x00\x00\x08".to_vec();
    if index.is_empty() {
        write_ifd(&mut out, attributes);
    } else {
        let next = write_ifd(&mut out, index);
        let attr_start = out.len() as u32;
        out[next..next + 4].copy_from_slice(&attr_start.to_be_bytes());
        write_ifd(&mut out, attributes);
    }
    out
}

fn app2_segment(mp_header: &[u8]) -> std::result::Result<Vec<u8>, Failure> {
    let len = u16::try_from(2 + 4 + mp_header.len())
        .map_err(|_| Failure::encode("MPF segment too long"))?;
    let mut seg = vec![0xFF, APP2];
    seg.extend_from_slice(&len.to_be_bytes());
    seg.extend_from_slice(b"MPF\0");
    seg.extend_from_slice(mp_header);
    Ok(seg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;

    fn eye(c: Color) -> Image {
        let mut img = Image::new(24, 16);
        img.pixels.fill(c);
        img
    }

    /// (marker, segment payload start, payload end) of the header segments
    /// of the JPEG starting at `start`, up to SOS.
    fn segments(bytes: &[u8], start: usize) -> Vec<(u8, usize, usize)> {
        assert_eq!(&bytes[start..start + 2], &[0xFF, 0xD8], "SOI at {start}");
        let mut pos = start + 2;
        let mut out = Vec::new();
        loop {
            assert_eq!(bytes[pos], 0xFF);
            let marker = bytes[pos + 1];
            let len = u16::from_be_bytes([bytes[pos + 2], bytes[pos + 3]]) as usize;
            out.push((marker, pos + 4, pos + 2 + len));
            if marker == 0xDA {
                return out;
            }
            pos += 2 + len;
        }
    }

    struct Ifd {
        fields: Vec<(u16, u16, u32, [u8; 4])>,
        next: u32,
    }

    fn be16(b: &[u8], at: usize) -> u16 {
        u16::from_be_bytes([b[at], b[at + 1]])
    }
    fn be32(b: &[u8], at: usize) -> u32 {
        u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
    }

    fn parse_ifd(tiff: &[u8], at: usize) -> Ifd {
        let n = be16(tiff, at) as usize;
        let fields = (0..n)
            .map(|i| {
                let e = at + 2 + 12 * i;
                let mut v = [0u8; 4];
                v.copy_from_slice(&tiff[e + 8..e + 12]);
                (be16(tiff, e), be16(tiff, e + 2), be32(tiff, e + 4), v)
            })
            .collect();
        Ifd {
            fields,
            next: be32(tiff, at + 2 + 12 * n),
        }
    }

    fn field(ifd: &Ifd, tag: u16) -> (u16, u32, [u8; 4]) {
        let f = ifd
            .fields
            .iter()
            .find(|f| f.0 == tag)
            .unwrap_or_else(|| panic!("tag {tag:#x}"));
        (f.1, f.2, f.3)
    }

    fn rational_at(tiff: &[u8], value: [u8; 4]) -> f64 {
        let at = u32::from_be_bytes(value) as usize;
        be32(tiff, at) as f64 / be32(tiff, at + 4) as f64
    }

    fn mpf_payload(bytes: &[u8], start: usize) -> (usize, usize) {
        let segs = segments(bytes, start);
        let &(_, s, e) = segs
            .iter()
            .find(|&&(m, s, _)| m == APP2 && &bytes[s..s + 4] == b"MPF\0")
            .expect("APP2 MPF segment");
        // JFIF APP0 must stay first.
        assert_eq!(segs[0].0, 0xE0);
        (s + 4, e)
    }

    #[test]
    fn mpo_structure_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pair.mpo");
        let red = Color::new(1.0, 0.0, 0.0);
        let blue = Color::new(0.0, 0.0, 1.0);
        write_mpo(
            &path,
            &eye(red),
            &eye(blue),
            0.065,
            &WriteOptions::default(),
        )
        .unwrap();
        let bytes = std::fs::read(&path).unwrap();

        // First image: MP index IFD.
        let (h0, h_end) = mpf_payload(&bytes, 0);
        let tiff = &bytes[h0..h_end];
        assert_eq!(&tiff[..8], b"MM\x00\x2A\x00\x00\x00\x08");
        let index = parse_ifd(tiff, 8);
        let tags: Vec<u16> = index.fields.iter().map(|f| f.0).collect();
        assert_eq!(tags, [0xB000, 0xB001, 0xB002]);
        assert_eq!(field(&index, 0xB000), (UNDEFINED, 4, *b"0100"));
        assert_eq!(field(&index, 0xB001), (LONG, 1, 2u32.to_be_bytes()));
        let (kind, count, off) = field(&index, 0xB002);
        assert_eq!((kind, count), (UNDEFINED, 32));
        let entries = u32::from_be_bytes(off) as usize;
        let entry = |i: usize| {
            let e = entries + 16 * i;
            (
                be32(tiff, e),
                be32(tiff, e + 4) as usize,
                be32(tiff, e + 8) as usize,
            )
        };
        let (attr1, size1, off1) = entry(0);
        let (attr2, size2, off2) = entry(1);
        assert_eq!(attr1 & 0x00FF_FFFF, 0x020002);
        assert_eq!(attr2 & 0x00FF_FFFF, 0x020002);
        assert_eq!(
            attr1 >> 24,
            0x20,
            "representative, JPEG, no dependency flags"
        );
        assert_eq!(attr2 >> 24, 0x00);
        assert_eq!(off1, 0);
        assert_eq!(size1 + size2, bytes.len());
        // Second SOI: at size1, which the offset reaches from the MP header.
        assert_eq!(h0 + off2, size1);
        assert_eq!(&bytes[size1..size1 + 2], &[0xFF, 0xD8]);
        assert_eq!(&bytes[size1 - 2..size1], &[0xFF, 0xD9], "first EOI");
        assert_eq!(&bytes[bytes.len() - 2..], &[0xFF, 0xD9], "second EOI");

        // First image's attribute IFD, linked from the index IFD.
        let attrs = parse_ifd(tiff, index.next as usize);
        assert_eq!(attrs.next, 0);
        assert_eq!(field(&attrs, 0xB101).2, 1u32.to_be_bytes());
        assert_eq!(field(&attrs, 0xB204).2, 1u32.to_be_bytes());
        let (kind, _, v) = field(&attrs, 0xB206);
        assert_eq!(kind, RATIONAL);
        assert!((rational_at(tiff, v) - 0.065).abs() < 1e-9);
        assert_eq!(rational_at(tiff, field(&attrs, 0xB205).2), 0.0);
        let sorted: Vec<u16> = attrs.fields.iter().map(|f| f.0).collect();
        assert!(sorted.windows(2).all(|w| w[0] < w[1]), "tags ascending");

        // Second image's attribute IFD.
        let (h1, h1_end) = mpf_payload(&bytes, size1);
        let tiff2 = &bytes[h1..h1_end];
        let attrs2 = parse_ifd(tiff2, 8);
        assert_eq!(field(&attrs2, 0xB000).2, *b"0100");
        assert_eq!(field(&attrs2, 0xB101).2, 2u32.to_be_bytes());
        assert!((rational_at(tiff2, field(&attrs2, 0xB206).2) - 0.065).abs() < 1e-9);
        assert!((rational_at(tiff2, field(&attrs2, 0xB208).2) - 0.065).abs() < 1e-9);

        // Both JPEGs decode, left eye first.
        let decode = |b: &[u8]| {
            ::image::load_from_memory_with_format(b, ::image::ImageFormat::Jpeg)
                .unwrap()
                .to_rgb8()
        };
        let first = decode(&bytes[..size1]);
        let second = decode(&bytes[size1..]);
        assert_eq!(first.dimensions(), (24, 16));
        assert_eq!(second.dimensions(), (24, 16));
        let p1 = first.get_pixel(5, 5).0;
        let p2 = second.get_pixel(5, 5).0;
        assert!(p1[0] > 200 && p1[2] < 50, "left is red: {p1:?}");
        assert!(p2[2] > 200 && p2[0] < 50, "right is blue: {p2:?}");
        // A plain JPEG reader shows the left eye.
        let whole = decode(&bytes);
        assert_eq!(whole.get_pixel(5, 5).0, p1);
    }

    #[test]
    fn rationals() {
        assert_eq!(rational(0.065, u32::MAX), (13, 200));
        assert_eq!(rational(0.0, u32::MAX), (0, 1));
        assert_eq!(rational(1.0, u32::MAX), (1, 1));
        let (n, d) = rational(3999.123456, u32::MAX);
        assert!((n as f64 / d as f64 - 3999.123456).abs() < 1e-6);
    }

    #[test]
    fn large_interaxials_fit_signed_rationals() {
        let fields = attribute_ifd_entries(2, 3999.5, 3999.5);
        let ax = fields
            .iter()
            .find(|f| f.tag == TAG_AXIS_DISTANCE_X)
            .unwrap();
        let n = u32::from_be_bytes(ax.value[..4].try_into().unwrap());
        let d = u32::from_be_bytes(ax.value[4..].try_into().unwrap());
        assert!(n <= i32::MAX as u32 && d <= i32::MAX as u32);
        assert!((n as f64 / d as f64 - 3999.5).abs() < 1e-2);
    }

    #[test]
    fn bad_parameters_are_errors_and_write_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.mpo");
        let l = eye(Color::ONE);
        let opts = WriteOptions::default();
        for b in [f64::NAN, -0.1, f64::INFINITY, 1e9] {
            assert!(matches!(
                write_mpo(&path, &l, &l, b, &opts),
                Err(Error::Invalid(_))
            ));
        }
        let small = Image::new(3, 3);
        assert!(matches!(
            write_mpo(&path, &l, &small, 0.1, &opts),
            Err(Error::Invalid(_))
        ));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    /// Cross-check with exiftool, the reference reader. Skipped (with a
    /// notice) where exiftool is missing, except on CI (`CI` set).
    #[test]
    fn exiftool_reads_the_mpo() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pair.mpo");
        let (l, r) = (
            eye(Color::new(0.8, 0.1, 0.1)),
            eye(Color::new(0.1, 0.1, 0.8)),
        );
        write_mpo(&path, &l, &r, 0.065, &WriteOptions::default()).unwrap();
        let output = match std::process::Command::new("exiftool")
            .args(["-j", "-G"])
            .arg(&path)
            .output()
        {
            Ok(o) => o,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                if std::env::var_os("CI").is_some() {
                    panic!("exiftool is required on CI (apt-get install libimage-exiftool-perl)");
                }
                eprintln!("notice: exiftool not found, skipping the MPO cross-check");
                return;
            }
            Err(e) => panic!("cannot run exiftool: {e}"),
        };
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        let tags = &json[0];
        let text = |k: &str| tags[k].to_string();
        assert_eq!(tags["MPF:NumberOfImages"], 2, "{tags:#}");
        assert_eq!(tags["MPF:MPFVersion"], "0100", "{tags:#}");
        // MPImage2 is a composite tag, grouped as MPF by recent versions.
        assert!(
            tags.get("MPF:MPImage2")
                .or(tags.get("Composite:MPImage2"))
                .is_some(),
            "{tags:#}"
        );
        let kind = text("MPF:MPImageType").to_lowercase();
        assert!(
            kind.contains("multi-frame") && kind.contains("disparity"),
            "{tags:#}"
        );
        assert_eq!(tags["MPF:BaseViewpointNum"], 1);
        let baseline = tags["MPF:BaselineLength"].as_f64().unwrap_or(f64::NAN);
        assert!((baseline - 0.065).abs() < 1e-6, "{tags:#}");
        assert!(!tags.to_string().contains("Warning"), "{tags:#}");
    }
}
