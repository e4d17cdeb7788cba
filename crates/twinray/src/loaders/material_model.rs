//! Roughness-based materials in Whitted's terms: the one model behind glTF's
//! metallic-roughness materials and OBJ/MTL's `Ns` (read as Blender's
//! importer reads it). docs/formats.md has the table of every field.
//!
//! A surface of roughness `r` and specular reflectance `F0` at normal
//! incidence gets a Phong highlight of weight `F0 · (1 − r)` and exponent
//! `2/α² − 2` with `α = r²` (the Blinn-Phong exponent of the same lobe width
//! as a GGX lobe of that roughness, clamped to 1..10 000), and a mirror
//! weight `F0 · (1 − r)²`: roughness widens the highlight and dims it, and
//! at `r = 1` neither is left.

/// A file's material inputs brought into the ranges the shading model is
/// defined for, as NFF's are ([`Material::clamped`](crate::scene::Material::clamped)),
/// and what was changed, for a warning that names the file and material:
/// out of range, a colour of 3.4e38 or an emission of 1e38 gave infinite
/// pixels.
#[derive(Debug, Default)]
pub struct Inputs {
    pub changed: Vec<String>,
}

impl Inputs {
    /// `value` of input `name` in `lo..=hi` (NaN: `lo`).
    pub fn clamp(&mut self, name: &str, value: f32, lo: f32, hi: f32) -> f32 {
        let fixed = if value.is_nan() {
            lo
        } else {
            value.clamp(lo, hi)
        };
        if fixed != value || value.is_nan() {
            self.changed
                .push(format!("{name} {value} clamped to {fixed}"));
        }
        fixed
    }

    /// Each component of `values` in `lo..=hi`.
    pub fn clamp_all<const N: usize>(
        &mut self,
        name: &str,
        values: [f32; N],
        lo: f32,
        hi: f32,
    ) -> [f32; N] {
        let fixed = values.map(|v| if v.is_nan() { lo } else { v.clamp(lo, hi) });
        if fixed.iter().zip(&values).any(|(f, v)| f != v) {
            let show = |a: &[f32]| a.iter().map(f32::to_string).collect::<Vec<_>>().join(" ");
            self.changed.push(format!(
                "{name} {} clamped to {}",
                show(&values),
                show(&fixed)
            ));
        }
        fixed
    }

    /// The material after its inputs, with the final guard of
    /// [`Material::clamped`](crate::scene::Material::clamped) (which
    /// should find nothing left to change).
    pub fn finish(
        mut self,
        material: crate::scene::Material,
    ) -> (crate::scene::Material, Vec<String>) {
        let (material, more) = material.clamped();
        self.changed.extend(more);
        (material, self.changed)
    }
}

/// The highlight and mirror of a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongTerms {
    pub ks: f32,
    pub shine: f32,
    pub mirror: f32,
}

/// The highlight and mirror of roughness `roughness` (0..=1) and specular
/// reflectance `specular` at normal incidence.
pub fn phong_from_roughness(specular: f32, roughness: f32) -> PhongTerms {
    let alpha = (roughness * roughness).max(1e-3);
    PhongTerms {
        ks: specular * (1.0 - roughness),
        shine: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 10_000.0),
        mirror: specular * (1.0 - roughness) * (1.0 - roughness),
    }
}

/// MTL `Ns` (0..1000) as a roughness, as Blender's OBJ importer maps it:
/// `1 − √(Ns / 1000)`. `Ns 0` is fully rough (no highlight), not a Phong
/// lobe of exponent 0 (a uniform highlight that whitens the whole surface).
pub fn roughness_from_ns(ns: f32) -> f32 {
    let ns = if ns.is_finite() {
        ns.clamp(0.0, 1000.0)
    } else {
        0.0
    };
    1.0 - (ns / 1000.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_roughness_has_no_highlight_and_no_mirror() {
        let p = phong_from_roughness(1.0, roughness_from_ns(0.0));
        assert_eq!((p.ks, p.mirror), (0.0, 0.0));
    }

    #[test]
    fn smoother_is_brighter_and_narrower() {
        let rough = phong_from_roughness(0.5, roughness_from_ns(50.0));
        let smooth = phong_from_roughness(0.5, roughness_from_ns(900.0));
        assert!(smooth.ks > rough.ks && smooth.shine > rough.shine);
        assert!(smooth.mirror > rough.mirror);
        // Ns 1000: a mirror-like surface, the exponent at its cap.
        let mirror = phong_from_roughness(1.0, roughness_from_ns(1000.0));
        assert_eq!(
            (mirror.ks, mirror.mirror, mirror.shine),
            (1.0, 1.0, 10_000.0)
        );
    }

    #[test]
    fn bad_ns_is_rough() {
        assert_eq!(roughness_from_ns(f32::NAN), 1.0);
        assert_eq!(roughness_from_ns(-5.0), 1.0);
        assert_eq!(roughness_from_ns(5000.0), 0.0);
    }
}
