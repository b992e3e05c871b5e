//! Attaching hair to bones: the [`Hair`] component, strand entities, the head collider.

use bevy::math::Affine3A;
use bevy::prelude::*;

use super::attach_work::AttachWork;

use bevy::asset::UntypedAssetId;
use bevy::transform::helper::TransformHelper;

use super::bone::BoneSearch;
use super::collider::HairCollider;
use super::events::{
    BoneMismatch, BoneScaleMismatch, HairAnimationMismatch, HairAssetFailed, HairAssetKind,
    HairReady, HairRebuilt, RebuildReason,
};
use super::settings::HairSimSettings;
use super::solver::{Batch, LANES, PINNED, build_chain};
use crate::asset::{HairAnimation, HairGroom, HeadCollision};

/// Hair on this entity. Hang the entity on a bone with [`AttachToBone`](super::AttachToBone)
/// (or make it a child of the bone yourself): positions in the groom are relative to this
/// entity, so with an identity [`Transform`] they are in bone space, as exported.
///
/// Once every asset given here has loaded (in any order; a failed animation or collision file
/// is reported and left out, a failed groom is reported and builds nothing), the plugin spawns one
/// entity per guide strand with [`StrandOf`], [`Strand`] and [`StrandParticles`], in the styled
/// pose on the bone, and triggers [`HairReady`](super::HairReady). Reloading any of the files
/// rebuilds the hair. Despawning this entity despawns the strands; removing this component
/// detaches (despawns) them.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug)]
#[require(Transform, Visibility, HairSimSettings, HairStatus)]
pub struct Hair {
    /// The guide strands.
    pub groom: Handle<HairGroom>,
    /// Keyframe styles the anchors follow; `None` anchors to the groom's own style.
    pub animation: Option<Handle<HairAnimation>>,
    /// Spheres to collide with; they become a [`HairCollider`] on this entity's child (and,
    /// with the `rapier` or `avian` feature, a compound collider of that engine there, so its
    /// other users see the head too).
    pub collision: Option<Handle<HeadCollision>>,
}

/// A guide strand's hair entity.
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
#[relationship(relationship_target = HairStrands)]
pub struct StrandOf(pub Entity);

/// The strand entities of a hair; despawning the hair despawns them.
#[derive(Component, Reflect, Debug, Default)]
#[reflect(Component, Debug, Default)]
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
#[derive(Component, Reflect, Debug, Clone, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct StrandParticles {
    /// The guide strand's particles (as many as the groom has).
    pub positions: Vec<Vec3>,
    /// The extra structural particles (Selle et al.), for debug drawing; filled only while
    /// [`HairSimControl::write_structural`](super::HairSimControl::write_structural) is set.
    pub structural: Vec<Vec3>,
}

/// The child entity holding a hair's head collider.
#[derive(Component, Reflect, Debug, Clone, Copy)]
#[reflect(Component, Debug)]
pub struct HeadColliderOf(pub Entity);

