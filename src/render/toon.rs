//! [`ToonHairMaterial`]: cartoon shading for strand meshes (thesis 4.3.3-4.3.6, 4.3.8).

use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{MaterialPipeline, MaterialPipelineKey};
use bevy::prelude::*;
use bevy::render::render_resource::{
    AsBindGroup, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError,
};
use bevy::shader::ShaderRef;

use super::linear_color;
use crate::math::finite_or;

/// What indexes the ramp texture's y axis (its x axis is always the light intensity
/// `max(N.L, 0)`, X-Toon style).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum RampMode {
    /// A constant row ([`ToonShading::ramp_row`]): a plain 1D cartoon ramp.
    #[default]
    Constant,
    /// Depth detail: `D = 1 - log(z/zmin) / log(zmax/zmin)`, near strands vivid, far washed out.
    Depth,
    /// Back lighting: `|N.V|^r`.
    BackLight,
    /// Specular ramp: `(N.H)^shininess`, highlights drawn in the texture.
    Specular,
}

/// Which light the toon ramp is lit by.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ToonLighting {
    /// The thesis's model: `N.L` of the first directional light's direction only (its colour,
    /// illuminance and shadows are ignored; no other light counts).
    FirstDirectional,
    /// Every light Bevy gives a PBR material (directional, point and spot lights with their
    /// colour and intensity, ambient and environment light, and the shadows they cast), measured
    /// on a white, rough surface: its brightness indexes the ramp's x axis (full at
    /// [`ToonShading::full_light_lux`]) and its hue tints the hair. Hair in a game scene then
    /// matches the characters next to it. Where almost no light reaches (turned away from
    /// every light, in a shadow, no ambient light) the hair takes the first directional light's
    /// hue: it draws its darkest tone there, not black (black only with no directional light).
    /// Hair always receives shadows here (`NotShadowReceiver` is not read).
    #[default]
    Scene,
}

/// Hatching with a tonal art map (see [`crate::hatching`]).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum HatchingMode {
    /// No hatching.
    #[default]
    None,
    /// Strokes projected on the screen (Lake et al. 2000): looks hand-drawn in a still frame,
    /// but strokes stay put as hair moves.
    Screen,
    /// Strokes on the strand surface (Praun et al. 2001), tones blended, coherent as hair moves.
    Surface,
}

/// The shape of the angel ring's band ([`ToonShading::angel_ring`]).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum AngelRingProfile {
    /// A hard-edged band of even width.
    Even,
    /// Hard-edged, thinning toward the sides of the hair (where it turns away from the view),
    /// as rings are drawn.
    Tapered,
    /// Tapered, with saw teeth along the strands ([`ToonShading::angel_ring_teeth`] apart):
    /// the classic cel-anime ring.
    #[default]
    ZigZag,
    /// Soft edges, fading out from the band's middle.
    Soft,
}

impl AngelRingProfile {
    fn index(self) -> f32 {
        match self {
            Self::Even => 0.0,
            Self::Tapered => 1.0,
            Self::ZigZag => 2.0,
            Self::Soft => 3.0,
        }
    }
}

