//! A glTF material's paint under a toon look: a [`ToonHairMeshes`](super::ToonHairMeshes) mesh
//! keeps its own colours (base colour and texture), its alpha cut-out and its sides while it
//! wears the rest of a [`ToonHairMaterial`] (ramp, lighting, angel ring, tips, rim, hatching).
//!
//! With a material of the user's, each glTF material's meshes wear one copy of it in that
//! material's paint; [`follow_look_edits`] keeps the copies in step when the user's material
//! changes (a panel, a preset, code), so a look is still edited in one place.
//!
//! A VRM's MToon material also gives its shade colour ([`VrmShadeColor`]): the copy's
//! [`ToonShading::shade_color`](super::ToonShading::shade_color) is set so the ramp's darkest
//! tone draws that colour (times the texture) where the base colour would be drawn dark. The
//! default look also takes its shading band ([`VrmShading`]): a two-tone ramp that turns where
//! the band says ([`BandRamps`]).

use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::*;

use super::ToonHairMaterial;
use super::ramps::{BAND_DARKEST, ToonRamps, band_ramp, three_tone, two_tone};
use crate::asset::{VrmRim, VrmShadeColor, VrmShading};
use crate::math::finite_or;

/// Where the colours of the meshes a [`ToonHairMeshes`](super::ToonHairMeshes) dresses with a
/// material of yours come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
#[reflect(Default, Debug, PartialEq)]
pub enum HairPaint {
    /// Your material as it is, on every mesh: its base colour and texture, cut-out and sides
    /// (a recolour). A mesh whose glTF material is double-sided or cut out, on a material that
    /// is not, is reported with a warning naming it.
    #[default]
    Material,
    /// Each mesh's glTF material: its base colour and base colour texture, its alpha cut-out
    /// and its sides, under the rest of your material (ramp, lighting, angel ring, tips, rim,
    /// hatching, shade colour): a look applied to painted hair, a VRM's with several hair
    /// materials. Each glTF material's meshes wear one copy of your material, kept in step
    /// with your edits to it. A mesh without a glTF material wears yours as it is. A VRM's
    /// MToon shade colour is kept too: the ramp's darkest tone draws it, tinted by your shade
    /// colour.
    Gltf,
}

/// What a glTF material gives the toon material that dresses its meshes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct GltfPaint {
    pub base_color: Color,
    pub texture: Option<Handle<Image>>,
    pub double_sided: bool,
    /// The cut-off: a mask's own, `0.5` for alpha that blends (which the toon material does
    /// not), `None` when opaque.
    pub alpha_cutoff: Option<f32>,
    /// The glTF material blends by alpha: it is cut out instead.
    pub blends: bool,
    /// Its MToon shade colour (a VRM's), if it has one.
    pub shade: Option<Color>,
    /// The ramp of its MToon shading band (see [`BandRamps`]), when the look worn is the
    /// default one: it replaces the look's ramp.
    pub band_ramp: Option<Handle<Image>>,
    /// Its MToon rim light (a VRM's), if it has one.
    pub rim: Option<VrmRim>,
}

impl GltfPaint {
    /// The paint of the glTF material `m` (as Bevy's glTF loader builds it), with the MToon
    /// shade colour of the mesh wearing it.
    pub fn of(m: &StandardMaterial, shade: Option<&VrmShadeColor>) -> Self {
        let (alpha_cutoff, blends) = match m.alpha_mode {
            AlphaMode::Opaque => (None, false),
            AlphaMode::Mask(cutoff) => (Some(cutoff), false),
            _ => (Some(0.5), true),
        };
        Self {
            base_color: m.base_color,
            texture: m.base_color_texture.clone(),
            double_sided: m.double_sided || m.cull_mode.is_none(),
            alpha_cutoff,
            blends,
            shade: shade.map(|s| s.0),
            band_ramp: None,
            rim: None,
        }
    }

    /// `look` in this paint: its base colour and texture this paint's (its own texture kept
    /// where the glTF material has none), double-sided if either is, cut out at its own
    /// cut-off or else this paint's; with a band ramp, that ramp instead of the look's; with an
    /// MToon shade colour, its shade colour set so the ramp's darkest tone (see
    /// [`darkest_tone`]) draws that colour, times the look's own; with an MToon rim light, that
    /// rim unless the look has one of its own.
    pub fn on(&self, look: &ToonHairMaterial, ramps: &ToonRamps) -> ToonHairMaterial {
        let mut m = look.clone();
        m.base_color = self.base_color;
        if self.texture.is_some() {
            m.base_color_texture = self.texture.clone();
        }
        m.double_sided |= self.double_sided;
        m.alpha_cutoff = look.alpha_cutoff.or(self.alpha_cutoff);
        let mut darkest = darkest_tone(&look.ramp, ramps);
        if let Some(ramp) = &self.band_ramp {
            m.ramp = ramp.clone();
            darkest = Some(BAND_DARKEST);
        }
        m.shading.mtoon_rim = look.shading.mtoon_rim.or(self.rim);
        if let Some(shade) = self.shade {
            let tint = shade_tint(shade, self.base_color, darkest);
            let own = look.shading.shade_color.to_linear();
            m.shading.shade_color = Color::linear_rgb(
                own.red * tint.red,
                own.green * tint.green,
                own.blue * tint.blue,
            );
        }
        m
    }
}