/// Solver state of a hair, derived from [`Hair`] and [`HairSimSettings`]; rebuilt when the groom,
/// the animation or the structure offset changes. Reflected for inspectors: the counters, the
/// size and the clocks (the solver's batches are not).
#[derive(Component, Reflect, Default)]
#[reflect(Component, Default, from_reflect = false)]
pub struct ComputedHair {
    #[reflect(ignore)]
    pub(crate) batches: Vec<Batch>,
    /// `(batch, lane)` of each strand.
    #[reflect(ignore)]
    pub(crate) lane_of: Vec<(u32, u8)>,
    #[reflect(ignore)]
    pub(crate) groom: AssetId<HairGroom>,
    #[reflect(ignore)]
    pub(crate) animation: Option<AssetId<HairAnimation>>,
    #[reflect(ignore)]
    pub(crate) collision: Option<AssetId<HeadCollision>>,
    pub(crate) offset: f32,
    #[reflect(ignore)]
    pub(crate) margin_key: (u64, u32, u32),
    /// The bone's scale the groom was built at (see [`split_bone`]).
    pub(crate) scale: Vec3,
    /// The bone's scale over its scale at the first build: margins, gravity, teleport distance
    /// and tube radius are multiplied by it, so a character scaled at run time keeps its hair
    /// in proportion.
    pub(crate) size: f32,
    /// Last frame's bone pose without its scale.
    pub(crate) last_bone: Option<Affine3A>,
    /// Last frame's pose of the inertia frame ([`HairInertiaFrame`](super::HairInertiaFrame)),
    /// without its scale.
    pub(crate) last_frame: Option<Affine3A>,
    /// The rest shape's bounding box in the bone's rigid space (see [`ComputedHair::rest_bounds`]).
    pub(crate) rest_bounds: Option<(Vec3, Vec3)>,
    /// The longest strand's rest length, metres: how far from its root a particle can swing.
    pub(crate) longest: f32,
    pub(crate) accumulator: f32,
    pub(crate) animation_time: f32,
    /// Substeps simulated since the hair was built (the signed volume runs on every other one).
    pub(crate) substeps_done: u64,
    /// Simulated time since the hair was built, seconds: the wind's clock (the substep length
    /// changes while the hair is culled).
    pub(crate) time_done: f64,
    /// The hair–hair volume pass's buffers.
    #[reflect(ignore)]
    pub(crate) volume: super::VolumeScratch,
    /// The step's per-frame buffers.
    #[reflect(ignore)]
    pub(crate) scratch: super::scratch::StepScratch,
    /// A bone-chain hair's particle box as this frame's step left them, measured while the
    /// batches were in the stepping thread's cache; `None` when the step did not measure it
    /// (no substep this frame, another kind of hair, a volume pass after the step).
    #[reflect(ignore)]
    pub(crate) particle_box: Option<super::chain_lanes::ParticleBox>,
    /// This frame's step wrote the hair's strands' particles itself, from the thread that
    /// stepped it; otherwise the pass after the step writes them.
    #[reflect(ignore)]
    pub(crate) strands_written: bool,
    /// What happened last frame, for the debug panel and tests.
    pub stats: HairStepStats,
}

/// Counters of a hair's simulation.
#[derive(Reflect, Debug, Clone, Copy, Default, PartialEq)]
#[reflect(Debug, Default, PartialEq)]
pub struct HairStepStats {
    /// Substeps run in the last frame.
    pub substeps: u32,
    /// Frames in which the bone teleported and the hair was carried.
    pub teleports: u32,
    /// Frames skipped because the bone transform was not usable (NaN, zero scale).
    pub invalid_bone_frames: u32,
    /// Strands reset because their state stopped being finite.
    pub strand_resets: u32,
    /// Pairs of particles of different strands the hair–hair volume pushed apart last frame.
    pub volume_pairs: u32,
    /// Particles the hair–hair volume spread out of crowded hair by its density last frame.
    pub volume_spread: u32,
    /// Collider shapes tested against this hair last frame, after the broad phase (shapes whose
    /// bounds cannot meet the hair are not counted).
    pub colliders: u32,
}

impl ComputedHair {
    /// How much larger the character is than when the hair was first built (1 until it is
    /// scaled at run time). Sizes in the settings (margins, gravity, teleport distance, tube
    /// radius) are multiplied by it.
    pub fn size(&self) -> f32 {
        self.size
    }

    /// The bounding box `(min, max)` of the strands' rest shape (every chain node of the
    /// styled pose) in the bone's space without its scale, in metres: the groom as it sits on
    /// the bone. `None` for a hair without strands.
    pub fn rest_bounds(&self) -> Option<(Vec3, Vec3)> {
        self.rest_bounds
    }

    /// Last frame's bone pose without its scale (rotation and translation), the space of
    /// [`ComputedHair::rest_bounds`]; `None` before the first step.
    pub fn bone_pose(&self) -> Option<Affine3A> {
        self.last_bone
    }