/// Toon shading for hair: the tunable [`ToonShading`] (reached directly through `Deref`, so
/// `material.base_color` works) and its textures. Every change takes effect live; changing a
/// mode switches to another pipeline variant (shader defs), not a branch in the shader.
#[derive(Asset, AsBindGroup, Reflect, Clone, Debug, Default, Deref, DerefMut)]
#[bind_group_data(ToonHairMaterialKey)]
#[uniform(0, ToonHairUniform)]
#[reflect(Debug)]
pub struct ToonHairMaterial {
    /// Colours, ramp use, depth detail, back light, specular and hatching settings (presets
    /// store this as it is).
    #[deref]
    pub shading: ToonShading,
    /// The ramp: x = light intensity, y = see [`ToonShading::ramp_mode`]. Use a nearest
    /// sampler for hard bands. Default: none (set one from [`crate::render::ToonRamps`]).
    #[texture(1)]
    #[sampler(2)]
    pub ramp: Handle<Image>,
    /// Tonal art map (2D array, layer per tone); required when hatching.
    #[texture(3, dimension = "2d_array")]
    #[sampler(4)]
    pub tonal_art_map: Option<Handle<Image>>,
    /// The specular layer's ramp ([`ToonShading::specular_ramp`]): x = light intensity, y =
    /// `(N.H)^shininess`; `1 - alpha` is where the highlight is drawn. When the layer is on and
    /// this is `None`, the render plugin fills in [`crate::render::ToonRamps::specular`].
    #[texture(5)]
    #[sampler(6)]
    pub specular_ramp_texture: Option<Handle<Image>>,
    /// A colour texture multiplying [`ToonShading::base_color`] (sampled with the mesh's first
    /// UVs; its alpha is read only for [`alpha_cutoff`](Self::alpha_cutoff)): a character's
    /// painted hair (a VRM's hair texture) under the toon ramp, its coloured tips blending from
    /// the painted colour. Default: none.
    #[texture(7)]
    #[sampler(8)]
    pub base_color_texture: Option<Handle<Image>>,
    /// Draw back faces too, lit as the side they show (the normal turned toward the viewer), as
    /// a glTF material with `doubleSided` is drawn: for a character's hair modelled as single
    /// sheets, which otherwise have holes wherever their back faces the camera. The crate's
    /// strand tubes are closed and need no back faces (they would cost fragments and shadow
    /// draws for nothing). Default: `false`.
    pub double_sided: bool,
    /// Cut the hair out where its alpha (the base colour's times the texture's) is below this,
    /// as a glTF material with `alphaMode` `MASK`: hair cards with painted strand tips. The
    /// cut-out parts are left out of the colour, the depth and normal prepasses (so outlines and
    /// the fringe shadow follow the cut) and the shadow maps. Clamped to `[0, 1]`; a NaN is
    /// `0.5`. Under MSAA the colour is cut by alpha to coverage (the share of a pixel's samples
    /// drawn follows the alpha across the cut-off, so cut edges are anti-aliased as a mesh's
    /// edges are); the prepass and shadow maps cut whole pixels. Costs a texture sample per
    /// fragment in the prepass and shadow passes, and turns off the early depth test for this
    /// material. Default: `None` (opaque).
    pub alpha_cutoff: Option<f32>,
}

impl ToonHairMaterial {
    /// The alpha cut-off the shaders use, if the material is cut out: finite, in `[0, 1]`.
    pub fn cutoff(&self) -> Option<f32> {
        self.alpha_cutoff.map(|c| finite_or(c, 0.5).clamp(0.0, 1.0))
    }

    /// The uniform block: the shading's, with the alpha cut-off.
    fn uniform(&self) -> ToonHairUniform {
        let mut uniform = self.shading.uniform();
        uniform.base_lab.w = self.cutoff().unwrap_or(0.0);
        uniform
    }

    /// A material with this shading and `ramp`.
    pub fn new(shading: ToonShading, ramp: Handle<Image>) -> Self {
        Self {
            shading,
            ramp,
            tonal_art_map: None,
            specular_ramp_texture: None,
            base_color_texture: None,
            double_sided: false,
            alpha_cutoff: None,
        }
    }
}

