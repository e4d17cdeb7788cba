//! Hits whose shading reads no normal: the first stage of shading
//! (`Tracer::surfaces`) then takes the surface's colour without its normal
//! (`Scene::surface_colour_at`), sparing the interpolation of corner normals
//! and the normal map. Matte surfaces in a scene without lights or
//! environment are such hits (the eye-ray benchmark against Embree renders
//! them); in a lit scene every hit that takes light needs its normal.
//! Hits that read nothing of the hit at all (`shades_flat`: no light, ray or
//! texture taken) shade to one colour per material, shaded once per row.

use crate::render::TraceSettings;
use crate::scene::{AlphaMode, Material, Scene};

/// Whether shading a hit on `material` reads the surface's normal: an
/// environment's light (`ambient_under`), a light's (diffuse or highlight),
/// or a ray it spawns (reflected, refracted, or passing a BLEND surface:
/// their directions and start points are offset along the normal). `spawn`:
/// whether the hit's level may still spawn rays. The SPD's forced
/// reflections come from mirror or transmitting materials, counted here.
#[inline]
pub(super) fn needs_normal(scene: &Scene, material: &Material, spawn: bool) -> bool {
    scene.environment.is_some()
        || (!scene.lights.is_empty() && (material.kd > 0.0 || material.ks > 0.0))
        || (spawn
            && (material.mirror > 0.0
                || material.t > 0.0
                || material.alpha_mode == AlphaMode::Blend))
}

/// Whether every eye hit on `material` shades to one colour, wherever it
/// lies: its shading reads no normal (`needs_normal`), and its colour takes
/// nothing from the hit (no texture, emission or occlusion texture, corner
/// colour or BLEND coverage). Then `surfaces` gives the material's ambient
/// term, direct light adds nothing (no light, or none taken) and no ray is
/// spawned: the mono row shades one such hit per material and gives the
/// others its colour (`TwinBatch::trace_mono_row`). `spawn`: whether the
/// eye hit's level may still spawn rays.
#[inline]
pub(super) fn shades_flat(scene: &Scene, material: &Material, spawn: bool) -> bool {
    !needs_normal(scene, material, spawn)
        && scene.corner_colors.is_empty()
        && material.alpha_mode == AlphaMode::Opaque
        && material.texture.is_none()
        && material.emission_texture.is_none()
        && material.occlusion_texture.is_none()
}