    /// The bone's world scale the hair was built at.
    pub fn bone_scale(&self) -> Vec3 {
        self.scale
    }

    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.lane_of.len()
    }

    /// Current position of particle `i` of strand `s`.
    pub fn particle(&self, s: usize, i: usize) -> Vec3 {
        let (b, l) = self.lane_of[s];
        self.batches[b as usize].particle(l as usize, i)
    }

    /// How many particles strand `s` has (0 when there is no such strand).
    pub(crate) fn particle_count(&self, s: usize) -> usize {
        self.lane_of
            .get(s)
            .and_then(|&(b, _)| self.batches.get(b as usize))
            .map_or(0, |b| b.nodes.len() / 2)
    }

    /// Moves particle `i` of strand `s` to `p` (a limit that cut its step short).
    pub(crate) fn set_particle(&mut self, s: usize, i: usize, p: Vec3) {
        if let Some(&(b, l)) = self.lane_of.get(s) {
            self.batches[b as usize].set_particle(l as usize, i, p);
        }
    }

    /// [`Batch::move_particle`] for particle `i` of strand `s`.
    pub(crate) fn move_particle(&mut self, s: usize, i: usize, p: Vec3) {
        if let Some(&(b, l)) = self.lane_of.get(s) {
            self.batches[b as usize].move_particle(l as usize, i, p);
        }
    }

    /// Puts every strand back on its styled (base) pose under the hair entity's current
    /// transform `bone`, at rest, as when the strands were built. The clip recorder does this
    /// before its first frame so a clip never depends on when assets finished loading.
    pub fn reset(&mut self, bone: &GlobalTransform) {
        let (bone, _) = split_bone(&bone.affine());
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

/// Splits a bone's world transform into its rigid part (rotation and translation) and its scale.
///
/// The groom is in the bone's own space, so on a scaled rig (Mixamo's armature carries 0.01) its
/// numbers are not metres. The solver works in world metres: the groom is multiplied by the
/// bone's scale once, when the strands are built (so rest lengths, anchors and keyframes are in
/// metres), and moved every frame by the rigid part only. Margins, radii and gravity are world
/// metres whatever the scale. A mirrored bone gives a negative scale on one axis, which mirrors
/// the groom. Shear, which no rig exports, is dropped.
pub(crate) fn split_bone(bone: &Affine3A) -> (Affine3A, Vec3) {
    let (scale, rotation, translation) = bone.to_scale_rotation_translation();
    (
        Affine3A::from_rotation_translation(rotation, translation),
        scale,
    )
}

/// The scale [`split_bone`] takes out of `bone`, without the rotation (a built hair's check,
/// every frame).
pub(crate) fn bone_scale(bone: &Affine3A) -> Vec3 {
    let m = &bone.matrix3;
    // As `Affine3A::to_scale_rotation_translation` writes it: the same bits.
    Vec3::new(
        m.x_axis.length() * m.determinant().signum(),
        m.y_axis.length(),
        m.z_axis.length(),
    )
}

/// Whether the bone's scale moved far enough from `built` (relative 1e-3) to rebuild the hair.
pub(crate) fn scale_changed(built: Vec3, now: Vec3) -> bool {
    let tolerance = 1e-3 * built.abs().max_element().max(1e-12);
    (built - now).abs().max_element() > tolerance
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
/// The groom and keyframes are multiplied by `scale` (the bone's, see [`split_bone`]) first.
pub(crate) fn build_batches(
    groom: &HairGroom,
    animation: Option<&HairAnimation>,
    offset: f32,
    margins: &[f32],
    scale: Vec3,
) -> (Vec<Batch>, Vec<(u32, u8)>) {
    let n = groom.strand_count();
    let mut chains: Vec<Vec<Vec3>> = Vec::with_capacity(n);
    let mut frames = Vec::with_capacity(n);
    let scale_strand =
        |strand: &[Vec3]| -> Vec<Vec3> { strand.iter().map(|p| *p * scale).collect() };
    for s in 0..n {
        let mut chain = Vec::new();
        let points = scale_strand(groom.strand(s));
        frames.push(build_chain(&points, offset, None, &mut chain));
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
                            let points = scale_strand(k.pose.strand(s));
                            build_chain(&points, offset, Some(frames[s]), &mut c);
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

/// Per hair: what has been reported and whether a reload is pending. Derived; inserted by the
/// plugin.
#[derive(Component, Reflect, Debug, Default)]
#[reflect(Component, Debug, Default)]
pub struct HairStatus {
    /// Failures already reported: `(what, asset)`, so each is logged and triggered once.
    #[reflect(ignore)]
    reported: Vec<(Report, UntypedAssetId)>,
    /// The last failed reload reported for each asset, and its error: Bevy tries a failed
    /// reload twice (typed, then untyped), and one broken save is reported once.
    #[reflect(ignore)]
    pub(crate) failed_reloads: Vec<(UntypedAssetId, String)>,
    /// A file of this hair was reloaded: rebuild.
    pub(crate) reloaded: bool,
    /// How many times the strands were built.
    pub builds: u32,
    /// The bone's (mean) scale at the first build: the size the hair was made for.
    pub(crate) first_scale: Option<f32>,
}

impl HairStatus {
    /// Records `(what, id)`; `true` the first time.
    pub(super) fn first_report(&mut self, what: Report, id: UntypedAssetId) -> bool {
        if self.reported.contains(&(what, id)) {
            return false;
        }
        self.reported.push((what, id));
        true
    }

    /// Forgets failures of `id` (it was reloaded).
    pub(crate) fn forget(&mut self, id: UntypedAssetId) {
        self.allow_report(id);
        self.failed_reloads.retain(|(r, _)| *r != id);
    }

    /// Lets the next failure of `id` be reported again.
    pub(crate) fn allow_report(&mut self, id: UntypedAssetId) {
        self.reported.retain(|(_, r)| *r != id);
    }

    /// Records a failed reload of `id`; `false` when it repeats the last one reported for it.
    pub(crate) fn new_failed_reload(&mut self, id: UntypedAssetId, error: &str) -> bool {
        match self.failed_reloads.iter_mut().find(|(r, _)| *r == id) {
            Some((_, last)) if last == error => false,
            Some((_, last)) => {
                *last = error.to_owned();
                true
            }
            None => {
                self.failed_reloads.push((id, error.to_owned()));
                true
            }
        }
    }
}

/// What a hair reports once per asset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Report {
    /// The asset failed to load.
    Failed(HairAssetKind),
    /// The animation's keyframes do not match the groom.
    AnimationMismatch,
    /// The files were exported for another bone.
    BoneMismatch,
    /// The groom was authored on a bone of another scale.
    BoneScale,
}

/// The hairs [`build_hair_strands`] looks at.
type HairBuildQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Hair,
        &'static HairSimSettings,
        &'static mut GlobalTransform,
        Option<&'static mut ComputedHair>,
        Option<&'static HairStrands>,
        &'static mut HairStatus,
        Option<&'static BoneSearch>,
    ),
>;

/// The assets a hair build reads.
#[derive(bevy::ecs::system::SystemParam)]
pub(crate) struct HairAssets<'w> {
    pub(super) grooms: Res<'w, Assets<HairGroom>>,
    pub(super) animations: Res<'w, Assets<HairAnimation>>,
    pub(super) collisions: Res<'w, Assets<HeadCollision>>,
    server: Res<'w, AssetServer>,
}

impl HairAssets<'_> {
    /// The load error of `id`, if its load failed.
    fn failure(&self, id: impl Into<UntypedAssetId>) -> Option<String> {
        match self.server.load_state(id.into()) {
            bevy::asset::LoadState::Failed(e) => Some(load_failure(&e)),
            _ => None,
        }
    }

    pub(super) fn path(&self, id: impl Into<UntypedAssetId>) -> String {
        self.server
            .get_path(id.into())
            .map(|p| p.to_string())
            .unwrap_or_default()
    }
}

