//! What photo viewers read to show a JPEG as a panorama: Google's GPano
//! XMP (projection, the full panorama's size and the image's crop of it),
//! and for a stereo pair the right eye's JPEG in the left eye's extended
//! XMP (`GImage:Mime`, `GImage:Data`): the format of Google's VR180 photos
//! and Cardboard Camera's stereo panoramas.
//!
//! The XMP packet goes in an APP1 segment after the encoder's JFIF APP0
//! (`http://ns.adobe.com/xap/1.0/\0`); the extended XMP, which does not
//! fit one segment, in APP1 chunks of `http://ns.adobe.com/xmp/extension/\0`,
//! each with the 32 hex digits of its MD5 (the GUID the main packet names
//! in `xmpNote:HasExtendedXMP`), its full length and the chunk's offset
//! (Adobe's XMP specification, part 3, 1.1.3.1).

use std::path::Path;

use base64::Engine as _;
use md5::{Digest, Md5};

use super::atomic::{write_atomically, Failure};
use crate::{Error, Result};

const XMP_ID: &[u8] = b"http://ns.adobe.com/xap/1.0/\0";
const EXTENSION_ID: &[u8] = b"http://ns.adobe.com/xmp/extension/\0";
/// Most bytes of extended XMP in one APP1 segment (its length field
/// counts at most 65535: 2 for itself, the namespace, 32 + 4 + 4).
const EXTENSION_CHUNK: usize = 65_000;

/// Where an image lies in its full equirectangular panorama, in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GPano {
    pub full_width: u32,
    pub full_height: u32,
    pub width: u32,
    pub height: u32,
    pub left: u32,
    pub top: u32,
}

impl GPano {
    /// A whole 360°×180° image.
    pub fn full(width: u32, height: u32) -> GPano {
        GPano {
            full_width: width,
            full_height: height,
            width,
            height,
            left: 0,
            top: 0,
        }
    }

    /// A 180°×180° image centred in a 360° panorama twice as wide.
    pub fn half(width: u32, height: u32) -> GPano {
        GPano {
            full_width: width.saturating_mul(2),
            full_height: height,
            width,
            height,
            left: width / 2,
            top: 0,
        }
    }
}

/// The main XMP packet: the GPano tags, and where `extended` is given the
/// GUID of the extended packet that holds the other eye.
fn main_packet(pano: &GPano, extended: Option<&str>) -> String {
    let note = match extended {
        Some(guid) => format!(
            "\n   xmlns:xmpNote=\"http://ns.adobe.com/xmp/note/\"\n   xmpNote:HasExtendedXMP=\"{guid}\""
        ),
        None => String::new(),
    };
    format!(
        "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\">\n <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n  <rdf:Description rdf:about=\"\"\n   xmlns:GPano=\"http://ns.google.com/photos/1.0/panorama/\"\n   GPano:ProjectionType=\"equirectangular\"\n   GPano:UsePanoramaViewer=\"True\"\n   GPano:FullPanoWidthPixels=\"{}\"\n   GPano:FullPanoHeightPixels=\"{}\"\n   GPano:CroppedAreaImageWidthPixels=\"{}\"\n   GPano:CroppedAreaImageHeightPixels=\"{}\"\n   GPano:CroppedAreaLeftPixels=\"{}\"\n   GPano:CroppedAreaTopPixels=\"{}\"{note}/>\n </rdf:RDF>\n</x:xmpmeta>",
        pano.full_width,
        pano.full_height,
        pano.width,
        pano.height,
        pano.left,
        pano.top,
    )
}

/// The extended packet: the right eye's JPEG.
fn extended_packet(right_jpeg: &[u8]) -> String {
    let data = base64::engine::general_purpose::STANDARD.encode(right_jpeg);
    format!(
        "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\"><rdf:Description rdf:about=\"\" xmlns:GImage=\"http://ns.google.com/photos/1.0/image/\" GImage:Mime=\"image/jpeg\" GImage:Data=\"{data}\"/></rdf:RDF></x:xmpmeta>"
    )
}

fn app1(payload: &[&[u8]]) -> std::result::Result<Vec<u8>, String> {
    let len: usize = payload.iter().map(|p| p.len()).sum::<usize>() + 2;
    let len = u16::try_from(len).map_err(|_| "an XMP segment over 64 KiB".to_string())?;
    let mut seg = vec![0xFF, 0xE1];
    seg.extend_from_slice(&len.to_be_bytes());
    for p in payload {
        seg.extend_from_slice(p);
    }
    Ok(seg)
}