/// The tunable part of a [`ToonHairMaterial`]: everything but its textures.
#[derive(Reflect, Clone, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq)]
pub struct ToonShading {
    /// Hair colour, multiplied by the ramp. Default: orange `srgb(0.95, 0.55, 0.15)`.
    pub base_color: Color,
    /// What indexes the ramp's y axis. Default: [`RampMode::Constant`].
    pub ramp_mode: RampMode,
    /// Ramp row used with [`RampMode::Constant`], 0 (bottom) to 1 (top). Default: `0.5`.
    pub ramp_row: f32,
    /// Depth detail: distance (metres) at which detail is full. Default: `1.0`.
    pub z_min: f32,
    /// Depth detail: detail has faded at `z_min * z_scale`. Default: `6.0`.
    pub z_scale: f32,
    /// Back lighting exponent `r >= 0` in `|N.V|^r`: below 1 widens the lit rim, above 1 narrows
    /// it. Default: `2.0`.
    pub back_light_power: f32,
    /// Adds a rim of [`ToonShading::back_light_color`] (thesis: "mixed in like the specular")
    /// where the hair turns away from the view: full when the light is behind the hair, facing
    /// the viewer, a quarter when it lights the hair from the front, in the light's hue.
    /// Default: `0.0` (off).
    pub back_light_strength: f32,
    /// Rim colour. Default: white.
    pub back_light_color: Color,
    /// How much the rim takes the hair's own colour, 0 to 1: at 0 it is
    /// [`ToonShading::back_light_color`] as given, at 1 that colour times
    /// [`ToonShading::base_color`] (a white or grey `back_light_color` brighter than 1 then gives
    /// a glow in the hair's hue that follows the hair when the game recolours it). Default: `0.0`.
    pub back_light_hair_tint: f32,
    /// Adds Blinn specular `(N.H)^shininess` on top. Default: `0.0` (off).
    pub specular_strength: f32,
    /// Adds the highlight drawn in a specular ramp
    /// ([`ToonHairMaterial::specular_ramp_texture`], indexed by the light and `(N.H)^shininess`)
    /// in [`ToonShading::specular_color`], times this, as a layer of its own on top of whatever
    /// [`ToonShading::ramp_mode`] the main ramp uses: depth detail, the back light rim and drawn
    /// highlights can all be on at once (the thesis added specular and back light on top of the
    /// cartoon shading). 0 turns it off (and its shader variant). Default: `0.0`.
    pub specular_ramp: f32,
    /// Shininess exponent for Blinn and the specular ramps: higher is a smaller highlight.
    /// Default: `40.0`.
    pub shininess: f32,
    /// Specular colour. Default: white.
    pub specular_color: Color,
    /// Hatching mode; hatching also needs [`ToonHairMaterial::tonal_art_map`] (the render plugin
    /// generates one for materials that ask). Default: [`HatchingMode::None`].
    pub hatching: HatchingMode,
    /// Hatching scale (HScale): larger gives bigger strokes. Default: `1.0`.
    pub hatch_scale: f32,
    /// Which light indexes the ramp. Default: [`ToonLighting::Scene`] (every light of the
    /// game's scene, with shadows).
    pub lighting: ToonLighting,
    /// With [`ToonLighting::Scene`]: the illuminance (lux, as Bevy's lights measure it) that
    /// reaches the right end of the ramp; less light walks left along it. Default: `10000.0`
    /// (Bevy's default directional light, full daylight).
    pub full_light_lux: f32,
    /// Angel ring: a highlight band across the whole hair where the strands run across the
    /// half vector (Kajiya-Kay on the strand direction), so it sits at a height that follows
    /// the view and the light, like the ring drawn on anime hair (and Unity Toon Shader's
    /// Angel Ring). Its opacity over the hair colour; 0 turns it off (and its shader variant).
    /// Works best with hair-mass normals (`HairMeshSettings::mass_normals`). Default: `0.0`.
    pub angel_ring: f32,
    /// Ring colour (linear RGB is multiplied by the light's hue). Default: `srgb(1.0, 0.95, 0.8)`.
    pub angel_ring_color: Color,
    /// Band width, 0 (a line) to 1 (everything facing the half vector). Default: `0.25`.
    pub angel_ring_width: f32,
    /// Kajiya-Kay exponent: higher gives a tighter, more even band. Default: `60.0`.
    pub angel_ring_sharpness: f32,
    /// Moves the band along the strands (the tangent leans by this times the normal): positive
    /// toward the roots when lit from above. Default: `0.0`.
    pub angel_ring_shift: f32,
    /// The band's shape. Default: [`AngelRingProfile::ZigZag`].
    pub angel_ring_profile: AngelRingProfile,
    /// Distance between the zig-zag's teeth, metres across the strands. Default: `0.02`.
    pub angel_ring_teeth: f32,
    /// Tips in another colour (dyed or sun-bleached ends, a gradient toward the tips): the hair
    /// colour blends from [`ToonShading::base_color`] toward this along each strand, from
    /// [`ToonShading::tip_start`] to the tip, as far as [`ToonShading::tip_strength`]. Shading,
    /// and a back light in the hair's colour, follow the blended colour. On the crate's strand
    /// meshes the UV's `v` runs from root (0) to tip (1); on a mesh of your own the blend
    /// follows its UVs' `v` (none without UVs). Default: white.
    pub tip_color: Color,
    /// Where along the strand the blend toward [`ToonShading::tip_color`] begins, 0 (root) to 1
    /// (tip); it reaches the full strength at the tip. Default: `0.6`.
    pub tip_start: f32,
    /// How much of [`ToonShading::tip_color`] the tips take, 0 (off) to 1. Default: `0.0`.
    pub tip_strength: f32,
    /// The shadow tones' colour: the ramp's darker tones are multiplied by it as far as they are
    /// dark (not at all in a tone as bright as the lit one, fully at half its brightness or
    /// below; the three-tone ramp's middle tone takes about half), so shadows can shift hue
    /// (orange hair with red-brown or violet shadows, as anime and Unity Toon Shader's shade
    /// colours paint them) while the ramp keeps its bands. It multiplies the hair's own
    /// colour, so it follows a recoloured hair and its tips; a tint darker than white also
    /// darkens the shadows. Channels are clamped to 0-16 (non-finite ones read as 1). Default:
    /// white (shadows are darker hair colour).
    pub shade_color: Color,
    /// MToon's parametric rim light ([`VrmRim`](crate::asset::VrmRim)): its colour times
    /// [`VrmRim::strength`](crate::asset::VrmRim::strength) added where the hair turns away
    /// from the viewer, times what the hair's shading draws a white strand in there (the ramp's
    /// tone, the shade colour and the light's hue) as far as its lighting mix says. Set by
    /// [`ToonHairMeshes`](super::ToonHairMeshes) for a VRM's MToon hair with a rim (unless the
    /// look has one). Unlike the back light it does not depend on where the light is. Default:
    /// `None`.
    #[reflect(default)]
    pub mtoon_rim: Option<crate::asset::VrmRim>,
}