/// An optional asset of a hair: `Some(Some(asset))` when loaded, `Some(None)` when there is none
/// or it failed (`failed` reports it and returns `Some`), `None` while it is still loading.
fn optional<'a, A: Asset>(
    handle: &Option<Handle<A>>,
    store: &'a Assets<A>,
    failed: impl FnOnce(UntypedAssetId) -> Option<()>,
) -> Option<Option<&'a A>> {
    let Some(handle) = handle else {
        return Some(None);
    };
    match store.get(handle) {
        Some(asset) => Some(Some(asset)),
        None => failed(handle.id().untyped()).map(|()| None),
    }
}

/// A failed load in words, without the backtrace Bevy's loader errors carry. A hair file's error
/// is taken as the loader returned it, so the backtrace is never resolved: resolving one reads
/// the program's debug information (tens of megabytes, kept for the rest of the process).
pub(crate) fn load_failure(error: &bevy::asset::AssetLoadError) -> String {
    if let bevy::asset::AssetLoadError::AssetLoaderError(e) = error
        && let Some(hair) = e.error().downcast_ref::<crate::asset::HairAssetError>()
    {
        return format!("Failed to load asset '{}': {hair}", e.path());
    }
    without_backtrace(&error.to_string())
}

/// The message of a load error without the backtrace Bevy's errors may carry on their later
/// lines (indented frames, then a `note:` about them).
pub(super) fn without_backtrace(error: &str) -> String {
    error
        .lines()
        .take_while(|l| !l.starts_with(char::is_whitespace) && !l.starts_with("note: "))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Reports a failed asset of `hair` once: an error log line and a [`HairAssetFailed`] event.
#[expect(
    clippy::too_many_arguments,
    reason = "the hair's commands, status and assets, and what failed of which asset"
)]
pub(super) fn report_failure(
    commands: &mut Commands,
    status: &mut HairStatus,
    assets: &HairAssets,
    hair: Entity,
    kind: HairAssetKind,
    id: UntypedAssetId,
    error: String,
    kept_last_good: bool,
) {
    if !status.first_report(Report::Failed(kind), id) {
        return;
    }
    let path = assets.path(id);
    let consequence = match (kind, kept_last_good) {
        (_, true) => "the hair keeps the last version that loaded; save the file again to retry",
        (HairAssetKind::Groom, false) => "no hair is built",
        (HairAssetKind::Animation, false) => "the hair anchors to the groom's own style",
        (HairAssetKind::Collision, false) => "the hair is built without a head collider",
        (HairAssetKind::Character, false) => "the hair stays detached",
    };
    error!("hair {hair}: {kind:?} {path:?} failed to load ({consequence}): {error}");
    commands.trigger(HairAssetFailed {
        entity: hair,
        asset: kind,
        path,
        error,
        kept_last_good,
    });
}