/// The darkest tone of `ramp` when it is one of the crate's generated ramps (the two-tone
/// ramp's, or the three-tone one's, which the depth, back light and specular ramps share);
/// `None` for a ramp of the user's, whose tones are not known here.
pub(crate) fn darkest_tone(ramp: &Handle<Image>, ramps: &ToonRamps) -> Option<f32> {
    if *ramp == ramps.two_tone {
        Some(two_tone(0.0))
    } else if [
        &ramps.three_tone,
        &ramps.depth,
        &ramps.back_light,
        &ramps.specular,
    ]
    .contains(&ramp)
    {
        Some(three_tone(0.0))
    } else {
        None
    }
}

/// The toon shader's shade colour that makes a tone `darkest` bright draw `shade` on a surface
/// of `base` colour: the shader multiplies a tone by `mix(1, shade colour, w)`, `w = 2 (1 -
/// tone)` clamped to `[0, 1]`, so the shade colour is `(shade / (base * darkest) - (1 - w)) /
/// w`, per channel, clamped to the shader's `[0, 16]` (a base channel of 0 cannot be shaded
/// into colour). With no known darkest tone (`None`), or one too bright to take the shade
/// colour, the shade over the base colour: its hue and darkness relative to the base tint the
/// darker tones.
pub(crate) fn shade_tint(shade: Color, base: Color, darkest: Option<f32>) -> LinearRgba {
    let (s, b) = (shade.to_linear(), base.to_linear());
    let (d, w) = match darkest {
        Some(d) if d > 0.0 && 2.0 * (1.0 - d) > 0.0 => (d, (2.0 * (1.0 - d)).min(1.0)),
        _ => (1.0, 1.0),
    };
    let channel = |s: f32, b: f32| {
        if b * d <= 1e-6 {
            return 1.0;
        }
        finite_or((s / (b * d) - (1.0 - w)) / w, 1.0).clamp(0.0, 16.0)
    };
    LinearRgba::rgb(
        channel(s.red, b.red),
        channel(s.green, b.green),
        channel(s.blue, b.blue),
    )
}

/// What a VRM's MToon material put on a mesh: its shade colour, shading band and rim light, if
/// any.
pub(crate) type MtoonParts = (
    Option<&'static VrmShadeColor>,
    Option<&'static VrmShading>,
    Option<&'static VrmRim>,
);

/// An MToon rim's two uniform lanes, as the cel and toon shaders read them: its colour (linear,
/// non-negative) and lighting mix, then its Fresnel power (at least `1e-5`) and lift; all zero
/// without a rim (the shaders skip it).
pub(crate) fn rim_uniform(rim: Option<&VrmRim>) -> (Vec4, Vec4) {
    let Some(rim) = rim else {
        return (Vec4::ZERO, Vec4::ZERO);
    };
    let c = rim.color.to_linear();
    let channel = |x: f32| finite_or(x, 0.0).max(0.0);
    (
        Vec4::new(
            channel(c.red),
            channel(c.green),
            channel(c.blue),
            finite_or(rim.lighting_mix, 1.0).clamp(0.0, 1.0),
        ),
        Vec4::new(
            finite_or(rim.fresnel_power, 5.0).clamp(1e-5, crate::asset::MAX_RIM_POWER),
            finite_or(rim.lift, 0.0).clamp(-1.0, 1.0),
            0.0,
            0.0,
        ),
    )
}

/// The ramps made for MToon shading bands ([`band_ramp`]), one per band, for the default look
/// of hair whose glTF material is MToon: its terminator where the band puts it, measured as the
/// toon material measures light (as [`mtoon_cel_band`](super::mtoon_cel_band) places the
/// body's).
#[derive(Resource, Default)]
pub(crate) struct BandRamps(HashMap<[u32; 2], Handle<Image>>);

