//! Key views (approximate, `--share-shading`): the tracer's part. A mirror
//! or glass surface point that several views see is traced in full by some
//! of them, the key views, which record what each of their secondary rays
//! hit (`Chain`). A view between two key views may take their secondary
//! colour interpolated (`twin::key_views` decides) if both chains hit the
//! same primitives, the segments from their hits toward each light are
//! free of occluders between the two key views' hits (a shadow fan), and its
//! own first reflected and refracted rays hit what the key views' did (a
//! probe: nearest hits, not shaded). Its ambient and direct light stay its
//! own (`shade_direct`).

use super::{Donor, SecondaryRays, ShadingTree, Tracer};
use crate::bvh::{distance_to_segment, Packet, PacketHits};
use crate::lights::LightKind;
use crate::math::{Color, Vec3};
use crate::shading::offset_point;
use crate::shapes::{Shape, TriangleNormals};

/// What one secondary ray of a key view hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// Its level (the eye ray is 1, the hit's own secondary rays 2).
    pub level: u32,
    /// The primitive hit (`PacketHits::NO_HIT`: none).
    pub prim: u32,
    /// Where, and the ray's direction and distance.
    pub point: Vec3,
    pub dir: Vec3,
    pub t: f32,
}

impl Link {
    /// Lane 0 of a traced packet.
    pub(super) fn of<const K: usize>(packet: &Packet<K>, hits: &PacketHits<K>, level: u32) -> Link {
        let t = hits.hit[0].t;
        Link {
            level,
            prim: hits.prim[0],
            point: packet.origins[0] + packet.dirs[0] * t,
            dir: packet.dirs[0],
            t,
        }
    }
}

/// Every secondary ray of a one-lane shading tree, in the order traced
/// (reflected before refracted, depth first).
pub type Chain = Vec<Link>;

