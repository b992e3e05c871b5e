//! Attaching hair to bones: the [`Hair`] component, strand entities, the head collider.

use bevy::math::Affine3A;
use bevy::prelude::*;
use bevy_rapier3d::prelude::Collider;

use super::settings::HairSimSettings;
use super::solver::{Batch, LANES, build_chain};
use crate::asset::{HairAnimation, HairGroom, HeadCollision};

/// Hair on this entity. Put it on a child of a bone (or use [`AttachHair`] to find the bone by
/// name): positions in the groom are relative to this entity, so with an identity [`Transform`]
/// they are in bone space, as exported.
///
/// Once the groom (and animation, if any) are loaded, the plugin spawns one entity per guide
/// strand with [`StrandOf`], [`Strand`] and [`StrandParticles`]; despawning this entity despawns
/// them, and removing this component detaches (despawns) them too.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug)]
#[require(Transform, Visibility, HairSimSettings)]
pub struct Hair {
    /// The guide strands.
    pub groom: Handle<HairGroom>,
    /// Keyframe styles the anchors follow; `None` anchors to the groom's own style.
    pub animation: Option<Handle<HairAnimation>>,
    /// Spheres to collide with; they become a compound rapier [`Collider`] on this entity's
    /// child, so other rapier users see the head too.
    pub collision: Option<Handle<HeadCollision>>,
}

/// Finds the bone named [`AttachHair::bone`] among this entity's descendants (a glTF scene
/// spawns asynchronously) and attaches the hair to it, then removes itself.
#[derive(Component, Clone, Debug)]
pub struct AttachHair {
    /// Name of the bone entity (glTF node name), e.g. `"head"`.
    pub bone: String,
    /// The hair to attach.
    pub hair: Hair,
    /// Its settings.
    pub settings: HairSimSettings,
}

impl AttachHair {
    /// Attach `hair` with default settings to the descendant named `bone`.
    pub fn new(bone: impl Into<String>, hair: Hair) -> Self {
        Self {
            bone: bone.into(),
            hair,
            settings: HairSimSettings::default(),
        }
    }
}

/// A guide strand's hair entity.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[relationship(relationship_target = HairStrands)]
pub struct StrandOf(pub Entity);

/// The strand entities of a hair; despawning the hair despawns them.
#[derive(Component, Debug, Default)]
#[relationship_target(relationship = StrandOf, linked_spawn)]
pub struct HairStrands(Vec<Entity>);

/// Which strand of the groom an entity is, and its collision margin.
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq)]
#[reflect(Component, Debug)]
pub struct Strand {
    /// Index of the strand in the groom.
    pub index: u32,
    /// Collision margin drawn for this strand (metres).
    pub margin: f32,
}

/// Simulated particle positions of a strand, world space, root first; written every frame.
#[derive(Component, Debug, Clone, Default, PartialEq)]
pub struct StrandParticles {
    /// The guide strand's particles (as many as the groom has).
    pub positions: Vec<Vec3>,
    /// The extra structural particles (Selle et al.), for debug drawing; filled only while
    /// [`HairSimControl::write_structural`](super::HairSimControl::write_structural) is set.
    pub structural: Vec<Vec3>,
}

/// The child entity holding a hair's head collider.
#[derive(Component, Debug, Clone, Copy)]
pub struct HeadColliderOf(pub Entity);

/// Solver state of a hair, derived from [`Hair`] and [`HairSimSettings`]; rebuilt when the groom,
/// the animation or the structure offset changes.
#[derive(Component, Default)]
pub struct ComputedHair {
    pub(crate) batches: Vec<Batch>,
    /// `(batch, lane)` of each strand.
    pub(crate) lane_of: Vec<(u32, u8)>,
    pub(crate) groom: AssetId<HairGroom>,
    pub(crate) animation: Option<AssetId<HairAnimation>>,
    pub(crate) offset: f32,
    pub(crate) margin_key: (u64, u32, u32),
    pub(crate) last_bone: Option<Affine3A>,
    pub(crate) accumulator: f32,
    pub(crate) animation_time: f32,
    /// What happened last frame, for the debug panel and tests.
    pub stats: HairStepStats,
}

/// Counters of a hair's simulation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HairStepStats {
    /// Substeps run in the last frame.
    pub substeps: u32,
    /// Frames in which the bone teleported and the hair was carried.
    pub teleports: u32,
    /// Frames skipped because the bone transform was not usable (NaN, zero scale).
    pub invalid_bone_frames: u32,
    /// Strands reset because their state stopped being finite.
    pub strand_resets: u32,
}