impl BandRamps {
    /// The ramp of `band`: the one made before, else a new one in `images`.
    pub fn of(&mut self, band: &VrmShading, images: &mut Assets<Image>) -> Handle<Image> {
        let (threshold, softness) = super::mtoon_cel_band(band);
        self.0
            .entry([threshold.to_bits(), softness.to_bits()])
            .or_insert_with(|| images.add(band_ramp(threshold, softness)))
            .clone()
    }
}

/// The copies of users' materials in glTF paint: for each (look, glTF material), the copy the
/// meshes wear and the paint it was made with. Entries whose copy is gone are dropped.
#[derive(Resource, Default)]
pub(crate) struct LookCopies(HashMap<LookInPaint, (AssetId<ToonHairMaterial>, GltfPaint)>);

/// A user's material and a glTF material whose paint it is worn in.
type LookInPaint = (AssetId<ToonHairMaterial>, AssetId<StandardMaterial>);

impl LookCopies {
    /// The copy of `look` in `gltf`'s `paint`: the one already made while a mesh still wears
    /// it, else a new one.
    pub fn copy(
        &mut self,
        look: &Handle<ToonHairMaterial>,
        gltf: AssetId<StandardMaterial>,
        paint: GltfPaint,
        materials: &mut Assets<ToonHairMaterial>,
        ramps: &ToonRamps,
    ) -> Option<Handle<ToonHairMaterial>> {
        self.0.retain(|_, (copy, _)| materials.contains(*copy));
        let key = (look.id(), gltf);
        if let Some(copy) = self
            .0
            .get(&key)
            .and_then(|(copy, _)| materials.get_strong_handle(*copy))
        {
            return Some(copy);
        }
        let copy = materials.add(paint.on(materials.get(look)?, ramps));
        self.0.insert(key, (copy.id(), paint));
        Some(copy)
    }
}