impl Default for ToonShading {
    fn default() -> Self {
        Self {
            base_color: Color::srgb(0.95, 0.55, 0.15),
            ramp_mode: RampMode::Constant,
            ramp_row: 0.5,
            z_min: 1.0,
            z_scale: 6.0,
            back_light_power: 2.0,
            back_light_strength: 0.0,
            back_light_color: Color::WHITE,
            back_light_hair_tint: 0.0,
            specular_strength: 0.0,
            specular_ramp: 0.0,
            shininess: 40.0,
            specular_color: Color::WHITE,
            hatching: HatchingMode::None,
            hatch_scale: 1.0,
            lighting: ToonLighting::Scene,
            full_light_lux: 10_000.0,
            angel_ring: 0.0,
            angel_ring_color: Color::srgb(1.0, 0.95, 0.8),
            angel_ring_width: 0.25,
            angel_ring_sharpness: 60.0,
            angel_ring_shift: 0.0,
            angel_ring_profile: AngelRingProfile::ZigZag,
            angel_ring_teeth: 0.02,
            tip_color: Color::WHITE,
            tip_start: 0.6,
            tip_strength: 0.0,
            shade_color: Color::WHITE,
            mtoon_rim: None,
        }
    }
}

/// The uniform block of [`ToonHairMaterial`] (see `toon.wesl`).
#[derive(Clone, Default, ShaderType)]
pub struct ToonHairUniform {
    base_color: Vec4,
    specular_color: Vec4,
    back_light_color: Vec4,
    params: Vec4,
    params2: Vec4,
    params3: Vec4,
    angel_ring_color: Vec4,
    angel_ring: Vec4,
    tip_lab: Vec4,
    base_lab: Vec4,
    shade_color: Vec4,
    rim: Vec4,
    rim_shape: Vec4,
}

impl bevy::render::render_resource::AsBindGroupShaderType<ToonHairUniform> for ToonHairMaterial {
    fn as_bind_group_shader_type(
        &self,
        _images: &bevy::render::render_asset::RenderAssets<bevy::render::texture::GpuImage>,
    ) -> ToonHairUniform {
        self.uniform()
    }
}

/// A linear RGB colour (the `xyz` of `c`) in Oklab, `(L, a, b)`: the tip blend's two ends,
/// converted once here rather than in every fragment.
fn oklab(c: Vec4) -> Vec3 {
    let lab = bevy::color::Oklaba::from(LinearRgba::rgb(c.x, c.y, c.z));
    Vec3::new(lab.lightness, lab.a, lab.b)
}