impl Tracer<'_> {
    /// [`Tracer::shade_donor`] for a key view: also the chain of what its
    /// secondary rays hit, in `chain` (its buffer is reused).
    pub fn shade_key(
        &mut self,
        packet: &Packet<1>,
        hits: &PacketHits<1>,
        secondary: SecondaryRays,
        donor: &mut Donor,
        chain: &mut Chain,
    ) {
        chain.clear();
        let mut tree = ShadingTree::new(secondary);
        tree.chain = Some(std::mem::take(chain));
        donor.through.clear();
        donor.through.resize(self.world.scene.lights.len(), 0.0);
        donor.secondary = Color::ZERO;
        let record = Some((
            &mut donor.through[..],
            std::slice::from_mut(&mut donor.secondary),
        ));
        donor.color = self.shade_stages(packet, hits, 1, [1.0], &mut tree, record)[0];
        donor.tree_coefficient = tree.largest_coefficient;
        *chain = tree.chain.take().unwrap_or_default();
        self.counts.key_view_samples += 1;
    }

    /// Whether two key views' chains hit the same primitives in the same
    /// order and, at each lit hit, the segments from both hits toward each
    /// point light are free of anything (one shadow fan per hit and light):
    /// a shadow that falls between the two hits is seen. Directional lights
    /// (no point to fan toward) make the chains disagree where they light a
    /// surface. `slack` widens each fan: how far the views between may
    /// start their rays off the line of the key views' (their hits differ).
    ///
    /// Between two lit hits the direct light varies, and the interpolation
    /// is off by at most its second derivative along the segment times s²/8
    /// (s the segment's length, widened by `slack`): for a diffuse term
    /// cos θ / d^p toward a light at least D away, (p + 1)(p + 5) / D^(p+2)
    /// (p = 2 with an inverse-square falloff), times kd, the surface's and
    /// the light's colour. The chains disagree if that sum exceeds
    /// `tolerance`, or a chain's lit surface is not flat, evenly coloured
    /// and diffuse (a highlight, a map, per-corner normals or colours, a
    /// curved shape) or has a spot light on it (terms with no such bound
    /// here), or their rays leave the scene toward an environment image in
    /// directions more than 1/64 of a texel apart.
    pub fn chains_agree(&mut self, a: &Chain, b: &Chain, slack: f32, tolerance: f32) -> bool {
        if a.len() != b.len()
            || a.iter()
                .zip(b)
                .any(|(x, y)| (x.level, x.prim) != (y.level, y.prim))
        {
            return false;
        }
        let world = self.world;
        let scene = &world.scene;
        let mut curvature = 0.0f32;
        for (x, y) in a.iter().zip(b) {
            if x.prim == PacketHits::<1>::NO_HIT {
                // Rays leaving the scene see the environment image, which
                // may change anywhere: only rays the same way (a flat
                // mirror's, nearly parallel) see the same radiance.
                if let Some(env) = &scene.environment {
                    let cos = x.dir.normalize_or_zero().dot(y.dir.normalize_or_zero());
                    let near = (env.texel_angle() / 64.0).cos();
                    if cos.is_nan() || cos < near {
                        return false;
                    }
                }
                continue;
            }
            let material = world.material_of(x.prim);
            if material.kd <= 0.0 && material.ks <= 0.0 {
                continue; // takes no direct light
            }
            let shape = &scene.shapes[x.prim as usize];
            let origin = |l: &Link| {
                let n = shape.geometric_normal(l.point);
                let facing = if n.dot(l.dir) < 0.0 { n } else { -n };
                (offset_point(l.point, facing, l.t), facing)
            };
            let ((oa, na), (ob, nb)) = (origin(x), origin(y));
            let span = (oa - ob).length() + slack;
            let albedo = material.kd * material.color.max_element();
            // The bound holds for a flat, evenly coloured, diffuse surface:
            // a highlight, any map, per-corner normals or colours, or a
            // curved surface (whose normal turns between the hits) has none.
            let flat = matches!(shape, Shape::Triangle(t) if t.normals == TriangleNormals::Flat);
            let unbounded = material.ks > 0.0
                || !flat
                || material.texture.is_some()
                || material.emission_texture.is_some()
                || material.occlusion_texture.is_some()
                || material.alpha_texture.is_some()
                || material.normal_map.is_some();
            for light in &scene.lights {
                let Some(position) = light.position() else {
                    return false;
                };
                let faces = |o: Vec3, n: Vec3| n.dot(position - o) > 0.0;
                match (faces(oa, na), faces(ob, nb)) {
                    (false, false) => continue,
                    (true, true) => {
                        let p = match light.kind {
                            LightKind::Point { inverse_square, .. } => {
                                if inverse_square {
                                    2
                                } else {
                                    0
                                }
                            }
                            _ => return false,
                        };
                        if unbounded {
                            return false;
                        }
                        let near = distance_to_segment(position, oa, ob) - slack;
                        if near.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                            return false;
                        }
                        let colour = light.color.unwrap_or(Color::ONE).max_element();
                        let k = ((p + 1) * (p + 5)) as f32;
                        curvature += albedo * colour * span * span / 8.0 * k / near.powi(p + 2);
                        if curvature.is_nan() || curvature > tolerance {
                            return false;
                        }
                        let end_error = position.abs().max_element() * 4.0 * f32::EPSILON;
                        if !self.span_is_free(&[oa, ob], position, end_error + slack) {
                            return false;
                        }
                    }
                    _ => return false,
                }
            }
        }
        true
    }

    /// Whether the reflected and refracted rays of an eye ray's known hit
    /// (lane 0) hit, in order, the primitives `chain` lists at level 2, and
    /// spawn no ray the chain lacks. The rays are traced to their nearest
    /// hit, not shaded.
    pub fn probe_matches(
        &mut self,
        packet: &Packet<1>,
        hits: &PacketHits<1>,
        chain: &Chain,
    ) -> bool {
        let mut tree = ShadingTree::new(SecondaryRays::Own);
        let surfaces = self.surfaces(packet, hits, 1, [1.0], &mut tree);
        let mut expected = chain.iter().filter(|l| l.level == 2).map(|l| l.prim);
        for spawn in [
            surfaces.reflected[0],
            surfaces.refracted[0],
            surfaces.passed[0],
        ]
        .into_iter()
        .flatten()
        {
            let ray = Packet::ray(spawn.origin, spawn.dir);
            let hit = self.closest(&ray);
            self.counts.key_view_probes += 1;
            if expected.next() != Some(hit.prim[0]) {
                return false;
            }
        }
        expected.next().is_none()
    }

    /// The ambient and direct light of the lanes' known hits (shadow rays
    /// as one packet), without their reflected and refracted rays.
    pub fn shade_direct<const K: usize>(
        &mut self,
        packet: &Packet<K>,
        hits: &PacketHits<K>,
    ) -> [Color; K] {
        let mut tree = ShadingTree::new(SecondaryRays::Own);
        self.shade(packet, hits, self.settings.max_depth, [1.0; K], &mut tree)
    }
}
