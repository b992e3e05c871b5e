//! Hair-mass normals: each vertex normal leans toward the normal of a smooth shape around the
//! whole hair, so light and shadow flow across the hair as one shape instead of one band per
//! strand (how anime hair is shaded in games: edited or remapped normals).
//!
//! The shape is an ellipsoid in the bone's space ([`HairMassShape`]); its normal field is the
//! gradient of `|A⁻¹ (p - c)|²`, the normal of the concentric ellipsoid through each point, so
//! it is defined inside the shape too (where most hair vertices are).

use bevy::math::{Affine3A, Mat3A, Vec3A};
use bevy::prelude::*;

/// The smooth shape a hair's normals lean toward ([`HairMeshSettings::mass_normals`]).
///
/// [`HairMeshSettings::mass_normals`]: super::HairMeshSettings::mass_normals
#[derive(Reflect, Clone, Copy, Debug, PartialEq, Default)]
#[reflect(Default, Debug, PartialEq)]
#[non_exhaustive]
pub enum HairMassShape {
    /// An ellipsoid fitted to the groom's rest shape: centred on its bounding box in the bone's
    /// space, with the box's half extents as half axes (each at least a quarter of the longest,
    /// so a flat or single-strand groom still gets a round shape).
    #[default]
    Fitted,
    /// An ellipsoid given in the bone's space, in the groom's units (as in the `.hair.xml`);
    /// for a character's own hair mesh (`ToonHairMeshes::mass_shapes`), in the mesh's space.
    Ellipsoid {
        /// Centre.
        centre: Vec3,
        /// Half axis lengths along the bone's x, y and z; each is kept above 1e-6.
        half_extents: Vec3,
    },
}

/// The smallest half axis of a fitted ellipsoid, relative to its longest.
const MIN_AXIS_RATIO: f32 = 0.25;

impl HairMassShape {
    /// `(centre, half_extents)` in the bone's rigid space (the groom scaled to the bone), given
    /// the groom's rest bounds there and the bone's scale; `None` if nothing usable is known.
    pub(crate) fn ellipsoid(
        &self,
        rest_bounds: Option<(Vec3, Vec3)>,
        scale: Vec3,
    ) -> Option<(Vec3, Vec3)> {
        let (centre, half) = match *self {
            Self::Fitted => {
                let (min, max) = rest_bounds?;
                let half = (max - min) * 0.5;
                let floor = half.max_element() * MIN_AXIS_RATIO;
                ((min + max) * 0.5, half.max(Vec3::splat(floor)))
            }
            Self::Ellipsoid {
                centre,
                half_extents,
            } => (centre * scale, (half_extents * scale).abs()),
        };
        let half = half.max(Vec3::splat(1e-6));
        (centre.is_finite() && half.is_finite()).then_some((centre, half))
    }
}

/// An ellipsoid's normal field in world space: `normal(p) ∝ M (p - c)`, with
/// `M = R diag(1/a²) Rᵀ` for the bone's rotation `R` and half axes `a`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct MassField {
    centre: Vec3A,
    metric: Mat3A,
    /// The bone's up axis (its `+Y`) in world space: the mass's meridians run down from it.
    up: Vec3A,
    /// Blend weight toward the field's normal, `[0, 1]`.
    weight: f32,
}

impl MassField {
    /// The field of the ellipsoid `(centre, half_extents)` in the rigid bone space `bone`;
    /// `None` when the weight is 0 (or not finite) or the pose is unusable.
    pub(crate) fn new(
        bone: &Affine3A,
        (centre, half_extents): (Vec3, Vec3),
        weight: f32,
    ) -> Option<Self> {
        let weight = if weight.is_finite() {
            weight.clamp(0.0, 1.0)
        } else {
            0.0
        };
        if weight == 0.0 || !bone.is_finite() {
            return None;
        }
        let inv2 = (half_extents * half_extents).recip();
        // Scaled so the largest entry is 1: only the direction matters, and tiny axes (metres
        // on a 0.01 rig) would otherwise overflow.
        let inv2 = inv2 / inv2.max_element();
        let r = bone.matrix3;
        let metric = r * Mat3A::from_diagonal(inv2) * r.transpose();
        Some(Self {
            centre: bone.transform_point3a(centre.into()),
            metric,
            up: r.y_axis.normalize_or_zero(),
            weight,
        })
    }