impl ComputedHair {
    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.lane_of.len()
    }

    /// Current position of particle `i` of strand `s`.
    pub fn particle(&self, s: usize, i: usize) -> Vec3 {
        let (b, l) = self.lane_of[s];
        self.batches[b as usize].particle(l as usize, i)
    }

    /// Puts every strand back on its styled (base) pose under the hair entity's current
    /// transform `bone`, at rest, as when the strands were built. The clip recorder does this
    /// before its first frame so a clip never depends on when assets finished loading.
    pub fn reset(&mut self, bone: &GlobalTransform) {
        let bone = bone.affine();
        for b in &mut self.batches {
            b.reset(&bone);
        }
        self.last_bone = Some(bone);
        self.accumulator = 0.0;
        self.animation_time = 0.0;
    }

    /// World position of the anchor (the keyframed style the anchor spring pulls toward) of
    /// particle `i` of strand `s`, at last frame's bone pose; `None` before the first step or
    /// out of range. For debug drawing.
    pub fn anchor(&self, s: usize, i: usize) -> Option<Vec3> {
        let bone = self.last_bone?;
        let &(b, l) = self.lane_of.get(s)?;
        let batch = self.batches.get(b as usize)?;
        let k = 2 * i + 1;
        (k < batch.nodes.len()).then(|| bone.transform_point3(batch.anchor(l as usize, k)))
    }
}

/// A strand's margin: a hash of (seed, strand) mapped into `[min, max]`.
pub(crate) fn draw_margin(seed: u64, strand: u32, min: f32, max: f32) -> f32 {
    let mut z = seed ^ (u64::from(strand).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    let u = (z >> 40) as f32 / (1u64 << 24) as f32;
    min + (max - min) * u
}

/// Builds solver batches for a groom (and its keyframes): strands grouped by particle count,
/// [`LANES`] to a batch.
pub(crate) fn build_batches(
    groom: &HairGroom,
    animation: Option<&HairAnimation>,
    offset: f32,
    margins: &[f32],
) -> (Vec<Batch>, Vec<(u32, u8)>) {
    let n = groom.strand_count();
    let mut chains: Vec<Vec<Vec3>> = Vec::with_capacity(n);
    let mut frames = Vec::with_capacity(n);
    for s in 0..n {
        let mut chain = Vec::new();
        frames.push(build_chain(groom.strand(s), offset, None, &mut chain));
        chains.push(chain);
    }
    // Keyframe chains, with the structural particles on the same side as the base's.
    let key_chains: Vec<Vec<Vec<Vec3>>> = animation
        .map(|a| {
            a.keys
                .iter()
                .map(|k| {
                    (0..n)
                        .map(|s| {
                            let mut c = Vec::new();
                            build_chain(k.pose.strand(s), offset, Some(frames[s]), &mut c);
                            c
                        })
                        .collect()
                })
                .collect()
        })
        .unwrap_or_default();
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by_key(|&s| (groom.strand(s as usize).len(), s));
    let mut batches = Vec::new();
    let mut lane_of = vec![(0u32, 0u8); n];
    for group in
        order.chunk_by(|a, b| groom.strand(*a as usize).len() == groom.strand(*b as usize).len())
    {
        for ids in group.chunks(LANES) {
            let b = batches.len() as u32;
            for (l, &s) in ids.iter().enumerate() {
                lane_of[s as usize] = (b, l as u8);
            }
            let chain_refs: Vec<&[Vec3]> = ids.iter().map(|&s| &chains[s as usize][..]).collect();
            let keys: Vec<Vec<&[Vec3]>> = key_chains
                .iter()
                .map(|key| ids.iter().map(|&s| &key[s as usize][..]).collect())
                .collect();
            let m: Vec<f32> = ids.iter().map(|&s| margins[s as usize]).collect();
            batches.push(Batch::new(ids, &chain_refs, &keys, &m));
        }
    }
    (batches, lane_of)
}

/// Attaches [`AttachHair`] requests once their bone exists.
pub(crate) fn attach_hair_to_named_bones(
    mut commands: Commands,
    requests: Query<(Entity, &AttachHair)>,
    children: Query<&Children>,
    names: Query<&Name>,
) {
    for (root, request) in &requests {
        let bone = children
            .iter_descendants(root)
            .find(|e| names.get(*e).is_ok_and(|n| n.as_str() == request.bone));
        if let Some(bone) = bone {
            commands.entity(root).remove::<AttachHair>();
            commands.spawn((
                Name::new(format!("hair on {}", request.bone)),
                request.hair.clone(),
                request.settings.clone(),
                ChildOf(bone),
            ));
        }
    }
}

/// The hairs [`build_hair_strands`] looks at.
type HairBuildQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Hair,
        &'static HairSimSettings,
        &'static GlobalTransform,
        Option<&'static mut ComputedHair>,
        Option<&'static HairStrands>,
    ),