impl ToonShading {
    /// The uniform block the shader reads: every value finite and within the range the shader
    /// expects.
    fn uniform(&self) -> ToonHairUniform {
        let (rim, rim_shape) = super::gltf_paint::rim_uniform(self.mtoon_rim.as_ref());
        ToonHairUniform {
            base_color: linear_color(self.base_color, 0.0, 1e4)
                .truncate()
                .extend(finite_or(self.base_color.alpha(), 1.0).clamp(0.0, 1.0)),
            specular_color: linear_color(self.specular_color, 0.0, 1e4),
            back_light_color: linear_color(self.back_light_color, 0.0, 1e4)
                .truncate()
                .extend(finite_or(self.back_light_hair_tint, 0.0).clamp(0.0, 1.0)),
            params: Vec4::new(
                finite_or(self.z_min, 1.0).max(1e-3),
                finite_or(self.z_scale, 6.0).max(1.0001),
                finite_or(self.back_light_power, 2.0).max(0.0),
                finite_or(self.shininess, 40.0).clamp(1.0, 4096.0),
            ),
            params2: Vec4::new(
                finite_or(self.specular_strength, 0.0).max(0.0),
                finite_or(self.back_light_strength, 0.0).max(0.0),
                finite_or(self.hatch_scale, 1.0).max(1e-3),
                finite_or(self.ramp_row, 0.5).clamp(0.0, 1.0),
            ),
            params3: Vec4::new(
                finite_or(self.full_light_lux, 10_000.0).max(1e-3),
                finite_or(self.angel_ring_teeth, 0.02).max(1e-4),
                self.angel_ring_profile.index(),
                finite_or(self.specular_ramp, 0.0).clamp(0.0, 16.0),
            ),
            angel_ring_color: linear_color(self.angel_ring_color, 0.0, 1e4)
                .truncate()
                .extend(finite_or(self.angel_ring, 0.0).clamp(0.0, 1.0)),
            angel_ring: Vec4::new(
                finite_or(self.angel_ring_width, 0.25).clamp(0.0, 1.0),
                finite_or(self.angel_ring_sharpness, 60.0).clamp(1.0, 4096.0),
                finite_or(self.angel_ring_shift, 0.0).clamp(-4.0, 4.0),
                finite_or(self.tip_start, 0.6).clamp(0.0, 0.999),
            ),
            tip_lab: oklab(linear_color(self.tip_color, 0.0, 1e4))
                .extend(finite_or(self.tip_strength, 0.0).clamp(0.0, 1.0)),
            base_lab: oklab(linear_color(self.base_color, 0.0, 1e4)).extend(0.0),
            shade_color: linear_color(self.shade_color, 1.0, 16.0),
            rim,
            rim_shape,
        }
    }
}

/// Pipeline variant of a [`ToonHairMaterial`]: which shader defs it compiles with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ToonHairMaterialKey {
    ramp_mode: RampMode,
    blinn: bool,
    back_light: bool,
    hatching: HatchingMode,
    scene_lights: bool,
    angel_ring: bool,
    specular_layer: bool,
    double_sided: bool,
    base_texture: bool,
    alpha_mask: bool,
}

impl From<&ToonHairMaterial> for ToonHairMaterialKey {
    fn from(m: &ToonHairMaterial) -> Self {
        Self {
            ramp_mode: m.ramp_mode,
            blinn: m.specular_strength > 0.0,
            back_light: m.back_light_strength > 0.0,
            // Without a map there is nothing to hatch with.
            hatching: if m.tonal_art_map.is_some() {
                m.hatching
            } else {
                HatchingMode::None
            },
            scene_lights: m.lighting == ToonLighting::Scene,
            angel_ring: m.angel_ring > 0.0,
            // Without a ramp there is nothing to draw the highlight from.
            specular_layer: m.specular_ramp > 0.0 && m.specular_ramp_texture.is_some(),
            double_sided: m.double_sided,
            base_texture: m.base_color_texture.is_some(),
            alpha_mask: m.alpha_cutoff.is_some(),
        }
    }
}