/// What [`build_hair_strands`] has to do for a hair whose bone is `full`: `None` nothing (built
/// and up to date), `Some(None)` its first build, `Some(Some(reason))` a rebuild.
pub(crate) fn build_wanted(
    (hair, settings): (&Hair, &HairSimSettings),
    computed: Option<&ComputedHair>,
    status: &HairStatus,
    full: &Affine3A,
) -> Option<Option<RebuildReason>> {
    let Some(c) = computed else {
        return Some(None);
    };
    let reason = if status.reloaded {
        RebuildReason::Reloaded
    } else if c.groom != hair.groom.id()
        || c.animation != hair.animation.as_ref().map(Handle::id)
        || c.collision != hair.collision.as_ref().map(Handle::id)
    {
        RebuildReason::Assets
    } else if c.offset != settings.structure_offset() {
        RebuildReason::Settings
    } else if crate::math::usable_frame(full) && scale_changed(c.scale, bone_scale(full)) {
        RebuildReason::Scale
    } else {
        return None;
    };
    Some(Some(reason))
}

/// Run condition of [`build_hair_strands`]: some hair has a build, a rebuild or a report to
/// make (the same test the system makes), so that a frame in which every hair is built and up
/// to date does not run it.
#[expect(
    clippy::type_complexity,
    reason = "a run condition: its parameter is its query"
)]
pub(crate) fn hairs_to_build(
    hairs: Query<(
        &Hair,
        &HairSimSettings,
        &GlobalTransform,
        Option<&ComputedHair>,
        &HairStatus,
        Option<&BoneSearch>,
    )>,
) -> bool {
    hairs
        .iter()
        .any(|(hair, settings, global, computed, status, search)| {
            !matches!(search, Some(BoneSearch::Waiting | BoneSearch::NotFound))
                && build_wanted((hair, settings), computed, status, &global.affine()).is_some()
        })
}