    /// Leans each normal toward the field's normal at its position (normalised linear blend).
    /// Where the two cancel, or at the centre, the tube's own normal stays.
    pub(crate) fn apply(&self, positions: &[[f32; 3]], normals: &mut [[f32; 3]]) {
        // Eight vertices at a time in coordinate rows, with no branch in the arithmetic, so the
        // compiler vectorises across vertices (the per-vertex form was a tenth of a frame of
        // 10,000 strands).
        const W: usize = 8;
        let m = self.metric;
        let (c, w) = (self.centre, self.weight);
        let mut p_chunks = positions.chunks(W);
        for ns in normals.chunks_mut(W) {
            let Some(ps) = p_chunks.next() else {
                break;
            };
            let k = ns.len().min(ps.len());
            let mut out = [[0.0f32; W]; 3];
            let mut keep = [false; W];
            let (mut px, mut py, mut pz) = ([0.0f32; W], [0.0f32; W], [0.0f32; W]);
            let (mut nx, mut ny, mut nz) = ([0.0f32; W], [0.0f32; W], [0.0f32; W]);
            for i in 0..k {
                [px[i], py[i], pz[i]] = ps[i];
                [nx[i], ny[i], nz[i]] = ns[i];
            }
            for i in 0..W {
                let d = [px[i] - c.x, py[i] - c.y, pz[i] - c.z];
                let f = [
                    m.x_axis.x * d[0] + m.y_axis.x * d[1] + m.z_axis.x * d[2],
                    m.x_axis.y * d[0] + m.y_axis.y * d[1] + m.z_axis.y * d[2],
                    m.x_axis.z * d[0] + m.y_axis.z * d[1] + m.z_axis.z * d[2],
                ];
                let fl2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
                // `normalize_or_zero`: no field at the centre.
                let fi = if fl2 > 0.0 && fl2.is_finite() {
                    fl2.sqrt().recip()
                } else {
                    0.0
                };
                let b = [
                    nx[i] + (f[0] * fi - nx[i]) * w,
                    ny[i] + (f[1] * fi - ny[i]) * w,
                    nz[i] + (f[2] * fi - nz[i]) * w,
                ];
                let l2 = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
                keep[i] = l2 > 1e-12 && l2.is_finite();
                let inv = if keep[i] { l2.sqrt().recip() } else { 0.0 };
                for a in 0..3 {
                    out[a][i] = b[a] * inv;
                }
            }
            // Where the two cancel, the tube's own normal stays.
            for i in 0..k {
                if keep[i] {
                    ns[i] = [out[0][i], out[1][i], out[2][i]];
                }
            }
        }
    }
}

impl MassField {
    /// The field's centre, metric, the bone's up axis and the weight, for the GPU's copy of it.
    #[cfg(feature = "render")]
    pub(crate) fn parts(&self) -> (Vec3, Mat3, Vec3, f32) {
        (
            self.centre.into(),
            Mat3::from(self.metric),
            self.up.into(),
            self.weight,
        )
    }

