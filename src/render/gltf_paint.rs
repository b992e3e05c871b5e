//! A glTF material's paint under a toon look: a [`ToonHairMeshes`](super::ToonHairMeshes) mesh
//! keeps its own colours (base colour and texture), its alpha cut-out and its sides while it
//! wears the rest of a [`ToonHairMaterial`] (ramp, lighting, angel ring, tips, rim, hatching).
//!
//! With a material of the user's, each glTF material's meshes wear one copy of it in that
//! material's paint; [`follow_look_edits`] keeps the copies in step when the user's material
//! changes (a panel, a preset, code), so a look is still edited in one place.

use bevy::platform::collections::{HashMap, HashSet};
use bevy::prelude::*;

use super::ToonHairMaterial;

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
    /// with your edits to it. A mesh without a glTF material wears yours as it is.
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
}

impl GltfPaint {
    /// The paint of the glTF material `m` (as Bevy's glTF loader builds it).
    pub fn of(m: &StandardMaterial) -> Self {
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
        }
    }

    /// `look` in this paint: its base colour and texture this paint's (its own texture kept
    /// where the glTF material has none), double-sided if either is, cut out at its own
    /// cut-off or else this paint's.
    pub fn on(&self, look: &ToonHairMaterial) -> ToonHairMaterial {
        let mut m = look.clone();
        m.base_color = self.base_color;
        if self.texture.is_some() {
            m.base_color_texture = self.texture.clone();
        }
        m.double_sided |= self.double_sided;
        m.alpha_cutoff = look.alpha_cutoff.or(self.alpha_cutoff);
        m
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
        let copy = materials.add(paint.on(materials.get(look)?));
        self.0.insert(key, (copy.id(), paint));
        Some(copy)
    }
}

/// Remakes the copies of every user's material that changed, each in its paint.
pub(crate) fn follow_look_edits(
    mut events: MessageReader<AssetEvent<ToonHairMaterial>>,
    copies: Res<LookCopies>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
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
        let Some(remade) = materials.get(*look).map(|l| paint.on(l)) else {
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
        let opaque = GltfPaint::of(&StandardMaterial {
            base_color: Color::srgb(0.2, 0.4, 0.6),
            base_color_texture: Some(texture.clone()),
            ..default()
        });
        assert_eq!(opaque.base_color, Color::srgb(0.2, 0.4, 0.6));
        assert_eq!(opaque.texture, Some(texture));
        assert_eq!((opaque.double_sided, opaque.alpha_cutoff), (false, None));
        let sides = |double_sided, cull_mode| {
            GltfPaint::of(&StandardMaterial {
                double_sided,
                cull_mode,
                ..default()
            })
            .double_sided
        };
        assert!(sides(true, None) && sides(false, None) && sides(true, Some(Face::Back)));
        assert!(!sides(false, Some(Face::Back)));
        let cut = |alpha_mode| {
            let p = GltfPaint::of(&StandardMaterial {
                alpha_mode,
                ..default()
            });
            (p.alpha_cutoff, p.blends)
        };
        assert_eq!(cut(AlphaMode::Mask(0.3)), (Some(0.3), false));
        assert_eq!(cut(AlphaMode::Blend), (Some(0.5), true));
        assert_eq!(cut(AlphaMode::AlphaToCoverage), (Some(0.5), true));
    }

    /// A look in a glTF material's paint keeps everything of the look but the colour and
    /// texture; sides and cut-out are the look's or the paint's.
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
        };
        let worn = paint.on(&look);
        let mut expected = look.clone();
        expected.base_color = Color::srgb(0.9, 0.3, 0.2);
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
        let worn = plain.on(&cut_look);
        assert_eq!(worn.base_color_texture, Some(own));
        assert_eq!(worn.alpha_cutoff, Some(0.8));
        assert!(worn.double_sided);
    }
}