/// Spawns strand entities and solver state once a hair's assets are ready, and rebuilds them
/// when a handle, a file (hot reload), the bone's scale or the structure offset changes. Failed
/// assets and bone mismatches are reported once each.
pub(crate) fn build_hair_strands(
    mut commands: Commands,
    (mut work, ticks): (ResMut<AttachWork>, bevy::ecs::system::SystemChangeTick),
    mut hairs: HairBuildQuery,
    assets: HairAssets,
    names: Query<&Name>,
    helper: TransformHelper,
    head_colliders: Query<(Entity, &HeadColliderOf)>,
) {
    for (entity, hair, settings, mut global, computed, strands, status, search) in &mut hairs {
        let anim_id = hair.animation.as_ref().map(bevy::prelude::Handle::id);
        let collision_id = hair.collision.as_ref().map(bevy::prelude::Handle::id);
        let offset = settings.structure_offset();
        if matches!(search, Some(BoneSearch::Waiting | BoneSearch::NotFound)) {
            continue;
        }
        // The hair may have been parented to its bone this frame, after transform propagation:
        // compute its pose from the hierarchy so it appears on the bone, not at the origin.
        let full = match &computed {
            // Built before: its pose was propagated like any other entity's.
            Some(_) => global.affine(),
            None => helper
                .compute_global_transform(entity)
                .unwrap_or(*global)
                .affine(),
        };
        let bone_ok = crate::math::usable_frame(&full);
        let Some(reason) = build_wanted((hair, settings), computed.as_deref(), &status, &full)
        else {
            continue;
        };
        let (bone, scale) = if bone_ok {
            split_bone(&full)
        } else {
            (Affine3A::IDENTITY, Vec3::ONE)
        };
        // From here on this hair may queue commands.
        work.strands = ticks.this_run();
        // Only now: a hair that is up to date is not marked changed every frame.
        let status = status.into_inner();
        let mut failed = |kind, id: UntypedAssetId| {
            let error = assets.failure(id)?;
            report_failure(
                &mut commands,
                status,
                &assets,
                entity,
                kind,
                id,
                error,
                false,
            );
            Some(())
        };
        let Some(groom) = assets.grooms.get(&hair.groom) else {
            failed(HairAssetKind::Groom, hair.groom.id().untyped());
            continue;
        };
        // Optional assets: a failed one is left out (reported once); one still loading waits.
        let Some(animation) = optional(&hair.animation, &assets.animations, |id| {
            failed(HairAssetKind::Animation, id)
        }) else {
            continue;
        };
        let Some(collision) = optional(&hair.collision, &assets.collisions, |id| {
            failed(HairAssetKind::Collision, id)
        }) else {
            continue;
        };
        let animation = match (animation, &hair.animation) {
            (Some(a), Some(h)) if !a.base().same_topology(groom) => {
                // Refuse rather than crash (the thesis crashed here): anchor to the groom.
                if status.first_report(Report::AnimationMismatch, h.id().untyped()) {
                    let message = format!(
                        "the animation {:?} has keyframes of {} strands ({} particles), the \
                         groom {:?} has {} strands ({} particles)",
                        assets.path(h),
                        a.base().strand_count(),
                        a.base().points.len(),
                        assets.path(&hair.groom),
                        groom.strand_count(),
                        groom.points.len()
                    );
                    error!("hair {entity}: {message}; the hair anchors to the groom's own style");
                    commands.trigger(HairAnimationMismatch { entity, message });
                }
                None
            }
            (animation, _) => animation,
        };
        // Hung by name: the files must have been exported for that bone.
        if let Some(BoneSearch::Found(bone_entity)) = search
            && let Ok(bone_name) = names.get(*bone_entity)
        {
            let exported = [Some(&groom.bone), collision.map(|c| &c.bone)];
            if let Some(file_bone) = exported
                .into_iter()
                .flatten()
                .find(|b| !b.is_empty() && b.as_str() != bone_name.as_str())
            {
                if status.first_report(Report::BoneMismatch, hair.groom.id().untyped()) {
                    error!(
                        "hair {entity}: it hangs on the bone {:?} but its files were exported \
                         for {file_bone:?}; attach it to {file_bone:?} or export the hair for \
                         {:?} (bone=\"\" in the file skips this check)",
                        bone_name.as_str(),
                        bone_name.as_str()
                    );
                    commands.trigger(BoneMismatch {
                        entity,
                        attached: bone_name.as_str().to_string(),
                        exported: file_bone.clone(),
                    });
                }
                continue;
            }
        }
        let mean_scale = (scale.abs().element_sum() / 3.0).max(1e-12);
        let size = mean_scale / *status.first_scale.get_or_insert(mean_scale);
        if let Some(authored) = groom.bone_scale
            && !(0.99..=1.01).contains(&(mean_scale / authored))
            && status.first_report(Report::BoneScale, hair.groom.id().untyped())
        {
            warn!(
                "hair {entity}: the groom {:?} was made on a bone of {authored} m per unit, this \
                 bone is {mean_scale} m per unit: the hair is {:.3}x its authored size. Export \
                 the character and its hair from the same .blend (and apply or keep the \
                 armature's scale in both)",
                assets.path(&hair.groom),
                mean_scale / authored
            );
            commands.trigger(BoneScaleMismatch {
                entity,
                authored,
                bone: mean_scale,
            });
        }
        let (lo, hi) = settings.margins();
        let margins: Vec<f32> = (0..groom.strand_count() as u32)
            .map(|s| draw_margin(settings.margin_seed, s, lo * size, hi * size))
            .collect();
        let (mut batches, lane_of) = build_batches(groom, animation, offset, &margins, scale);
        if bone_ok {
            for b in &mut batches {
                b.reset(&bone);
            }
            // This frame's step and the head collider below read the pose; propagation would
            // only write it next frame.
            global.set_if_neq(GlobalTransform::from(full));
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
        if let Some(shape) = collision {
            // Physics engine features add their own collider to it (`physics`).
            commands.spawn((
                Name::new("head collider"),
                HairCollider {
                    spheres: shape.spheres.clone(),
                    capsules: shape.capsules.clone(),
                    planes: shape.planes.clone(),
                    ..default()
                },
                HeadColliderOf(entity),
                Transform::default(),
                // Its parent's pose, so the spheres are in place on their first frame.
                GlobalTransform::from(full),
                ChildOf(entity),
            ));
        }
        // A re-exported file with the same strands keeps the hair where it is and how it moves
        // (the roots take the new style); anything else starts from the style.
        let kept = match (&computed, reason) {
            (Some(old), Some(RebuildReason::Reloaded)) if same_layout(&old.batches, &batches) => {
                for (new, old) in batches.iter_mut().zip(&old.batches) {
                    for (n, o) in new.nodes.iter_mut().zip(&old.nodes).skip(PINNED) {
                        n.x = o.x;
                        n.p = o.p;
                    }
                }
                Some((old.last_bone, old.accumulator, old.animation_time))
            }
            _ => None,
        };
        let strand_count = groom.strand_count();
        let (last_bone, accumulator, animation_time) =
            kept.unwrap_or((bone_ok.then_some(bone), 0.0, 0.0));
        let rest_bounds = rest_bounds(&batches, &lane_of);
        let longest = longest_strand(&batches);
        commands.entity(entity).insert(ComputedHair {
            rest_bounds,
            longest,
            batches,
            lane_of,
            groom: hair.groom.id(),
            animation: anim_id,
            collision: collision_id,
            offset,
            margin_key: margin_key(settings),
            scale,
            size,
            last_bone,
            accumulator,
            animation_time,
            ..default()
        });
        status.reloaded = false;
        status.builds += 1;
        match reason {
            None => commands.trigger(HairReady {
                entity,
                strands: strand_count,
            }),
            Some(reason) => commands.trigger(HairRebuilt { entity, reason }),
        }
    }
}

/// The longest strand's rest length (the sum of its particle-to-particle distances).
fn longest_strand(batches: &[Batch]) -> f32 {
    let mut longest = 0.0f32;
    for b in batches {
        for l in 0..b.count {
            let mut length = 0.0;
            for k in (3..b.nodes.len()).step_by(2) {
                // Node k (odd) is a particle; two nodes back is the one before it.
                length += b.rest(l, k).distance(b.rest(l, k - 2));
            }
            longest = longest.max(length);
        }
    }
    longest
}

/// The bounding box of every used lane's rest nodes.
fn rest_bounds(batches: &[Batch], lane_of: &[(u32, u8)]) -> Option<(Vec3, Vec3)> {
    let mut bounds: Option<(Vec3, Vec3)> = None;
    for &(b, l) in lane_of {
        let Some(batch) = batches.get(b as usize) else {
            continue;
        };
        for k in 0..batch.local.len() {
            let p = batch.rest(l as usize, k);
            if p.is_finite() {
                bounds = Some(bounds.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))));
            }
        }
    }
    bounds
}