/// Remakes the copies of every user's material that changed, each in its paint.
pub(crate) fn follow_look_edits(
    mut events: MessageReader<AssetEvent<ToonHairMaterial>>,
    copies: Res<LookCopies>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    ramps: Res<ToonRamps>,
) {
    let edited: HashSet<AssetId<ToonHairMaterial>> = events
        .read()
        .filter_map(|e| match e {
            AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    if edited.is_empty() {
        return;
    }
    for ((look, _), (copy, paint)) in &copies.0 {
        // Remaking a copy does not feed back: a copy is never a look.
        if !edited.contains(look) {
            continue;
        }
        let Some(remade) = materials.get(*look).map(|l| paint.on(l, &ramps)) else {
            continue;
        };
        if let Some(mut worn) = materials.get_mut(*copy) {
            *worn = remade;
        }
    }
}

#[cfg(test)]
mod tests {
    use bevy::render::render_resource::Face;

    use super::*;
    use crate::render::{AngelRingProfile, ToonShading};

    fn image(app: &mut App) -> Handle<Image> {
        app.world_mut()
            .resource_mut::<Assets<Image>>()
            .add(Image::default())
    }

    /// A glTF material's paint: its colour and texture, its sides (either flag), and its cut-off
    /// (a mask's own; half for blended alpha; none when opaque).
    #[test]
    fn a_gltf_materials_paint_is_its_colour_texture_sides_and_cut() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>();
        let texture = image(&mut app);
        let opaque = GltfPaint::of(
            &StandardMaterial {
                base_color: Color::srgb(0.2, 0.4, 0.6),
                base_color_texture: Some(texture.clone()),
                ..default()
            },
            None,
        );
        assert_eq!(opaque.base_color, Color::srgb(0.2, 0.4, 0.6));
        assert_eq!(opaque.texture, Some(texture));
        assert_eq!((opaque.double_sided, opaque.alpha_cutoff), (false, None));
        let sides = |double_sided, cull_mode| {
            GltfPaint::of(
                &StandardMaterial {
                    double_sided,
                    cull_mode,
                    ..default()
                },
                None,
            )
            .double_sided
        };
        assert!(sides(true, None) && sides(false, None) && sides(true, Some(Face::Back)));
        assert!(!sides(false, Some(Face::Back)));
        let cut = |alpha_mode| {
            let p = GltfPaint::of(
                &StandardMaterial {
                    alpha_mode,
                    ..default()
                },
                None,
            );
            (p.alpha_cutoff, p.blends)
        };
        assert_eq!(cut(AlphaMode::Mask(0.3)), (Some(0.3), false));
        assert_eq!(cut(AlphaMode::Blend), (Some(0.5), true));
        assert_eq!(cut(AlphaMode::AlphaToCoverage), (Some(0.5), true));
    }

    /// A look in a glTF material's paint keeps everything of the look but the colour and
    /// texture; sides and cut-out are the look's or the paint's; the paint's MToon rim is worn
    /// unless the look has a rim of its own.
    #[test]
    fn a_look_in_paint_keeps_its_look_and_takes_the_colours() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>();
        let (ramp, own, painted) = (image(&mut app), image(&mut app), image(&mut app));
        let look = ToonHairMaterial {
            shading: ToonShading {
                base_color: Color::srgb(0.1, 0.8, 0.1),
                angel_ring: 0.7,
                angel_ring_profile: AngelRingProfile::Tapered,
                tip_color: Color::srgb(0.9, 0.1, 0.5),
                tip_strength: 0.8,
                ..default()
            },
            ramp: ramp.clone(),
            base_color_texture: Some(own.clone()),
            ..default()
        };
        let paint = GltfPaint {
            base_color: Color::srgb(0.9, 0.3, 0.2),
            texture: Some(painted.clone()),
            double_sided: true,
            alpha_cutoff: Some(0.4),
            blends: false,
            shade: None,
            band_ramp: None,
            rim: Some(VrmRim {
                color: Color::linear_rgb(0.4, 0.2, 0.1),
                ..default()
            }),
        };
        let ramps = ToonRamps::generate(&mut app.world_mut().resource_mut::<Assets<Image>>());
        let worn = paint.on(&look, &ramps);
        let mut expected = look.clone();
        expected.base_color = Color::srgb(0.9, 0.3, 0.2);
        expected.shading.mtoon_rim = paint.rim;
        assert_eq!(worn.shading, expected.shading);
        assert_eq!(worn.ramp, ramp);
        assert_eq!(worn.base_color_texture, Some(painted));
        assert!(worn.double_sided);
        assert_eq!(worn.alpha_cutoff, Some(0.4));
        // A glTF material without a texture leaves the look's; the look's own cut-off wins.
        let plain = GltfPaint {
            texture: None,
            double_sided: false,
            ..paint
        };
        let cut_look = ToonHairMaterial {
            alpha_cutoff: Some(0.8),
            double_sided: true,
            ..look
        };
        let worn = plain.on(&cut_look, &ramps);
        assert_eq!(worn.base_color_texture, Some(own));
        assert_eq!(worn.alpha_cutoff, Some(0.8));
        assert!(worn.double_sided);
        let own_rim = VrmRim {
            color: Color::WHITE,
            fresnel_power: 2.0,
            ..default()
        };
        let mut ringed = cut_look.clone();
        ringed.shading.mtoon_rim = Some(own_rim);
        assert_eq!(plain.on(&ringed, &ramps).shading.mtoon_rim, Some(own_rim));
    }

    /// What the toon shader draws for a tone `tone` bright with shade colour `shade` on
    /// `base`: `base * tone * mix(1, shade, w)`, as `toon.wesl` does (its luma is `tone` for a
    /// grey ramp).
    fn drawn(base: f32, tone: f32, shade: f32) -> f32 {
        let w = (2.0 * (1.0 - tone)).clamp(0.0, 1.0);
        base * tone * (1.0 + (shade - 1.0) * w)
    }

    /// The MToon shade colour comes out of the darkest tone of the crate's ramps as given: a
    /// skin-pink shade on a pale base, through the three-tone ramp (0.45) and the two-tone one
    /// (0.55, whose darkest tone takes only 0.9 of the shade colour); a base channel of 0
    /// cannot be shaded (1, no change); a shade beyond 16x the tone is clamped; a ramp of the
    /// user's takes the shade over the base colour.
    #[test]
    fn the_mtoon_shade_is_what_the_darkest_tone_draws() {
        let base = Color::linear_rgb(0.9, 0.8, 0.7);
        let shade = Color::linear_rgb(0.6, 0.3, 0.35);
        for d in [three_tone(0.0), two_tone(0.0)] {
            let tint = shade_tint(shade, base, Some(d));
            let out = [
                drawn(0.9, d, tint.red),
                drawn(0.8, d, tint.green),
                drawn(0.7, d, tint.blue),
            ];
            for (got, want) in out.into_iter().zip([0.6, 0.3, 0.35]) {
                assert!((got - want).abs() < 1e-5, "tone {d}: {out:?}");
            }
        }
        let tint = shade_tint(
            Color::linear_rgb(0.5, 0.9, 0.1),
            Color::linear_rgb(0.0, 0.05, 0.5),
            Some(0.45),
        );
        assert_eq!(tint.red, 1.0);
        assert_eq!(tint.green, 16.0);
        assert!((tint.blue - 0.1 / (0.5 * 0.45)).abs() < 1e-6);
        let tint = shade_tint(shade, base, None);
        assert!((tint.red - 0.6 / 0.9).abs() < 1e-6 && (tint.green - 0.3 / 0.8).abs() < 1e-6);
    }

    /// A look in the paint of an MToon material: its shade colour is the look's times the
    /// tint for the look's ramp (the crate's three-tone ramp here); a ramp of the user's takes
    /// the shade over the base; without a shade colour the look's own is kept.
    #[test]
    fn a_look_in_mtoon_paint_takes_the_shade_colour() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>();
        let ramps = ToonRamps::generate(&mut app.world_mut().resource_mut::<Assets<Image>>());
        let own_ramp = image(&mut app);
        let base = Color::linear_rgb(0.8, 0.8, 0.8);
        let shade = VrmShadeColor(Color::linear_rgb(0.3, 0.2, 0.5));
        let paint = GltfPaint::of(
            &StandardMaterial {
                base_color: base,
                ..default()
            },
            Some(&shade),
        );
        let violet = Color::linear_rgb(1.0, 0.5, 1.0);
        let look = ToonHairMaterial {
            shading: ToonShading {
                shade_color: violet,
                ..default()
            },
            ramp: ramps.three_tone.clone(),
            ..default()
        };
        let worn = paint.on(&look, &ramps).shading.shade_color.to_linear();
        let tint = shade_tint(shade.0, base, Some(0.45));
        assert_eq!(
            (worn.red, worn.green, worn.blue),
            (tint.red, 0.5 * tint.green, tint.blue)
        );
        let theirs = ToonHairMaterial {
            ramp: own_ramp,
            ..look.clone()
        };
        let worn = paint.on(&theirs, &ramps).shading.shade_color.to_linear();
        assert!((worn.red - 0.3 / 0.8).abs() < 1e-6 && (worn.blue - 0.5 / 0.8).abs() < 1e-6);
        let unshaded = GltfPaint {
            shade: None,
            ..paint
        };
        assert_eq!(unshaded.on(&look, &ramps).shading.shade_color, violet);
    }

    /// An MToon band's ramp (made once per band): dark (half the lit tone) below the band, lit
    /// above it, the smooth step's middle at its middle; worn by the default look in place of
    /// its ramp, with the shade colour worked out for that ramp's dark tone.
    #[test]
    fn an_mtoon_bands_ramp_replaces_the_looks_and_keeps_the_shade_exact() {
        let mut images = Assets::<Image>::default();
        let ramps = ToonRamps::generate(&mut images);
        let mut bands = BandRamps::default();
        let band = VrmShading {
            shift: -0.5,
            toony: 0.9,
        };
        let ramp = bands.of(&band, &mut images);
        assert_eq!(bands.of(&band, &mut images), ramp);
        assert_eq!(bands.0.len(), 1);
        // N.L 0.4 to 0.6: texel x covers (x + 0.5) / 256 of the light.
        let image = images.get(&ramp).unwrap();
        let texel = |light: f32| {
            let x = ((light * 256.0) as usize).min(255);
            image.data.as_ref().unwrap()[4 * x]
        };
        let dark = (BAND_DARKEST * 255.0).round() as u8;
        assert_eq!((texel(0.1), texel(0.39)), (dark, dark));
        assert_eq!((texel(0.61), texel(0.95)), (255, 255));
        let middle = (255.0 + f32::from(dark)) / 2.0;
        assert!(
            (f32::from(texel(0.5)) - middle).abs() <= 2.0,
            "{}",
            texel(0.5)
        );
        let look = ToonHairMaterial {
            ramp: ramps.three_tone.clone(),
            ..default()
        };
        let (base, shade) = (
            Color::linear_rgb(0.8, 0.6, 0.5),
            Color::linear_rgb(0.3, 0.2, 0.4),
        );
        let paint = GltfPaint {
            base_color: base,
            shade: Some(shade),
            band_ramp: Some(ramp.clone()),
            ..GltfPaint::of(&StandardMaterial::default(), None)
        };
        let worn = paint.on(&look, &ramps);
        assert_eq!(worn.ramp, ramp);
        assert_eq!(
            worn.shading.shade_color.to_linear(),
            shade_tint(shade, base, Some(BAND_DARKEST))
        );
        // Without the band ramp, the look's own ramp and its darkest tone.
        let plain = GltfPaint {
            band_ramp: None,
            ..paint
        };
        let worn = plain.on(&look, &ramps);
        assert_eq!(worn.ramp, ramps.three_tone);
        assert_eq!(
            worn.shading.shade_color.to_linear(),
            shade_tint(shade, base, Some(three_tone(0.0)))
        );
    }
}