>;

/// Spawns strand entities and solver state once a hair's assets are loaded, and rebuilds them
/// when the groom, the animation or the structure offset changes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn build_hair_strands(
    mut commands: Commands,
    mut hairs: HairBuildQuery,
    grooms: Res<Assets<HairGroom>>,
    animations: Res<Assets<HairAnimation>>,
    collisions: Res<Assets<HeadCollision>>,
    head_colliders: Query<(Entity, &HeadColliderOf)>,
) {
    for (entity, hair, settings, global, computed, strands) in &mut hairs {
        let anim_id = hair.animation.as_ref().map(|h| h.id());
        let offset = settings.structure_offset();
        if let Some(c) = &computed
            && c.groom == hair.groom.id()
            && c.animation == anim_id
            && c.offset == offset
        {
            continue;
        }
        let Some(groom) = grooms.get(&hair.groom) else {
            continue;
        };
        let animation = match &hair.animation {
            Some(h) => match animations.get(h) {
                Some(a) if a.base().same_topology(groom) => Some(a),
                Some(_) => {
                    // Refuse rather than crash (the thesis crashed here): anchor to the groom.
                    warn_once!(
                        "hair animation does not match the groom's strands; anchors follow the \
                         groom's own style instead"
                    );
                    None
                }
                None => continue,
            },
            None => None,
        };
        let (lo, hi) = settings.margins();
        let margins: Vec<f32> = (0..groom.strand_count() as u32)
            .map(|s| draw_margin(settings.margin_seed, s, lo, hi))
            .collect();
        let (mut batches, lane_of) = build_batches(groom, animation, offset, &margins);
        let bone = global.affine();
        let bone_ok = bone.is_finite() && bone.matrix3.determinant().abs() > 1e-12;
        if bone_ok {
            for b in &mut batches {
                b.reset(&bone);
            }
        }
        if let Some(strands) = strands {
            for e in strands.iter() {
                commands.entity(e).despawn();
            }
        }
        for (i, strand) in groom.strands().enumerate() {
            let (b, l) = lane_of[i];
            let batch = &batches[b as usize];
            commands.spawn((
                Name::new(format!("strand {i}")),
                StrandOf(entity),
                Strand {
                    index: i as u32,
                    margin: margins[i],
                },
                StrandParticles {
                    positions: (0..strand.len())
                        .map(|p| batch.particle(l as usize, p))
                        .collect(),
                    structural: Vec::new(),
                },
            ));
        }
        for (e, of) in &head_colliders {
            if of.0 == entity {
                commands.entity(e).despawn();
            }
        }
        if let Some(shape) = hair.collision.as_ref().and_then(|h| collisions.get(h)) {
            let balls = shape
                .spheres
                .iter()
                .map(|s| (s.center, Quat::IDENTITY, Collider::ball(s.radius)))
                .collect();
            commands.spawn((
                Name::new("head collider"),
                Collider::compound(balls),
                HeadColliderOf(entity),
                Transform::default(),
                ChildOf(entity),
            ));
        }
        commands.entity(entity).insert(ComputedHair {
            batches,
            lane_of,
            groom: hair.groom.id(),
            animation: anim_id,
            offset,
            margin_key: margin_key(settings),
            last_bone: bone_ok.then_some(bone),
            ..default()
        });
    }
}

/// What the margins were drawn from; a change redraws them.
pub(crate) fn margin_key(s: &HairSimSettings) -> (u64, u32, u32) {
    let (lo, hi) = s.margins();
    (s.margin_seed, lo.to_bits(), hi.to_bits())
}

/// Removing [`Hair`] detaches it: strands, collider and solver state go.
pub(crate) fn detach_hair(
    remove: On<Remove, Hair>,
    mut commands: Commands,
    strands: Query<&HairStrands>,
    head_colliders: Query<(Entity, &HeadColliderOf)>,
) {
    let hair = remove.entity;
    if let Ok(strands) = strands.get(hair) {
        for e in strands.iter() {
            commands.entity(e).try_despawn();
        }
    }
    for (e, of) in &head_colliders {
        if of.0 == hair {
            commands.entity(e).try_despawn();
        }
    }
    if let Ok(mut entity) = commands.get_entity(hair) {
        entity.try_remove::<ComputedHair>();
    }
}
