//! Packets of eight lanes filled from several groups of samples: the
//! exact groups', and the approximate paths' donors and the samples that
//! take their light (`packed` shades them).

use crate::bvh::{Packet, PacketHits, EYE_PACKET};
use crate::math::{Color, Vec3};
use crate::render::tracer::Donors;
use crate::shapes::SurfaceHit;

/// A packet of eight eye rays being filled, lane by lane, with known hits.
pub(in crate::render) struct Lanes {
    pub(in crate::render) packet: Packet<EYE_PACKET>,
    pub(in crate::render) hits: PacketHits<EYE_PACKET>,
    /// Lane `l` is view `at[l].0`'s sample `at[l].1`.
    pub(in crate::render) at: [(usize, usize); EYE_PACKET],
    /// Lane `l`'s group of views: merged secondary rays join only lanes of
    /// one group (`Tracer::shade_eye_groups`).
    pub(in crate::render) groups: [u8; EYE_PACKET],
    /// Lanes filled (the first `n`).
    pub(in crate::render) n: usize,
    /// Lanes a packet of donors or takers is shaded at (`EYE_PACKET`; 1
    /// in the tests' reference, where each lane is lane 0 of its packet).
    pub(in crate::render) capacity: usize,
    /// The group of the next lanes (counted round: a packet's at most
    /// eight groups are consecutive, so theirs differ).
    pub(in crate::render) group: u8,
}

impl Lanes {
    /// An empty packet of eye rays starting `hither` from their eyes, shaded
    /// once `capacity` lanes (at most `EYE_PACKET`) are filled.
    pub(in crate::render) fn new(hither: f32, capacity: usize) -> Lanes {
        Lanes {
            packet: Packet {
                origins: [Vec3::ZERO; EYE_PACKET],
                dirs: [Vec3::Z; EYE_PACKET],
                t_min: hither,
                t_max: [f32::INFINITY; EYE_PACKET],
                mask: 0,
            },
            hits: PacketHits::none(),
            at: [(0, 0); EYE_PACKET],
            groups: [0; EYE_PACKET],
            n: 0,
            capacity: capacity.clamp(1, EYE_PACKET),
            group: 0,
        }
    }

    pub(in crate::render) fn is_full(&self) -> bool {
        self.n >= self.capacity
    }

    /// The lanes pushed from now on belong to a new group of views.
    pub(in crate::render) fn next_group(&mut self) {
        self.group = self.group.wrapping_add(1);
    }

    /// View `at.0`'s sample `at.1`, its eye ray from `origin` along `dir`
    /// with its known hit, as the next lane (the packet is not full).
    pub(in crate::render) fn push(
        &mut self,
        origin: Vec3,
        dir: Vec3,
        hit: (u32, SurfaceHit),
        at: (usize, usize),
    ) {
        let l = self.n;
        self.packet.origins[l] = origin;
        self.packet.dirs[l] = dir;
        (self.hits.prim[l], self.hits.hit[l]) = hit;
        self.packet.mask |= 1 << l;
        self.at[l] = at;
        self.groups[l] = self.group;
        self.n += 1;
    }

    /// The filled lanes, as (lane, view, sample).
    pub(in crate::render) fn filled(&self) -> impl Iterator<Item = (usize, usize, usize)> + '_ {
        self.at[..self.n]
            .iter()
            .enumerate()
            .map(|(l, &(v, i))| (l, v, i))
    }

    /// Empties the packet (its lanes were shaded).
    pub(in crate::render) fn clear(&mut self) {
        self.packet.mask = 0;
        self.n = 0;
    }
}

/// Donors (view 0's samples whose light the group's other samples may
/// take) gathered into one packet, and what their shading kept.
#[derive(Default)]
pub(in crate::render) struct DonorPacket {
    pub(in crate::render) lanes: Option<Lanes>,
    pub(in crate::render) donors: Donors,
}

/// Samples that take a donor's light gathered into one packet, with it:
/// lane `l`'s transmittances at `through[l * lights..]`, and its
/// secondary colour.
#[derive(Default)]
pub(in crate::render) struct TakerPacket {
    pub(in crate::render) lanes: Option<Lanes>,
    pub(in crate::render) through: Vec<f32>,
    pub(in crate::render) secondary: [Color; EYE_PACKET],
}