/// Whether two builds hold the same strands in the same lanes with the same node counts.
fn same_layout(old: &[Batch], new: &[Batch]) -> bool {
    old.len() == new.len()
        && old.iter().zip(new).all(|(a, b)| {
            a.strands == b.strands && a.count == b.count && a.nodes.len() == b.nodes.len()
        })
}

/// What the margins were drawn from; a change redraws them.
pub(crate) fn margin_key(s: &HairSimSettings) -> (u64, u32, u32) {
    let (lo, hi) = s.margins();
    (s.margin_seed, lo.to_bits(), hi.to_bits())
}

/// Removing [`Hair`] detaches it: strands, collider and solver state go.
pub(crate) fn detach_hair(
    remove: On<Remove<Hair>>,
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

#[cfg(test)]
mod tests {
    use bevy::math::Affine3A;
    use bevy::prelude::*;

    /// The every-frame scale check reads the same scale the build splits off, to the bit.
    #[test]
    fn the_bone_scale_is_the_scale_split_off_the_bone() {
        let turn = Quat::from_euler(EulerRot::XYZ, 0.3, -1.1, 2.0);
        for scale in [
            Vec3::ONE,
            Vec3::splat(0.01),
            Vec3::new(1.0, 2.5, 0.3),
            Vec3::new(-1.0, 1.0, 1.0),
            Vec3::new(2.0, -0.5, 3.0),
        ] {
            let bone = Affine3A::from_scale_rotation_translation(scale, turn, Vec3::X);
            let split = super::split_bone(&bone).1;
            assert_eq!(super::bone_scale(&bone).to_array(), split.to_array());
            assert!((split.abs() - scale.abs()).abs().max_element() < 1e-5);
        }
    }

    #[test]
    fn load_errors_lose_their_backtrace_not_their_message() {
        let error = "Failed to load asset 'a.hair.xml': a.hair.xml:3:7: strand 0: \"x\": not a \
                     number\n   5: <bevy_asset::server::AssetServer>::load_internal\n             \
                     at /src/loader.rs:97:18\nnote: Some \"noisy\" backtrace lines have been filtered";
        assert_eq!(
            super::without_backtrace(error),
            "Failed to load asset 'a.hair.xml': a.hair.xml:3:7: strand 0: \"x\": not a number"
        );
        assert_eq!(super::without_backtrace("one\ntwo"), "one\ntwo");
    }
}