impl ToonHairMaterialKey {
    /// The shader defs of this variant.
    pub fn shader_defs(&self) -> Vec<&'static str> {
        let mut defs = Vec::new();
        match self.ramp_mode {
            RampMode::Constant => {}
            RampMode::Depth => defs.push("RAMP_DEPTH"),
            RampMode::BackLight => defs.push("RAMP_BACK_LIGHT"),
            RampMode::Specular => defs.push("RAMP_SPECULAR"),
        }
        if self.blinn {
            defs.push("BLINN_SPECULAR");
        }
        if self.back_light {
            defs.push("BACK_LIGHT");
        }
        match self.hatching {
            HatchingMode::None => {}
            HatchingMode::Screen => defs.extend(["HATCHING", "HATCH_SCREEN"]),
            HatchingMode::Surface => defs.push("HATCHING"),
        }
        if self.scene_lights {
            defs.push("SCENE_LIGHTS");
        }
        if self.angel_ring {
            defs.push("ANGEL_RING");
        }
        if self.specular_layer {
            defs.push("SPECULAR_LAYER");
        }
        if self.double_sided {
            defs.push("DOUBLE_SIDED");
        }
        if self.base_texture {
            defs.push("BASE_COLOR_TEXTURE");
        }
        if self.alpha_mask {
            defs.push("ALPHA_MASK");
        }
        defs
    }

    /// Every variant, for validation.
    pub fn all() -> Vec<Self> {
        let mut v = Vec::new();
        for ramp_mode in [
            RampMode::Constant,
            RampMode::Depth,
            RampMode::BackLight,
            RampMode::Specular,
        ] {
            for hatching in [
                HatchingMode::None,
                HatchingMode::Screen,
                HatchingMode::Surface,
            ] {
                for blinn in [false, true] {
                    for back_light in [false, true] {
                        for scene_lights in [false, true] {
                            for angel_ring in [false, true] {
                                for specular_layer in [false, true] {
                                    // A cut-out with and without paint, single- and
                                    // double-sided.
                                    for (double_sided, base_texture, alpha_mask) in [
                                        (false, false, false),
                                        (true, false, false),
                                        (false, true, false),
                                        (true, true, false),
                                        (false, false, true),
                                        (true, true, true),
                                    ] {
                                        v.push(Self {
                                            ramp_mode,
                                            blinn,
                                            back_light,
                                            hatching,
                                            scene_lights,
                                            angel_ring,
                                            specular_layer,
                                            double_sided,
                                            base_texture,
                                            alpha_mask,
                                        });
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        v
    }
}

impl Material for ToonHairMaterial {
    fn fragment_shader() -> ShaderRef {
        ShaderRef::Path(
            bevy::asset::AssetPath::from_path_buf(bevy::asset::embedded_path!("toon.wesl"))
                .with_source("embedded"),
        )
    }

    /// The hair's prepass marks hair in the normal target's alpha, for the
    /// [`OutlineSource::Mass`](crate::render::OutlineSource::Mass) outline.
    fn prepass_fragment_shader() -> ShaderRef {
        ShaderRef::Path(
            bevy::asset::AssetPath::from_path_buf(bevy::asset::embedded_path!("hair_prepass.wesl"))
                .with_source("embedded"),
        )
    }

    /// Cut out ([`AlphaMode::Mask`]) with an [`alpha_cutoff`](Self::alpha_cutoff): drawn in
    /// the alpha-mask phase, its prepass and shadow fragments run to discard.
    fn alpha_mode(&self) -> AlphaMode {
        match self.cutoff() {
            Some(c) => AlphaMode::Mask(c),
            None => AlphaMode::Opaque,
        }
    }

    fn specialize(
        _pipeline: &MaterialPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        _layout: &MeshVertexBufferLayoutRef,
        key: MaterialPipelineKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        // Back faces are culled in every pass: the main pass's default, and the prepass and
        // shadow passes would otherwise draw them (Bevy leaves culling there to the material),
        // shading each tube's hidden half in the prepass and casting it into every cascade.
        // A double-sided material (hair modelled as sheets) draws them everywhere.
        descriptor.primitive.cull_mode = if key.bind_group_data.double_sided {
            None
        } else {
            Some(bevy::render::render_resource::Face::Back)
        };
        // A cut-out's main pass under MSAA cuts by alpha to coverage: its cut edges are
        // anti-aliased as a mesh's edges are. Its prepass and shadow passes (Bevy's prepass
        // pipeline, which tells its shaders so with `PREPASS_PIPELINE`) still discard at the
        // cut-off: the normal target's alpha is the hair mask.
        let prepass = descriptor
            .vertex
            .shader_defs
            .contains(&"PREPASS_PIPELINE".into());
        let coverage =
            key.bind_group_data.alpha_mask && descriptor.multisample.count > 1 && !prepass;
        descriptor.multisample.alpha_to_coverage_enabled |= coverage;
        if let Some(fragment) = descriptor.fragment.as_mut() {
            for def in key.bind_group_data.shader_defs() {
                fragment.shader_defs.push(def.into());
            }
            if coverage {
                fragment.shader_defs.push("CUT_COVERAGE".into());
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a preset or a panel can hand the shader, hostile: the uniform is finite.
    #[test]
    fn hostile_shading_reaches_the_shader_finite() {
        let bad = Color::linear_rgba(f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::NAN);
        let shading = ToonShading {
            base_color: bad,
            ramp_row: f32::NAN,
            z_min: f32::NAN,
            z_scale: f32::INFINITY,
            back_light_power: f32::NAN,
            back_light_strength: f32::INFINITY,
            back_light_color: bad,
            back_light_hair_tint: f32::NAN,
            specular_strength: f32::NAN,
            specular_ramp: f32::INFINITY,
            shininess: f32::NAN,
            specular_color: bad,
            hatch_scale: f32::NEG_INFINITY,
            full_light_lux: f32::NAN,
            angel_ring: f32::NAN,
            angel_ring_color: bad,
            angel_ring_width: f32::INFINITY,
            angel_ring_sharpness: f32::NAN,
            angel_ring_shift: f32::NEG_INFINITY,
            angel_ring_teeth: f32::NAN,
            tip_color: bad,
            tip_start: f32::NAN,
            tip_strength: f32::INFINITY,
            shade_color: bad,
            ..default()
        };
        let u = shading.uniform();
        let all = [
            u.base_color,
            u.specular_color,
            u.back_light_color,
            u.params,
            u.params2,
            u.params3,
            u.angel_ring_color,
            u.angel_ring,
            u.tip_lab,
            u.base_lab,
            u.shade_color,
        ];
        for (i, v) in all.iter().enumerate() {
            assert!(v.is_finite(), "uniform vector {i}: {v}");
        }
        // The colours' non-finite channels read as their default, alpha opaque; finite ones
        // out of range are clamped.
        assert_eq!(u.base_color, Vec4::new(0.0, 0.0, 0.0, 1.0));
        assert_eq!(u.shade_color.truncate(), Vec3::ONE);
        let far = ToonShading {
            base_color: Color::linear_rgba(2e4, -1.0, 0.5, 3.0),
            shade_color: Color::linear_rgb(20.0, -1.0, 0.5),
            ..default()
        }
        .uniform();
        assert_eq!(far.base_color, Vec4::new(1e4, 0.0, 0.5, 1.0));
        assert_eq!(far.shade_color.truncate(), Vec3::new(16.0, 0.0, 0.5));
        // The defaults go through unchanged.
        let d = ToonShading::default().uniform();
        assert_eq!(
            d.base_color,
            ToonShading::default().base_color.to_linear().to_vec4()
        );
        assert_eq!(d.shade_color, Vec4::ONE);
        // The tip blend's ends in Oklab: white is lightness 1 with no hue.
        assert!(
            d.tip_lab.truncate().distance(Vec3::X) < 1e-3,
            "{}",
            d.tip_lab
        );
        assert!(
            d.base_lab.x > 0.5 && d.base_lab.y > 0.05,
            "orange: {}",
            d.base_lab
        );
    }

    /// A cut-out material is drawn masked at its cut-off, which reaches the shaders clamped and
    /// finite, with the def that makes them discard; without one it is opaque.
    #[test]
    fn a_cut_out_material_masks_at_its_cutoff() {
        let opaque = ToonHairMaterial::default();
        assert_eq!(opaque.alpha_mode(), AlphaMode::Opaque);
        assert_eq!(opaque.uniform().base_lab.w, 0.0);
        assert!(
            !ToonHairMaterialKey::from(&opaque)
                .shader_defs()
                .contains(&"ALPHA_MASK")
        );
        for (given, used) in [(0.3, 0.3), (f32::NAN, 0.5), (-2.0, 0.0), (7.0, 1.0)] {
            let cut = ToonHairMaterial {
                alpha_cutoff: Some(given),
                ..default()
            };
            assert_eq!(cut.alpha_mode(), AlphaMode::Mask(used), "cut-off {given}");
            assert_eq!(cut.uniform().base_lab.w, used, "cut-off {given}");
            // The Oklab colour beside it is the shading's.
            assert_eq!(
                cut.uniform().base_lab.truncate(),
                opaque.uniform().base_lab.truncate()
            );
            assert!(
                ToonHairMaterialKey::from(&cut)
                    .shader_defs()
                    .contains(&"ALPHA_MASK")
            );
        }
    }
}
