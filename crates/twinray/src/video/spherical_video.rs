//! Google's Spherical Video V2 boxes, written into an MP4 that ffmpeg
//! made: ffmpeg's MP4 muxer writes `sv3d` only from a stream's spherical
//! side data, which no command-line option of ffmpeg 5.1 gives raw frames.
//!
//! The video track's sample entry (`avc1`, `hvc1`) gets, after its own
//! boxes:
//!
//! ```text
//! sv3d
//!   svhd  metadata source "twinray"
//!   proj
//!     prhd  yaw, pitch, roll 0
//!     equi  bounds top, bottom, left, right (0.32 fixed point)
//! ```
//!
//! A 360° panorama has no bounds; VR180 crops a quarter of a 360°
//! panorama's width on each side. Every box that holds the entry grows by
//! as much, and where the movie box comes before the media data (ffmpeg's
//! `+faststart`) every chunk offset (`stco`, `co64`) moves by as much.

use super::Spherical;

/// A box: its type, where it starts, where its payload starts and where
/// it ends.
#[derive(Clone, Copy, Debug)]
struct Mp4Box {
    kind: [u8; 4],
    start: usize,
    payload: usize,
    end: usize,
}

fn be32(data: &[u8], at: usize) -> Result<u32, String> {
    data.get(at..at + 4)
        .map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| "a truncated MP4".to_string())
}

/// The boxes in `data[start..end]`.
fn boxes(data: &[u8], start: usize, end: usize) -> Result<Vec<Mp4Box>, String> {
    let mut out = Vec::new();
    let mut at = start;
    while at + 8 <= end {
        let size = be32(data, at)? as u64;
        let kind = [data[at + 4], data[at + 5], data[at + 6], data[at + 7]];
        let (size, header) = match size {
            0 => ((end - at) as u64, 8),
            1 => {
                let hi = be32(data, at + 8)? as u64;
                let lo = be32(data, at + 12)? as u64;
                ((hi << 32) | lo, 16)
            }
            n => (n, 8),
        };
        let box_end = usize::try_from(size)
            .ok()
            .and_then(|s| at.checked_add(s))
            .filter(|&e| e <= end && size >= header as u64)
            .ok_or_else(|| format!("a box '{}' past its parent's end", kind_name(kind)))?;
        out.push(Mp4Box {
            kind,
            start: at,
            payload: at + header,
            end: box_end,
        });
        at = box_end;
    }
    Ok(out)
}

fn kind_name(kind: [u8; 4]) -> String {
    String::from_utf8_lossy(&kind).into_owned()
}

fn child(data: &[u8], parent: &Mp4Box, kind: &[u8; 4]) -> Result<Option<Mp4Box>, String> {
    Ok(boxes(data, parent.payload, parent.end)?
        .into_iter()
        .find(|b| &b.kind == kind))
}

fn need(b: Option<Mp4Box>, kind: &str) -> Result<Mp4Box, String> {
    b.ok_or_else(|| format!("no '{kind}' box"))
}

fn mp4_box(kind: &[u8; 4], payload: &[u8]) -> Vec<u8> {
    let mut b = ((payload.len() + 8) as u32).to_be_bytes().to_vec();
    b.extend_from_slice(kind);
    b.extend_from_slice(payload);
    b
}

/// A full box (version 0, flags 0).
fn full_box(kind: &[u8; 4], payload: &[u8]) -> Vec<u8> {
    let mut p = vec![0u8; 4];
    p.extend_from_slice(payload);
    mp4_box(kind, &p)
}

/// The `sv3d` box of `spherical`.
pub(super) fn sv3d(spherical: Spherical) -> Vec<u8> {
    let side: u32 = match spherical {
        Spherical::Equirect180 => 0x4000_0000,
        _ => 0,
    };
    let mut bounds = Vec::new();
    for b in [0, 0, side, side] {
        bounds.extend_from_slice(&u32::to_be_bytes(b));
    }
    let proj = [full_box(b"prhd", &[0u8; 12]), full_box(b"equi", &bounds)].concat();
    let sv3d = [full_box(b"svhd", b"twinray\0"), mp4_box(b"proj", &proj)].concat();
    mp4_box(b"sv3d", &sv3d)
}