/// `jpeg` with the GPano XMP of `pano`, and where `right_jpeg` is given
/// that JPEG as the right eye in the extended XMP.
pub fn with_gpano(
    jpeg: &[u8],
    pano: &GPano,
    right_jpeg: Option<&[u8]>,
) -> std::result::Result<Vec<u8>, String> {
    if jpeg.get(..2) != Some(&[0xFF, 0xD8]) {
        return Err("not a JPEG (no SOI)".into());
    }
    let mut segments = Vec::new();
    match right_jpeg {
        None => segments.push(app1(&[XMP_ID, main_packet(pano, None).as_bytes()])?),
        Some(right) => {
            let extended = extended_packet(right);
            let guid: String = Md5::digest(extended.as_bytes())
                .iter()
                .map(|b| format!("{b:02X}"))
                .collect();
            segments.push(app1(&[XMP_ID, main_packet(pano, Some(&guid)).as_bytes()])?);
            let total = u32::try_from(extended.len())
                .map_err(|_| "the right eye's JPEG is over 4 GiB".to_string())?;
            for (k, chunk) in extended.as_bytes().chunks(EXTENSION_CHUNK).enumerate() {
                let offset = (k * EXTENSION_CHUNK) as u32;
                segments.push(app1(&[
                    EXTENSION_ID,
                    guid.as_bytes(),
                    &total.to_be_bytes(),
                    &offset.to_be_bytes(),
                    chunk,
                ])?);
            }
        }
    }
    // After SOI and the encoder's JFIF APP0, which must stay first.
    let mut at = 2;
    if jpeg.get(2..4) == Some(&[0xFF, 0xE0]) {
        let len = jpeg
            .get(4..6)
            .map(|l| u16::from_be_bytes([l[0], l[1]]) as usize)
            .ok_or("a truncated JPEG")?;
        at = 4 + len;
        if at > jpeg.len() {
            return Err("a truncated JPEG".into());
        }
    }
    let extra: usize = segments.iter().map(Vec::len).sum();
    let mut out = Vec::with_capacity(jpeg.len() + extra);
    out.extend_from_slice(&jpeg[..at]);
    for s in &segments {
        out.extend_from_slice(s);
    }
    out.extend_from_slice(&jpeg[at..]);
    Ok(out)
}

/// Gives the JPEG file at `path` the GPano XMP of `pano`, and where
/// `right` is given that JPEG file as the right eye; rewritten atomically.
pub fn tag_jpeg_file(path: &Path, pano: &GPano, right: Option<&Path>) -> Result<()> {
    let read = |p: &Path| {
        std::fs::read(p).map_err(|source| Error::Io {
            path: p.to_path_buf(),
            source,
        })
    };
    let jpeg = read(path)?;
    let right = right.map(read).transpose()?;
    let tagged = with_gpano(&jpeg, pano, right.as_deref())
        .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
    write_atomically(path, |w| {
        w.write_all(&tagged)?;
        Ok::<(), Failure>(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny_jpeg() -> Vec<u8> {
        let mut out = Vec::new();
        ::image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 90)
            .encode(&[200u8; 8 * 4 * 3], 8, 4, ::image::ExtendedColorType::Rgb8)
            .unwrap();
        out
    }

    /// The APP1 segments of `jpeg`, in order, as their payloads.
    fn app1_payloads(jpeg: &[u8]) -> Vec<Vec<u8>> {
        let mut at = 2;
        let mut out = Vec::new();
        while at + 4 <= jpeg.len() && jpeg[at] == 0xFF && jpeg[at + 1] != 0xDA {
            let len = u16::from_be_bytes([jpeg[at + 2], jpeg[at + 3]]) as usize;
            if jpeg[at + 1] == 0xE1 {
                out.push(jpeg[at + 4..at + 2 + len].to_vec());
            }
            at += 2 + len;
        }
        out
    }

    #[test]
    fn the_right_eye_comes_back_whole_from_the_extended_chunks() {
        let left = tiny_jpeg();
        // A right eye large enough for several chunks.
        let right: Vec<u8> = (0..150_000u32).map(|i| (i * 7 % 251) as u8).collect();
        let out = with_gpano(&left, &GPano::half(8, 4), Some(&right)).unwrap();
        assert!(::image::load_from_memory(&out).is_ok(), "still a JPEG");
        let segs = app1_payloads(&out);
        let main = String::from_utf8(segs[0][XMP_ID.len()..].to_vec()).unwrap();
        assert!(main.contains("GPano:FullPanoWidthPixels=\"16\""));
        assert!(main.contains("GPano:CroppedAreaLeftPixels=\"4\""));
        let guid = main.split("HasExtendedXMP=\"").nth(1).unwrap()[..32].to_string();
        let mut extended = Vec::new();
        for s in &segs[1..] {
            let rest = &s[EXTENSION_ID.len()..];
            assert_eq!(&rest[..32], guid.as_bytes());
            let offset = u32::from_be_bytes(rest[36..40].try_into().unwrap()) as usize;
            assert_eq!(offset, extended.len());
            extended.extend_from_slice(&rest[40..]);
        }
        assert!(segs.len() > 3);
        let digest: String = Md5::digest(&extended)
            .iter()
            .map(|b| format!("{b:02X}"))
            .collect();
        assert_eq!(digest, guid);
        let text = String::from_utf8(extended).unwrap();
        let data = text
            .split("GImage:Data=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        let decoded = base64::engine::general_purpose::STANDARD
            .decode(data)
            .unwrap();
        assert_eq!(decoded, right);
    }

    #[test]
    fn jfif_stays_first() {
        let out = with_gpano(&tiny_jpeg(), &GPano::full(8, 4), None).unwrap();
        assert_eq!(&out[2..4], &[0xFF, 0xE0]);
        assert!(with_gpano(b"not a jpeg", &GPano::full(8, 4), None).is_err());
    }
}