/// Per material of `scene`, `shades_flat` for eye hits traced with `settings`.
pub(in crate::render) fn flat_materials(scene: &Scene, settings: &TraceSettings) -> Vec<bool> {
    let spawn = 1 < settings.max_depth;
    scene
        .materials
        .iter()
        .map(|m| shades_flat(scene, m, spawn))
        .collect()
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::environment::Environment;
    use crate::loaders::{nff::parse_nff, LoadOptions};
    use crate::math::{Color, Vec3};
    use crate::render::tracer::tests::pixel_ray;
    use crate::render::tracer::Tracer;
    use crate::render::tracer::{SecondaryRays, ShadingTree};
    use crate::render::TraceSettings;
    use crate::rig::Camera;
    use crate::scene::{MeshPolygon, NormalMap, NormalMapKind, Uv};
    use crate::texture::Texture;
    use crate::world::World;

    /// A floor, a sphere and a cone under two lights, and a textured,
    /// normal-mapped quad (material 3) facing the camera.
    pub(in crate::render) fn scene() -> Scene {
        let text = "b 0.1 0.2 0.3\nv\nfrom 0 -8 2\nat 0 0 1\nup 0 0 1\nangle 45\nhither 0.01\n\
            resolution 48 36\n\
            l -5 -5 6 0.6 0.5 0.5\nl 4 -3 5 0.5 0.6 0.5\n\
            f 0.8 0.8 0.7 0.6 0.3 20 0 1\np 4\n-6 -6 0\n6 -6 0\n6 6 0\n-6 6 0\n\
            f 0.9 0.2 0.2 0.7 0.2 30 0 1\ns -1.5 0 1 0.8\n\
            f 0.3 0.4 0.9 0.7 0.2 30 0 1\nc\n2.5 -1.5 0 0.6\n2.5 -1.5 2 0.1\n";
        let mut s = parse_nff(text, std::path::Path::new("t.nff"), &LoadOptions::default())
            .expect("test scene");
        let checker: Vec<[u8; 3]> = (0..64)
            .map(|i| match (i % 8 + i / 8) % 2 {
                0 => [250, 40, 40],
                _ => [40, 40, 250],
            })
            .collect();
        let bumps: Vec<[u8; 3]> = (0..64)
            .map(|i| [128 + (i % 8) as u8 * 15, 128, 200 + (i / 8) as u8 * 6])
            .collect();
        s.textures.push(Texture::from_srgb8(8, 8, &checker));
        s.textures.push(Texture::from_srgb8(8, 8, &bumps));
        let material = s.add_material(Material {
            color: Color::new(0.9, 0.9, 0.9),
            kd: 0.6,
            ks: 0.3,
            shine: 20.0,
            texture: Some(0),
            normal_map: Some(NormalMap {
                texture: 1,
                scale: 1.0,
                kind: NormalMapKind::Tangent,
            }),
            ..Material::default()
        });
        let vertices = [
            Vec3::new(0.2, -3.0, 0.3),
            Vec3::new(2.2, -3.0, 0.3),
            Vec3::new(2.2, -3.0, 2.3),
            Vec3::new(0.2, -3.0, 2.3),
        ];
        let uv = [
            Uv::new(0.0, 0.0),
            Uv::new(1.0, 0.0),
            Uv::new(1.0, 1.0),
            Uv::new(0.0, 1.0),
        ];
        let group = s.new_group();
        s.add_mesh_polygon(
            &MeshPolygon {
                vertices: &vertices,
                normals: None,
                uv: Some(&uv),
                material,
                group,
            },
            &|| "quad".into(),
        );
        s
    }

    /// Every material matte (`kd` 0.5: half of the colour is ambient),
    /// without lights: no hit needs a normal.
    pub(in crate::render) fn unlit(mut s: Scene) -> Scene {
        s.lights.clear();
        for m in &mut s.materials {
            (m.kd, m.ks, m.t, m.mirror) = (0.5, 0.0, 0.0, 0.0);
        }
        s
    }

    /// Per pixel centre, the bits of its colour and of the rays its hit
    /// spawns (start and direction: offset along the normal), with and
    /// without the lean surfaces.
    fn both(scene: Scene, settings: TraceSettings) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
        let world = World::new(scene);
        let camera = Camera::new(&world.scene.viewpoint, 48, 36);
        let render = |lean: bool| {
            let mut tracer = Tracer::new(&world, settings);
            tracer.lean_surfaces = lean;
            let mut out = Vec::new();
            for y in 0..camera.height {
                for x in 0..camera.width {
                    let packet = pixel_ray(&camera, x, y);
                    let hits = tracer.eye_hits(&packet, &[0]);
                    let mut tree = ShadingTree::new(SecondaryRays::Own);
                    let first = tracer.surfaces(&packet, &hits, 1, [1.0], &mut tree);
                    let mut bits = vec![];
                    for spawn in [first.reflected[0], first.refracted[0], first.passed[0]] {
                        let (o, d) = spawn.map_or((Vec3::ZERO, Vec3::ZERO), |s| (s.origin, s.dir));
                        bits.extend(o.to_array().into_iter().chain(d.to_array()));
                    }
                    bits.extend(tracer.trace_eye(&packet, &[0])[0].to_array());
                    out.push(bits.into_iter().map(f32::to_bits).collect());
                }
            }
            out
        };
        (render(true), render(false))
    }

    fn assert_same(what: &str, (lean, full): (Vec<Vec<u32>>, Vec<Vec<u32>>)) {
        let differ = lean.iter().zip(&full).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{what}: {differ} pixels differ without normals");
        // The scene shows something besides the background.
        let colours: std::collections::HashSet<_> =
            full.iter().map(|p| &p[p.len() - 3..]).collect();
        assert!(colours.len() > 20, "{what}: {} colours", colours.len());
    }

    #[test]
    fn unlit_matte_hits_skip_their_normal_and_keep_their_colour() {
        let s = unlit(scene());
        for m in &s.materials {
            assert!(!needs_normal(&s, m, true), "{m:?}");
        }
        assert_same(
            "matte, textured, no light",
            both(s, TraceSettings::default()),
        );
    }

    /// Each reason to read the normal, alone in a scene that has no other:
    /// skipping it anyway changes pixels.
    #[test]
    fn hits_that_read_their_normal_keep_it() {
        let settings = TraceSettings::default();
        assert_same("lights, normal map", both(scene(), settings));
        // Highlights alone (no diffuse, no mirror), at the last level.
        let mut s = scene();
        for m in &mut s.materials {
            (m.kd, m.ks, m.mirror) = (0.0, 0.6, 0.0);
        }
        let last = TraceSettings {
            max_depth: 1,
            ..settings
        };
        assert_same("lights, highlights only", both(s, last));
        let mut s = unlit(scene());
        s.materials[2].mirror = 0.7;
        assert_same("a mirror, no light", both(s, settings));
        let mut s = unlit(scene());
        (s.materials[2].t, s.materials[2].ior) = (0.7, 1.5);
        assert_same("glass, no light", both(s, settings));
        let mut s = unlit(scene());
        (s.materials[3].alpha_mode, s.materials[3].alpha) = (AlphaMode::Blend, 0.5);
        assert_same("BLEND, no light", both(s, settings));
        let mut s = unlit(scene());
        let sky = [Color::new(2.0, 0.2, 0.1), Color::new(0.1, 0.3, 1.5)];
        let texels = (0..32).map(|i| sky[i / 16]).collect();
        s.environment = Some(std::sync::Arc::new(Environment::from_texels(
            8, 4, texels, true,
        )));
        assert_same("environment, no light", both(s, settings));
        // SPD: every mirror spawns its ray, at any weight.
        let mut s = unlit(scene());
        s.materials[1].mirror = 1e-4;
        let spd = TraceSettings {
            spd: true,
            min_weight: 0.0,
            ..settings
        };
        assert_same("SPD, a faint mirror, no light", both(s, spd));
    }
}