/// `mp4` with the `sv3d` box of `spherical` in its video track's sample
/// entry.
pub(super) fn with_sv3d(mp4: &[u8], spherical: Spherical) -> Result<Vec<u8>, String> {
    let insert = sv3d(spherical);
    let top = boxes(mp4, 0, mp4.len())?;
    let moov = need(top.iter().copied().find(|b| &b.kind == b"moov"), "moov")?;
    // The boxes that hold the sample entry, outermost first.
    let mut path = vec![moov];
    let mut found = None;
    for trak in boxes(mp4, moov.payload, moov.end)? {
        if &trak.kind != b"trak" {
            continue;
        }
        let mdia = need(child(mp4, &trak, b"mdia")?, "mdia")?;
        let hdlr = need(child(mp4, &mdia, b"hdlr")?, "hdlr")?;
        // Version and flags, pre_defined, then the handler type.
        if mp4.get(hdlr.payload + 8..hdlr.payload + 12) != Some(b"vide") {
            continue;
        }
        let minf = need(child(mp4, &mdia, b"minf")?, "minf")?;
        let stbl = need(child(mp4, &minf, b"stbl")?, "stbl")?;
        let stsd = need(child(mp4, &stbl, b"stsd")?, "stsd")?;
        // Version and flags, entry count, then the entries.
        let entries = boxes(mp4, stsd.payload + 8, stsd.end)?;
        let entry = need(entries.first().copied(), "sample entry")?;
        if child_of_entry(mp4, &entry, b"sv3d")? {
            return Ok(mp4.to_vec());
        }
        path.extend([trak, mdia, minf, stbl, stsd, entry]);
        found = Some(entry);
        break;
    }
    let entry = found.ok_or("no video track")?;
    let at = entry.end;
    let delta = insert.len();
    let mut out = Vec::with_capacity(mp4.len() + delta);
    out.extend_from_slice(&mp4[..at]);
    out.extend_from_slice(&insert);
    out.extend_from_slice(&mp4[at..]);
    for b in &path {
        if b.payload - b.start != 8 {
            return Err(format!("a 64-bit '{}' box", kind_name(b.kind)));
        }
        let size = u32::try_from(b.end - b.start + delta)
            .map_err(|_| format!("a '{}' box over 4 GiB", kind_name(b.kind)))?;
        out[b.start..b.start + 4].copy_from_slice(&size.to_be_bytes());
    }
    // The media data after the movie box moved: so do the chunk offsets.
    let data_after = top
        .iter()
        .any(|b| &b.kind == b"mdat" && b.start > moov.start);
    if data_after {
        shift_chunk_offsets(&mut out, moov.start, delta as u64)?;
    }
    Ok(out)
}

/// Whether a visual sample entry already holds a box of `kind` (its own
/// boxes follow 78 bytes of fields).
fn child_of_entry(data: &[u8], entry: &Mp4Box, kind: &[u8; 4]) -> Result<bool, String> {
    let first = entry.payload + 78;
    if first > entry.end {
        return Err("a short video sample entry".into());
    }
    Ok(boxes(data, first, entry.end)?
        .iter()
        .any(|b| &b.kind == kind))
}