    /// Leans each tangent (Bevy's `[x, y, z, w]`, its `xyz` along the strand) toward the
    /// mass's meridian at its position: the way down the ellipsoid from its top, as a comb runs
    /// over the whole hair. The angel ring (Kajiya-Kay on the tangent) then runs as one band
    /// around the mass instead of breaking up along every spike. At the top, where there is
    /// no meridian, the strand's own direction stays; `w` is kept.
    pub(crate) fn lean_tangents(&self, positions: &[[f32; 3]], tangents: &mut [[f32; 4]]) {
        let (m, c, w, up) = (self.metric, self.centre, self.weight, self.up);
        for (p, t) in positions.iter().zip(tangents) {
            let normal = (m * (Vec3A::from_array(*p) - c)).normalize_or_zero();
            // Down the surface: -up less its part along the normal. Its length (the sine of the
            // angle from the top) fades the lean out near the top.
            let meridian = normal * normal.dot(up) - up;
            let own = Vec3A::new(t[0], t[1], t[2]);
            // Kajiya-Kay does not see the tangent's sign: lean toward the nearer of the two.
            let meridian = if meridian.dot(own) < 0.0 {
                -meridian
            } else {
                meridian
            };
            let blended = (own + (meridian - own * meridian.length()) * w).normalize_or_zero();
            if blended != Vec3A::ZERO && blended.is_finite() {
                [t[0], t[1], t[2]] = blended.to_array();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(weight: f32) -> MassField {
        let shape = HairMassShape::Ellipsoid {
            centre: Vec3::new(0.0, 1.0, 0.0),
            half_extents: Vec3::new(2.0, 1.0, 1.0),
        };
        let e = shape.ellipsoid(None, Vec3::ONE).unwrap();
        MassField::new(&Affine3A::IDENTITY, e, weight).unwrap()
    }

    #[test]
    fn weight_zero_keeps_the_tubes_normals_and_one_gives_the_ellipsoids() {
        assert!(MassField::new(&Affine3A::IDENTITY, (Vec3::ZERO, Vec3::ONE), 0.0).is_none());
        assert!(MassField::new(&Affine3A::IDENTITY, (Vec3::ZERO, Vec3::ONE), f32::NAN).is_none());
        // On the surface point (2, 1, 0) the ellipsoid's normal is +X; at (0, 2, 0) it is +Y.
        let positions = [[2.0, 1.0, 0.0], [0.0, 2.0, 0.0], [1.0, 1.5, 0.0]];
        let mut normals = [[0.0, 0.0, 1.0]; 3];
        field(1.0).apply(&positions, &mut normals);
        assert!(
            Vec3::from(normals[0]).abs_diff_eq(Vec3::X, 1e-6),
            "{normals:?}"
        );
        assert!(
            Vec3::from(normals[1]).abs_diff_eq(Vec3::Y, 1e-6),
            "{normals:?}"
        );
        // Gradient of x²/4 + (y-1)²: (x/2, 2(y-1)) at (1, 1.5) is (0.5, 1), normalised.
        let expected = Vec3::new(0.5, 1.0, 0.0).normalize();
        assert!(
            Vec3::from(normals[2]).abs_diff_eq(expected, 1e-6),
            "{normals:?}"
        );
        // Half way: the normalised mean of the two.
        let mut half = [[0.0, 0.0, 1.0]; 1];
        field(0.5).apply(&positions[..1], &mut half);
        let expected = (Vec3::Z + Vec3::X).normalize();
        assert!(Vec3::from(half[0]).abs_diff_eq(expected, 1e-6), "{half:?}");
    }

    #[test]
    fn tangents_lean_down_the_mass_and_keep_their_own_at_the_top() {
        // On the side (2, 1, 0) the meridian is vertical; at the top (0, 2, 0) there is none.
        let positions = [[2.0, 1.0, 0.0], [2.0, 1.0, 0.0], [0.0, 2.0, 0.0]];
        let mut tangents = [
            [0.0, 0.0, 1.0, -1.0],
            [0.6, 0.8, 0.0, 1.0],
            [1.0, 0.0, 0.0, 1.0],
        ];
        field(1.0).lean_tangents(&positions, &mut tangents);
        // A strand running around the head turns to run down it; one pointing up (a spike)
        // turns to straight up (the same line), and `w` stays.
        assert_eq!(tangents[0], [0.0, -1.0, 0.0, -1.0]);
        assert!(
            Vec3::new(tangents[1][0], tangents[1][1], tangents[1][2]).abs_diff_eq(Vec3::Y, 1e-6)
        );
        assert_eq!(tangents[2], [1.0, 0.0, 0.0, 1.0]);
        // Half way on the side: between its own and the meridian.
        let mut half = [[0.0, 0.0, 1.0, 1.0]];
        field(0.5).lean_tangents(&positions[..1], &mut half);
        let expected = Vec3::new(0.0, -1.0, 1.0).normalize();
        assert!(
            Vec3::new(half[0][0], half[0][1], half[0][2]).abs_diff_eq(expected, 1e-6),
            "{half:?}"
        );
    }

    #[test]
    fn the_field_turns_with_the_bone_and_survives_degenerate_input() {
        // The bone turned a quarter about +Z: its x axis is the world's y.
        let bone = Affine3A::from_rotation_translation(
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::new(5.0, 0.0, 0.0),
        );
        let shape = HairMassShape::Ellipsoid {
            centre: Vec3::ZERO,
            half_extents: Vec3::new(2.0, 1.0, 1.0),
        };
        let f = MassField::new(&bone, shape.ellipsoid(None, Vec3::ONE).unwrap(), 1.0).unwrap();
        let mut n = [[1.0, 0.0, 0.0]; 3];
        // The bone-space tip of the long axis, (2, 0, 0), is at world (5, 2, 0); its normal is
        // the bone's x axis, world +Y. At the centre and opposite the tube's normal: unchanged
        // or finite.
        f.apply(&[[5.0, 2.0, 0.0], [5.0, 0.0, 0.0], [6.0, 0.0, 0.0]], &mut n);
        assert!(Vec3::from(n[0]).abs_diff_eq(Vec3::Y, 1e-5), "{n:?}");
        assert_eq!(n[1], [1.0, 0.0, 0.0]);
        assert!(n.iter().flatten().all(|v| v.is_finite()));
        // A flat fitted groom still gets a round shape; no bounds gives none.
        let (c, half) = HairMassShape::Fitted
            .ellipsoid(
                Some((Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0))),
                Vec3::ONE,
            )
            .unwrap();
        assert_eq!(c, Vec3::ZERO);
        assert_eq!(half, Vec3::new(1.0, 0.25, 0.25));
        assert!(HairMassShape::Fitted.ellipsoid(None, Vec3::ONE).is_none());
        // Tiny rigs (0.01 scale) keep a usable direction.
        let tiny = HairMassShape::Ellipsoid {
            centre: Vec3::ZERO,
            half_extents: Vec3::splat(1e-4),
        }
        .ellipsoid(None, Vec3::splat(0.01))
        .unwrap();
        let f = MassField::new(&Affine3A::IDENTITY, tiny, 1.0).unwrap();
        let mut n = [[0.0, 0.0, 1.0]];
        f.apply(&[[1e-6, 0.0, 0.0]], &mut n);
        assert!(Vec3::from(n[0]).abs_diff_eq(Vec3::X, 1e-5), "{n:?}");
    }
}