/// Adds `delta` to every chunk offset of every track of the movie box at
/// `moov_start` (which `data` holds grown already).
fn shift_chunk_offsets(data: &mut [u8], moov_start: usize, delta: u64) -> Result<(), String> {
    let moov = need(
        boxes(data, moov_start, data.len())?.first().copied(),
        "moov",
    )?;
    for trak in boxes(data, moov.payload, moov.end)? {
        if &trak.kind != b"trak" {
            continue;
        }
        let mdia = need(child(data, &trak, b"mdia")?, "mdia")?;
        let minf = need(child(data, &mdia, b"minf")?, "minf")?;
        let stbl = need(child(data, &minf, b"stbl")?, "stbl")?;
        for table in boxes(data, stbl.payload, stbl.end)? {
            let wide = match &table.kind {
                b"stco" => false,
                b"co64" => true,
                _ => continue,
            };
            let count = be32(data, table.payload + 4)? as usize;
            let width = if wide { 8 } else { 4 };
            let first = table.payload + 8;
            if first + count * width > table.end {
                return Err("a chunk offset table past its box".into());
            }
            for i in 0..count {
                let at = first + i * width;
                if wide {
                    let mut b = [0u8; 8];
                    b.copy_from_slice(&data[at..at + 8]);
                    let v = u64::from_be_bytes(b) + delta;
                    data[at..at + 8].copy_from_slice(&v.to_be_bytes());
                } else {
                    let v = u64::from(be32(data, at)?) + delta;
                    let v = u32::try_from(v).map_err(|_| "a chunk offset over 4 GiB")?;
                    data[at..at + 4].copy_from_slice(&v.to_be_bytes());
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A movie box with one video track (an `avc1` entry of 78 bytes of
    /// fields and an `avcC`) and one chunk offset, then the media data.
    fn tiny_mp4() -> Vec<u8> {
        let mut entry = vec![0u8; 78];
        entry.extend(mp4_box(b"avcC", &[1, 2, 3]));
        let stsd = [vec![0, 0, 0, 0, 0, 0, 0, 1], mp4_box(b"avc1", &entry)].concat();
        let stco = full_box(b"stco", &[0, 0, 0, 1, 0, 0, 0, 0]);
        let stbl = mp4_box(b"stbl", &[full_box(b"stsd", &stsd[4..]), stco].concat());
        let mut hdlr = vec![0u8; 8];
        hdlr.extend_from_slice(b"vide");
        hdlr.extend_from_slice(&[0u8; 13]);
        let minf = mp4_box(b"minf", &stbl);
        let mdia = mp4_box(b"mdia", &[mp4_box(b"hdlr", &hdlr), minf].concat());
        let moov = mp4_box(b"moov", &mp4_box(b"trak", &mdia));
        let ftyp = mp4_box(b"ftyp", b"isom");
        let mdat_at = (ftyp.len() + moov.len() + 8) as u32;
        let mut out = [ftyp, moov, mp4_box(b"mdat", b"FRAME")].concat();
        // Point the one chunk at the media data.
        let stco_at = out.windows(4).position(|w| w == b"stco").unwrap() + 12;
        out[stco_at..stco_at + 4].copy_from_slice(&mdat_at.to_be_bytes());
        out
    }

    fn chunk_offset(mp4: &[u8]) -> usize {
        let at = mp4.windows(4).position(|w| w == b"stco").unwrap() + 12;
        be32(mp4, at).unwrap() as usize
    }

    #[test]
    fn the_box_goes_in_the_sample_entry_and_the_chunks_follow_their_data() {
        let before = tiny_mp4();
        assert_eq!(&before[chunk_offset(&before)..][..5], b"FRAME");
        let after = with_sv3d(&before, Spherical::Equirect180).unwrap();
        assert_eq!(
            after.len(),
            before.len() + sv3d(Spherical::Equirect180).len()
        );
        assert_eq!(&after[chunk_offset(&after)..][..5], b"FRAME");
        // Every box still ends where its size says, down to the entry.
        let top = boxes(&after, 0, after.len()).unwrap();
        let moov = top.iter().find(|b| &b.kind == b"moov").unwrap();
        let trak = child(&after, moov, b"trak").unwrap().unwrap();
        let mdia = child(&after, &trak, b"mdia").unwrap().unwrap();
        let minf = child(&after, &mdia, b"minf").unwrap().unwrap();
        let stbl = child(&after, &minf, b"stbl").unwrap().unwrap();
        let stsd = child(&after, &stbl, b"stsd").unwrap().unwrap();
        let entry = boxes(&after, stsd.payload + 8, stsd.end).unwrap()[0];
        assert!(child_of_entry(&after, &entry, b"sv3d").unwrap());
        assert!(child_of_entry(&after, &entry, b"avcC").unwrap());
        // The bounds of VR180: a quarter on each side.
        let equi = after.windows(4).position(|w| w == b"equi").unwrap() + 8;
        assert_eq!(be32(&after, equi + 8).unwrap(), 0x4000_0000);
        assert_eq!(be32(&after, equi + 12).unwrap(), 0x4000_0000);
        // Written once.
        assert_eq!(with_sv3d(&after, Spherical::Equirect180).unwrap(), after);
    }

    #[test]
    fn a_file_without_a_movie_box_is_refused() {
        assert!(with_sv3d(b"\0\0\0\x0cftypisom", Spherical::Equirect360).is_err());
        assert!(with_sv3d(b"\0\0\0\xffmoov", Spherical::Equirect360).is_err());
    }
}
